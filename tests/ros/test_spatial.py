"""Spatial candidates (`model` 1) through the live node, from rclpy over Fast DDS:

- random spatial grasps of every kind (in the plane, tilted normals, centre of mass near and on the contact
  axis), in random 3D frames and units: every answer equals what `grasp_orient solve` prints for the same JSON
  line, bit for bit; answers where the object would swing have infinite current-pose fields and say so, and
  answers on or near the axis say they are sensitive;
- the bad-input catalogue of the spatial model: every case answered with status 2 naming the field (status 1
  naming the contact for a normal tilted beyond its friction angle), equal to `solve` where JSON can carry it,
  and a good spatial candidate right after it answered as `solve` answers it;
- spatial candidates in a set, on `grasp_candidate_sets` and through `~/recommend`: both answers equal, each
  recommendation equal to `solve`'s, the whole answer equal to `grasp_orient rank --json`'s; a set whose best
  candidate is spatial gets 3D markers;
- the markers of a spatial answer are drawn in 3D and obey the physics: the forces balance the weight along the
  recommended gravity, and lie in their true 3D cones;
- a recording of spatial candidates (with markers) replays without a difference.

Nothing here skips: a missing rclpy or binary fails with the reason.
"""
from __future__ import annotations

import copy
import json
import math
import random
import signal
import subprocess

import mcap_util as mu
from conftest import GraspClient, Peer, binary_path, compare, reliable_qos, run_solve, to_plain
from test_node import check_against_solve

from grasp_orient.msg import GraspCandidate, GripRecommendation  # noqa: E402

SEED = 111111
N_RANDOM = 400


def spatial_batch(n: int, seed: int, prefix: str) -> list[dict]:
    """n random spatial grasps, the kinds in turn, floats cut to 15 significant digits."""
    rng = random.Random(seed)
    frames = ["object", "camera_optical", "tool0", "world"]
    kinds = mu.SPATIAL_KINDS
    return [mu.quantize(mu.random_spatial_grasp(rng, f"{prefix}-{k}", kinds[k % len(kinds)], frames[k % 4]))
            for k in range(n)]


def upright_square(cid: str) -> dict:
    """The paper's case (c) square stood up in the y-z plane of its frame, gravity along -z: the planar answer
    in that plane, turned about x."""
    return {
        "header": {"stamp": {"sec": 7, "nanosec": 11}, "frame_id": "tool0"},
        "id": cid,
        "contact_1": {"x": 0.0, "y": 0.04, "z": 0.3},
        "contact_2": {"x": 0.0, "y": -0.04, "z": 0.3},
        "normal_1": {"x": 0.0, "y": -1.0, "z": 0.0},
        "normal_2": {"x": 0.0, "y": 1.0, "z": 0.0},
        "friction_1": 3 ** 0.5,
        "friction_2": 3 ** -0.5,
        "center_of_mass": {"x": 0.0, "y": 0.0, "z": 0.26},
        "mass": 0.5,
        "gravity": {"x": 0.0, "y": 0.0, "z": -9.81},
        "model": 1,
    }


def test_model_field_is_in_the_message():
    assert GraspCandidate.MODEL_PLANAR == 0 and GraspCandidate.MODEL_SPATIAL == 1
    assert GraspCandidate().model == GraspCandidate.MODEL_PLANAR, "a candidate without a model is planar"
    assert "rotation_axis" in GripRecommendation.get_fields_and_field_types()


# ---------------------------------------------------------------------------------------------------
# Answers
# ---------------------------------------------------------------------------------------------------
def test_spatial_candidates_equal_solve(client):
    cands = spatial_batch(N_RANDOM, SEED, "spatial") + [upright_square("upright")]
    answers = client.send_and_collect(cands, timeout=120.0)
    ref = check_against_solve(answers, cands)
    same = sum(1 for c, r in zip(cands, ref) if to_plain(answers[c["id"]]) == r)
    assert same == len(cands), f"only {same} of {len(cands)} spatial answers are bit-identical to solve's"
    statuses = [a.status for a in answers.values()]
    assert statuses.count(0) == len(cands), f"statuses {sorted(set(statuses))}: the generator makes held grasps"

    swings = [a for a in answers.values() if math.isinf(a.gripping_power_current)]
    held = [a for a in answers.values() if math.isfinite(a.gripping_power_current)]
    sensitive = [a for a in answers.values() if "sensitive" in a.message]
    assert len(swings) > N_RANDOM // 4 and len(held) > N_RANDOM // 8, (len(swings), len(held))
    assert len(sensitive) >= N_RANDOM // 2 - 5, f"near- and on-axis grasps are half the batch: {len(sensitive)}"
    for a in swings:
        assert math.isinf(a.internal_force_current) and "swings about the contact axis" in a.message, to_plain(a)
    for c in cands:
        a = answers[c["id"]]
        k = (a.rotation_axis.x, a.rotation_axis.y, a.rotation_axis.z)
        assert abs(math.sqrt(sum(x * x for x in k)) - 1.0) < 1e-12, f"{c['id']}: rotation_axis {k} is not a unit"
        assert 0.0 <= a.wrist_rotation <= math.pi, f"{c['id']}: wrist_rotation {a.wrist_rotation} not in [0, pi]"
        q = a.rotation
        assert abs(2.0 * math.atan2(math.sqrt(q.x ** 2 + q.y ** 2 + q.z ** 2), q.w) - a.wrist_rotation) < 1e-12
        # the rotation takes the recommended gravity to the current one: R d = g / |g|
        d = (a.gravity_direction.x, a.gravity_direction.y, a.gravity_direction.z)
        g = (c["gravity"]["x"], c["gravity"]["y"], c["gravity"]["z"])
        gn = math.sqrt(sum(x * x for x in g))
        turned = _rotate(k, a.wrist_rotation, d)
        assert all(abs(t - x / gn) < 1e-9 for t, x in zip(turned, g)), f"{c['id']}: R d = {turned}, g = {g}"

    up = answers["upright"]
    assert abs(up.wrist_rotation - math.pi / 12) < 1e-12 and abs(abs(up.rotation_axis.x) - 1.0) < 1e-12, to_plain(up)
    assert up.recommended_label == "C" and up.message == "", to_plain(up)


def _rotate(k, angle, v):
    """Rodrigues: v turned by `angle` about the unit axis k."""
    s, c = math.sin(angle), math.cos(angle)
    kv = sum(a * b for a, b in zip(k, v))
    cross = (k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0])
    return tuple(v[i] * c + cross[i] * s + k[i] * kv * (1 - c) for i in range(3))


def test_model_0_is_the_planar_model_and_planar_rotation_axis_is_z(client):
    planar = mu.quantize(mu.random_grasp(random.Random(SEED + 1), "planar-default"))
    explicit = dict(copy.deepcopy(planar), id="planar-model-0", model=0)
    answers = client.send_and_collect([planar, explicit])
    check_against_solve(answers, [planar, explicit])
    a, b = to_plain(answers["planar-default"]), to_plain(answers["planar-model-0"])
    a.pop("candidate_id"), b.pop("candidate_id")
    assert a == b, compare(a, b)
    assert a["rotation_axis"] == {"x": 0.0, "y": 0.0, "z": 1.0}, a["rotation_axis"]


# ---------------------------------------------------------------------------------------------------
# Bad input of the spatial model
# ---------------------------------------------------------------------------------------------------
def _spatial_bad_cases(base: dict):
    def mut(f):
        c = copy.deepcopy(base)
        f(c)
        return c

    zero = {"x": 0.0, "y": 0.0, "z": 0.0}
    return [
        # (name, candidate, status, words the message must contain, also checkable by `solve`)
        ("nan contact z", mut(lambda c: c["contact_1"].update(z=math.nan)), 2, ["contact_1.z"], False),
        ("inf normal z", mut(lambda c: c["normal_2"].update(z=math.inf)), 2, ["normal_2.z"], False),
        ("-inf gravity z", mut(lambda c: c["gravity"].update(z=-math.inf)), 2, ["gravity.z"], False),
        ("1e300 centre of mass z", mut(lambda c: c["center_of_mass"].update(z=1e300)), 2, ["center_of_mass.z"], True),
        ("contact z beyond 1e6 m", mut(lambda c: c["contact_2"].update(z=2e6)), 2, ["contact_2.z"], True),
        ("zero normal", mut(lambda c: c.update(normal_1=zero)), 2, ["normal_1 is the zero vector"], True),
        ("zero gravity", mut(lambda c: c.update(gravity=zero)), 2, ["gravity is the zero vector"], True),
        ("normal perpendicular to the grasp plane", mut(lambda c: c.update(normal_2={"x": 3.0, "y": 0.0, "z": 0.0})),
         2, ["normal_2 is perpendicular to the grasp plane"], True),
        ("centre of mass at a contact", mut(lambda c: c.update(center_of_mass=dict(c["contact_2"]))), 2,
         ["center_of_mass coincides with contact_2"], True),
        ("coincident contacts", mut(lambda c: c.update(contact_2=dict(c["contact_1"]))), 2, ["coincide"], True),
        ("normal pointing out", mut(lambda c: c.update(normal_1={"x": 0.0, "y": 1.0, "z": 0.0})), 2,
         ["normal_1 does not point into the object"], True),
        ("mass 0", mut(lambda c: c.update(mass=0.0)), 2, ["mass"], True),
        ("nan friction", mut(lambda c: c.update(friction_2=math.nan)), 2, ["friction_2"], False),
        ("1 MB id", mut(lambda c: c.update(id="s" * (1 << 20))), 2, ["id is 1048576 bytes"], True),
        ("2 kB frame_id", mut(lambda c: c["header"].update(frame_id="f" * 2000)), 2, ["frame_id"], True),
        ("nan centre of mass z", mut(lambda c: c["center_of_mass"].update(z=math.nan)), 2, ["center_of_mass.z"],
         False),
        ("model 2", mut(lambda c: c.update(model=2)), 2, ["model"], True),
        ("model 7", mut(lambda c: c.update(model=7)), 2, ["model is 7: it must be 0", "or 1 (MODEL_SPATIAL"], True),
        ("model 255", mut(lambda c: c.update(model=255)), 2, ["model"], True),
        ("normal tilted beyond the friction angle",
         mut(lambda c: c.update(normal_1={"x": math.sin(0.7), "y": -math.cos(0.7), "z": 0.0}, friction_1=0.5)), 1,
         ["normal at contact_1 is tilted out of the grasp plane", "beyond the friction angle"], True),
        ("sliced cone misses the other contact",
         mut(lambda c: c.update(normal_2={"x": 0.2, "y": 1.0, "z": 0.45}, friction_2=0.45)), 1,
         ["friction cone at contact_2", "misses contact_1"], True),
    ]


def test_normals_along_the_contact_axis_are_answered_not_refused(client):
    """Normals along the contact axis lie in every plane through it: a can gripped through its centre (centre of
    mass on the axis) and a box with its centre of mass off the axis are both held, as `solve` answers them."""
    can = dict(upright_square("along-axis-on"), center_of_mass={"x": 0.0, "y": 0.0, "z": 0.3})
    box = upright_square("along-axis-off")
    answers = client.send_and_collect([can, box])
    check_against_solve(answers, [can, box])
    assert answers["along-axis-on"].status == 0 and answers["along-axis-on"].message.startswith("sensitive"), \
        to_plain(answers["along-axis-on"])
    assert answers["along-axis-off"].status == 0 and answers["along-axis-off"].message == "", \
        to_plain(answers["along-axis-off"])


def test_centre_of_mass_behind_a_tangent_is_answered_with_a_note(client):
    """Objects need not be convex (docs/theory.md, "A centre of mass behind a tangent"): a centre of mass behind the
    tangent plane at contact_1, and one on the contact axis beyond contact_2, are answered (status 0, as `solve`
    answers them), each with a note naming the contact in `message`; they were refused with status 2 before."""
    base = upright_square("behind")
    beyond_1 = dict(copy.deepcopy(base), id="behind-1")
    beyond_1["center_of_mass"]["y"] = 0.3
    beyond_2 = dict(copy.deepcopy(base), id="behind-2", center_of_mass={"x": 0.0, "y": -0.1, "z": 0.3})
    answers = client.send_and_collect([beyond_1, beyond_2])
    check_against_solve(answers, [beyond_1, beyond_2])
    for cid, contact in (("behind-1", "contact_1"), ("behind-2", "contact_2")):
        ans = answers[cid]
        assert ans.status == 0, to_plain(ans)
        assert f"center_of_mass lies behind the surface tangent at {contact}" in ans.message, to_plain(ans)
        assert math.isfinite(ans.gripping_power), to_plain(ans)


def test_spatial_bad_input_is_answered_and_the_node_keeps_serving(client):
    goods = spatial_batch(40, SEED + 2, "after-spatial-bad")
    problems = []
    for k, (name, cand, status, words, by_solve) in enumerate(_spatial_bad_cases(upright_square("base"))):
        if cand["id"] == "base":
            cand["id"] = f"spatial-bad-{k}"
        try:
            ans = client.send_one(cand, timeout=15.0)
        except AssertionError as e:
            problems.append(f"{name}: {e}")
            continue
        if ans.status != status:
            problems.append(f"{name}: status {ans.status}, expected {status} (message {ans.message!r})")
        missing = [w for w in words if w not in ans.message]
        if missing:
            problems.append(f"{name}: message {ans.message[:200]!r} does not name {missing}")
        if len(ans.message) > 400 or len(ans.candidate_id.encode()) > 1024:
            problems.append(f"{name}: message of {len(ans.message)} characters, id of {len(ans.candidate_id)}")
        numbers = (ans.gravity_angle, ans.gripping_power, ans.wrist_rotation, ans.rotation_axis.x)
        if not all(math.isnan(x) for x in numbers):
            problems.append(f"{name}: a refused answer carries numbers {numbers}")
        if status == 1 and not math.isinf(ans.gripping_power_current):
            problems.append(f"{name}: no force closure with a finite current power {ans.gripping_power_current}")
        if by_solve:
            (r,) = run_solve([cand])
            diff = compare(to_plain(ans), r)
            if diff:
                problems.append(f"{name}: differs from solve: {'; '.join(diff[:4])}")
        good = goods[k % len(goods)]
        try:
            check_against_solve(client.send_and_collect([good], timeout=15.0), [good])
        except AssertionError as e:
            problems.append(f"good spatial candidate after {name}: {e}")
    check_against_solve(client.send_and_collect(goods, timeout=30.0), goods)
    assert not problems, "\n".join(problems)


# ---------------------------------------------------------------------------------------------------
# Sets and the service
# ---------------------------------------------------------------------------------------------------
def test_spatial_candidates_in_a_set_and_through_the_service_equal_solve_and_rank(peer, grasp_node, tmp_path):
    """A set mixing spatial, planar and refused spatial candidates: the topic and `~/recommend` give the same
    answer, every recommendation equals `solve`'s line, and the answer equals `grasp_orient rank --json`'s."""
    from test_sets import SetClient, set_msg

    refused = [c for name, c, _, _, by_solve in _spatial_bad_cases(upright_square("set-bad"))
               if by_solve and name != "1 MB id"]
    for k, c in enumerate(refused):
        c["id"] = f"set-bad-{k}"
    rng = random.Random(SEED + 5)
    planar = [mu.quantize(mu.random_grasp(rng, f"set-planar-{k}")) for k in range(3)]
    cands = spatial_batch(60, SEED + 6, "set") + planar + refused + [upright_square("set-upright")]
    sets = SetClient(peer)
    msg = set_msg(cands, "spatial-set")
    by_topic = to_plain(sets.send(msg, timeout=60))
    by_service = to_plain(sets.call(msg, timeout=60))
    assert by_service == by_topic, "; ".join(compare(by_service, by_topic)[:10])
    recs = by_topic["recommendations"]
    assert len(recs) == len(cands) and by_topic["status"] == 0, by_topic["message"]
    statuses = [r["status"] for r in recs]
    assert {0, 1, 2} <= set(statuses), statuses
    problems = [f"{c['id']}: " + "; ".join(d[:4]) for c, r, ref in zip(cands, recs, run_solve(cands))
                if (d := compare(r, ref))]
    assert not problems, f"{len(problems)} answers in the set differ from solve's:\n" + "\n".join(problems[:10])
    ranked = [cands[i]["id"] for i in by_topic["ranking"]]
    assert any(cands[i].get("model") == 1 for i in by_topic["ranking"][:10]), ranked[:10]
    # `grasp_orient rank --json` on the same JSON lines: the same set answer
    lines = tmp_path / "set.jsonl"
    lines.write_text("".join(json.dumps(c) + "\n" for c in cands))
    r = subprocess.run([str(binary_path()), "rank", str(lines), "--json"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    ranked_by_cli = json.loads(r.stdout)
    for key in ("ranking", "ranked_by"):
        assert ranked_by_cli[key] == by_topic[key], (key, ranked_by_cli[key][:10], by_topic[key][:10])
    diff = [d for a, b in zip(by_topic["recommendations"], ranked_by_cli["recommendations"]) for d in compare(a, b)]
    assert len(ranked_by_cli["recommendations"]) == len(recs) and not diff, diff[:10]


def test_a_set_whose_best_candidate_is_spatial_gets_3d_markers(peer, client):
    from test_sets import SetClient, set_msg
    from visualization_msgs.msg import MarkerArray

    frames = [f"spatial_best_{k}" for k in range(6)]
    cands = spatial_batch(6, SEED + 7, "set-marker")
    for c, f in zip(cands, frames):
        c["header"]["frame_id"] = f
    got: list = []
    sub = peer.node.create_subscription(MarkerArray, "grip_markers", got.append, reliable_qos(100))
    try:
        assert peer.spin_until(lambda: sub.get_publisher_count() > 0, 15.0), "no publisher on /grip_markers"
        client.ensure_markers(got)  # the node has matched our reader too (probes in a frame of their own)
        answer = SetClient(peer).send(set_msg(cands, "spatial-markers"), timeout=30)
        best = answer.ranking[0]

        def ours():
            return [m for m in got if m.markers and m.markers[0].header.frame_id in frames]

        assert peer.spin_until(lambda: bool(ours()), 10.0), "no markers for the set"
        arrays = ours()
        assert len(arrays) == 1 and arrays[0].markers[0].header.frame_id == frames[best], len(arrays)
    finally:
        peer.node.destroy_subscription(sub)
    check_spatial_markers({m.ns: m for m in arrays[0].markers}, cands[best], answer.recommendations[best])


# ---------------------------------------------------------------------------------------------------
# Markers in 3D
# ---------------------------------------------------------------------------------------------------
def test_spatial_markers_are_3d_and_balance_the_weight(peer, client):
    from visualization_msgs.msg import MarkerArray

    got: list = []
    sub = peer.node.create_subscription(MarkerArray, "grip_markers", got.append, reliable_qos(100))
    try:
        assert peer.spin_until(lambda: sub.get_publisher_count() > 0, 15.0), "no publisher on /grip_markers"
        frame = "spatial_marker_frame"
        c = spatial_batch(2, SEED + 3, "spatial-marker")[1]  # tilted normals, off the axis
        c["header"]["frame_id"] = frame

        def mine():
            return [m for m in got if m.markers and m.markers[0].header.frame_id == frame]

        client.ensure_markers(got)  # the node has matched our reader too: the answer below gets its markers
        answer = client.send_and_collect([c], timeout=10.0)[c["id"]]
        assert peer.spin_until(lambda: bool(mine()), 10.0), f"no MarkerArray in frame {frame!r} on /grip_markers"
        assert answer.status == 0, answer
        arr = {m.ns: m for m in mine()[-1].markers}
    finally:
        peer.node.destroy_subscription(sub)

    check_spatial_markers(arr, c, answer)


def check_spatial_markers(arr: dict, c: dict, answer) -> None:
    """The markers of a spatial answer: contacts and centre of mass where the candidate puts them in 3D, the
    forces balance the weight along the recommended gravity and lie in their true 3D friction cones."""
    def v(p):
        return (p.x, p.y, p.z)

    def sub3(a, b):
        return tuple(x - y for x, y in zip(a, b))

    p1, p2 = (tuple(c[k][a] for a in "xyz") for k in ("contact_1", "contact_2"))
    com = tuple(c["center_of_mass"][a] for a in "xyz")
    assert [v(p) for p in arr["contacts"].points] == [p1, p2]
    assert v(arr["center_of_mass"].pose.position) == com
    span = math.dist(p1, p2)
    g = tuple(c["gravity"][a] for a in "xyz")
    weight = c["mass"] * math.sqrt(sum(x * x for x in g))
    f = [v(p) for p in arr["contact_forces"].points]
    forces = [tuple(x * weight / span for x in sub3(f[1], f[0])), tuple(x * weight / span for x in sub3(f[3], f[2]))]
    d = (answer.gravity_direction.x, answer.gravity_direction.y, answer.gravity_direction.z)
    residual = [forces[0][i] + forces[1][i] + weight * d[i] for i in range(3)]
    assert max(map(abs, residual)) < 1e-9 * weight, f"forces do not balance the weight: {residual}"
    for i, n in enumerate((c["normal_1"], c["normal_2"])):
        n = tuple(n[a] for a in "xyz")
        cos = sum(a * b for a, b in zip(forces[i], n)) / (math.dist(forces[i], (0, 0, 0)) * math.dist(n, (0, 0, 0)))
        mu_i = c[f"friction_{i + 1}"]
        assert cos >= 1 / math.sqrt(1 + mu_i ** 2) - 1e-9, f"force {i + 1} outside its 3D friction cone"
    assert len({round(p.z, 9) for m in arr.values() for p in m.points}) > 2, "the markers are not drawn in 3D"


# ---------------------------------------------------------------------------------------------------
# A recording of spatial candidates replays
# ---------------------------------------------------------------------------------------------------
def test_a_recording_of_spatial_candidates_replays(start_node, rclpy_context, tmp_path):
    ns = "/spatial_rec"
    record_dir = tmp_path / "runs"
    node = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", f"record_dir:={record_dir}",
                      "-p", "record_markers:=true", "-p", "friction_safety_factor:=1.1",
                      "-p", "range:=graspable", name="recording node (spatial)")
    peer = Peer("grasp_orient_spatial_rec_peer")
    refused = [c for name, c, _, _, by_solve in _spatial_bad_cases(upright_square("rec-bad"))
               if by_solve and name != "1 MB id"]
    for k, c in enumerate(refused):
        c["id"] = f"rec-bad-{k}"
    cands = spatial_batch(120, SEED + 4, "rec") + refused
    try:
        client = GraspClient(peer, ns=ns)
        client.ensure_roundtrip()
        answers = client.send_and_collect(cands, timeout=120)
        node.stop_and_check(signal.SIGINT)
    finally:
        peer.destroy()
        node.kill()
    statuses = {a.status for a in answers.values()}
    assert statuses == {0, 1, 2}, f"the recording needs answers of every status: {statuses}"
    (path,) = record_dir.glob("*.mcap")
    recs = mu.read_mcap(path)
    recorded = [r.msg for r in recs if r.topic == f"{ns}/grasp_candidates"]
    # the model field is recorded as sent: 1, and 2, 7 and 255 for the refused models
    models = {m["id"]: m["model"] for m in recorded}
    wrong = [(c["id"], c["model"], models.get(c["id"])) for c in cands if models.get(c["id"]) != c["model"]]
    assert not wrong, f"the model field is not recorded as sent (id, sent, recorded): {wrong[:5]}"
    assert {c["model"] for c in cands} == {1, 2, 7, 255}
    solved = [r.msg for r in recs if r.topic == f"{ns}/grip_recommendations" and r.msg["status"] == 0]
    markers = [r.msg for r in recs if r.topic == f"{ns}/grip_markers"]
    assert len(markers) == len(solved), f"{len(markers)} marker arrays for {len(solved)} solved candidates"
    r = subprocess.run([str(binary_path()), "replay", str(path)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, f"replay exited {r.returncode}:\n{(r.stdout + r.stderr)[-3000:]}"
    # every candidate sent, and the round-trip probes (planar)
    assert f"{len(recorded)} compared with a recorded recommendation, 0 differ" in r.stdout, r.stdout
