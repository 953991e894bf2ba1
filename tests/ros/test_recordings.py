"""The node's recordings: nothing lost, shared or overwritten, settings carried along. Each test
runs its own node(s) in a namespace of its own on the session's domain, driven from rclpy:

- two nodes in different namespaces started together with one record_dir write two files, each holding its
  own node's candidates and answers, and each replays;
- `record` takes effect when it is set: a start that failed (the folder could not be made) is retried when
  `record` is set to true again, with no candidate in between; off and on within a second gives a new file;
- a full disk (the node runs with RLIMIT_FSIZE, so the file system refuses to grow its file: EFBIG, the
  unprivileged equivalent of a small full file system): the node keeps answering, logs the cause once on
  stderr and /rosout, the file is closed at its last flush and replays, and setting `record` to true again
  starts a new file;
- the settings the node answered with travel in the recording as MCAP metadata, and `replay` uses them.

Nothing here skips: a missing rclpy or binary fails with the reason.
"""
from __future__ import annotations

import random
import re
import resource
import signal
import subprocess
import time
from pathlib import Path

import pytest
import yaml

import mcap_util as mu
from conftest import (GraspClient, Peer, Parameter, ParameterValue, SetParameters, binary_path, reliable_qos,
                      require_environment)

SEED = 880088
SETTINGS = "grasp_orient.settings"


def grasps(n: int, seed: int, prefix: str) -> list[dict]:
    rng = random.Random(seed)
    frames = ["object", "world", "tool0"]
    return [mu.quantize(mu.random_grasp(rng, f"{prefix}-{k}", frames[k % len(frames)])) for k in range(n)]


def run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([str(binary_path()), *map(str, args)], capture_output=True, text=True, timeout=300)


def set_param(peer: Peer, node: str, name: str, value):
    """Sets one parameter of `node` (bool or str or float) and asserts it was accepted."""
    from rcl_interfaces.msg import ParameterType

    v = ParameterValue()
    if isinstance(value, bool):
        v.type, v.bool_value = ParameterType.PARAMETER_BOOL, value
    elif isinstance(value, float):
        v.type, v.double_value = ParameterType.PARAMETER_DOUBLE, value
    else:
        v.type, v.string_value = ParameterType.PARAMETER_STRING, value
    client = peer.node.create_client(SetParameters, f"{node}/set_parameters")
    try:
        (r,) = peer.call(client, SetParameters.Request(parameters=[Parameter(name=name, value=v)])).results
    finally:
        peer.node.destroy_client(client)
    assert r.successful, f"{node}: {name}={value!r} refused: {r.reason!r}"


def candidate_ids(path: Path, topic: str) -> list[str]:
    return [r.msg["id"] for r in mu.read_mcap(path) if r.topic == topic]


def settings_records(path: Path) -> list[dict]:
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return [dict(m.metadata) for m in make_reader(f).iter_metadata() if m.name == SETTINGS]


def test_two_nodes_in_one_folder_write_two_files(start_node, rclpy_context, tmp_path):
    """What a launch file with two nodes does: same record_dir, started in the same second, 1,000 candidates
    each. Each file holds its own node's 1,000 and replays; nothing of one node is in the other's file."""
    record_dir = tmp_path / "runs"
    spaces = ("/rec_left", "/rec_right")
    nodes = {ns: start_node("--ros-args", "-r", f"__ns:={ns}", "-p", f"record_dir:={record_dir}",
                            "-p", "publish_markers:=false", name=f"recording node {ns}", ready=False)
             for ns in spaces}
    for n in nodes.values():
        n.wait_ready()
    peer = Peer("grasp_orient_two_nodes_peer")
    try:
        for i, ns in enumerate(spaces):
            client = GraspClient(peer, ns=ns)
            client.ensure_roundtrip()
            client.send_and_collect(grasps(1000, SEED + i, ns.strip("/")), timeout=120)
        for n in nodes.values():
            n.stop_and_check(signal.SIGINT)
    finally:
        peer.destroy()
        for n in nodes.values():
            n.kill()

    files = sorted(record_dir.glob("*.mcap"))
    names = [f.name for f in files]
    assert len(files) == 2, f"expected one file per node in {record_dir}, found {names}"
    for ns, path in zip(spaces, files):
        assert path.name.startswith(f"{ns.strip('/')}__grasp_orient_"), f"{path.name} does not name node {ns}"
        ids = candidate_ids(path, f"{ns}/grasp_candidates")
        mine = [i for i in ids if i.startswith(ns.strip("/") + "-")]
        assert len(mine) == 1000 and len(set(mine)) == 1000, f"{path.name}: {len(mine)} of node {ns}'s 1000"
        others = [r.topic for r in mu.read_mcap(path) if not r.topic.startswith(ns + "/")]
        assert not others, f"{path.name} holds messages of another node: {sorted(set(others))}"
        closed = nodes[ns].wait_for_line(rf"recording \S*{re.escape(path.name)} closed: (\d+) candidates")
        assert f"closed: {len(ids)} candidates, {len(ids)} recommendations" in closed, closed
        r = run("replay", path)
        assert r.returncode == 0, f"replay {path.name} exited {r.returncode}:\n{(r.stdout + r.stderr)[-2000:]}"
        assert f"{len(ids)} compared with a recorded recommendation, 0 differ" in r.stdout, r.stdout


def test_record_takes_effect_when_set_and_a_failed_start_is_retried(start_node, rclpy_context, tmp_path):
    """The folder cannot be made (a file is in its place), `record` is set to true: the node says so and
    recording is off. The folder is fixed, and `record` set to false and back to true with no candidate in
    between: the file is there at once, and the next 100 candidates are all in it. Off and on within a
    second: a new file each time, none reused."""
    ns, node_name = "/rec_switch", "/rec_switch/grasp_orient"
    blocked = tmp_path / "runs"
    blocked.write_text("a file where the recording folder should be")
    node = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", "record:=false", "-p", f"record_dir:={blocked}",
                      "-p", "publish_markers:=false", name="recording node (switch)")
    peer = Peer("grasp_orient_switch_peer")
    try:
        client = GraspClient(peer, ns=ns)
        client.ensure_roundtrip()
        mark = len(node.all_lines())
        set_param(peer, node_name, "record", True)
        failed = node.wait_for_line(r"recording is off: cannot create", after=mark)
        assert "Set record to true to try again" in failed, failed

        blocked.unlink()  # fixed
        mark = len(node.all_lines())
        set_param(peer, node_name, "record", False)
        set_param(peer, node_name, "record", True)
        started = node.wait_for_line(r"recording to \S+\.mcap", after=mark)
        files = sorted(blocked.glob("*.mcap"))
        assert len(files) == 1 and files[0].name in started, f"{started!r}: files {files}"
        first = files[0]

        sent = grasps(100, SEED + 10, "switch")
        client.send_and_collect(sent)

        for _ in range(2):
            mark = len(node.all_lines())
            set_param(peer, node_name, "record", False)
            set_param(peer, node_name, "record", True)
            node.wait_for_line(r"recording to \S+\.mcap", after=mark)
        node.stop_and_check(signal.SIGINT)
    finally:
        peer.destroy()
        node.kill()

    files = sorted(blocked.glob("*.mcap"))
    assert len({f.name for f in files}) == 3, f"three switch-ons, three files: {[f.name for f in files]}"
    ids = candidate_ids(first, f"{ns}/grasp_candidates")
    assert sorted(ids) == sorted(c["id"] for c in sent), f"{first.name}: {len(ids)} candidates, 100 sent"
    for f in files:
        mu.read_mcap(f)  # each one whole


def limit_file_size(limit: int):
    """For the child: files may not grow past `limit` bytes; the write that would gets EFBIG (SIGXFSZ, which
    would kill the process instead, is ignored, and stays ignored across exec)."""
    def pre():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return pre


def test_a_full_disk_is_reported_once_and_recording_comes_back(start_node, rclpy_context, tmp_path):
    from rcl_interfaces.msg import Log

    ns, node_name = "/rec_disk", "/rec_disk/grasp_orient"
    record_dir = tmp_path / "runs"
    node = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", f"record_dir:={record_dir}",
                      "-p", "publish_markers:=false", name="recording node (full disk)",
                      preexec_fn=limit_file_size(64 * 1024))
    peer = Peer("grasp_orient_disk_peer")
    logs: list = []
    peer.node.create_subscription(Log, "/rosout", logs.append, reliable_qos(1000))
    try:
        client = GraspClient(peer, ns=ns)
        client.ensure_roundtrip()
        client.send_and_collect(grasps(20, SEED + 20, "disk-early"))
        peer.spin_for(1.5)  # the writer flushes at least once a second: these reach the file
        answers = client.send_and_collect(grasps(3000, SEED + 21, "disk"), timeout=180)
        assert len(answers) == 3000, "the node must keep answering"
        stopped = node.wait_for_line(r"recording \S+ stopped: ", timeout=20)
        peer.spin_for(1.0)
        rosout = [m.msg for m in logs if "stopped: " in m.msg and str(record_dir) in m.msg]

        mark = len(node.all_lines())
        set_param(peer, node_name, "record", True)
        restarted = node.wait_for_line(r"recording to \S+\.mcap", after=mark)
        after = grasps(10, SEED + 22, "disk-after")
        client.send_and_collect(after)
        node.stop_and_check(signal.SIGINT)
    finally:
        peer.destroy()
        node.kill()

    lines = [l for l in node.all_lines() if " stopped: " in l]
    assert len(lines) == 1, f"the failure is logged {len(lines)} times:\n" + "\n".join(lines[:5])
    # The file is cut back to its last complete flush and closed there; unless that flush ended too
    # near the 64 KiB limit for the summary (which repeats every schema): then the close fails and
    # says so, and `recover` makes the closed file. Where the flushes fall depends on the timing.
    closed = "closed at its last complete flush" in stopped
    assert "File too large" in stopped, stopped
    assert closed or ("could not be closed" in stopped and "grasp_orient recover" in stopped), stopped
    assert "set record to true to start a new file" in stopped, stopped
    assert len(rosout) == 1, f"/rosout has the failure {len(rosout)} times: {rosout[:3]}"
    kept = int(re.search(r"holds (\d+) candidates", stopped).group(1))
    assert kept >= 20, f"the 20 candidates flushed before the burst are lost: {stopped}"

    files = sorted(record_dir.glob("*.mcap"))
    assert len(files) == 2, [f.name for f in files]
    first = next(f for f in files if f.name in stopped)
    second = next(f for f in files if f.name in restarted)
    assert first.stat().st_size <= 64 * 1024
    if not closed:
        fixed = tmp_path / "fixed.mcap"
        r = run("recover", first, "-o", fixed)
        assert r.returncode == 0, f"recover lost something of a file cut at a flush:\n{(r.stdout + r.stderr)[-2000:]}"
        first = fixed
    r = run("replay", first)
    assert r.returncode == 0, f"the closed file does not replay:\n{(r.stdout + r.stderr)[-2000:]}"
    assert f"replayed {kept} candidates" in r.stdout, r.stdout
    # Closed with a summary, so that readers that need an index (rosbags) open it too, and agree.
    a, b = mu.read_mcap(first), mu.read_rosbags(first)
    assert not mu.compare_readers(b, a), mu.compare_readers(b, a)[:5]
    assert len(candidate_ids(first, f"{ns}/grasp_candidates")) == kept
    ids = candidate_ids(second, f"{ns}/grasp_candidates")
    assert sorted(ids) == sorted(c["id"] for c in after), f"the new file holds {ids}"
    r = run("replay", second)
    assert r.returncode == 0, (r.stdout + r.stderr)[-2000:]


def test_recordings_carry_the_settings_and_replay_uses_them(start_node, rclpy_context, tmp_path):
    """Started with range:=graspable and a safety factor of 1.5, then objective and safety factor changed
    mid-run: each change is in the file as metadata, and replay solves every candidate as the node did."""
    ns, node_name = "/rec_settings", "/rec_settings/grasp_orient"
    record_dir = tmp_path / "runs"
    node = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", f"record_dir:={record_dir}",
                      "-p", "range:=graspable", "-p", "friction_safety_factor:=1.5",
                      name="recording node (settings)")
    peer = Peer("grasp_orient_settings_peer")
    try:
        client = GraspClient(peer, ns=ns)
        client.ensure_roundtrip()
        before = client.send_and_collect(grasps(20, SEED + 30, "before"))
        set_param(peer, node_name, "objective", "norm1")
        set_param(peer, node_name, "friction_safety_factor", 1.2)
        after = client.send_and_collect(grasps(20, SEED + 31, "after"))
        node.stop_and_check(signal.SIGINT)
    finally:
        peer.destroy()
        node.kill()
    assert {a.objective for a in before.values()} == {"norm2"}
    assert {a.objective for a in after.values()} == {"norm1"}

    (path,) = record_dir.glob("*.mcap")
    records = settings_records(path)
    assert len(records) == 3, f"at start and at each change: {records}"
    assert all(r["node"] == node_name for r in records), records
    assert [r["reason"] for r in records] == ["start", "parameter objective set",
                                               "parameter friction_safety_factor set"]
    since = [int(r["since_ns"]) for r in records]
    assert since[0] == 0 and since[1] <= since[2], since
    params = [yaml.safe_load(r["parameters"])["/**"]["ros__parameters"] for r in records]
    assert (params[0]["range"], params[0]["friction_safety_factor"], params[0]["objective"]) == \
        ("graspable", 1.5, "norm2"), params[0]
    assert (params[2]["range"], params[2]["friction_safety_factor"], params[2]["objective"]) == \
        ("graspable", 1.2, "norm1"), params[2]

    r = run("replay", path)
    assert r.returncode == 0, f"replay with the recorded settings:\n{(r.stdout + r.stderr)[-3000:]}"
    assert "solved with the settings it recorded (3 settings records)" in r.stdout, r.stdout
    r = run("replay", path, "--friction-safety-factor", "1.0")
    assert r.returncode == 1, f"an override that changes answers must show:\n{(r.stdout + r.stderr)[-3000:]}"
    assert "overridden from the command line: friction_safety_factor" in r.stdout, r.stdout
