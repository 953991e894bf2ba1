"""Gripper poses from a real rclpy peer over Fast DDS (docs/poses.md): single pose candidates on
`pose_candidates` -> `pose_recommendations`, pose sets on `pose_candidate_sets` -> `pose_recommendation_sets`,
and the service `~/recommend_poses`, on an inline mesh, on a mesh named by `package://grasp_orient/...` (the
peer's install of this package holds meshes/), on primitives, and refused ones (tests/ros/pose_cases.py).

Every answer must equal `grasp_orient solve`'s (or `rank --json`'s) on the same JSON: ids, status, the
recommendation (rotation, forces: REL_TOL, as every rclpy test), the contacts, normals and centre of mass. See
conftest.py for how to run.
"""
from __future__ import annotations

import json
import os
import subprocess
import time

import pytest

from conftest import (
    LINE_PREFIX, Peer, binary_path, compare, load_paper_cases, reliable_qos, run_solve, to_plain,
)
import pose_cases as pc
from tf_cases import tool_pose_by_numpy, tool_pose_gap

from grasp_orient.msg import (  # noqa: E402
    PoseCandidate, PoseCandidateSet, PoseRecommendation, PoseRecommendationSet,
)
from grasp_orient.srv import RecommendPoses  # noqa: E402


class PoseClient:
    """Publishers on pose_candidates and pose_candidate_sets, subscribers on their answers (by id), and a client
    of ~/recommend_poses."""

    def __init__(self, peer: Peer, ns: str = ""):
        self.peer = peer
        node = peer.node
        self.pub = node.create_publisher(PoseCandidate, f"{ns}/pose_candidates" if ns else "pose_candidates",
                                         reliable_qos(100))
        self.set_pub = node.create_publisher(PoseCandidateSet,
                                             f"{ns}/pose_candidate_sets" if ns else "pose_candidate_sets",
                                             reliable_qos(10))
        self.answers: dict[str, object] = {}
        self.set_answers: dict[str, object] = {}
        self.sub = node.create_subscription(
            PoseRecommendation, f"{ns}/pose_recommendations" if ns else "pose_recommendations",
            lambda m: self.answers.setdefault(m.recommendation.candidate_id, m), reliable_qos(100))
        self.set_sub = node.create_subscription(
            PoseRecommendationSet, f"{ns}/pose_recommendation_sets" if ns else "pose_recommendation_sets",
            lambda m: self.set_answers.setdefault(m.set_id, m), reliable_qos(10))
        self.srv = node.create_client(RecommendPoses, f"{ns}/grasp_orient/recommend_poses")

    def wait_matched(self):
        # Both directions: the node's answers published before its publisher matches our
        # subscription would be lost (reliable, volatile).
        ok = self.peer.spin_until(lambda: self.pub.get_subscription_count() > 0
                                  and self.set_pub.get_subscription_count() > 0
                                  and self.sub.get_publisher_count() > 0
                                  and self.set_sub.get_publisher_count() > 0, 15.0)
        assert ok, "no match on the pose topics"

    def send(self, cands: list[dict]) -> dict[str, dict]:
        for c in cands:
            self.pub.publish(pc.fill(PoseCandidate(), c))
        ids = [c["id"] for c in cands]
        ok = self.peer.spin_until(lambda: all(i in self.answers for i in ids), 60.0)
        assert ok, f"not answered: {[i for i in ids if i not in self.answers]}"
        return {i: to_plain(self.answers[i]) for i in ids}

    def send_set(self, s: dict) -> dict:
        self.set_pub.publish(pc.fill(PoseCandidateSet(), s))
        ok = self.peer.spin_until(lambda: s["id"] in self.set_answers, 60.0)
        assert ok, f"no answer to pose set {s['id']}"
        return to_plain(self.set_answers[s["id"]])

    def call(self, s: dict) -> dict:
        req = RecommendPoses.Request()
        req.pose_set = pc.fill(PoseCandidateSet(), s)
        return to_plain(self.peer.call(self.srv, req, timeout=60.0).recommendation_set)


@pytest.fixture(scope="module")
def poses(peer, grasp_node) -> PoseClient:
    c = PoseClient(peer)
    c.wait_matched()
    return c


def rank_json(s: dict) -> dict:
    """`grasp_orient rank --json` of one PoseCandidateSet line."""
    r = subprocess.run([str(binary_path()), "rank", "--json"], input=json.dumps(s) + "\n", capture_output=True,
                       text=True, timeout=120)
    assert r.returncode in (0, 1), f"rank exited {r.returncode}: {r.stderr[-2000:]}"
    return json.loads(r.stdout)


def test_pose_topics_and_service_in_the_ros_graph(peer, poses):
    topics = dict(peer.node.get_topic_names_and_types())
    for name, typ in [("/pose_candidates", "PoseCandidate"), ("/pose_recommendations", "PoseRecommendation"),
                      ("/pose_candidate_sets", "PoseCandidateSet"),
                      ("/pose_recommendation_sets", "PoseRecommendationSet")]:
        assert f"grasp_orient/msg/{typ}" in topics.get(name, []), (name, topics.get(name))
    services = dict(peer.node.get_service_names_and_types())
    assert "grasp_orient/srv/RecommendPoses" in services.get("/grasp_orient/recommend_poses", [])


def test_single_pose_candidates_equal_solves(poses):
    cands = pc.singles()
    got = poses.send(cands)
    want = run_solve(cands)
    statuses = {}
    for c, ref in zip(cands, want):
        ours = got[c["id"]]
        # solve names the line of a refusal; the node has no lines
        ref["recommendation"]["message"] = LINE_PREFIX.sub("", ref["recommendation"]["message"])
        diffs = compare(ours, ref)
        assert not diffs, f"{c['id']}: {diffs[:5]}"
        statuses[c["id"]] = ours["recommendation"]["status"]
    # every object answered somewhere, the refusals refused
    for name in pc.objects():
        assert any(statuses[f"{name}-{g}"] in (0, 3) for g, _, _ in pc.grasps()), (name, statuses)
    assert statuses["refused-nothing"] == 1
    for k in ("refused-inside", "refused-scale", "refused-primitive-scale", "refused-type"):
        assert statuses[k] == 2, (k, statuses[k])
    block = got["package-mid"]
    assert block["contact_1"] is not None and block["recommendation"]["status"] == 0, block


def check_tool_poses(pairs: list[tuple[dict, dict, dict]]) -> tuple[int, int]:
    """Each (grasp pose, header, answer): an answer with a rotation carries the tool pose numpy computes
    (tf_cases.tool_pose_by_numpy) within 1e-9, with the candidate's header; one without (refused, NaN rotation)
    carries the header and a pose all NaN (None here). Returns how many of each."""
    turned = refused = 0
    for grasp_pose, header, a in pairs:
        tp = a["tool_pose"]
        rid = a["recommendation"]["candidate_id"]
        assert tp["header"] == header, (rid, tp["header"], header)
        numbers = [*tp["pose"]["position"].values(), *tp["pose"]["orientation"].values()]
        if a["recommendation"]["rotation"]["w"] is None:
            assert all(v is None for v in numbers), (rid, tp)
            refused += 1
            continue
        gap = tool_pose_gap(tp["pose"], tool_pose_by_numpy(grasp_pose, a))
        assert gap <= 1e-9, (rid, gap, tp)
        turned += 1
    return turned, refused


def test_tool_poses_equal_numpy(poses):
    """The tool pose of every single pose and every pose set member, against numpy on the answer's axis, angle and
    contacts (the node, in the candidate's frame: this node has no gravity_frame)."""
    cands = pc.singles()
    got = poses.send(cands)
    pairs = [(c["grasp_pose"], c["header"], got[c["id"]]) for c in cands]
    for s in pc.sets():
        answer = poses.send_set(s)
        if answer["recommendations"]:
            pairs += [(m["grasp_pose"], s["header"], r) for m, r in zip(s["poses"], answer["recommendations"])]
    turned, refused = check_tool_poses(pairs)
    assert turned >= 30 and refused >= 5, (turned, refused)
    # the turn is a real one somewhere, and the grasp centre is not the tool origin everywhere
    assert any((got[c["id"]]["recommendation"]["wrist_rotation"] or 0.0) > 0.1 for c in cands)

    def off_centre(c: dict) -> bool:
        a = got[c["id"]]
        if a["contact_1"]["x"] is None:
            return False
        m = [(a["contact_1"][k] + a["contact_2"][k]) / 2 for k in "xyz"]
        return max(abs(m[i] - c["grasp_pose"]["position"][k]) for i, k in enumerate("xyz")) > 1e-4

    assert sum(map(off_centre, cands)) >= 3


@pytest.mark.parametrize("index", range(len(pc.sets())), ids=[s["id"] for s in pc.sets()])
def test_pose_sets_on_the_topic_and_the_service_equal_rank(poses, index):
    s = pc.sets()[index]
    want = rank_json(s)
    for how, got in [("topic", poses.send_set(s)), ("service", poses.call(s))]:
        diffs = compare(got, want)
        assert not diffs, f"{s['id']} ({how}): {diffs[:5]}"
    if s["id"] != "set-refused":
        assert want["recommendations"][-1]["recommendation"]["status"] == 1, "miss closes on nothing"
        assert want["ranking"], f"{s['id']}: nothing ranked"


def binary_stl(mesh: dict, scale: float) -> bytes:
    """A shape_msgs/Mesh dict as binary STL bytes, its vertices multiplied by `scale`."""
    import struct
    tris = mesh["triangles"]
    out = bytearray(80) + struct.pack("<I", len(tris))
    for t in tris:
        out += struct.pack("<3f", 0.0, 0.0, 0.0)
        for i in t["vertex_indices"]:
            v = mesh["vertices"][i]
            out += struct.pack("<3f", v["x"] * scale, v["y"] * scale, v["z"] * scale)
        out += b"\0\0"
    return bytes(out)


def test_mesh_files_are_read_only_under_mesh_roots(start_node, peer, tmp_path):
    """The node reads a file:// mesh under `mesh_roots` (its answer equals solve's on the same file), and refuses
    every other file a candidate names with one message, whatever the reason: a path through a file, through a
    directory, through a missing one, a FIFO, a link to /dev/zero, a file outside the roots and a `..` out of a
    package get the same text once the resource itself is removed from it (docs/bad-input.md)."""
    root = tmp_path / "meshes"
    root.mkdir()
    data = binary_stl(pc.block_mesh(), 0.001)
    (root / "block.stl").write_bytes(data)
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "block.stl").write_bytes(data)
    os.mkfifo(root / "never.stl")
    os.symlink("/dev/zero", root / "zero.stl")
    ns = "/mesh_roots"
    start_node("--ros-args", "-r", f"__ns:={ns}", "-p", "record:=false", "-p", f"mesh_roots:=[{root}]",
               name="grasp_orient node (mesh roots)")
    client = PoseClient(peer, ns)
    client.wait_matched()
    cand = next(c for c in pc.singles() if c["id"] == "package-mid")
    cand["object"]["scale"] = {"x": 1.0, "y": 1.0, "z": 1.0}
    probes = {
        "through-a-file": f"{root}/block.stl/../x.stl",
        "through-a-directory": f"{tmp_path}/../x.stl",
        "through-a-missing-path": f"{tmp_path}/nowhere/../x.stl",
        "a-fifo": f"file://{root}/never.stl",
        "dev-zero": f"file://{root}/zero.stl",
        "outside-the-roots": f"file://{outside}/block.stl",
        "out-of-the-package": "package://grasp_orient/../../../../etc/passwd.stl",
        "no-such-package": "package://no_such_package/x.stl",
    }
    sent = [dict(cand, id="under-the-roots", object={**cand["object"], "mesh": f"file://{root}/block.stl"})]
    sent += [dict(cand, id=name, object={**cand["object"], "mesh": mesh}) for name, mesh in probes.items()]
    got = client.send(sent)
    messages = set()
    for name, mesh in probes.items():
        r = got[name]["recommendation"]
        assert r["status"] == 2, (name, r["message"])
        assert mesh in r["message"], (name, r["message"])
        messages.add(r["message"].replace(mesh, "<resource>"))
    assert len(messages) == 1, messages
    (message,) = messages
    assert "not under mesh_roots or not readable" in message, message
    assert str(tmp_path) not in message and "AMENT" not in message, message
    (want,) = run_solve([sent[0]])
    diffs = compare(got["under-the-roots"], want)
    assert not diffs, diffs[:5]
    assert got["under-the-roots"]["recommendation"]["status"] == 0
