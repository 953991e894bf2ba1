#!/usr/bin/env python3
"""Regenerates the golden MCAP bags of grasp_orient (see bags/README.md).

    source "$(bash tests/peer/setup.sh | tail -n 1)" && python bags/make_bags.py [--out DIR] [--bin PATH]

- paper_cases.mcap     the paper's 4 cases (examples/paper_cases.jsonl) and their recommendations
- random_grasps.mcap   300 random force-closure grasps in random frames, 3 reused ids with new stamps, 2
                       resent candidates, 30 refused candidates, and their recommendations
- rosbags_written.mcap the 4 paper cases and 20 random grasps only, written by the `rosbags` library
  (rosbags_written/ is the rosbag2 directory it wrote: metadata.yaml + the same .mcap)

The first two are written with mcap + mcap_ros2.writer.Writer the way rosbag2 (Jazzy) writes MCAP: profile
"ros2", one ros2msg schema per type with the complete definition (the .msg files of msg/ and of the installed
Jazzy packages, rosbag2's concatenation), cdr messages, channel metadata offered_qos_profiles. The
recommendations are what `grasp_orient solve` prints for the same candidates, turned into messages (null ->
NaN, or infinity for the *_current powers of a solved / no-force-closure grasp); the candidates with NaN or
infinite fields, which JSON cannot carry to `solve`, are answered by `grasp_orient node` itself (over rclpy
on a private ROS domain). Everything is seeded: a rerun gives the same bytes unless the solver changed.
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent
sys.path.insert(0, str(REPO_ROOT / "tests" / "ros"))

import mcap_util as mu  # noqa: E402

SEED = 20250101
N_RANDOM = 300
N_ROSBAGS_RANDOM = 20
FRAMES = ["object", "world", "tool0", "camera_optical", "base_link"]
T0 = 1_735_689_600_000_000_000  # 2025-01-01T00:00:00Z, the first send time of every bag, ns
PERIOD = 10_000_000  # one candidate every 10 ms
RECEIVE_DELAY = 150_000  # publish -> receive of a candidate, ns
ANSWER_DELAY = 40_000  # receive of a candidate -> publish of its answer, ns
QOS_DEPTH = 100


def die(msg: str):
    print(f"make_bags: ERROR: {msg}", file=sys.stderr)
    sys.exit(1)


# ---------------------------------------------------------------------------------------------------
# Candidates
# ---------------------------------------------------------------------------------------------------
def stamp_of(t_ns: int) -> dict:
    return {"sec": t_ns // 1_000_000_000, "nanosec": t_ns % 1_000_000_000}


def random_candidates(rng: random.Random, n: int, prefix: str, t0: int) -> list[dict]:
    out = []
    for k in range(n):
        c = mu.random_grasp(rng, f"{prefix}-{k}", FRAMES[k % len(FRAMES)], stamp=(0, 0))
        c["header"]["stamp"] = stamp_of(t0 + k * PERIOD)
        out.append(mu.quantize(c))
    return out


def refused_candidates(rng: random.Random, t0: int) -> list[tuple[str, int, dict]]:
    """(what, expected status, candidate): 30 candidates the solver refused when the bags were made (one is
    answered now: a centre of mass behind a tangent), built from random grasps."""
    cases: list[tuple[str, int, dict]] = []

    def add(what: str, status: int, change):
        c = mu.quantize(mu.random_grasp(rng, f"refused-{len(cases)}", FRAMES[len(cases) % len(FRAMES)],
                                         stamp=(0, 0)))
        c["header"]["stamp"] = stamp_of(t0 + len(cases) * PERIOD)
        change(c)
        cases.append((what, status, c))

    def flip(v):
        return {"x": -v["x"], "y": -v["y"], "z": -v["z"]}

    def narrow_cones(c):
        c["friction_1"] = c["friction_2"] = 1e-3
        # turn normal_1 well away from the contact line (cone half-angle 1e-3 rad): no force closure
        d = (c["contact_2"]["x"] - c["contact_1"]["x"], c["contact_2"]["y"] - c["contact_1"]["y"])
        ln = math.hypot(*d)
        r = mu._rot((d[0] / ln, d[1] / ln), 0.3)
        c["normal_1"] = {"x": r[0], "y": r[1], "z": 0.0}

    # not finite: `solve` cannot read these (JSON has no NaN); the node answers them
    add("NaN mass", 2, lambda c: c.update(mass=math.nan))
    add("NaN mass", 2, lambda c: c.update(mass=math.nan))
    add("infinite contact_1.x", 2, lambda c: c["contact_1"].update(x=math.inf))
    add("-infinite gravity.y", 2, lambda c: c["gravity"].update(y=-math.inf))
    add("NaN friction_2", 2, lambda c: c.update(friction_2=math.nan))
    add("NaN center_of_mass.z", 2, lambda c: c["center_of_mass"].update(z=math.nan))
    # out of range or degenerate
    add("negative mass", 2, lambda c: c.update(mass=-1.0))
    add("zero mass", 2, lambda c: c.update(mass=0.0))
    add("mass over 1e9 kg", 2, lambda c: c.update(mass=2e9))
    add("negative friction_1", 2, lambda c: c.update(friction_1=-0.5))
    add("negative friction_2", 2, lambda c: c.update(friction_2=-1.0))
    add("zero friction_1", 2, lambda c: c.update(friction_1=0.0))
    add("friction over 1e3", 2, lambda c: c.update(friction_2=5e3))
    add("coincident contacts", 2, lambda c: c.update(contact_2=dict(c["contact_1"])))
    add("coincident contacts (z differs)", 2, lambda c: c.update(contact_2={**c["contact_1"], "z": 0.5}))
    add("normal_1 pointing out", 2, lambda c: c.update(normal_1=flip(c["normal_1"])))
    add("normal_2 pointing out", 2, lambda c: c.update(normal_2=flip(c["normal_2"])))
    add("both normals pointing out", 2, lambda c: c.update(normal_1=flip(c["normal_1"]), normal_2=flip(c["normal_2"])))
    add("zero normal_2", 2, lambda c: c.update(normal_2={"x": 0.0, "y": 0.0, "z": 0.0}))
    add("normal_1 along z", 2, lambda c: c.update(normal_1={"x": 0.0, "y": 0.0, "z": 1.0}))
    add("zero gravity", 2, lambda c: c.update(gravity={"x": 0.0, "y": 0.0, "z": 0.0}))
    add("gravity along z", 2, lambda c: c.update(gravity={"x": 0.0, "y": 0.0, "z": -9.81}))
    add("gravity over 1e4", 2, lambda c: c.update(gravity={"x": 0.0, "y": -2e4, "z": 0.0}))
    add("coordinate over 1e6 m", 2, lambda c: c["contact_1"].update(y=3e6))
    # Behind the tangent at contact_1: refused (status 2) when the committed bags were made; answered
    # since objects need not be convex (docs/recordings.md, "Refusals answered now").
    add("center_of_mass behind the tangent at contact_1", 0, lambda c: c.update(center_of_mass={
        "x": c["contact_1"]["x"] - 1e3 * c["normal_1"]["x"], "y": c["contact_1"]["y"] - 1e3 * c["normal_1"]["y"],
        "z": 0.0}))
    add("id over 1024 bytes", 2, lambda c: c.update(id=c["id"] + "-" + "i" * 1500))
    add("frame_id over 1024 bytes", 2, lambda c: c["header"].update(frame_id="f" * 1100))
    # no force closure
    add("no force closure", 1, narrow_cones)
    add("no force closure", 1, narrow_cones)
    add("no force closure (tiny friction)", 1, lambda c: c.update(friction_1=1e-6, friction_2=1e-6))
    return cases


def all_finite(v) -> bool:
    if isinstance(v, dict):
        return all(all_finite(x) for x in v.values())
    if isinstance(v, float):
        return math.isfinite(v)
    return True


# ---------------------------------------------------------------------------------------------------
# Answers
# ---------------------------------------------------------------------------------------------------
def solve(binary: Path, cands: list[dict]) -> list[dict]:
    inp = "".join(json.dumps(c, allow_nan=False) + "\n" for c in cands)
    r = subprocess.run([str(binary), "solve"], input=inp, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        die(f"{binary} solve exited {r.returncode}: {r.stderr[-2000:]}")
    out = [json.loads(l) for l in r.stdout.splitlines() if l.strip()]
    if len(out) != len(cands):
        die(f"solve printed {len(out)} answers for {len(cands)} candidates: {r.stderr[-2000:]}")
    for c, a in zip(cands, out):
        if a["candidate_id"] != c["id"][:1024]:
            die(f"solve answered {a['candidate_id'][:40]!r} for {c['id'][:40]!r}")
    return [mu.recommendation_from_solve(a) for a in out]


def node_answers(binary: Path, cands: list[dict]) -> list[dict]:
    """Answers of `grasp_orient node` (defaults) to candidates `solve` cannot read, over rclpy."""
    if not cands:
        return []
    domain = 200 + os.getpid() % 30
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("ROS_LOCALHOST_ONLY", None)
    os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    try:
        import rclpy
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from grasp_orient.msg import GraspCandidate, GripRecommendation
    except ImportError as e:
        die(f"cannot import rclpy / grasp_orient.msg ({e}); run with the peer: source \"$(bash tests/peer/setup.sh | tail -n 1)\"")

    lines: list[str] = []
    ready = threading.Event()
    with tempfile.TemporaryDirectory() as cwd:
        proc = subprocess.Popen([str(binary), "node"], env=dict(os.environ), cwd=cwd, stdin=subprocess.DEVNULL,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace")

        def pump():
            for line in proc.stdout:
                lines.append(line.rstrip("\n"))
                if "waiting for" in line:
                    ready.set()

        threading.Thread(target=pump, daemon=True).start()
        try:
            if not ready.wait(30):
                die("grasp_orient node did not come up within 30 s:\n" + "\n".join(lines[-30:]))
            rclpy.init()
            node = rclpy.create_node("grasp_orient_make_bags")
            qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                             durability=DurabilityPolicy.VOLATILE)
            got: dict[str, object] = {}
            pub = node.create_publisher(GraspCandidate, "grasp_candidates", qos)
            sub = node.create_subscription(GripRecommendation, "grip_recommendations",
                                           lambda m: got.setdefault(m.candidate_id, m), qos)
            deadline = time.monotonic() + 20
            while not (pub.get_subscription_count() and sub.get_publisher_count()):
                rclpy.spin_once(node, timeout_sec=0.05)
                if time.monotonic() > deadline:
                    die("no match with grasp_orient node within 20 s")
            deadline = time.monotonic() + 30
            last_send = 0.0
            while any(c["id"][:1024] not in got for c in cands):
                if time.monotonic() - last_send > 2.0:  # (re)send the unanswered: the first may beat discovery
                    for c in cands:
                        if c["id"][:1024] not in got:
                            m = GraspCandidate()
                            fill(m, c)
                            pub.publish(m)
                    last_send = time.monotonic()
                rclpy.spin_once(node, timeout_sec=0.05)
                if time.monotonic() > deadline:
                    missing = [c["id"] for c in cands if c["id"][:1024] not in got]
                    die(f"grasp_orient node did not answer {missing}:\n" + "\n".join(lines[-30:]))
            answers = [mu.plain(got[c["id"][:1024]]) for c in cands]
            node.destroy_node()
            rclpy.shutdown()
        finally:
            proc.send_signal(2)
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
    return answers


def fill(msg, data: dict):
    for k, v in data.items():
        if isinstance(v, dict):
            fill(getattr(msg, k), v)
        else:
            setattr(msg, k, v)


def answer_all(binary: Path, cands: list[dict]) -> list[dict]:
    finite = [c for c in cands if all_finite(c)]
    other = [c for c in cands if not all_finite(c)]
    by_solve = iter(solve(binary, finite))
    by_node = iter(node_answers(binary, other))
    return [next(by_solve) if all_finite(c) else next(by_node) for c in cands]


# ---------------------------------------------------------------------------------------------------
# Writers
# ---------------------------------------------------------------------------------------------------
def write_mcap_ros2(path: Path, pairs: list[tuple[dict, dict]], t0: int):
    """Candidates and their answers with mcap_ros2.writer.Writer, as rosbag2 would record the node's topics:
    the k-th candidate sent at t0 + k*PERIOD, received RECEIVE_DELAY later, answered ANSWER_DELAY after that."""
    from mcap_ros2.writer import Writer

    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        w = Writer(f)
        # mcap_ros2's Writer registers channels without metadata; rosbag2 puts offered_qos_profiles there,
        # so register the channels on its MCAP writer first (mcap-ros2-support 0.6.0 internals).
        if not (hasattr(w, "_writer") and isinstance(getattr(w, "_channel_ids", None), dict)):
            die("mcap_ros2.writer.Writer has no _writer/_channel_ids (mcap-ros2-support != 0.6.0?)")
        schemas = {}
        for topic, typ in ((mu.CANDIDATES_TOPIC, mu.CANDIDATE_TYPE), (mu.RECOMMENDATIONS_TOPIC, mu.RECOMMENDATION_TYPE)):
            schemas[topic] = w.register_msgdef(typ, mu.rosbag2_full_text(typ))
            w._channel_ids[topic] = w._writer.register_channel(
                topic=topic, message_encoding="cdr", schema_id=schemas[topic].id,
                metadata={"offered_qos_profiles": mu.offered_qos_yaml(QOS_DEPTH)})
        seq = {mu.CANDIDATES_TOPIC: 0, mu.RECOMMENDATIONS_TOPIC: 0}
        for k, (cand, rec) in enumerate(pairs):
            sent = t0 + k * PERIOD
            received = sent + RECEIVE_DELAY
            answered = received + ANSWER_DELAY
            for topic, msg, log_time, publish_time in ((mu.CANDIDATES_TOPIC, cand, received, sent),
                                                       (mu.RECOMMENDATIONS_TOPIC, rec, answered, answered)):
                seq[topic] += 1
                w.write_message(topic, schemas[topic], msg, log_time=log_time, publish_time=publish_time,
                                sequence=seq[topic])
        w.finish()


def write_rosbags(directory: Path, cands: list[dict], t0: int) -> Path:
    """Candidates only, with rosbags' rosbag2 writer (MCAP storage, zstd chunks); returns the .mcap."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(mu.msg_file(mu.CANDIDATE_TYPE).read_text(), mu.CANDIDATE_TYPE))
    Cand = store.types[mu.CANDIDATE_TYPE]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    Point = store.types["geometry_msgs/msg/Point"]
    Vector3 = store.types["geometry_msgs/msg/Vector3"]

    def build(c: dict):
        h = c["header"]
        return Cand(
            header=Header(stamp=Time(sec=h["stamp"]["sec"], nanosec=h["stamp"]["nanosec"]), frame_id=h["frame_id"]),
            id=c["id"],
            contact_1=Point(**c["contact_1"]), contact_2=Point(**c["contact_2"]),
            normal_1=Vector3(**c["normal_1"]), normal_2=Vector3(**c["normal_2"]),
            friction_1=c["friction_1"], friction_2=c["friction_2"],
            center_of_mass=Point(**c["center_of_mass"]), mass=c["mass"], gravity=Vector3(**c["gravity"]),
            model=c.get("model", 0),
            center_of_mass_tolerance=Vector3(**c.get("center_of_mass_tolerance", {"x": 0.0, "y": 0.0, "z": 0.0})),
            mass_tolerance=c.get("mass_tolerance", 0.0))

    never = QosTime(sec=9223372036, nsec=854775807)
    qos = Qos(QosHistory.KEEP_LAST, QOS_DEPTH, QosReliability.RELIABLE, QosDurability.VOLATILE, never, never,
              QosLiveliness.AUTOMATIC, never, False)
    if directory.exists():
        shutil.rmtree(directory)
    writer = Writer(directory, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        conn = writer.add_connection(mu.CANDIDATES_TOPIC, mu.CANDIDATE_TYPE, typestore=store,
                                     offered_qos_profiles=[qos])
        for k, c in enumerate(cands):
            writer.write(conn, t0 + k * PERIOD + RECEIVE_DELAY, store.serialize_cdr(build(c), mu.CANDIDATE_TYPE))
    files = list(directory.glob("*.mcap"))
    if len(files) != 1:
        die(f"rosbags wrote {files} into {directory}")
    return files[0]


# ---------------------------------------------------------------------------------------------------
def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=HERE, help="where to write the bags (default: bags/)")
    ap.add_argument("--bin", type=Path, default=Path(os.environ.get("GRASP_ORIENT_BIN",
                                                                    REPO_ROOT / "target" / "debug" / "grasp_orient")))
    args = ap.parse_args()
    binary = args.bin.resolve()
    if not (binary.is_file() and os.access(binary, os.X_OK)):
        die(f"no grasp_orient binary at {binary} (cargo build, or --bin / GRASP_ORIENT_BIN)")
    out: Path = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    for typ in (mu.CANDIDATE_TYPE, mu.RECOMMENDATION_TYPE):
        mu.rosbag2_full_text(typ)  # every .msg file found

    # a. the paper's cases
    paper = mu.load_paper_cases()
    write_mcap_ros2(out / "paper_cases.mcap", list(zip(paper, answer_all(binary, paper))), T0)

    # b. random grasps, reused ids, resent candidates, refused candidates
    rng = random.Random(SEED)
    good = random_candidates(rng, N_RANDOM, "random", T0)
    reused = []
    for k in range(3):  # the same id again later with a new stamp and another grasp
        c = random_candidates(rng, 1, "x", T0 + (N_RANDOM + k) * PERIOD)[0]
        c["id"] = good[k]["id"]
        reused.append(c)
    resent = [copy.deepcopy(good[10]), copy.deepcopy(good[11])]  # identical id, stamp and contents
    refused = refused_candidates(rng, T0 + (N_RANDOM + 10) * PERIOD)
    cands = good + reused + resent + [c for _, _, c in refused]
    order = list(range(len(cands)))
    # interleave the refused ones with the rest, deterministically
    random.Random(SEED + 1).shuffle(order)
    cands = [cands[i] for i in order]
    answers = answer_all(binary, cands)
    status = {c["id"]: a["status"] for c, a in zip(cands, answers)}
    wrong = [f"{what}: status {status[c['id']]}, expected {st}" for what, st, c in refused if status[c["id"]] != st]
    if wrong:
        die("refused candidates answered unexpectedly:\n  " + "\n  ".join(wrong))
    bad_good = [c["id"] for c, a in zip(cands, answers)
                if not c["id"].startswith("refused-") and a["status"] != 0]
    if bad_good:
        die(f"random force-closure grasps not solved: {bad_good[:5]}")
    write_mcap_ros2(out / "random_grasps.mcap", list(zip(cands, answers)), T0)

    # c. candidates only, written by rosbags
    rng = random.Random(SEED + 2)
    rb_cands = [dict(c, header=dict(c["header"], stamp=stamp_of(T0 + k * PERIOD))) for k, c in enumerate(paper)]
    rb_cands += random_candidates(rng, N_ROSBAGS_RANDOM, "rosbags", T0 + len(paper) * PERIOD)
    with tempfile.TemporaryDirectory() as tmp:
        mcap_file = write_rosbags(Path(tmp) / "rosbags_written", rb_cands, T0)
        shutil.copyfile(mcap_file, out / "rosbags_written.mcap")
        keep = out / "rosbags_written"
        if keep.exists():
            shutil.rmtree(keep)
        shutil.copytree(Path(tmp) / "rosbags_written", keep)

    n_ok = sum(1 for a in answers if a["status"] == 0)
    print(f"paper_cases.mcap: {len(paper)} candidates, {len(paper)} recommendations")
    print(f"random_grasps.mcap: {len(cands)} candidates ({n_ok} solved, "
          f"{sum(1 for a in answers if a['status'] == 1)} without force closure, "
          f"{sum(1 for a in answers if a['status'] == 2)} invalid), {len(answers)} recommendations")
    print(f"rosbags_written.mcap: {len(rb_cands)} candidates, no recommendations")
    for name in ("paper_cases.mcap", "random_grasps.mcap", "rosbags_written.mcap"):
        print(f"  {out / name}: {(out / name).stat().st_size} bytes")


if __name__ == "__main__":
    main()
