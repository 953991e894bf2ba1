"""MCAP recordings of grasp_orient, read by two independent Python readers (rosbags, mcap + mcap_ros2).

- the golden bags in bags/ (bags/make_bags.py) decode identically with both readers, are what rosbag2 writes,
  and hold `grasp_orient solve`'s answers;
- `grasp_orient replay` re-solves them (and a bag written by rosbags) and notices a tampered answer;
- `grasp_orient node -p record:=true` records what it receives and answers, readable by both readers;
- `grasp_orient recover` salvages a recording whose node was SIGKILLed.

Run with the ROS peer like the rest of tests/ros:  source "$(bash tests/peer/setup.sh | tail -n 1)" && python -m pytest tests/ros/test_mcap.py
Nothing here skips: a missing reader library, binary or subcommand fails with the reason.
"""
from __future__ import annotations

import datetime as dt
import json
import math
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import (
    DOMAIN_ID, NodeProcess, compare, is_probe_markers, probe_candidate, require_environment, ros_env, run_solve,
)

import mcap_util as mu

BAGS = mu.BAGS_DIR
MAX_BAG_BYTES = 200 * 1024
# (candidates, recommendations) of each golden bag, as bags/make_bags.py writes them
GOLDEN = {
    "paper_cases.mcap": (4, 4),
    "random_grasps.mcap": (335, 335),
    "rosbags_written.mcap": (24, 0),
}
SEED = 77031
CANDIDATE_DEPS = {"std_msgs/msg/Header", "builtin_interfaces/msg/Time", "geometry_msgs/msg/Point",
                  "geometry_msgs/msg/Vector3"}
RECOMMENDATION_DEPS = {"std_msgs/msg/Header", "builtin_interfaces/msg/Time", "geometry_msgs/msg/Quaternion",
                       "geometry_msgs/msg/Vector3"}
FILE_NAME = re.compile(r"^grasp_orient_(\d{8}T\d{6}Z)\.mcap$")


# ---------------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------------
def _require_readers():
    try:
        import mcap  # noqa: F401
        import mcap_ros2.decoder  # noqa: F401
        import mcap_ros2.writer  # noqa: F401
        import rosbags.highlevel  # noqa: F401
    except ImportError as e:
        pytest.fail(f"MCAP reader libraries missing ({e}): run with the ROS peer venv "
                    f"(source \"$(bash tests/peer/setup.sh | tail -n 1)\")", pytrace=False)


@pytest.fixture(scope="session")
def binary() -> Path:
    _require_readers()
    return require_environment()


def require_subcommand(binary: Path, name: str):
    r = subprocess.run([str(binary), "--help"], capture_output=True, text=True, timeout=30)
    if not re.search(rf"^\s+{name}\s", r.stdout, re.M):
        pytest.fail(f"{binary} has no `{name}` subcommand; its --help:\n{r.stdout}", pytrace=False)


def run(binary: Path, *args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def both_readers(path: Path) -> list[mu.Rec]:
    """The file decoded by rosbags and by mcap_ros2; asserts they agree; returns mcap_ros2's (with publish_time)."""
    try:
        a = mu.read_rosbags(path)
    except Exception as e:  # noqa: BLE001 - the reader's own words are the point
        raise AssertionError(f"rosbags cannot read {path}: {type(e).__name__}: {e}") from e
    try:
        b = mu.read_mcap(path)
    except Exception as e:  # noqa: BLE001
        raise AssertionError(f"mcap + mcap_ros2 cannot read {path}: {type(e).__name__}: {e}") from e
    diff = mu.compare_readers(a, b)
    assert not diff, f"rosbags and mcap_ros2 decode {path} differently:\n" + "\n".join(diff[:20])
    return b


def _sections(schema_text: str) -> tuple[str, list[str]]:
    """The top-level text and the dependency names ("MSG: ..." lines) of a ros2msg schema."""
    parts = re.split(r"^={80}\n", schema_text, flags=re.M)
    names = []
    for p in parts[1:]:
        first = p.split("\n", 1)[0]
        assert first.startswith("MSG: "), f"dependency section starts with {first!r}, not 'MSG: <type>'"
        names.append(first[len("MSG: "):].strip())
    return parts[0], names


def check_conventions(path: Path, topics: dict[str, str], deps: dict[str, set[str]], own_text: bool = True,
                      older: bool = False):
    """rosbag2's MCAP conventions: profile, schemas, encodings, QoS metadata, CDR header, compressed chunks.
    With `own_text` (every writer but rosbags), each schema's text is exactly rosbag2's; with `older` (the golden
    bags, recorded before messages grew), rosbag2's text of the definitions of their time (a prefix of today's
    in every section)."""
    from rosbags.rosbag2.metadata import parse_qos

    f = mu.mcap_facts(path)
    problems = []
    if f["profile"] != "ros2":
        problems.append(f"profile {f['profile']!r}, expected 'ros2'")
    if set(f["channels"]) != set(topics):
        problems.append(f"channels {sorted(f['channels'])}, expected {sorted(topics)}")
    for topic, ch in f["channels"].items():
        want = topics.get(topic)
        if ch["schema"] != want:
            problems.append(f"{topic}: schema {ch['schema']!r}, expected {want!r}")
        if ch["message_encoding"] != "cdr":
            problems.append(f"{topic}: message encoding {ch['message_encoding']!r}, expected 'cdr'")
        qos = ch["metadata"].get("offered_qos_profiles")
        if qos is None:
            problems.append(f"{topic}: no offered_qos_profiles in channel metadata {ch['metadata']}")
        else:
            try:
                profiles = parse_qos(qos)
                if not profiles:
                    problems.append(f"{topic}: offered_qos_profiles holds no profile: {qos!r}")
                for p in profiles:
                    if p.reliability.name not in ("RELIABLE",) or p.durability.name != "VOLATILE":
                        problems.append(f"{topic}: offered QoS {p.reliability.name}/{p.durability.name}, "
                                        f"expected RELIABLE/VOLATILE (the node's QoS)")
            except Exception as e:  # noqa: BLE001
                problems.append(f"{topic}: rosbags rejects offered_qos_profiles {qos!r}: {e}")
        heads = f["payload_heads"].get(topic, set())
        if heads - {mu.CDR_HEADER}:
            problems.append(f"{topic}: payloads start with {sorted(heads)}, expected {mu.CDR_HEADER!r}")
    for s in f["schemas"].values():
        if s["encoding"] != "ros2msg":
            problems.append(f"schema {s['name']}: encoding {s['encoding']!r}, expected 'ros2msg'")
            continue
        own, names = _sections(s["data"])
        if own_text and s["data"] != mu.rosbag2_full_text(s["name"]) and not (
                older and mu.is_rosbag2_text_of_an_older_version(s["name"], s["data"])):
            # the whole text, byte for byte, as rosbag2 (Jazzy) builds it from the installed .msg files
            problems.append(f"schema {s['name']}: the text is not what rosbag2 writes for it")
        want = deps.get(s["name"])
        got = {mu._normal(n) for n in names}
        if want is not None and not want <= got:
            problems.append(f"schema {s['name']}: dependencies {sorted(names)}, missing {sorted(want - got)}")
        if len(got) != len(names):
            problems.append(f"schema {s['name']}: a dependency appears twice: {names}")
    if not f["chunk_compressions"]:
        problems.append("no chunks (the contract says chunked)")
    elif not set(f["chunk_compressions"]) <= {"lz4", "zstd"}:
        problems.append(f"chunk compressions {sorted(set(f['chunk_compressions']))}, expected lz4 or zstd")
    assert not problems, f"{path}:\n  " + "\n  ".join(problems)
    return f


def by_topic(recs: list[mu.Rec], topic: str) -> list[mu.Rec]:
    return [r for r in recs if r.topic == topic]


def key(msg: dict, id_field: str) -> tuple:
    s = msg["header"]["stamp"]
    return (msg[id_field][:1024], s["sec"], s["nanosec"])


def pair_in_order(cands: list[mu.Rec], recs: list[mu.Rec]) -> tuple[list[tuple[mu.Rec, mu.Rec | None]], list]:
    """Each candidate with the first unused recommendation of the same (id, stamp); and the leftovers."""
    queue: dict[tuple, list] = {}
    for r in recs:
        queue.setdefault(key(r.msg, "candidate_id"), []).append(r)
    pairs = []
    for c in cands:
        q = queue.get(key(c.msg, "id"))
        pairs.append((c, q.pop(0) if q else None))
    return pairs, [r for q in queue.values() for r in q]


def finite(v) -> bool:
    if isinstance(v, dict):
        return all(finite(x) for x in v.values())
    if isinstance(v, list):
        return all(finite(x) for x in v)
    return not (isinstance(v, float) and not math.isfinite(v))


RECORDED_BEHIND_TANGENT = "invalid input: center_of_mass lies outside the object: behind the surface tangent at "


def answered_behind_tangent(recorded: dict, now: dict) -> bool:
    """The recorded refusal of a centre of mass behind a tangent, answered now with a note naming that contact
    (docs/recordings.md, "Refusals answered now"; the same rule as `replay`)."""
    message = recorded["message"]
    if recorded["status"] != 2 or not message.startswith(RECORDED_BEHIND_TANGENT):
        return False
    contact = message[len(RECORDED_BEHIND_TANGENT):]
    note = "center_of_mass lies behind the surface tangent at "
    named = any(contact in part[len(note):].split(" (")[0].split(" and ")
                for part in now["message"].split("; ") if part.startswith(note))
    return now["status"] != 2 and named


def check_answers_equal_solve(pairs: list[tuple[mu.Rec, mu.Rec]], what: str, recorded_fields_only: bool = False):
    """Every recorded recommendation equals `solve` on its candidate (to 1e-12), but for a recorded refusal of a
    centre of mass behind a tangent that `solve` answers now (counted; returned); a candidate JSON cannot carry
    (NaN, inf) must have been answered with status 2 naming a field. With `recorded_fields_only` (a recording made
    before the message grew), the fields added since are not compared."""
    finite_pairs = [(c, r) for c, r in pairs if finite(c.msg)]
    ref = run_solve([c.msg for c, _ in finite_pairs]) if finite_pairs else []
    problems = []
    answered_now = 0
    for (c, r), s in zip(finite_pairs, ref):
        if answered_behind_tangent(mu.jsonish(r.msg), s):
            answered_now += 1
            continue
        if recorded_fields_only:
            s = {k: v for k, v in s.items() if k in r.msg}
        diff = compare(mu.jsonish(r.msg), s)
        if diff:
            problems.append(f"{c.msg['id'][:40]}: " + "; ".join(diff[:4]))
    for c, r in pairs:
        if not finite(c.msg):
            m = r.msg
            if m["status"] != 2 or not m["message"]:
                problems.append(f"{c.msg['id'][:40]} (not finite): status {m['status']}, message {m['message']!r}")
    assert not problems, f"{what}: {len(problems)} recorded answers differ from solve:\n  " + "\n  ".join(problems[:20])
    return answered_now


# ---------------------------------------------------------------------------------------------------
# The golden bags
# ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_golden_bag_decodes_identically_with_rosbags_and_mcap(binary, name):
    path = BAGS / name
    assert path.is_file(), f"{path} is missing (regenerate: source \"$(bash tests/peer/setup.sh | tail -n 1)\" && python bags/make_bags.py)"
    size = path.stat().st_size
    assert size < MAX_BAG_BYTES, f"{path} is {size} bytes, more than {MAX_BAG_BYTES}"
    recs = both_readers(path)
    n_cand, n_rec = GOLDEN[name]
    topics = {mu.CANDIDATES_TOPIC: mu.CANDIDATE_TYPE}
    if n_rec:
        topics[mu.RECOMMENDATIONS_TOPIC] = mu.RECOMMENDATION_TYPE
    # rosbags writes the definition it generates (no comments), not the .msg file
    check_conventions(path, topics, {mu.CANDIDATE_TYPE: CANDIDATE_DEPS, mu.RECOMMENDATION_TYPE: RECOMMENDATION_DEPS},
                      own_text=name != "rosbags_written.mcap", older=True)
    assert len(by_topic(recs, mu.CANDIDATES_TOPIC)) == n_cand
    assert len(by_topic(recs, mu.RECOMMENDATIONS_TOPIC)) == n_rec
    assert all(r.msgtype == topics[r.topic] for r in recs)


def test_golden_schemas_are_rosbag2s_text():
    """The mcap_ros2-written bags carry exactly the text rosbag2 (Jazzy) would write for these types with the
    .msg files of their time: today's files cut before the fields added since (the spatial candidates'
    `model` and `rotation_axis`, the grip forces of sets, the tolerances and `gripping_power_nominal`)."""
    f = mu.mcap_facts(BAGS / "random_grasps.mcap")
    by_name = {s["name"]: s["data"] for s in f["schemas"].values()}
    for type_name, added in ((mu.CANDIDATE_TYPE, ["MODEL_PLANAR", "uint8 model", "mass_tolerance"]),
                             (mu.RECOMMENDATION_TYPE, ["finger_force", "rotation_axis", "gripping_power_nominal"])):
        old = by_name[type_name]
        assert old != mu.rosbag2_full_text(type_name), f"the golden bags predate {added} of {type_name}"
        assert mu.is_rosbag2_text_of_an_older_version(type_name, old), \
            f"{type_name}: schema text is not rosbag2's for an older version of the .msg file"
        assert not [a for a in added if a in old], (type_name, added)
    # and the check is not vacuous: a changed line is no older version
    old = by_name[mu.RECOMMENDATION_TYPE]
    assert not mu.is_rosbag2_text_of_an_older_version(mu.RECOMMENDATION_TYPE,
                                                       old.replace("float64 gripping_power ", "float32 gripping_power "))


def test_rosbags_directory_matches_its_mcap(binary):
    """bags/rosbags_written/ (metadata.yaml: RIHS01 type hash and QoS) reads like bags/rosbags_written.mcap."""
    d = mu.read_rosbags(BAGS / "rosbags_written")
    m = mu.read_rosbags(BAGS / "rosbags_written.mcap")
    assert not mu.compare_readers(d, m)
    assert (BAGS / "rosbags_written" / "rosbags_written.mcap").read_bytes() == (BAGS / "rosbags_written.mcap").read_bytes()


def test_golden_paper_bag_holds_the_paper_cases(binary):
    recs = mu.read_mcap(BAGS / "paper_cases.mcap")
    got = [r.msg for r in by_topic(recs, mu.CANDIDATES_TOPIC)]
    want = mu.load_paper_cases()
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert mu.same(g, w), f"{w['id']}: " + "; ".join(mu.differences(g, w))


@pytest.mark.parametrize("name", ["paper_cases.mcap", "random_grasps.mcap"])
def test_golden_recommendations_equal_solve(binary, name):
    recs = mu.read_mcap(BAGS / name)
    pairs, left = pair_in_order(by_topic(recs, mu.CANDIDATES_TOPIC), by_topic(recs, mu.RECOMMENDATIONS_TOPIC))
    missing = [c.msg["id"][:40] for c, r in pairs if r is None]
    assert not missing and not left, f"unpaired candidates {missing[:5]}, unpaired recommendations {len(left)}"
    answered_now = check_answers_equal_solve(pairs, name, recorded_fields_only=True)
    if name == "random_grasps.mcap":
        assert answered_now >= 1, "the recorded refusals of a centre of mass behind a tangent"
        statuses = [r.msg["status"] for _, r in pairs]
        assert statuses.count(1) >= 1 and statuses.count(2) >= 20, f"refused ones missing: {statuses}"
        ids = [c.msg["id"] for c, _ in pairs]
        assert len(set(ids)) < len(ids), "the bag should reuse some ids (matching by id + stamp, in order)"


def test_golden_bag_recorded_by_the_node(binary):
    """bags/node_recorded.mcap, written by `grasp_orient node` itself (bags/record_node_bag.py): both readers
    agree, it follows rosbag2's conventions with the node's namespaced topics and markers, it holds exactly the
    candidates the script sends with an answer each, and the node's two settings records."""
    import importlib.util

    path = BAGS / "node_recorded.mcap"
    assert path.stat().st_size < MAX_BAG_BYTES
    ns = "/golden"
    check_conventions(path, {f"{ns}/grasp_candidates": mu.CANDIDATE_TYPE,
                             f"{ns}/grip_recommendations": mu.RECOMMENDATION_TYPE,
                             f"{ns}/grip_markers": mu.MARKER_ARRAY_TYPE},
                      {mu.CANDIDATE_TYPE: CANDIDATE_DEPS, mu.RECOMMENDATION_TYPE: RECOMMENDATION_DEPS},
                      older=True)  # recorded before the grip force fields
    recs = both_readers(path)
    spec = importlib.util.spec_from_file_location("record_node_bag", BAGS / "record_node_bag.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    before, after = script.candidates()
    sent = before + after
    got = [r.msg for r in by_topic(recs, f"{ns}/grasp_candidates")]
    assert len(got) == len(sent) == 38
    for g, w in zip(got, sent):
        assert mu.same(g, w), f"{w['id'][:40]}: " + "; ".join(mu.differences(g, w)[:4])
    answers = by_topic(recs, f"{ns}/grip_recommendations")
    pairs, left = pair_in_order(by_topic(recs, f"{ns}/grasp_candidates"), answers)
    assert not left and all(r is not None for _, r in pairs)
    statuses = [r.msg["status"] for _, r in pairs]
    assert (statuses.count(0), statuses.count(1), statuses.count(2)) == (8, 3, 27), statuses
    assert len(by_topic(recs, f"{ns}/grip_markers")) == 8, "one marker array per solved candidate"
    from mcap.reader import make_reader
    with open(path, "rb") as f:
        meta = [m for m in make_reader(f).iter_metadata() if m.name == "grasp_orient.settings"]
    assert [m.metadata["reason"] for m in meta] == ["start", "parameter objective set"], meta
    assert all(m.metadata["node"] == f"{ns}/grasp_orient" for m in meta)


def test_make_bags_regenerates_the_same_bags(binary, tmp_path):
    """bags/make_bags.py still runs and reproduces the committed bags' contents, on the fields they have (they
    were recorded before messages grew; the regenerated ones carry today's fields too)."""
    r = subprocess.run([sys.executable, str(BAGS / "make_bags.py"), "--out", str(tmp_path), "--bin", str(binary)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, f"make_bags.py exited {r.returncode}:\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
    for name in GOLDEN:
        new = mu.read_mcap(tmp_path / name)
        old = mu.read_mcap(BAGS / name)
        assert len(new) == len(old), f"{name}: {len(new)} messages regenerated, {len(old)} committed"
        problems = []
        for a, b in zip(new, old):
            if (a.topic, a.log_time, a.publish_time) != (b.topic, b.log_time, b.publish_time):
                problems.append(f"{a.topic}@{a.log_time} vs {b.topic}@{b.log_time}")
            elif a.topic == mu.CANDIDATES_TOPIC:
                problems += mu.differences(a.msg, mu.as_message(b.msg))
            elif answered_behind_tangent(mu.jsonish(b.msg), mu.jsonish(a.msg)):
                continue  # a recorded refusal answered now (docs/recordings.md)
            else:
                added = set(a.msg) - set(b.msg)
                problems += compare({k: v for k, v in mu.jsonish(a.msg).items() if k not in added},
                                    mu.jsonish(b.msg))
        assert not problems, f"{name} regenerated differently (rerun bags/make_bags.py?):\n  " + "\n  ".join(problems[:10])


# ---------------------------------------------------------------------------------------------------
# replay
# ---------------------------------------------------------------------------------------------------
SUMMARY = re.compile(r"replayed (\d+) candidates.*?(\d+) compared with a recorded recommendation, (\d+) differ"
                     r".*?(\d+) recorded recommendations unmatched", re.S)


def replay_summary(out: str) -> dict:
    m = SUMMARY.search(out)
    assert m, f"no summary line ('replayed N candidates ...: M compared ..., D differ ..., U ... unmatched') in:\n{out}"
    return dict(zip(("candidates", "compared", "differ", "unmatched"), map(int, m.groups())))


def test_replay_golden_bags(binary):
    require_subcommand(binary, "replay")
    r = run(binary, "replay", BAGS / "paper_cases.mcap", BAGS / "random_grasps.mcap")
    out = r.stdout + r.stderr
    assert r.returncode == 0, f"replay exited {r.returncode}:\n{out[-3000:]}"
    s = replay_summary(out)
    n = GOLDEN["paper_cases.mcap"][0] + GOLDEN["random_grasps.mcap"][0]
    if s != {"candidates": n, "compared": n, "differ": 0, "unmatched": 0}:
        # which answers pair by the contract's key (candidate_id as the node echoes it, i.e. cut to 1024 bytes,
        # and header stamp; frame_id is echoed cut as well)
        odd = []
        for name in ("paper_cases.mcap", "random_grasps.mcap"):
            recs = mu.read_mcap(BAGS / name)
            for c in by_topic(recs, mu.CANDIDATES_TOPIC):
                if len(c.msg["id"].encode()) > 1024 or len(c.msg["header"]["frame_id"].encode()) > 1024:
                    odd.append(f"{c.msg['id'][:24]}... (id {len(c.msg['id'])} B, frame_id "
                               f"{len(c.msg['header']['frame_id'])} B)")
        raise AssertionError(f"replay summary {s}, expected every one of {n} candidates compared and nothing "
                             f"unmatched. Candidates whose answer echoes a cut id / frame_id: {odd}\n{out[-3000:]}")
    for name in ("paper_cases.mcap", "random_grasps.mcap"):
        c, k = GOLDEN[name]
        assert re.search(rf"{re.escape(name)}: {c} candidates, {k} recorded recommendations", out), out[-3000:]


def test_replay_bag_written_by_rosbags(binary):
    """A bag of candidates alone: solved, but with nothing to compare, not a pass (exit 1) unless asked for."""
    require_subcommand(binary, "replay")
    r = run(binary, "replay", BAGS / "rosbags_written.mcap")
    out = r.stdout + r.stderr
    assert r.returncode == 1, f"replay exited {r.returncode}:\n{out[-3000:]}"
    assert "24 of 24 candidates have no recorded recommendation" in out, out[-3000:]
    r = run(binary, "replay", "--no-compare", BAGS / "rosbags_written.mcap")
    out = r.stdout + r.stderr
    assert r.returncode == 0, f"replay --no-compare exited {r.returncode}:\n{out[-3000:]}"
    assert replay_summary(out) == {"candidates": 24, "compared": 0, "differ": 0, "unmatched": 0}, out[-3000:]


def rewrite(src: Path, dst: Path, change) -> int:
    """Copy `src` with mcap_ros2's writer (same schemas, channels, metadata, times); `change(topic, msg)` may edit
    each decoded message in place and returns True when it did. Returns how many it changed."""
    from mcap.reader import make_reader
    from mcap_ros2.writer import Writer

    with open(src, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
    decoded = mu.read_mcap(src)
    changed = 0
    with open(dst, "wb") as out:
        w = Writer(out)
        schemas, chans = {}, {}
        for ch in summary.channels.values():
            s = summary.schemas[ch.schema_id]
            if s.name not in schemas:
                schemas[s.name] = w.register_msgdef(s.name, s.data.decode())
            w._channel_ids[ch.topic] = w._writer.register_channel(
                topic=ch.topic, message_encoding=ch.message_encoding, schema_id=schemas[s.name].id,
                metadata=dict(ch.metadata))
            chans[ch.topic] = schemas[s.name]
        for r in decoded:
            msg = json.loads(json.dumps(r.msg))  # a copy (NaN survives)
            if change(r.topic, msg):
                changed += 1
            w.write_message(r.topic, chans[r.topic], msg, log_time=r.log_time, publish_time=r.publish_time)
        w.finish()
    return changed


@pytest.mark.parametrize("field,edit", [
    ("gripping_power", lambda v: v * (1 + 1e-6)),
    ("recommended_label", lambda v: "E" if v != "E" else "A"),
])
def test_replay_fails_on_a_tampered_recommendation(binary, tmp_path, field, edit):
    require_subcommand(binary, "replay")
    dst = tmp_path / "tampered.mcap"

    def change(topic, msg):
        if topic == mu.RECOMMENDATIONS_TOPIC and msg["candidate_id"] == "paper-b":
            msg[field] = edit(msg[field])
            return True
        return False

    assert rewrite(BAGS / "paper_cases.mcap", dst, change) == 1
    both_readers(dst)
    r = run(binary, "replay", dst)
    out = r.stdout + r.stderr
    assert r.returncode != 0, f"replay of a bag with {field} of paper-b changed exited 0:\n{out[-3000:]}"
    assert field in out and "paper-b" in out, f"replay output does not name {field} of paper-b:\n{out[-3000:]}"
    s = replay_summary(out)
    assert (s["compared"], s["differ"]) == (4, 1), s
    # the untouched copy replays cleanly (the rewrite itself changes nothing else)
    clean = tmp_path / "clean.mcap"
    rewrite(BAGS / "paper_cases.mcap", clean, lambda t, m: False)
    r = run(binary, "replay", clean)
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]


def test_replay_write_produces_a_readable_recording(binary, tmp_path):
    require_subcommand(binary, "replay")
    out_bag = tmp_path / "replayed.mcap"
    r = run(binary, "replay", BAGS / "random_grasps.mcap", "--write", out_bag)
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    check_conventions(out_bag, {mu.CANDIDATES_TOPIC: mu.CANDIDATE_TYPE, mu.RECOMMENDATIONS_TOPIC: mu.RECOMMENDATION_TYPE},
                      {mu.CANDIDATE_TYPE: CANDIDATE_DEPS, mu.RECOMMENDATION_TYPE: RECOMMENDATION_DEPS})
    new = both_readers(out_bag)
    old = mu.read_mcap(BAGS / "random_grasps.mcap")
    nc, oc = by_topic(new, mu.CANDIDATES_TOPIC), by_topic(old, mu.CANDIDATES_TOPIC)
    assert len(nc) == len(oc) == GOLDEN["random_grasps.mcap"][0]
    assert (sorted(mu.canonical(mu.jsonish(x.msg)) for x in nc)
            == sorted(mu.canonical(mu.jsonish(mu.as_message(x.msg))) for x in oc))
    pairs, left = pair_in_order(nc, by_topic(new, mu.RECOMMENDATIONS_TOPIC))
    assert not left and all(r is not None for _, r in pairs)
    check_answers_equal_solve(pairs, "replay --write")
    r = run(binary, "replay", out_bag)
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]


# ---------------------------------------------------------------------------------------------------
# Live recordings
# ---------------------------------------------------------------------------------------------------
class DomainPeer:
    """An rclpy node in its own context on `domain` (away from the session's default node), publishing
    candidates and collecting recommendations (and markers) by candidate id."""

    def __init__(self, domain: int, markers: bool = False):
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from grasp_orient.msg import GraspCandidate, GripRecommendation
        from visualization_msgs.msg import MarkerArray

        self.Candidate = GraspCandidate
        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("grasp_orient_mcap_test", context=self.ctx)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                         durability=DurabilityPolicy.VOLATILE)
        self.pub = self.node.create_publisher(GraspCandidate, "grasp_candidates", qos)
        self.answers: dict[str, list] = {}
        self.markers: list = []
        self.sub = self.node.create_subscription(
            GripRecommendation, "grip_recommendations",
            lambda m: self.answers.setdefault(m.candidate_id, []).append((time.time_ns(), m)), qos)
        self.msub = (self.node.create_subscription(MarkerArray, "grip_markers", self.markers.append, qos)
                     if markers else None)

    def spin_until(self, cond, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not cond():
            if time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=0.02)
        return True

    def wait_matched(self, timeout: float = 20.0):
        ok = self.spin_until(lambda: self.pub.get_subscription_count() > 0 and self.sub.get_publisher_count() > 0
                             and (self.msub is None or self.msub.get_publisher_count() > 0), timeout)
        assert ok, f"no match with the recording node within {timeout} s"

    def ensure_roundtrip(self, timeout: float = 20.0) -> list[dict]:
        """Match, then send probes (`probe_candidate`: paper case a in a frame of its own, ids probe-N,
        stamped now) until one is answered: both directions are live. With markers, until a probe's marker
        array has arrived as well: the node matches our marker reader a little after we match its writer,
        and a probe answered in between has its markers recorded but not received (leave the probes' frame
        out of the comparison). Returns the probes sent (the recording holds them too)."""
        self.wait_matched(timeout)
        probes = []
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            t = time.time_ns()
            p = probe_candidate(f"probe-{len(probes)}")
            p["header"]["stamp"] = {"sec": t // 10**9, "nanosec": t % 10**9}
            p["_sent"] = self.publish(p)
            probes.append(p)
            if self.spin_until(lambda: p["id"] in self.answers and (
                    self.msub is None or any(is_probe_markers(m) for m in self.markers)), 1.0):
                return probes
        raise AssertionError(f"no answer to {len(probes)} probes within {timeout} s"
                             + ("" if self.msub is None else f" with markers ({len(self.markers)} arrays received)"))

    def publish(self, cand: dict) -> tuple[int, int]:
        m = self.Candidate()
        _fill(m, cand)
        before = time.time_ns()
        self.pub.publish(m)
        return before, time.time_ns()

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.ctx.try_shutdown()


def _fill(msg, data: dict):
    for k, v in data.items():
        if k.startswith("_"):
            continue
        if isinstance(v, dict):
            _fill(getattr(msg, k), v)
        else:
            setattr(msg, k, v)


def live_candidates(n: int, seed: int, prefix: str) -> list[dict]:
    rng = random.Random(seed)
    frames = ["object", "world", "tool0", "camera_optical", "base_link"]
    out = []
    for k in range(n):
        t = time.time_ns()
        out.append(mu.quantize(mu.random_grasp(rng, f"{prefix}-{k}", frames[k % len(frames)],
                                               stamp=(t // 10**9, t % 10**9))))
    return out


def recording_in(d: Path, started_ns: int) -> Path:
    files = sorted(d.iterdir()) if d.is_dir() else []
    assert len(files) == 1, f"expected one recording in {d}, found {[f.name for f in files]}"
    m = FILE_NAME.match(files[0].name)
    assert m, f"recording named {files[0].name!r}, expected grasp_orient_YYYYMMDDTHHMMSSZ.mcap"
    t = dt.datetime.strptime(m.group(1), "%Y%m%dT%H%M%SZ").replace(tzinfo=dt.timezone.utc).timestamp()
    assert started_ns / 1e9 - 2 <= t <= started_ns / 1e9 + 30, \
        f"{files[0].name}: start time {t} is not the node's start ({started_ns / 1e9:.0f}, UTC)"
    return files[0]


@pytest.fixture()
def rec_domain() -> int:
    return DOMAIN_ID + 100  # 101..200, away from the session's nodes on DOMAIN_ID


def test_live_recording_holds_what_was_sent_and_answered(binary, tmp_path, rec_domain):
    record_dir = tmp_path / "runs"
    started = time.time_ns()
    node = NodeProcess(["--ros-args", "-p", "record:=true", "-p", f"record_dir:={record_dir}",
                        "-p", "record_markers:=true"], ros_env(rec_domain), tmp_path, "recording node")
    peer = None
    try:
        node.wait_ready()
        peer = DomainPeer(rec_domain, markers=True)
        t_first = time.time_ns()
        probes = peer.ensure_roundtrip()
        paper = mu.load_paper_cases()
        for c in paper:
            c["id"] = "live-" + c["id"]
        cands = live_candidates(200, SEED, "live")
        cands = paper + cands
        sent: dict[str, tuple[int, int]] = {}
        idx = 0
        deadline = time.monotonic() + 90

        def answered() -> int:
            return sum(1 for c in cands[:idx] if c["id"] in peer.answers)

        while (idx < len(cands) or answered() < len(cands)) and time.monotonic() < deadline:
            n = answered()
            while idx < len(cands) and idx - n < 50:  # at most 50 unanswered: below the node's depth of 100
                sent[cands[idx]["id"]] = peer.publish(cands[idx])
                idx += 1
            peer.executor.spin_once(timeout_sec=0.02)
        missing = [c["id"] for c in cands if c["id"] not in peer.answers]
        assert not missing, f"{len(missing)} candidates not answered: {missing[:5]}"
        for p in probes:
            sent[p["id"]] = p.pop("_sent")
        solved = sum(1 for c in cands if peer.answers[c["id"]][0][1].status == 0)
        cands = probes + cands
        peer.spin_until(lambda: sum(1 for m in peer.markers if not is_probe_markers(m)) >= solved, 5.0)
        peer.spin_until(lambda: False, 0.3)
        t_last = time.time_ns()
        node.stop_and_check(signal.SIGINT)
    finally:
        if peer is not None:
            peer.close()
        node.kill()

    path = recording_in(record_dir, started)
    check_conventions(path, {mu.CANDIDATES_TOPIC: mu.CANDIDATE_TYPE, mu.RECOMMENDATIONS_TOPIC: mu.RECOMMENDATION_TYPE,
                             mu.MARKERS_TOPIC: mu.MARKER_ARRAY_TYPE},
                      {mu.CANDIDATE_TYPE: CANDIDATE_DEPS, mu.RECOMMENDATION_TYPE: RECOMMENDATION_DEPS})
    recs = both_readers(path)
    rc = by_topic(recs, mu.CANDIDATES_TOPIC)
    rr = by_topic(recs, mu.RECOMMENDATIONS_TOPIC)
    problems = []

    # every candidate recorded once, exactly as sent, at a plausible time
    want = {c["id"]: c for c in cands}
    seen: dict[str, int] = {}
    for r in rc:
        cid = r.msg["id"]
        seen[cid] = seen.get(cid, 0) + 1
        if cid not in want:
            problems.append(f"recorded a candidate never sent: {cid!r}")
            continue
        d = mu.differences(r.msg, mu.as_message(want[cid]))
        if d:
            problems.append(f"candidate {cid}: " + "; ".join(d[:4]))
        before, after = sent[cid]
        if not (before <= r.log_time <= t_last):
            problems.append(f"candidate {cid}: log_time {r.log_time} outside [send {before}, end {t_last}]")
        if r.publish_time is None or not (before - 5_000_000 <= r.publish_time <= r.log_time):
            problems.append(f"candidate {cid}: publish_time {r.publish_time} not in [send {before} - 5 ms, "
                            f"log_time {r.log_time}]")
    problems += [f"candidate {i} recorded {n} times" for i, n in seen.items() if n != 1]
    problems += [f"candidate {i} not recorded" for i in want if i not in seen]

    # every answer recorded once, equal to solve and to what the peer received
    cand_log = {r.msg["id"]: r.log_time for r in rc}
    rec_by_id: dict[str, list] = {}
    for r in rr:
        rec_by_id.setdefault(r.msg["candidate_id"], []).append(r)
    problems += [f"answer to {i}: recorded {len(rec_by_id.get(i, []))} times" for i in want
                 if len(rec_by_id.get(i, [])) != 1]
    ok_pairs = []
    for cid, c in want.items():
        if len(rec_by_id.get(cid, [])) != 1:
            continue
        r = rec_by_id[cid][0]
        got = mu.plain(peer.answers[cid][0][1])
        d = mu.differences(r.msg, got)
        if d:
            problems.append(f"answer to {cid}: recorded differs from published: " + "; ".join(d[:4]))
        if cid in cand_log and r.log_time < cand_log[cid]:
            problems.append(f"answer to {cid}: log_time {r.log_time} before its candidate's {cand_log[cid]}")
        if r.publish_time is None or not (t_first <= r.publish_time <= t_last):
            problems.append(f"answer to {cid}: publish_time {r.publish_time} outside the run")
        ok_pairs.append((mu.Rec(mu.CANDIDATES_TOPIC, 0, 0, mu.CANDIDATE_TYPE, c), r))
    assert not problems, f"{path}: {len(problems)} problems:\n  " + "\n  ".join(problems[:30])
    check_answers_equal_solve(ok_pairs, f"live recording {path.name}")

    # markers: recorded as published, the probes' left out on both sides (one answered before the node
    # matched our marker reader is recorded, not received); one array recorded for each probe
    rm = by_topic(recs, mu.MARKERS_TOPIC)
    assert rm, "record_markers:=true recorded no /grip_markers"
    got = sorted(mu.canonical(mu.jsonish(x)) for x in map(mu.plain, peer.markers) if not is_probe_markers(x))
    rec = sorted(mu.canonical(mu.jsonish(r.msg)) for r in rm if not is_probe_markers(r.msg))
    assert len(rm) - len(rec) == len(probes), f"{len(rm) - len(rec)} marker arrays recorded for {len(probes)} probes"
    assert len(rec) == len(got), f"{len(rec)} marker arrays recorded, {len(got)} received by the peer"
    assert rec == got, "recorded marker arrays differ from the published ones"


def test_sigkilled_recording_is_recovered(binary, tmp_path, rec_domain):
    require_subcommand(binary, "recover")
    domain = rec_domain + 30  # 131..230
    record_dir = tmp_path / "runs"
    started = time.time_ns()
    node = NodeProcess(["--ros-args", "-p", "record:=true", "-p", f"record_dir:={record_dir}"],
                       ros_env(domain), tmp_path, "recording node (to be killed)")
    peer = None
    sent: dict[str, tuple[int, dict]] = {}
    try:
        node.wait_ready()
        peer = DomainPeer(domain)
        for p in peer.ensure_roundtrip():
            sent[p["id"]] = (p.pop("_sent")[0], p)
        rng = random.Random(SEED + 1)
        # ~150 candidates a second for 3 s, at most 50 unanswered (below the node's keep-last depth of 100,
        # so DDS drops none), then SIGKILL at once
        t_end = time.monotonic() + 3.0
        next_send = time.monotonic()
        k = 0
        while time.monotonic() < t_end:
            if time.monotonic() >= next_send and len(sent) - len(peer.answers) < 50:
                t = time.time_ns()
                c = mu.quantize(mu.random_grasp(rng, f"kill-{k}", "world", stamp=(t // 10**9, t % 10**9)))
                before, _ = peer.publish(c)
                sent[c["id"]] = (before, c)
                k += 1
                next_send += 1 / 150
            peer.executor.spin_once(timeout_sec=0.002)
        t_kill = time.time_ns()
        node.proc.send_signal(signal.SIGKILL)
        node.proc.wait(10)
    finally:
        if peer is not None:
            peer.close()
        node.kill()
    assert len(sent) > 100, f"only {len(sent)} candidates sent in 3 s"

    broken = recording_in(record_dir, started)
    assert broken.stat().st_size > 0, "the killed node left an empty file: nothing was flushed"
    assert not broken.read_bytes().endswith(mu.MCAP_MAGIC), "the killed recording ends like a finished one?"
    fixed = tmp_path / "fixed.mcap"
    r = run(binary, "recover", broken, "-o", fixed)
    out = r.stdout + r.stderr
    # The writer flushes whole chunks, so a kill mostly leaves a file that ends where a record ends
    # (exit 0); a kill during a flush cuts a chunk, whose messages are lost (exit 1, and said so).
    assert r.returncode in (0, 1), f"recover exited {r.returncode}:\n{out[-3000:]}"
    if r.returncode == 1:
        assert "cut short inside this record" in out, out[-3000:]
    else:
        assert "where a record ends" in out, out[-3000:]
    assert fixed.is_file(), f"recover wrote no {fixed}:\n{out[-3000:]}"

    check_conventions(fixed, {mu.CANDIDATES_TOPIC: mu.CANDIDATE_TYPE, mu.RECOMMENDATIONS_TOPIC: mu.RECOMMENDATION_TYPE},
                      {mu.CANDIDATE_TYPE: CANDIDATE_DEPS, mu.RECOMMENDATION_TYPE: RECOMMENDATION_DEPS})
    recs = both_readers(fixed)
    rc = by_topic(recs, mu.CANDIDATES_TOPIC)
    problems = []
    got: dict[str, int] = {}
    for x in rc:
        cid = x.msg["id"]
        got[cid] = got.get(cid, 0) + 1
        if cid not in sent:
            problems.append(f"recovered a candidate never sent: {cid!r}")
            continue
        d = mu.differences(x.msg, mu.as_message(sent[cid][1]))
        if d:
            problems.append(f"candidate {cid}: " + "; ".join(d[:4]))
    problems += [f"candidate {i} recovered {n} times" for i, n in got.items() if n != 1]
    # the node received (and answered) everything sent up to the last moments; what it answered more
    # than 1.5 s before the kill must have reached the file (flushed at least once a second)
    early = t_kill - 1_500_000_000
    unanswered = [i for i, (t, _) in sent.items() if t < early and i not in peer.answers]
    if unanswered:
        problems.append(f"{len(unanswered)} candidates sent more than 1.5 s before the kill were never answered "
                        f"(first {unanswered[:5]})")
    lost = [i for i, (t, _) in sent.items() if i in peer.answers and peer.answers[i][0][0] < early and i not in got]
    if lost:
        problems.append(f"{len(lost)} candidates answered more than 1.5 s before the kill are missing from the "
                        f"recovered file (first {lost[:5]}); {len(got)} of {len(sent)} recovered")
    assert not problems, f"{fixed}:\n  " + "\n  ".join(problems[:30])

    pairs, left = pair_in_order(rc, by_topic(recs, mu.RECOMMENDATIONS_TOPIC))
    assert not left, f"{len(left)} recovered recommendations answer no recovered candidate"
    check_answers_equal_solve([(c, r) for c, r in pairs if r is not None], f"recovered {fixed.name}")
    # the recovered file replays cleanly
    if re.search(r"^\s+replay\s", run(binary, "--help").stdout, re.M):
        r = run(binary, "replay", fixed)
        assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
