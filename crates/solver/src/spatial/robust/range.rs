//! The allowed range (module docs §6): the tilts at which every object of the region hangs from
//! above, is graspable, or meets the explicit bounds, and the reason when there is none.

use super::problem::Problem;
use super::region::RegionPoint;
use crate::planar::robust::periodic_meet;
use crate::AllowedRange;
use std::f64::consts::FRAC_PI_2;
use std::fmt;

/// Why no tilt of the contact axis suits every object in the region (status 1).
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialNoCommonOrientation")]
pub enum NoCommonOrientation {
    /// Hanging from above: `first` needs the gravity angle at least `lo`, `second` at most
    /// `hi < lo`.
    Disjoint {
        /// The point whose range starts last.
        first: RegionPoint,
        /// Its range's start, rad.
        lo: f64,
        /// The point whose range ends first.
        second: RegionPoint,
        /// Its range's end, rad.
        hi: f64,
    },
    /// Explicit bounds miss `[−π/2, π/2]`, the tilts at which every object hangs (module docs §1).
    BoundsMissed {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
    },
}

impl fmt::Display for NoCommonOrientation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("no tilt of the contact axis suits every object in the tolerances: ")?;
        match self {
            NoCommonOrientation::Disjoint {
                first,
                lo,
                second,
                hi,
            } => write!(
                f,
                "to hang from above with the centre of mass at {first} the gravity angle must be \
                 at least {lo:.6} rad, at {second} at most {hi:.6} rad"
            ),
            NoCommonOrientation::BoundsMissed { lo, hi } => write!(
                f,
                "the range bounds [{lo:.6}, {hi:.6}] rad miss [-pi/2, pi/2], the gravity angles at \
                 which an object whose centre of mass is uncertain hangs below the contact axis"
            ),
        }
    }
}

impl Problem {
    /// The gravity angles allowed for every object (module docs §6).
    pub(super) fn allowed(
        &self,
        range: &AllowedRange,
    ) -> Result<Vec<(f64, f64)>, NoCommonOrientation> {
        match *range {
            AllowedRange::FromAbove => {
                let v = &self.view;
                let p1 = v.p2 + v.a * v.d;
                let (hi, second) = self.region.least_elevation(&v.p2, &v.a);
                let (low, first) = self.region.least_elevation(&p1, &-v.a);
                let lo = -low;
                if lo > hi {
                    return Err(NoCommonOrientation::Disjoint {
                        first,
                        lo,
                        second,
                        hi,
                    });
                }
                Ok(vec![(lo, hi)])
            }
            AllowedRange::Graspable => Ok(vec![(-FRAC_PI_2, FRAC_PI_2)]),
            AllowedRange::Bounds { lo, hi } => {
                let out = periodic_meet(lo, hi, -FRAC_PI_2, FRAC_PI_2);
                if out.is_empty() {
                    Err(NoCommonOrientation::BoundsMissed { lo, hi })
                } else {
                    Ok(out)
                }
            }
        }
    }
}
