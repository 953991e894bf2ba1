"""Send candidates to a running grasp_orient node from rclpy, with whatever grasp_orient message module the
environment provides, and print what was used and what came back. tests/ros/test_colcon.py runs it in the
environment of a colcon workspace's `install/setup.bash`, so the module is the workspace's.

    python tests/colcon/ask_installed.py CANDIDATES.jsonl [--ns NAMESPACE] [--timeout S]

Prints one JSON object on stdout: `msg_module` (grasp_orient.msg.__file__), `msg_libraries` (the
grasp_orient shared libraries this process loaded, from /proc/self/maps) and `answers` (one per candidate,
in order, in conftest.to_plain form). Exit status 0 when every candidate was answered, 1 otherwise, with
the reason on stderr. ROS_DOMAIN_ID comes from GRASP_ORIENT_TEST_DOMAIN_ID as in the pytest session.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

# The helpers of tests/ros (Peer, GraspClient, to_plain); importing conftest sets the session's ROS
# environment and imports rclpy and grasp_orient.msg from this process's environment.
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "ros"))
import conftest  # noqa: E402


def loaded_libraries(fragment: str) -> list[str]:
    """Paths of the shared objects mapped into this process whose path contains `fragment`."""
    paths = set()
    with open("/proc/self/maps", encoding="utf-8") as f:
        for line in f:
            parts = line.split(maxsplit=5)
            if len(parts) == 6 and fragment in parts[5]:
                paths.add(parts[5].strip())
    return sorted(paths)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("candidates", help="GraspCandidate JSON lines (the `solve` input form), each with an id")
    ap.add_argument("--ns", default="", help="the node's namespace (topics NS/grasp_candidates, ...)")
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds for the match and for the answers (30)")
    args = ap.parse_args()
    if conftest.RCLPY_IMPORT_ERROR:
        print(conftest.RCLPY_IMPORT_ERROR, file=sys.stderr)
        return 1
    import grasp_orient.msg
    import rclpy

    cands = [json.loads(line) for line in Path(args.candidates).read_text().splitlines() if line.strip()]
    rclpy.init()
    try:
        peer = conftest.Peer("grasp_orient_colcon_check")
        client = conftest.GraspClient(peer, args.ns)
        client.ensure_roundtrip(args.timeout)
        answers = client.send_and_collect(cands, args.timeout)
        print(json.dumps({
            "msg_module": grasp_orient.msg.__file__,
            "msg_libraries": loaded_libraries("libgrasp_orient__"),
            "answers": [conftest.to_plain(answers[c["id"]]) for c in cands],
        }))
        peer.destroy()
        return 0
    except AssertionError as e:
        print(f"ask_installed: {e}", file=sys.stderr)
        return 1
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
