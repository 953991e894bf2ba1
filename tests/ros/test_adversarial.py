"""The adversarial catalogue: everything odd that can reach the live node, one case each, and after every
one a good candidate answered exactly as `grasp_orient solve` answers it.

- Candidates the solver refuses (the 15 kinds of test_node.py, and the sizes the contract refuses): status 2
  naming the field. Grasps at extreme but admitted magnitudes: status 0 without a NaN, as `solve` answers.
- Payloads that are not a GraspCandidate (empty, truncated, lying lengths, another message type): no answer,
  a counted and logged refusal, and the same publisher's next candidate answered at once.
- Parameters out of their domain: refused with the reason; bounds of any span: answered at once.
- A stop request with seconds of work queued: exit within a second, the work left undone. --log-level: the level the user asked for.
"""
from __future__ import annotations

import copy
import math
import re
import signal
import struct
import time

import pytest

from conftest import GraspClient, candidate_msg, compare, load_paper_cases, reliable_qos, run_solve, to_plain
from test_node import SEED, Params, _bad_cases, check_against_solve, random_batch

from grasp_orient.msg import GraspCandidate, GripRecommendation  # noqa: E402

UNDECODABLE = re.compile(r"could not be decoded .*; (\d+) so far")


def undecodable(node) -> int:
    """The node's count of undecodable messages, from its last warning (0 before the first)."""
    with node._lock:
        counts = [int(m.group(1)) for line in node.lines if (m := UNDECODABLE.search(line))]
    return max(counts, default=0)


_goods = iter(random_batch(200, SEED + 90, "adversarial-good"))


def good_one_answered(client, timeout: float = 5.0):
    """A fresh good candidate from the same publisher is answered within `timeout`, as `solve` answers it."""
    good = next(_goods)
    answers = client.send_and_collect([good], timeout=timeout)
    check_against_solve(answers, [good])


def no_nan_with_status_0(ans):
    plain = to_plain(ans)
    if ans.status != 0:
        return
    for k in ("wrist_rotation", "gravity_angle", "gripping_power", "internal_force"):
        assert plain[k] is not None, f"{k} is NaN or infinite with status 0: {plain}"
    assert all(v is not None for v in plain["contact_forces"]), plain["contact_forces"]
    assert all(plain["rotation"][k] is not None for k in "xyzw"), plain["rotation"]


# ---------------------------------------------------------------------------------------------------
# Candidates: refused ones name the field; extreme admitted ones are answered without a NaN
# ---------------------------------------------------------------------------------------------------
def _scaled(c: dict, field: str, k: float) -> dict:
    c = copy.deepcopy(c)
    if isinstance(c[field], dict):
        c[field] = {a: v * k for a, v in c[field].items()}
    else:
        c[field] *= k
    return c


BASE = load_paper_cases()[0]
CANDIDATES = [(f"kind: {name}", cand, words, 2) for name, cand, words, _ in _bad_cases(BASE)] + [
    ("gravity 1e-163", _scaled(BASE, "gravity", 1e-163), [], 0),
    ("normals 1e-170", _scaled(_scaled(BASE, "normal_1", 1e-170), "normal_2", 1e-170), [], 0),
    ("mass 1e-300", dict(BASE, mass=1e-300), [], 0),
    ("contacts and centre of mass 1e-300 m", _scaled(_scaled(_scaled(BASE, "contact_1", 1e-300), "contact_2",
                                                                 1e-300), "center_of_mass", 1e-300), [], 0),
    ("weight below the smallest double", _scaled(dict(BASE, mass=1e-300), "gravity", 1e-10), ["mass", "gravity"],
     2),
    ("friction 1e-9", dict(BASE, friction_1=1e-9), ["friction_1"], 2),
    ("normals 1e300", _scaled(BASE, "normal_1", 1e300), ["normal_1"], 2),
    ("gravity 1e300", _scaled(BASE, "gravity", 1e300), ["gravity"], 2),
]


@pytest.mark.parametrize("name,cand,words,status", CANDIDATES, ids=[c[0] for c in CANDIDATES])
def test_candidate(client, name, cand, words, status):
    if cand["id"] == BASE["id"]:
        cand = dict(cand, id=f"adversarial {name}")
    ans = client.send_one(cand, timeout=15.0)
    assert ans.status == status, f"status {ans.status}, expected {status}: {ans.message!r}"
    missing = [w for w in words if w not in ans.message]
    assert not missing, f"message {ans.message[:200]!r} does not name {missing}"
    no_nan_with_status_0(ans)
    if len(cand["id"]) <= 1024 and all(math.isfinite(x) for x in _numbers(cand)):
        (r,) = run_solve([cand])
        diff = compare(to_plain(ans), r)
        assert not diff, f"differs from solve: {diff[:4]}"
    good_one_answered(client)


def _numbers(c):
    for v in c.values():
        if isinstance(v, dict):
            yield from _numbers(v)
        elif isinstance(v, float):
            yield v


# ---------------------------------------------------------------------------------------------------
# Payloads that are not a GraspCandidate: counted, logged, and the stream goes on
# ---------------------------------------------------------------------------------------------------
def _valid_bytes() -> bytes:
    from rclpy.serialization import serialize_message
    return serialize_message(candidate_msg(dict(BASE, id="serialized")))


PAYLOADS = [
    ("zero-length payload", lambda: b""),
    ("encapsulation header only", lambda: b"\x00\x01\x00\x00"),
    ("truncated candidate", lambda: _valid_bytes()[:40]),
    ("string claiming 4 GB", lambda: b"\x00\x01\x00\x00" + struct.pack("<iI", 0, 0) + struct.pack("<I", 0xFFFFFFF0)
     + b"x" * 64),
    ("unknown encapsulation", lambda: b"\x7f\x7f\x00\x00" + _valid_bytes()[4:]),
]


@pytest.mark.parametrize("name,payload", PAYLOADS, ids=[p[0] for p in PAYLOADS])
def test_payload_is_counted_and_the_stream_goes_on(client, grasp_node, name, payload):
    before = undecodable(grasp_node)
    client.pub.publish(payload())
    # The same publisher's next candidate is answered at once: nothing waits for the bad sample.
    good_one_answered(client, timeout=5.0)
    assert client.peer.spin_until(lambda: undecodable(grasp_node) == before + 1, 5.0), \
        f"{name}: undecodable count {undecodable(grasp_node)}, expected {before + 1}"


def test_another_message_type_on_the_topic(peer, client, grasp_node):
    """A std_msgs/String publisher on grasp_candidates (from a participant of its own: Fast DDS refuses two
    types for one topic in one participant). DDS may match it with the node's reader (then each message is
    a counted refusal) or not (then nothing arrives); either way the node serves on."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import String
    before = undecodable(grasp_node)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        other = rclpy.create_node("wrong_type_peer", context=ctx)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(other)
        pub = other.create_publisher(String, "grasp_candidates", reliable_qos(10))
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline and pub.get_subscription_count() == 0:
            ex.spin_once(timeout_sec=0.05)
        matched = pub.get_subscription_count() > 0
        print(f"String publisher matched the node: {matched}")
        for k in range(3):
            pub.publish(String(data=f"not a grasp {k}"))
        deadline = time.monotonic() + 1.0
        while time.monotonic() < deadline:
            ex.spin_once(timeout_sec=0.05)
        if matched:
            assert peer.spin_until(lambda: undecodable(grasp_node) == before + 3, 5.0), \
                f"matched, but {undecodable(grasp_node) - before} of 3 counted"
        else:
            peer.spin_for(1.0)
            assert undecodable(grasp_node) == before
        ex.shutdown()
        other.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)
    good_one_answered(client)


# ---------------------------------------------------------------------------------------------------
# Parameters: every number in its domain; bounds of any span cost nothing
# ---------------------------------------------------------------------------------------------------
def test_bounds_of_any_span_are_answered_at_once(peer, client):
    params = Params(peer)
    cands = load_paper_cases()
    try:
        res = params.set(range="bounds", range_min=-1e308, range_max=1e308)
        assert all(r.successful for r in res), [r.reason for r in res]
        answers = client.send_and_collect(cands, timeout=10.0)
        check_against_solve(answers, cands, "--range", "graspable")
    finally:
        res = params.set(range="from_above", range_min=-math.pi, range_max=math.pi)
        assert all(r.successful for r in res), [r.reason for r in res]
    good_one_answered(client)


@pytest.mark.parametrize("name,value", [
    ("range_min", math.nan), ("range_max", math.inf), ("range_min", -math.inf),
    ("friction_safety_factor", math.nan), ("friction_safety_factor", 1e9), ("friction_safety_factor", 0.5),
    ("qos_depth", 0),
])
def test_parameter_out_of_its_domain_is_refused(peer, client, name, value):
    params = Params(peer)
    (old,) = params.get(name)
    (r,) = params.set(**{name: value})
    assert not r.successful, f"{name}={value} accepted (range is {params.get('range')[0]})"
    assert name in r.reason or "fixed" in r.reason, r.reason
    assert params.get(name) == [old]
    good_one_answered(client)


def test_tolerances_every_candidate_would_be_refused_for_are_refused_when_set(peer, client):
    """A center_of_mass_tolerance of 1e6 m was accepted, and then every candidate was refused for a field it
    left at zero; the domains now end where the solver's limits do, and the service says why."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    params = Params(peer)
    box = ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=[1e6, 0.0, 0.0])
    mass = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=1e9)
    for name, value, words in [
            ("center_of_mass_tolerance", box, "center_of_mass_tolerance: x: must be in [0, 1e6), got 1e6"),
            ("mass_tolerance", mass, "mass_tolerance: must be in [0, 1e9), got 1e9")]:
        req = SetParameters.Request(parameters=[Parameter(name=name, value=value)])
        (r,) = peer.call(params.set_client, req).results
        assert not r.successful, f"{name} accepted"
        assert words in r.reason, r.reason
    assert params.get("mass_tolerance") == [0.0]
    good_one_answered(client)


def test_descriptors_state_every_numeric_domain(peer, client):
    from rcl_interfaces.srv import DescribeParameters
    cl = peer.node.create_client(DescribeParameters, "/grasp_orient/describe_parameters")
    names = ["range_min", "range_max", "friction_safety_factor", "qos_depth"]
    d = {x.name: x for x in peer.call(cl, DescribeParameters.Request(names=names)).descriptors}
    for n in ("range_min", "range_max"):
        (r,) = d[n].floating_point_range
        assert (r.from_value, r.to_value) == (-1.7976931348623157e308, 1.7976931348623157e308), (n, r)
    (r,) = d["friction_safety_factor"].floating_point_range
    assert (r.from_value, r.to_value) == (1.0, 1000.0), r
    (r,) = d["qos_depth"].integer_range
    assert (r.from_value, r.to_value) == (1, 100000), r
    peer.node.destroy_client(cl)


# ---------------------------------------------------------------------------------------------------
# The process: stop requests, log levels, params files
# ---------------------------------------------------------------------------------------------------
def test_stop_request_honoured_within_a_second_with_work_queued(start_node, peer):
    """With slow candidates queued (bounds 1e8 rad wide took seconds each) SIGTERM took 9 s. Candidates are
    cheap now, so the queue here is of sets of 10,000 candidates (tens of ms each, answers of about 3 MB):
    seconds of work in all. The node must stop within a second and leave most of it unanswered, which a
    loop that drained its queue before looking at the signal would not."""
    from rclpy.serialization import serialize_message

    from grasp_orient.msg import GraspCandidateSet, GripRecommendationSet

    n = start_node("--ros-args", "-r", "__ns:=/slow", "-r", "__node:=slow", "-p", "record:=false",
                   "-p", "publish_markers:=false", "-p", "qos_depth:=100", "--log-level", "debug",
                   name="grasp_orient node /slow (sets of 10,000 queued)")
    sets, per_set = 40, 10_000
    big = GraspCandidateSet()
    big.id = "queued"
    big.candidates = [candidate_msg(c) for c in random_batch(per_set, SEED + 91, "queued")]
    raw = serialize_message(big)
    pub = peer.node.create_publisher(GraspCandidateSet, "/slow/grasp_candidate_sets", reliable_qos(sets))
    sub = peer.node.create_subscription(GripRecommendationSet, "/slow/grip_recommendation_sets",
                                        lambda m: None, reliable_qos(sets), raw=True)
    try:
        assert peer.spin_until(lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0, 10.0), \
            "the node's set topics did not match"
        for _ in range(sets):
            pub.publish(raw)
        # The node's own line for its first set: from then on it has the other sets to answer.
        n.wait_for_line(r'set "queued" \(topic\): 10000 candidates', timeout=60.0)
        t0 = time.monotonic()
        n.proc.send_signal(signal.SIGTERM)
        rc = n.proc.wait(30)
        took = time.monotonic() - t0
    finally:
        peer.node.destroy_publisher(pub)
        peer.node.destroy_subscription(sub)
    assert rc == 0, f"exit {rc}\n{n.output(20)}"
    assert took < 1.0, f"SIGTERM honoured after {took:.2f} s\n{n.output(20)}"
    done = [int(m.group(1)) for m in map(re.compile(r"answered (\d+) candidates").search, n.all_lines()) if m]
    assert done, f"no summary line\n{n.output(20)}"
    assert done[-1] < sets * per_set // 2, \
        f"{done[-1]} of {sets * per_set} candidates answered: the queue was drained before the stop\n{n.output(20)}"


def _debug_lines(node, cid: str) -> list[str]:
    with node._lock:
        return [line for line in node.lines if "DEBUG" in line and cid in line]


def _one_candidate(peer, ns: str, cid: str):
    c = GraspClient(peer, ns=ns)
    try:
        c.ensure_roundtrip()
        c.send_one(dict(BASE, id=cid))
    finally:
        peer.node.destroy_publisher(c.pub)
        peer.node.destroy_subscription(c.sub)


def test_log_level_debug_shows_debug_lines_and_the_default_does_not(start_node, peer, client, grasp_node):
    n = start_node("--ros-args", "-r", "__ns:=/dbg", "--log-level", "debug", "-p", "record:=false",
                   name="grasp_orient node /dbg (--log-level debug)")
    _one_candidate(peer, "/dbg", "debug-probe")
    assert n.proc.poll() is None
    assert peer.spin_until(lambda: _debug_lines(n, "debug-probe"), 5.0), n.output(20)
    n.stop_and_check()
    client.send_one(dict(BASE, id="no-debug-probe"))
    assert not _debug_lines(grasp_node, "no-debug-probe"), grasp_node.output(5)


def test_log_level_for_one_logger_and_params_file_for_another_node(start_node, peer, tmp_path):
    pf = tmp_path / "other.yaml"
    pf.write_text("some_other_node:\n  ros__parameters:\n    objective: norm1\n")
    n = start_node("--ros-args", "-r", "__ns:=/named", "--log-level", "grasp_orient:=debug", "--log-level",
                   "rustdds:=unset", "--params-file", str(pf), "-p", "record:=false",
                   name="grasp_orient node /named (--log-level grasp_orient:=debug)")
    _one_candidate(peer, "/named", "named-probe")
    assert peer.spin_until(lambda: _debug_lines(n, "named-probe"), 5.0), n.output(20)
    with n._lock:
        warned = [line for line in n.lines if "WARN" in line and "no section applies" in line]
    assert warned and "some_other_node" in warned[0], n.output(20)
    n.stop_and_check()


def test_log_level_fatal_hides_info(start_node, peer):
    n = start_node("--ros-args", "-r", "__ns:=/quiet", "--log-level", "FATAL", "-p", "record:=false",
                   name="grasp_orient node /quiet (--log-level fatal)", ready=False)
    c = GraspClient(peer, ns="/quiet")
    try:
        c.ensure_roundtrip()
    finally:
        peer.node.destroy_publisher(c.pub)
        peer.node.destroy_subscription(c.sub)
    n.stop_and_check()
    with n._lock:
        assert not any("INFO" in line or "WARN" in line for line in n.lines), n.output(20)


def test_a_node_of_the_same_name_on_the_domain_is_warned_of(start_node, peer):
    """Two nodes of one full name share their parameter services and /rosout logger; rcl warns only of a
    namesake in its own process. The node warns once, on stderr and /rosout, when an rclpy node of its name
    joins the domain, and `get_node_names` shows both."""
    import rclpy
    from rcl_interfaces.msg import Log
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    n = start_node("--ros-args", "-r", "__ns:=/twin", "-p", "record:=false", name="grasp_orient node /twin")
    logs = []
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
    sub = peer.node.create_subscription(Log, "/rosout", logs.append, qos)
    peer.spin_until(lambda: sub.get_publisher_count() > 1, 5.0)
    peer.spin_for(1.0)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    warning = "another node named /twin/grasp_orient is on the ROS graph"
    try:
        twin = rclpy.create_node("grasp_orient", namespace="/twin", context=ctx)
        n.wait_for_line(re.escape(warning), timeout=15.0)
        assert peer.spin_until(lambda: any(warning in m.msg for m in logs), 10.0), \
            f"not on /rosout; saw {[m.msg[:80] for m in logs][:5]}"
        (log,) = [m for m in logs if warning in m.msg]
        assert log.level == Log.WARN and log.name.endswith("grasp_orient"), log
        assert peer.spin_until(lambda: peer.node.get_node_names_and_namespaces().count(
            ("grasp_orient", "/twin")) == 2, 5.0), peer.node.get_node_names_and_namespaces()
        peer.spin_for(1.0)
        assert sum(warning in line for line in n.all_lines()) == 1, n.output(20)
        twin.destroy_node()
    finally:
        peer.node.destroy_subscription(sub)
        rclpy.try_shutdown(context=ctx)
    n.stop_and_check()
