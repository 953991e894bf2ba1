//! `replay`, `recover` and `plot` as a user runs them on recordings that are whole, cut short,
//! damaged or not recordings at all: the exit codes (0 same, 1 differences or losses, 2
//! trouble), errors that name the file and the byte offset, settings taken from the recording,
//! and outputs that never replace an input or an existing file until they are complete.

use crate::util::answer;
use crate::util::run::{bin, paper_messages, temp_dir};
use grasp_orient::config::{Config, RangeKind};
use grasp_orient::msg::GraspCandidate;
use grasp_orient::record::settings::SettingsRecord;
use grasp_orient::record::{BagWriter, Entry, Payload, Topics};
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

fn topics() -> Topics {
    Topics::new("/grasp_candidates", "/grip_recommendations")
}

/// A pose answerer that reads no mesh (the candidates here are contact ones).
fn no_meshes() -> grasp_orient::answer::PoseAnswerer {
    grasp_orient::answer::PoseAnswerer::new(
        grasp_orient::geometry::ClosingAxis::Y,
        grasp_orient::geometry::AmentIndex::default(),
    )
}

/// A recording of `n` paper cases (ids made unique) with their answers under `config`,
/// carrying `config` as its settings when `with_settings`.
fn write_bag(path: &Path, n: usize, config: &Config, with_settings: bool) {
    let settings = *config.answering(no_meshes()).expect("valid").settings();
    let cases = paper_messages();
    let mut w = BagWriter::create(path, &topics(), 100).expect("create");
    if with_settings {
        w.write(&Entry {
            payload: Payload::settings(SettingsRecord {
                since: 0,
                node: "/grasp_orient".into(),
                reason: "start".into(),
                config: config.clone(),
            }),
            log_time: 0,
            publish_time: 0,
        })
        .expect("settings");
    }
    for i in 0..n {
        let mut c = cases[i % cases.len()].clone();
        c.id = format!("{}-{i}", c.id).into();
        let a = answer(&c, &settings);
        let t = 1_000_000_000 + i as u64 * 1000;
        for payload in [
            Payload::request::<grasp_orient::kind::Candidates>(c),
            Payload::answer::<grasp_orient::kind::Candidates>(a),
        ] {
            w.write(&Entry {
                payload,
                log_time: t,
                publish_time: t,
            })
            .expect("write");
        }
    }
    w.finish().expect("finish");
}

fn run(args: &[&str]) -> (Option<i32>, String) {
    let out = bin().args(args).output().expect("binary runs");
    (out.status.code(), text(&out))
}

fn text(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr)
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8")
}

/// Offsets of the chunk records of an MCAP file, read from its summary by hand: each chunk
/// record starts with opcode 0x06 and is followed by message index records (0x07).
fn chunk_offsets(bytes: &[u8]) -> Vec<usize> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().expect("8 bytes")) as usize;
        if op == 0x06 {
            out.push(at);
        }
        if op == 0x0F {
            break;
        }
        at += 9 + len;
    }
    out
}

/// What a recovered recording replays to when chunks were lost: no answer differs, and the only
/// messages without a partner are those of pairs that a lost chunk's `boundaries` split (a chunk
/// ends wherever its bytes run out, so a candidate can be kept while its recommendation is lost,
/// or the other way round). Exit 0 when no pair was split, 1 (unmatched) when one was.
fn replays_but_for_split_pairs(code: Option<i32>, text: &str, boundaries: u64) {
    let summary = regex::Regex::new(concat!(
        r"(\d+) compared with a recorded recommendation, (\d+) differ beyond 1e-9, ",
        r"(\d+) recorded recommendations unmatched"
    ))
    .expect("regex");
    let m = summary.captures(text).unwrap_or_else(|| panic!("{text}"));
    let n = |i: usize| -> u64 { m[i].parse().expect("a count") };
    assert_eq!(n(2), 0, "what was kept replays unchanged: {text}");
    let alone = regex::Regex::new(r"(\d+) of \d+ candidates have no recorded recommendation")
        .expect("regex")
        .captures(text)
        .map_or(0, |c| c[1].parse::<u64>().expect("a count"));
    let split = n(3) + alone;
    assert!(split <= boundaries, "{split} unmatched: {text}");
    assert_eq!(code, Some(if split == 0 { 0 } else { 1 }), "{text}");
}

#[test]
fn exit_codes_are_those_of_diff_and_cmp_and_documented() {
    for command in ["replay", "recover"] {
        let (code, help) = run(&[command, "--help"]);
        assert_eq!(code, Some(0));
        assert!(
            help.contains("Exit codes") && help.contains("1 differences found"),
            "{help}"
        );
    }
    let (code, text) = run(&["replay"]);
    assert_eq!(code, Some(2), "bad arguments: {text}");
    let (code, text) = run(&["replay", "--objective", "norm3", "x.mcap"]);
    assert_eq!(code, Some(2), "{text}");
}

#[test]
fn empty_short_foreign_and_device_inputs_are_trouble_with_the_file_named() {
    let dir = temp_dir("not_bags");
    let cases: [(&str, &[u8], &str); 3] = [
        ("empty.mcap", b"", "is damaged at byte 0: the file is empty"),
        ("magic.mcap", b"\x89MCAP0\r\n", "is cut short at byte 8"),
        (
            "random.mcap",
            b"\x13\x37 these are random bytes, not a recording \x00\xff",
            "no MCAP magic",
        ),
    ];
    for (name, bytes, says) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).expect("write");
        for args in [
            vec!["replay", s(&path)],
            vec!["recover", s(&path), "-o", s(&dir.path().join("out.mcap"))],
            vec!["play", s(&path), "--wait", "0.1"],
        ] {
            let (code, text) = run(&args);
            assert_eq!(code, Some(2), "{args:?}: {text}");
            assert!(
                text.contains(name) && text.contains(says),
                "{args:?}: {text}"
            );
        }
        assert!(!dir.path().join("out.mcap").exists());
    }
    // /dev/zero never ends: refused at once rather than read forever.
    let t = Instant::now();
    let (code, text) = run(&["replay", "/dev/zero"]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("/dev/zero: not a regular file"), "{text}");
    assert!(t.elapsed() < Duration::from_secs(10));
}

#[test]
fn a_cut_recording_is_refused_with_its_offset_and_recovered_with_its_losses() {
    let dir = temp_dir("cut");
    let whole = dir.path().join("whole.mcap");
    write_bag(&whole, 2000, &Config::default(), true);
    let bytes = std::fs::read(&whole).expect("read");
    let chunks = chunk_offsets(&bytes);
    assert!(chunks.len() >= 2, "{chunks:?}");
    // Cut in the middle of the last chunk, as a killed recorder leaves it.
    let last = *chunks.last().expect("a chunk");
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..last + 200]).expect("write");
    let (code, text) = run(&["replay", s(&cut)]);
    assert_eq!(code, Some(2), "{text}");
    assert!(
        text.contains(&format!("cut.mcap is cut short at byte {last}"))
            && text.contains("grasp_orient recover"),
        "{text}"
    );
    let fixed = dir.path().join("fixed.mcap");
    let (code, text) = run(&["recover", s(&cut), "-o", s(&fixed)]);
    assert_eq!(code, Some(1), "messages were lost: {text}");
    assert!(
        text.contains("whose messages nothing counts")
            && text.contains(&format!("at byte {last}: "))
            && text.contains("cut short inside this record"),
        "{text}"
    );
    let (code, text) = run(&["replay", s(&fixed)]);
    replays_but_for_split_pairs(code, &text, 1);
    // Cut exactly where the last chunk starts: nothing in the file was cut.
    std::fs::write(&cut, &bytes[..last]).expect("write");
    let (code, text) = run(&["recover", s(&cut), "-o", s(&fixed)]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("where a record ends"), "{text}");
}

#[test]
fn a_damaged_chunk_is_named_by_replay_and_dropped_and_counted_by_recover() {
    let dir = temp_dir("flip");
    let whole = dir.path().join("whole.mcap");
    write_bag(&whole, 2000, &Config::default(), true);
    let mut bytes = std::fs::read(&whole).expect("read");
    let chunk = chunk_offsets(&bytes)[1];
    bytes[chunk + 300] ^= 0x04;
    let flipped = dir.path().join("flipped.mcap");
    std::fs::write(&flipped, &bytes).expect("write");
    for args in [vec!["replay", s(&flipped)], vec!["play", s(&flipped)]] {
        let (code, text) = run(&args);
        assert_eq!(code, Some(2), "{args:?}: {text}");
        assert!(
            text.contains(&format!(
                "flipped.mcap is damaged at byte {chunk}: chunk record"
            )),
            "{args:?}: {text}"
        );
    }
    let fixed = dir.path().join("fixed.mcap");
    let (code, text) = run(&["recover", s(&flipped), "-o", s(&fixed)]);
    assert_eq!(code, Some(1), "{text}");
    let dropped =
        regex::Regex::new(r"/grasp_candidates: (\d+) messages kept, (\d+) dropped").expect("regex");
    let m = dropped.captures(&text).unwrap_or_else(|| panic!("{text}"));
    let (kept, lost): (u64, u64) = (m[1].parse().expect("n"), m[2].parse().expect("n"));
    assert!(lost > 0 && kept + lost == 2000, "{text}");
    assert!(
        text.contains(&format!("at byte {chunk}: chunk record")),
        "{text}"
    );
    let (code, text) = run(&["replay", s(&fixed)]);
    replays_but_for_split_pairs(code, &text, 2);
    assert!(
        text.contains(&format!("replayed {kept} candidates")),
        "{text}"
    );
}

#[test]
fn a_whole_recording_recovers_whole_with_its_settings() {
    let dir = temp_dir("whole");
    let whole = dir.path().join("whole.mcap");
    let config = Config {
        friction_safety_factor: 1.5,
        ..Config::default()
    };
    write_bag(&whole, 10, &config, true);
    let fixed = dir.path().join("fixed.mcap");
    let (code, text) = run(&["recover", s(&whole), "-o", s(&fixed)]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("1 metadata records kept"), "{text}");
    let (code, text) = run(&["replay", s(&fixed)]);
    assert_eq!(code, Some(0), "the settings came along: {text}");
}

#[test]
fn replay_solves_with_the_recorded_settings_and_says_what_the_command_line_overrode() {
    let dir = temp_dir("settings");
    let config = Config {
        range: RangeKind::Graspable,
        friction_safety_factor: 1.5,
        ..Config::default()
    };
    let with = dir.path().join("with_settings.mcap");
    write_bag(&with, 8, &config, true);
    let (code, text) = run(&["replay", s(&with)]);
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("solved with the settings it recorded (1 settings record)")
            && text.contains("8 compared with a recorded recommendation, 0 differ"),
        "{text}"
    );
    // The command line wins, and the summary says so.
    let (code, text) = run(&["replay", s(&with), "--friction-safety-factor", "1.0"]);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("overridden from the command line: friction_safety_factor"),
        "{text}"
    );
    let (code, text) = run(&[
        "replay",
        s(&with),
        "--friction-safety-factor",
        "1.5",
        "--range",
        "graspable",
    ]);
    assert_eq!(code, Some(0), "{text}");
    // The same answers without their settings differ from the built-in config: the settings
    // are what makes the replay exact.
    let without = dir.path().join("without_settings.mcap");
    write_bag(&without, 8, &config, false);
    let (code, text) = run(&["replay", s(&without)]);
    assert_eq!(code, Some(1), "{text}");
    assert!(text.contains("recorded no settings"), "{text}");
}

#[test]
fn replay_write_carries_the_settings_it_used() {
    let dir = temp_dir("write_settings");
    let config = Config {
        range: RangeKind::Graspable,
        ..Config::default()
    };
    let bag = dir.path().join("in.mcap");
    write_bag(&bag, 8, &config, true);
    let out = dir.path().join("out.mcap");
    let (code, text) = run(&["replay", s(&bag), "--write", s(&out)]);
    assert_eq!(code, Some(0), "{text}");
    let (code, text) = run(&["replay", s(&out)]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("settings it recorded"), "{text}");
}

#[test]
fn answers_that_cannot_be_compared_are_not_a_pass() {
    let dir = temp_dir("uncompared");
    let whole = dir.path().join("whole.mcap");
    write_bag(&whole, 8, &Config::default(), true);
    // A corrupted schema name: the answers are no longer recognised as answers.
    let renamed = dir.path().join("renamed.mcap");
    rewrite(
        &whole,
        &renamed,
        |name| name.replace("Recommendation", "Recommendatio_"),
        |_, d| d,
    );
    let (code, text) = run(&["replay", s(&renamed)]);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("0 compared") && text.contains("8 of 8 candidates have no recorded"),
        "{text}"
    );
    // Answers that do not decode: trouble, named.
    let cut = dir.path().join("undecodable.mcap");
    rewrite(
        &whole,
        &cut,
        |name| name.to_string(),
        |topic, data| {
            if topic == "/grip_recommendations" {
                data[..data.len() / 2].to_vec()
            } else {
                data
            }
        },
    );
    let (code, text) = run(&["replay", s(&cut)]);
    assert_eq!(code, Some(2), "{text}");
    assert!(
        text.contains("8 messages of grasp_orient's types do not decode")
            && text.contains("/grip_recommendations #1"),
        "{text}"
    );
}

/// Copies a bag through the mcap crate, with its schema names and payloads edited.
fn rewrite(
    from: &Path,
    to: &Path,
    schema_name: impl Fn(&str) -> String,
    payload: impl Fn(&str, Vec<u8>) -> Vec<u8>,
) {
    let bytes = std::fs::read(from).expect("read");
    let file = std::fs::File::create(to).expect("create");
    let mut w = mcap::Writer::new(std::io::BufWriter::new(file)).expect("writer");
    let mut channels = std::collections::HashMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("a message");
        let id = *channels.entry(m.channel.id).or_insert_with(|| {
            let schema = m.channel.schema.as_ref().expect("a schema");
            let sid = w
                .add_schema(&schema_name(&schema.name), &schema.encoding, &schema.data)
                .expect("schema");
            w.add_channel(
                sid,
                &m.channel.topic,
                &m.channel.message_encoding,
                &m.channel.metadata,
            )
            .expect("channel")
        });
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: m.sequence,
            log_time: m.log_time,
            publish_time: m.publish_time,
        };
        let data = payload(&m.channel.topic, m.data.into_owned());
        w.write_to_known_channel(&header, &data).expect("write");
    }
    w.finish().expect("finish");
}

#[test]
fn no_command_writes_over_its_own_input() {
    let dir = temp_dir("own_input");
    let bag = dir.path().join("bag.mcap");
    write_bag(&bag, 4, &Config::default(), true);
    let before = std::fs::read(&bag).expect("read");
    let link = dir.path().join("link.mcap");
    std::fs::hard_link(&bag, &link).expect("a link");
    for args in [
        vec!["replay", s(&bag), "--write", s(&bag)],
        vec!["replay", s(&bag), "--write", s(&link)],
        vec!["recover", s(&bag), "-o", s(&bag)],
    ] {
        let (code, text) = run(&args);
        assert_eq!(code, Some(2), "{args:?}: {text}");
        assert!(text.contains("refusing to write"), "{args:?}: {text}");
        assert_eq!(std::fs::read(&bag).expect("read"), before, "{args:?}");
    }
    let json = dir.path().join("case.json");
    let case = serde_json::to_string(&paper_messages()[1]).expect("json");
    std::fs::write(&json, &case).expect("write");
    let (code, text) = run(&["plot", s(&json), "-o", s(&json)]);
    assert_eq!(code, Some(2), "{text}");
    assert_eq!(std::fs::read_to_string(&json).expect("read"), case);
}

/// A recording big enough that writing its replay or its recovery takes a while; made once in
/// the target's temporary folder (written under another name and renamed, so that a run
/// killed while writing it leaves no half bag for the next one).
fn big_bag() -> &'static Path {
    static BAG: OnceLock<PathBuf> = OnceLock::new();
    BAG.get_or_init(|| {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
        let path = dir.join("grasp_orient_big_150000.mcap");
        if !path.exists() {
            let part = dir.join(format!("grasp_orient_big_{}.part", std::process::id()));
            std::fs::remove_file(&part).ok();
            write_bag(&part, 150_000, &Config::default(), true);
            std::fs::rename(&part, &path).expect("renamed into place");
        }
        path
    })
}

/// Starts `args`, waits until a temporary `.NAME.*.part` beside `destination` has grown past
/// 256 KiB, kills the process there, and returns the temporary files left.
fn kill_while_writing(args: &[&str], destination: &Path) -> Vec<PathBuf> {
    let folder = destination.parent().expect("a folder");
    let prefix = format!(
        ".{}.",
        destination.file_name().expect("named").to_string_lossy()
    );
    let mut child = bin()
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("runs");
    let deadline = Instant::now() + Duration::from_secs(120);
    let temps = || -> Vec<PathBuf> {
        std::fs::read_dir(folder)
            .expect("the folder")
            .map(|e| e.expect("an entry").path())
            .filter(|p| {
                p.file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with(&prefix))
            })
            .collect()
    };
    loop {
        let grown = temps()
            .iter()
            .any(|p| std::fs::metadata(p).is_ok_and(|m| m.len() > 256 * 1024));
        if grown {
            break;
        }
        if let Some(status) = child.try_wait().expect("status") {
            panic!("{args:?} ended ({status}) before it could be killed while writing");
        }
        assert!(Instant::now() < deadline, "{args:?} never wrote 256 KiB");
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().expect("killed");
    child.wait().expect("reaped");
    temps()
}

#[test]
fn a_killed_replay_write_or_recover_leaves_the_old_file_as_it_was() {
    let dir = temp_dir("killed");
    let old = dir.path().join("precious.mcap");
    write_bag(&old, 4, &Config::default(), true);
    let before = std::fs::read(&old).expect("read");
    let big = big_bag();
    for args in [
        vec!["replay", s(big), "--write", s(&old)],
        vec!["recover", s(big), "-o", s(&old)],
    ] {
        let left = kill_while_writing(&args, &old);
        assert_eq!(
            std::fs::read(&old).expect("read"),
            before,
            "{args:?} changed the old file before it was done"
        );
        assert_eq!(left.len(), 1, "{left:?}");
        std::fs::remove_file(&left[0]).ok();
    }
    // Let to finish, the same commands replace it.
    let (code, text) = run(&["recover", s(big), "-o", s(&old)]);
    assert_eq!(code, Some(0), "{text}");
    assert!(std::fs::metadata(&old).expect("there").len() > before.len() as u64);
}

#[test]
fn a_closed_stdout_pipe_is_success() {
    // `solve | head -1`: the reader goes away while answers are still coming.
    let mut child = bin()
        .arg("solve")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let mut stdin = child.stdin.take().expect("stdin");
    let mut stdout = child.stdout.take().expect("stdout");
    let feeder = std::thread::spawn(move || {
        let line = serde_json::to_string(&paper_messages()[0]).expect("json") + "\n";
        for _ in 0..50_000 {
            if std::io::Write::write_all(&mut stdin, line.as_bytes()).is_err() {
                break;
            }
        }
    });
    let mut first = [0u8; 64];
    std::io::Read::read_exact(&mut stdout, &mut first).expect("a first answer");
    drop(stdout);
    let out = child.wait_with_output().expect("ends");
    feeder.join().expect("fed");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
}

/// A recording of spatial candidates (`examples/spatial_cases.jsonl`) with their answers replays
/// unchanged; the same with one answer's `rotation_axis` turned differs, naming the field.
#[test]
fn a_recording_of_spatial_candidates_replays_and_a_turned_axis_differs() {
    let cases: Vec<GraspCandidate> = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/spatial_cases.jsonl"
    ))
    .expect("examples/spatial_cases.jsonl")
    .lines()
    .map(|l| serde_json::from_str(l).expect("a candidate"))
    .collect();
    let settings = *Config::default()
        .answering(no_meshes())
        .expect("valid")
        .settings();
    let dir = temp_dir("spatial_replay");
    let write = |path: &Path, turn: bool| {
        let mut w = BagWriter::create(path, &topics(), 100).expect("create");
        for (i, c) in cases.iter().enumerate() {
            let mut a = answer(c, &settings);
            assert_eq!(c.model, GraspCandidate::MODEL_SPATIAL);
            if turn && i == 0 {
                a.rotation_axis.x = -a.rotation_axis.x;
            }
            let t = 1_000 + i as u64;
            for payload in [
                Payload::request::<grasp_orient::kind::Candidates>(c.clone()),
                Payload::answer::<grasp_orient::kind::Candidates>(a),
            ] {
                w.write(&Entry {
                    payload,
                    log_time: t,
                    publish_time: t,
                })
                .expect("write");
            }
        }
        w.finish().expect("finish");
    };
    let same = dir.path().join("same.mcap");
    write(&same, false);
    let (code, text) = run(&["replay", s(&same)]);
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("3 compared with a recorded recommendation, 0 differ"),
        "{text}"
    );
    let turned = dir.path().join("turned.mcap");
    write(&turned, true);
    let (code, text) = run(&["replay", s(&turned)]);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("1 differ") && text.contains("rotation_axis.x") && text.contains("mug"),
        "{text}"
    );
}

/// A decompression bomb is damage to the reader and to `recover`, and is never decompressed.
#[test]
fn a_decompression_bomb_is_damage_never_decompressed() {
    use grasp_orient::record::{bag, recover};
    let bomb = crate::util::zstd_bomb::zstd_bomb();
    assert!(bomb.len() < 8 << 10, "{} bytes", bomb.len());
    let d = bag::read_bytes(&bomb).expect_err("refused");
    assert_eq!(d.offset, 8 + 9 + 12, "the chunk's offset: {d}");
    assert!(
        d.what.contains("declares 67108864 bytes") && d.what.contains("1024 times"),
        "{d}"
    );
    let (got, _) =
        recover::recover_bytes(&bomb, std::io::Cursor::new(Vec::new())).expect("recovered");
    assert_eq!((got.kept_total(), got.damage_count), (0, 1), "{got:?}");
}
