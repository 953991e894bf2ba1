//! The Rust wire structs cannot drift from `msg/*.msg`: same fields, same order, same types, same
//! constants.

use grasp_orient::msg::{GraspCandidate, GripRecommendation, RosMessage};
use std::collections::BTreeSet;

struct Parsed {
    fields: Vec<(String, String)>,
    constants: BTreeSet<(String, String, String)>,
}

fn parse(file: &str) -> Parsed {
    let path = format!("{}/msg/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut fields = Vec::new();
    let mut constants = BTreeSet::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (ty, rest) = line.split_once(char::is_whitespace).expect("type and name");
        let rest = rest.trim();
        if let Some((name, value)) = rest.split_once('=') {
            constants.insert((
                name.trim().to_string(),
                ty.to_string(),
                value.trim().to_string(),
            ));
        } else {
            fields.push((rest.to_string(), ty.to_string()));
        }
    }
    Parsed { fields, constants }
}

fn check<M: RosMessage>(file: &str) {
    let parsed = parse(file);
    let rust: Vec<(String, String)> = M::fields()
        .into_iter()
        .map(|(n, t)| (n.to_string(), t))
        .collect();
    assert_eq!(
        rust, parsed.fields,
        "{file}: fields differ from the Rust struct"
    );
    let consts: BTreeSet<(String, String, String)> = M::constants()
        .into_iter()
        .map(|(n, t, v)| (n.to_string(), t, v))
        .collect();
    assert_eq!(consts, parsed.constants, "{file}: constants differ");
    assert!(
        M::TYPE_NAME.ends_with(file.trim_end_matches(".msg")),
        "{}",
        M::TYPE_NAME
    );
}

#[test]
fn grasp_candidate_matches_its_msg_file() {
    check::<GraspCandidate>("GraspCandidate.msg");
}

#[test]
fn grip_recommendation_matches_its_msg_file() {
    check::<GripRecommendation>("GripRecommendation.msg");
}

/// The contract in the issue fixes the first fields of GripRecommendation; extra fields may only
/// come after them.
#[test]
fn contract_fields_come_first_and_in_order() {
    let contract = [
        "header",
        "candidate_id",
        "status",
        "message",
        "wrist_rotation",
        "rotation",
        "gravity_direction",
        "gravity_angle",
        "gripping_power",
        "internal_force",
        "contact_forces",
        "gripping_power_current",
        "internal_force_current",
        "grasp_case",
        "local_minima",
        "local_minima_power",
        "local_minima_labels",
    ];
    let fields: Vec<&str> = GripRecommendation::fields()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    assert_eq!(&fields[..contract.len()], &contract);
}
