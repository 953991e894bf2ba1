//! How `grasp_orient node` starts: `--ros-args` and parameters that every candidate would be
//! refused for refused in one line before it joins the graph, a refusal after it joined without
//! the spinner's noise, and a warning when another node of its
//! name is on the domain. Each node runs on a domain of these tests' own, on loopback.

use crate::util::run::{bin, temp_dir};
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A domain apart from the one `play.rs` uses (200 to 229).
fn domain() -> String {
    (140 + std::process::id() % 30).to_string()
}

/// A node started with `ros_args`, its stderr collected as it comes.
struct Node {
    child: Child,
    stderr: Arc<Mutex<String>>,
}

impl Node {
    fn start(ros_args: &[&str]) -> Self {
        let mut child = bin()
            .args(["node", "--ros-args"])
            .args(ros_args)
            .env("ROS_DOMAIN_ID", domain())
            .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the node starts");
        let stderr = Arc::new(Mutex::new(String::new()));
        let pipe = child.stderr.take().expect("stderr");
        let sink = Arc::clone(&stderr);
        std::thread::spawn(move || {
            for line in BufReader::new(pipe).lines().map_while(Result::ok) {
                let mut text = sink.lock().unwrap_or_else(|e| e.into_inner());
                text.push_str(&line);
                text.push('\n');
            }
        });
        Self { child, stderr }
    }

    fn stderr(&self) -> String {
        self.stderr
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Waits up to `limit` for stderr to contain `text`.
    fn wait_for(&self, text: &str, limit: Duration) -> bool {
        let deadline = Instant::now() + limit;
        while Instant::now() < deadline {
            if self.stderr().contains(text) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        false
    }

    /// Its exit code within `limit` (after SIGINT when `interrupt`); `None` if it had to be
    /// killed.
    fn exit(mut self, interrupt: bool, limit: Duration) -> (Option<i32>, String) {
        if interrupt {
            let _ = Command::new("kill")
                .args(["-INT", &self.child.id().to_string()])
                .status();
        }
        let deadline = Instant::now() + limit;
        let code = loop {
            if let Some(s) = self.child.try_wait().expect("wait") {
                break s.code();
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        // The reader thread has the last lines once the pipe closes.
        std::thread::sleep(Duration::from_millis(100));
        (code, self.stderr())
    }
}

#[test]
fn remaps_against_the_ros_2_rules_are_one_line_errors() {
    for (rule, why) in [
        (":=x", "the left side is empty"),
        ("a:=b:=c", "has more than one ':='"),
        ("__ns:=/arm/", "\"/arm/\" has an empty token"),
        ("__node:=2arm", "\"2arm\" has a token starting with a digit"),
        ("grip_markers:=a-b", "\"a-b\" has '-' at 1"),
        (
            "grip_markers:=grip_recommendations",
            "topics grip_recommendations and grip_markers are both remapped to \
             /grip_recommendations",
        ),
    ] {
        let (code, stderr) = Node::start(&["-r", rule]).exit(false, Duration::from_secs(20));
        assert_eq!(code, Some(2), "{rule}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{rule}: {stderr}");
        assert!(
            stderr.starts_with("grasp_orient: error: --ros-args: ") && stderr.contains(why),
            "{rule}: {stderr}"
        );
    }
}

#[test]
fn tolerances_every_candidate_would_be_refused_for_are_refused_at_start() {
    for (param, why) in [
        (
            "center_of_mass_tolerance:=[0.0, 0.0, 1e6]",
            "parameter center_of_mass_tolerance: z: must be in [0, 1e6), got 1e6",
        ),
        (
            "mass_tolerance:=1e9",
            "parameter mass_tolerance: must be in [0, 1e9), got 1e9",
        ),
    ] {
        let (code, stderr) = Node::start(&["-p", param]).exit(false, Duration::from_secs(20));
        assert_eq!(code, Some(2), "{param}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{param}: {stderr}");
        assert!(stderr.contains(why), "{param}: {stderr}");
    }
}

#[test]
fn a_gripper_action_that_cannot_be_used_is_refused_at_start() {
    for (params, why) in [
        (
            &["gripper_action:=a", "parallel_gripper_action:=b"][..],
            "parameters gripper_action (a) and parallel_gripper_action (b) are both set",
        ),
        (
            &["gripper_action:=gripper//cmd"][..],
            "parameter gripper_action: \"gripper//cmd\" is not a ROS name",
        ),
    ] {
        let args: Vec<&str> = params.iter().flat_map(|p| ["-p", p]).collect();
        let (code, stderr) = Node::start(&args).exit(false, Duration::from_secs(20));
        assert_eq!(code, Some(2), "{params:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{params:?}: {stderr}");
        assert!(stderr.contains(why), "{params:?}: {stderr}");
    }
}

#[test]
fn a_refusal_after_joining_the_graph_is_not_preceded_by_spinner_noise() {
    let dir = temp_dir("refusal");
    let file = dir.path().join("a_file");
    std::fs::write(&file, "").expect("write");
    let record_dir = format!("record_dir:={}", file.join("runs").display());
    let (code, stderr) = Node::start(&["-r", "__node:=refused", "-p", &record_dir])
        .exit(false, Duration::from_secs(20));
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr
            .lines()
            .last()
            .is_some_and(|l| l.starts_with("grasp_orient: error: recording is off")),
        "{stderr}"
    );
    assert!(!stderr.contains("Cannot notify spin task"), "{stderr}");
}

#[test]
fn a_namesake_on_the_domain_is_warned_of_by_both() {
    let name = format!("twin_{}", std::process::id());
    let args = ["-r", &format!("__node:={name}"), "-p", "record:=false"];
    let first = Node::start(&args);
    assert!(
        first.wait_for("waiting for", Duration::from_secs(20)),
        "{}",
        first.stderr()
    );
    let second = Node::start(&args);
    let warning = format!("another node named /{name} is on the ROS graph");
    let heard = [&first, &second].map(|n| n.wait_for(&warning, Duration::from_secs(20)));
    let (first_code, first_err) = first.exit(true, Duration::from_secs(10));
    let (second_code, second_err) = second.exit(true, Duration::from_secs(10));
    assert_eq!(heard, [true, true], "{first_err}\n---\n{second_err}");
    for (code, stderr) in [(first_code, &first_err), (second_code, &second_err)] {
        assert_eq!(code, Some(0), "{stderr}");
        assert_eq!(stderr.matches(&warning).count(), 1, "warned once: {stderr}");
    }
    let alone = Node::start(&[
        "-r",
        &format!("__node:={name}_alone"),
        "-p",
        "record:=false",
    ]);
    let quiet = !alone.wait_for("another node named", Duration::from_secs(3));
    let (_, alone_err) = alone.exit(true, Duration::from_secs(10));
    assert!(quiet, "{alone_err}");
}

/// A node stopped with no pose candidate in flight leaves at once, without a warning about a
/// mesh still loading: the wait for pose answers at a stop waited out its whole grace, and
/// warned, at every stop.
#[test]
fn a_stop_with_no_pose_in_flight_says_nothing_of_meshes() {
    let name = format!("stop_{}", std::process::id());
    let node = Node::start(&["-r", &format!("__node:={name}"), "-p", "record:=false"]);
    assert!(
        node.wait_for("waiting for", Duration::from_secs(20)),
        "{}",
        node.stderr()
    );
    let (code, stderr) = node.exit(true, Duration::from_secs(10));
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stderr.contains("leaving the ROS graph"), "{stderr}");
    assert!(!stderr.contains("still loading"), "{stderr}");
}
