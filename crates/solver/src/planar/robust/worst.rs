//! The region's vertices analysed at the largest mass, and their upper envelope (module docs,
//! sections 1, 2, 5 and 6): the worst case at one orientation, and where it is attained.

use super::envelope::Envelope;
use super::range::{self, Common, NoCommonOrientation};
use super::region::{BoxPoint, BoxPointKind};
use crate::planar::analysis::Analysis;
use crate::planar::curve::Curve;
use crate::planar::frame::{length, GraspFrame};
use crate::planar::paper::{self, FORCE_SCALE};
use crate::planar::{Candidate, LocalMinimum, NoForceClosure};
use crate::sinusoid::Angle;
use crate::{Objective, Settings};
use nalgebra::Vector2;

/// A vertex this far (in contact distances) on the far side of the contact line counts as on it.
const ON_LINE: f64 = 1e-12;

/// Why the robust answer is not a recommendation.
pub(super) enum Refusal {
    NoCommon(NoCommonOrientation),
    NoClosure(NoForceClosure),
}

/// The region's vertices analysed at the largest mass, and their upper envelope.
pub(super) struct Worst {
    pub(super) objective: Objective,
    /// The nominal frame (axes, labelling, current pose).
    pub(super) nominal_frame: GraspFrame,
    /// The nominal centre of mass, candidate frame, m.
    center_of_mass: Vector2<f64>,
    pub(super) region: Vec<BoxPoint>,
    frames: Vec<GraspFrame>,
    analyses: Vec<Analysis>,
    pub(super) graspable: (f64, f64),
    pub(super) allowed: Vec<(f64, f64)>,
    envelope: Envelope,
    /// `m_max |g|`, N.
    pub(super) weight: f64,
    /// `m_min / m_max`: a negative squeeze (the 1-norm's, module docs section 5) is largest at
    /// the smallest mass.
    mass_ratio: f64,
}

impl Worst {
    /// Builds every vertex's frame and analysis, the allowed range for the whole region, and the
    /// envelope over the region's graspable range (module docs, sections 2, 4 and 6).
    pub(super) fn new(
        frame: &GraspFrame,
        candidate: &Candidate,
        region: &[BoxPoint],
        (mass_least, mass_worst): (f64, f64),
        settings: &Settings,
    ) -> Result<Self, Refusal> {
        let weight = mass_worst * length(&candidate.gravity);
        let mut frames = Vec::with_capacity(region.len());
        for p in region {
            let f = vertex_frame(frame, candidate.center_of_mass, p.position, weight);
            if f.y < -ON_LINE {
                return Err(Refusal::NoCommon(NoCommonOrientation::AcrossContactLine {
                    point: *p,
                }));
            }
            frames.push(GraspFrame {
                y: f.y.max(0.0),
                ..f
            });
        }
        let analyses = frames
            .iter()
            .map(|f| Analysis::new(f, settings.objective))
            .collect::<Result<Vec<_>, _>>()
            .map_err(Refusal::NoClosure)?;
        // `paper::ranges` of each vertex's frame.
        let graspable = Common::of(analyses.iter().map(Analysis::graspable_range));
        let from_above = Common::of(analyses.iter().map(Analysis::from_above_range));
        let allowed = range::allowed(settings.range, graspable, from_above, region)
            .map_err(Refusal::NoCommon)?;
        let tracks: Vec<Vec<(f64, f64, Curve)>> =
            analyses.iter().map(|a| a.pieces().collect()).collect();
        let envelope = Envelope::new(&tracks, graspable.lo, graspable.hi);
        Ok(Self {
            objective: settings.objective,
            nominal_frame: *frame,
            center_of_mass: candidate.center_of_mass,
            region: region.to_vec(),
            frames,
            analyses,
            graspable: (graspable.lo, graspable.hi),
            allowed,
            envelope,
            weight,
            mass_ratio: mass_least / mass_worst,
        })
    }

    /// `k` of the curves: objective = `k sqrt(Q)` or `k S`.
    fn scale(&self) -> f64 {
        self.weight * FORCE_SCALE
    }

    /// The gravity angle of least worst case over the allowed range (module docs, section 6).
    pub(super) fn minimiser(&self, current: f64) -> f64 {
        self.envelope
            .least(&self.allowed, current, self.scale(), self.weight)
    }

    /// Every local minimum of the worst case over the region's graspable range.
    pub(super) fn local_minima(&self) -> Vec<LocalMinimum> {
        self.envelope.local_minima(self.scale())
    }

    /// A force proportional to the mass at `m_max`, made the largest over the mass interval: at
    /// `m_max` if it is positive, at `m_min` if it is negative.
    pub(super) fn over_masses(&self, force: f64) -> f64 {
        if force < 0.0 {
            force * self.mass_ratio
        } else {
            force
        }
    }

    /// The worst objective and internal force at `theta` (the internal force at `m_max`; see
    /// [`Worst::over_masses`]), and where they are attained.
    pub(super) fn worst_at(&self, theta: f64) -> ((f64, BoxPoint), (f64, BoxPoint)) {
        let mut power = (f64::NEG_INFINITY, self.region[0]);
        let mut internal = (f64::NEG_INFINITY, self.region[0]);
        for (a, p) in self.analyses.iter().zip(&self.region) {
            let v = a.evaluate(theta);
            if v.power > power.0 {
                power = (v.power, *p);
            }
            if v.internal_force > internal.0 {
                internal = (v.internal_force, *p);
            }
        }
        if self.objective == Objective::Norm1 {
            for (position, f) in self.norm1_edge_points(theta) {
                if let Ok(a) = Analysis::new(&f, Objective::Norm1) {
                    let v = a.evaluate(theta).internal_force;
                    if v > internal.0 {
                        internal = (
                            v,
                            BoxPoint {
                                position,
                                kind: BoxPointKind::Edge,
                            },
                        );
                    }
                }
            }
        }
        (power, internal)
    }

    /// Where the line `β_1 = β_2` (the two friction forces' zeros in α, each affine in `c`)
    /// crosses the region's edge at `theta`, with the frames there (module docs, section 5).
    fn norm1_edge_points(&self, theta: f64) -> Vec<(Vector2<f64>, GraspFrame)> {
        let at = Angle::new(theta);
        let w = paper::balance_internal(&self.frames[0]);
        let mut out = Vec::new();
        if w[1] == 0.0 || w[3] == 0.0 || self.frames.len() < 2 {
            return out;
        }
        let gap: Vec<f64> = self
            .frames
            .iter()
            .map(|f| {
                let t = paper::balance_particular(f);
                t[3].value(&at) / w[3] - t[1].value(&at) / w[1]
            })
            .collect();
        let n = self.frames.len();
        for i in 0..n {
            let j = (i + 1) % n;
            if (gap[i] < 0.0) != (gap[j] < 0.0) && gap[i] != gap[j] {
                let s = gap[i] / (gap[i] - gap[j]);
                let (a, b) = (self.region[i].position, self.region[j].position);
                let position = a + (b - a) * s;
                let f = vertex_frame(
                    &self.nominal_frame,
                    self.center_of_mass,
                    position,
                    self.weight,
                );
                out.push((
                    position,
                    GraspFrame {
                        y: f.y.max(0.0),
                        ..f
                    },
                ));
            }
        }
        out
    }
}

/// The frame of the object with its centre of mass moved from `from` to `to` (candidate frame)
/// and weight `weight`, with `frame`'s axes and labelling (module docs, section 2). `y` may come
/// out negative: the point lies across the contact line.
pub(super) fn vertex_frame(
    frame: &GraspFrame,
    from: Vector2<f64>,
    to: Vector2<f64>,
    weight: f64,
) -> GraspFrame {
    let delta = (to - from) / frame.contact_distance;
    let (dx, dy) = (delta.dot(&frame.e_x), delta.dot(&frame.e_y));
    GraspFrame {
        x1: frame.x1 - dx,
        x2: frame.x2 + dx,
        y: frame.y - dy,
        weight,
        ..*frame
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::planar::robust::region::region;
    use crate::planar::robust::region::tests::tolerance;
    use crate::planar::robust::uncertainty::Uncertainty;
    use crate::AllowedRange;

    /// Module docs, section 5: the 1-norm's squeeze is `max(α_min, h)` with `h` set by the
    /// friction zeros and the slopes `s1 + s2 ± |c1| ± |c2|`, which depend on neither `c` nor θ.
    #[test]
    fn norm1_squeeze_is_alpha_min_or_a_friction_zero() {
        let mut checked = [0usize; 2];
        for k in 0..400 {
            let u = f64::from(k);
            let phi1 = 0.2 + 1.2 * (0.5 + 0.5 * (u * 0.37).sin());
            let phi2 = 0.2 + 1.2 * (0.5 + 0.5 * (u * 0.73).cos());
            let c = Candidate {
                contact_1: Vector2::new(0.5, 0.3 + 0.2 * (u * 0.11).sin()),
                contact_2: Vector2::new(-0.5, 0.3 + 0.2 * (u * 0.11).sin()),
                normal_1: Vector2::new(-phi1.sin(), -phi1.cos()),
                normal_2: Vector2::new(phi2.sin(), -phi2.cos()),
                friction_1: 1.5 + (u * 0.29).sin(),
                friction_2: 1.5 + (u * 0.53).cos(),
                center_of_mass: Vector2::new(0.3 * (u * 0.91).sin(), 0.0),
                mass: 1.0,
                gravity: Vector2::new(0.0, -1.0),
            };
            let Ok(f) = GraspFrame::new(&c, 1.0) else {
                continue;
            };
            let Ok(a) = Analysis::new(&f, Objective::Norm1) else {
                continue;
            };
            let w = paper::balance_internal(&f);
            let t = paper::balance_particular(&f);
            let (s, c1, c2) = (w[0] + w[2], w[1].abs(), w[3].abs());
            let (d0, d1, d2) = (s - c1 - c2, s + c1 - c2, s - c1 + c2);
            for i in 0..50 {
                let theta = -3.0 + 0.12 * f64::from(i);
                let at = Angle::new(theta);
                let (b1, b2) = (-t[1].value(&at) / w[1], -t[3].value(&at) / w[3]);
                // s_i + |c_i| >= 1 >= |c_j| and s_j > 0: passing one zero always suffices.
                assert!(d1 > 0.0 && d2 > 0.0);
                let (h, case) = if d0 >= 0.0 {
                    (f64::NEG_INFINITY, 0)
                } else {
                    (b1.min(b2), 1)
                };
                let v = a.evaluate(theta);
                let want = v.alpha_min.max(h);
                assert!(
                    (v.alpha - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "θ {theta}: solver's α {} vs max(α_min, h) {want}",
                    v.alpha
                );
                checked[case] += 1;
            }
        }
        assert!(
            checked.iter().all(|&n| n > 0),
            "every case met: {checked:?}"
        );
    }

    /// The envelope tiles the region's graspable range and is the largest vertex curve there.
    pub(in crate::planar::robust) fn assert_envelope_is_the_maximum(
        c: &Candidate,
        u: &Uncertainty,
        objective: Objective,
    ) {
        let settings = Settings {
            objective,
            range: AllowedRange::Graspable,
            ..Settings::default()
        };
        let frame = GraspFrame::new(c, 1.0).expect("valid");
        let region = region(c, u, frame.contact_distance);
        let masses = (c.mass - u.mass_tolerance, c.mass + u.mass_tolerance);
        let w = match Worst::new(&frame, c, &region, masses, &settings) {
            Ok(w) => w,
            Err(_) => panic!("the box is on one side of the contact line"),
        };
        let env = &w.envelope.pieces;
        assert_eq!(env[0].lo, w.graspable.0);
        assert_eq!(env.last().map(|p| p.hi), Some(w.graspable.1));
        for pair in env.windows(2) {
            assert_eq!(pair[0].hi, pair[1].lo);
        }
        assert!(env.iter().any(|p| p.vertex != env[0].vertex));
        for piece in env {
            for k in 0..=50 {
                let t = piece.lo + (piece.hi - piece.lo) * f64::from(k) / 50.0;
                let on_top = piece.curve.power(&Angle::new(t), w.scale());
                let max = w
                    .analyses
                    .iter()
                    .map(|a| a.evaluate(t).power)
                    .fold(f64::NEG_INFINITY, f64::max);
                assert!(
                    (on_top - max).abs() <= 1e-9 * max.abs().max(w.weight),
                    "{objective:?} at {t}: envelope {on_top}, max {max}"
                );
            }
        }
    }

    #[test]
    fn envelope_is_the_pointwise_maximum() {
        let c = Candidate {
            contact_1: Vector2::new(5.0, 4.0),
            contact_2: Vector2::new(-3.0, 4.0),
            normal_1: Vector2::new(-(0.785f64).sin(), -(0.785f64).cos()),
            normal_2: Vector2::new((0.785f64).sin(), -(0.785f64).cos()),
            friction_1: 1.5,
            friction_2: 2.5,
            center_of_mass: Vector2::zeros(),
            mass: 1.0,
            gravity: Vector2::new(0.0, -1.0),
        };
        for objective in [Objective::Norm2, Objective::Norm1, Objective::InternalForce] {
            assert_envelope_is_the_maximum(&c, &tolerance(1.0, 1.5, 0.2), objective);
        }
    }
}
