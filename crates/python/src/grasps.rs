//! `solve`: rows of contacts, normals, centre of mass, gravity, mass and friction, each row the
//! `GraspCandidate` that `grasp_orient solve` reads from a JSON line, answered by the root
//! crate's answering object (`Answering`) under the same settings and rules.

use crate::chunks::{answer_in_chunks, Threads};
use crate::columns::Columns;
use grasp_orient::answer::{Answering, PoseAnswerer, Rules};
use grasp_orient::geometry::{AmentIndex, ClosingAxis};
use grasp_orient::kind::Candidates;
use grasp_orient::msg::{CompactString, GraspCandidate, GripRecommendation, Point, Vector3};
use grasp_orient::solver::Settings;
use std::ops::Range;

/// Rows answered together: small enough to share among threads, large enough that handing a
/// chunk to a thread costs nothing next to solving it (a planar candidate takes about a
/// microsecond).
const CHUNK: usize = 4096;

/// The checked inputs of `solve`, in C order: `(N, 3)` arrays as `3N` values, `(N,)` as `N`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grasps<'a> {
    pub contact_1: &'a [f64],
    pub normal_1: &'a [f64],
    pub contact_2: &'a [f64],
    pub normal_2: &'a [f64],
    pub center_of_mass: &'a [f64],
    pub gravity: &'a [f64],
    pub mass: &'a [f64],
    pub friction: &'a [f64],
    /// 1: one coefficient a row for both contacts; 2: `(friction_1, friction_2)` a row.
    pub friction_stride: usize,
    /// `GraspCandidate::MODEL_PLANAR` or `MODEL_SPATIAL`.
    pub model: u8,
}

fn point(v: &[f64], i: usize) -> Point {
    Point {
        x: v[3 * i],
        y: v[3 * i + 1],
        z: v[3 * i + 2],
    }
}

fn vector(v: &[f64], i: usize) -> Vector3 {
    Vector3 {
        x: v[3 * i],
        y: v[3 * i + 1],
        z: v[3 * i + 2],
    }
}

impl Grasps<'_> {
    /// Rows.
    pub(crate) fn len(&self) -> usize {
        self.mass.len()
    }

    /// Row `i` as the candidate a JSON line with the same numbers is (no header, no id, no
    /// tolerances of its own: the call's apply, as `solve`'s flags do).
    fn candidate(&self, i: usize) -> GraspCandidate {
        GraspCandidate {
            contact_1: point(self.contact_1, i),
            contact_2: point(self.contact_2, i),
            normal_1: vector(self.normal_1, i),
            normal_2: vector(self.normal_2, i),
            friction_1: self.friction[self.friction_stride * i],
            friction_2: self.friction[self.friction_stride * i + self.friction_stride - 1],
            center_of_mass: point(self.center_of_mass, i),
            mass: self.mass[i],
            gravity: vector(self.gravity, i),
            model: self.model,
            ..GraspCandidate::default()
        }
    }
}

/// The message a row's answer is reported with when it is not the answer's own: a refusal of
/// its input (status 2) names the row, as `solve` names the line.
fn row_message(row: usize, r: &GripRecommendation) -> Option<CompactString> {
    (r.status == GripRecommendation::STATUS_INVALID_INPUT).then(|| compact_str_row(row, &r.message))
}

/// `row I: MESSAGE`.
pub(crate) fn compact_str_row(row: usize, message: &str) -> CompactString {
    let mut out = CompactString::new("row ");
    out.push_str(&row.to_string());
    out.push_str(": ");
    out.push_str(message);
    out
}

/// Candidates made at a time within a chunk (about 250 bytes each): a slice stays in the core's
/// cache while it is answered.
const SLICE: usize = 64;

/// The rows of `range`, answered `with` the call's settings and rules, a slice at a time through
/// the answer layer's batch path (`Answering::answer_many`).
fn answer_range(with: &Answering, g: &Grasps<'_>, range: Range<usize>) -> Columns {
    let mut out = Columns::with_capacity(range.len());
    let mut candidates = Vec::with_capacity(SLICE);
    for start in range.clone().step_by(SLICE) {
        let rows = start..(start + SLICE).min(range.end);
        candidates.clear();
        candidates.extend(rows.clone().map(|i| g.candidate(i)));
        out.push_all(with.answer_many::<Candidates>(&candidates), |i, r| {
            row_message(start + i, r)
        });
    }
    out
}

/// Every row of `g` answered, on `threads`, by one answering object (no mesh is involved: its
/// pose answerer is never asked).
pub(crate) fn solve(
    g: &Grasps<'_>,
    settings: &Settings,
    rules: &Rules,
    threads: &Threads,
) -> Columns {
    let with = Answering::new(
        *settings,
        *rules,
        PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()),
    );
    answer_in_chunks(g.len(), CHUNK, threads, |range| {
        answer_range(&with, g, range)
    })
}
