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

/// The answers to `candidates`, each handed to `each` with its index in the slice, in order: the
/// one place a slice of candidates is answered, so that a batch path of the solver can take it
/// over. An answer is handed over as soon as it is made, so that it is still in the core's cache
/// when it becomes columns.
pub(crate) fn answer_candidates(
    candidates: &[GraspCandidate],
    settings: &Settings,
    rules: &Rules,
    mut each: impl FnMut(usize, &GripRecommendation),
) {
    let with = Answering::new(
        *settings,
        *rules,
        PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()),
    );
    for (i, m) in candidates.iter().enumerate() {
        each(i, &with.answer::<Candidates>(m));
    }
}

/// The message a row's answer is reported with: a refusal of its input (status 2) names the
/// row, as `solve` names the line.
pub(crate) fn row_message(row: usize, r: &GripRecommendation) -> CompactString {
    if r.status == GripRecommendation::STATUS_INVALID_INPUT {
        compact_str_row(row, &r.message)
    } else {
        r.message.clone()
    }
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

/// The rows of `range`, answered.
fn answer_range(
    g: &Grasps<'_>,
    range: Range<usize>,
    settings: &Settings,
    rules: &Rules,
) -> Columns {
    let mut out = Columns::with_capacity(range.len());
    let mut candidates = Vec::with_capacity(SLICE);
    for start in range.clone().step_by(SLICE) {
        let rows = start..(start + SLICE).min(range.end);
        candidates.clear();
        candidates.extend(rows.clone().map(|i| g.candidate(i)));
        answer_candidates(&candidates, settings, rules, |i, r| {
            out.push(r, row_message(start + i, r));
        });
    }
    out
}

/// Every row of `g` answered, on `threads`.
pub(crate) fn solve(
    g: &Grasps<'_>,
    settings: &Settings,
    rules: &Rules,
    threads: &Threads,
) -> Columns {
    answer_in_chunks(g.len(), CHUNK, threads, |range| {
        answer_range(g, range, settings, rules)
    })
}
