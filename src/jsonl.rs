//! JSON lines, as `grasp_orient solve` reads and writes them: one `GraspCandidate` per line in,
//! one `GripRecommendation` per line out, in order; a line with a `grasp_pose` field is a
//! `PoseCandidate`, answered with a `PoseRecommendation` (`docs/poses.md`). Any bytes are input: a line that is not
//! UTF-8, not JSON or not a candidate gets status 2 with its line number, and the lines after it
//! are answered as usual. Memory is bounded by the longest line.

use crate::answer::{without_geometry, Answering};
use crate::kind::{Candidates, Poses};
use crate::msg::{invalid, GraspCandidate, GripRecommendation, PoseCandidate, PoseRecommendation};
use std::io::{BufRead, Read, Write};

/// Longest line read, bytes (a candidate with a 1 MiB id is about 1 MiB); a longer line is
/// answered with status 2 and skipped, so memory stays bounded even by an input without line
/// breaks.
pub(crate) const MAX_LINE_BYTES: usize = 16 << 20;

/// What a run of [`answer_lines`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Lines answered (blank lines are skipped).
    pub answered: usize,
    /// Answered with a status other than 0.
    pub not_solved: usize,
}

/// Why [`answer_lines`] stopped early.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinesError {
    /// The input could not be read.
    #[error("cannot read line {line}: {source}")]
    Read {
        /// The line being read, from 1.
        line: usize,
        /// The cause.
        source: std::io::Error,
    },
    /// An answer could not be written.
    #[error("cannot write the answer: {0}")]
    Write(std::io::Error),
}

/// Why a text is not a candidate: the field at fault (its path, as `contact_1.x`), what the field
/// takes and what it was given, with where in the text.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum JsonError {
    /// The text is not JSON.
    #[error("not JSON: {why} {at}")]
    Syntax {
        /// serde_json's words.
        why: String,
        /// Where: `at column C`, or `at line L column C` in a text of several lines.
        at: String,
    },
    /// A field of the wrong type, or a number outside its type's range.
    #[error("{prefix}expected {expected}, got {got} {at}", prefix = field_prefix(.path))]
    Field {
        /// The path of the field, as `candidates[3].model` (empty at the top).
        path: String,
        /// What the field takes.
        expected: String,
        /// What it was given.
        got: String,
        /// Where.
        at: String,
    },
    /// A field that is missing or unknown, or another refusal of an object.
    #[error("{prefix}{why} {at}", prefix = field_prefix(.path))]
    Object {
        /// The path of the object (empty at the top).
        path: String,
        /// serde's words.
        why: String,
        /// Where.
        at: String,
    },
}

/// `field PATH: `, or nothing for the top level.
fn field_prefix(path: &str) -> String {
    if path.is_empty() {
        String::new()
    } else {
        format!("field {path}: ")
    }
}

/// Reads a value of type `T` (a `GraspCandidate`, a set) from JSON `text`, naming the field at
/// fault when it is not one.
pub(crate) fn parse<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, JsonError> {
    let mut reader = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut reader)
        .map_err(|e| describe(&e.path().to_string(), e.inner(), text))?;
    reader.end().map_err(|e| describe(".", &e, text))?;
    Ok(value)
}

/// serde's words for a refusal at `path` (`.` for the top level) turned into [`JsonError`].
fn describe(path: &str, inner: &serde_json::Error, text: &str) -> JsonError {
    let at = if inner.line() <= 1 {
        format!("at column {}", inner.column())
    } else {
        format!("at line {} column {}", inner.line(), inner.column())
    };
    // serde_json's message without its " at line L column C".
    let full = inner.to_string();
    let suffix = format!(" at line {} column {}", inner.line(), inner.column());
    let why = full.strip_suffix(&suffix).unwrap_or(&full).to_string();
    let path = if path == "." { "" } else { path }.to_string();
    if let Some(rest) = why
        .strip_prefix("invalid type: ")
        .or_else(|| why.strip_prefix("invalid value: "))
    {
        if let Some((got, expected)) = rest.rsplit_once(", expected ") {
            return JsonError::Field {
                path,
                expected: expected_in_words(expected),
                got: got.replace('`', ""),
                at,
            };
        }
    }
    if why == "number out of range" && !path.is_empty() {
        return JsonError::Field {
            path,
            expected: "a number within ±1.8e308 (a double)".to_string(),
            got: number_before(text, inner.line(), inner.column()),
            at,
        };
    }
    if inner.is_syntax() || inner.is_eof() {
        return JsonError::Syntax { why, at };
    }
    // The path of an unknown field ends with its own name, which the words already give.
    let path = if why.starts_with("unknown field") {
        path.rsplit_once('.').map_or("", |(parent, _)| parent)
    } else {
        &path
    };
    JsonError::Object {
        path: path.to_string(),
        why,
        at,
    }
}

/// serde's name of an expected type in words: the range of an integer type.
fn expected_in_words(expected: &str) -> String {
    let range = match expected {
        "u8" => "0 to 255",
        "u16" => "0 to 65535",
        "u32" => "0 to 4294967295",
        "i32" => "-2147483648 to 2147483647",
        "u64" => "0 to 18446744073709551615",
        "i64" => "-9223372036854775808 to 9223372036854775807",
        "f64" => return "a number (a double)".to_string(),
        other => return other.to_string(),
    };
    format!("an integer from {range} ({expected})")
}

/// The number that ends just before `line`, `column` (from 1) of `text`, as written.
fn number_before(text: &str, line: usize, column: usize) -> String {
    let Some(row) = text.lines().nth(line.saturating_sub(1)) else {
        return "a number out of range".to_string();
    };
    let end = row.char_indices().nth(column).map_or(row.len(), |(i, _)| i);
    let head = &row[..end];
    let start = head
        .rfind(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-')))
        .map_or(0, |i| i + 1);
    let number = head[start..].trim_end_matches(|c: char| !c.is_ascii_digit());
    if number.is_empty() {
        "a number out of range".to_string()
    } else {
        number.to_string()
    }
}

/// The answer to line `number` (from 1) holding `line` (without its line break), with the
/// gripper's limit of `rules` applied.
pub(crate) fn answer_line(line: &[u8], number: usize, with: &Answering) -> GripRecommendation {
    let mut reply = match std::str::from_utf8(line) {
        Err(e) => invalid(
            &GraspCandidate::default(),
            &format_args!("not UTF-8: invalid byte at column {}", e.valid_up_to() + 1),
        ),
        Ok(text) => match parse::<GraspCandidate>(text) {
            Ok(candidate) => with.answer::<Candidates>(&candidate),
            Err(e) => invalid(&partial(text), &e),
        },
    };
    if reply.status == GripRecommendation::STATUS_INVALID_INPUT {
        reply.message = compact_str::format_compact!("line {number}: {}", reply.message);
    }
    reply
}

/// The answer to one line: to a `GraspCandidate`, or to a `PoseCandidate`. One lives at a time,
/// written and dropped before the next line, so the pose answer's 208 bytes more than a grasp
/// answer cost nothing; boxing it would leave the grasp answer the one far larger than the box,
/// and boxing that would cost an allocation on every line of `solve`'s grasp candidates.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum LineAnswer {
    /// A `GraspCandidate`'s (or a line that is none).
    Grasp(GripRecommendation),
    /// A `PoseCandidate`'s.
    Pose(PoseRecommendation),
}

impl LineAnswer {
    /// The recommendation: the answer itself, or the pose's inner one.
    pub(crate) fn recommendation(&self) -> &GripRecommendation {
        match self {
            LineAnswer::Grasp(r) => r,
            LineAnswer::Pose(p) => &p.recommendation,
        }
    }

    fn write(&self, output: &mut impl Write) -> serde_json::Result<()> {
        match self {
            LineAnswer::Grasp(r) => serde_json::to_writer(output, r),
            LineAnswer::Pose(p) => serde_json::to_writer(output, p),
        }
    }
}

/// The top-level fields that make a line a `PoseCandidate` (`grasp_pose`) or a
/// pose set (`poses`) rather than a `GraspCandidate`.
#[derive(serde::Deserialize)]
struct Kind {
    #[serde(default)]
    grasp_pose: Option<serde::de::IgnoredAny>,
    #[serde(default)]
    poses: Option<serde::de::IgnoredAny>,
}

/// Whether a JSON text is an object with a `grasp_pose` field (a `PoseCandidate`); a text that
/// is no JSON object is not.
///
/// Only a text holding `"grasp_pose"` is parsed to tell: a second parse of every
/// `GraspCandidate` line cost `solve` 15 % (100,000 lines of `examples/paper_cases.jsonl`: 0.58 s
/// against 0.50 s before pose candidates; 0.53 s with this check, the test profile's build).
/// A key written with escapes (`"grasp\u005fpose"`) is not seen, and its line is refused as a
/// `GraspCandidate` with an unknown field `grasp_pose`.
pub(crate) fn is_pose_candidate(text: &str) -> bool {
    text.contains("\"grasp_pose\"")
        && serde_json::from_str::<Kind>(text).is_ok_and(|k| k.grasp_pose.is_some())
}

/// Whether a JSON text is an object with a `poses` field (a pose set).
pub(crate) fn is_pose_set(text: &str) -> bool {
    serde_json::from_str::<Kind>(text).is_ok_and(|k| k.poses.is_some())
}

/// [`answer_line`], or a `PoseCandidate` line's answer.
pub(crate) fn answer_any_line(line: &[u8], number: usize, with: &Answering) -> LineAnswer {
    let Some(text) = std::str::from_utf8(line)
        .ok()
        .filter(|text| is_pose_candidate(text))
    else {
        return LineAnswer::Grasp(answer_line(line, number, with));
    };
    let mut reply = match parse::<PoseCandidate>(text) {
        Ok(candidate) => with.answer::<Poses>(&candidate),
        Err(e) => without_geometry(invalid(&partial(text), &e)),
    };
    let r = &mut reply.recommendation;
    if r.status == GripRecommendation::STATUS_INVALID_INPUT {
        r.message = compact_str::format_compact!("line {number}: {}", r.message);
    }
    LineAnswer::Pose(reply)
}

/// Answers every non-blank line of `input` on `output`, one JSON line each, flushed at once;
/// `refused` hears the message of every answer whose status is not 0. A closed output (a
/// reader that went away, as `solve | head` does) ends the run without an error. Every line is
/// answered `with` the same settings, rules and meshes.
pub fn answer_lines(
    mut input: impl BufRead,
    mut output: impl Write,
    with: &Answering,
    mut refused: impl FnMut(&str),
) -> Result<Counts, LinesError> {
    let mut counts = Counts::default();
    let mut line = Vec::new();
    for number in 1.. {
        line.clear();
        let read_error = |source| LinesError::Read {
            line: number,
            source,
        };
        let read = (&mut input)
            .take(MAX_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut line)
            .map_err(read_error)?;
        if read == 0 {
            break;
        }
        let reply = if line.len() > MAX_LINE_BYTES && !line.ends_with(b"\n") {
            skip_line(&mut input).map_err(read_error)?;
            let mut r = invalid(
                &GraspCandidate::default(),
                &format_args!("longer than {MAX_LINE_BYTES} bytes"),
            );
            r.message = compact_str::format_compact!("line {number}: {}", r.message);
            LineAnswer::Grasp(r)
        } else {
            let text = line.strip_suffix(b"\n").unwrap_or(&line);
            let text = text.strip_suffix(b"\r").unwrap_or(text);
            if text.iter().all(u8::is_ascii_whitespace) {
                continue;
            }
            answer_any_line(text, number, with)
        };
        counts.answered += 1;
        let r = reply.recommendation();
        if r.status != GripRecommendation::STATUS_OK {
            counts.not_solved += 1;
            refused(&r.message);
        }
        let written = reply
            .write(&mut output)
            .map_err(std::io::Error::from)
            .and_then(|()| output.write_all(b"\n"))
            .and_then(|()| output.flush());
        match written {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => break,
            Err(e) => return Err(LinesError::Write(e)),
        }
    }
    Ok(counts)
}

/// Reads past the rest of the current line, its line break included, keeping nothing.
fn skip_line(input: &mut impl BufRead) -> std::io::Result<()> {
    loop {
        let buf = input.fill_buf()?;
        if buf.is_empty() {
            return Ok(());
        }
        match buf.iter().position(|&b| b == b'\n') {
            Some(i) => {
                input.consume(i + 1);
                return Ok(());
            }
            None => {
                let n = buf.len();
                input.consume(n);
            }
        }
    }
}

/// What can be salvaged from a line that is not a valid candidate: its `id` and `header`, so the
/// answer can still be matched to it.
pub(crate) fn partial(line: &str) -> GraspCandidate {
    let mut out = GraspCandidate::default();
    if let Ok(value) = serde_json::from_str::<serde_json::Value>(line) {
        if let Some(id) = value.get("id").and_then(|v| v.as_str()) {
            out.id = id.into();
        }
        if let Some(header) = value
            .get("header")
            .and_then(|h| serde_json::from_value(h.clone()).ok())
        {
            out.header = header;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(input: &[u8]) -> (Vec<serde_json::Value>, Counts) {
        let mut out = Vec::new();
        let counts = answer_lines(input, &mut out, &Answering::from_env(), |_| {}).expect("runs");
        let lines = String::from_utf8(out)
            .expect("the output is UTF-8")
            .lines()
            .map(|l| serde_json::from_str(l).expect("JSON"))
            .collect();
        (lines, counts)
    }

    #[test]
    fn a_line_that_is_not_utf8_is_refused_and_the_next_is_answered() {
        let good = include_str!("../examples/paper_cases.jsonl")
            .lines()
            .next()
            .expect("case a");
        let mut input = b"{\"id\": \"\xff\xfe\"}\r\n\n".to_vec();
        input.extend_from_slice(good.as_bytes());
        input.extend_from_slice(b"\r\n\xc3");
        let (out, counts) = run(&input);
        assert_eq!(
            counts,
            Counts {
                answered: 3,
                not_solved: 2
            }
        );
        assert_eq!(out[0]["status"], 2);
        assert_eq!(
            out[0]["message"],
            "line 1: invalid input: not UTF-8: invalid byte at column 9"
        );
        assert_eq!(out[1]["status"], 0);
        assert_eq!(out[1]["candidate_id"], "paper-a");
        assert_eq!(out[2]["status"], 2);
        assert!(out[2]["message"]
            .as_str()
            .is_some_and(|m| m.starts_with("line 4: ")));
    }

    /// The message of the answer to `line`, with the paper's case (a) as the rest of it.
    fn refusal(field: &str) -> String {
        let good = include_str!("../examples/paper_cases.jsonl")
            .lines()
            .next()
            .expect("case a");
        let line = good.replacen('{', &format!("{{{field}, "), 1);
        let (out, _) = run(line.as_bytes());
        out[0]["message"].as_str().expect("a message").to_string()
    }

    #[test]
    fn every_refused_field_is_named_with_what_it_takes() {
        for (field, message) in [
            (
                "\"model\": -1",
                "line 1: invalid input: field model: expected an integer from 0 to 255 (u8), got \
                 integer -1 at column 12",
            ),
            (
                "\"mass\": 1e999",
                "line 1: invalid input: field mass: expected a number within ±1.8e308 (a double), \
                 got 1e999 at column 14",
            ),
            (
                "\"contact_1\": {\"x\": \"a\"}",
                "line 1: invalid input: field contact_1.x: expected a number (a double), got \
                 string \"a\" at column 23",
            ),
            (
                "\"header\": {\"stamp\": {\"sec\": 1.5}}",
                "line 1: invalid input: field header.stamp.sec: expected an integer from \
                 -2147483648 to 2147483647 (i32), got floating point 1.5 at column 32",
            ),
        ] {
            assert_eq!(refusal(field), message, "{field}");
        }
        let unknown = refusal("\"massa\": 1");
        assert!(
            unknown.starts_with("line 1: invalid input: unknown field `massa`, expected one of"),
            "{unknown}"
        );
        let nested = refusal("\"contact_1\": {\"w\": 1}");
        assert!(
            nested.starts_with("line 1: invalid input: field contact_1: unknown field `w`"),
            "{nested}"
        );
        let (out, _) = run(b"{\"id\": \"x\"}\n{\n\"x\"\n");
        assert_eq!(
            out[0]["message"],
            "line 1: invalid input: missing field `contact_1` at column 11"
        );
        assert_eq!(
            out[1]["message"],
            "line 2: invalid input: not JSON: EOF while parsing an object at column 1"
        );
        assert_eq!(
            out[2]["message"],
            "line 3: invalid input: expected struct GraspCandidate, got string \"x\" at column 3"
        );
    }

    #[test]
    fn a_line_too_long_is_refused_and_skipped() {
        let mut input = vec![b'x'; MAX_LINE_BYTES + 10];
        input.extend_from_slice(b"\n{}\n");
        let (out, counts) = run(&input);
        assert_eq!(counts.answered, 2);
        assert_eq!(
            out[0]["message"],
            format!("line 1: invalid input: longer than {MAX_LINE_BYTES} bytes")
        );
        assert!(out[1]["message"]
            .as_str()
            .is_some_and(|m| m.starts_with("line 2: ")));
    }

    #[test]
    fn a_closed_output_ends_the_run_quietly() {
        struct Closed;
        impl Write for Closed {
            fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
                Err(std::io::ErrorKind::BrokenPipe.into())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let counts = answer_lines(&b"{}\n{}\n"[..], Closed, &Answering::from_env(), |_| {})
            .expect("a closed pipe is not an error");
        assert_eq!(counts.answered, 1);
    }
}
