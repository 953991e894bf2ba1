"""A deliberately slow rclpy reader of the node's answers (tests/ros/slow_reader.py: 16 kB socket buffers, a
callback that sleeps 1 ms, and stopped for 30 ms of every 50 ms, as a reader on a busy machine is): a burst of
answers overflows its socket, and the node's writer has to repair what the kernel dropped. Every answer must
still arrive, and the repair must follow the reader (patches/rustdds-0.15.1/0010-repair-window.patch) instead
of flooding it: the datagrams dropped at its socket stay fewer than the answers."""
from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import conftest as C
from conftest import DOMAIN_ID, GraspClient, Peer, ros_env

N = 2000


def stop_and_go(pid: int, done: threading.Event):
    """Stops the process for 30 ms of every 50 ms until `done`."""
    try:
        while not done.is_set():
            os.kill(pid, signal.SIGSTOP)
            time.sleep(0.03)
            os.kill(pid, signal.SIGCONT)
            time.sleep(0.02)
    except ProcessLookupError:
        pass  # it exited
    finally:
        try:
            os.kill(pid, signal.SIGCONT)
        except ProcessLookupError:
            pass


def test_a_slow_reader_gets_every_answer_without_a_flood(start_node, peer: Peer):
    ns = "/slow_reader"
    start_node("--ros-args", "-r", f"__ns:={ns}", "-p", "record:=false", "-p", "publish_markers:=false",
               "-p", f"qos_depth:={2 * N}", name="grasp_orient node (slow reader)")
    script = Path(__file__).resolve().parent / "slow_reader.py"
    slow = subprocess.Popen([sys.executable, str(script), ns, "--count", str(N), "--timeout", "120"],
                            env=ros_env(DOMAIN_ID), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    done = threading.Event()
    try:
        assert slow.stdout is not None
        first = ""
        while first not in ("ready", "unmatched"):  # Fast DDS may print its own lines first
            line = slow.stdout.readline()
            assert line, f"the slow reader exited: {slow.communicate()[1][-2000:]}"
            first = line.strip()
        assert first == "ready", "the slow reader did not match the node"
        client = GraspClient(peer, ns, depth=2 * N)
        client.ensure_roundtrip()
        rng = random.Random(11)
        cands = [dict(C.random_grasp(rng, f"slow-{k}")) for k in range(N)]
        pauser = threading.Thread(target=stop_and_go, args=(slow.pid, done), daemon=True)
        pauser.start()
        start = time.monotonic()
        for c in cands:  # a burst: as fast as rclpy publishes
            client.pub.publish(C.candidate_msg(c))
        ok = peer.spin_until(lambda: all(c["id"] in client.answers for c in cands), 60.0)
        assert ok, "the node did not answer the burst (to the test's own, fast reader) within 60 s"
        while slow.poll() is None and time.monotonic() - start < 60.0:
            time.sleep(0.1)
        done.set()
        pauser.join()
        out, err = slow.communicate(timeout=150)
        took = time.monotonic() - start
    finally:
        done.set()
        if slow.poll() is None:
            slow.kill()
            slow.communicate()
    res = json.loads([line for line in out.splitlines() if line.startswith("{")][-1])
    print(f"slow reader: {res['received']} of {N} answers (+1 probe) in {took:.1f} s, "
          f"{res['udp_drops']} datagrams dropped at its socket")
    assert res["received"] >= N, f"the slow reader got {res['received']} of {N} answers:\n{err[-2000:]}"
    # Most drops come from the first sending of the burst while the reader is stopped (237 to 615 in three runs
    # with patch 0010, 105 to 561 in four without, on a loaded machine). A writer whose repair rounds did not
    # shrink for this reader would send it rounds larger than its 32 kB buffer over and over: drops by the
    # thousand, and answers that never arrive.
    assert res["udp_drops"] < N, f"{res['udp_drops']} datagrams dropped at the slow reader's socket"
