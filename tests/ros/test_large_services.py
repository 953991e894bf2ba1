"""Large service requests and replies between rclpy (Fast DDS) and the node (RustDDS).

A reply that does not fit one datagram (about 1.3 kB here) goes out as RTPS DATA_FRAGs, and a service reply
carries the request's identity as inline QoS. RustDDS 0.15.1 wrote that inline QoS with a stray byte in front,
so no such reply ever reached an rclpy client, and in a debug build the node's DDS thread died on the way.
These tests drive the parameter services, which ros2-client answers like any other service, with
requests and replies from 10 kB to 1 MB, and check that the same clients are answered afterwards.
"""
from __future__ import annotations

import time

import pytest

from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import GetParameters, SetParameters  # noqa: E402

NODE = "/grasp_orient_large"
LARGE_CALL_TIMEOUT_S = 30.0
# One value of `objective` ("norm2") in a GetParameters reply: 56 bytes of CDR.
VALUE_BYTES = 56


@pytest.fixture(scope="module")
def large_node(start_node):
    """A node of its own, so that a failure here cannot take the shared node's services down."""
    n = start_node("--ros-args", "-r", "__node:=grasp_orient_large", "-p", "record:=false",
                   name=f"grasp_orient node {NODE}")
    yield n
    n.stop_and_check()


class Services:
    """A SetParameters and a GetParameters client of the node, kept for the whole module."""

    def __init__(self, peer):
        self.peer = peer
        self.set_client = peer.node.create_client(SetParameters, f"{NODE}/set_parameters")
        self.get_client = peer.node.create_client(GetParameters, f"{NODE}/get_parameters")

    def call(self, client, request, what: str, timeout: float = LARGE_CALL_TIMEOUT_S):
        """The reply and the round trip in ms; fails naming the call when no reply comes."""
        assert client.wait_for_service(timeout_sec=15.0), f"{client.srv_name} not available"
        t0 = time.monotonic()
        fut = client.call_async(request)
        ok = self.peer.spin_until(fut.done, timeout, step=0.005)
        ms = 1e3 * (time.monotonic() - t0)
        assert ok, f"no reply within {timeout:.0f} s to {what} on {client.srv_name}"
        return fut.result(), ms

    def get_objective_many(self, count: int):
        reply, ms = self.call(self.get_client, GetParameters.Request(names=["objective"] * count),
                              f"a get of {count} values (reply ~{count * VALUE_BYTES / 1e3:.0f} kB)")
        values = [v.string_value for v in reply.values]
        assert len(values) == count, f"{len(values)} values for {count} names"
        wrong = [v for v in values if v != "norm2"]
        assert not wrong, f"{len(wrong)} of {count} values are not 'norm2' (first: {wrong[0][:40]!r})"
        return ms

    def still_answered(self, after: str):
        """Small calls on both services, from the same clients, right after a large one."""
        reply, _ = self.call(self.get_client, GetParameters.Request(names=["objective", "qos_depth"]),
                             f"a small get after {after}", timeout=10.0)
        assert [reply.values[0].string_value, reply.values[1].integer_value] == ["norm2", 100]
        req = SetParameters.Request(parameters=[Parameter(
            name="objective", value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="norm2"))])
        reply, _ = self.call(self.set_client, req, f"a small set after {after}", timeout=10.0)
        assert [r.successful for r in reply.results] == [True], reply


@pytest.fixture(scope="module")
def services(peer, large_node):
    s = Services(peer)
    s.still_answered("start-up")
    return s


def test_get_replies_of_10_kb_and_1_mb_reach_rclpy(services):
    times = {}
    for size_kb in (2, 10, 100, 1000):
        count = size_kb * 1000 // VALUE_BYTES + 1
        times[size_kb] = services.get_objective_many(count)
        services.still_answered(f"a {size_kb} kB reply")
    print("GetParameters round trips: " + ", ".join(f"{k} kB {v:.1f} ms" for k, v in times.items()))


def test_long_string_value_comes_back_whole(services):
    # The case first reported: a get of a 2,000-character record_dir, then 10 kB.
    for n in (2000, 10_000):
        path = "runs/" + "d" * (n - 5)
        req = SetParameters.Request(parameters=[Parameter(
            name="record_dir", value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=path))])
        reply, _ = services.call(services.set_client, req, f"a set of a {n}-character record_dir")
        assert reply.results[0].successful, f"record_dir of {n} characters refused: {reply.results[0].reason}"
        reply, _ = services.call(services.get_client, GetParameters.Request(names=["record_dir"]),
                                 f"a get of a {n}-character record_dir")
        assert reply.values[0].string_value == path, f"record_dir came back with {len(reply.values[0].string_value)} characters"
        services.still_answered(f"a get of a {n}-character record_dir")
    req = SetParameters.Request(parameters=[Parameter(
        name="record_dir", value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="runs"))])
    reply, _ = services.call(services.set_client, req, "restoring record_dir")
    assert reply.results[0].successful, reply.results[0].reason


@pytest.mark.parametrize("count,name_len", [(1000, 20), (2000, 500)], ids=["1000-entries", "1MB-request"])
def test_refused_sets_with_many_entries_are_answered(services, count, name_len):
    # Each unknown parameter is refused with a reason naming it: a 1,000-entry set (a ~70 kB reply), and
    # 2,000 names of 500 characters (a ~1 MB request and a ~1.1 MB reply).
    names = [f"no_such_parameter_{i:05d}_".ljust(name_len, "z") for i in range(count)]
    req = SetParameters.Request(parameters=[Parameter(
        name=n, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=1.0)) for n in names])
    reply, ms = services.call(services.set_client, req, f"a set of {count} unknown parameters")
    assert len(reply.results) == count, f"{len(reply.results)} results for {count} parameters"
    accepted = [n for n, r in zip(names, reply.results) if r.successful]
    assert not accepted, f"{len(accepted)} unknown parameters accepted, first {accepted[0][:40]!r}"
    unnamed = [n for n, r in zip(names, reply.results) if n not in r.reason]
    assert not unnamed, f"{len(unnamed)} refusals do not name their parameter, first {unnamed[0][:40]!r}"
    size = sum(len(r.reason) for r in reply.results)
    print(f"a set of {count} unknown parameters: reasons total {size / 1e3:.0f} kB, round trip {ms:.1f} ms")
    services.still_answered(f"a set of {count} unknown parameters")
