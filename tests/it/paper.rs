//! The paper's own numbers and claims, checked against the closed forms and the independent
//! reference. Where the paper is wrong, the test names the entry and the correct value.

use crate::util::table_1::table_1;
use crate::util::{random_grasp, wrap, RefObjective, RefRange, Reference};
use approx::{abs_diff_eq, abs_diff_ne, assert_abs_diff_eq};
use grasp_orient::msg::GraspCandidate;
use grasp_orient::solver::{
    planar::{self, analyse, Analysis, Candidate, CandidateC, PaperCandidate, Verdict},
    Settings,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Table 2 as printed: `θ_min, θ_max, θ_36, θ_34, θ_45`.
fn table_2(case: char) -> [f64; 5] {
    match case {
        'a' => [-2.094, 2.094, -2.491, -0.311, 2.397],
        'b' => [-2.498, 2.498, -2.733, 0.089, 2.594],
        'c' => [-2.356, 2.356, -1.921, 0.261, 2.510],
        'd' => [-2.820, 2.820, -1.006, -0.129, 2.742],
        _ => unreachable!("Table 2 has four cases"),
    }
}

const NAMES: [&str; 5] = ["theta_min", "theta_max", "theta_36", "theta_34", "theta_45"];

/// The 2-norm objective of a grasp with force closure, with the paper's friction.
fn analysis(c: &Candidate) -> Analysis {
    analyse(c, &Settings::default())
        .expect("valid")
        .expect("force closure")
}

fn computed(case: char) -> [f64; 5] {
    let a = analysis(&table_1(case)).candidate_angles();
    [a.theta_min, a.theta_max, a.theta_36, a.theta_34, a.theta_45]
}

/// `examples/paper_cases.jsonl` is Table 1 in SI units: lengths in centimetres written in metres,
/// `m |g| = 1` N with standard gravity.
#[test]
fn paper_cases_jsonl_is_table_1() {
    let lines = include_str!("../../examples/paper_cases.jsonl").lines();
    let cases: Vec<GraspCandidate> = lines
        .map(|l| serde_json::from_str(l).expect("a GraspCandidate"))
        .collect();
    assert_eq!(cases.len(), 4);
    for (m, case) in cases.iter().zip(['a', 'b', 'c', 'd']) {
        assert_eq!(m.id, format!("paper-{case}"));
        let c = Candidate::try_from(m).expect("valid");
        let t = table_1(case);
        for (got, want) in [
            (c.contact_1 * 100.0, t.contact_1),
            (c.contact_2 * 100.0, t.contact_2),
            (c.normal_1, t.normal_1),
            (c.normal_2, t.normal_2),
            (c.center_of_mass, t.center_of_mass),
            (c.gravity / c.gravity.norm(), t.gravity),
        ] {
            assert!(
                abs_diff_eq!(got, want, epsilon = 1e-12),
                "({case}) {got} vs {want}"
            );
        }
        assert_eq!((c.friction_1, c.friction_2), (t.friction_1, t.friction_2));
        assert_abs_diff_eq!(c.mass * c.gravity.norm(), 1.0, epsilon = 1e-12);
    }
}

/// Every Table 2 entry, from the paper's own formulas (9), (10), (36)–(44) and Table 1, agrees
/// to the three printed decimals — except these, which the paper gets wrong:
/// - (b) θ_max: printed 2.498 (θ_min's magnitude copied); eq. (10) gives π - atan2(5, 4) = 2.246.
/// - (c) θ_34: printed +0.261; eqs. (42)–(44) give -0.262 (the sign is lost), and the
///   reference confirms -π/12 is where both contacts slip and where the power is least.
/// - (a) θ_36: printed -2.491, formula -2.4915 rounds to -2.492; (c) θ_36: printed -1.921,
///   formula -1.9216 rounds to -1.922 (truncated, not rounded).
#[test]
fn table_2_follows_from_table_1_except_named_entries() {
    let wrong: &[(char, usize, f64)] = &[('b', 1, 2.2455), ('c', 3, -0.2618)];
    let truncated: &[(char, usize)] = &[('a', 2), ('c', 2)];
    for case in ['a', 'b', 'c', 'd'] {
        let ours = computed(case);
        let paper = table_2(case);
        for k in 0..5 {
            let name = NAMES[k];
            if let Some((_, _, correct)) = wrong.iter().find(|(c, i, _)| *c == case && *i == k) {
                assert!(
                    abs_diff_ne!(ours[k], paper[k], epsilon = 0.1),
                    "({case}) {name}: expected the paper's {} to be wrong",
                    paper[k]
                );
                assert!(
                    abs_diff_eq!(ours[k], *correct, epsilon = 1e-4),
                    "({case}) {name}: {} vs {correct}",
                    ours[k]
                );
            } else if truncated.contains(&(case, k)) {
                assert!(
                    abs_diff_eq!(ours[k], paper[k], epsilon = 1e-3)
                        && abs_diff_ne!(ours[k], paper[k], epsilon = 5e-4),
                    "({case}) {name}: {} vs printed {}",
                    ours[k],
                    paper[k]
                );
            } else {
                assert!(
                    abs_diff_eq!(ours[k], paper[k], epsilon = 5e-4),
                    "({case}) {name}: formula gives {:.5}, paper prints {}",
                    ours[k],
                    paper[k]
                );
            }
        }
    }
}

/// The candidate angles are where the reference's bounds really cross: θ_34 is the orientation
/// at which both contacts are about to slip at the least squeeze of the two (α_3 = α_4).
#[test]
fn theta_34_is_where_both_contacts_slip() {
    for case in ['a', 'b', 'c', 'd'] {
        let c = table_1(case);
        let theta_34 = computed(case)[3];
        // Gravity angle θ in the paper frame is the object rotation ω = -θ from gravity (0, -1).
        let reference = Reference::new(&c, 1.0, RefObjective::InternalForce);
        let p = reference.at(-theta_34).expect("feasible");
        let [n1, f1, n2, f2] = p.forces;
        assert!(
            abs_diff_eq!(f1.abs(), c.friction_1 * n1, epsilon = 1e-9),
            "({case}) contact 1 not at slip"
        );
        assert!(
            abs_diff_eq!(f2.abs(), c.friction_2 * n2, epsilon = 1e-9),
            "({case}) contact 2 not at slip"
        );
    }
}

/// The four case studies: the solver's recommendation equals the reference's, and the paper's
/// claim "in all cases the minimal point of our interest is θ_34" holds for the paper's own
/// examples (over the from-above range, with the 2-norm).
#[test]
fn paper_case_studies_recommend_theta_34() {
    for case in ['a', 'b', 'c', 'd'] {
        let c = table_1(case);
        let Ok(Verdict::Recommended(r)) = planar::solve(&c, &Settings::default()) else {
            panic!("({case}) must be solvable")
        };
        let reference = Reference::new(&c, 1.0, RefObjective::Norm2);
        let (w, p) = reference.minimise(RefRange::FromAbove, c.gravity, 20_000);
        assert!(wrap(r.wrist_rotation - w).abs() < 1e-9, "({case})");
        assert!(
            abs_diff_eq!(r.gripping_power, p, epsilon = 1e-12),
            "({case})"
        );
        assert_eq!(r.recommended_label, Some(PaperCandidate::C), "({case})");
        assert_eq!(r.candidate_c, CandidateC::Recommended, "({case})");
        let theta_34 = computed(case)[3];
        assert!(
            abs_diff_eq!(r.gravity_angle, theta_34, epsilon = 1e-12),
            "({case})"
        );
        println!(
            "({case}) θ = {:.6} rad, P = {:.6} N, squeeze {:.6} N, case {}, minima {:?}",
            r.gravity_angle,
            r.gripping_power,
            r.internal_force,
            r.grasp_case.name(),
            r.local_minima
                .iter()
                .map(|m| (m.gravity_angle, m.label.map(|l| l.name())))
                .collect::<Vec<_>>()
        );
    }
}

/// Theorem 1's case (Fig. 7): (a) both cones hold the centre of mass; the paper's case studies
/// are built to show (a)–(d) in order, and (a), (b) have local minima at A, C and E.
#[test]
fn paper_case_studies_fall_in_their_cases() {
    let settings = Settings {
        range: grasp_orient::solver::AllowedRange::Graspable,
        ..Settings::default()
    };
    for (case, expected) in [('a', "a"), ('b', "a"), ('c', "b"), ('d', "d")] {
        let Ok(Verdict::Recommended(r)) = planar::solve(&table_1(case), &settings) else {
            panic!("({case}) must be solvable")
        };
        assert_eq!(r.grasp_case.name(), expected, "({case})");
    }
}

/// Theorem 1 says C is always a local minimum. It is not: on random force-closure grasps a
/// sizeable share pass through θ_34 without a minimum, and in others C is a local minimum but an
/// end of the from-above range is lower. In every case the solver's answer is the reference's.
#[test]
fn theorem_1_fails_on_random_grasps_and_the_solver_does_not() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut counts = [0usize; 4];
    let mut examples: [Option<Candidate>; 4] = [None; 4];
    let n = 5000;
    for _ in 0..n {
        let c = random_grasp(&mut rng);
        let Ok(Verdict::Recommended(r)) = planar::solve(&c, &Settings::default()) else {
            panic!("valid grasp refused")
        };
        let k = r.candidate_c as usize;
        counts[k] += 1;
        examples[k].get_or_insert(c);
    }
    println!(
        "over {n} random grasps, C is: recommended {}, not a minimum {}, a beaten minimum {}, \
         outside the from-above range {}",
        counts[0], counts[1], counts[2], counts[3]
    );
    assert!(counts[CandidateC::NotAMinimum as usize] > n / 100);
    assert!(counts[CandidateC::Beaten as usize] > 0);
    for (k, example) in examples.iter().enumerate() {
        let Some(c) = example else { continue };
        let Ok(Verdict::Recommended(r)) = planar::solve(c, &Settings::default()) else {
            unreachable!("solved above")
        };
        let reference = Reference::new(c, 1.0, RefObjective::Norm2);
        let (w, p) = reference.minimise(RefRange::FromAbove, c.gravity, 20_000);
        assert!(
            wrap(r.wrist_rotation - w).abs() < 1e-7,
            "status {k}: solver and reference disagree"
        );
        assert_abs_diff_eq!(r.gripping_power, p, epsilon = 1e-9 * p);
        println!(
            "status {k}: recommended θ = {:.6} ({:?}), P = {:.6} N, reference P = {p:.6} N",
            r.gravity_angle,
            r.recommended_label.map(|l| l.name()),
            r.gripping_power
        );
    }
}

/// One explicit grasp of each kind of failure of Theorem 1, what the paper would pick, and what
/// the solver picks instead.
#[test]
fn named_counterexamples_to_theorem_1() {
    // Kind 1: gripping power passes through θ_34 without a minimum.
    // Kind 2: θ_34 is a local minimum but an end of the from-above range is lower.
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut seen = [false; 2];
    for _ in 0..5000 {
        let c = random_grasp(&mut rng);
        let Ok(Verdict::Recommended(r)) = planar::solve(&c, &Settings::default()) else {
            panic!("valid grasp refused")
        };
        let kind = match r.candidate_c {
            CandidateC::NotAMinimum => 0,
            CandidateC::Beaten => 1,
            _ => continue,
        };
        if seen[kind] {
            continue;
        }
        seen[kind] = true;
        let analysis = analysis(&c);
        let theta_34 = analysis.candidate_angles().theta_34;
        let at_c = analysis.evaluate(theta_34).power;
        // The paper's pick is worse than the solver's.
        assert!(at_c > r.gripping_power, "C must cost more than the optimum");
        if kind == 0 {
            // Not a minimum: a nearby point on one side is lower.
            let h = 1e-6;
            let lower = analysis
                .evaluate(theta_34 - h)
                .power
                .min(analysis.evaluate(theta_34 + h).power);
            assert!(lower < at_c, "θ_34 must not be a local minimum");
            assert!(r
                .local_minima
                .iter()
                .all(|m| m.label != Some(PaperCandidate::C)));
        } else {
            assert!(r
                .local_minima
                .iter()
                .any(|m| m.label == Some(PaperCandidate::C)));
        }
        println!(
            "kind {kind}: {c:?}\n  θ_34 = {theta_34:.6} costs {at_c:.6} N; the solver picks θ = {:.6} \
             ({:?}) at {:.6} N",
            r.gravity_angle,
            r.recommended_label.map(|l| l.name()),
            r.gripping_power
        );
    }
    assert!(
        seen[0] && seen[1],
        "both kinds of counterexample must occur"
    );
}

/// Local minima of the 2-norm over the graspable range for the four case studies, against the
/// reference. Theorem 1 lists, per case of Fig. 7, (a) A, C, E; (b) B, C, E; (c) A, C, D;
/// (d) B, C, D. Study (d) is Theorem 1's case (d) (neither cone holds the centre of mass), yet
/// its gripping power has minima at A, C and E, not at B or D: θ_36 = -1.006 and θ_45 = 2.742 lie
/// in the graspable range but the power has no minimum there. (The paper's own remark on study
/// (d), "θ_34 and θ_45 are minimal points", does not hold for the gripping power.)
#[test]
fn local_minima_of_the_case_studies() {
    let settings = Settings {
        range: grasp_orient::solver::AllowedRange::Graspable,
        ..Settings::default()
    };
    let expected: [(char, &[&str]); 4] = [
        ('a', &["A", "C", "E"]),
        ('b', &["A", "C", "E"]),
        ('c', &["B", "C", "E"]),
        ('d', &["A", "C", "E"]),
    ];
    for (case, labels) in expected {
        let c = table_1(case);
        let Ok(Verdict::Recommended(r)) = planar::solve(&c, &settings) else {
            panic!("({case}) must be solvable")
        };
        let reference = Reference::new(&c, 1.0, RefObjective::Norm2);
        let want = reference.local_minima(RefRange::Graspable, c.gravity, 20_000);
        let got: Vec<f64> = r.local_minima.iter().map(|m| m.gravity_angle).collect();
        // Current gravity is (0, -1), so θ = -ω.
        let want_theta: Vec<f64> = want.iter().map(|(w, _)| -w).collect();
        assert_eq!(
            got.len(),
            want_theta.len(),
            "({case}) {got:?} vs {want_theta:?}"
        );
        for g in &got {
            assert!(
                want_theta.iter().any(|w| wrap(g - w).abs() < 1e-7),
                "({case}) minimum {g} not among the reference's {want_theta:?}"
            );
        }
        let names: Vec<&str> = r
            .local_minima
            .iter()
            .map(|m| m.label.map_or("", |l| l.name()))
            .collect();
        assert_eq!(names, labels, "({case})");
    }
}
