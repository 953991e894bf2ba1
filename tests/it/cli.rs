//! The `grasp_orient` binary as a user runs it.

use crate::util::run::{bin, json_lines, paper_lines, run_fed, temp_dir};
use serde_json::Value;
use std::io::Write;
use std::process::Stdio;

fn run_solve(args: &[&str], input: &str) -> (Vec<Value>, String, bool) {
    let mut cmd = bin();
    cmd.arg("solve").args(args);
    let (out, written) = run_fed(cmd, input);
    written.expect("write stdin");
    (
        json_lines(&out),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.success(),
    )
}

#[test]
fn solve_answers_every_line_and_survives_bad_ones() {
    let mut input = paper_lines();
    input.push_str("not json at all\n");
    input.push_str("{\"id\": \"half\", \"mass\": 1.0}\n");
    input.push('\n');
    input.push_str(
        &paper_lines()
            .lines()
            .next()
            .expect("a line")
            .replace("\"mass\": ", "\"mass\": -"),
    );
    input.push('\n');
    let (out, stderr, ok) = run_solve(&[], &input);
    assert!(ok, "{stderr}");
    assert_eq!(out.len(), 7, "one answer per non-blank line");
    for (i, v) in out.iter().take(4).enumerate() {
        assert_eq!(v["status"], 0, "paper case {i}: {v}");
        assert_eq!(v["recommended_label"], "C");
        assert_eq!(v["candidate_c"], 0);
    }
    assert_eq!(out[4]["status"], 2);
    assert!(out[4]["message"]
        .as_str()
        .is_some_and(|m| m.starts_with("line 5:")));
    assert_eq!(out[5]["candidate_id"], "half");
    assert!(out[5]["message"]
        .as_str()
        .is_some_and(|m| m.contains("line 6") && m.contains("contact_1")));
    assert_eq!(out[6]["status"], 2);
    assert!(out[6]["message"]
        .as_str()
        .is_some_and(|m| m.contains("line 8") && m.contains("mass")));
    assert!(out[6]["gripping_power"].is_null(), "NaN is written as null");
}

#[test]
fn options_change_the_answer() {
    let input = paper_lines();
    let (base, _, _) = run_solve(&[], &input);
    let (graspable, _, _) = run_solve(&["--range", "graspable"], &input);
    let (norm1, _, _) = run_solve(&["--objective", "norm1"], &input);
    let (safe, _, _) = run_solve(&["--friction-safety-factor", "1.2"], &input);
    assert_ne!(base[0]["gravity_angle"], graspable[0]["gravity_angle"]);
    assert_eq!(norm1[0]["objective"], "norm1");
    assert!(safe[0]["internal_force"].as_f64() > base[0]["internal_force"].as_f64());
    let (bounded, _, _) = run_solve(&["--range=-0.2:0.2"], &input);
    let theta = bounded[0]["gravity_angle"].as_f64().expect("a number");
    assert!((-0.2..=0.2).contains(&theta));
}

/// The tolerance options apply to every candidate that gives none, exactly as the same values
/// in the candidate's own JSON fields; a candidate's own wins.
#[test]
fn tolerance_options_are_the_candidates_own_fields_where_it_gives_none() {
    let bottle = r#"{"id":"bottle","contact_1":{"x":0.04,"y":0.16},"contact_2":{"x":-0.04,"y":0.16},"normal_1":{"x":-1,"y":0},"normal_2":{"x":1,"y":0},"friction_1":0.8,"friction_2":0.5,"center_of_mass":{"x":0,"y":0.10},"mass":1.05,"gravity":{"x":0,"y":-9.81}}"#;
    let own = bottle.replace(
        r#""mass":1.05,"#,
        r#""mass":1.05,"center_of_mass_tolerance":{"x":0.02,"y":0.02},"mass_tolerance":0.05,"#,
    );
    let (nominal, _, ok) = run_solve(&[], &format!("{bottle}\n"));
    assert!(ok);
    let (by_option, _, ok) = run_solve(
        &[
            "--center-of-mass-tolerance",
            "0.02,0.02,0",
            "--mass-tolerance",
            "0.05",
        ],
        &format!("{bottle}\n"),
    );
    assert!(ok);
    let (by_field, _, ok) = run_solve(&[], &format!("{own}\n"));
    assert!(ok);
    assert_eq!(by_option, by_field);
    let (both, _, ok) = run_solve(
        &["--center-of-mass-tolerance", "0.001,0.001,0"],
        &format!("{own}\n"),
    );
    assert!(ok);
    assert_eq!(both, by_field, "the candidate's own tolerance wins");
    let num = |v: &Value, f: &str| v[f].as_f64().expect("a number");
    let (n, r) = (&nominal[0], &by_field[0]);
    assert_eq!(r["status"], 0, "{r}");
    assert_eq!(num(n, "gripping_power"), num(n, "gripping_power_nominal"));
    assert!(num(r, "gripping_power") > num(r, "gripping_power_nominal"));
    assert!(num(r, "gripping_power") > num(n, "gripping_power"));
    assert!(num(r, "finger_force") > num(n, "finger_force"));
    assert_ne!(num(r, "wrist_rotation"), num(n, "wrist_rotation"));
}

/// `plot` with tolerances draws the box vertices' curves and their envelope, with the robust
/// recommendation; the numbers printed are `solve`'s.
#[test]
fn plot_draws_the_worst_case_with_tolerances() {
    let dir = temp_dir("plot-robust");
    let candidate = dir.path().join("bottle.json");
    std::fs::write(&candidate, r#"{"id":"bottle","contact_1":{"x":0.04,"y":0.16},"contact_2":{"x":-0.04,"y":0.16},"normal_1":{"x":-1,"y":0},"normal_2":{"x":1,"y":0},"friction_1":0.8,"friction_2":0.5,"center_of_mass":{"x":0,"y":0.10},"mass":1.05,"gravity":{"x":0,"y":-9.81}}"#).expect("write");
    let svg = dir.path().join("bottle.svg");
    let out = bin()
        .args(["plot", candidate.to_str().expect("utf-8"), "-o"])
        .arg(&svg)
        .args(["--center-of-mass-tolerance", "0.02,0.02,0"])
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("worst case over 4 vertices")
            && stdout.contains("norm2 19.773196 N (nominal object there 14.332308 N)"),
        "{stdout}"
    );
    let text = std::fs::read_to_string(&svg).expect("svg written");
    assert!(text.contains("worst case (envelope)") && text.contains("box vertices"));
    // Across the contact line: the reason, and the nominal figure.
    let out = bin()
        .args(["plot", candidate.to_str().expect("utf-8"), "-o"])
        .arg(&svg)
        .args(["--center-of-mass-tolerance", "0.05,0.07,0"])
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("either side of the line"),
        "{stdout}"
    );
}

#[test]
fn bad_options_fail_with_a_readable_error() {
    let (_, stderr, ok) = run_solve(&["--objective", "norm3"], "");
    assert!(!ok);
    assert!(stderr.contains("norm3"), "{stderr}");
    let dir = temp_dir("cli");
    let cfg = dir.path().join("bad.yaml");
    std::fs::write(
        &cfg,
        "grasp_orient:\n  ros__parameters:\n    friction_safety_factor: 0.5\n",
    )
    .expect("write");
    let (_, stderr, ok) = run_solve(&["--config", cfg.to_str().expect("utf-8")], "");
    assert!(!ok);
    assert!(stderr.contains("friction_safety_factor"), "{stderr}");
}

#[test]
fn plot_writes_an_svg() {
    let dir = temp_dir("plot");
    let candidate = dir.path().join("case.json");
    std::fs::write(&candidate, paper_lines().lines().nth(1).expect("case b")).expect("write");
    let svg = dir.path().join("case.svg");
    let out = bin()
        .args([
            "plot",
            candidate.to_str().expect("utf-8"),
            "-o",
            svg.to_str().expect("utf-8"),
        ])
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&svg).expect("svg written");
    assert!(text.starts_with("<svg") && text.contains("α_3") && text.contains("recommended"));
}

/// The paper's case (c) stood up in the y-z plane (model 1), gravity along -z, as a JSON line.
fn upright_square(id: &str, gravity_x: f64) -> String {
    format!(
        r#"{{"id": "{id}", "model": 1, "contact_1": {{"x": 0, "y": 1, "z": 1}}, "contact_2": {{"x": 0, "y": -1, "z": 1}}, "normal_1": {{"x": 0, "y": -1, "z": 0}}, "normal_2": {{"x": 0, "y": 1, "z": 0}}, "friction_1": 1.7320508075688772, "friction_2": 0.5773502691896258, "center_of_mass": {{"x": 0, "y": 0, "z": 0}}, "mass": 1, "gravity": {{"x": {gravity_x}, "y": 0, "z": -1}}}}"#
    )
}

#[test]
fn solve_reads_the_model_absent_as_planar() {
    let case_c = paper_lines().lines().nth(2).expect("case c").to_string();
    let explicit = case_c.replacen('{', "{\"model\": 0, ", 1);
    let unknown = case_c.replacen('{', "{\"model\": 7, ", 1);
    let input = [
        case_c,
        explicit,
        unknown,
        upright_square("upright", 0.0),
        upright_square("swinging", 0.5),
    ]
    .join("\n");
    let (out, stderr, ok) = run_solve(&[], &input);
    assert!(ok, "{stderr}");
    // Absent and 0: the planar model, turning about +z.
    assert_eq!(out[0], out[1]);
    assert_eq!(
        out[0]["rotation_axis"],
        serde_json::json!({"x": 0.0, "y": 0.0, "z": 1.0})
    );
    // Neither 0 nor 1: refused, naming the field.
    assert_eq!(out[2]["status"], 2);
    let why = out[2]["message"].as_str().expect("a message");
    assert!(
        why.contains("line 3") && why.contains("model is 7"),
        "{why}"
    );
    // Spatial: the same turn, about x, in [0, π], with the 3D gravity direction.
    let up = &out[3];
    assert_eq!(up["status"], 0, "{up}");
    let num = |v: &Value| v.as_f64().expect("a number");
    assert!((num(&up["wrist_rotation"]) - std::f64::consts::PI / 12.0).abs() < 1e-12);
    assert!(
        (num(&up["rotation_axis"]["x"]).abs() - 1.0).abs() < 1e-12,
        "{up}"
    );
    assert!(
        (num(&up["gravity_direction"]["z"]) + (std::f64::consts::PI / 12.0).cos()).abs() < 1e-12
    );
    assert_eq!(up["gripping_power"], out[0]["gripping_power"]);
    assert_eq!(up["message"], "");
    // Gravity out of the grasp plane: the object would swing; said, and the current fields are
    // infinite (written as null).
    let swing = &out[4];
    assert_eq!(swing["status"], 0, "{swing}");
    assert!(swing["gripping_power_current"].is_null() && swing["finger_force_current"].is_null());
    let why = swing["message"].as_str().expect("a message");
    assert!(why.contains("swings about the contact axis"), "{why}");
}

/// A spatial candidate with a centre-of-mass box is answered by the spatial robust solver: the
/// tilt of least worst case, its worst values, the nominal object's at rest there; `solve` prints
/// the library's numbers.
#[test]
fn solve_answers_a_spatial_box_with_the_spatial_robust_solver() {
    use grasp_orient::solver::{spatial, Settings};
    use nalgebra::Vector3;
    let boxed = |id: &str, gravity_x: f64, t: [f64; 3], dm: f64| {
        upright_square(id, gravity_x).replacen(
            '{',
            &format!(
                r#"{{"center_of_mass_tolerance": {{"x": {}, "y": {}, "z": {}}}, "mass_tolerance": {dm}, "#,
                t[0], t[1], t[2]
            ),
            1,
        )
    };
    let cases = [
        ("in-plane", 0.0, [0.0, 0.1, 0.05], 0.0),
        ("out-of-plane", 0.0, [0.1, 0.1, 0.0], 0.1),
        ("swinging", 0.5, [0.05, 0.02, 0.1], 0.2),
    ];
    let input: Vec<String> = cases
        .iter()
        .map(|(id, gx, t, dm)| boxed(id, *gx, *t, *dm))
        .collect();
    let (out, stderr, ok) = run_solve(&[], &input.join("\n"));
    assert!(ok, "{stderr}");
    let num = |v: &Value| v.as_f64().expect("a number");
    for ((id, gx, t, dm), a) in cases.iter().zip(&out) {
        let grasp = spatial::Candidate {
            contact_1: Vector3::new(0.0, 1.0, 1.0),
            contact_2: Vector3::new(0.0, -1.0, 1.0),
            normal_1: Vector3::new(0.0, -1.0, 0.0),
            normal_2: Vector3::new(0.0, 1.0, 0.0),
            friction_1: 1.7320508075688772,
            friction_2: 0.5773502691896258,
            center_of_mass: Vector3::zeros(),
            mass: 1.0,
            gravity: Vector3::new(*gx, 0.0, -1.0),
        };
        let u = spatial::robust::Uncertainty {
            center_of_mass_tolerance: Vector3::new(t[0], t[1], t[2]),
            mass_tolerance: *dm,
        };
        let Ok(spatial::robust::Verdict::Recommended(r)) =
            spatial::robust::solve(&grasp, &u, &Settings::default())
        else {
            panic!("{id}: every object in the box can be held");
        };
        assert_eq!(a["status"], 0, "{id}: {a}");
        for (field, value) in [
            ("gravity_angle", r.gravity_angle),
            ("wrist_rotation", r.rotation_angle),
            ("gripping_power", r.gripping_power),
            ("internal_force", r.internal_force),
            ("finger_force", r.finger_force),
            ("gripping_power_current", r.gripping_power_current),
            ("internal_force_current", r.internal_force_current),
            ("finger_force_current", r.finger_force_current),
            ("gripping_power_nominal", r.gripping_power_nominal),
        ] {
            assert_eq!(num(&a[field]), value, "{id}: {field}");
        }
        for (i, f) in r.contact_forces.iter().enumerate() {
            assert_eq!(
                num(&a["contact_forces"][i]),
                *f,
                "{id}: contact_forces[{i}]"
            );
        }
        let g = &a["gravity_direction"];
        let d = r.gravity_direction;
        assert_eq!(
            [num(&g["x"]), num(&g["y"]), num(&g["z"])],
            [d.x, d.y, d.z],
            "{id}"
        );
        assert!(r.gripping_power > r.gripping_power_nominal, "{id}");
    }
}

#[test]
fn plot_draws_a_spatial_candidate_in_its_grasp_plane() {
    let dir = temp_dir("plot-spatial");
    for (name, gravity_x, current) in [("held", 0.0, true), ("swinging", 0.5, false)] {
        let candidate = dir.path().join(format!("{name}.json"));
        std::fs::write(&candidate, upright_square(name, gravity_x)).expect("write");
        let svg = dir.path().join(format!("{name}.svg"));
        let out = bin()
            .args(["plot", candidate.to_str().expect("utf-8"), "-o"])
            .arg(&svg)
            .output()
            .expect("runs");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // The recommended gravity is (0, -sin 15°, -cos 15°) either way; the rotation turns the
        // current gravity onto it, and the weight is mass × |gravity|.
        let g = [gravity_x, 0.0, -1.0_f64];
        let g_norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
        let cos_turn = (std::f64::consts::PI / 12.0).cos() / g_norm;
        let expected = [
            "grasp plane normal (1.000000, 0.000000, 0.000000)".to_string(),
            format!("rotation {:.6} rad about (", cos_turn.acos()),
            format!("norm2 {g_norm:.6} N"),
        ];
        assert!(expected.iter().all(|e| stdout.contains(e)), "{stdout}");
        assert_eq!(stdout.contains("swings"), !current, "{stdout}");
        let text = std::fs::read_to_string(&svg).expect("svg written");
        assert!(text.contains("in the grasp plane") && text.contains("recommended"));
        // plotters writes each text on a line of its own, between `<text …>` and `</text>`; the
        // current pose is a blue dot of radius 5 (its legend's dot has radius 4).
        let legend = text.lines().any(|line| line.trim() == "current");
        let dot = text.contains(r##"r="5" opacity="1" fill="#0000FF""##);
        assert_eq!(
            (legend, dot),
            (current, current),
            "the current pose is drawn only when held"
        );
    }
    // A model that is neither 0 nor 1 is refused.
    let candidate = dir.path().join("bad.json");
    std::fs::write(
        &candidate,
        upright_square("bad", 0.0).replace("\"model\": 1", "\"model\": 3"),
    )
    .expect("write");
    let out = bin()
        .args(["plot", candidate.to_str().expect("utf-8"), "-o"])
        .arg(dir.path().join("bad.svg"))
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("model is 3"));
}

#[test]
fn a_line_of_invalid_utf8_is_answered_and_the_run_goes_on() {
    let cases = paper_lines();
    let mut input = cases.lines().next().expect("case a").as_bytes().to_vec();
    input.extend_from_slice(b"\n{\"id\": \"caf\xe9\"}\n");
    input.extend_from_slice(cases.lines().nth(1).expect("case b").as_bytes());
    input.push(b'\n');
    let mut child = bin()
        .arg("solve")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary runs");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(&input)
        .expect("write stdin");
    let out = child.wait_with_output().expect("binary exits");
    assert!(out.status.success());
    let lines: Vec<Value> = String::from_utf8(out.stdout)
        .expect("utf-8")
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    assert_eq!(lines.len(), 3, "one answer per line");
    assert_eq!(lines[1]["status"], 2);
    assert!(lines[1]["message"]
        .as_str()
        .is_some_and(|m| m.starts_with("line 2: ") && m.contains("UTF-8")));
    assert_eq!(lines[2]["status"], 0);
    assert_eq!(lines[2]["candidate_id"], "paper-b");
}

/// Runs the binary with `args`; (exit code, stderr).
fn exit_of(args: &[&str]) -> (Option<i32>, String) {
    let out = bin()
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn every_numeric_option_has_a_domain_and_exit_code_2() {
    let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/paper_cases.mcap");
    let json = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper_cases.jsonl");
    let cases: &[(&[&str], &str)] = &[
        (&["play", bag, "--wait", "nan"], "--wait"),
        (&["play", bag, "--wait", "inf"], "--wait"),
        (&["play", bag, "--wait", "1e300"], "--wait"),
        (&["play", bag, "--wait", "-1"], "--wait"),
        (&["play", bag, "--rate", "1e-300"], "--rate"),
        (&["play", bag, "--rate", "-2"], "--rate"),
        (&["play", bag, "--rate", "nan"], "--rate"),
        (&["play", bag, "--depth", "0"], "--depth"),
        (&["play", bag, "--depth", "-5"], "--depth"),
        (&["play", bag, "--depth", "100001"], "--depth"),
        (
            &["plot", json, "-o", "x.svg", "--samples", "1e11"],
            "--samples",
        ),
        (
            &["plot", json, "-o", "x.svg", "--samples", "0"],
            "--samples",
        ),
        (
            &["solve", "--friction-safety-factor", "nan"],
            "--friction-safety-factor",
        ),
        (
            &["solve", "--friction-safety-factor", "0.5"],
            "--friction-safety-factor",
        ),
        (
            &["solve", "--friction-safety-factor", "1e300"],
            "--friction-safety-factor",
        ),
        (&["solve", "--range=nan:1"], "--range"),
        (&["solve", "--range=1:inf"], "--range"),
        (&["solve", "--range=1:0"], "--range"),
        (&["solve", "--objective", "norm3"], "--objective"),
        (
            &["replay", bag, "--friction-safety-factor", "-1"],
            "--friction-safety-factor",
        ),
        (&["node", "--ros-args", "-p", "qos_depth:=0"], "qos_depth"),
        (
            &["node", "--ros-args", "-p", "range_min:=.nan"],
            "range_min",
        ),
        (
            &["node", "--ros-args", "-p", "friction_safety_factor:=1e9"],
            "friction_safety_factor",
        ),
        (&["node", "--ros-args", "-p", "no_such:=1"], "no_such"),
        (
            &["solve", "--center-of-mass-tolerance", "0.01,-0.01,0"],
            "--center-of-mass-tolerance",
        ),
        (
            &["solve", "--center-of-mass-tolerance", "0.01,0.01"],
            "--center-of-mass-tolerance",
        ),
        (
            &["rank", "--center-of-mass-tolerance", "nan,0,0"],
            "--center-of-mass-tolerance",
        ),
        (&["solve", "--mass-tolerance", "-0.1"], "--mass-tolerance"),
        (&["rank", "--mass-tolerance", "inf"], "--mass-tolerance"),
        (
            &[
                "node",
                "--ros-args",
                "-p",
                "center_of_mass_tolerance:=[0.01, -1.0, 0.0]",
            ],
            "center_of_mass_tolerance",
        ),
        (
            &["node", "--ros-args", "-p", "mass_tolerance:=-0.5"],
            "mass_tolerance",
        ),
        (&["node", "--ros-args", "--log-level", "loud"], "loud"),
        (
            &["play", bag, "--ros-args", "--log-level", "x:=loud"],
            "loud",
        ),
    ];
    for (args, named) in cases {
        let (code, stderr) = exit_of(args);
        assert_eq!(code, Some(2), "{args:?}: {stderr}");
        let first = stderr.lines().next().unwrap_or_default();
        assert!(
            first.contains("error") && first.contains(named),
            "{args:?}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

#[test]
fn a_config_for_another_node_is_an_error_naming_the_sections() {
    let dir = temp_dir("cfg_cli");
    let cfg = dir.path().join("other.yaml");
    std::fs::write(
        &cfg,
        "gripper:\n  ros__parameters:\n    objective: norm1\narm:\n  ros__parameters: {}\n",
    )
    .expect("write");
    let (code, stderr) = exit_of(&["solve", "--config", cfg.to_str().expect("utf-8")]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("no section for node grasp_orient") && stderr.contains("gripper, arm"),
        "{stderr}"
    );
}

#[test]
fn any_span_of_bounds_is_answered_at_once() {
    let input = paper_lines();
    let (graspable, _, _) = run_solve(&["--range", "graspable"], &input);
    for range in [
        "--range=-1e308:1e308",
        "--range=-1e12:1e12",
        "--range=-1e8:1e8",
    ] {
        let (wide, stderr, ok) = run_solve(&[range], &input);
        assert!(ok, "{range}: {stderr}");
        assert_eq!(wide, graspable, "{range}");
    }
}

/// The spatial example of `docs/spatial.md` is what `solve` prints for
/// `examples/spatial_cases.jsonl`.
#[test]
fn the_spatial_docs_example_is_solves_output() {
    let readme = include_str!("../../docs/spatial.md");
    let command = "$ grasp_orient solve examples/spatial_cases.jsonl | jq -c '{";
    let at = readme
        .find(command)
        .expect("the example in docs/spatial.md");
    let block = &readme[at..readme[at..].find("```").map_or(readme.len(), |e| at + e)];
    let mut lines = block.lines();
    let head = lines.next().expect("the command line");
    let fields: Vec<&str> = head
        [head.find("'{").expect("jq filter") + 2..head.rfind("}'").expect("jq filter end")]
        .split(", ")
        .collect();
    let shown: Vec<Value> = lines
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect();
    let input = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/spatial_cases.jsonl"
    ))
    .expect("the example file");
    let (out, stderr, ok) = run_solve(&[], &input);
    assert!(ok, "{stderr}");
    assert_eq!(shown.len(), out.len(), "one line per candidate");
    // jq prints 0.0 as 0: numbers compare as numbers.
    fn same(a: &Value, b: &Value) -> bool {
        match (a, b) {
            (Value::Number(x), Value::Number(y)) => x.as_f64() == y.as_f64(),
            (Value::Object(x), Value::Object(y)) => {
                x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same(v, w)))
            }
            _ => a == b,
        }
    }
    for (want, got) in shown.iter().zip(&out) {
        for f in &fields {
            assert!(
                same(&want[f], &got[f]),
                "{f} of {}: {} / {}",
                got["candidate_id"],
                want[f],
                got[f]
            );
        }
    }
}

/// A JSON field of the wrong type or out of range is named with what it takes, by each command
/// that reads candidates: `solve` and `rank` per line, `plot` for its file.
#[test]
fn json_errors_name_the_field_and_what_it_takes() {
    let good = paper_lines().lines().next().expect("case a").to_string();
    let bad_model = good.replacen('{', "{\"model\": -1, ", 1);
    let bad_mass = good.replacen('{', "{\"mass\": 1e999, ", 1);
    let (lines, _, _) = run_solve(&[], &format!("{bad_model}\n{bad_mass}\n"));
    assert_eq!(
        lines[0]["message"],
        "line 1: invalid input: field model: expected an integer from 0 to 255 (u8), got \
         integer -1 at column 12"
    );
    assert_eq!(
        lines[1]["message"],
        "line 2: invalid input: field mass: expected a number within ±1.8e308 (a double), got \
         1e999 at column 14"
    );
    let dir = temp_dir("json_errors");
    let input = dir.path().join("bad.jsonl");
    std::fs::write(&input, format!("{good}\n{bad_model}\n")).expect("write");
    let out = bin()
        .args(["rank", "--json", input.to_str().expect("utf-8")])
        .output()
        .expect("rank runs");
    let reply: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(
        reply["recommendations"][1]["message"],
        "line 2: invalid input: field model: expected an integer from 0 to 255 (u8), got \
         integer -1 at column 12"
    );
    let plotted = dir.path().join("bad.json");
    std::fs::write(&plotted, &bad_mass).expect("write");
    let (code, stderr) = exit_of(&[
        "plot",
        plotted.to_str().expect("utf-8"),
        "-o",
        dir.path().join("x.svg").to_str().expect("utf-8"),
    ]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("field mass: expected a number within ±1.8e308 (a double), got 1e999"),
        "{stderr}"
    );
}

/// A tolerance that every candidate would be refused for is refused when given as an option (it
/// was accepted, then every candidate was refused for a field it left at zero); the node's
/// parameters are checked in `node_start.rs`.
#[test]
fn tolerances_every_candidate_would_be_refused_for_are_refused_when_set() {
    let cases: &[(&[&str], &str)] = &[
        (
            &["solve", "--center-of-mass-tolerance", "1e6,0,0"],
            "x: must be in [0, 1e6), got 1e6",
        ),
        (
            &["rank", "--mass-tolerance", "1e9"],
            "must be in [0, 1e9), got 1e9",
        ),
    ];
    for (args, why) in cases {
        let (code, stderr) = exit_of(args);
        assert_eq!(code, Some(2), "{args:?}: {stderr}");
        let first = stderr.lines().next().unwrap_or_default();
        assert!(first.contains(why), "{args:?}: {stderr}");
    }
    // Just below, no candidate is refused as invalid (a box this large holds none of them: status 1).
    let (lines, stderr, _) = run_solve(
        &["--center-of-mass-tolerance", "999999,0,0"],
        &paper_lines(),
    );
    assert_eq!(lines.len(), 4, "{stderr}");
    for line in &lines {
        assert_ne!(line["status"], 2, "{} {stderr}", line["message"]);
    }
}

/// A COLLADA cube (40 units a side) whose `<p>` holds `indices`, its geometry under `depth`
/// nested `<node>` elements.
fn collada_cube(indices: &str, depth: usize) -> String {
    let open = "<node>".repeat(depth);
    let close = "</node>".repeat(depth);
    format!(
        r##"<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><unit meter="0.001"/></asset>
<library_geometries><geometry id="g"><mesh>
<source id="pos"><float_array id="pos-a" count="24">-20 -20 -20 20 -20 -20 -20 20 -20 20 20 -20 -20 -20 20 20 -20 20 -20 20 20 20 20 20</float_array>
<technique_common><accessor source="#pos-a" count="8" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#pos"/></vertices>
<triangles count="12"><input semantic="VERTEX" source="#v" offset="0"/><p>{indices}</p></triangles>
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="s">{open}<node id="n"><instance_geometry url="#g"/></node>{close}</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#s"/></scene>
</COLLADA>"##
    )
}

const CUBE_INDICES: &str =
    "0 2 3 0 3 1 4 5 7 4 7 6 0 1 5 0 5 4 2 6 7 2 7 3 0 4 6 0 6 2 1 3 7 1 7 5";

/// A pose candidate on the mesh file `mesh` (a 40 mm cube about the origin): the fingers close
/// along the world's x axis at a 60 mm opening.
fn pose_on(id: &str, mesh: &str) -> String {
    serde_json::json!({
        "header": {"frame_id": "world"}, "id": id,
        "grasp_pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": -std::f64::consts::FRAC_1_SQRT_2, "w": std::f64::consts::FRAC_1_SQRT_2}},
        "width": 0.06,
        "object": {
            "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
            "mesh": mesh, "mass": 0.1, "friction": 0.5,
        },
        "gravity": {"x": 0.0, "y": 0.0, "z": -9.81},
    })
    .to_string()
}

/// Malformed COLLADA files (an index past the vertices; 10,000 nested `<node>` elements): `solve`
/// answers each with status 2 naming the cause, does not crash (a panic exited 101, the stack
/// overflow 134), and answers the next line; the well-formed cube (its millimetre unit applied)
/// is answered.
#[test]
fn malformed_collada_files_are_refused_and_solve_goes_on() {
    let dir = temp_dir("cli_malformed_collada");
    let write = |name: &str, text: String| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("write");
        path.display().to_string()
    };
    let past = write(
        "past.dae",
        collada_cube(&CUBE_INDICES.replace("0 2 3", "0 2 99"), 0),
    );
    let deep = write("deep.dae", collada_cube(CUBE_INDICES, 10_000));
    let good = write("good.dae", collada_cube(CUBE_INDICES, 3));
    let input = [
        pose_on("past", &past),
        pose_on("deep", &deep),
        pose_on("good", &good),
    ]
    .join("\n");
    let mut cmd = bin();
    cmd.arg("solve");
    let (out, written) = run_fed(cmd, &input);
    written.expect("write stdin");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !matches!(out.status.code(), Some(101 | 134) | None),
        "solve crashed: {:?} {stderr}",
        out.status
    );
    let lines = json_lines(&out);
    assert_eq!(lines.len(), 3, "{lines:?} {stderr}");
    let r = |i: usize| &lines[i]["recommendation"];
    assert_eq!(r(0)["status"], 2, "{}", lines[0]);
    let m = r(0)["message"].as_str().unwrap_or("");
    assert!(
        m.contains("the file is malformed") && m.contains("index 99, past the 8 values"),
        "{m}"
    );
    assert_eq!(r(1)["status"], 2, "{}", lines[1]);
    let m = r(1)["message"].as_str().unwrap_or("");
    assert!(m.contains("nest deeper than 256 levels"), "{m}");
    assert_eq!(r(2)["status"], 0, "{}", lines[2]);
    // The contacts on the cube's faces at x = ∓20 mm: the unit was applied.
    let c1 = lines[2]["contact_1"]["x"].as_f64().unwrap_or(f64::NAN);
    assert!((c1 + 0.02).abs() < 1e-6, "{}", lines[2]);
}

/// `replay` of a recording whose pose candidates name the malformed files: each answer (status 2,
/// the cause named) is reproduced, and `replay` finishes (a panic exited 101, the stack overflow
/// 134).
#[test]
fn replay_of_malformed_collada_files_finishes() {
    use grasp_orient::answer::PoseAnswerer;
    use grasp_orient::config::Config;
    use grasp_orient::geometry::{AmentIndex, ClosingAxis};
    use grasp_orient::msg::PoseCandidate;
    use grasp_orient::record::{BagWriter, Payload};

    let dir = temp_dir("cli_replay_malformed_collada");
    let mut entries = Vec::new();
    let with = Config::default()
        .answering(PoseAnswerer::new(
            ClosingAxis::Y,
            AmentIndex::new(Vec::<std::path::PathBuf>::new()),
        ))
        .expect("valid");
    for (name, text) in [
        (
            "past.dae",
            collada_cube(&CUBE_INDICES.replace("0 2 3", "0 2 99"), 0),
        ),
        ("deep.dae", collada_cube(CUBE_INDICES, 10_000)),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("write");
        let c: PoseCandidate =
            serde_json::from_str(&pose_on(name, &path.display().to_string())).expect("a pose");
        let a = with.answer::<grasp_orient::kind::Poses>(&c);
        assert_eq!(a.recommendation.status, 2, "{a:?}");
        entries.push(Payload::request::<grasp_orient::kind::Poses>(c));
        entries.push(Payload::answer::<grasp_orient::kind::Poses>(a));
    }
    let bag = dir.path().join("malformed.mcap");
    let w = BagWriter::create(&bag, &crate::util::pose_bag_topics(), 100).expect("create");
    crate::util::write_in_order(w, entries, 1_000, 1);
    let out = bin().arg("replay").arg(&bag).output().expect("runs");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(
        !matches!(out.status.code(), Some(101 | 134) | None),
        "replay crashed: {:?} {text}",
        out.status
    );
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.contains("0 differ"), "{text}");
}
