//! What each channel of a recording carries, decided once per channel: which of our types (by
//! schema name, never by schema text), and, from the schema text, which fields the recording's
//! version of the type has ([`crate::msg::schema`]). Recordings made before a message grew decode
//! with the missing trailing fields at their defaults, and [`RecordedFields`] remembers which
//! fields were recorded, so that `replay` compares only those.

use super::scan::{Channel, KnownSchema, Table};
use crate::kind;
use crate::msg::definitions::split_type_name;
use crate::msg::schema::RecordedType;
use crate::msg::{
    cdr, GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet,
    PoseRecommendation, RosMessage,
};
use serde::de::DeserializeOwned;
use std::collections::hash_map::Entry;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// Which of our channels (a kind's requests or answers, [`crate::kind`]) a recording's channel
/// carries, with the type's name as this crate knows it; `None` for anything else.
fn carried(
    channel: &Channel,
    schema: Option<&KnownSchema>,
) -> Option<(kind::Channel, &'static str)> {
    let schema = schema?;
    if channel.message_encoding != "cdr" {
        return None;
    }
    let (package, name) = split_type_name(&schema.name)?;
    let ours = kind::Channel::of_type(package, name)?;
    let (_, type_name, _) = kind::Channel::all()[ours.slot()];
    Some((ours, type_name))
}

/// How one channel decodes.
#[derive(Debug, Clone)]
pub(crate) struct ChannelReader {
    /// Which of our channels it carries; `None`: not one of ours.
    pub(crate) carried: Option<kind::Channel>,
    /// The recorded version of its type when it differs from ours; `None` decodes as it is (our
    /// own version, or a schema in a form this crate does not read, e.g. `ros2idl`).
    recorded: Option<Arc<RecordedType>>,
}

impl ChannelReader {
    /// Decodes one message of the channel.
    pub(crate) fn decode<T: DeserializeOwned>(&self, bytes: &[u8]) -> Result<T, cdr::CdrError> {
        match &self.recorded {
            Some(t) => t.decode(bytes),
            None => cdr::decode(bytes),
        }
    }
}

/// The readers of the channels seen so far, by channel id; an incompatible channel is the reason.
#[derive(Debug, Default)]
pub(crate) struct Channels {
    by_id: HashMap<u16, Result<ChannelReader, IncompatibleChannel>>,
}

impl Channels {
    /// The reader of channel `id` as `table` defines it, made on its first message; `fields`
    /// hears which fields it has. `None` when no record defines the channel.
    pub(crate) fn reader(
        &mut self,
        table: &Table,
        id: u16,
        fields: &mut RecordedFields,
    ) -> Option<&Result<ChannelReader, IncompatibleChannel>> {
        match self.by_id.entry(id) {
            Entry::Occupied(known) => Some(known.into_mut()),
            Entry::Vacant(new) => {
                let channel = table.channels.get(&id)?;
                Some(new.insert(make(channel, table.schema_of(channel), fields)))
            }
        }
    }
}

/// How `channel` (with its schema, if any) decodes; `fields` hears which fields it has.
fn make(
    channel: &Channel,
    schema: Option<&KnownSchema>,
    fields: &mut RecordedFields,
) -> Result<ChannelReader, IncompatibleChannel> {
    let ours = carried(channel, schema);
    let as_it_is = Ok(ChannelReader {
        carried: ours.map(|(c, _)| c),
        recorded: None,
    });
    let (Some((carried, type_name)), Some(schema)) = (ours, schema) else {
        return as_it_is;
    };
    if schema.encoding != "ros2msg" || schema.data.is_empty() {
        return as_it_is;
    }
    let text = String::from_utf8_lossy(&schema.data);
    match RecordedType::new(&text, type_name) {
        Ok(t) => {
            fields.note(&t);
            Ok(ChannelReader {
                carried: Some(carried),
                recorded: (!t.is_ours()).then(|| Arc::new(t)),
            })
        }
        Err(source) => Err(IncompatibleChannel {
            topic: channel.topic.clone(),
            schema: schema.name.clone(),
            source: Box::new(source),
        }),
    }
}

/// A channel whose recorded type cannot be read as ours: its messages are not decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("channel {topic} ({schema}) cannot be read as ours: {source}")]
pub struct IncompatibleChannel {
    /// The channel's topic.
    pub topic: String,
    /// The name of its schema.
    pub schema: String,
    /// Why not.
    pub source: Box<crate::msg::schema::Incompatible>,
}

/// Which fields of our types a recording has: for each type, the fewest fields any of its
/// channels recorded (our message types only grow at their end, so a count is a prefix). A type
/// not listed has all our fields.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RecordedFields {
    counts: BTreeMap<String, usize>,
}

/// [`RosMessage::fields`] of one type.
type FieldList = fn() -> Vec<(&'static str, String)>;

/// The field-type name (`pkg/Name`, as a field names a type) of each of our message types with
/// trailing fields, with its fields: the keys of [`RecordedFields`].
fn our_types() -> [(String, FieldList); 5] {
    fn entry<M: RosMessage>() -> (String, FieldList) {
        (format!("{}/{}", M::PACKAGE, M::NAME), M::fields)
    }
    [
        entry::<GraspCandidate>(),
        entry::<GripRecommendation>(),
        entry::<GraspCandidateSet>(),
        entry::<GripRecommendationSet>(),
        entry::<PoseRecommendation>(),
    ]
}

/// The fields of our type named `type_name` (`pkg/Name`), if it is one with trailing fields.
fn our_fields(type_name: &str) -> Option<Vec<&'static str>> {
    let (_, fields) = our_types()
        .into_iter()
        .find(|(name, _)| name == type_name)?;
    Some(fields().into_iter().map(|(name, _)| name).collect())
}

impl RecordedFields {
    /// Notes the fields of every one of our types that `t` holds.
    fn note(&mut self, t: &RecordedType) {
        for (name, _) in our_types() {
            if let Some(n) = t.field_count(&name) {
                self.limit(&name, n);
            }
        }
    }

    fn limit(&mut self, type_name: &str, count: usize) {
        let full = our_fields(type_name).map_or(usize::MAX, |f| f.len());
        if count < full {
            let entry = self.counts.entry(type_name.to_string()).or_insert(count);
            *entry = (*entry).min(count);
        }
    }

    /// Adds what another part of the same recording has.
    pub(crate) fn merge(&mut self, other: &RecordedFields) {
        for (name, count) in &other.counts {
            self.limit(name, *count);
        }
    }

    /// Whether the recording has field `field` of `M` wherever `M` appears.
    pub(crate) fn has<M: RosMessage>(&self, field: &str) -> bool {
        let Some((package, name)) = split_type_name(M::TYPE_NAME) else {
            return true;
        };
        let Some(count) = self.counts.get(&format!("{package}/{name}")) else {
            return true;
        };
        our_fields(&format!("{package}/{name}"))
            .and_then(|fields| fields.iter().position(|f| *f == field))
            .is_none_or(|index| index < *count)
    }

    /// The fields of `M` the recording lacks, in order (empty when it has them all).
    pub fn missing<M: RosMessage>(&self) -> Vec<&'static str> {
        M::fields()
            .into_iter()
            .map(|(name, _)| name)
            .filter(|name| !self.has::<M>(name))
            .collect()
    }
}
