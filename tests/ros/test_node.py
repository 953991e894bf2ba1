"""The grasp_orient ROS 2 node driven from a real rclpy peer over Fast DDS (see conftest.py for how to run).

Every answer of the node is compared, field by field, with what `grasp_orient solve` prints for the same JSON
line and settings: the node and `solve` share the solver, so they must agree to rounding.
"""
from __future__ import annotations

import copy
import json
import math
import random
import signal
import subprocess
import sys
import time

import pytest

from conftest import (
    CANDIDATE_TYPE, DOMAIN_ID, EXAMPLE_SCRIPT, MARKER_ARRAY_TYPE, RECOMMENDATION_TYPE, GraspClient, compare,
    is_probe_markers, load_paper_cases, random_grasp, reliable_qos, ros_env, run_python, run_solve, to_plain,
)

from grasp_orient.msg import GripRecommendation  # noqa: E402  (conftest reports a missing rclpy as a failure)
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import GetParameters, SetParameters  # noqa: E402
from visualization_msgs.msg import MarkerArray  # noqa: E402

SEED = 20240611
N_RANDOM = 1000


def quantize(v, digits: int = 15):
    """Every float rounded to `digits` significant digits: a decimal that any JSON reader turns into exactly
    the double the ROS message carries (15 digits and a small exponent: exact even without correct rounding)."""
    if isinstance(v, dict):
        return {k: quantize(x, digits) for k, x in v.items()}
    if isinstance(v, float):
        return float(f"{v:.{digits}g}")
    return v


def random_batch(n: int, seed: int, prefix: str, full_precision: bool = False) -> list[dict]:
    """n random force-closure grasps in random frames; floats cut to 15 significant digits unless
    full_precision (then 17-digit decimals reach `solve`)."""
    rng = random.Random(seed)
    frames = ["object", "world", "tool0", "camera_optical", "base_link"]
    out = [random_grasp(rng, f"{prefix}-{k}", frames[k % len(frames)]) for k in range(n)]
    return out if full_precision else [quantize(c) for c in out]


def check_against_solve(answers: dict, cands: list[dict], *flags: str, expect: dict | None = None):
    """Every ROS answer equals `solve FLAGS` on the same lines; `expect` fields must hold in every answer."""
    ref = run_solve(cands, *flags)
    problems = []
    for c, r in zip(cands, ref):
        assert r["candidate_id"] == c["id"][:1024]
        ros = to_plain(answers[c["id"]])
        diff = compare(ros, r)
        if expect and ros.get("status") == 0:
            diff += [f"{k}: {ros.get(k)!r}, expected {v!r}" for k, v in expect.items() if ros.get(k) != v]
        if diff:
            problems.append(f"{c['id']}: " + "; ".join(diff[:6]))
    assert not problems, (f"{len(problems)} of {len(cands)} answers differ from `grasp_orient solve "
                          f"{' '.join(flags)}`:\n" + "\n".join(problems[:20]))
    return ref


# ---------------------------------------------------------------------------------------------------
# Answers
# ---------------------------------------------------------------------------------------------------
def test_paper_cases_and_random_grasps_equal_solve(client):
    cands = load_paper_cases() + random_batch(N_RANDOM, SEED, "rand")
    answers = client.send_and_collect(cands, timeout=120.0)
    ref = check_against_solve(answers, cands)
    # inputs that reach both exactly, same code: bit for bit, in fact
    same = sum(1 for c, r in zip(cands[4:], ref[4:]) if to_plain(answers[c["id"]]) == r)
    assert same == N_RANDOM, f"only {same} of {N_RANDOM} answers to random grasps are bit-identical to solve's"
    statuses = [r["status"] for r in ref]
    # the generator makes force-closure grasps: they must all be solved
    assert statuses.count(0) == len(cands), f"statuses: { {s: statuses.count(s) for s in set(statuses)} }"
    for c in cands:
        a = answers[c["id"]]
        assert a.header.frame_id == c["header"]["frame_id"]
        assert (a.header.stamp.sec, a.header.stamp.nanosec) == (c["header"]["stamp"]["sec"],
                                                                c["header"]["stamp"]["nanosec"])
    # the paper's case (a) as printed by the paper (Table 2 / Fig. 9): C at theta_34
    a = answers["paper-a"]
    assert a.objective == "norm2" and a.grasp_case == "a" and a.recommended_label == "C"


def test_full_precision_inputs_equal_solve(client):
    """17-significant-digit inputs (Python's repr, what any exact JSON writer emits): `solve` must read the same
    doubles the ROS messages carry. A failure here while the test above passes means `solve`'s JSON reader
    rounds some inputs by an ulp (serde_json without its `float_roundtrip` feature), not that the node is off."""
    cands = random_batch(N_RANDOM, SEED, "full", full_precision=True)
    answers = client.send_and_collect(cands, timeout=120.0)
    ref = run_solve(cands)
    same = sum(1 for c, r in zip(cands, ref) if to_plain(answers[c["id"]]) == r)
    try:
        check_against_solve(answers, cands)
    except AssertionError as e:
        raise AssertionError(f"{e}\n({same} of {len(cands)} bit-identical. When "
                             f"test_paper_cases_and_random_grasps_equal_solve (the same grasps cut to 15 significant "
                             f"digits) passes, `solve` does not parse 17-digit JSON numbers exactly)") from None


def test_node_in_ros_graph(peer, client):
    want_topics = {"/grasp_candidates": CANDIDATE_TYPE, "/grip_recommendations": RECOMMENDATION_TYPE,
                   "/grip_markers": MARKER_ARRAY_TYPE}

    def seen():
        names = peer.node.get_node_names_and_namespaces()
        topics = dict(peer.node.get_topic_names_and_types())
        return ("grasp_orient", "/") in names and all(t in topics.get(n, []) for n, t in want_topics.items())

    ok = peer.spin_until(seen, 10.0)
    names = peer.node.get_node_names_and_namespaces()
    topics = dict(peer.node.get_topic_names_and_types())
    assert ("grasp_orient", "/") in names, f"('grasp_orient', '/') not among nodes {names}"
    for n, t in want_topics.items():
        assert topics.get(n) == [t], f"topic {n}: types {topics.get(n)}, expected [{t}]; all topics: {topics}"
    assert ok
    # who publishes and subscribes what
    pubs = {(i.node_name, i.node_namespace) for i in peer.node.get_publishers_info_by_topic("/grip_recommendations")}
    subs = {(i.node_name, i.node_namespace) for i in peer.node.get_subscriptions_info_by_topic("/grasp_candidates")}
    assert ("grasp_orient", "/") in pubs, f"publishers of /grip_recommendations: {pubs}"
    assert ("grasp_orient", "/") in subs, f"subscribers of /grasp_candidates: {subs}"
    # QoS as announced in discovery: reliable, volatile (the history depth is not announced by DDS)
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
    for topic, infos in [("/grip_recommendations", peer.node.get_publishers_info_by_topic("/grip_recommendations")),
                         ("/grip_markers", peer.node.get_publishers_info_by_topic("/grip_markers")),
                         ("/grasp_candidates", peer.node.get_subscriptions_info_by_topic("/grasp_candidates"))]:
        for i in infos:
            if (i.node_name, i.node_namespace) == ("grasp_orient", "/"):
                q = i.qos_profile
                assert (q.reliability, q.durability) == (ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE), \
                    f"{topic}: the node's endpoint has {q.reliability!r}, {q.durability!r}; expected reliable, volatile"
    services = dict(peer.node.get_service_names_and_types_by_node("grasp_orient", "/"))
    for s, t in [("/grasp_orient/set_parameters", "rcl_interfaces/srv/SetParameters"),
                 ("/grasp_orient/get_parameters", "rcl_interfaces/srv/GetParameters")]:
        assert t in services.get(s, []), f"service {s} ({t}) not offered; services of the node: {services}"


# ---------------------------------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------------------------------
def pvalue(v) -> ParameterValue:
    if isinstance(v, bool):
        return ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=v)
    if isinstance(v, int):
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=v)
    if isinstance(v, float):
        return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=v)
    return ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=v)


def from_pvalue(p: ParameterValue):
    return {ParameterType.PARAMETER_BOOL: lambda: p.bool_value,
            ParameterType.PARAMETER_INTEGER: lambda: p.integer_value,
            ParameterType.PARAMETER_DOUBLE: lambda: p.double_value,
            ParameterType.PARAMETER_STRING: lambda: p.string_value,
            ParameterType.PARAMETER_NOT_SET: lambda: None}.get(p.type, lambda: ("type", p.type))()


class Params:
    def __init__(self, peer, node_fqn: str = "/grasp_orient"):
        self.peer = peer
        self.set_client = peer.node.create_client(SetParameters, f"{node_fqn}/set_parameters")
        self.get_client = peer.node.create_client(GetParameters, f"{node_fqn}/get_parameters")

    def set(self, **values) -> list:
        req = SetParameters.Request(parameters=[Parameter(name=k, value=pvalue(v)) for k, v in values.items()])
        res = self.peer.call(self.set_client, req).results
        assert len(res) == len(values), f"{len(res)} results for {len(values)} parameters"
        return res

    def get(self, *names):
        res = self.peer.call(self.get_client, GetParameters.Request(names=list(names))).values
        assert len(res) == len(names), f"{len(res)} values for {len(names)} names"
        return [from_pvalue(v) for v in res]


DEFAULTS = dict(objective="norm2", range="from_above", friction_safety_factor=1.0, publish_markers=True)


def test_parameters_set_get_and_refusals(peer, client):
    params = Params(peer)
    assert params.get("objective", "range", "friction_safety_factor", "qos_depth", "publish_markers") == \
        ["norm2", "from_above", 1.0, 100, True], "defaults of config/grasp_orient.yaml"
    cands = load_paper_cases() + random_batch(40, SEED + 1, "param")
    try:
        (r,) = params.set(objective="norm1")
        assert r.successful, f"objective=norm1 refused: {r.reason!r}"
        assert params.get("objective") == ["norm1"]
        answers = client.send_and_collect(cands)
        check_against_solve(answers, cands, "--objective", "norm1", expect={"objective": "norm1"})

        (r,) = params.set(objective="norm3")
        assert not r.successful, "objective=norm3 was accepted"
        assert r.reason.strip(), "refusal of objective=norm3 has an empty reason"
        assert params.get("objective") == ["norm1"], "a refused set changed the value"

        (r,) = params.set(friction_safety_factor=0.5)
        assert not r.successful and r.reason.strip(), f"friction_safety_factor=0.5: {r}"
        assert params.get("friction_safety_factor") == [1.0]

        (r,) = params.set(objective=3)  # wrong type
        assert not r.successful and r.reason.strip(), f"objective=3 (integer): {r}"
        assert params.get("objective") == ["norm1"]

        (r,) = params.set(qos_depth=10)
        assert not r.successful, "qos_depth was changed while running"
        assert r.reason.strip(), "refusal of qos_depth has an empty reason"
        assert params.get("qos_depth") == [100]

        # the answers still follow the last accepted settings
        answers = client.send_and_collect(cands[:4], timeout=20)
        check_against_solve(answers, cands[:4], "--objective", "norm1", expect={"objective": "norm1"})

        # several at once: graspable range and a safety factor
        res = params.set(objective="internal_force", range="graspable", friction_safety_factor=1.5)
        assert all(r.successful for r in res), [r.reason for r in res]
        answers = client.send_and_collect(cands)
        check_against_solve(answers, cands, "--objective", "internal_force", "--range", "graspable",
                            "--friction-safety-factor", "1.5", expect={"objective": "internal_force"})

        # explicit bounds
        res = params.set(objective="norm2", friction_safety_factor=1.0, range="bounds", range_min=-1.0,
                         range_max=0.5)
        assert all(r.successful for r in res), [r.reason for r in res]
        answers = client.send_and_collect(cands)
        check_against_solve(answers, cands, "--range=-1.0:0.5", expect={"objective": "norm2"})
    finally:
        res = params.set(**DEFAULTS, range_min=-math.pi, range_max=math.pi)
        assert all(r.successful for r in res), f"restoring the defaults failed: {[r.reason for r in res]}"
    answers = client.send_and_collect(cands[:4], timeout=20)
    check_against_solve(answers, cands[:4], expect={"objective": "norm2"})


# ---------------------------------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------------------------------
def _bad_cases(base: dict):
    def mut(f):
        c = copy.deepcopy(base)
        f(c)
        return c

    big_id = "x" * (1 << 20)
    return [
        # (name, candidate, words the message must contain, also checkable by `solve`)
        ("nan mass", mut(lambda c: c.update(mass=math.nan)), ["mass"], False),
        ("inf contact", mut(lambda c: c["contact_1"].update(x=math.inf)), ["contact_1"], False),
        ("-inf gravity", mut(lambda c: c["gravity"].update(y=-math.inf)), ["gravity"], False),
        ("nan friction", mut(lambda c: c.update(friction_2=math.nan)), ["friction_2"], False),
        ("nan z", mut(lambda c: c["center_of_mass"].update(z=math.nan)), ["center_of_mass"], False),
        ("1e300 coordinate", mut(lambda c: c["center_of_mass"].update(y=1e300)), ["center_of_mass"], True),
        ("mass -1", mut(lambda c: c.update(mass=-1.0)), ["mass"], True),
        ("mass 0", mut(lambda c: c.update(mass=0.0)), ["mass"], True),
        ("1 MB id", mut(lambda c: c.update(id=big_id)), ["id"], True),
        ("2 kB frame_id", mut(lambda c: c["header"].update(frame_id="f" * 2000)), ["frame_id"], True),
        ("zero normal", mut(lambda c: c.update(normal_2={"x": 0.0, "y": 0.0, "z": 0.0})), ["normal_2"], True),
        ("normal along z", mut(lambda c: c.update(normal_1={"x": 0.0, "y": 0.0, "z": 1.0})), ["normal_1"], True),
        ("coincident contacts", mut(lambda c: c.update(contact_2=dict(c["contact_1"]))), ["contact"], True),
        ("zero friction", mut(lambda c: c.update(friction_1=0.0)), ["friction_1"], True),
        ("zero gravity", mut(lambda c: c.update(gravity={"x": 0.0, "y": 0.0, "z": 0.0})), ["gravity"], True),
    ]


def test_bad_input_answered_with_status_2_and_node_keeps_serving(client):
    base = load_paper_cases()[0]
    goods = random_batch(20, SEED + 2, "after-bad")
    problems = []
    for k, (name, cand, words, by_solve) in enumerate(_bad_cases(base)):
        if cand["id"] == base["id"]:
            cand["id"] = f"bad-{k}"
        cid = cand["id"]
        try:
            ans = client.send_one(cand, timeout=15.0)
        except AssertionError as e:
            problems.append(f"{name}: {e}")
            continue
        if len(cid) > 1024 and ans.candidate_id != cid[:1024]:
            problems.append(f"{name}: candidate_id {ans.candidate_id[:40]!r}... ({len(ans.candidate_id)} chars), "
                            f"expected the first 1024 bytes of the id")
        if ans.status != GripRecommendation.STATUS_INVALID_INPUT:
            problems.append(f"{name}: status {ans.status}, expected 2 (message {ans.message!r})")
        if not ans.message.strip():
            problems.append(f"{name}: empty message")
        missing = [w for w in words if w not in ans.message]
        if missing:
            problems.append(f"{name}: message {ans.message[:200]!r} does not name {missing}")
        if len(ans.message) > 400:
            problems.append(f"{name}: message is {len(ans.message)} characters long: {ans.message[:120]!r}...")
        if len(ans.candidate_id.encode()) > 1024:
            problems.append(f"{name}: candidate_id of {len(ans.candidate_id.encode())} bytes echoed")
        if by_solve:
            (r,) = run_solve([cand])
            diff = compare(to_plain(ans), r)
            if diff:
                problems.append(f"{name}: differs from solve: {'; '.join(diff[:4])}")
        # a good candidate right after it is answered correctly
        good = goods[k % len(goods)]
        answers = client.send_and_collect([good], timeout=15.0)
        try:
            check_against_solve(answers, [good])
        except AssertionError as e:
            problems.append(f"good candidate after {name}: {e}")
    # and a whole batch afterwards
    answers = client.send_and_collect(goods, timeout=30.0)
    check_against_solve(answers, goods)
    assert not problems, "\n".join(problems)


def test_no_force_closure_is_status_1(client):
    c = load_paper_cases()[0]
    c["id"] = "no-closure"
    c["friction_1"] = c["friction_2"] = 0.01  # cones far too narrow for the contact line
    (ans,) = client.send_and_collect([c]).values()
    (r,) = check_against_solve({c["id"]: ans}, [c])
    assert ans.status == GripRecommendation.STATUS_NO_FORCE_CLOSURE and ans.message, to_plain(ans)


# ---------------------------------------------------------------------------------------------------
# Markers
# ---------------------------------------------------------------------------------------------------
def test_markers_in_candidate_frame(peer, client):
    got: list = []
    sub = peer.node.create_subscription(MarkerArray, "grip_markers", got.append, reliable_qos(100))
    params = Params(peer)
    try:
        assert peer.spin_until(lambda: sub.get_publisher_count() > 0, 15.0), \
            "no publisher matched our /grip_markers subscriber"
        frame = "marker_test_frame"
        c = random_batch(1, SEED + 3, "marker")[0]
        c["header"]["frame_id"] = frame

        def mine():
            return [m for m in got if m.markers and any(x.header.frame_id == frame for x in m.markers)]

        # the node's marker writer may match our reader a little after we see it: probe until it has
        client.ensure_markers(got)
        client.send_and_collect([c], timeout=10.0)
        peer.spin_until(lambda: bool(mine()), 10.0)
        arrays = mine()
        assert arrays, f"no MarkerArray with markers in frame {frame!r} on /grip_markers ({len(got)} arrays seen)"
        arr = arrays[-1]
        frames = {x.header.frame_id for x in arr.markers}
        assert frames == {frame}, f"marker frames {frames}, expected only {frame!r}"
        for x in arr.markers:
            p = x.pose.position
            assert all(math.isfinite(v) for v in (p.x, p.y, p.z)), f"non-finite marker pose {x}"
        assert len({(x.ns, x.id) for x in arr.markers}) == len(arr.markers), "markers with the same (ns, id)"

        # publish_markers=false: no more markers
        (r,) = params.set(publish_markers=False)
        assert r.successful, r.reason
        got.clear()
        c2 = dict(c, id="marker-off")
        client.send_and_collect([c2], timeout=10.0)
        peer.spin_for(1.0)
        assert not mine(), "markers published with publish_markers=false"
    finally:
        (r,) = params.set(publish_markers=True)
        assert r.successful, r.reason
        peer.node.destroy_subscription(sub)


def markers_line(n) -> tuple[int, int]:
    """(built, published) from the node's last words: `markers: N arrays built, M published`."""
    lines = [line for line in n.lines if "markers: " in line and " arrays built, " in line]
    assert lines, f"no markers line in the node's last words:\n{n.output(8)}"
    words = lines[-1].split("markers: ", 1)[1].split()
    return int(words[0]), int(words[3])


def test_markers_built_only_for_a_subscriber(start_node, peer):
    """With nobody subscribed to grip_markers and record_markers off, the node builds no marker array at all
    (its last words count them); a subscriber that comes later gets markers for the answers from then on,
    and every array built is published to it."""
    n = start_node("--ros-args", "-r", "__ns:=/lazy_markers", "-p", "record:=false",
                   name="grasp_orient node (markers on demand)")
    c = GraspClient(peer, ns="/lazy_markers")
    got: list = []
    sub = None
    try:
        c.ensure_roundtrip()
        cands = random_batch(20, SEED + 9, "unwatched")
        answers = c.send_and_collect(cands)
        solved = [x for x in cands if answers[x["id"]].status == GripRecommendation.STATUS_OK]
        assert solved, f"none of {len(cands)} candidates solved: {answers}"
        sub = peer.node.create_subscription(MarkerArray, "/lazy_markers/grip_markers", got.append,
                                            reliable_qos(100))
        assert peer.spin_until(lambda: sub.get_publisher_count() > 0, 15.0), "no publisher on grip_markers"
        # the node sees our reader matched a little after we see its writer: probe until markers come
        probes = c.ensure_markers(got)
        frame = "watched_frame"
        watched = [dict(x, id=f"watched-{k}", header=dict(x["header"], frame_id=frame))
                   for k, x in enumerate(solved[:3])]
        c.send_and_collect(watched, timeout=10.0)
        mine = lambda: [m for m in got if not is_probe_markers(m)]  # noqa: E731
        peer.spin_until(lambda: len(mine()) >= len(watched), 10.0)
        peer.spin_for(0.3)
        assert len(mine()) == len(watched), f"{len(mine())} marker arrays for {len(watched)} watched candidates"
        assert all(m.markers and m.markers[0].header.frame_id == frame for m in mine()), \
            "markers of a candidate answered before anybody subscribed"
        received = len(got)
    finally:
        if sub is not None:
            peer.node.destroy_subscription(sub)
        peer.node.destroy_publisher(c.pub)
        peer.node.destroy_subscription(c.sub)
    n.stop_and_check(signal.SIGINT)
    built, published = markers_line(n)
    k = probes + len(watched)
    assert len(watched) < built <= k, f"{built} arrays built for {k} candidates sent while subscribed (none before)"
    assert published == built == received, f"built {built}, published {published}, received {received}"


# ---------------------------------------------------------------------------------------------------
# Names, namespaces, remaps, params file, signals
# ---------------------------------------------------------------------------------------------------
def test_namespace_and_node_name_remap(start_node, peer, grasp_node):
    n = start_node("--ros-args", "-r", "__ns:=/robot1", "-r", "__node:=gripper", "-p", "objective:=internal_force",
                   name="grasp_orient node /robot1/gripper")
    c = GraspClient(peer, ns="/robot1")
    try:
        c.ensure_roundtrip()
        assert peer.spin_until(lambda: ("gripper", "/robot1") in peer.node.get_node_names_and_namespaces(), 10.0), \
            f"('gripper', '/robot1') not among nodes {peer.node.get_node_names_and_namespaces()}"
        topics = dict(peer.node.get_topic_names_and_types())
        assert topics.get("/robot1/grip_recommendations") == [RECOMMENDATION_TYPE], topics
        assert topics.get("/robot1/grasp_candidates") == [CANDIDATE_TYPE], topics
        cands = load_paper_cases() + random_batch(30, SEED + 4, "ns")
        answers = c.send_and_collect(cands)
        check_against_solve(answers, cands, "--objective", "internal_force", expect={"objective": "internal_force"})
        assert Params(peer, "/robot1/gripper").get("objective") == ["internal_force"]
    finally:
        peer.node.destroy_publisher(c.pub)
        peer.node.destroy_subscription(c.sub)
    n.stop_and_check(signal.SIGTERM)


def test_topic_remap_and_params_file(start_node, peer, tmp_path, grasp_node):
    pf = tmp_path / "params.yaml"
    pf.write_text("/**:\n  ros__parameters:\n    objective: norm1\n    range: graspable\n"
                  "    friction_safety_factor: 1.25\n    record: false\n")
    n = start_node("--ros-args", "--params-file", str(pf), "-r", "__node:=remapped", "-r", "__ns:=/arm",
                   "-r", "grasp_candidates:=/arm_in/candidates", "-r", "grip_recommendations:=/arm_out/answers",
                   name="grasp_orient node /arm/remapped")
    c = GraspClient(peer, ns="")
    peer.node.destroy_publisher(c.pub)
    peer.node.destroy_subscription(c.sub)
    from grasp_orient.msg import GraspCandidate
    c.pub = peer.node.create_publisher(GraspCandidate, "/arm_in/candidates", reliable_qos(1000))
    c.sub = peer.node.create_subscription(GripRecommendation, "/arm_out/answers", c._on_answer, reliable_qos(1000))
    try:
        c.ensure_roundtrip()
        cands = random_batch(30, SEED + 5, "remap")
        answers = c.send_and_collect(cands)
        check_against_solve(answers, cands, "--objective", "norm1", "--range", "graspable",
                            "--friction-safety-factor", "1.25", expect={"objective": "norm1"})
        assert Params(peer, "/arm/remapped").get("objective", "range", "friction_safety_factor", "record") == \
            ["norm1", "graspable", 1.25, False]
    finally:
        peer.node.destroy_publisher(c.pub)
        peer.node.destroy_subscription(c.sub)
    n.stop_and_check(signal.SIGINT)


def test_sigint_exits_zero(start_node):
    n = start_node("--ros-args", "-r", "__node:=sigint_probe", "-r", "__ns:=/sigint",
                   name="grasp_orient node /sigint/sigint_probe")
    time.sleep(0.5)
    n.stop_and_check(signal.SIGINT)


# ---------------------------------------------------------------------------------------------------
# The example a user runs
# ---------------------------------------------------------------------------------------------------
def test_example_script(grasp_node, client, tmp_path):
    env = ros_env(DOMAIN_ID)
    r = run_python([str(EXAMPLE_SCRIPT)], env, timeout=60)
    assert r.returncode == 0, f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}"
    assert "paper-a" in r.stdout and "wrist rotation" in r.stdout and "deg" in r.stdout, r.stdout
    ref = run_solve(load_paper_cases()[:1])[0]
    assert f"{math.degrees(ref['wrist_rotation']):.5g} deg" in r.stdout, (ref["wrist_rotation"], r.stdout)

    f = tmp_path / "one.json"
    f.write_text(json.dumps(random_batch(1, SEED + 6, "example-file")[0]))
    r = run_python([str(EXAMPLE_SCRIPT), str(f)], env, timeout=60)
    assert r.returncode == 0 and "example-file-0" in r.stdout and "status 0" in r.stdout, \
        f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}"

    # no node on that namespace: a clear message and exit 1 within the timeout
    t0 = time.monotonic()
    r = run_python([str(EXAMPLE_SCRIPT), "--ns", "/nobody_here", "--timeout", "2"], env, timeout=60)
    assert r.returncode == 1 and f"ROS_DOMAIN_ID={DOMAIN_ID}" in r.stderr, (r.returncode, r.stderr)
    assert time.monotonic() - t0 < 20


def test_parameters_are_described_listed_and_set_atomically(peer, client):
    """describe_parameters states each parameter's doc, unit, range and constraints (from the declarations in
    src/config/params.rs); list_parameters, get_parameter_types and set_parameters_atomically answer as rclcpp's."""
    from rcl_interfaces.srv import DescribeParameters, GetParameterTypes, ListParameters, SetParametersAtomically

    node = "/grasp_orient"
    describe = peer.node.create_client(DescribeParameters, f"{node}/describe_parameters")
    names = ["friction_safety_factor", "qos_depth", "objective", "range_min", "use_sim_time", "no_such_parameter",
             "gravity", "gravity_frame", "tf_timeout", "objects_file"]
    ds = peer.call(describe, DescribeParameters.Request(names=names)).descriptors
    assert [d.name for d in ds] == names, [d.name for d in ds]
    by = dict(zip(names, ds))
    f = by["friction_safety_factor"]
    assert f.type == ParameterType.PARAMETER_DOUBLE and "friction coefficients" in f.description, f
    assert len(f.floating_point_range) == 1 and f.floating_point_range[0].from_value == 1.0, f
    assert f.floating_point_range[0].to_value == 1000.0 and not f.read_only, f
    q = by["qos_depth"]
    assert q.type == ParameterType.PARAMETER_INTEGER and q.read_only and "[messages]" in q.description, q
    assert [(r.from_value, r.to_value) for r in q.integer_range] == [(1, 100000)], q
    o = by["objective"]
    assert o.type == ParameterType.PARAMETER_STRING and "norm2, norm1, internal_force" in o.additional_constraints, o
    assert by["range_min"].description.endswith("[rad]"), by["range_min"]
    assert by["use_sim_time"].type == ParameterType.PARAMETER_BOOL
    assert by["no_such_parameter"].type == ParameterType.PARAMETER_NOT_SET

    listed = peer.call(peer.node.create_client(ListParameters, f"{node}/list_parameters"),
                       ListParameters.Request()).result.names
    want = {"objective", "range", "range_min", "range_max", "friction_safety_factor", "qos_depth", "publish_markers",
            "record", "record_dir", "record_markers", "gripper_drive", "max_grip_force", "rank_by", "max_set_size",
            "solver_threads", "max_set_time", "max_queued_sets",
            "center_of_mass_tolerance", "mass_tolerance", "closing_axis", "max_mesh_load_time",
            "max_inline_mesh_triangles", "mesh_roots", "max_mesh_file_bytes", "max_message_bytes", "gravity_frame",
            "gravity", "tf_timeout", "use_sim_time", "gripper_action", "parallel_gripper_action",
            "parallel_gripper_joints", "grip_safety_factor", "grip_position", "grip_timeout", "objects_file",
            "grasp_planner_action", "grasp_planner_timeout", "grasp_planner_width"}
    assert set(listed) == want, sorted(listed)
    g = by["gravity"]
    assert g.type == ParameterType.PARAMETER_DOUBLE_ARRAY and "[m/s²]" in g.description, g
    assert [(r.from_value, r.to_value) for r in g.floating_point_range] == [(-5000.0, 5000.0)], g
    assert by["gravity_frame"].type == ParameterType.PARAMETER_STRING, by["gravity_frame"]
    t = by["tf_timeout"]
    assert [(r.from_value, r.to_value) for r in t.floating_point_range] == [(0.0, 10.0)], t
    o = by["objects_file"]
    assert o.type == ParameterType.PARAMETER_STRING and o.read_only and "mass and friction" in o.description, o
    types = peer.call(peer.node.create_client(GetParameterTypes, f"{node}/get_parameter_types"),
                      GetParameterTypes.Request(names=["qos_depth", "record", "mesh_roots", "nothing"])).types
    assert list(types) == [ParameterType.PARAMETER_INTEGER, ParameterType.PARAMETER_BOOL,
                           ParameterType.PARAMETER_STRING_ARRAY, ParameterType.PARAMETER_NOT_SET], types

    atomic = peer.node.create_client(SetParametersAtomically, f"{node}/set_parameters_atomically")
    params = Params(peer)

    def set_atomically(**values):
        req = SetParametersAtomically.Request(parameters=[Parameter(name=k, value=pvalue(v)) for k, v in values.items()])
        return peer.call(atomic, req).result

    try:
        r = set_atomically(objective="norm1", friction_safety_factor=0.5)
        assert not r.successful and "friction_safety_factor" in r.reason, r
        assert params.get("objective", "friction_safety_factor") == ["norm2", 1.0], "a refused atomic set changed values"
        r = set_atomically(objective="norm1", friction_safety_factor=1.25)
        assert r.successful, r.reason
        assert params.get("objective", "friction_safety_factor") == ["norm1", 1.25]
    finally:
        res = params.set(objective="norm2", friction_safety_factor=1.0)
        assert all(r.successful for r in res), [r.reason for r in res]


def test_record_switched_off_and_on_by_parameter(peer, client, tmp_path):
    """record:=false closes the recording when it is set; record:=true starts a new file that holds
    exactly what was answered while it was on (read back with the mcap reader)."""
    import mcap_util as mu

    params = Params(peer)
    before = params.get("record", "record_dir")
    rec_dir = tmp_path / "toggled"
    try:
        for name, value in (("record", False), ("record_dir", str(rec_dir))):
            (r,) = params.set(**{name: value})
            assert r.successful, f"{name}={value!r} refused: {r.reason!r}"
        client.send_and_collect(random_batch(5, SEED + 7, "rec-off"))
        assert not rec_dir.exists() or not list(rec_dir.glob("*.mcap")), "recorded while off"
        (r,) = params.set(record=True)
        assert r.successful, r.reason
        on = random_batch(7, SEED + 8, "rec-on")
        client.send_and_collect(on)
        (r,) = params.set(record=False)
        assert r.successful, r.reason
        # Closed at once, with no candidate needed: the file ends with the MCAP magic.
        deadline = time.monotonic() + 5.0
        while not all(f.read_bytes().endswith(b"\x89MCAP0\r\n") for f in rec_dir.glob("*.mcap")):
            assert time.monotonic() < deadline, "record:=false did not close the file"
            time.sleep(0.02)
        client.send_and_collect(random_batch(2, SEED + 9, "rec-after"))
        files = sorted(rec_dir.glob("*.mcap"))
        assert len(files) == 1, f"expected one recording, found {files}"
        recs = mu.read_mcap(files[0])
        ids = [r.msg["id"] for r in recs if r.topic.endswith("grasp_candidates")]
        answered = [r.msg["candidate_id"] for r in recs if r.topic.endswith("grip_recommendations")]
        want = [c["id"] for c in on]
        assert sorted(ids) == sorted(want), f"recorded candidates {ids}, sent while on {want}"
        assert sorted(answered) == sorted(want), f"recorded answers {answered}"
    finally:
        params.set(record=before[0])
        params.set(record_dir=before[1])


def test_node_logs_to_rosout(peer, client):
    """A refused candidate is logged to /rosout as a warning naming it, as rclpy nodes log."""
    from rcl_interfaces.msg import Log
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    logs = []
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    sub = peer.node.create_subscription(Log, "/rosout", logs.append, qos)
    try:
        bad = copy.deepcopy(load_paper_cases()[0])
        bad["id"] = "rosout-probe"
        bad["mass"] = -1.0
        # Resend until the /rosout subscription has matched and the warning has come.
        deadline = time.monotonic() + 20.0
        found = []
        while time.monotonic() < deadline and not found:
            ans = client.send_one(bad, timeout=10.0)
            assert ans.status == GripRecommendation.STATUS_INVALID_INPUT
            peer.spin_until(lambda: any("rosout-probe" in m.msg for m in logs), 1.0)
            found = [m for m in logs if "rosout-probe" in m.msg]
        assert found, f"no /rosout message about the refused candidate; saw {[m.msg[:80] for m in logs][:5]}"
        assert found[0].level == Log.WARN, f"level {found[0].level}"
        assert found[0].name.endswith("grasp_orient"), f"logger name {found[0].name!r}"
        assert "mass" in found[0].msg
    finally:
        peer.node.destroy_subscription(sub)


def test_sustained_load_from_rcl_peer_none_lost(start_node):
    """10,000 candidates at 5,000 per second from one rcl publisher process (rmw_fastrtps_cpp, no Python per
    message), answers collected by another: every candidate is answered exactly once. No timing is asserted
    (the benchmark measures rates); this checks that a sustained stream loses nothing and that the rcl peer
    works."""
    import rcl_peer

    count, rate = 10_000, 5_000
    n = start_node("--ros-args", "-r", "__ns:=/load", "-r", "__node:=load_probe",
                   "-p", f"qos_depth:={count + 100}", "-p", "publish_markers:=false", "-p", "record:=false",
                   name="grasp_orient node (load)")
    run = rcl_peer.offered_load("/load/grasp_candidates", "/load/grip_recommendations", "recommendation",
                                rate=rate, count=count, tag="load", depth=count + 100, idle=15.0)
    assert run.publisher["acked"], f"the node did not acknowledge every candidate: {run.publisher}"
    assert run.lost == 0, f"{run.lost} of {count} candidates unanswered: {run.collector}\n{n.output(20)}"
    assert run.collector["duplicates"] == 0, f"answered twice: {run.collector}"
    assert run.collector["other"] == 0, f"answers with ids that were never sent: {run.collector}"
    n.stop_and_check()
    assert any(f"answered {count} candidates" in line for line in n.lines), n.output(5)
