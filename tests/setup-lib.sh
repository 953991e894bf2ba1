# shellcheck shell=bash
# Shared by tests/peer/setup.sh, tests/foxglove/setup.sh and tests/colcon/setup.sh, which source it (it is not
# run on its own) after `set -euo pipefail`:
#     source "$(dirname "${BASH_SOURCE[0]}")/../setup-lib.sh"
#
#   setup_init TAG [stdout|stderr]  first, before anything can fail: messages are "[TAG] ...", log() writes to
#                                   the given stream (default stderr; tests/peer/setup.sh logs to stdout), die()
#                                   and every ERROR to stderr; sets the ERR trap that names the failed command
#   setup_logs DIR [N]              run_logged writes DIR/NAME.log (DIR must exist) and, on failure, shows its
#                                   last N lines (default 60)
#   setup_lock FILE                 one setup at a time per FILE (flock on fd 9, held until the script exits;
#                                   no lock where there is no flock), for parallel CI jobs sharing a cache
#   log MSG... / die MSG...         die exits 1
#   run_logged NAME CMD...          runs CMD with its output in DIR/NAME.log; on failure shows the log's tail on
#                                   stderr and exits 1
#   apt_install_missing [--no-install-recommends] HINT [PKG...]
#                                   installs the Debian packages PKG (the caller lists those it found missing;
#                                   none given: nothing to do), plus ca-certificates when there is no CA bundle
#                                   (pip and npm need one for https; minimal images lack it): apt-get update once,
#                                   then apt-get install -y, with sudo when not root, logged as apt-get-update and
#                                   apt-get-install. HINT tells what to install by hand when there is no apt-get.
#
# Functions here exit through die or run_logged only: the ERR trap is not inherited by functions (no errtrace,
# which would also report each failure once more from every command substitution).

setup_init() {
    SETUP_TAG="$1"
    case "${2:-stderr}" in
        stdout) SETUP_LOG_FD=1 ;;
        stderr) SETUP_LOG_FD=2 ;;
        *) printf '[%s] ERROR: setup_init: stream must be stdout or stderr, not %s\n' "$SETUP_TAG" "$2" >&2; exit 1 ;;
    esac
    SETUP_LOGS=""
    SETUP_LOG_TAIL=60
    # shellcheck disable=SC2154  # rc is assigned in the trap itself
    trap 'rc=$?; printf "[%s] ERROR: command failed (exit %s) at %s line %s: %s\n" "$SETUP_TAG" "$rc" "${BASH_SOURCE[0]}" "$LINENO" "$BASH_COMMAND" >&2' ERR
}

log() { printf '[%s] %s\n' "$SETUP_TAG" "$*" >&"$SETUP_LOG_FD"; }
die() { printf '[%s] ERROR: %s\n' "$SETUP_TAG" "$*" >&2; exit 1; }

setup_logs() {
    SETUP_LOGS="$1"
    SETUP_LOG_TAIL="${2:-60}"
}

setup_lock() {
    local file="$1"
    command -v flock >/dev/null 2>&1 || return 0
    exec 9>"$file" || die "cannot lock $file"
    flock 9 || die "cannot lock $file"
}

run_logged() {
    local name="$1"; shift
    [ -n "$SETUP_LOGS" ] || die "run_logged $name: no log folder (setup_logs DIR first)"
    local logf="$SETUP_LOGS/$name.log"
    if ! "$@" >"$logf" 2>&1; then
        printf '[%s] ERROR: %s failed; last lines of %s:\n' "$SETUP_TAG" "$name" "$logf" >&2
        tail -n "$SETUP_LOG_TAIL" "$logf" >&2
        exit 1
    fi
}

apt_install_missing() {
    local install_opts=()
    if [ "${1:-}" = --no-install-recommends ]; then install_opts+=("$1"); shift; fi
    local hint="$1"; shift
    [ "$#" -gt 0 ] || return 0
    local pkgs=("$@")
    [ -f /etc/ssl/certs/ca-certificates.crt ] || pkgs+=(ca-certificates)
    command -v apt-get >/dev/null 2>&1 \
        || die "missing ${pkgs[*]} and no apt-get to install them ($hint)"
    local sudo=()
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null 2>&1 || die "need root (or sudo) to apt-get install ${pkgs[*]}"
        sudo=(sudo)
    fi
    log "apt-get install ${pkgs[*]}"
    export DEBIAN_FRONTEND=noninteractive
    run_logged apt-get-update "${sudo[@]}" apt-get update
    run_logged apt-get-install "${sudo[@]}" apt-get install -y "${install_opts[@]}" "${pkgs[@]}"
}
