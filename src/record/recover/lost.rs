//! What a damaged place the walk leaves behind is reported as: a chunk whose messages the
//! message index records after it count (per topic), one whose messages nothing counts, bytes
//! that start no record, or a record of an opcode MCAP does not define (not reported).

use super::copy::topic;
use super::report::Recovered;
use crate::record::scan::{op, Damage, Table};

/// A damaged place whose messages the message index records after it may count.
struct Lost {
    /// Where, and what is wrong there.
    damage: Damage,
    /// Messages the index records after it counted.
    counted: u64,
    /// What it is believed to be when no index record counts messages in it.
    kind: LostKind,
}

/// What a damaged place is believed to be, when no message index record follows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LostKind {
    /// A chunk (or a message): its messages are lost, and how many is not recorded.
    Chunk,
    /// Bytes that start with no opcode MCAP defines: no record, nothing lost but the bytes.
    Bytes,
    /// A sound record of an opcode MCAP does not define, which readers skip: not reported.
    Unknown,
}

/// The damaged place the walk left last, until the next sound record says what was lost there.
#[derive(Default)]
pub(super) struct Pending(Option<Lost>);

impl Pending {
    /// A message index record of `count` messages on `channel_id`: when it follows a dropped
    /// place, those messages were in it, and are counted as dropped.
    pub(super) fn index(
        &mut self,
        channel_id: u16,
        count: u64,
        table: &Table,
        got: &mut Recovered,
    ) {
        if let Some(lost) = &mut self.0 {
            lost.counted += count;
            *got.dropped.entry(topic(table, channel_id)).or_default() += count;
        }
    }

    /// A sound record at `offset` of `opcode`, which MCAP does not define: readers skip it, and
    /// it is not reported unless message index records follow it (then it was a chunk).
    pub(super) fn unknown(&mut self, offset: u64, opcode: u8, got: &mut Recovered) {
        self.flush(got);
        self.0 = Some(Lost {
            damage: Damage {
                offset,
                what: format!(
                    "a record of opcode 0x{opcode:02x}, which MCAP does not define, followed by \
                     message index records: a damaged chunk"
                ),
                cut_short: false,
            },
            counted: 0,
            kind: LostKind::Unknown,
        });
    }

    /// Reports the damaged record at `damage.offset`, believed of `opcode`, which the walk
    /// leaves for `next` (`next_is_end`: the end of the data section).
    pub(super) fn damaged(
        &mut self,
        damage: Damage,
        opcode: u8,
        next: u64,
        next_is_end: bool,
        got: &mut Recovered,
    ) {
        self.flush(got);
        let cut = damage.cut_short && next_is_end;
        match opcode {
            op::MESSAGE_INDEX | op::DATA_END if cut => got.notes.push(format!(
                "{damage}: an index or end record was cut (they are rebuilt; no message is in them)"
            )),
            op::MESSAGE_INDEX => got.damaged(|| {
                format!("{damage}: a message index record (no message is in it) is dropped")
            }),
            op::METADATA | op::ATTACHMENT => got.damaged(|| format!("{damage}: dropped")),
            op::SCHEMA | op::CHANNEL => got.damaged(|| {
                format!("{damage}: dropped; its messages are dropped unless the summary names it")
            }),
            op::DATA_END => got.damaged(|| format!("{damage}: dropped")),
            op::CHUNK | op::MESSAGE if cut => {
                self.0 = Some(Lost {
                    damage: Damage {
                        what: format!(
                            "{}: the file is cut short inside this record; the messages in it \
                             are lost, and how many is not recorded",
                            damage.what
                        ),
                        ..damage
                    },
                    counted: 0,
                    kind: LostKind::Chunk,
                })
            }
            _ => {
                let defined = (op::HEADER..=op::DATA_END).contains(&opcode);
                self.0 = Some(Lost {
                    damage: Damage {
                        what: if defined {
                            format!("{}; the walk goes on at byte {next}", damage.what)
                        } else {
                            format!(
                                "{}; the {} bytes up to byte {next} start no record",
                                damage.what,
                                next - damage.offset
                            )
                        },
                        ..damage
                    },
                    counted: 0,
                    kind: if defined {
                        LostKind::Chunk
                    } else {
                        LostKind::Bytes
                    },
                })
            }
        }
    }

    /// Reports the pending dropped place, with the messages the index records after it counted.
    pub(super) fn flush(&mut self, got: &mut Recovered) {
        let Some(lost) = self.0.take() else {
            return;
        };
        let d = lost.damage;
        match lost.kind {
            _ if lost.counted > 0 => {
                got.chunks_dropped += 1;
                got.damaged(|| format!("{d}: its {} messages are dropped", lost.counted));
            }
            LostKind::Chunk => {
                got.chunks_dropped += 1;
                got.uncounted += 1;
                got.damaged(|| {
                    if d.cut_short {
                        d.to_string()
                    } else {
                        format!("{d}: dropped, with a number of messages nothing records")
                    }
                });
            }
            LostKind::Bytes => got.damaged(|| format!("{d}: skipped")),
            LostKind::Unknown => {}
        }
    }
}
