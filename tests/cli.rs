//! The `grasp_orient` binary as a user runs it.

mod common;

use common::run::{bin, temp_dir};
use serde_json::Value;
use std::io::Write;
use std::process::Stdio;

fn run_solve(args: &[&str], input: &str) -> (Vec<Value>, String, bool) {
    let mut child = bin()
        .arg("solve")
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary runs");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(input.as_bytes())
        .expect("write stdin");
    let out = child.wait_with_output().expect("binary exits");
    let lines = String::from_utf8(out.stdout)
        .expect("utf-8")
        .lines()
        .map(|l| serde_json::from_str(l).expect("every output line is JSON"))
        .collect();
    (
        lines,
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.success(),
    )
}

fn paper_cases() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/paper_cases.jsonl"
    ))
    .expect("examples/paper_cases.jsonl")
}

#[test]
fn solve_answers_every_line_and_survives_bad_ones() {
    let mut input = paper_cases();
    input.push_str("not json at all\n");
    input.push_str("{\"id\": \"half\", \"mass\": 1.0}\n");
    input.push('\n');
    input.push_str(
        &paper_cases()
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
    let input = paper_cases();
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
    std::fs::write(&candidate, paper_cases().lines().nth(1).expect("case b")).expect("write");
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
