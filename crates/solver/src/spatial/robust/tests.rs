//! Tests of the whole solve: scale-freedom, and the exchange's stopping rules and its fans
//! (module docs, *Tolerances*, §5, §7) on slow candidates.

use super::problem::tests::grasp;
use super::{EXCHANGE, EXCHANGE_ABS};
use crate::{AllowedRange, Objective, Settings};
use nalgebra::Vector3;

/// As the planar `tiny_normals_and_gravity_give_the_answer_of_unit_ones`: normals and
/// gravity of lengths whose squares underflow give the answer of unit ones, never a panic.
#[test]
fn tiny_normals_and_gravity_give_the_answer_of_unit_ones() {
    let u = super::Uncertainty {
        center_of_mass_tolerance: Vector3::new(0.02, 0.05, 0.05),
        mass_tolerance: 0.1,
    };
    let mut compared = 0;
    for k in 0..20 {
        let c = grasp(k);
        let Ok(super::Verdict::Recommended(want)) = super::solve(&c, &u, &Settings::default())
        else {
            continue;
        };
        for scale in [1e-200, 1e-160, 1e3] {
            let scaled = crate::spatial::Candidate {
                normal_1: c.normal_1 * scale,
                normal_2: c.normal_2 * scale,
                gravity: c.gravity * scale,
                ..c
            };
            let got = super::solve(&scaled, &u, &Settings::default());
            let Ok(super::Verdict::Recommended(got)) = got else {
                panic!("grasp {k} at scale {scale:e}: {got:?}");
            };
            let power = got.gripping_power / scale;
            assert!(
                (power - want.gripping_power).abs() <= 1e-9 * want.gripping_power,
                "grasp {k} at scale {scale:e}: {power} against {}",
                want.gripping_power
            );
        }
        compared += 1;
    }
    assert!(compared >= 5, "only {compared} grasps held");
}

/// A slow candidate of `benches/tail.rs` or of a search over grasps like those of `grasp`,
/// with the answer the code before the absolute tolerances gave (tilt, rad; worst objective
/// or squeeze, N; its optimality gap, N).
struct Slow {
    candidate: crate::spatial::Candidate,
    uncertainty: super::Uncertainty,
    settings: Settings,
    theta: f64,
    worst: f64,
    gap: f64,
}

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

fn settings(objective: Objective, range: AllowedRange) -> Settings {
    Settings {
        objective,
        range,
        friction_safety_factor: 1.0,
    }
}

/// Two grasps whose least worst squeeze is nearly zero (2.4e-12 N and 3.2e-12 N for 1 kg):
/// before, 13.1 s and 3.4 s, 848,650 and 432,890 splits, 60 exchanges each.
fn near_zero() -> [Slow; 2] {
    let on_x = |n1: Vector3<f64>, n2: Vector3<f64>, mu: [f64; 2], c: Vector3<f64>| {
        crate::spatial::Candidate {
            contact_1: v(0.5, 0.0, 0.0),
            contact_2: v(-0.5, 0.0, 0.0),
            normal_1: n1,
            normal_2: n2,
            friction_1: mu[0],
            friction_2: mu[1],
            center_of_mass: c,
            mass: 1.0,
            gravity: v(0.0, 0.0, -9.81),
        }
    };
    let box_only = |t: Vector3<f64>| super::Uncertainty {
        center_of_mass_tolerance: t,
        mass_tolerance: 0.0,
    };
    let squeeze = settings(Objective::InternalForce, AllowedRange::FromAbove);
    [
        Slow {
            candidate: on_x(
                v(
                    -0.6815505217213076,
                    -0.07242003458118966,
                    0.7281787039818404,
                ),
                v(
                    0.9500655588463088,
                    -0.27151487552663317,
                    0.15380216598542368,
                ),
                [2.6557311296951367, 2.8237716723701576],
                v(
                    -0.10530261081942052,
                    0.06744281348838999,
                    -0.25338512008042935,
                ),
            ),
            uncertainty: box_only(v(
                0.018852004023307157,
                0.05779785540169908,
                0.1334933618506316,
            )),
            settings: squeeze,
            theta: -0.20833619399952674,
            worst: 2.4107865703726363e-12,
            gap: 9.042170769802352e-15,
        },
        Slow {
            candidate: on_x(
                v(-0.7737229617873674, 0.16951864688963342, 0.6104229736499862),
                v(
                    0.9996627730722427,
                    0.015832826018956688,
                    -0.02058304529867066,
                ),
                [2.730273375802295, 2.8415419211549255],
                v(0.18397766953444217, 0.0, -0.3732619286966661),
            ),
            uncertainty: box_only(v(
                0.12533002197510593,
                0.04859973371867802,
                0.14544780395194531,
            )),
            settings: squeeze,
            theta: -0.2767464724034294,
            worst: 3.1955038615194554e-12,
            gap: 9.779493863340376e-15,
        },
    ]
}

/// Two random candidates of `benches/tail.rs` (#8792 and #7057 of 10,000) near their friction
/// limits (worst cases of 6e6 and 3e4 weights), where the closed form and the envelope's
/// curves differ by more than 1e-9 of the value: before, 60 exchanges each, the same point
/// added again from the sixth and the ninth on (17 ms and 16 ms).
fn stalled() -> [Slow; 2] {
    [
        Slow {
            candidate: crate::spatial::Candidate {
                contact_1: v(
                    -1.1574751372189247,
                    -0.19217043114056687,
                    0.38937497679891575,
                ),
                contact_2: v(-0.6808526915378249, -1.2532419930319527, 0.470093511767125),
                normal_1: v(5.6384536440844295, -1.5475668434245964, -4.178425842080429),
                normal_2: v(-1.0439514926140983, 0.8059377811084422, 0.523303758841005),
                friction_1: 1.8457809785157102,
                friction_2: 0.7705562784004047,
                center_of_mass: v(
                    -1.2149217611679903,
                    -1.263057387385236,
                    -0.05271830066805705,
                ),
                mass: 0.19478281224264662,
                gravity: v(10.32822757158938, 2.6231222872542594, -3.533838044566626),
            },
            uncertainty: super::Uncertainty {
                center_of_mass_tolerance: v(
                    0.3285526076281989,
                    0.29987471628323575,
                    0.15696614367656203,
                ),
                mass_tolerance: 0.02144190228808399,
            },
            settings: settings(Objective::Norm2, AllowedRange::Graspable),
            theta: -0.9058400928580875,
            worst: 1.2319644428713254e6,
            gap: 1.7167989416105476e-3,
        },
        Slow {
            candidate: crate::spatial::Candidate {
                contact_1: v(
                    -0.35555005168395126,
                    -1.3960802994854324,
                    0.5316673674899104,
                ),
                contact_2: v(-0.24847967096433804, -1.511068468207179, 0.5008542388780519),
                normal_1: v(0.20889315338557216, -0.9137321244483038, -2.011038268922028),
                normal_2: v(-0.12522124598822784, 0.126065726927939, 0.01260070716404045),
                friction_1: 1.5882557096741559,
                friction_2: 0.12763932692758997,
                center_of_mass: v(-0.3636958059404188, -1.4832912499306736, 0.537686013987476),
                mass: 22.537203552058187,
                gravity: v(9.043802656199327, 3.178870681810648, 3.5678849579373537),
            },
            uncertainty: super::Uncertainty {
                center_of_mass_tolerance: v(
                    0.040722356533697934,
                    0.04132116257966973,
                    0.005015202613254787,
                ),
                mass_tolerance: 3.971054276253289,
            },
            settings: settings(Objective::InternalForce, AllowedRange::Graspable),
            theta: -0.6388369768524306,
            worst: 8.403534968804736e6,
            gap: 5.3825707519851634e-2,
        },
    ]
}

fn solved(s: &Slow) -> super::Recommendation {
    match super::solve(&s.candidate, &s.uncertainty, &s.settings) {
        Ok(super::Verdict::Recommended(r)) => *r,
        other => panic!("{other:?}"),
    }
}

/// The points the exchange method added to the region's vertices and axis points (the worst
/// point of each round and its neighbours).
fn exchanges(r: &super::Recommendation) -> usize {
    r.samples - r.region.len() - usize::from(r.axis_segment.is_some()) * 2
}

/// Module docs, *Tolerances*: a least worst squeeze near zero stops at the absolute
/// tolerance, within the iteration counts of ordinary candidates (a few hundred splits, a
/// few exchanges), at the tilt and squeeze of before to well within the tolerance.
#[test]
fn near_zero_worst_squeeze_stops_at_the_absolute_tolerance() {
    for (k, s) in near_zero().iter().enumerate() {
        let r = solved(s);
        let tol = EXCHANGE_ABS * r.mass_worst * s.candidate.gravity.norm();
        println!(
            "near zero {k}: θ {:.17} squeeze {:e} N gap {:e} N, {} splits, {} exchanges",
            r.gravity_angle,
            r.internal_force,
            r.optimality_gap,
            r.splits,
            exchanges(&r)
        );
        assert!(r.splits <= 2_000, "{k}: {} splits", r.splits);
        assert!(exchanges(&r) <= 10, "{k}: {} exchanges", exchanges(&r));
        assert!(r.optimality_gap <= tol, "{k}");
        // Within the tolerance (1e-10 of the weight, 9.8e-10 N here) of the answer before.
        assert!((r.internal_force - s.worst).abs() <= tol + s.gap, "{k}");
        assert!((r.gravity_angle - s.theta).abs() <= 1e-9, "{k}");
    }
}

/// Module docs §5, *Iteration bounds*: when the worst point at θ_S is already a sample, or
/// its curve does not rise above the envelope there by more than its two evaluations differ,
/// the exchange stops instead of adding it again until [`MAX_EXCHANGES`] (60 points before);
/// the answer is the one of before.
#[test]
fn exchange_stops_when_no_point_can_move_its_tilt() {
    for (k, s) in stalled().iter().enumerate() {
        let r = solved(s);
        let value = match s.settings.objective {
            Objective::InternalForce => r.internal_force,
            _ => r.gripping_power,
        };
        println!(
            "stalled {k}: θ {:.17} worst {value:e} N gap {:e} N, {} splits, {} exchanges",
            r.gravity_angle,
            r.optimality_gap,
            r.splits,
            exchanges(&r)
        );
        assert!(exchanges(&r) <= 20, "{k}: {} exchanges", exchanges(&r));
        assert!(r.splits <= 2_000, "{k}: {} splits", r.splits);
        assert!(
            (value - s.worst).abs() <= 1e-9 * s.worst,
            "{k}: {value} {}",
            s.worst
        );
        assert!(r.optimality_gap <= s.gap.max(1e-9 * value), "{k}");
        assert!((r.gravity_angle - s.theta).abs() <= 1e-9, "{k}");
    }
}

/// Module docs §7, *One minimum per fan*: the slowest candidate of `benches/tail.rs`
/// (#14833) reported 27 local minima, 25 of them a fan within 0.01 rad of the answer whose
/// separating barriers rise at most 9.7e-6 of the weight, each valued by its own certified
/// maximisation (2,765 splits in all). One per fan: the minimum 0.3 rad below it, the fan's
/// lowest and the one across the range; the answer is the one of before.
#[test]
fn one_minimum_per_fan() {
    let s = Slow {
        candidate: crate::spatial::Candidate {
            contact_1: v(0.37579301970347456, 1.678390513028841, 0.28867764865079115),
            contact_2: v(0.3166935767251592, 2.3230553430081073, -0.7094528743328252),
            normal_1: v(
                -0.04638894109481941,
                0.10181071083527465,
                -0.018378483100017443,
            ),
            normal_2: v(1.5148189627253503, -2.154160498127905, 2.2995217854345333),
            friction_1: 1.9447726842882251,
            friction_2: 0.7322443735890246,
            center_of_mass: v(0.3432331554470405, 2.0335597154983973, -0.2612246238803148),
            mass: 0.28647168020482605,
            gravity: v(5.03818004870848, -0.24842905177107885, 5.4974205787526635),
        },
        uncertainty: super::Uncertainty {
            center_of_mass_tolerance: v(
                0.15020811588559219,
                0.3258216811122028,
                0.19660497230142177,
            ),
            mass_tolerance: 0.0413978533856024,
        },
        settings: settings(Objective::InternalForce, AllowedRange::FromAbove),
        theta: -0.636877542429512,
        worst: 6.666259049438088,
        gap: 2.8269938110932852e-9,
    };
    let r = solved(&s);
    println!(
        "fan: {} minima, {} splits, θ {:.17}",
        r.local_minima.len(),
        r.splits,
        r.gravity_angle
    );
    let angles: Vec<f64> = r.local_minima.iter().map(|m| m.gravity_angle).collect();
    assert_eq!(angles.len(), 3, "{angles:?}");
    assert!((angles[0] + 0.937).abs() < 1e-3, "{angles:?}");
    assert!((angles[1] - s.theta).abs() < 0.01, "{angles:?}");
    assert!((angles[2] - 0.703).abs() < 1e-3, "{angles:?}");
    // The fan's minimum is worth no more than the answer, to the exchange's tolerance.
    let tol = EXCHANGE * s.worst + EXCHANGE_ABS * r.mass_worst * s.candidate.gravity.norm();
    assert!(r.local_minima[1].power <= r.internal_force + tol);
    assert!((r.gravity_angle - s.theta).abs() <= 1e-12);
    assert!((r.internal_force - s.worst).abs() <= 1e-12 * s.worst);
    assert!(r.optimality_gap <= s.gap + tol);
    assert!(r.splits < 2_000, "{} splits", r.splits);
}
