//! The region of possible centres of mass: the box cut by both surface tangents (module docs,
//! section 3), and its points as the answer names them.

use super::uncertainty::Uncertainty;
use crate::planar::frame::{unit, BEHIND_TANGENT};
use crate::planar::Candidate;
use crate::Contact;
use nalgebra::Vector2;
use std::fmt;

/// Region vertices closer than this fraction of the contact distance and the box are one.
const SAME_POINT: f64 = 1e-12;

/// A point of the region of possible centres of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxPoint {
    /// Position in the candidate frame, m.
    pub position: Vector2<f64>,
    /// Which point it is.
    pub kind: BoxPointKind,
}

/// Which point of the region a [`BoxPoint`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxPointKind {
    /// A corner of the box: the signs of its offset from `center_of_mass` along x and y
    /// (`0` along an axis whose tolerance is zero; both `0` is the nominal centre of mass).
    Corner {
        /// `-1`, `0` or `1`.
        x: i8,
        /// `-1`, `0` or `1`.
        y: i8,
    },
    /// Where an edge of the box meets the surface tangent at a contact: the box reaches out of
    /// the object there and is cut (module docs, section 3).
    Cut {
        /// The contact whose tangent cuts.
        contact: Contact,
    },
    /// A point on an edge of the region between two vertices (module docs, section 5).
    Edge,
}

impl fmt::Display for BoxPoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (px, py) = (self.position.x, self.position.y);
        let sign = |s: i8| if s < 0 { '-' } else { '+' };
        match self.kind {
            BoxPointKind::Corner { x: 0, y: 0 } => {
                write!(f, "the centre of mass ({px:.6}, {py:.6}) m")
            }
            BoxPointKind::Corner { x, y: 0 } => {
                write!(f, "corner ({}x) of the box, ({px:.6}, {py:.6}) m", sign(x))
            }
            BoxPointKind::Corner { x: 0, y } => {
                write!(f, "corner ({}y) of the box, ({px:.6}, {py:.6}) m", sign(y))
            }
            BoxPointKind::Corner { x, y } => write!(
                f,
                "corner ({}x, {}y) of the box, ({px:.6}, {py:.6}) m",
                sign(x),
                sign(y)
            ),
            BoxPointKind::Cut { contact } => write!(
                f,
                "({px:.6}, {py:.6}) m, where the box meets the surface tangent at {contact}"
            ),
            BoxPointKind::Edge => write!(f, "({px:.6}, {py:.6}) m on the edge of the box"),
        }
    }
}

/// The region of possible centres of mass: the box cut by both surface tangents (module docs,
/// section 3), its vertices in order around it, duplicates merged.
///
/// Sutherland–Hodgman against each tangent half-plane `n_i · (q - p_i) >= min(0, n_i · (c - p_i))`
/// (the bound gives way by the rounding of a nominal `c` on the tangent, so `c` stays inside); a
/// tangent the nominal `c` lies behind ([`BEHIND_TANGENT`]) cuts nothing (module docs, section 3).
pub(super) fn region(c: &Candidate, u: &Uncertainty, contact_distance: f64) -> Vec<BoxPoint> {
    let t = u.center_of_mass_tolerance;
    let sign = |s: i8, half_width: f64| if half_width > 0.0 { s } else { 0 };
    let mut poly: Vec<BoxPoint> = [(-1i8, -1i8), (1, -1), (1, 1), (-1, 1)]
        .iter()
        .map(|&(sx, sy)| BoxPoint {
            position: c.center_of_mass + Vector2::new(f64::from(sx) * t.x, f64::from(sy) * t.y),
            kind: BoxPointKind::Corner {
                x: sign(sx, t.x),
                y: sign(sy, t.y),
            },
        })
        .collect();
    for (contact, p, n) in [
        (Contact::First, c.contact_1, c.normal_1),
        (Contact::Second, c.contact_2, c.normal_2),
    ] {
        // Scale-free: a normal whose square underflows still has its direction (`validate`
        // accepted it, so it is not zero).
        let n = unit(&n).unwrap_or_else(Vector2::zeros);
        if unit(&(c.center_of_mass - p)).is_some_and(|u| n.dot(&u) < -BEHIND_TANGENT) {
            // The object is not convex at this contact: its tangent bounds nothing.
            continue;
        }
        let limit = n.dot(&(c.center_of_mass - p)).min(0.0);
        let side = |q: &Vector2<f64>| n.dot(&(q - p)) - limit;
        let mut cut = Vec::with_capacity(poly.len() + 1);
        for (i, a) in poly.iter().enumerate() {
            let b = &poly[(i + 1) % poly.len()];
            let (da, db) = (side(&a.position), side(&b.position));
            if da >= 0.0 {
                cut.push(*a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let s = da / (da - db);
                cut.push(BoxPoint {
                    position: a.position + (b.position - a.position) * s,
                    kind: BoxPointKind::Cut { contact },
                });
            }
        }
        poly = cut;
    }
    let eps = SAME_POINT * contact_distance.max(t.x).max(t.y);
    let mut out: Vec<BoxPoint> = Vec::with_capacity(poly.len());
    for q in poly {
        if out
            .last()
            .is_none_or(|l| (l.position - q.position).norm() > eps)
        {
            out.push(q);
        }
    }
    while out.len() > 1 && (out[0].position - out[out.len() - 1].position).norm() <= eps {
        out.pop();
    }
    if out.is_empty() {
        // Each cut keeps the nominal centre of mass (its bound gives way to it), so only
        // rounding can leave nothing, when the box is within rounding of a tangent: the region
        // is then the nominal point.
        out.push(BoxPoint {
            position: c.center_of_mass,
            kind: BoxPointKind::Corner { x: 0, y: 0 },
        });
    }
    out
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    pub(in crate::planar::robust) fn square_case_c() -> Candidate {
        Candidate {
            contact_1: Vector2::new(1.0, 1.0),
            contact_2: Vector2::new(-1.0, 1.0),
            normal_1: Vector2::new(-1.0, 0.0),
            normal_2: Vector2::new(1.0, 0.0),
            friction_1: 3f64.sqrt(),
            friction_2: 1.0 / 3f64.sqrt(),
            center_of_mass: Vector2::zeros(),
            mass: 1.0,
            gravity: Vector2::new(0.0, -1.0),
        }
    }

    pub(in crate::planar::robust) fn tolerance(x: f64, y: f64, m: f64) -> Uncertainty {
        Uncertainty {
            center_of_mass_tolerance: Vector2::new(x, y),
            mass_tolerance: m,
        }
    }

    #[test]
    fn region_is_the_box_cut_by_the_tangents() {
        let c = square_case_c();
        // Inside: the four corners, in order.
        let r = region(&c, &tolerance(0.5, 0.25, 0.0), 2.0);
        assert_eq!(r.len(), 4);
        assert_eq!(r[0].kind, BoxPointKind::Corner { x: -1, y: -1 });
        assert_eq!(r[2].position, Vector2::new(0.5, 0.25));
        // Past the tangent at contact 1 (x = 1): cut there, two new vertices.
        let r = region(&c, &tolerance(1.5, 0.25, 0.0), 2.0);
        assert_eq!(r.len(), 4);
        assert!(r.iter().all(|p| p.position.x.abs() <= 1.0 + 1e-15));
        assert_eq!(
            r.iter()
                .filter(|p| p.kind
                    == BoxPointKind::Cut {
                        contact: Contact::First
                    })
                .count(),
            2
        );
        // One axis only: a segment with two ends.
        let r = region(&c, &tolerance(0.5, 0.0, 0.0), 2.0);
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].kind, BoxPointKind::Corner { x: -1, y: 0 });
        // Mass only: the nominal point.
        let r = region(&c, &tolerance(0.0, 0.0, 0.1), 2.0);
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].kind, BoxPointKind::Corner { x: 0, y: 0 });
    }
}
