//! JSON lines, as `grasp_orient solve` reads and writes them: one `GraspCandidate` per line in,
//! one `GripRecommendation` per line out, in order. Any bytes are input: a line that is not
//! UTF-8, not JSON or not a candidate gets status 2 with its line number, and the lines after it
//! are answered as usual. Memory is bounded by the longest line.

use crate::answer::{answer_one, Rules};
use crate::msg::{invalid, GraspCandidate, GripRecommendation};
use crate::solver::Settings;
use std::io::{BufRead, Read, Write};

/// Longest line read, bytes (a candidate with a 1 MiB id is about 1 MiB); a longer line is
/// answered with status 2 and skipped, so memory stays bounded even by an input without line
/// breaks.
pub const MAX_LINE_BYTES: usize = 16 << 20;

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

/// The answer to line `number` (from 1) holding `line` (without its line break), with the
/// gripper's limit of `rules` applied.
pub fn answer_line(
    line: &[u8],
    number: usize,
    settings: &Settings,
    rules: &Rules,
) -> GripRecommendation {
    let mut reply = match std::str::from_utf8(line) {
        Err(e) => invalid(
            &GraspCandidate::default(),
            &format_args!("not UTF-8: invalid byte at column {}", e.valid_up_to() + 1),
        ),
        Ok(text) => match serde_json::from_str::<GraspCandidate>(text) {
            Ok(candidate) => answer_one(&candidate, settings, rules),
            Err(e) => invalid(&partial(text), &e),
        },
    };
    if reply.status == GripRecommendation::STATUS_INVALID_INPUT {
        reply.message = compact_str::format_compact!("line {number}: {}", reply.message);
    }
    reply
}

/// Answers every non-blank line of `input` on `output`, one JSON line each, flushed at once;
/// `refused` hears the message of every answer whose status is not 0. A closed output (a
/// reader that went away, as `solve | head` does) ends the run without an error.
pub fn answer_lines(
    mut input: impl BufRead,
    mut output: impl Write,
    settings: &Settings,
    rules: &Rules,
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
            r
        } else {
            let text = line.strip_suffix(b"\n").unwrap_or(&line);
            let text = text.strip_suffix(b"\r").unwrap_or(text);
            if text.iter().all(u8::is_ascii_whitespace) {
                continue;
            }
            answer_line(text, number, settings, rules)
        };
        counts.answered += 1;
        if reply.status != GripRecommendation::STATUS_OK {
            counts.not_solved += 1;
            refused(&reply.message);
        }
        let written = serde_json::to_writer(&mut output, &reply)
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
pub fn partial(line: &str) -> GraspCandidate {
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
        let counts = answer_lines(
            input,
            &mut out,
            &Settings::default(),
            &Rules::default(),
            |_| {},
        )
        .expect("runs");
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
        let counts = answer_lines(
            &b"{}\n{}\n"[..],
            Closed,
            &Settings::default(),
            &Rules::default(),
            |_| {},
        )
        .expect("a closed pipe is not an error");
        assert_eq!(counts.answered, 1);
    }
}
