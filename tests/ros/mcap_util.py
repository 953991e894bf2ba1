"""MCAP helpers for the grasp_orient tests and for bags/make_bags.py (no rclpy needed here).

- The complete `ros2msg` message definitions, built exactly as rosbag2 (Jazzy) builds them
  (rosbag2_cpp's LocalMessageDefinitionSource): the type's .msg text, then every dependency, each after
  "\\n" + a line of 80 '=' + a line "MSG: <type as written in the field>", depth first, dependencies of
  one text in sorted order, each type once.
- The `offered_qos_profiles` channel metadata in rosbag2's (version 9) YAML.
- Two independent readers of an MCAP file, each returning [Rec(topic, log_time, publish_time, msg)] with
  `msg` a plain dict (nested dicts, lists, Python floats with NaN/inf kept):
    read_rosbags(path)  rosbags.highlevel.AnyReader over the bare .mcap (types from the embedded schemas);
                        rosbags does not expose publish_time, so it is None there.
    read_mcap(path)     mcap.reader.make_reader + mcap_ros2.decoder.DecoderFactory.
- mcap_facts(path): profile, schemas, channels with metadata, chunk compressions, raw payload headers.
- The random force-closure grasp generator of tests/it/util/mod.rs (conftest re-exports it).
"""
from __future__ import annotations

import array
import dataclasses
import json
import math
import os
import random
import re
import sys
from pathlib import Path
from typing import Any, NamedTuple

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent.parent
MSG_DIR = REPO_ROOT / "msg"
BAGS_DIR = REPO_ROOT / "bags"
PAPER_CASES = REPO_ROOT / "examples" / "paper_cases.jsonl"

CANDIDATE_TYPE = "grasp_orient/msg/GraspCandidate"
RECOMMENDATION_TYPE = "grasp_orient/msg/GripRecommendation"
MARKER_ARRAY_TYPE = "visualization_msgs/msg/MarkerArray"
CANDIDATES_TOPIC = "/grasp_candidates"
RECOMMENDATIONS_TOPIC = "/grip_recommendations"
MARKERS_TOPIC = "/grip_markers"

CDR_HEADER = b"\x00\x01\x00\x00"  # CDR little endian, options 0
MCAP_MAGIC = b"\x89MCAP0\r\n"


# ---------------------------------------------------------------------------------------------------
# Message definitions (rosbag2's ros2msg form)
# ---------------------------------------------------------------------------------------------------
# rosbag2_cpp: MSG_FIELD_TYPE_REGEX and PRIMITIVE_TYPES
_MSG_FIELD_TYPE_RE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
_PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
               "uint32", "int64", "uint64", "string"}
SEPARATOR = "=" * 80 + "\n"


def share_dirs() -> list[Path]:
    """Where installed interface packages live: <prefix>/share for AMENT_PREFIX_PATH and this venv."""
    out = []
    for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if p:
            out.append(Path(p) / "share")
    out.append(Path(sys.prefix) / "share")
    return out


def msg_file(type_name: str) -> Path:
    """The .msg file of `pkg/Name` or `pkg/msg/Name`: ours from msg/, the others from the Jazzy install."""
    parts = type_name.split("/")
    if len(parts) == 2:
        pkg, name = parts
    elif len(parts) == 3 and parts[1] == "msg":
        pkg, name = parts[0], parts[2]
    else:
        raise ValueError(f"not a message type name: {type_name!r}")
    if pkg == "grasp_orient":
        f = MSG_DIR / f"{name}.msg"
        if f.is_file():
            return f
        raise FileNotFoundError(f"{f} is missing")
    tried = []
    for share in share_dirs():
        f = share / pkg / "msg" / f"{name}.msg"
        tried.append(str(f))
        if f.is_file():
            return f
    raise FileNotFoundError(f"no .msg file for {type_name} (tried {tried}); source \"$(bash tests/peer/setup.sh | tail -n 1)\" first")


def _dependencies(text: str, package: str) -> list[str]:
    deps = set()
    for m in _MSG_FIELD_TYPE_RE.finditer(text):
        t = m.group(1)
        if t in _PRIMITIVES:
            continue
        deps.add(t if "/" in t else f"{package}/{t}")
    return sorted(deps)  # std::set<std::string> order


def rosbag2_full_text(type_name: str) -> str:
    """The complete ros2msg definition of `type_name` exactly as rosbag2 (Jazzy) writes it into MCAP."""
    seen: set[str] = set()

    def rec(name: str, depth: int) -> str:
        if depth <= 0:
            raise RuntimeError(f"recursion too deep resolving {type_name}")
        text = msg_file(name).read_text()
        out = text
        for dep in _dependencies(text, name.split("/")[0]):
            if dep in seen:  # rosbag2 keys the seen set by the name as the field writes it
                continue
            seen.add(dep)
            out += "\n" + SEPARATOR + f"MSG: {dep}\n" + rec(dep, depth - 1)
        return out

    return rec(type_name, 50)


def _sections(text: str) -> list[str]:
    return text.split("\n" + SEPARATOR)


def is_rosbag2_text_of_an_older_version(type_name: str, recorded: str) -> bool:
    """Whether `recorded` is what rosbag2 wrote for `type_name` before some of its messages grew by trailing
    fields: the same sections (the type's text, then each dependency) as today's text, each one a prefix of
    today's, cut at the end of a line. (Message contracts only ever grow by lines appended to a .msg file.)"""
    now = _sections(rosbag2_full_text(type_name))
    then = _sections(recorded)
    if len(now) != len(then):
        return False
    for a, b in zip(then, now):
        head_a, head_b = a.split("\n", 1)[0], b.split("\n", 1)[0]
        if a.startswith("MSG: ") and head_a != head_b:
            return False
        if not b.startswith(a) or (a != b and not a.endswith("\n")):
            return False
    return True


def _normal(name: str) -> str:
    p = name.split("/")
    return f"{p[0]}/msg/{p[-1]}"


# rosbag2 (Jazzy, metadata version 9) YAML of one offered profile: reliable, volatile, keep-last.
def offered_qos_yaml(depth: int = 100) -> str:
    inf = "    sec: 9223372036\n    nsec: 854775807\n"
    return (f"- history: keep_last\n  depth: {depth}\n  reliability: reliable\n  durability: volatile\n"
            f"  deadline:\n{inf}  lifespan:\n{inf}  liveliness: automatic\n"
            f"  liveliness_lease_duration:\n{inf}  avoid_ros_namespace_conventions: false")


# ---------------------------------------------------------------------------------------------------
# Plain values
# ---------------------------------------------------------------------------------------------------
def plain(v: Any) -> Any:
    """Any decoded message (rosbags dataclass, mcap_ros2 dynamic class, rclpy message) as nested dicts and
    lists of Python scalars; floats stay floats (NaN and infinities kept)."""
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        # rosbags: its dataclasses also carry __msgtype__ and the constants; ROS 2 field names are lower case
        return {f.name: plain(getattr(v, f.name)) for f in dataclasses.fields(v)
                if not f.name.startswith("__") and f.name == f.name.lower()}
    if hasattr(v, "get_fields_and_field_types"):  # rclpy
        return {k: plain(getattr(v, k)) for k in v.get_fields_and_field_types()}
    if hasattr(v, "__slots__") and not isinstance(v, (str, bytes, int, float)) and type(v).__module__ != "numpy":
        # mcap_ros2 dynamic classes
        return {k: plain(getattr(v, k)) for k in v.__slots__}
    if isinstance(v, dict):
        return {k: plain(x) for k, x in v.items()}
    if isinstance(v, (bytes, bytearray)):  # uint8[] / byte[] (mcap_ros2) as a list like the others
        return list(v)
    if isinstance(v, (list, tuple, array.array)) or type(v).__name__ == "ndarray":
        return [plain(x) for x in v]
    if hasattr(v, "item") and not isinstance(v, (str, bytes)):  # numpy scalar
        return plain(v.item())
    if isinstance(v, bool):
        return v
    if isinstance(v, float):
        return float(v)
    return v


def jsonish(v: Any) -> Any:
    """As `grasp_orient solve` writes values: NaN and infinities as None."""
    if isinstance(v, dict):
        return {k: jsonish(x) for k, x in v.items()}
    if isinstance(v, list):
        return [jsonish(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def as_message(candidate: dict) -> dict:
    """A candidate dict as a GraspCandidate holds it: `model` 0 (planar) where the dict has none, as a JSON line,
    an older message or a recording made before spatial candidates without the field means; the tolerances 0
    (known exactly) where it has none."""
    defaults = {"model": 0, "center_of_mass_tolerance": {"x": 0.0, "y": 0.0, "z": 0.0}, "mass_tolerance": 0.0}
    return {**defaults, **candidate}


def same(a: Any, b: Any) -> bool:
    """Exact equality, NaN equal to NaN (bit-level sign of NaN ignored), ints equal to equal floats."""
    return not differences(a, b)


def differences(a: Any, b: Any, path: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}{k}: only in {'second' if k not in a else 'first'}")
            else:
                out += differences(a[k], b[k], f"{path}{k}.")
        return out
    p = path.rstrip(".") or "<value>"
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{p}: length {len(a)} vs {len(b)}"]
        out = []
        for i, (x, y) in enumerate(zip(a, b)):
            out += differences(x, y, f"{p}[{i}].")
        return out
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return []
    if type(a) in (int, float) and type(b) in (int, float):
        return [] if a == b else [f"{p}: {a!r} vs {b!r}"]
    return [] if (type(a) is type(b) and a == b) else [f"{p}: {a!r} vs {b!r}"]


def canonical(v: Any) -> str:
    return json.dumps(v, sort_keys=True, allow_nan=True)


# ---------------------------------------------------------------------------------------------------
# Readers
# ---------------------------------------------------------------------------------------------------
class Rec(NamedTuple):
    topic: str
    log_time: int
    publish_time: int | None
    msgtype: str
    msg: dict


def read_rosbags(path: Path | str) -> list[Rec]:
    """Every message of a bare .mcap (or a rosbag2 directory) decoded by rosbags' AnyReader, in log-time order;
    the types come from the schemas embedded in the file. publish_time is None (rosbags does not expose it)."""
    from rosbags.highlevel import AnyReader

    out = []
    with AnyReader([Path(path)]) as reader:
        for conn, timestamp, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            out.append(Rec(conn.topic, timestamp, None, conn.msgtype, plain(msg)))
    return out


def read_mcap(path: Path | str, topics: list[str] | None = None) -> list[Rec]:
    """Every message (or every one on `topics`) decoded by the mcap library with mcap_ros2's DecoderFactory, in
    log-time order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages(topics=topics, log_time_order=True):
            out.append(Rec(channel.topic, message.log_time, message.publish_time,
                           schema.name if schema else "", plain(decoded)))
    return out


def sort_key(r: Rec):
    return (r.topic, r.log_time, canonical(jsonish(r.msg)))


def compare_readers(a: list[Rec], b: list[Rec]) -> list[str]:
    """Differences between the decodings of one file by two readers (topic, log_time, type, contents)."""
    if len(a) != len(b):
        return [f"message count {len(a)} vs {len(b)}"]
    problems = []
    for x, y in zip(sorted(a, key=sort_key), sorted(b, key=sort_key)):
        if (x.topic, x.log_time) != (y.topic, y.log_time):
            problems.append(f"{x.topic}@{x.log_time} vs {y.topic}@{y.log_time}")
            continue
        if x.msgtype and y.msgtype and _normal(x.msgtype) != _normal(y.msgtype):
            problems.append(f"{x.topic}@{x.log_time}: type {x.msgtype} vs {y.msgtype}")
        d = differences(x.msg, y.msg)
        if d:
            problems.append(f"{x.topic}@{x.log_time}: " + "; ".join(d[:5]))
    return problems


def mcap_facts(path: Path | str) -> dict:
    """What a file says about itself, from the mcap library without decoding: header, schemas, channels (with
    metadata), the compression of every chunk, message counts, and the first 4 bytes of every payload."""
    from mcap.reader import make_reader
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    with open(path, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        heads: dict[str, set] = {}
        counts: dict[str, int] = {}
        for schema, channel, message in reader.iter_messages():
            heads.setdefault(channel.topic, set()).add(bytes(message.data[:4]))
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    compressions = []
    with open(path, "rb") as f:
        for rec in StreamReader(f, emit_chunks=True).records:
            if isinstance(rec, Chunk):
                compressions.append(rec.compression)
    assert summary is not None, f"{path} has no summary section"
    schemas = {s.id: {"name": s.name, "encoding": s.encoding, "data": s.data.decode()}
               for s in summary.schemas.values()}
    channels = {c.topic: {"message_encoding": c.message_encoding, "metadata": dict(c.metadata),
                          "schema": schemas.get(c.schema_id, {}).get("name")} for c in summary.channels.values()}
    return {"profile": header.profile, "library": header.library, "schemas": schemas, "channels": channels,
            "chunk_compressions": compressions, "payload_heads": heads, "counts": counts,
            "chunk_count": len(summary.chunk_indexes)}


# ---------------------------------------------------------------------------------------------------
# Candidates
# ---------------------------------------------------------------------------------------------------
def load_paper_cases() -> list[dict]:
    return [json.loads(l) for l in PAPER_CASES.read_text().splitlines() if l.strip()]


def quantize(v: Any, digits: int = 15) -> Any:
    """Floats cut to `digits` significant digits: decimals any JSON reader turns into exactly these doubles."""
    if isinstance(v, dict):
        return {k: quantize(x, digits) for k, x in v.items()}
    if isinstance(v, float) and math.isfinite(v):
        return float(f"{v:.{digits}g}")
    return v


def _rot(v, a):
    s, c = math.sin(a), math.cos(a)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1])


def _cone_contains(p, n, mu, q) -> bool:
    d = (q[0] - p[0], q[1] - p[1])
    ln = math.hypot(*n)
    n = (n[0] / ln, n[1] / ln)
    along = n[0] * d[0] + n[1] * d[1]
    return along > 0.0 and abs(n[0] * d[1] - n[1] * d[0]) < mu * along


def random_grasp(rng: random.Random, cid: str, frame_id: str = "object", stamp: tuple[int, int] | None = None) -> dict:
    """A random force-closure grasp in a random frame (the generator of tests/it/util/mod.rs)."""
    u = rng.uniform
    while True:
        p1 = (u(-1, 1), u(-1, 1))
        p2 = (u(-1, 1), u(-1, 1))
        if math.hypot(p1[0] - p2[0], p1[1] - p2[1]) < 0.05:
            continue
        ln = math.hypot(p2[0] - p1[0], p2[1] - p1[1])
        along = ((p2[0] - p1[0]) / ln, (p2[1] - p1[1]) / ln)
        n1 = _rot(along, u(-1.4, 1.4))
        n2 = _rot((-along[0], -along[1]), u(-1.4, 1.4))
        mu1, mu2 = u(0.1, 2.0), u(0.1, 2.0)
        if not _cone_contains(p1, n1, mu1, p2) or not _cone_contains(p2, n2, mu2, p1):
            continue
        mid = ((p1[0] + p2[0]) / 2, (p1[1] + p2[1]) / 2)
        com = (mid[0] + u(-1, 1), mid[1] + u(-1, 1))
        if (n1[0] * (com[0] - p1[0]) + n1[1] * (com[1] - p1[1]) <= 1e-3
                or n2[0] * (com[0] - p2[0]) + n2[1] * (com[1] - p2[1]) <= 1e-3):
            continue
        angle = u(-math.pi, math.pi)
        shift = (u(-2, 2), u(-2, 2))
        scale = 10 ** u(-2, 1)

        def place(p):
            r = _rot(p, angle)
            return {"x": r[0] * scale + shift[0], "y": r[1] * scale + shift[1], "z": u(-1, 1)}

        def vec(v, k):
            r = _rot(v, angle)
            return {"x": r[0] * k, "y": r[1] * k, "z": 0.0}

        g = 9.81 * u(0.5, 1.5)
        gv = _rot((0.0, -g), u(-math.pi, math.pi))
        if stamp is None:
            stamp = (rng.randrange(0, 2**31), rng.randrange(0, 10**9))
        return {
            "header": {"stamp": {"sec": stamp[0], "nanosec": stamp[1]}, "frame_id": frame_id},
            "id": cid,
            "contact_1": place(p1),
            "contact_2": place(p2),
            "normal_1": vec(n1, u(0.1, 10.0)),
            "normal_2": vec(n2, u(0.1, 10.0)),
            "friction_1": mu1,
            "friction_2": mu2,
            "center_of_mass": place(com),
            "mass": 10 ** u(-2, 2),
            "gravity": {"x": gv[0], "y": gv[1], "z": 0.0},
        }


def _unit3(v):
    n = math.sqrt(sum(x * x for x in v))
    return tuple(x / n for x in v)


def _random_rotation(rng: random.Random):
    """A uniformly random 3D rotation as a function on 3-tuples (a normalised Gaussian quaternion)."""
    w, x, y, z = _unit3([rng.gauss(0.0, 1.0) for _ in range(4)])
    m = ((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
         (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
         (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))
    return lambda v: tuple(sum(m[i][j] * v[j] for j in range(3)) for i in range(3))


SPATIAL_KINDS = ("in_plane", "tilted", "near_axis", "on_axis")


def random_spatial_grasp(rng: random.Random, cid: str, kind: str, frame_id: str = "object",
                         stamp: tuple[int, int] | None = None) -> dict:
    """A random spatial candidate (`model` 1) with force closure, in a random 3D frame and unit, built in a local
    frame whose x-y plane is the grasp plane (independently of tests/it/util/spatial.rs, the same kinds):
    - in_plane: normals in the plane; tilted: each normal tilted out of it by up to half its friction angle
      (so its sliced cone keeps the other contact); near_axis: the centre of mass 0.1% to 0.9% of the contact
      distance off the contact axis; on_axis: on it, normals within 0.8 of the friction angle of the axis.
    Gravity is random in 3D, or in the grasp plane (off the axis) one time in three, so that some current poses
    can be held and others swing."""
    u = rng.uniform
    while True:
        mu = (u(0.1, 2.0), u(0.1, 2.0))
        if kind == "on_axis":
            p1, p2 = (u(0.3, 1.0), 0.0, 0.0), (-u(0.3, 1.0), 0.0, 0.0)
            com = (u(-0.2, 0.2), 0.0, 0.0)
            normals = []
            for i, sign in enumerate((-1.0, 1.0)):
                delta, az = u(0.0, 0.8) * math.atan(mu[i]), u(-math.pi, math.pi)
                normals.append((sign * math.cos(delta), math.sin(delta) * math.cos(az), math.sin(delta) * math.sin(az)))
            break
        p1, p2 = (u(-1, 1), u(-1, 1)), (u(-1, 1), u(-1, 1))
        d = math.hypot(p1[0] - p2[0], p1[1] - p2[1])
        if d < 0.05:
            continue
        along = ((p2[0] - p1[0]) / d, (p2[1] - p1[1]) / d)
        n2d = (_rot(along, u(-1.4, 1.4)), _rot((-along[0], -along[1]), u(-1.4, 1.4)))
        betas = [0.0, 0.0] if kind == "in_plane" else [u(-0.5, 0.5) * math.atan(m) for m in mu]
        # The cone sliced by the plane: mu' = sqrt(mu^2 cos^2 b - sin^2 b) (docs/theory.md, "A friction cone sliced by the plane").
        sliced = [math.sqrt(m * m * math.cos(b) ** 2 - math.sin(b) ** 2) for m, b in zip(mu, betas)]
        if not _cone_contains(p1, n2d[0], sliced[0], p2) or not _cone_contains(p2, n2d[1], sliced[1], p1):
            continue
        if kind == "near_axis":
            t, off = u(0.2, 0.8), u(0.001, 0.009) * d * rng.choice((-1.0, 1.0))
            com2 = (p2[0] + t * (p1[0] - p2[0]) - off * along[1], p2[1] + t * (p1[1] - p2[1]) + off * along[0])
        else:
            mid = ((p1[0] + p2[0]) / 2, (p1[1] + p2[1]) / 2)
            com2 = (mid[0] + u(-1, 1), mid[1] + u(-1, 1))
        if any(n[0] * (com2[0] - p[0]) + n[1] * (com2[1] - p[1]) <= 1e-3 * d for n, p in zip(n2d, (p1, p2))):
            continue
        p1, p2, com = (*p1, 0.0), (*p2, 0.0), (*com2, 0.0)
        normals = [(n[0] * math.cos(b), n[1] * math.cos(b), math.sin(b)) for n, b in zip(n2d, betas)]
        break
    turn = _random_rotation(rng)
    shift = (u(-2, 2), u(-2, 2), u(-2, 2))
    scale = 10 ** u(-2, 1)

    def place(p):
        r = turn(p)
        return {"x": r[0] * scale + shift[0], "y": r[1] * scale + shift[1], "z": r[2] * scale + shift[2]}

    def vec(v, k):
        r = turn(v)
        return {"x": r[0] * k, "y": r[1] * k, "z": r[2] * k}

    if kind != "on_axis" and rng.random() < 1 / 3:
        phi = u(-math.pi, math.pi)
        g = (math.cos(phi), math.sin(phi), 0.0)
    else:
        g = _unit3([rng.gauss(0.0, 1.0) for _ in range(3)])
    if stamp is None:
        stamp = (rng.randrange(0, 2**31), rng.randrange(0, 10**9))
    return {
        "header": {"stamp": {"sec": stamp[0], "nanosec": stamp[1]}, "frame_id": frame_id},
        "id": cid,
        "contact_1": place(p1),
        "contact_2": place(p2),
        "normal_1": vec(normals[0], u(0.1, 10.0)),
        "normal_2": vec(normals[1], u(0.1, 10.0)),
        "friction_1": mu[0],
        "friction_2": mu[1],
        "center_of_mass": place(com),
        "mass": 10 ** u(-2, 2),
        "gravity": vec(g, 9.81 * u(0.5, 1.5)),
        "model": 1,
    }


# ---------------------------------------------------------------------------------------------------
# `solve` answers as recommendation messages
# ---------------------------------------------------------------------------------------------------
_LINE_PREFIX = re.compile(r"^line \d+: ")
_CURRENT = ("gripping_power_current", "internal_force_current", "finger_force_current")


def recommendation_from_solve(ans: dict) -> dict:
    """A `grasp_orient solve` JSON answer as the GripRecommendation the node publishes for the same candidate:
    null is NaN, except the *_current powers of a solved or force-closure-less grasp, where null means
    "cannot be held" (infinity); the "line N: " prefix of a status-2 message is solve's own."""
    status = ans["status"]

    def fix(v, key=None):
        if isinstance(v, dict):
            return {k: fix(x, k) for k, x in v.items()}
        if isinstance(v, list):
            return [fix(x) for x in v]
        if v is None:
            return math.inf if key in _CURRENT and status in (0, 1) else math.nan
        if isinstance(v, int) and key not in ("status", "candidate_c", "sec", "nanosec"):
            return float(v)
        return v

    out = fix(ans)
    if status == 2:
        out["message"] = _LINE_PREFIX.sub("", out["message"])
    for k in ("local_minima", "local_minima_power"):
        out[k] = [float(x) for x in out[k]]
    return out
