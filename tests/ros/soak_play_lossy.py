"""A soak run, not part of tests/run.sh: a recording played with `grasp_orient play` (a RustDDS writer) from the
peer's namespace to the node over the lossy link of test_hosts.py (5% of the packets into the node's namespace
dropped), SOAK_RUNS times (default 200), a fresh node each run. Each run's recording must hold every candidate of
bags/random_grasps.mcap. It fails on two known limits (docs/node.md, "Several hosts"): about one run in a hundred
loses a few consecutive candidates (a hypothesis: dropped by the node's keep-last history when a repair held them
back longer than `qos_depth` candidates; none were lost in 200 runs with SOAK_NODE_ARGS="--ros-args -p
qos_depth:=1000"), and at a faster pace
(SOAK_RATE=10) a run now and then loses every candidate, sent before the node's reader had discovered play's
writer. It is kept out of the test run, so that the run stays deterministic; run it by name, as root, in the
peer's environment:

    GRASP_ORIENT_BIN=target/debug/grasp_orient python -m pytest tests/ros/soak_play_lossy.py -s

It prints each losing run's missing positions and writes the node's and play's logs (RustDDS's matching at info)
to the test's temporary folder.
"""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

from conftest import require_environment
from test_hosts import drop_into, enter, env_for, node_in, tool, two_hosts

import mcap_util as mu

RUNS = int(os.environ.get("SOAK_RUNS", "200"))
BAG = Path(__file__).resolve().parents[2] / "bags" / "random_grasps.mcap"
NODE_ARGS = os.environ.get("SOAK_NODE_ARGS", "").split()
# 4: the bag's 335 candidates (10 ms apart as recorded) in 0.84 s, about 400 a second.
RATE = float(os.environ.get("SOAK_RATE", "4"))
LOGS = "info,rustdds=warn,rustdds::rtps::reader=info,rustdds::rtps::writer=info,rustdds::discovery=info," \
       "rustdds::network::udp_listener=off"


def candidate_keys(recording: Path) -> list[tuple]:
    return [(r.msg["id"], r.msg["header"]["stamp"]["sec"], r.msg["header"]["stamp"]["nanosec"])
            for r in mu.read_mcap(recording) if r.topic == "/grasp_candidates"]


def test_a_recording_played_from_another_host_arrives_whole_over_a_lossy_link(tmp_path):
    grasp = require_environment()
    want = candidate_keys(BAG)
    nft = tool("nft")
    losing: list[tuple[int, list[int]]] = []
    with two_hosts("s") as (node_ns, peer_ns):
        drop_into(node_ns, nft)
        env = env_for("SUBNET", None)
        env["RUST_LOG"] = LOGS
        for run in range(RUNS):
            cwd = tmp_path / f"run{run}"
            cwd.mkdir()
            with node_in(node_ns, env, cwd, NODE_ARGS) as node:
                r = subprocess.run([str(grasp), "play", str(BAG), "--rate", f"{RATE:g}"], env=env,
                                   capture_output=True, text=True, timeout=60, preexec_fn=enter(peer_ns),
                                   cwd=str(cwd))
                assert r.returncode == 0, f"play in {peer_ns} exited {r.returncode}:\n{r.stderr[-3000:]}"
            recordings = sorted((cwd / "runs").glob("*.mcap"))
            assert len(recordings) == 1, recordings
            got = set(candidate_keys(recordings[0]))
            missing = [k for k, w in enumerate(want) if w not in got]
            if missing:
                losing.append((run, missing))
                (cwd / "node.log").write_text("\n".join(node.all_lines()))
                (cwd / "play.log").write_text(r.stderr)
                print(f"run {run}: missing positions {missing} (logs in {cwd})")
    print(f"\n{RUNS} runs of {len(want)} candidates, {len(losing)} with candidates missing")
    assert not losing, f"runs that lost candidates (run, positions in the bag): {losing}"
