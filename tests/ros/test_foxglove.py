"""Recordings decoded with Foxglove's own decoders, the code path of Foxglove's MCAP player.

tests/foxglove/decode.mjs runs under Node.js with the npm packages that tests/foxglove/setup.sh installs
(@mcap/core with @mcap/support's lz4 and zstd decompressors, @foxglove/rosmsg `parse(text, { ros2: true })`,
@foxglove/rosmsg2-serialization `MessageReader`). Checked here:
- every golden bag in bags/: every message of every channel decodes, with the indexed reader the player uses
  and with the stream reader it falls back to, and the values equal what the Python readers (mcap_ros2 and
  rosbags, tests/ros/mcap_util.py) read;
- a live recording of `grasp_orient node -p record_markers:=true` fed valid and refused candidates from
  rclpy: every message of its three channels decodes, and the values equal what went out and came back
  over DDS (candidates, answers, marker arrays) and what the Python readers read.

The Foxglove packages come from GRASP_ORIENT_FOXGLOVE_DIR when set (tests/run.sh sets it), else from
`bash tests/foxglove/setup.sh`, run here. A missing Node.js or npm package fails, never skips.
"""
from __future__ import annotations

import json
import math
import os
import random
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

import mcap_util as mu
from conftest import GraspClient, Peer, is_probe_markers, load_paper_cases, reliable_qos, require_environment

HERE = Path(__file__).resolve().parent
FOXGLOVE = HERE.parent / "foxglove"
DECODE = FOXGLOVE / "decode.mjs"
SETUP = FOXGLOVE / "setup.sh"
GOLDEN = sorted(p.relative_to(mu.BAGS_DIR).as_posix() for p in mu.BAGS_DIR.rglob("*.mcap"))
LIVE_NS = "/foxglove_live"
SEED = 80808


# ---------------------------------------------------------------------------------------------------
# Running Foxglove's decoders
# ---------------------------------------------------------------------------------------------------
@pytest.fixture(scope="session")
def foxglove_dir() -> Path:
    """The directory with Foxglove's npm packages: $GRASP_ORIENT_FOXGLOVE_DIR, else what setup.sh installs."""
    given = os.environ.get("GRASP_ORIENT_FOXGLOVE_DIR")
    if given:
        d = Path(given)
        if not (d / "node_modules").is_dir():
            pytest.fail(f"GRASP_ORIENT_FOXGLOVE_DIR={given} has no node_modules: run bash {SETUP}", pytrace=False)
        return d
    r = subprocess.run(["bash", str(SETUP)], capture_output=True, text=True, timeout=1800)
    lines = r.stdout.strip().splitlines()
    if r.returncode != 0 or not lines:
        pytest.fail(f"bash {SETUP} exited {r.returncode}: Foxglove's decoders are not installed\n{r.stderr[-3000:]}",
                    pytrace=False)
    return Path(lines[-1])


class Decoded:
    """What decode.mjs said about some files: per-file summaries, every decoded message, its stderr and exit code."""

    def __init__(self, summaries: list[dict], messages: list[dict], stderr: str, returncode: int):
        self.summaries = summaries
        self.messages = messages
        self.stderr = stderr
        self.returncode = returncode

    def failures(self) -> list[str]:
        """Every way in which some message of some channel did not decode (empty when all did)."""
        out = []
        if self.returncode != 0:
            out.append(f"decode.mjs exited {self.returncode}")
        for s in self.summaries:
            out += [f"{s['file']}: {p}" for p in s["problems"]]
            if not s["channels"]:
                out.append(f"{s['file']}: no channel")
            for c in s["channels"]:
                where = f"{s['file']} {c['topic']} [{c['schema']}]"
                if c["error"] is not None:
                    e = c["error"]
                    out.append(f"{where}: {e['stage']} error on {e['failures']} of {c['messages']} messages: "
                               f"{e['message']}")
                elif c["decoded"] != c["messages"]:
                    out.append(f"{where}: {c['decoded']} of {c['messages']} messages decoded")
                if c["statistics"] is not None and c["statistics"] != c["messages"]:
                    out.append(f"{where}: {c['messages']} messages read, {c['statistics']} in the statistics")
            if not s["ok"] and not out:
                out.append(f"{s['file']}: not ok: {s}")
        return out

    def recs(self) -> list[mu.Rec]:
        """The decoded messages as mcap_util.Rec, with the schema name of their channel."""
        schema = {(s["file"], c["topic"]): c["schema"] for s in self.summaries for c in s["channels"]}
        return [mu.Rec(m["topic"], m["logTime"], m["publishTime"], schema[(m["file"], m["topic"])], m["message"])
                for m in self.messages]


def foxglove_decode(foxglove_dir: Path, tmp_path: Path, *files: Path, reader: str = "auto") -> Decoded:
    """decode.mjs on these files: every message of every channel, as Foxglove's player decodes it."""
    out = tmp_path / f"foxglove-{reader}-{time.monotonic_ns()}.jsonl"
    env = dict(os.environ, GRASP_ORIENT_FOXGLOVE_DIR=str(foxglove_dir))
    try:
        r = subprocess.run(["node", str(DECODE), "--reader", reader, "--messages", str(out), *map(str, files)],
                           capture_output=True, text=True, env=env, timeout=600)
    except FileNotFoundError:
        pytest.fail(f"no `node` on PATH: run bash {SETUP} (it installs Node.js from Debian)", pytrace=False)
    assert r.returncode in (0, 1), f"decode.mjs exited {r.returncode} (bad usage or missing package):\n{r.stderr[-3000:]}"
    summaries = [json.loads(l) for l in r.stdout.splitlines() if l.strip()]
    assert len(summaries) == len(files), f"decode.mjs summarised {len(summaries)} of {len(files)} files:\n{r.stderr[-3000:]}"
    # decode.mjs writes NaN, Infinity and -0.0 as Python's json reads them
    messages = [json.loads(l) for l in out.read_text().splitlines() if l.strip()] if out.exists() else []
    return Decoded(summaries, messages, r.stderr, r.returncode)


def assert_decodes_everything(d: Decoded, what: str):
    f = d.failures()
    assert not f, f"Foxglove's decoders fail on {what}:\n  " + "\n  ".join(f[:20]) + f"\n\ndecode.mjs said:\n{d.stderr[-3000:]}"


def _content_key(msg) -> str:
    """A sort key for decoded messages that does not tell 1 from 1.0 (Foxglove's JSON writes a float64 2.0 as 2)."""
    def floats(v):
        if isinstance(v, dict):
            return {k: floats(x) for k, x in v.items()}
        if isinstance(v, list):
            return [floats(x) for x in v]
        return float(v) if type(v) is int else v

    return mu.canonical(mu.jsonish(floats(msg)))


def compare_decodings(a: list[mu.Rec], b: list[mu.Rec], publish_time: bool = True) -> list[str]:
    """Differences between two decodings of one file: same messages (topic, log_time, publish_time unless told
    not to, schema, every field; NaN equals NaN, 2 equals 2.0), paired after sorting."""
    if len(a) != len(b):
        return [f"message count {len(a)} vs {len(b)}"]
    key = lambda r: (r.topic, r.log_time, _content_key(r.msg))  # noqa: E731
    out = []
    for x, y in zip(sorted(a, key=key), sorted(b, key=key)):
        where = f"{x.topic}@{x.log_time}"
        if (x.topic, x.log_time) != (y.topic, y.log_time):
            out.append(f"{where} vs {y.topic}@{y.log_time}")
            continue
        if publish_time and x.publish_time != y.publish_time:
            out.append(f"{where}: publish_time {x.publish_time} vs {y.publish_time}")
        if x.msgtype and y.msgtype and mu._normal(x.msgtype) != mu._normal(y.msgtype):
            out.append(f"{where}: type {x.msgtype} vs {y.msgtype}")
        out += [f"{where}: {d}" for d in mu.differences(x.msg, y.msg)[:5]]
    return out


def same_as_python_readers(fox: list[mu.Rec], path: Path) -> list[str]:
    """Differences between Foxglove's decoding of `path` and mcap_ros2's (with publish_time) and rosbags'."""
    return ([f"vs mcap_ros2: {p}" for p in compare_decodings(fox, mu.read_mcap(path))]
            + [f"vs rosbags: {p}" for p in compare_decodings(fox, mu.read_rosbags(path), publish_time=False)])


# ---------------------------------------------------------------------------------------------------
# The golden bags
# ---------------------------------------------------------------------------------------------------
def test_every_golden_bag_is_checked():
    assert len(GOLDEN) >= 3, f"expected the golden bags in {mu.BAGS_DIR}, found {GOLDEN}"


@pytest.mark.parametrize("name", GOLDEN)
def test_golden_bag_decodes_with_foxglove(foxglove_dir, tmp_path, name):
    path = mu.BAGS_DIR / name
    indexed = foxglove_decode(foxglove_dir, tmp_path, path)
    assert_decodes_everything(indexed, name)
    (s,) = indexed.summaries
    assert s["reader"] == "indexed", f"{name}: Foxglove's player would read it with the {s['reader']} reader"
    fox = indexed.recs()
    assert len(fox) == sum(c["messages"] for c in s["channels"]) > 0
    problems = same_as_python_readers(fox, path)
    assert not problems, f"{name}: Foxglove's decoders and the Python readers disagree:\n  " + "\n  ".join(problems[:20])

    # the player's fallback for files without an index reads the same messages, in file order
    stream = foxglove_decode(foxglove_dir, tmp_path, path, reader="stream")
    assert_decodes_everything(stream, f"{name} (stream reader)")
    d = compare_decodings(stream.recs(), fox)
    assert not d, f"{name}: the stream reader decodes differently from the indexed one:\n  " + "\n  ".join(d[:20])


def _with_dependency_headers_as_pkg_msg_name(src: Path, dst: Path):
    """A copy of `src` whose schema texts name each dependency `pkg/msg/Name` ("MSG: std_msgs/msg/Header")
    where the fields say `pkg/Name`: the form the node wrote before it followed rosbag2. Messages untouched."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    with open(src, "rb") as f, open(dst, "wb") as out:
        r = make_reader(f)
        summary = r.get_summary()
        w = Writer(out, compression=CompressionType.ZSTD)
        w.start(profile=r.get_header().profile, library="test_foxglove.py")
        sids = {s.id: w.register_schema(s.name, s.encoding,
                                        re.sub(r"^MSG: (\w+)/(\w+)$", r"MSG: \1/msg/\2", s.data.decode(), flags=re.M).encode())
                for s in summary.schemas.values()}
        cids = {c.id: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id], dict(c.metadata))
                for c in summary.channels.values()}
        for _, channel, m in r.iter_messages():
            w.add_message(cids[channel.id], m.log_time, m.data, m.publish_time, m.sequence)
        w.finish()


def test_foxglove_check_fails_on_pkg_msg_name_dependency_headers(foxglove_dir, tmp_path):
    """The check can fail: with dependencies named `pkg/msg/Name`, Foxglove's parser finds no definition for the
    `pkg/Name` of the fields and no channel decodes, while the Python readers accept the file."""
    bad = tmp_path / "pkg_msg_name_headers.mcap"
    _with_dependency_headers_as_pkg_msg_name(mu.BAGS_DIR / "paper_cases.mcap", bad)
    assert "MSG: std_msgs/msg/Header" in bad.read_bytes().decode("latin-1")
    d = foxglove_decode(foxglove_dir, tmp_path, bad)
    assert d.returncode == 1, f"decode.mjs exited {d.returncode} on {bad.name}:\n{d.stderr}"
    (s,) = d.summaries
    assert not s["ok"] and len(s["channels"]) == 2 and d.messages == []
    for c in s["channels"]:
        e = c["error"]
        assert e is not None and e["stage"] == "parse" and e["failures"] == c["messages"] == 4, c
        # Foxglove's error on the old schema text, verbatim (the root's first field is `std_msgs/Header header`)
        assert e["message"] == "Expected 1 top level type definition for 'std_msgs/Header' but found 0", e
    assert len(mu.read_mcap(bad)) == 8, "mcap_ros2 should still read the file: it accepts both forms"


# ---------------------------------------------------------------------------------------------------
# A live recording with markers
# ---------------------------------------------------------------------------------------------------
def _refused_and_unclosed(base: dict) -> list[dict]:
    """Candidates the node answers with status 2 (refused) or 1 (no force closure): they carry no markers."""
    def variant(cid, f):
        c = json.loads(json.dumps(base))
        c["id"] = cid
        f(c)
        return c

    return [
        variant("fox-nan-mass", lambda c: c.update(mass=math.nan)),
        variant("fox-inf-contact", lambda c: c["contact_1"].update(x=math.inf)),
        variant("fox-negative-mass", lambda c: c.update(mass=-1.0)),
        variant("fox-zero-normal", lambda c: c.update(normal_2={"x": 0.0, "y": 0.0, "z": 0.0})),
        variant("fox-coincident", lambda c: c.update(contact_2=dict(c["contact_1"]))),
        variant("fox-zero-friction", lambda c: c.update(friction_1=0.0)),
        # case (a) with cones of 0.6 degrees: the line between the contacts leaves both
        variant("fox-no-closure", lambda c: c.update(friction_1=0.01, friction_2=0.01)),
    ]


def _live_candidates() -> list[dict]:
    now = time.time_ns()
    paper = load_paper_cases()
    for c in paper:
        c["id"] = "fox-" + c["id"]
        c["header"]["stamp"] = {"sec": now // 10**9, "nanosec": now % 10**9}
    rng = random.Random(SEED)
    frames = ["object", "world", "tool0", "camera_optical", "base_link"]
    rand = [mu.quantize(mu.random_grasp(rng, f"fox-random-{k}", frames[k % len(frames)],
                                        stamp=(now // 10**9, (now + k) % 10**9))) for k in range(20)]
    # spatial candidates: `model` 1 and a 3D rotation_axis, in every kind, for Foxglove to decode
    spatial = [mu.quantize(mu.random_spatial_grasp(rng, f"fox-spatial-{k}", mu.SPATIAL_KINDS[k % 4],
                                                   frames[k % len(frames)])) for k in range(8)]
    return paper + rand + spatial + _refused_and_unclosed(paper[0])


def test_live_recording_with_markers_decodes_with_foxglove(foxglove_dir, rclpy_context, start_node, tmp_path):
    require_environment()
    from visualization_msgs.msg import MarkerArray

    record_dir = tmp_path / "runs"
    node = start_node("--ros-args", "-r", f"__ns:={LIVE_NS}", "-p", "record:=true", "-p", f"record_dir:={record_dir}",
                      "-p", "record_markers:=true", name="recording node (Foxglove check)")
    peer = Peer("grasp_orient_foxglove_peer")
    try:
        client = GraspClient(peer, ns=LIVE_NS)
        markers: list = []
        msub = peer.node.create_subscription(MarkerArray, f"{LIVE_NS}/grip_markers", markers.append, reliable_qos())
        assert peer.spin_until(lambda: msub.get_publisher_count() > 0, 15.0), f"no publisher on {LIVE_NS}/grip_markers"
        # probes (in a frame of their own) until the node has matched our marker reader as well: a probe
        # answered before has its markers recorded but not received, so the comparisons leave probes out
        client.ensure_markers(markers)
        cands = _live_candidates()
        answers = client.send_and_collect(cands)
        sent = {c["id"]: c for c in cands}
        answered = {m.candidate_id: m for ms in client.answers.values() for m in ms}  # probes too
        ok = [a for a in answers.values() if a.status == 0]
        ok_probes = [a for i, a in answered.items() if i not in sent and a.status == 0]
        statuses = sorted({a.status for a in answers.values()})
        assert statuses == [0, 1, 2], f"the live run needs answers of every status, got {statuses}"
        received = lambda: [m for m in markers if not is_probe_markers(m)]  # noqa: E731
        peer.spin_until(lambda: len(received()) >= len(ok), 10.0)
        peer.spin_for(0.3)
        assert len(received()) == len(ok), f"{len(received())} marker arrays received for {len(ok)} solved candidates"
        probe_markers = len(markers) - len(received())
        assert 1 <= probe_markers <= len(ok_probes), f"{probe_markers} marker arrays for {len(ok_probes)} probes"
        node.stop_and_check(signal.SIGINT)
    finally:
        peer.destroy()
        node.kill()

    files = sorted(record_dir.rglob("*.mcap"))
    assert len(files) == 1, f"expected one recording in {record_dir}, found {files}"
    path = files[0]
    topics = {f"{LIVE_NS}/grasp_candidates": mu.CANDIDATE_TYPE, f"{LIVE_NS}/grip_recommendations": mu.RECOMMENDATION_TYPE,
              f"{LIVE_NS}/grip_markers": mu.MARKER_ARRAY_TYPE}

    d = foxglove_decode(foxglove_dir, tmp_path, path)
    assert_decodes_everything(d, f"the node's live recording {path.name}")
    (s,) = d.summaries
    got_topics = {c["topic"]: c["schema"] for c in s["channels"]}
    assert got_topics == topics, f"channels {got_topics}, expected {topics}"
    fox = d.recs()
    by_topic: dict[str, list[mu.Rec]] = {}
    for r in fox:
        by_topic.setdefault(r.topic, []).append(r)
    problems = []

    # candidates: as sent (NaN and infinities included)
    rc = by_topic.get(f"{LIVE_NS}/grasp_candidates", [])
    rc_ids = sorted(r.msg["id"] for r in rc)
    if rc_ids != sorted(answered):
        problems.append(f"recorded candidates {len(rc_ids)}, answered {len(answered)}: "
                        f"{sorted(set(rc_ids) ^ set(answered))[:5]}")
    for r in rc:
        if r.msg["id"] in sent:
            problems += [f"candidate {r.msg['id']}: {x}" for x in mu.differences(r.msg, mu.as_message(sent[r.msg["id"]]))[:4]]
    # the spatial fields are decoded, not defaulted: spatial candidates' model 1 and their 3D rotation axes
    spatial_ids = {c["id"] for c in cands if c.get("model") == 1}
    if sorted(r.msg["id"] for r in rc if r.msg.get("model") == 1) != sorted(spatial_ids):
        problems.append(f"Foxglove decoded model 1 on other candidates than the {len(spatial_ids)} spatial ones")
    axes = [r.msg["rotation_axis"] for r in by_topic.get(f"{LIVE_NS}/grip_recommendations", [])
            if r.msg["candidate_id"] in spatial_ids and r.msg["status"] == 0]
    if len(axes) != len(spatial_ids) or any(abs(a["z"]) == 1.0 for a in axes):
        problems.append(f"Foxglove's rotation_axis of the spatial answers: {axes[:3]}")

    # answers: equal to what the peer received over DDS, every field
    rr = by_topic.get(f"{LIVE_NS}/grip_recommendations", [])
    if sorted(r.msg["candidate_id"] for r in rr) != sorted(answered):
        problems.append(f"{len(rr)} recorded answers, {len(answered)} received over DDS")
    for r in rr:
        a = answered.get(r.msg["candidate_id"])
        if a is not None:
            problems += [f"answer to {a.candidate_id}: {x}" for x in mu.differences(r.msg, mu.plain(a))[:4]]

    # marker arrays: as the peer received them (paired by content, compared field by field), the probes'
    # left out on both sides (one answered before the node matched our reader is recorded, not received)
    rm = by_topic.get(f"{LIVE_NS}/grip_markers", [])
    got = sorted((mu.plain(m) for m in markers if not is_probe_markers(m)), key=_content_key)
    rec = sorted((r.msg for r in rm if not is_probe_markers(r.msg)), key=_content_key)
    if len(rm) - len(rec) != len(ok_probes):
        problems.append(f"{len(rm) - len(rec)} marker arrays of probes recorded, {len(ok_probes)} probes solved")
    if len(rec) != len(got):
        problems.append(f"{len(rec)} marker arrays recorded, {len(got)} received over DDS")
    for k, (a, b) in enumerate(zip(rec, got)):
        problems += [f"marker array {k}: {x}" for x in mu.differences(a, b)[:4]]
    assert not problems, f"{path}: {len(problems)} problems:\n  " + "\n  ".join(problems[:30])

    # and the Python readers read the same, and so does the player's stream reader (its fallback)
    diff = same_as_python_readers(fox, path)
    assert not diff, f"{path}: Foxglove's decoders and the Python readers disagree:\n  " + "\n  ".join(diff[:20])
    stream = foxglove_decode(foxglove_dir, tmp_path, path, reader="stream")
    assert_decodes_everything(stream, f"{path.name} (stream reader)")
    diff = compare_decodings(stream.recs(), fox)
    assert not diff, f"{path}: the stream reader decodes differently from the indexed one:\n  " + "\n  ".join(diff[:20])


# ---------------------------------------------------------------------------------------------------
# A live recording of pose candidates: the tool poses
# ---------------------------------------------------------------------------------------------------
POSES_NS = "/foxglove_poses"


def test_live_pose_recording_holds_the_tool_poses(foxglove_dir, rclpy_context, start_node, tmp_path):
    """The node records pose candidates and their answers; Foxglove's decoders read every message, and the
    tool_pose of each recorded answer equals what the peer received over DDS and numpy's tool pose
    (tf_cases.tool_pose_by_numpy) from the recorded candidate's gripper pose and the recorded answer's axis,
    angle and contacts; an answer without a rotation holds NaN. mcap_ros2 and rosbags read the same."""
    require_environment()
    import pose_cases as pc
    from grasp_orient.msg import PoseCandidate, PoseRecommendation
    from tf_cases import tool_pose_by_numpy, tool_pose_gap

    record_dir = tmp_path / "runs"
    node = start_node("--ros-args", "-r", f"__ns:={POSES_NS}", "-p", "record:=true", "-p",
                      f"record_dir:={record_dir}", name="recording node (tool poses)")
    peer = Peer("grasp_orient_foxglove_pose_peer")
    cands = pc.singles()
    answers: dict[str, object] = {}
    try:
        pub = peer.node.create_publisher(PoseCandidate, f"{POSES_NS}/pose_candidates", reliable_qos())
        sub = peer.node.create_subscription(PoseRecommendation, f"{POSES_NS}/pose_recommendations",
                                            lambda m: answers.setdefault(m.recommendation.candidate_id, m),
                                            reliable_qos())
        assert peer.spin_until(lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0, 15.0), \
            "no match on the pose topics"
        for c in cands:
            pub.publish(pc.fill(PoseCandidate(), c))
        assert peer.spin_until(lambda: all(c["id"] in answers for c in cands), 60.0), \
            f"not answered: {[c['id'] for c in cands if c['id'] not in answers]}"
        node.stop_and_check(signal.SIGINT)
    finally:
        peer.destroy()
        node.kill()

    files = sorted(record_dir.rglob("*.mcap"))
    assert len(files) == 1, f"expected one recording in {record_dir}, found {files}"
    path = files[0]
    d = foxglove_decode(foxglove_dir, tmp_path, path)
    assert_decodes_everything(d, f"the node's pose recording {path.name}")
    fox = d.recs()
    recorded_cands = {r.msg["id"]: r.msg for r in fox if r.topic == f"{POSES_NS}/pose_candidates"}
    recorded = {r.msg["recommendation"]["candidate_id"]: r.msg for r in fox
                if r.topic == f"{POSES_NS}/pose_recommendations"}
    assert sorted(recorded) == sorted(c["id"] for c in cands), sorted(recorded)
    problems, turned, refused = [], 0, 0
    for cid, a in recorded.items():
        problems += [f"answer to {cid}: {x}" for x in mu.differences(a, mu.plain(answers[cid]))[:4]]
        tp = a["tool_pose"]
        if tp["header"]["frame_id"] != "base_link":
            problems.append(f"answer to {cid}: tool_pose in {tp['header']['frame_id']!r}")
        numbers = [*tp["pose"]["position"].values(), *tp["pose"]["orientation"].values()]
        if math.isnan(a["recommendation"]["rotation"]["w"]):
            refused += 1
            if not all(math.isnan(v) for v in numbers):
                problems.append(f"answer to {cid}: no rotation, tool_pose {tp['pose']}")
            continue
        turned += 1
        gap = tool_pose_gap(tp["pose"], tool_pose_by_numpy(recorded_cands[cid]["grasp_pose"], a))
        if not gap <= 1e-9:
            problems.append(f"answer to {cid}: tool_pose {tp['pose']} is {gap:.3g} from numpy's")
    assert not problems, f"{path}: {len(problems)} problems:\n  " + "\n  ".join(problems[:30])
    assert turned >= 20 and refused >= 5, (turned, refused)
    diff = same_as_python_readers(fox, path)
    assert not diff, f"{path}: Foxglove's decoders and the Python readers disagree:\n  " + "\n  ".join(diff[:20])
