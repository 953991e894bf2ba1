//! The file under a recording, and closing one whose writing failed.
//!
//! [`Sink`] passes writes to the file and keeps count of where it is, so that the recording
//! knows where its last complete flush ended. Once a write has failed it takes nothing more:
//! the MCAP writer tries to finish the file when it is dropped, and must not write a summary
//! after a half-written chunk. [`close_at`] then cuts the file back to the last complete flush
//! and appends the records that end a valid MCAP file without a summary (data end with the data
//! section's CRC, footer, magic), so that every reader opens what was written.

use super::scan::{op, MAGIC};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

/// What a [`Sink`] shares with its recording.
#[derive(Debug, Default)]
pub struct State {
    position: AtomicU64,
    refused: AtomicBool,
    /// Tests: writes past this many bytes fail as on a full disk.
    limit: AtomicU64,
}

impl State {
    /// Bytes written so far (the position after the last write).
    pub fn position(&self) -> u64 {
        self.position.load(Ordering::SeqCst)
    }

    /// From now on every write fails.
    pub fn refuse_writes(&self) {
        self.refused.store(true, Ordering::SeqCst);
    }

    /// Writes past `bytes` fail with "no space left on device" (for tests of a full disk).
    #[cfg(test)]
    pub fn fail_past(&self, bytes: u64) {
        self.limit.store(bytes, Ordering::SeqCst);
    }
}

/// A recording's file: counts its position, and refuses every write after the first failure.
#[derive(Debug)]
pub struct Sink {
    file: File,
    state: Arc<State>,
}

impl Sink {
    /// Writes into `file` from its start.
    pub fn new(file: File) -> Self {
        Self {
            file,
            state: Arc::new(State {
                limit: AtomicU64::new(u64::MAX),
                ..State::default()
            }),
        }
    }

    /// Its state, to look at from the recording.
    pub fn state(&self) -> Arc<State> {
        self.state.clone()
    }

    fn failed(&self, e: std::io::Error) -> std::io::Error {
        self.state.refuse_writes();
        e
    }
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.state.refused.load(Ordering::SeqCst) {
            return Err(std::io::Error::other(
                "an earlier write to this file failed",
            ));
        }
        let position = self.state.position();
        let room = self
            .state
            .limit
            .load(Ordering::SeqCst)
            .saturating_sub(position);
        if room == 0 && !buf.is_empty() {
            // ENOSPC, as a full disk answers.
            return Err(self.failed(std::io::Error::from_raw_os_error(28)));
        }
        let buf = &buf[..buf.len().min(usize::try_from(room).unwrap_or(usize::MAX))];
        match self.file.write(buf) {
            Ok(n) => {
                self.state
                    .position
                    .store(position + n as u64, Ordering::SeqCst);
                Ok(n)
            }
            Err(e) => Err(self.failed(e)),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush().map_err(|e| self.failed(e))
    }
}

impl Seek for Sink {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        let at = self.file.seek(pos).map_err(|e| self.failed(e))?;
        self.state.position.store(at, Ordering::SeqCst);
        Ok(at)
    }
}

/// Cuts the MCAP file at `path` back to `length` bytes (the end of its last complete flush)
/// and ends it there: a data end record with the CRC of those bytes, a footer without a
/// summary, the end magic.
pub fn close_at(path: &Path, length: u64) -> std::io::Result<()> {
    let mut file = OpenOptions::new().read(true).write(true).open(path)?;
    file.set_len(length)?;
    file.seek(SeekFrom::Start(0))?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut reader = (&mut file).take(length);
    loop {
        let n = reader.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    let mut end = Vec::with_capacity(50);
    end.push(op::DATA_END);
    end.extend_from_slice(&4u64.to_le_bytes());
    end.extend_from_slice(&hasher.finalize().to_le_bytes());
    end.push(op::FOOTER);
    end.extend_from_slice(&20u64.to_le_bytes());
    end.extend_from_slice(&[0u8; 20]); // no summary, no summary offsets, no summary CRC
    end.extend_from_slice(MAGIC);
    file.seek(SeekFrom::Start(length))?;
    file.write_all(&end)?;
    file.sync_all()
}
