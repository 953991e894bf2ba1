#!/usr/bin/env python3
"""Smoke test of the ROS 2 Jazzy peer made by tests/peer/setup.sh.

Publishes a grasp_orient/msg/GraspCandidate on `grasp_candidates` with rclpy over Fast DDS and receives it
back with an rclpy subscriber in the same process; checks every field survived the round trip.

    source "$(tests/peer/setup.sh | tail -n1)" && python tests/peer/smoke_pubsub.py

Exit status 0 when the message came back intact within the timeout (10 s), 1 otherwise.
Runs on ROS_DOMAIN_ID 57 (GRASP_ORIENT_SMOKE_DOMAIN_ID overrides) with discovery limited to this host.
"""
import math
import os
import sys
import time

# Keep the traffic on this machine and off domain 0; must be set before rclpy initialises.
os.environ["ROS_DOMAIN_ID"] = os.environ.get("GRASP_ORIENT_SMOKE_DOMAIN_ID", "57")
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_LOCALHOST_ONLY", None)  # deprecated in Jazzy; the range above replaces it
os.environ.pop("ROS_STATIC_PEERS", None)
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")

TOPIC = "grasp_candidates"
TYPE_NAME = "grasp_orient/msg/GraspCandidate"
TIMEOUT_S = 10.0


def fail(msg: str) -> "None":
    print(f"smoke_pubsub: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


try:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
    from grasp_orient.msg import GraspCandidate
except ImportError as e:  # pragma: no cover - environment problem
    fail(f"{e}: run with the peer venv's python after `source <peer dir>/env.sh` (tests/peer/setup.sh)")


def make_candidate() -> GraspCandidate:
    m = GraspCandidate()
    m.header.stamp.sec = 1_700_000_000
    m.header.stamp.nanosec = 123_456_789
    m.header.frame_id = "object"
    m.id = "smoke-1 ünïcode"
    m.contact_1.x, m.contact_1.y, m.contact_1.z = -0.03, 0.01, 0.0
    m.contact_2.x, m.contact_2.y, m.contact_2.z = 0.03, -0.005, 0.0
    m.normal_1.x, m.normal_1.y, m.normal_1.z = 1.0, 0.0, 0.0
    m.normal_2.x, m.normal_2.y, m.normal_2.z = -1.0, 0.1, 0.0
    m.friction_1 = 0.5
    m.friction_2 = 0.35
    m.center_of_mass.x, m.center_of_mass.y, m.center_of_mass.z = 0.002, 0.004, 0.0
    m.mass = 0.25
    m.gravity.x, m.gravity.y, m.gravity.z = 0.0, -9.81, 0.0
    return m


def fields(m) -> dict:
    """Flatten a message into {dotted.field: value}."""
    out = {}
    for name in m.get_fields_and_field_types():
        v = getattr(m, name)
        if hasattr(v, "get_fields_and_field_types"):
            out.update({f"{name}.{k}": x for k, x in fields(v).items()})
        else:
            out[name] = v
    return out


def main() -> int:
    rclpy.init()
    try:
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
        pub_node = rclpy.create_node("grasp_orient_smoke_pub")
        sub_node = rclpy.create_node("grasp_orient_smoke_sub")
        received = []
        sub_node.create_subscription(GraspCandidate, TOPIC, received.append, qos)
        pub = pub_node.create_publisher(GraspCandidate, TOPIC, qos)
        sent = make_candidate()

        executor = SingleThreadedExecutor()
        executor.add_node(pub_node)
        executor.add_node(sub_node)

        t0 = time.monotonic()
        next_pub = t0
        n_pub = 0
        while not received and time.monotonic() - t0 < TIMEOUT_S:
            if time.monotonic() >= next_pub:
                pub.publish(sent)  # repeated until discovery has matched the pair
                n_pub += 1
                next_pub += 0.2
            executor.spin_once(timeout_sec=0.05)
        elapsed = time.monotonic() - t0

        if not received:
            fail(f"no {TYPE_NAME} received on '{TOPIC}' within {TIMEOUT_S:.0f} s "
                 f"({n_pub} published, {pub.get_subscription_count()} matched subscriptions, "
                 f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']})")

        got = received[0]
        if not isinstance(got, GraspCandidate):
            fail(f"received a {type(got).__name__}, not GraspCandidate")
        a, b = fields(sent), fields(got)
        bad = [k for k in a if not (a[k] == b.get(k) or (isinstance(a[k], float) and math.isclose(a[k], b.get(k, math.nan))))]
        if bad:
            fail("fields changed in transit: " + ", ".join(f"{k}: {a[k]!r} -> {b.get(k)!r}" for k in bad))

        rmw = rclpy.get_rmw_implementation_identifier()
        if rmw != "rmw_fastrtps_cpp":
            fail(f"running on {rmw}, expected rmw_fastrtps_cpp")

        types = dict(sub_node.get_topic_names_and_types())
        if TYPE_NAME not in types.get("/" + TOPIC, []):
            fail(f"graph shows /{TOPIC} with types {types.get('/' + TOPIC)}, expected {TYPE_NAME}")

        print(f"smoke_pubsub: OK: {TYPE_NAME} round trip on /{TOPIC} in {elapsed:.2f} s "
              f"({n_pub} published, {len(received)} received, {len(a)} fields checked, "
              f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}, rmw={rmw}, "
              f"discovery range LOCALHOST)")
        executor.shutdown()
        pub_node.destroy_node()
        sub_node.destroy_node()
        return 0
    finally:
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
