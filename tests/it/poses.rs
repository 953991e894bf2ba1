//! Pose candidates through `solve` and `rank` (`docs/poses.md`): a gripper pose on a primitive
//! or a mesh answers as the spatial `GraspCandidate` its fingers make, the contacts computed here
//! by a reference that shares no code with the product (closed-form ray casts on the primitives,
//! plain Möller–Trumbore over every triangle of a mesh, the centroid from the solid's boxes).

use crate::util::run::{bin, json_lines, run_fed, temp_dir};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{json, Value};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Stdio;

/// Runs `grasp_orient <command> <args>` on `input` with extra environment variables: the JSON
/// lines it prints, its standard error, and whether it succeeded.
fn run(command: &str, args: &[&str], input: &str, env: &[(&str, &Path)]) -> (Vec<Value>, String) {
    let mut cmd = bin();
    cmd.arg(command).args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    let (out, written) = run_fed(cmd, input);
    written.expect("write stdin");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{command} failed: {stderr}");
    let lines = json_lines(&out);
    (lines, stderr)
}

fn solve(input: &str) -> Vec<Value> {
    run("solve", &[], input, &[]).0
}

/// The L-shaped prism, mm: the arms [0, 60] × [0, 40] and [0, 40] × [0, 60], 30 high, the notch
/// [40, 60] × [40, 60]. Its centroid: the arm of 2400 mm² at (30, 20) and the rest, 800 mm² at
/// (20, 50), give (27.5, 27.5), inside.
const L_OUTLINE: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [60.0, 0.0],
    [60.0, 40.0],
    [40.0, 40.0],
    [40.0, 60.0],
    [0.0, 60.0],
];
const L_HEIGHT: f64 = 30.0;
const L_CENTROID: [f64; 3] = [27.5, 27.5, 15.0];

/// The triangles of a prism over a counter-clockwise outline fanned from its first corner (a
/// fan that stays inside the L), wound outward; `skip_top` leaves the top open.
fn prism(outline: &[[f64; 2]], height: f64, skip_top: bool) -> Vec<[[f64; 3]; 3]> {
    let at = |p: [f64; 2], z: f64| [p[0], p[1], z];
    let mut out = Vec::new();
    for i in 1..outline.len() - 1 {
        let (a, b, c) = (outline[0], outline[i], outline[i + 1]);
        if !skip_top {
            out.push([at(a, height), at(b, height), at(c, height)]);
        }
        out.push([at(a, 0.0), at(c, 0.0), at(b, 0.0)]);
    }
    for i in 0..outline.len() {
        let (p, q) = (outline[i], outline[(i + 1) % outline.len()]);
        out.push([at(p, 0.0), at(q, 0.0), at(q, height)]);
        out.push([at(p, 0.0), at(q, height), at(p, height)]);
    }
    out
}

/// A binary STL of the triangles (values exact in f32).
fn write_stl(path: &Path, triangles: &[[[f64; 3]; 3]]) {
    let mut bytes = vec![0u8; 80];
    bytes.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    for t in triangles {
        bytes.extend_from_slice(&[0u8; 12]);
        for v in t {
            for c in v {
                bytes.extend_from_slice(&(*c as f32).to_le_bytes());
            }
        }
        bytes.extend_from_slice(&[0u8; 2]);
    }
    std::fs::write(path, bytes).expect("write the STL");
}

/// The test's own view of a shape, in its frame, metres.
enum Solid {
    Box([f64; 3]),
    Sphere(f64),
    Cylinder {
        height: f64,
        radius: f64,
    },
    /// Triangles wound outward, metres; the boxes whose union it is (for points inside).
    Mesh {
        triangles: Vec<[Vector3<f64>; 3]>,
        boxes: Vec<([f64; 3], [f64; 3])>,
    },
}

impl Solid {
    /// The first surface point along `o + t d` (`d` unit) for `t` in `[0, max]`, with the outward
    /// normal there.
    fn first_hit(&self, o: Vector3<f64>, d: Vector3<f64>, max: f64) -> Option<(f64, Vector3<f64>)> {
        let hits: Vec<(f64, Vector3<f64>)> = match self {
            Solid::Box(size) => {
                // Slabs: entering through the face of the latest entry.
                let mut near = (f64::NEG_INFINITY, Vector3::zeros());
                let mut far = f64::INFINITY;
                for i in 0..3 {
                    let h = size[i] / 2.0;
                    if d[i] == 0.0 {
                        if o[i].abs() > h {
                            return None;
                        }
                        continue;
                    }
                    let (t1, t2) = ((-h - o[i]) / d[i], (h - o[i]) / d[i]);
                    let (enter, leave) = (t1.min(t2), t1.max(t2));
                    if enter > near.0 {
                        let mut n = Vector3::zeros();
                        n[i] = -d[i].signum();
                        near = (enter, n);
                    }
                    far = far.min(leave);
                }
                if near.0 <= far {
                    vec![near]
                } else {
                    vec![]
                }
            }
            Solid::Sphere(r) => {
                let b = o.dot(&d);
                let c = o.norm_squared() - r * r;
                let disc = b * b - c;
                if disc < 0.0 {
                    vec![]
                } else {
                    let t = -b - disc.sqrt();
                    vec![(t, (o + d * t) / *r)]
                }
            }
            Solid::Cylinder { height, radius } => {
                let mut hits = Vec::new();
                let a = d.x * d.x + d.y * d.y;
                let b = o.x * d.x + o.y * d.y;
                let c = o.x * o.x + o.y * o.y - radius * radius;
                let disc = b * b - a * c;
                if a > 0.0 && disc >= 0.0 {
                    for t in [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a] {
                        let q = o + d * t;
                        if q.z.abs() <= height / 2.0 {
                            hits.push((t, Vector3::new(q.x, q.y, 0.0) / *radius));
                        }
                    }
                }
                for z in [-height / 2.0, height / 2.0] {
                    if d.z != 0.0 {
                        let t = (z - o.z) / d.z;
                        let q = o + d * t;
                        if q.x * q.x + q.y * q.y <= radius * radius {
                            hits.push((t, Vector3::new(0.0, 0.0, z.signum())));
                        }
                    }
                }
                hits
            }
            Solid::Mesh { triangles, .. } => triangles
                .iter()
                .filter_map(|[a, b, c]| {
                    // Möller–Trumbore.
                    let (e1, e2) = (b - a, c - a);
                    let p = d.cross(&e2);
                    let det = e1.dot(&p);
                    if det.abs() < 1e-300 {
                        return None;
                    }
                    let s = o - a;
                    let u = s.dot(&p) / det;
                    let q = s.cross(&e1);
                    let v = d.dot(&q) / det;
                    if u < 0.0 || v < 0.0 || u + v > 1.0 {
                        return None;
                    }
                    Some((e2.dot(&q) / det, e1.cross(&e2).normalize()))
                })
                .collect(),
        };
        hits.into_iter()
            .filter(|(t, _)| (0.0..=max).contains(t))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// A random point well inside the solid.
    fn inside(&self, rng: &mut ChaCha8Rng) -> Vector3<f64> {
        let mut u = || rng.gen_range(-0.8..0.8);
        match self {
            Solid::Box(s) => Vector3::new(u() * s[0] / 2.0, u() * s[1] / 2.0, u() * s[2] / 2.0),
            Solid::Sphere(r) => Vector3::new(u(), u(), u()) * (r / 3f64.sqrt()),
            Solid::Cylinder { height, radius } => Vector3::new(
                u() * radius / 2f64.sqrt(),
                u() * radius / 2f64.sqrt(),
                u() * height / 2.0,
            ),
            Solid::Mesh { boxes, .. } => {
                let (lo, hi) = boxes[rng.gen_range(0..boxes.len())];
                Vector3::from_fn(|i, _| {
                    let mid = (lo[i] + hi[i]) / 2.0;
                    mid + rng.gen_range(-0.45..0.45) * (hi[i] - lo[i])
                })
            }
        }
    }

    /// The farthest its points lie from its frame's origin, at most, m.
    fn reach(&self) -> f64 {
        match self {
            Solid::Box(s) => Vector3::from(*s).norm() / 2.0,
            Solid::Sphere(r) => *r,
            Solid::Cylinder { height, radius } => (height * height / 4.0 + radius * radius).sqrt(),
            Solid::Mesh { triangles, .. } => triangles
                .iter()
                .flatten()
                .map(|v| v.norm())
                .fold(0.0, f64::max),
        }
    }
}

/// The L prism as the test's solid: the file's mm values times 0.001, as the product scales them.
fn l_solid() -> Solid {
    let m = |v: [f64; 3]| Vector3::new(v[0] * 0.001, v[1] * 0.001, v[2] * 0.001);
    Solid::Mesh {
        triangles: prism(&L_OUTLINE, L_HEIGHT, false)
            .into_iter()
            .map(|t| t.map(m))
            .collect(),
        boxes: vec![
            ([0.0, 0.0, 0.0], [0.06, 0.04, 0.03]),
            ([0.0, 0.04, 0.0], [0.04, 0.06, 0.03]),
        ],
    }
}

fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    let mut u = || rng.gen_range(-1.0..1.0);
    UnitQuaternion::from_quaternion(Quaternion::new(u(), u(), u(), u()))
}

fn pose_json(position: &Vector3<f64>, q: &UnitQuaternion<f64>) -> Value {
    json!({
        "position": {"x": position.x, "y": position.y, "z": position.z},
        "orientation": {"x": q.i, "y": q.j, "z": q.k, "w": q.w},
    })
}

fn xyz(v: &Vector3<f64>) -> Value {
    json!({"x": v.x, "y": v.y, "z": v.z})
}

const MASS: f64 = 0.4;
const FRICTION: f64 = 0.6;

/// One random pose on `solid` (placed at a random pose): the pose candidate line, and the
/// `GraspCandidate` line from the reference's contacts with them.
fn random_case(
    rng: &mut ChaCha8Rng,
    solid: &Solid,
    shape: &Value,
    centroid: Vector3<f64>,
    id: &str,
) -> (String, String, [Vector3<f64>; 2]) {
    let object_rotation = random_rotation(rng);
    let object_position = Vector3::new(
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
        rng.gen_range(0.0..1.0),
    );
    let to_header = |p: Vector3<f64>| object_rotation * p + object_position;
    let tool_rotation = random_rotation(rng);
    let b = tool_rotation * Vector3::y();
    let centre = to_header(solid.inside(rng));
    // Each finger starts farther from the centre than any two points of the solid are apart.
    let width = 4.0 * solid.reach() + 0.01;
    let mut contacts = [Vector3::zeros(); 2];
    let mut normals = [Vector3::zeros(); 2];
    for (k, sign) in [-1.0, 1.0].into_iter().enumerate() {
        let start = centre + b * (sign * width / 2.0);
        let direction = -b * sign;
        let o = object_rotation.inverse() * (start - object_position);
        let d = object_rotation.inverse() * direction;
        let (t, outward) = solid
            .first_hit(o, d, width)
            .unwrap_or_else(|| panic!("{id}: the line misses the solid {o} {d} {width}"));
        contacts[k] = start + direction * t;
        normals[k] = -(object_rotation * outward);
    }
    let mut object = json!({
        "pose": pose_json(&object_position, &object_rotation),
        "mass": MASS,
        "friction": FRICTION,
    });
    for (k, v) in shape.as_object().expect("an object").iter() {
        object[k] = v.clone();
    }
    let gravity = json!({"x": 0.0, "y": 0.0, "z": -9.81});
    let header = json!({"frame_id": "world"});
    let pose = json!({
        "header": header, "id": id,
        "grasp_pose": pose_json(&centre, &tool_rotation),
        "width": width, "object": object, "gravity": gravity,
    });
    let com = to_header(centroid);
    let grasp = json!({
        "header": header, "id": id,
        "contact_1": xyz(&contacts[0]), "contact_2": xyz(&contacts[1]),
        "normal_1": xyz(&normals[0]), "normal_2": xyz(&normals[1]),
        "friction_1": FRICTION, "friction_2": FRICTION,
        "center_of_mass": xyz(&com), "mass": MASS, "gravity": gravity, "model": 1,
    });
    (pose.to_string(), grasp.to_string(), contacts)
}

/// `a` and `b` agree: numbers within `tol` relative to the larger magnitude (and 1), everything
/// else equal.
fn agree(a: &Value, b: &Value, tol: f64, path: &str) -> Result<(), String> {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            if (x - y).abs() <= tol * x.abs().max(y.abs()).max(1.0) {
                Ok(())
            } else {
                Err(format!("{path}: {x} against {y}"))
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .try_for_each(|(i, (x, y))| agree(x, y, tol, &format!("{path}[{i}]"))),
        (Value::Object(x), Value::Object(y)) if x.len() == y.len() => {
            x.iter().try_for_each(|(k, v)| {
                let w = y.get(k).ok_or_else(|| format!("{path}.{k} missing"))?;
                agree(v, w, tol, &format!("{path}.{k}"))
            })
        }
        _ if a == b => Ok(()),
        _ => Err(format!("{path}: {a} against {b}")),
    }
}

fn point(v: &Value) -> Vector3<f64> {
    let c = |k: &str| v[k].as_f64().expect("a number");
    Vector3::new(c("x"), c("y"), c("z"))
}

/// Random poses on each shape.
const POSES: usize = 100;

/// (a) and (b): random poses on a box, a sphere, a cylinder and the L prism (a mesh in mm at
/// scale 0.001) answer as the GraspCandidates of the reference's contacts, to 1e-9.
#[test]
fn random_poses_answer_as_the_spatial_candidate_of_their_contacts() {
    let dir = temp_dir("poses_random");
    let stl = dir.path().join("l.stl");
    write_stl(&stl, &prism(&L_OUTLINE, L_HEIGHT, false));
    let mesh =
        json!({"mesh": stl.display().to_string(), "scale": {"x": 0.001, "y": 0.001, "z": 0.001}});
    let cases: [(Solid, Value, Vector3<f64>); 4] = [
        (
            Solid::Box([0.06, 0.04, 0.1]),
            json!({"primitive": {"type": 1, "dimensions": [0.06, 0.04, 0.1]}}),
            Vector3::zeros(),
        ),
        (
            Solid::Sphere(0.035),
            json!({"primitive": {"type": 2, "dimensions": [0.035]}}),
            Vector3::zeros(),
        ),
        (
            Solid::Cylinder {
                height: 0.12,
                radius: 0.03,
            },
            json!({"primitive": {"type": 3, "dimensions": [0.12, 0.03]}}),
            Vector3::zeros(),
        ),
        (l_solid(), mesh, Vector3::from(L_CENTROID) * 0.001),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for (shape_index, (solid, shape, centroid)) in cases.iter().enumerate() {
        let (mut ok, mut outside, mut no_closure) = (0, 0, 0);
        let (mut poses, mut grasps, mut expected) = (String::new(), String::new(), Vec::new());
        for i in 0..POSES {
            let id = format!("s{shape_index}-{i}");
            let (pose, grasp, contacts) = random_case(&mut rng, solid, shape, *centroid, &id);
            poses.push_str(&pose);
            poses.push('\n');
            grasps.push_str(&grasp);
            grasps.push('\n');
            expected.push(contacts);
        }
        let (from_poses, from_grasps) = (solve(&poses), solve(&grasps));
        assert_eq!(from_poses.len(), POSES);
        for ((p, g), contacts) in from_poses.iter().zip(&from_grasps).zip(&expected) {
            let r = &p["recommendation"];
            let id = r["candidate_id"].as_str().unwrap_or_default();
            if let Err(e) = agree(r, g, 1e-9, id) {
                panic!("{e}\npose answer {r}\ncandidate answer {g}");
            }
            for (k, c) in contacts.iter().enumerate() {
                let got = point(&p[format!("contact_{}", k + 1)]);
                assert!(
                    (got - c).norm() <= 1e-9,
                    "{id}: contact {k}: {got} against {c}"
                );
            }
            match r["status"].as_u64() {
                Some(0) => ok += 1,
                Some(1) => no_closure += 1,
                _ if r["message"]
                    .as_str()
                    .is_some_and(|m| m.contains("outside the object")) =>
                {
                    outside += 1
                }
                _ => panic!("{id}: {r}"),
            }
        }
        eprintln!(
            "shape {shape_index}: {ok} of {POSES} held, {no_closure} without force closure, {outside} \
             refused for a centre of mass outside the object"
        );
        assert!(
            ok >= 15,
            "shape {shape_index}: only {ok} of {POSES} poses held"
        );
    }
}

/// (b) A box given as a mesh in millimetres at scale 0.001 meets the fingers where the same box
/// as a primitive in metres does.
#[test]
fn a_mesh_in_millimetres_at_scale_0_001_is_the_box_in_metres() {
    let dir = temp_dir("poses_mm");
    let stl = dir.path().join("box.stl");
    let outline = [[-30.0, -20.0], [30.0, -20.0], [30.0, 20.0], [-30.0, 20.0]];
    let shifted: Vec<[[f64; 3]; 3]> = prism(&outline, 100.0, false)
        .into_iter()
        .map(|t| t.map(|v| [v[0], v[1], v[2] - 50.0]))
        .collect();
    write_stl(&stl, &shifted);
    let line = |shape: Value| {
        let mut object = json!({
            "pose": pose_json(&Vector3::new(0.3, 0.1, 0.2), &UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0)),
            "mass": MASS, "friction": FRICTION,
        });
        for (k, v) in shape.as_object().expect("an object") {
            object[k] = v.clone();
        }
        json!({
            "id": "box",
            "grasp_pose": pose_json(&Vector3::new(0.31, 0.12, 0.21), &UnitQuaternion::from_euler_angles(0.1, 0.2, 0.9)),
            "width": 0.2, "object": object, "gravity": {"x": 0.0, "y": 0.0, "z": -9.81},
        })
        .to_string()
    };
    let input = [
        line(json!({"mesh": stl.display().to_string(), "scale": {"x": 0.001, "y": 0.001, "z": 0.001}})),
        line(json!({"primitive": {"type": 1, "dimensions": [0.06, 0.04, 0.1]}})),
    ]
    .join("\n");
    let out = solve(&input);
    assert_eq!(out[0]["recommendation"]["status"], 0, "{}", out[0]);
    for field in [
        "contact_1",
        "contact_2",
        "normal_1",
        "normal_2",
        "center_of_mass",
    ] {
        let (mesh, primitive) = (point(&out[0][field]), point(&out[1][field]));
        assert!(
            (mesh - primitive).norm() < 1e-12,
            "{field}: {mesh} against {primitive}"
        );
    }
    agree(
        &out[0]["recommendation"],
        &out[1]["recommendation"],
        1e-9,
        "box",
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

/// An ament prefix holding package `test_meshes` with the L prism at `meshes/l.stl`.
fn ament_prefix(root: &Path) -> PathBuf {
    let prefix = root.join("install");
    let index = prefix.join("share/ament_index/resource_index/packages");
    std::fs::create_dir_all(&index).expect("index folder");
    std::fs::write(index.join("test_meshes"), "").expect("index entry");
    let meshes = prefix.join("share/test_meshes/meshes");
    std::fs::create_dir_all(&meshes).expect("share folder");
    write_stl(&meshes.join("l.stl"), &prism(&L_OUTLINE, L_HEIGHT, false));
    prefix
}

/// A pose on the L prism, the mesh given as `resource`.
fn l_line(id: &str, resource: &str) -> String {
    json!({
        "header": {"frame_id": "world"}, "id": id,
        "grasp_pose": pose_json(&Vector3::new(0.02, 0.05, 0.015), &UnitQuaternion::from_euler_angles(0.0, 0.0, -std::f64::consts::FRAC_PI_2)),
        "width": 0.1,
        "object": {
            "pose": pose_json(&Vector3::zeros(), &UnitQuaternion::identity()),
            "mesh": resource, "scale": {"x": 0.001, "y": 0.001, "z": 0.001},
            "mass": MASS, "friction": FRICTION,
            "has_center_of_mass": true, "center_of_mass": {"x": 0.02, "y": 0.05, "z": 0.015},
        },
        "gravity": {"x": 0.0, "y": 0.0, "z": -9.81},
    })
    .to_string()
}

/// (c) `package://` through the ament index of `AMENT_PREFIX_PATH`: the same answer as the file's
/// path; without the package in the index, status 2 naming the package.
#[test]
fn package_resources_resolve_through_the_ament_prefix_path() {
    let dir = temp_dir("poses_package");
    let prefix = ament_prefix(dir.path());
    let file = prefix.join("share/test_meshes/meshes/l.stl");
    let input = [
        l_line("package", "package://test_meshes/meshes/l.stl"),
        l_line("file", &format!("file://{}", file.display())),
        l_line("missing", "package://no_such_package/meshes/l.stl"),
    ]
    .join("\n");
    let (out, _) = run("solve", &[], &input, &[("AMENT_PREFIX_PATH", &prefix)]);
    let r = |i: usize| &out[i]["recommendation"];
    assert_eq!(r(0)["status"], 0, "{}", out[0]);
    // Finger 1 starts on the -y side of the tool frame: the tool's y is +x of the world here,
    // so finger 1 meets the arm's face x = 0 and finger 2 its face x = 0.04.
    let c1 = point(&out[0]["contact_1"]);
    let c2 = point(&out[0]["contact_2"]);
    assert!((c1 - Vector3::new(0.0, 0.05, 0.015)).norm() < 1e-12, "{c1}");
    assert!(
        (c2 - Vector3::new(0.04, 0.05, 0.015)).norm() < 1e-12,
        "{c2}"
    );
    let mut file_answer = r(1).clone();
    file_answer["candidate_id"] = "package".into();
    agree(r(0), &file_answer, 0.0, "package").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r(2)["status"], 2);
    let message = r(2)["message"].as_str().unwrap_or_default();
    assert!(
        message.contains("no_such_package") && message.contains("line 3"),
        "{message}"
    );
}

/// A pose candidate line on a 6 cm cube at the origin, with `object` fields and the pose changed.
fn cube_line(id: &str, object: Value, position: [f64; 3], width: f64) -> String {
    let mut o = json!({
        "pose": pose_json(&Vector3::zeros(), &UnitQuaternion::identity()),
        "primitive": {"type": 1, "dimensions": [0.06, 0.06, 0.06]},
        "mass": MASS, "friction": FRICTION,
    });
    for (k, v) in object.as_object().expect("an object") {
        o[k] = v.clone();
    }
    json!({
        "id": id,
        "grasp_pose": pose_json(&Vector3::from(position), &UnitQuaternion::identity()),
        "width": width, "object": o, "gravity": {"x": 0.0, "y": 0.0, "z": -9.81},
    })
    .to_string()
}

/// A refused line, its status, and words its message holds.
type Refusal = (String, u64, Vec<String>);

fn words(w: &[&str]) -> Vec<String> {
    w.iter().map(|w| w.to_string()).collect()
}

/// The refusals that come from the fingers, the mesh files in `dir` and the scale.
fn mesh_refusals(dir: &Path) -> Vec<Refusal> {
    let open = dir.join("open.stl");
    write_stl(&open, &prism(&L_OUTLINE, L_HEIGHT, true));
    let open = open.display().to_string();
    let closed = dir.join("closed.stl");
    write_stl(&closed, &prism(&L_OUTLINE, L_HEIGHT, false));
    let closed = closed.display().to_string();
    let mm = json!({"x": 0.001, "y": 0.001, "z": 0.001});
    vec![
        (
            cube_line("nothing", json!({}), [0.0, 0.0, 0.5], 0.1),
            1,
            words(&["finger 1", "closes on nothing"]),
        ),
        (
            cube_line("narrow", json!({}), [0.0, 0.0, 0.0], 0.04),
            2,
            words(&["starts inside", "narrower"]),
        ),
        (
            cube_line(
                "unreadable",
                json!({"primitive": {}, "mesh": "/no/such/mesh.stl"}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["/no/such/mesh.stl", "cannot read"]),
        ),
        (
            cube_line(
                "open",
                json!({"primitive": {}, "mesh": open, "scale": mm}),
                [0.01, 0.04, 0.015],
                0.1,
            ),
            2,
            words(&[open.as_str(), "open"]),
        ),
        (
            cube_line(
                "millimetres",
                json!({"primitive": {}, "mesh": closed}),
                [0.01, 0.04, 0.015],
                0.1,
            ),
            2,
            words(&[
                "starts inside",
                "600 times wider",
                "millimetres? set object.scale to 0.001",
            ]),
        ),
        (
            cube_line(
                "zero scale",
                json!({"primitive": {}, "mesh": closed, "scale": {"x": 0.0, "y": 1.0, "z": 1.0}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&[closed.as_str(), "scale [0.0, 1.0, 1.0]"]),
        ),
        (
            cube_line(
                "negative scale",
                json!({"primitive": {}, "inline_mesh": {"vertices": [{"x": 0.0, "y": 0.0, "z": 0.0}], "triangles": [{"vertex_indices": [0, 0, 0]}]}, "scale": {"x": 1.0, "y": -1.0, "z": 1.0}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["inline_mesh", "scale"]),
        ),
    ]
}

/// The refusals that come from the primitive, the object's own fields and the JSON.
fn shape_refusals() -> Vec<Refusal> {
    vec![
        (
            cube_line(
                "primitive scale",
                json!({"scale": {"x": 2.0, "y": 2.0, "z": 2.0}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["object.scale", "primitive"]),
        ),
        (
            cube_line(
                "unknown type",
                json!({"primitive": {"type": 7, "dimensions": [0.1]}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["unknown", "type 7"]),
        ),
        (
            cube_line(
                "prism",
                json!({"primitive": {"type": 5, "dimensions": [0.1, 0.1]}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["type 5"]),
        ),
        (
            cube_line(
                "dimensions",
                json!({"primitive": {"type": 1, "dimensions": [0.1, 0.1]}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["box", "dimensions [0.1, 0.1]"]),
        ),
        (
            cube_line(
                "two shapes",
                json!({"mesh": "/no/such/mesh.stl"}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["exactly one shape", "mesh, primitive"]),
        ),
        (
            cube_line(
                "com flag",
                json!({"center_of_mass": {"x": 0.01, "y": 0.0, "z": 0.0}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["has_center_of_mass"]),
        ),
        (
            cube_line(
                "quaternion",
                json!({"pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}}}),
                [0.0; 3],
                0.1,
            ),
            2,
            words(&["object.pose.orientation"]),
        ),
        (
            cube_line("bad field", json!({"friction": "high"}), [0.0; 3], 0.1),
            2,
            words(&["field object.friction", "expected a number"]),
        ),
    ]
}

/// (d) Every refusal, each followed by a good line that is still answered.
#[test]
fn every_refusal_names_its_cause_and_the_next_line_is_answered() {
    let dir = temp_dir("poses_refusals");
    let mut refusals = mesh_refusals(dir.path());
    refusals.extend(shape_refusals());
    let good = cube_line("good", json!({}), [0.0, 0.0, 0.01], 0.1);
    let mut input = String::new();
    for (line, _, _) in &refusals {
        input.push_str(line);
        input.push('\n');
        input.push_str(&good);
        input.push('\n');
    }
    let out = solve(&input);
    assert_eq!(out.len(), 2 * refusals.len());
    for (k, (_, status, words)) in refusals.iter().enumerate() {
        let (refused, next) = (
            &out[2 * k]["recommendation"],
            &out[2 * k + 1]["recommendation"],
        );
        let message = refused["message"].as_str().unwrap_or_default();
        assert_eq!(refused["status"], *status, "{message}");
        for w in words {
            assert!(
                message.contains(w),
                "{:?}: {message:?} lacks {w:?}",
                refused["candidate_id"]
            );
        }
        // The units hint only where the mesh is about 1000 times the opening.
        if refused["candidate_id"] == "narrow" {
            assert!(!message.contains("millimetres"), "{message}");
        }
        if *status == 2 {
            assert!(
                message.starts_with(&format!("line {}: ", 2 * k + 1)),
                "{message}"
            );
        }
        assert_eq!(next["status"], 0, "{next}");
        assert_eq!(next["candidate_id"], "good");
        assert!(out[2 * k]["contact_1"]["x"].is_null(), "{}", out[2 * k]);
    }
}

/// `rank` of candidate lines mixes GraspCandidates and PoseCandidates in one set; a pose the
/// geometry refuses keeps its status (1 here) and is not ranked.
#[test]
fn rank_mixes_grasp_and_pose_candidate_lines() {
    let paper = crate::util::run::paper_lines();
    let input = format!(
        "{}\n{paper}{}\n",
        cube_line("cube", json!({}), [0.0, 0.0, 0.01], 0.1),
        cube_line("nothing", json!({}), [0.0, 0.0, 0.5], 0.1),
    );
    let (out, _) = run("rank", &["--json"], &input, &[]);
    let recommendations = out[0]["recommendations"].as_array().expect("a list");
    assert_eq!(recommendations.len(), 6);
    assert_eq!(recommendations[0]["candidate_id"], "cube");
    assert_eq!(recommendations[0]["status"], 0, "{}", recommendations[0]);
    assert_eq!(
        recommendations[0]["rotation_axis"]["z"]
            .as_f64()
            .map(f64::abs),
        Some(0.0)
    );
    let last = &recommendations[5];
    assert_eq!(
        (last["candidate_id"].as_str(), last["status"].as_u64()),
        (Some("nothing"), Some(1))
    );
    assert!(last["message"]
        .as_str()
        .is_some_and(|m| m.contains("finger 1 closes on nothing")));
    let ranking: Vec<u64> = out[0]["ranking"]
        .as_array()
        .expect("a ranking")
        .iter()
        .filter_map(Value::as_u64)
        .collect();
    assert!(ranking.contains(&0) && !ranking.contains(&5), "{ranking:?}");
}

/// A closing line through an edge of the box is answered, with the pseudo-normal and a note.
#[test]
fn a_contact_on_an_edge_is_answered_with_a_note() {
    // The tool turned 45° about z: its y is (-1, 1, 0)/√2, and the closing line through the
    // cube's centre meets its vertical edges at (0.03, -0.03) and (-0.03, 0.03).
    let mut line: Value =
        serde_json::from_str(&cube_line("edge", json!({}), [0.0; 3], 0.1)).expect("JSON");
    line["grasp_pose"] = pose_json(
        &Vector3::zeros(),
        &UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_4),
    );
    let out = solve(&line.to_string());
    assert_eq!(out[0]["recommendation"]["status"], 0, "{}", out[0]);
    let c1 = point(&out[0]["contact_1"]);
    assert!((c1 - Vector3::new(0.03, -0.03, 0.0)).norm() < 1e-12, "{c1}");
    let r = &out[0]["recommendation"];
    let message = r["message"].as_str().unwrap_or_default();
    assert!(message.contains("contact_1 lies on an edge"), "{message}");
    assert!(message.contains("contact_2 lies on an edge"), "{message}");
    let n1 = point(&out[0]["normal_1"]);
    let expected = Vector3::new(-1.0, 1.0, 0.0).normalize();
    assert!((n1 - expected).norm() < 1e-12, "{n1}");
}

/// What `rank -` prints for `input`: its table.
fn rank_table(input: &str) -> String {
    let output = bin()
        .args(["rank", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            c.stdin.take().expect("stdin").write_all(input.as_bytes())?;
            c.wait_with_output()
        })
        .expect("rank runs");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// (e) `rank` of a pose set ranks by grip force and holds the set's max_grip_force; each member
/// is the answer `solve` gives the same pose alone.
#[test]
fn rank_of_a_pose_set_ranks_by_grip_force_within_the_limit() {
    // Closing lines on a sphere farther and farther from its centre: the normals tilt from the
    // line, and the grasp needs more squeeze (out of order here, so the ranking has work to do).
    let offsets = [0.009, 0.0, 0.015, 0.003, 0.012, 0.006];
    let poses: Vec<Value> = offsets
        .iter()
        .enumerate()
        .map(|(i, x)| {
            json!({
                "id": format!("p{i}"),
                "grasp_pose": pose_json(&Vector3::new(*x, 0.0, 0.0), &UnitQuaternion::from_euler_angles(0.0, 0.3 * i as f64, 0.0)),
                "width": 0.1,
            })
        })
        .collect();
    let object = json!({
        "pose": pose_json(&Vector3::zeros(), &UnitQuaternion::identity()),
        "primitive": {"type": 2, "dimensions": [0.035]},
        "mass": MASS, "friction": FRICTION,
    });
    let gravity = json!({"x": 0.0, "y": 0.0, "z": -9.81});
    let set = |limit: f64| {
        json!({"id": "set", "object": object, "poses": poses, "gravity": gravity, "max_grip_force": limit})
            .to_string()
    };
    let (out, _) = run("rank", &["--json"], &set(0.0), &[]);
    let answer = &out[0];
    let members = answer["recommendations"].as_array().expect("a list");
    assert_eq!(members.len(), poses.len());
    let force = |i: usize| {
        members[i]["recommendation"]["internal_force"]
            .as_f64()
            .unwrap_or(f64::NAN)
    };
    let ranking: Vec<usize> = answer["ranking"]
        .as_array()
        .expect("a ranking")
        .iter()
        .map(|i| i.as_u64().expect("an index") as usize)
        .collect();
    assert_eq!(answer["ranked_by"], "internal_force");
    assert_eq!(ranking.len(), poses.len(), "{answer}");
    assert!(
        ranking.windows(2).all(|w| force(w[0]) <= force(w[1])),
        "{ranking:?}"
    );
    // Each member is the pose answered alone.
    let alone: String = poses
        .iter()
        .map(|p| {
            let mut line = p.clone();
            line["object"] = object.clone();
            line["gravity"] = gravity.clone();
            line.to_string() + "\n"
        })
        .collect();
    for (member, single) in members.iter().zip(solve(&alone)) {
        agree(member, &single, 0.0, "member").unwrap_or_else(|e| panic!("{e}"));
    }
    // A limit between the least and the greatest force: the others exceed it (status 3).
    let mut forces: Vec<f64> = (0..poses.len()).map(force).collect();
    forces.sort_by(f64::total_cmp);
    let limit = (forces[2] + forces[3]) / 2.0;
    let (out, _) = run("rank", &["--json"], &set(limit), &[]);
    let limited = &out[0];
    let ranked: Vec<u64> = limited["ranking"]
        .as_array()
        .expect("a ranking")
        .iter()
        .filter_map(Value::as_u64)
        .collect();
    assert_eq!(ranked.len(), 3, "{limited}");
    for (i, m) in limited["recommendations"]
        .as_array()
        .expect("a list")
        .iter()
        .enumerate()
    {
        let status = m["recommendation"]["status"].as_u64();
        let expected = if force(i) > limit { 3 } else { 0 };
        assert_eq!(status, Some(expected), "p{i}");
        assert_eq!(ranked.contains(&(i as u64)), expected == 0);
    }
    // The table names the limit.
    let table = rank_table(&set(limit));
    assert!(table.starts_with(&format!("6 candidates, 3 ranked by internal_force (gripper_drive coupled, max_grip_force {limit} N)")), "{table}");
}

/// `--closing-axis` turns the fingers: closing along the tool's x meets the cube's x faces.
#[test]
fn the_closing_axis_option_picks_the_tool_axis() {
    let line = cube_line("axis", json!({}), [0.0, 0.0, 0.01], 0.1);
    let (out, _) = run("solve", &["--closing-axis", "x"], &line, &[]);
    let c1 = point(&out[0]["contact_1"]);
    assert!((c1 - Vector3::new(-0.03, 0.0, 0.01)).norm() < 1e-15, "{c1}");
    let out = solve(&line);
    let c1 = point(&out[0]["contact_1"]);
    assert!((c1 - Vector3::new(0.0, -0.03, 0.01)).norm() < 1e-15, "{c1}");
}

/// Runs `plot FILE -o SVG` on a candidate written to `dir/name.json`: exit code, stdout, stderr,
/// and the SVG when written.
fn plot(dir: &Path, name: &str, candidate: &str) -> (Option<i32>, String, String, Option<String>) {
    let input = dir.join(format!("{name}.json"));
    std::fs::write(&input, candidate).expect("write the candidate");
    let svg = dir.join(format!("{name}.svg"));
    let out = bin()
        .arg("plot")
        .arg(&input)
        .arg("-o")
        .arg(&svg)
        .output()
        .expect("plot runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        std::fs::read_to_string(&svg).ok(),
    )
}

/// `plot` draws a pose candidate as the spatial candidate its fingers make: its line is that
/// candidate's, after the pose's id, contacts, normals and centre of mass, and the figure's title
/// names the pose and its contacts. A pose the geometry refuses is refused as a candidate is:
/// exit 2, the message `solve` answers it with, no figure.
#[test]
fn plot_draws_a_pose_as_the_spatial_candidate_of_its_contacts() {
    let dir = temp_dir("plot-pose");
    let line = cube_line("cube-side", json!({}), [0.01, 0.004, 0.012], 0.1);
    let answer = &solve(&line)[0];
    assert_eq!(answer["recommendation"]["status"], 0, "{answer}");
    let candidate = json!({
        "id": "cube-side",
        "contact_1": answer["contact_1"], "contact_2": answer["contact_2"],
        "normal_1": answer["normal_1"], "normal_2": answer["normal_2"],
        "friction_1": FRICTION, "friction_2": FRICTION,
        "center_of_mass": answer["center_of_mass"], "mass": MASS,
        "gravity": {"x": 0.0, "y": 0.0, "z": -9.81}, "model": 1,
    });
    let (code, drawn, stderr, svg) = plot(dir.path(), "candidate", &candidate.to_string());
    assert_eq!(code, Some(0), "{stderr}");
    let (_, summary) = drawn.split_once(": ").expect("wrote …: summary");
    let summary = summary.trim_end();
    assert!(summary.starts_with("grasp plane normal"), "{summary}");
    assert!(svg.is_some_and(|s| !s.contains("cube-side")));

    let (code, drawn, stderr, svg) = plot(dir.path(), "pose", &line);
    assert_eq!(code, Some(0), "{stderr}");
    let contacts = "contact_1 (0.010000, -0.030000, 0.012000), contact_2 (0.010000, 0.030000, \
                    0.012000)";
    let expected = format!(
        "pose \"cube-side\": {contacts}, inward normals (0.000000, 1.000000, 0.000000) and \
         (0.000000, -1.000000, 0.000000), center_of_mass (0.000000, 0.000000, 0.000000); {summary}"
    );
    assert!(drawn.trim_end().ends_with(&expected), "{drawn}\n{expected}");
    let svg = svg.expect("the figure is written");
    assert!(svg.contains("cube-side") && svg.contains(contacts), "{svg}");

    let mut unrotated: Value = serde_json::from_str(&line).expect("JSON");
    unrotated["grasp_pose"]["orientation"] = json!({"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0});
    for (name, refused, words) in [
        (
            "miss",
            cube_line("miss", json!({}), [0.0, 0.0, 0.5], 0.1),
            "finger 1 closes on nothing",
        ),
        (
            "unrotated",
            unrotated.to_string(),
            "invalid input: grasp_pose.orientation is not a rotation",
        ),
    ] {
        // `solve` puts the line's number before a status 2 message; `plot` reads one candidate.
        let message = solve(&refused)[0]["recommendation"]["message"]
            .as_str()
            .expect("a message")
            .trim_start_matches("line 1: ")
            .to_string();
        assert!(message.contains(words), "{message}");
        let (code, _, stderr, svg) = plot(dir.path(), name, &refused);
        assert_eq!(code, Some(2), "{name}: {stderr}");
        assert!(stderr.contains(&message), "{name}: {stderr}");
        assert!(svg.is_none(), "{name}: no figure");
    }
}
