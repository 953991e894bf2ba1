//! The allowed range: every object in the region must allow the orientation (module docs,
//! section 4), and the reason when no orientation suits them all.

use super::envelope::periodic_meet;
use super::region::BoxPoint;
use crate::AllowedRange;
use std::fmt;

/// Why no orientation suits every object in the region (to be answered with status 1).
#[derive(Debug, Clone, PartialEq)]
pub enum NoCommonOrientation {
    /// The region reaches across the contact line: `point` lies on the other side of it from the
    /// nominal centre of mass (module docs, section 4).
    AcrossContactLine {
        /// A vertex across the line.
        point: BoxPoint,
    },
    /// Two vertices allow no common orientation: `first` allows only gravity angles from `lo`
    /// on, `second` only up to `hi < lo`.
    Disjoint {
        /// The vertex whose range starts last.
        first: BoxPoint,
        /// Its range's start, rad.
        lo: f64,
        /// The vertex whose range ends first.
        second: BoxPoint,
        /// Its range's end, rad.
        hi: f64,
    },
    /// Explicit bounds miss the orientations that every object in the region can take.
    BoundsMissed {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
        /// The region's graspable range, rad.
        common: (f64, f64),
        /// The vertex whose graspable range starts last.
        first: BoxPoint,
        /// The vertex whose graspable range ends first.
        second: BoxPoint,
    },
}

impl fmt::Display for NoCommonOrientation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("no orientation in the allowed range suits every object in the tolerances: ")?;
        match self {
            NoCommonOrientation::AcrossContactLine { point } => write!(
                f,
                "the centre of mass may lie on either side of the line through the contacts \
                 ({point} is across it)"
            ),
            NoCommonOrientation::Disjoint {
                first,
                lo,
                second,
                hi,
            } => write!(
                f,
                "with the centre of mass at {first} the gravity angle must be at least {lo:.6} \
                 rad, at {second} at most {hi:.6} rad"
            ),
            NoCommonOrientation::BoundsMissed {
                lo,
                hi,
                common,
                first,
                second,
            } => write!(
                f,
                "the range bounds [{lo:.6}, {hi:.6}] rad miss [{:.6}, {:.6}] rad, the gravity \
                 angles graspable for every centre of mass (its ends are set by {first} and \
                 {second})",
                common.0, common.1
            ),
        }
    }
}

/// A closed interval of angles and the vertices that bound it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Common {
    pub(super) lo: f64,
    pub(super) lo_vertex: usize,
    pub(super) hi: f64,
    pub(super) hi_vertex: usize,
}

impl Common {
    /// The intersection of intervals, with which one sets each end.
    pub(super) fn of(ranges: impl Iterator<Item = (f64, f64)>) -> Self {
        let mut c = Common {
            lo: f64::NEG_INFINITY,
            lo_vertex: 0,
            hi: f64::INFINITY,
            hi_vertex: 0,
        };
        for (i, (lo, hi)) in ranges.enumerate() {
            if lo > c.lo {
                (c.lo, c.lo_vertex) = (lo, i);
            }
            if hi < c.hi {
                (c.hi, c.hi_vertex) = (hi, i);
            }
        }
        c
    }
}

/// The allowed range for every object in the region (module docs, section 4), from the
/// intersections of the vertices' graspable and from-above ranges; `region` names the vertices
/// that bound them when it is empty.
pub(super) fn allowed(
    range: AllowedRange,
    graspable: Common,
    from_above: Common,
    region: &[BoxPoint],
) -> Result<Vec<(f64, f64)>, NoCommonOrientation> {
    Ok(match range {
        AllowedRange::FromAbove | AllowedRange::Graspable => {
            let c = if range == AllowedRange::FromAbove {
                from_above
            } else {
                graspable
            };
            if c.lo > c.hi {
                return Err(NoCommonOrientation::Disjoint {
                    first: region[c.lo_vertex],
                    lo: c.lo,
                    second: region[c.hi_vertex],
                    hi: c.hi,
                });
            }
            vec![(c.lo, c.hi)]
        }
        AllowedRange::Bounds { lo, hi } => {
            let out = periodic_meet(lo, hi, graspable.lo, graspable.hi);
            if out.is_empty() {
                return Err(NoCommonOrientation::BoundsMissed {
                    lo,
                    hi,
                    common: (graspable.lo, graspable.hi),
                    first: region[graspable.lo_vertex],
                    second: region[graspable.hi_vertex],
                });
            }
            out
        }
    })
}
