//! `play` feeds a recording to a live node over DDS, and that node's own recording replays
//! unchanged: play, node, recording and replay end to end, with no ROS install.

mod common;

use common::run::{bin, temp_dir};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn played_candidates_are_answered_recorded_and_replay_unchanged() {
    let dir = temp_dir("play");
    let domain = (200 + std::process::id() % 30).to_string();
    let mut node = bin()
        .args(["node", "--ros-args", "-p"])
        .arg(format!("record_dir:={}", dir.path().display()))
        .env("ROS_DOMAIN_ID", &domain)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("node starts");
    let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/paper_cases.mcap");
    let played = bin()
        .args(["play", bag, "--rate", "0", "--wait", "20"])
        .env("ROS_DOMAIN_ID", &domain)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .output()
        .expect("play runs");
    std::thread::sleep(Duration::from_millis(500));
    let _ = Command::new("kill")
        .args(["-INT", &node.id().to_string()])
        .status();
    let deadline = Instant::now() + Duration::from_secs(10);
    let status = loop {
        if let Some(s) = node.try_wait().expect("wait") {
            break Some(s);
        }
        if Instant::now() > deadline {
            let _ = node.kill();
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let text = String::from_utf8_lossy(&played.stdout).into_owned()
        + &String::from_utf8_lossy(&played.stderr);
    assert!(played.status.success(), "{text}");
    assert!(text.contains("published 4 of 4 candidates"), "{text}");
    assert!(
        status.is_some_and(|s| s.success()),
        "node did not exit cleanly on SIGINT"
    );
    let recording = std::fs::read_dir(dir.path())
        .expect("record dir")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "mcap"))
        .expect("the node wrote a recording");
    let out = bin()
        .args(["replay", recording.to_str().expect("utf-8")])
        .output()
        .expect("replay runs");
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{summary}");
    assert!(
        summary.contains("4 compared with a recorded recommendation, 0 differ"),
        "{summary}"
    );
}
