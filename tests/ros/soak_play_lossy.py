"""A soak run, not part of tests/run.sh: test_hosts.py's play over the lossy link (a recording played with
`grasp_orient play`, a RustDDS writer, from the peer's namespace into a fresh recording node, 5% of the packets
into the node's namespace dropped) SOAK_RUNS times (default 200) at SOAK_RATE times the recorded pace (default
4: the bag's 335 candidates in 0.84 s, about 400 a second), the node started with SOAK_NODE_ARGS. Each run's
recording must hold every candidate of bags/random_grasps.mcap. Run it by name, as root, in the peer's
environment:

    GRASP_ORIENT_BIN=target/debug/grasp_orient python -m pytest tests/ros/soak_play_lossy.py -s

It prints each losing run's missing positions and leaves the node's and play's logs (RustDDS's matching at
info) in the test's temporary folder. What it found is in docs/node.md ("Several hosts").
"""
from __future__ import annotations

import os

from test_hosts import play_over_a_lossy_link

RUNS = int(os.environ.get("SOAK_RUNS", "200"))
RATE = float(os.environ.get("SOAK_RATE", "4"))
NODE_ARGS = os.environ.get("SOAK_NODE_ARGS", "").split()


def test_a_recording_played_from_another_host_arrives_whole_over_a_lossy_link(tmp_path):
    losing = play_over_a_lossy_link(tmp_path, RUNS, RATE, NODE_ARGS)
    assert not losing, f"runs that lost candidates (run, positions in the bag): {losing}"
