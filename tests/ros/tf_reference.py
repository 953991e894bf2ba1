"""Reference numbers for the TF buffer (src/tf/), computed with numpy alone.

The cases (two trees of static and dynamic transforms, lookups at stamps, between stamps and at
time 0) come from a fixed seed; each lookup's answer is computed here independently of the Rust
code: quaternions to rotation matrices, 4x4 homogeneous transforms composed along the path to the
common ancestor, slerp and linear interpolation written out, the latest common time taken as tf2
defines it. `python tests/ros/tf_reference.py` writes tests/tf/reference.json, which the Rust test
`tf::tests::lookups_match_the_numpy_reference` reads; tests/ros/test_tf_reference.py checks that
the file is what this script computes.
"""

import json
import math
import pathlib

import numpy as np

OUT = pathlib.Path(__file__).resolve().parents[1] / "tf" / "reference.json"
NS = 1_000_000_000


def unit_quaternion(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)  # (x, y, z, w)


def matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def homogeneous(t, q):
    m = np.eye(4)
    m[:3, :3] = matrix(q)
    m[:3, 3] = t
    return m


def slerp(a, b, s):
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    d = float(np.dot(a, b))
    if d < 0:
        b, d = -b, -d
    if d > 1 - 1e-12:
        q = (1 - s) * a + s * b
    else:
        th = math.acos(min(d, 1.0))
        q = (math.sin((1 - s) * th) * a + math.sin(s * th) * b) / math.sin(th)
    return q / np.linalg.norm(q)


# (child, parent, static)
TREE = [
    ("base", "world", False),
    ("arm", "base", True),
    ("tool", "arm", False),
    ("cam", "world", True),
    ("optical", "cam", False),
    ("wrist", "tool", True),
    ("odom", "map", False),
    ("robot", "odom", False),
]


def cases(seed=20261206):
    rng = np.random.default_rng(seed)
    transforms = []
    samples = {}
    for child, parent, static in TREE:
        if static:
            t = rng.uniform(-1, 1, 3)
            q = unit_quaternion(rng)
            transforms.append({"parent": parent, "child": child, "static": True,
                               "stamp_ns": 0, "t": list(t), "q": list(q)})
            samples[child] = (parent, [(0, t, q)])
        else:
            start = 100 * NS + int(rng.integers(0, 50_000_000))
            stamps = sorted(set(start + int(k * 100_000_000 + rng.integers(0, 30_000_000))
                                for k in range(6)))
            lst = []
            for s in stamps:
                t = rng.uniform(-2, 2, 3)
                q = unit_quaternion(rng)
                lst.append((s, t, q))
                transforms.append({"parent": parent, "child": child, "static": False,
                                   "stamp_ns": s, "t": list(t), "q": list(q)})
            samples[child] = (parent, lst)
    frames = sorted({f for c, p, _ in TREE for f in (c, p)})
    lookups = []
    for _ in range(60):
        target, source = rng.choice(frames, 2, replace=True)
        kind = rng.integers(0, 4)
        lookups.append({"target": str(target), "source": str(source), "kind": int(kind),
                        "u": float(rng.uniform())})
    # Every frame to every other at time 0.
    for a in frames:
        for b in frames:
            lookups.append({"target": a, "source": b, "kind": 0, "u": 0.0})
    # A permuted order of the transforms: the buffer sorts by stamp itself.
    order = rng.permutation(len(transforms))
    return [transforms[i] for i in order], samples, lookups


def chain(frame, samples):
    out = [frame]
    while frame in samples:
        frame = samples[frame][0]
        out.append(frame)
    return out


def link_at(samples, child, time):
    """(4x4 parent<-child, None) at time, or (None, reason)."""
    parent, lst = samples[child]
    if lst[0][0] == 0:
        return homogeneous(lst[0][1], lst[0][2]), None
    if time == 0:
        s, t, q = lst[-1]
        return homogeneous(t, q), None
    if len(lst) == 1 and lst[0][0] != time:
        return None, "single"
    if time > lst[-1][0]:
        return None, "future"
    if time < lst[0][0]:
        return None, "past"
    for (s0, t0, q0), (s1, t1, q1) in zip(lst, lst[1:]):
        if s0 <= time <= s1:
            r = (time - s0) / (s1 - s0)
            return homogeneous((1 - r) * np.asarray(t0) + r * np.asarray(t1), slerp(q0, q1, r)), None
    s, t, q = lst[-1]
    return homogeneous(t, q), None


def answer(samples, target, source, kind, u):
    if target == source:
        return {"ok": True, "time_ns": 0, "m": np.eye(4)}
    up_s, up_t = chain(source, samples), chain(target, samples)
    common = next((f for f in up_s if f in up_t), None)
    if common is None:
        return {"ok": False, "error": "not_connected"}
    path = up_s[:up_s.index(common)] + up_t[:up_t.index(common)]
    dynamic = [samples[f][1] for f in path if samples[f][1][0][0] != 0]
    if kind == 0:  # time 0: the latest common time
        time = min((lst[-1][0] for lst in dynamic), default=0)
    elif not dynamic:
        time = 123 * NS
    else:
        lo = max(lst[0][0] for lst in dynamic)
        hi = min(lst[-1][0] for lst in dynamic)
        if kind == 1:  # within every link's samples, when they overlap
            time = int(lo + u * (hi - lo)) if hi > lo else hi
        elif kind == 2:  # an exact stamp of the first dynamic link
            lst = dynamic[0]
            time = lst[int(u * len(lst)) % len(lst)][0]
        else:  # after every sample: extrapolation into the future
            time = max(lst[-1][0] for lst in dynamic) + 1 + int(u * NS)
    m_s = np.eye(4)  # common <- source
    for f in up_s[:up_s.index(common)]:
        link, why = link_at(samples, f, time)
        if link is None:
            return {"ok": False, "error": why, "time_ns": int(time)}
        m_s = link @ m_s
    m_t = np.eye(4)
    for f in up_t[:up_t.index(common)]:
        link, why = link_at(samples, f, time)
        if link is None:
            return {"ok": False, "error": why, "time_ns": int(time)}
        m_t = link @ m_t
    return {"ok": True, "time_ns": int(time), "m": np.linalg.inv(m_t) @ m_s}


def reference():
    transforms, samples, lookups = cases()
    out = []
    for lk in lookups:
        a = answer(samples, lk["target"], lk["source"], lk["kind"], lk["u"])
        row = {"target": lk["target"], "source": lk["source"], "time_ns": a.get("time_ns", 0),
               "latest": lk["kind"] == 0}
        if a["ok"]:
            row["translation"] = [float(v) for v in a["m"][:3, 3]]
            row["rotation"] = [float(v) for v in a["m"][:3, :3].reshape(9)]
        else:
            row["error"] = a["error"]
        out.append(row)
    return {"transforms": transforms, "lookups": out}


def encoded():
    return json.dumps(reference(), indent=1, default=float) + "\n"


if __name__ == "__main__":
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(encoded())
    print(f"wrote {OUT}")
