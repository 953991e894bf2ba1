"""`grasp_orient node` run for a golden recording: what record_node_bag.py and record_node_poses.py share.

    use_private_domain()   # before rclpy is imported
    with recording_node("record_node_x.py", args.bin, args.out, ["-p", "record_markers:=true"]) as run:
        ...                # rclpy sends, one at a time; run.die(msg) ends the script
    print(run.recorded)    # the node's file name, copied to args.out

The node runs in namespace /golden with its recording in a temporary folder. When the block ends, SIGINT stops the
node, which closes the file; the one recording is copied to `out`. A node that does not come up within 30 s, exits
with a failure or leaves other than one recording ends the script with the node's last lines.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from pathlib import Path

NS = "/golden"
NODE = f"{NS}/grasp_orient"


class NodeRun:
    """The node's output so far, and how the script ends on an error."""

    def __init__(self, script: str):
        self.script = script
        self.lines: list[str] = []
        self.recorded = ""

    def die(self, msg: str):
        print(f"{self.script}: {msg}", file=sys.stderr)
        sys.exit(1)

    def last_lines(self, n: int) -> str:
        return "\n".join(self.lines[-n:])

    def spin_until(self, node, done, timeout: float, failure):
        """Spins the rclpy `node` until `done()`; after `timeout` seconds ends the script with `failure` (a text,
        or a function that makes it then, with the node's lines up to that moment)."""
        import rclpy

        deadline = time.monotonic() + timeout
        while not done():
            rclpy.spin_once(node, timeout_sec=0.05)
            if time.monotonic() > deadline:
                self.die(failure() if callable(failure) else failure)


def reliable_qos(depth: int):
    """Reliable, volatile, keep-last `depth`: the node's QoS (its `qos_depth`), for the script's endpoints."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                      durability=DurabilityPolicy.VOLATILE)


def use_private_domain():
    """A ROS domain of this run's own (GRASP_ORIENT_TEST_DOMAIN_ID, else 200 to 229), on this host, over Fast DDS."""
    os.environ["ROS_DOMAIN_ID"] = os.environ.get("GRASP_ORIENT_TEST_DOMAIN_ID") or str(200 + os.getpid() % 30)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("ROS_LOCALHOST_ONLY", None)
    os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")


@contextmanager
def recording_node(script: str, binary: Path, out: Path, params: list[str]):
    """Runs the node at `binary` with `params` (`-p name:=value` pairs) until the block ends, then copies its
    recording to `out`."""
    run = NodeRun(script)
    if not binary.is_file():
        run.die(f"no binary at {binary} (cargo build --profile test, or --bin)")
    with tempfile.TemporaryDirectory() as tmp:
        record_dir = Path(tmp) / "runs"
        ready = threading.Event()
        proc = subprocess.Popen(
            [str(binary.resolve()), "node", "--ros-args", "-r", f"__ns:={NS}", "-p", f"record_dir:={record_dir}", *params],
            cwd=tmp, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            errors="replace")

        def pump():
            for line in proc.stdout:
                run.lines.append(line.rstrip("\n"))
                if "waiting for" in line:
                    ready.set()

        threading.Thread(target=pump, daemon=True).start()
        try:
            if not ready.wait(30):
                run.die("the node did not come up within 30 s:\n" + run.last_lines(30))
            yield run
        finally:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
        if proc.returncode != 0:
            run.die(f"the node exited with {proc.returncode}:\n" + run.last_lines(30))
        files = sorted(record_dir.glob("*.mcap"))
        if len(files) != 1:
            run.die(f"expected one recording, found {files}")
        shutil.copyfile(files[0], out)
        run.recorded = files[0].name
