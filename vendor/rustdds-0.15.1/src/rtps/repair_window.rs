// Patched for grasp_orient (0010-repair-window.patch): how many bytes one repair round may send
// to one reader, paced by what the reader acknowledges.
//
// A reliable writer repairs what a reader NACKs (RTPS 2.5 8.4.7, the StatefulWriter's
// ReaderProxy) in rounds, one round per repair interval. A fixed budget per round (8 KiB per
// 10 ms, 800 kB/s) was far below what a reader on the same host takes, and blind to a reader that
// cannot keep up. The window here grows while the reader's ACKNACKs show that repaired samples
// arrived, and halves when the reader NACKs again a sample that was repaired long enough ago for
// the repair to have arrived (it was lost, or the reader dropped it): additive increase,
// multiplicative decrease, as TCP does, with a doubling start until the first loss.

use std::{
  collections::BTreeMap,
  time::{Duration, Instant},
};

use crate::{rtps::constant::REPAIR_BATCH_MAX_BYTES, structure::sequence_number::SequenceNumber};

// The window of a new reader: the fixed budget that every round had before.
pub const REPAIR_WINDOW_INITIAL: usize = REPAIR_BATCH_MAX_BYTES;
// The window never shrinks below this (a round still sends at least one sample).
pub const REPAIR_WINDOW_MIN: usize = 4096;
// Nor grows above this: 1 MiB per repair interval (10 ms by default), about 100 MB/s.
pub const REPAIR_WINDOW_MAX: usize = 1 << 20;
// A repaired sample that the reader NACKs again this long after it went out was lost. A NACK
// sooner than this may have crossed the repair on the way.
pub const REPAIR_LOSS_AGE: Duration = Duration::from_millis(2);
// The most repaired-but-unacknowledged sequence numbers remembered per reader.
const MAX_TRACKED_REPAIRS: usize = 8192;

#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct RepairWindow {
  bytes: usize,
  // Below this the window doubles on each ACKNACK that shows progress; above it, it grows by
  // REPAIR_WINDOW_INITIAL. Set to half the window at each loss.
  threshold: usize,
  // Sequence numbers sent in repair rounds and not yet acknowledged, with when they went out.
  repaired: BTreeMap<SequenceNumber, Instant>,
}

impl Default for RepairWindow {
  fn default() -> Self {
    Self {
      bytes: REPAIR_WINDOW_INITIAL,
      threshold: REPAIR_WINDOW_MAX,
      repaired: BTreeMap::new(),
    }
  }
}

impl RepairWindow {
  /// The most bytes the next repair round may send.
  pub fn bytes(&self) -> usize {
    self.bytes
  }

  /// `sn` went out in a repair round at `now`.
  pub fn repaired(&mut self, sn: SequenceNumber, now: Instant) {
    self.repaired.insert(sn, now);
    while self.repaired.len() > MAX_TRACKED_REPAIRS {
      self.repaired.pop_first();
    }
  }

  /// An ACKNACK came at `now`: everything before `acked_before` is received, and `requested`
  /// (in increasing order) is asked for.
  pub fn on_acknack(
    &mut self,
    acked_before: SequenceNumber,
    requested: impl IntoIterator<Item = SequenceNumber>,
    now: Instant,
  ) {
    let requested: Vec<SequenceNumber> = requested.into_iter().collect();
    let lost = requested.iter().any(|sn| {
      self
        .repaired
        .get(sn)
        .is_some_and(|sent| now.saturating_duration_since(*sent) >= REPAIR_LOSS_AGE)
    });
    // Repairs the reader has now: acknowledged, or below the highest it asks for and not asked.
    let highest_requested = requested.last().copied();
    let delivered: Vec<SequenceNumber> = self
      .repaired
      .keys()
      .copied()
      .filter(|sn| {
        *sn < acked_before
          || (highest_requested.is_some_and(|h| *sn < h) && requested.binary_search(sn).is_err())
      })
      .collect();
    for sn in &delivered {
      self.repaired.remove(sn);
    }
    if lost {
      self.threshold = (self.bytes / 2).max(REPAIR_WINDOW_MIN);
      self.bytes = self.threshold;
      // What is asked for again goes out again and is timed afresh; one loss, one halving.
      for sn in &requested {
        self.repaired.remove(sn);
      }
    } else if !delivered.is_empty() {
      self.bytes = if self.bytes < self.threshold {
        self.bytes.saturating_mul(2)
      } else {
        self.bytes.saturating_add(REPAIR_WINDOW_INITIAL)
      }
      .min(REPAIR_WINDOW_MAX);
    }
  }
}

#[cfg(test)]
mod tests {
  use super::*;

  fn sns(range: std::ops::RangeInclusive<i64>) -> Vec<SequenceNumber> {
    range.map(SequenceNumber::new).collect()
  }

  #[test]
  fn the_window_grows_while_repairs_are_acknowledged_and_halves_on_loss() {
    let mut w = RepairWindow::default();
    let start = Instant::now();
    assert_eq!(w.bytes(), REPAIR_WINDOW_INITIAL);
    // Each round's samples acknowledged by the next ACKNACK: the window doubles.
    let mut next = 1;
    for expected in [16384, 32768, 65536] {
      for sn in sns(next..=next + 7) {
        w.repaired(sn, start);
      }
      next += 8;
      w.on_acknack(SequenceNumber::new(next), sns(next..=next + 100), start);
      assert_eq!(w.bytes(), expected);
    }
    // A repair asked for again right away may have crossed the ACKNACK: no loss.
    w.repaired(SequenceNumber::new(next), start);
    w.on_acknack(SequenceNumber::new(next), sns(next..=next + 100), start);
    assert_eq!(w.bytes(), 65536);
    // Asked for again REPAIR_LOSS_AGE after it went out: lost, the window halves, once.
    let later = start + REPAIR_LOSS_AGE;
    w.on_acknack(SequenceNumber::new(next), sns(next..=next + 100), later);
    assert_eq!(
      w.bytes(),
      32768,
      "a repeated NACK of a repaired sample did not shrink the window"
    );
    w.on_acknack(SequenceNumber::new(next), sns(next..=next + 100), later);
    assert_eq!(w.bytes(), 32768);
    // After a loss, growth is additive.
    w.repaired(SequenceNumber::new(next), later);
    w.on_acknack(
      SequenceNumber::new(next + 1),
      sns(next + 1..=next + 100),
      later,
    );
    assert_eq!(w.bytes(), 32768 + REPAIR_WINDOW_INITIAL);
  }

  #[test]
  fn the_window_stays_within_its_bounds() {
    let mut w = RepairWindow::default();
    let t0 = Instant::now();
    for round in 0..200 {
      let sn = SequenceNumber::new(round + 1);
      w.repaired(sn, t0);
      w.on_acknack(sn + SequenceNumber::new(1), [], t0);
    }
    assert_eq!(w.bytes(), REPAIR_WINDOW_MAX);
    let late = t0 + Duration::from_secs(1);
    for round in 0..100 {
      let sn = SequenceNumber::new(1000 + round);
      w.repaired(sn, t0);
      w.on_acknack(sn, [sn], late);
    }
    assert_eq!(w.bytes(), REPAIR_WINDOW_MIN);
    for sn in 0..(2 * MAX_TRACKED_REPAIRS as i64) {
      w.repaired(SequenceNumber::new(5000 + sn), t0);
    }
    assert_eq!(w.repaired.len(), MAX_TRACKED_REPAIRS);
  }
}
