//! Tests of the whole solve: the nominal and mass-only cases, scale-freedom, the checks, the
//! refusals, the allowed ranges and the forces' conventions (module docs, sections 3, 4 and 7).

use super::region::tests::{square_case_c, tolerance};
use super::worst::tests::assert_envelope_is_the_maximum;
use super::worst::vertex_frame;
use super::*;
use crate::limits::MAX_COORDINATE;
use crate::planar::paper;
use crate::{AllowedRange, Objective};
use nalgebra::Vector2;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

fn recommended(c: &Candidate, u: &Uncertainty, s: &Settings) -> Recommendation {
    match solve(c, u, s) {
        Ok(Verdict::Recommended(r)) => *r,
        other => panic!("expected a recommendation, got {other:?}"),
    }
}

#[test]
fn zero_tolerance_is_the_nominal_solver() {
    let c = square_case_c();
    let s = Settings::default();
    assert_eq!(
        super::solve(&c, &Uncertainty::EXACT, &s),
        crate::planar::solve(&c, &s).map(super::Verdict::Exact)
    );
}

#[test]
fn mass_only_scales_the_nominal_answer() {
    let c = square_case_c();
    let r = recommended(&c, &tolerance(0.0, 0.0, 0.25), &Settings::default());
    assert!((r.gravity_angle - r.nominal.gravity_angle).abs() < 1e-12);
    assert!((r.gripping_power - 1.25 * r.nominal.gripping_power).abs() < 1e-12);
    assert!((r.gripping_power_nominal - r.nominal.gripping_power).abs() < 1e-12);
}

/// Found by `tests/fuzz.rs`: normals and gravity of any length the validation accepts, down to
/// 1e-200 whose squares underflow, give the same answer as unit ones (the region's tangents
/// and the weight are computed scale-free), and never an empty region.
#[test]
fn tiny_normals_and_gravity_give_the_answer_of_unit_ones() {
    let c = square_case_c();
    let u = tolerance(0.1, 0.2, 0.1);
    let want = recommended(&c, &u, &Settings::default());
    for k in [1e-200, 1e-160, 1e-100, 1e3] {
        // Forces scale with the weight, so with the gravity's length; the angle does not.
        let scaled = Candidate {
            normal_1: c.normal_1 * k,
            normal_2: c.normal_2 * k,
            gravity: c.gravity * k,
            ..c
        };
        let got = recommended(&scaled, &u, &Settings::default());
        assert_eq!(got.gravity_angle, want.gravity_angle, "scale {k:e}");
        let power = got.gripping_power / k;
        assert!(
            (power - want.gripping_power).abs() <= 1e-12 * want.gripping_power,
            "scale {k:e}: {power} against {}",
            want.gripping_power
        );
    }
}

#[test]
fn tolerances_are_checked() {
    let c = square_case_c();
    let s = Settings::default();
    let refused = |u: Uncertainty| super::solve(&c, &u, &s).expect_err("refused");
    assert_eq!(
        refused(tolerance(-0.1, 0.0, 0.0)),
        InvalidInput::Tolerance {
            field: "center_of_mass_tolerance.x",
            value: -0.1,
            limit: MAX_COORDINATE,
            unit: " m"
        }
    );
    assert_eq!(
        refused(tolerance(0.0, f64::NAN, 0.0)),
        InvalidInput::NotFinite {
            field: "center_of_mass_tolerance.y"
        }
    );
    assert!(matches!(
        refused(tolerance(0.0, 0.0, 1.0)),
        InvalidInput::Tolerance {
            field: "mass_tolerance",
            ..
        }
    ));
    let message = refused(tolerance(0.0, 0.0, 2.0)).to_string();
    assert!(message.contains("mass_tolerance"), "{message}");
}

#[test]
fn across_the_contact_line_has_no_common_orientation() {
    // The contact line is y = 1; a box reaching past it.
    let c = square_case_c();
    match super::solve(&c, &tolerance(0.1, 1.5, 0.0), &Settings::default()) {
        Ok(super::Verdict::NoCommonOrientation {
            reason: NoCommonOrientation::AcrossContactLine { point },
            nominal,
        }) => {
            assert!(point.position.y > 1.0);
            assert_eq!(
                Some(*nominal),
                match crate::planar::solve(&c, &Settings::default()) {
                    Ok(crate::planar::Verdict::Recommended(r)) => Some(*r),
                    _ => None,
                }
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_box_wider_than_the_grip_cannot_hang_from_above_everywhere() {
    // Contacts 0.2 apart on an object whose tangents slope outward, box 1.0 wide below.
    let c = Candidate {
        contact_1: Vector2::new(0.1, 0.0),
        contact_2: Vector2::new(-0.1, 0.0),
        normal_1: Vector2::new(-0.2, -1.0),
        normal_2: Vector2::new(0.2, -1.0),
        friction_1: 10.0,
        friction_2: 10.0,
        center_of_mass: Vector2::new(0.0, -1.0),
        mass: 1.0,
        gravity: Vector2::new(0.0, -9.81),
    };
    match super::solve(&c, &tolerance(1.0, 0.1, 0.0), &Settings::default()) {
        Ok(super::Verdict::NoCommonOrientation {
            reason: NoCommonOrientation::Disjoint { lo, hi, .. },
            ..
        }) => assert!(lo > hi),
        other => panic!("{other:?}"),
    }
}

/// Module docs, section 4: the wide box below a short segment. Straight up (θ = π) is
/// graspable for every corner, but the box's middle then rests on the fingers, so it must
/// not be allowed; the interval intersection excludes it.
#[test]
fn graspable_range_is_the_hull_not_the_union() {
    let c = Candidate {
        contact_1: Vector2::new(1.0, 0.0),
        contact_2: Vector2::new(-1.0, 0.0),
        normal_1: Vector2::new(-0.11, -0.99),
        normal_2: Vector2::new(0.11, -0.99),
        friction_1: 20.0,
        friction_2: 20.0,
        center_of_mass: Vector2::new(0.0, -1.0),
        mass: 1.0,
        gravity: Vector2::new(0.0, -9.81),
    };
    let settings = Settings {
        range: AllowedRange::Graspable,
        ..Settings::default()
    };
    let r = recommended(&c, &tolerance(3.0, 0.5, 0.0), &settings);
    // Every corner allows θ = π on its own (its excluded arc is narrow).
    assert_eq!(r.region.len(), 4);
    let f0 = GraspFrame::new(&c, 1.0).expect("valid");
    for p in &r.region {
        let f = vertex_frame(&f0, c.center_of_mass, p.position, 1.0);
        let ((lo, hi), _) = paper::ranges(&f);
        let up = lo + (PI - lo).rem_euclid(TAU);
        assert!(up <= hi, "corner {p} allows straight up");
    }
    // The nominal centre does not, and neither does the region's range.
    let ((lo, hi), _) = paper::ranges(&f0);
    assert!(lo + (PI - lo).rem_euclid(TAU) > hi);
    let (glo, ghi) = r.graspable;
    assert!(glo + (PI - glo).rem_euclid(TAU) > ghi);
    assert!(glo <= -FRAC_PI_2 && ghi >= FRAC_PI_2);
}

#[test]
fn bounds_meet_the_region_graspable_range() {
    let c = square_case_c();
    let u = tolerance(0.5, 0.0, 0.0);
    let graspable = Settings {
        range: AllowedRange::Graspable,
        ..Settings::default()
    };
    let r = recommended(&c, &u, &graspable);
    // The corners at x = ±0.5 narrow [-3π/4, 3π/4] to ±(π - atan2(0.75, 0.5)).
    let end = PI - 0.75f64.atan2(0.5);
    assert!((r.graspable.0 + end).abs() < 1e-12 && (r.graspable.1 - end).abs() < 1e-12);
    // Bounds that cover it, shifted by a turn, give the same answer.
    let bounds = Settings {
        range: AllowedRange::Bounds {
            lo: -3.0 + TAU,
            hi: 3.0 + TAU,
        },
        ..Settings::default()
    };
    let b = recommended(&c, &u, &bounds);
    assert_eq!(b.allowed, vec![r.graspable]);
    assert_eq!(b.gravity_angle, r.gravity_angle);
    // Bounds the nominal object accepts but some corner does not.
    let narrow = Settings {
        range: AllowedRange::Bounds { lo: 2.3, hi: 2.35 },
        ..Settings::default()
    };
    match super::solve(&c, &u, &narrow) {
        Ok(super::Verdict::NoCommonOrientation {
            reason: reason @ NoCommonOrientation::BoundsMissed { .. },
            ..
        }) => {
            let text = reason.to_string();
            assert!(
                text.contains("corner (+x)") && text.contains("corner (-x)"),
                "{text}"
            );
        }
        other => panic!("{other:?}"),
    }
    // Bounds that miss the nominal object's range are bad input, as today.
    let outside = Settings {
        range: AllowedRange::Bounds { lo: 2.5, hi: 2.6 },
        ..Settings::default()
    };
    assert!(matches!(
        super::solve(&c, &u, &outside),
        Err(InvalidInput::RangeOutsideGraspable { .. })
    ));
}

/// A vertex whose curve is huge rises steeply through a small one just after its own zero:
/// at the crossing, the steep curve's rounding (relative to its coefficients, about 1e9)
/// exceeds the small curve's value scale. The walk once stayed on the small curve there and
/// missed the crossing (found by `tests/it/robust.rs`).
#[test]
fn envelope_takes_a_steep_crossing() {
    let c = Candidate {
        contact_1: Vector2::new(-1.7624265088373754, -6.033809603302954),
        contact_2: Vector2::new(-2.7162526087026224, -2.9868505067375284),
        normal_1: Vector2::new(3.1306820733503704, 4.556693109138684),
        normal_2: Vector2::new(1.1847306785850145, -0.890422040105583),
        friction_1: 1.2744341947159041,
        friction_2: 1.2929923720774528,
        center_of_mass: Vector2::new(2.449061861343098, -3.0458989187266146),
        mass: 5.06024162164664,
        gravity: Vector2::new(-6.324178599348415, 5.314653069558688),
    };
    let u = tolerance(0.0, 0.9136421215780067, 3.0496289962400778);
    assert_envelope_is_the_maximum(&c, &u, Objective::Norm2);
    let r = recommended(&c, &u, &Settings::default());
    // The worst case falls towards the start of the allowed range, which is the answer.
    assert_eq!(r.gravity_angle, r.allowed[0].0);
}

/// The forces in the candidate's labelling agree with the nominal solver's own report.
#[test]
fn contact_forces_use_the_solver_conventions() {
    for swap in [false, true] {
        let mut c = square_case_c();
        if swap {
            std::mem::swap(&mut c.contact_1, &mut c.contact_2);
            std::mem::swap(&mut c.normal_1, &mut c.normal_2);
            std::mem::swap(&mut c.friction_1, &mut c.friction_2);
        }
        let r = recommended(&c, &tolerance(0.0, 0.0, 0.5), &Settings::default());
        for k in 0..4 {
            assert!((r.contact_forces[k] - r.nominal.contact_forces[k]).abs() < 1e-12);
        }
    }
}
