//! The batch path answers every grasp as the single path does, bit for bit, every field: over the
//! paper's Table 1 and over random grasps (planar and spatial, with and without force closure,
//! refused input among them), every objective and range, on one thread and on several.
//!
//! Answers are compared by their `Debug` text: it prints every field, and each double in the
//! shortest form that reads back to the same bits (so `-0.0` differs from `0.0`, and two doubles
//! one rounding apart differ), which `==` on doubles would not tell apart.

mod support;

use grasp_orient_solver::batch::{self, Threads, MIN_PER_THREAD};
use grasp_orient_solver::{planar, spatial, table_1::table_1, AllowedRange, Objective, Settings};
use std::num::NonZeroUsize;
use support::random::{self, Rng};

/// Every objective with every kind of range: the two named ones, explicit bounds inside the
/// graspable range for most grasps, bounds that miss it for some (a refusal), bounds that are
/// not a range (a refusal), and a friction safety factor.
fn every_setting() -> Vec<Settings> {
    let ranges = [
        AllowedRange::FromAbove,
        AllowedRange::Graspable,
        AllowedRange::Bounds { lo: -0.7, hi: 0.4 },
        AllowedRange::Bounds { lo: 2.9, hi: 3.1 },
        AllowedRange::Bounds { lo: 1.0, hi: -1.0 },
    ];
    let mut out = Vec::new();
    for objective in [Objective::Norm2, Objective::Norm1, Objective::InternalForce] {
        for range in ranges {
            out.push(Settings {
                objective,
                range,
                friction_safety_factor: 1.0,
            });
        }
        out.push(Settings {
            objective,
            friction_safety_factor: 1.5,
            ..Settings::default()
        });
    }
    // Not a safety factor: every grasp is refused.
    out.push(Settings {
        friction_safety_factor: 0.5,
        ..Settings::default()
    });
    out
}

/// The thread limits the tests run the batch with: the calling thread only, three, and what
/// the machine has.
fn every_limit() -> [Threads; 3] {
    [
        Threads::ONE,
        Threads::AtMost(NonZeroUsize::new(3).expect("3 > 0")),
        Threads::Available,
    ]
}

/// `planar::solve`'s answer in the batch's form: the recommendation out of its box.
fn single_planar(c: &planar::Candidate, settings: &Settings) -> batch::PlanarAnswer {
    planar::solve(c, settings).map(|v| match v {
        planar::Verdict::Recommended(r) => Ok(*r),
        planar::Verdict::NoForceClosure(why) => Err(why),
    })
}

/// `spatial::solve`'s answer in the batch's form: the recommendation out of its box.
fn single_spatial(c: &spatial::Candidate, settings: &Settings) -> batch::SpatialAnswer {
    spatial::solve(c, settings).map(|v| match v {
        spatial::Verdict::Recommended(r) => Ok(*r),
        spatial::Verdict::NoForceClosure(why) => Err(why),
    })
}

/// Asserts that `got[i]` is `want(&inputs[i])`, bit for bit, for every `i`.
fn assert_same<C: std::fmt::Debug, R: std::fmt::Debug>(
    what: &str,
    inputs: &[C],
    got: &[R],
    want: impl Fn(&C) -> R,
) {
    assert_eq!(got.len(), inputs.len(), "{what}: one answer per candidate");
    for (i, (c, g)) in inputs.iter().zip(got).enumerate() {
        let (g, w) = (format!("{g:?}"), format!("{:?}", want(c)));
        assert_eq!(g, w, "{what}: candidate {i} {c:?}");
    }
}

/// A count of how the single path answered, so that a test can show its mix covers refusals,
/// grasps without force closure and recommendations.
#[derive(Debug, Default)]
struct Mix {
    recommended: usize,
    no_closure: usize,
    refused: usize,
}

fn planar_mix_of(answers: &[batch::PlanarAnswer]) -> Mix {
    let mut m = Mix::default();
    for a in answers {
        match a {
            Ok(Ok(_)) => m.recommended += 1,
            Ok(Err(_)) => m.no_closure += 1,
            Err(_) => m.refused += 1,
        }
    }
    m
}

fn spatial_mix_of(answers: &[batch::SpatialAnswer]) -> Mix {
    let mut m = Mix::default();
    for a in answers {
        match a {
            Ok(Ok(_)) => m.recommended += 1,
            Ok(Err(_)) => m.no_closure += 1,
            Err(_) => m.refused += 1,
        }
    }
    m
}

/// Table 1's four cases, each also relabelled (the contacts exchanged) and scaled, under every
/// setting and thread limit.
#[test]
fn table_1_is_answered_as_by_the_single_path() {
    let mut grasps = Vec::new();
    for case in ['a', 'b', 'c', 'd'] {
        let c = table_1(case);
        grasps.push(c);
        grasps.push(planar::Candidate {
            contact_1: c.contact_2,
            contact_2: c.contact_1,
            normal_1: c.normal_2,
            normal_2: c.normal_1,
            friction_1: c.friction_2,
            friction_2: c.friction_1,
            ..c
        });
        grasps.push(planar::Candidate {
            contact_1: c.contact_1 * 1e-3,
            contact_2: c.contact_2 * 1e-3,
            mass: 2.5,
            gravity: c.gravity * 9.81,
            ..c
        });
    }
    for settings in every_setting() {
        for threads in every_limit() {
            let mut out = Vec::new();
            batch::planar_with(&grasps, &settings, threads, &mut out);
            assert_same(&format!("{settings:?} {threads:?}"), &grasps, &out, |c| {
                single_planar(c, &settings)
            });
        }
    }
}

/// 12,000 random planar grasps (about a tenth without force closure, a tenth refused) under
/// every setting and thread limit; the answers go after what `out` held, which stays.
#[test]
fn random_planar_grasps_are_answered_as_by_the_single_path() {
    let mut rng = Rng::new(7);
    let grasps: Vec<_> = (0..12_000).map(|_| random::planar_mix(&mut rng)).collect();
    let default = Settings::default();
    let mut seen = Vec::new();
    batch::planar_with(&grasps, &default, Threads::ONE, &mut seen);
    let mix = planar_mix_of(&seen);
    assert!(
        mix.recommended > 9_000 && mix.no_closure > 600 && mix.refused > 600,
        "{mix:?}"
    );
    for settings in every_setting() {
        for threads in every_limit() {
            let mut out = vec![Err(grasp_orient_solver::InvalidInput::CoincidentContacts)];
            batch::planar_with(&grasps, &settings, threads, &mut out);
            assert_eq!(
                format!("{:?}", out[0]),
                "Err(CoincidentContacts)",
                "kept what was there"
            );
            assert_same(
                &format!("{settings:?} {threads:?}"),
                &grasps,
                &out[1..],
                |c| single_planar(c, &settings),
            );
        }
    }
}

/// 10,000 random spatial grasps (off the axis, on it for about a twentieth, in the x-y plane
/// for a tenth; without force closure and refused for about a tenth each) under every setting,
/// on one thread and on what the machine has.
#[test]
fn random_spatial_grasps_are_answered_as_by_the_single_path() {
    let mut rng = Rng::new(11);
    let grasps: Vec<_> = (0..10_000).map(|_| random::spatial_mix(&mut rng)).collect();
    let mut seen = Vec::new();
    batch::spatial_with(&grasps, &Settings::default(), Threads::ONE, &mut seen);
    let mix = spatial_mix_of(&seen);
    assert!(
        mix.recommended > 7_000 && mix.no_closure > 500 && mix.refused > 500,
        "{mix:?}"
    );
    for settings in every_setting() {
        // The on-axis norm1 search costs about 0.3 ms a grasp: its ranges once, one limit.
        let limits: &[Threads] = if settings.objective == Objective::Norm1 {
            &[Threads::Available]
        } else {
            &[Threads::ONE, Threads::Available]
        };
        for &threads in limits {
            let mut out = Vec::new();
            batch::spatial_with(&grasps, &settings, threads, &mut out);
            assert_same(&format!("{settings:?} {threads:?}"), &grasps, &out, |c| {
                single_spatial(c, &settings)
            });
        }
    }
}

/// A batch runs on as many threads as its length pays for, within the limit, and an empty
/// batch answers nothing.
#[test]
fn threads_follow_the_batch_length() {
    let three = Threads::AtMost(NonZeroUsize::new(3).expect("3 > 0"));
    assert_eq!(three.for_batch(0), 1);
    assert_eq!(three.for_batch(2 * MIN_PER_THREAD - 1), 1);
    assert_eq!(three.for_batch(2 * MIN_PER_THREAD), 2);
    assert_eq!(three.for_batch(100 * MIN_PER_THREAD), 3);
    assert_eq!(Threads::ONE.for_batch(100 * MIN_PER_THREAD), 1);
    let mut out = Vec::new();
    batch::planar(&[], &Settings::default(), &mut out);
    assert!(out.is_empty());
}
