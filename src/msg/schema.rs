//! Recordings made before a message grew: which fields a recorded type has, whether they are a
//! prefix of ours, and decoding of the shorter CDR with the missing trailing fields at their
//! defaults.
//!
//! Message contracts grow only by trailing fields whose zero default keeps the old meaning (0.0,
//! empty, false). A recording keeps, in each channel's `ros2msg` schema, the complete definition
//! its writer had: the top-level `.msg` text, then each dependency after a line of 80 `=` and
//! `MSG: <type>` ([`super::definitions`]). This module reads that text into a [`Layout`] (the
//! field list of every type, comments and constants left out), compares it with the layout of our
//! own definition, type by type, and
//! - when they are the same, the CDR decodes as it is (the fast path);
//! - when every recorded type's fields are a prefix of ours (same names, same types), the CDR is
//!   rewritten into ours ([`RecordedType::upgrade`]): the recorded fields copied value by value,
//!   re-aligned, and each missing trailing field written as its default. This works at any depth,
//!   so a `GripRecommendationSet` recorded before `GripRecommendation` grew decodes too, although
//!   its short recommendations sit in the middle of the payload;
//! - otherwise the channel is incompatible ([`Incompatible`] names the type and the first field
//!   that differs).
//!
//! CDR here is plain (XCDR1) CDR as ROS 2 writes it: primitives aligned to their size (8 at most)
//! from the start of the payload after the 4-byte encapsulation header, strings as a `u32` length
//! that counts the terminating NUL, sequences as a `u32` count, fixed arrays as their elements,
//! nested messages as their fields in order with no alignment of their own.

use super::cdr::CdrError;
use super::definitions::{full_text, split_type_name};
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};

/// A primitive type of a `.msg` file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Primitive {
    /// `bool`, `byte`, `char`, `int8`, `uint8`: one byte.
    One,
    /// `int16`, `uint16`.
    Two,
    /// `int32`, `uint32`, `float32`.
    Four,
    /// `int64`, `uint64`, `float64`.
    Eight,
    /// `string` (bounded or not).
    String,
}

impl Primitive {
    fn of(name: &str) -> Option<Self> {
        let base = name.split("<=").next().unwrap_or(name);
        Some(match base {
            "bool" | "byte" | "char" | "int8" | "uint8" => Primitive::One,
            "int16" | "uint16" => Primitive::Two,
            "int32" | "uint32" | "float32" => Primitive::Four,
            "int64" | "uint64" | "float64" => Primitive::Eight,
            "string" => Primitive::String,
            _ => return None,
        })
    }
}

/// The element type of a field.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Element {
    Primitive(Primitive),
    /// A message, by its `pkg/Name`.
    Message(String),
}

/// Whether and how a field repeats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Repeat {
    Single,
    /// `T[N]`.
    Fixed(usize),
    /// `T[]` and `T[<=N]`: a `u32` count, then the elements.
    Sequence,
}

/// One field of a message: its name, its type as written (package made explicit) and how it is
/// laid out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Field {
    /// The field name.
    pub(crate) name: String,
    /// The type as the `.msg` writes it, with `pkg/` in front of a message type written without
    /// one, and `pkg/msg/Name` as `pkg/Name`.
    pub(crate) type_name: String,
    element: Element,
    repeat: Repeat,
}

/// The field lists of a type and of every type it uses, by `pkg/Name`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct Layout {
    /// `pkg/Name` of the type the definition is for.
    pub(crate) root: String,
    /// Fields of each type, in order.
    pub(crate) types: BTreeMap<String, Vec<Field>>,
}

/// A definition this module cannot read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SchemaError {
    /// A type name is not `pkg/Name` or `pkg/msg/Name`.
    #[error("{0:?} is not a message type name")]
    TypeName(String),
    /// A line is not a field, a constant or a comment.
    #[error("{type_name}: cannot read the line {line:?}")]
    Line {
        /// The type whose text holds it.
        type_name: String,
        /// The line.
        line: String,
    },
    /// A dependency section does not start with `MSG: <type>`.
    #[error("a dependency section starts with {0:?}, not \"MSG: <type>\"")]
    Section(String),
    /// `wstring` (its width differs between writers; no grasp_orient type uses it).
    #[error("{0}: wstring fields are not read")]
    WideString(String),
}

/// Why a recorded type cannot be read as ours.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Incompatible {
    /// The schema text does not parse.
    #[error("its schema cannot be read: {0}")]
    Schema(#[from] SchemaError),
    /// A recorded field differs from ours at the same place.
    #[error(
        "{type_name} differs from ours at field {index}: recorded {recorded}, ours {ours}; only \
         trailing fields may be added"
    )]
    Field {
        /// The type.
        type_name: String,
        /// Position of the field, from 0.
        index: usize,
        /// The recorded field, `type name`.
        recorded: String,
        /// Ours at that place, `type name` (or "nothing" when the recording has more fields).
        ours: String,
    },
    /// The schema uses a type without giving its definition.
    #[error("its schema does not define {0}")]
    Missing(String),
}

/// `pkg/Name` of a type as written in a text of package `package`.
fn qualified(name: &str, package: &str) -> Result<String, SchemaError> {
    if name.contains('/') {
        let (p, n) = split_type_name(name).ok_or_else(|| SchemaError::TypeName(name.into()))?;
        Ok(format!("{p}/{n}"))
    } else {
        Ok(format!("{package}/{name}"))
    }
}

/// The fields of one `.msg` text of package `package`, comments and constants left out.
fn parse_fields(text: &str, type_name: &str, package: &str) -> Result<Vec<Field>, SchemaError> {
    let mut fields = Vec::new();
    for raw in text.lines() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let bad = || SchemaError::Line {
            type_name: type_name.to_string(),
            line: raw.to_string(),
        };
        let (ty, rest) = line.split_once(char::is_whitespace).ok_or_else(bad)?;
        let rest = rest.trim_start();
        let name_end = rest
            .find(|c: char| c.is_whitespace() || c == '=')
            .unwrap_or(rest.len());
        if rest[name_end..].trim_start().starts_with('=') {
            continue; // a constant
        }
        let name = &rest[..name_end];
        if name.is_empty() {
            return Err(bad());
        }
        let (base, repeat) = match ty.split_once('[') {
            None => (ty, Repeat::Single),
            Some((base, bracket)) => {
                let inner = bracket.strip_suffix(']').ok_or_else(bad)?;
                let repeat = if inner.is_empty() || inner.starts_with("<=") {
                    Repeat::Sequence
                } else {
                    Repeat::Fixed(inner.parse().map_err(|_| bad())?)
                };
                (base, repeat)
            }
        };
        if base.split("<=").next() == Some("wstring") {
            return Err(SchemaError::WideString(type_name.to_string()));
        }
        let (element, written) = match Primitive::of(base) {
            Some(p) => (Element::Primitive(p), base.to_string()),
            None => {
                let full = qualified(base, package)?;
                (Element::Message(full.clone()), full)
            }
        };
        let suffix = &ty[base.len()..];
        fields.push(Field {
            name: name.to_string(),
            type_name: format!("{written}{suffix}"),
            element,
            repeat,
        });
    }
    Ok(fields)
}

/// The separator line before each dependency.
const SEPARATOR: &str =
    "================================================================================";

impl Layout {
    /// Reads a complete `ros2msg` definition of `root` (`pkg/Name` or `pkg/msg/Name`).
    pub(crate) fn parse(text: &str, root: &str) -> Result<Self, SchemaError> {
        let root = qualified(root, "")?;
        let (root_package, _) =
            split_type_name(&root).ok_or_else(|| SchemaError::TypeName(root.clone()))?;
        let mut sections = Vec::new();
        let mut current = (root.clone(), String::new());
        let mut lines = text.lines();
        while let Some(line) = lines.next() {
            if line == SEPARATOR {
                let head = lines.next().unwrap_or("");
                let name = head
                    .strip_prefix("MSG: ")
                    .ok_or_else(|| SchemaError::Section(head.to_string()))?;
                let name = qualified(name.trim(), root_package)?;
                sections.push(std::mem::replace(&mut current, (name, String::new())));
            } else {
                current.1.push_str(line);
                current.1.push('\n');
            }
        }
        sections.push(current);
        let mut types = BTreeMap::new();
        for (name, body) in sections {
            let (package, _) =
                split_type_name(&name).ok_or_else(|| SchemaError::TypeName(name.clone()))?;
            let fields = parse_fields(&body, &name, package)?;
            types.entry(name).or_insert(fields);
        }
        Ok(Self { root, types })
    }

    /// The fields of `type_name` (`pkg/Name`), if the definition has it.
    pub(crate) fn fields(&self, type_name: &str) -> Option<&[Field]> {
        self.types.get(type_name).map(Vec::as_slice)
    }
}

/// The layout of our own definition of `type_name`, parsed once.
fn ours(type_name: &str) -> Option<Arc<Layout>> {
    static CACHE: OnceLock<Mutex<BTreeMap<String, Arc<Layout>>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let mut cache = cache.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(layout) = cache.get(type_name) {
        return Some(layout.clone());
    }
    let layout = Arc::new(Layout::parse(&full_text(type_name)?, type_name).ok()?);
    cache.insert(type_name.to_string(), layout.clone());
    Some(layout)
}

/// A type as a recording has it, next to ours.
#[derive(Debug, Clone)]
pub(crate) struct RecordedType {
    recorded: Layout,
    ours: Arc<Layout>,
    /// Whether every type has all our fields (then CDR decodes as it is).
    same: bool,
}

impl RecordedType {
    /// Compares the recorded definition `text` of `type_name` with ours. `type_name` must be one
    /// of [`super::definitions::DEFINITIONS`].
    pub(crate) fn new(text: &str, type_name: &str) -> Result<Self, Incompatible> {
        let root = qualified(type_name, "")?;
        let ours = ours(&root).ok_or_else(|| Incompatible::Missing(root.clone()))?;
        let recorded = Layout::parse(text, &root)?;
        let mut same = true;
        check(&recorded, &ours, &root, &mut same)?;
        Ok(Self {
            recorded,
            ours,
            same,
        })
    }

    /// The recorded type when it is exactly ours (no field missing anywhere).
    pub(crate) fn is_ours(&self) -> bool {
        self.same
    }

    #[cfg(test)]
    /// Whether the recording has field `field` of type `type_name` (`pkg/Name`); true for a type
    /// it does not use.
    pub(crate) fn has_field(&self, type_name: &str, field: &str) -> bool {
        self.recorded
            .fields(type_name)
            .is_none_or(|fields| fields.iter().any(|f| f.name == field))
    }

    /// How many fields of `type_name` (`pkg/Name`) the recording has; `None` for a type it does
    /// not use.
    pub(crate) fn field_count(&self, type_name: &str) -> Option<usize> {
        self.recorded.fields(type_name).map(<[Field]>::len)
    }

    /// Decodes encapsulated CDR of the recorded type as ours, with the missing trailing fields at
    /// their defaults.
    pub(crate) fn decode<T: DeserializeOwned>(&self, bytes: &[u8]) -> Result<T, CdrError> {
        if self.same {
            super::cdr::decode(bytes)
        } else {
            super::cdr::decode(&self.upgrade(bytes)?)
        }
    }

    /// Rewrites encapsulated CDR of the recorded type into CDR of ours.
    pub(crate) fn upgrade(&self, bytes: &[u8]) -> Result<Vec<u8>, CdrError> {
        let (header, payload) = bytes
            .split_at_checked(4)
            .ok_or_else(|| CdrError::Encapsulation(bytes.to_vec()))?;
        let little = match header[..2] {
            [0x00, 0x01] => true,
            [0x00, 0x00] => false,
            _ => return Err(CdrError::Encapsulation(header.to_vec())),
        };
        let mut out = Vec::with_capacity(bytes.len() + 64);
        out.extend_from_slice(header);
        let mut copy = Copy {
            from: payload,
            at: 0,
            little,
            out,
            layouts: (&self.recorded, &self.ours),
        };
        copy.message(&self.recorded.root)?;
        Ok(copy.out)
    }
}

/// Checks that every type reachable from `type_name` has, in `recorded`, a prefix of its fields in
/// `ours`; clears `same` when any is shorter.
fn check(
    recorded: &Layout,
    ours: &Layout,
    type_name: &str,
    same: &mut bool,
) -> Result<(), Incompatible> {
    let mut pending = vec![type_name.to_string()];
    let mut done = std::collections::BTreeSet::new();
    while let Some(name) = pending.pop() {
        if !done.insert(name.clone()) {
            continue;
        }
        let theirs = recorded
            .fields(&name)
            .ok_or_else(|| Incompatible::Missing(name.clone()))?;
        let mine = ours
            .fields(&name)
            .ok_or_else(|| Incompatible::Missing(name.clone()))?;
        for (index, field) in theirs.iter().enumerate() {
            let differs = mine
                .get(index)
                .is_none_or(|m| m.name != field.name || m.type_name != field.type_name);
            if differs {
                return Err(Incompatible::Field {
                    type_name: name,
                    index,
                    recorded: format!("{} {}", field.type_name, field.name),
                    ours: mine.get(index).map_or("nothing".to_string(), |m| {
                        format!("{} {}", m.type_name, m.name)
                    }),
                });
            }
            if let Element::Message(inner) = &field.element {
                pending.push(inner.clone());
            }
        }
        if theirs.len() < mine.len() {
            *same = false;
        }
    }
    Ok(())
}

/// Copies recorded CDR into our layout.
struct Copy<'a> {
    from: &'a [u8],
    at: usize,
    little: bool,
    out: Vec<u8>,
    /// (recorded, ours)
    layouts: (&'a Layout, &'a Layout),
}

fn short(what: &str) -> CdrError {
    CdrError::Payload(format!("the recorded message ends inside {what}"))
}

impl Copy<'_> {
    fn align_in(&mut self, n: usize) {
        self.at = self.at.div_ceil(n) * n;
    }

    fn align_out(&mut self, n: usize) {
        let len = self.out.len() - 4;
        self.out.resize(4 + len.div_ceil(n) * n, 0);
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&[u8], CdrError> {
        let end = self.at.checked_add(n).ok_or_else(|| short(what))?;
        let bytes = self.from.get(self.at..end).ok_or_else(|| short(what))?;
        self.at = end;
        Ok(bytes)
    }

    fn count(&mut self, what: &str) -> Result<u32, CdrError> {
        self.align_in(4);
        let b: [u8; 4] = self.take(4, what)?.try_into().map_err(|_| short(what))?;
        let n = if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        };
        self.write_count(n);
        Ok(n)
    }

    fn write_count(&mut self, n: u32) {
        self.align_out(4);
        let b = if self.little {
            n.to_le_bytes()
        } else {
            n.to_be_bytes()
        };
        self.out.extend_from_slice(&b);
    }

    /// Copies one recorded message of type `name`, then writes our trailing fields as defaults.
    fn message(&mut self, name: &str) -> Result<(), CdrError> {
        let (recorded, ours) = self.layouts;
        let missing = || CdrError::Payload(format!("no definition of {name}"));
        let theirs = recorded.fields(name).ok_or_else(missing)?;
        let mine = ours.fields(name).ok_or_else(missing)?;
        for field in theirs {
            self.field(field, true)?;
        }
        for field in &mine[theirs.len()..] {
            self.field(field, false)?;
        }
        Ok(())
    }

    /// Copies one field (`recorded`), or writes its default.
    fn field(&mut self, field: &Field, recorded: bool) -> Result<(), CdrError> {
        match field.repeat {
            Repeat::Single => self.element(&field.element, recorded, &field.name),
            Repeat::Fixed(n) => {
                for _ in 0..n {
                    self.element(&field.element, recorded, &field.name)?;
                }
                Ok(())
            }
            Repeat::Sequence => {
                let n = if recorded {
                    self.count(&field.name)?
                } else {
                    self.write_count(0);
                    0
                };
                for _ in 0..n {
                    self.element(&field.element, true, &field.name)?;
                }
                Ok(())
            }
        }
    }

    fn element(&mut self, element: &Element, recorded: bool, what: &str) -> Result<(), CdrError> {
        match element {
            Element::Message(name) if recorded => self.message(name),
            Element::Message(name) => self.default_message(name),
            Element::Primitive(Primitive::String) => {
                if recorded {
                    let n = self.count(what)?;
                    let bytes = self.take(n as usize, what)?.to_vec();
                    self.out.extend_from_slice(&bytes);
                } else {
                    self.write_count(1);
                    self.out.push(0);
                }
                Ok(())
            }
            Element::Primitive(p) => {
                let size = match p {
                    Primitive::One => 1,
                    Primitive::Two => 2,
                    Primitive::Four => 4,
                    Primitive::Eight | Primitive::String => 8,
                };
                self.align_out(size);
                if recorded {
                    self.align_in(size);
                    let bytes = self.take(size, what)?.to_vec();
                    self.out.extend_from_slice(&bytes);
                } else {
                    self.out.resize(self.out.len() + size, 0);
                }
                Ok(())
            }
        }
    }

    /// Writes a message of ours, every field at its default.
    fn default_message(&mut self, name: &str) -> Result<(), CdrError> {
        let ours = self.layouts.1;
        let fields = ours
            .fields(name)
            .ok_or_else(|| CdrError::Payload(format!("no definition of {name}")))?;
        for field in fields {
            self.field(field, false)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::answer::{answer_set, Rules};
    use crate::msg::{
        cdr, paper_cases, GraspCandidate, GraspCandidateSet, GripRecommendation,
        GripRecommendationSet, RosMessage, Vector3,
    };
    use crate::solver::Settings;
    use serde::Serialize;

    /// `GripRecommendation` as it was before the grip-force fields, field for field.
    #[derive(Debug, Clone, Serialize)]
    struct OldRecommendation {
        header: crate::msg::Header,
        candidate_id: crate::msg::CompactString,
        status: u8,
        message: crate::msg::CompactString,
        wrist_rotation: f64,
        rotation: crate::msg::Quaternion,
        gravity_direction: crate::msg::Vector3,
        gravity_angle: f64,
        gripping_power: f64,
        internal_force: f64,
        contact_forces: [f64; 4],
        gripping_power_current: f64,
        internal_force_current: f64,
        grasp_case: crate::msg::CompactString,
        local_minima: Vec<f64>,
        local_minima_power: Vec<f64>,
        local_minima_labels: Vec<crate::msg::CompactString>,
        objective: crate::msg::CompactString,
        recommended_label: crate::msg::CompactString,
        candidate_c: u8,
    }

    impl From<&GripRecommendation> for OldRecommendation {
        fn from(r: &GripRecommendation) -> Self {
            Self {
                header: r.header.clone(),
                candidate_id: r.candidate_id.clone(),
                status: r.status,
                message: r.message.clone(),
                wrist_rotation: r.wrist_rotation,
                rotation: r.rotation.clone(),
                gravity_direction: r.gravity_direction.clone(),
                gravity_angle: r.gravity_angle,
                gripping_power: r.gripping_power,
                internal_force: r.internal_force,
                contact_forces: r.contact_forces,
                gripping_power_current: r.gripping_power_current,
                internal_force_current: r.internal_force_current,
                grasp_case: r.grasp_case.clone(),
                local_minima: r.local_minima.clone(),
                local_minima_power: r.local_minima_power.clone(),
                local_minima_labels: r.local_minima_labels.clone(),
                objective: r.objective.clone(),
                recommended_label: r.recommended_label.clone(),
                candidate_c: r.candidate_c,
            }
        }
    }

    /// An older set, whose recommendations are the older ones and which has no status yet.
    #[derive(Debug, Clone, Serialize)]
    struct OldSet {
        header: crate::msg::Header,
        set_id: crate::msg::CompactString,
        recommendations: Vec<OldRecommendation>,
        ranking: Vec<u32>,
        ranked_by: crate::msg::CompactString,
    }

    /// Our schema text of `type_name` with, for each `(section, last)` of `cuts`, the lines after
    /// field `last` of that section's type taken out: a synthetic older definition.
    fn older_text(type_name: &str, cuts: &[(&str, &str)]) -> String {
        let text = full_text(type_name).expect("ours");
        let mut out = String::new();
        let mut section = split_type_name(type_name).map(|(p, n)| format!("{p}/{n}"));
        let mut dropping = false;
        for line in text.lines() {
            if line == SEPARATOR {
                dropping = false;
            }
            if let Some(name) = line.strip_prefix("MSG: ") {
                section = Some(name.to_string());
            }
            if !dropping {
                out.push_str(line);
                out.push('\n');
            }
            let field = line
                .split('#')
                .next()
                .unwrap_or("")
                .split_whitespace()
                .nth(1);
            if cuts
                .iter()
                .any(|(of, last)| section.as_deref() == Some(*of) && field == Some(*last))
            {
                dropping = true;
            }
        }
        out
    }

    fn old_recommendation_text() -> String {
        older_text(
            GripRecommendation::TYPE_NAME,
            &[("grasp_orient/GripRecommendation", "candidate_c")],
        )
    }

    #[test]
    fn our_own_definitions_are_ours_and_decode_as_they_are() {
        for (name, _) in super::super::definitions::DEFINITIONS {
            let t = RecordedType::new(&full_text(name).expect("known"), name).expect("ours");
            assert!(t.is_ours(), "{name}");
        }
    }

    #[test]
    fn fields_comments_constants_and_arrays_are_read() {
        let layout = Layout::parse(
            &full_text(GripRecommendation::TYPE_NAME).expect("ours"),
            GripRecommendation::TYPE_NAME,
        )
        .expect("parses");
        let fields = layout
            .fields("grasp_orient/GripRecommendation")
            .expect("root");
        let names: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
        let rust: Vec<&str> = GripRecommendation::fields()
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        assert_eq!(names, rust);
        let types: Vec<&str> = fields.iter().map(|f| f.type_name.as_str()).collect();
        assert_eq!(types[0], "std_msgs/Header");
        assert_eq!(types[10], "float64[4]");
        assert_eq!(types[16], "string[]");
        assert!(layout.fields("builtin_interfaces/Time").is_some());
    }

    /// A recording made before `finger_force`, `finger_force_current` (and `rotation_axis`):
    /// decoded with them at 0,
    /// every other field as recorded; the recording is said not to have them.
    #[test]
    fn an_older_recommendation_decodes_with_its_trailing_fields_at_zero() {
        let settings = Settings::default();
        for c in paper_cases() {
            let now = crate::answer::answer(&c, &settings);
            let bytes = cdr::encode(&OldRecommendation::from(&now)).expect("encodes");
            assert!(
                cdr::decode::<GripRecommendation>(&bytes).is_err(),
                "without the schema the short payload does not decode"
            );
            let t = RecordedType::new(&old_recommendation_text(), GripRecommendation::TYPE_NAME)
                .expect("a prefix of ours");
            assert!(!t.is_ours());
            assert!(!t.has_field("grasp_orient/GripRecommendation", "finger_force"));
            assert!(t.has_field("grasp_orient/GripRecommendation", "candidate_c"));
            let got: GripRecommendation = t.decode(&bytes).expect("decodes");
            let want = GripRecommendation {
                finger_force: 0.0,
                finger_force_current: 0.0,
                rotation_axis: Vector3::default(),
                gripping_power_nominal: 0.0,
                ..now.clone()
            };
            assert_eq!(format!("{got:?}"), format!("{want:?}"));
        }
    }

    /// `GraspCandidate` as it was before spatial candidates (no `model`), field for field.
    #[derive(Debug, Clone, Serialize)]
    struct OldCandidate {
        header: crate::msg::Header,
        id: crate::msg::CompactString,
        contact_1: crate::msg::Point,
        contact_2: crate::msg::Point,
        normal_1: crate::msg::Vector3,
        normal_2: crate::msg::Vector3,
        friction_1: f64,
        friction_2: f64,
        center_of_mass: crate::msg::Point,
        mass: f64,
        gravity: crate::msg::Vector3,
    }

    impl From<&GraspCandidate> for OldCandidate {
        fn from(c: &GraspCandidate) -> Self {
            Self {
                header: c.header.clone(),
                id: c.id.clone(),
                contact_1: c.contact_1.clone(),
                contact_2: c.contact_2.clone(),
                normal_1: c.normal_1.clone(),
                normal_2: c.normal_2.clone(),
                friction_1: c.friction_1,
                friction_2: c.friction_2,
                center_of_mass: c.center_of_mass.clone(),
                mass: c.mass,
                gravity: c.gravity.clone(),
            }
        }
    }

    /// Candidates recorded before `model` existed decode as planar ones (`model` 0),
    /// alone and inside a set recorded then, where each candidate is one byte shorter.
    #[test]
    fn an_older_candidate_decodes_as_a_planar_one() {
        let cases = paper_cases();
        let cut = [("grasp_orient/GraspCandidate", "gravity")];
        let t = RecordedType::new(
            &older_text(GraspCandidate::TYPE_NAME, &cut),
            GraspCandidate::TYPE_NAME,
        )
        .expect("a prefix of ours");
        assert!(!t.is_ours() && !t.has_field("grasp_orient/GraspCandidate", "model"));
        for c in &cases {
            let spatial = GraspCandidate {
                model: GraspCandidate::MODEL_SPATIAL,
                center_of_mass_tolerance: crate::msg::Vector3 {
                    x: 0.5,
                    y: 0.25,
                    z: 0.125,
                },
                mass_tolerance: 0.5,
                ..c.clone()
            };
            let bytes = cdr::encode(&OldCandidate::from(&spatial)).expect("encodes");
            let got: GraspCandidate = t.decode(&bytes).expect("decodes");
            assert_eq!(got, *c);
            assert_eq!(got.model, GraspCandidate::MODEL_PLANAR);
        }
        #[derive(Serialize)]
        struct OldSet {
            header: crate::msg::Header,
            id: crate::msg::CompactString,
            candidates: Vec<OldCandidate>,
            max_grip_force: f64,
        }
        let old = OldSet {
            header: crate::msg::Header::default(),
            id: "old set".into(),
            candidates: cases.iter().map(OldCandidate::from).collect(),
            max_grip_force: 12.5,
        };
        let t = RecordedType::new(
            &older_text(GraspCandidateSet::TYPE_NAME, &cut),
            GraspCandidateSet::TYPE_NAME,
        )
        .expect("a prefix of ours");
        let got: GraspCandidateSet = t
            .decode(&cdr::encode(&old).expect("encodes"))
            .expect("decodes");
        assert_eq!(got.candidates, cases);
        assert_eq!((got.id.as_str(), got.max_grip_force), ("old set", 12.5));
    }

    /// Nested: a set whose recommendations are the older ones, and which itself lacks the status
    /// and message: everything re-aligned, the defaults in the middle of the payload.
    #[test]
    fn an_older_set_decodes_with_defaults_inside_and_at_the_end() {
        let mut cases = paper_cases();
        cases[1].mass = f64::NAN;
        let set = GraspCandidateSet {
            id: "old".into(),
            candidates: cases,
            ..GraspCandidateSet::default()
        };
        let now = answer_set(&set, &Settings::default(), &Rules::default());
        let old = OldSet {
            header: now.header.clone(),
            set_id: now.set_id.clone(),
            recommendations: now
                .recommendations
                .iter()
                .map(OldRecommendation::from)
                .collect(),
            ranking: now.ranking.clone(),
            ranked_by: now.ranked_by.clone(),
        };
        let text = older_text(
            GripRecommendationSet::TYPE_NAME,
            &[
                ("grasp_orient/GripRecommendationSet", "ranked_by"),
                ("grasp_orient/GripRecommendation", "candidate_c"),
            ],
        );
        let t = RecordedType::new(&text, GripRecommendationSet::TYPE_NAME).expect("a prefix");
        assert!(!t.has_field("grasp_orient/GripRecommendation", "finger_force"));
        assert!(!t.has_field("grasp_orient/GripRecommendationSet", "status"));
        let bytes = cdr::encode(&old).expect("encodes");
        let got: GripRecommendationSet = t.decode(&bytes).expect("decodes");
        let mut want = now.clone();
        for r in &mut want.recommendations {
            r.finger_force = 0.0;
            r.finger_force_current = 0.0;
            r.rotation_axis = Vector3::default();
            r.gripping_power_nominal = 0.0;
        }
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
        // Big-endian CDR too.
        let mut big = vec![0, 0, 0, 0];
        cdr_encoding::to_writer::<_, byteorder::BigEndian, _>(&mut big, &old).expect("encodes");
        let got: GripRecommendationSet = t.decode(&big).expect("decodes big-endian");
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
        // A payload cut short is an error, not a panic.
        assert!(t
            .decode::<GripRecommendationSet>(&bytes[..bytes.len() / 2])
            .is_err());
    }

    #[test]
    fn a_changed_field_is_incompatible_naming_it() {
        let ours = full_text(GripRecommendation::TYPE_NAME).expect("ours");
        let changed = ours.replacen("float64 gravity_angle ", "float32 gravity_angle ", 1);
        let e = RecordedType::new(&changed, GripRecommendation::TYPE_NAME).expect_err("changed");
        assert_eq!(
            e.to_string(),
            "grasp_orient/GripRecommendation differs from ours at field 7: recorded float32 \
             gravity_angle, ours float64 gravity_angle; only trailing fields may be added"
        );
        let renamed = ours.replacen("string candidate_id ", "string id ", 1);
        let e = RecordedType::new(&renamed, GripRecommendation::TYPE_NAME).expect_err("renamed");
        assert!(e.to_string().contains("field 1: recorded string id"), "{e}");
        let longer = ours.replacen(
            "uint8 candidate_c ",
            "uint8 candidate_c\nfloat64 from_the_future\n#",
            1,
        );
        let e = RecordedType::new(&longer, GripRecommendation::TYPE_NAME).expect_err("newer");
        assert!(
            e.to_string().contains("ours nothing") || e.to_string().contains("from_the_future"),
            "{e}"
        );
        let no_deps = ours.split(SEPARATOR).next().expect("root").to_string();
        let e = RecordedType::new(&no_deps, GripRecommendation::TYPE_NAME).expect_err("missing");
        assert!(matches!(e, Incompatible::Missing(_)), "{e}");
    }

    /// Older schema texts named dependencies `pkg/msg/Name` and left comments out: same layout.
    #[test]
    fn the_form_of_the_text_does_not_matter() {
        let ours = full_text(GripRecommendation::TYPE_NAME).expect("ours");
        let other: String = ours
            .lines()
            .map(|l| {
                let l = l.replace("MSG: std_msgs/Header", "MSG: std_msgs/msg/Header");
                let code = l.split('#').next().unwrap_or("").trim_end().to_string();
                code + "\n"
            })
            .collect();
        let t = RecordedType::new(&other, "grasp_orient/msg/GripRecommendation").expect("same");
        assert!(t.is_ours());
    }
}
