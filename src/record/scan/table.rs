//! The schemas and channels a reader has met, by id.

use super::fields::{Channel, Schema};
use super::frame::Damage;

/// A schema as a channel table keeps it (copied out of the chunk it came in).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct KnownSchema {
    /// The type name.
    pub(crate) name: String,
    /// e.g. `ros2msg`.
    pub(crate) encoding: String,
    /// The definition.
    pub(crate) data: Vec<u8>,
}

/// The schemas and channels defined so far, by id. A second definition of an id must equal the
/// first.
#[derive(Debug, Clone, Default)]
pub(crate) struct Table {
    /// Schemas by id.
    pub(crate) schemas: std::collections::HashMap<u16, KnownSchema>,
    /// Channels by id.
    pub(crate) channels: std::collections::HashMap<u16, Channel>,
}

impl Table {
    /// Adds a schema found at `offset`.
    pub(crate) fn add_schema(&mut self, schema: &Schema<'_>, offset: u64) -> Result<(), Damage> {
        let known = KnownSchema {
            name: schema.name.clone(),
            encoding: schema.encoding.clone(),
            data: schema.data.to_vec(),
        };
        match self.schemas.get(&schema.id) {
            Some(old) if *old != known => Err(Damage::at(
                offset,
                format!("schema {} is defined twice, differently", schema.id),
            )),
            Some(_) => Ok(()),
            None => {
                self.schemas.insert(schema.id, known);
                Ok(())
            }
        }
    }

    /// Adds a channel found at `offset`.
    pub(crate) fn add_channel(&mut self, channel: &Channel, offset: u64) -> Result<(), Damage> {
        match self.channels.get(&channel.id) {
            Some(old) if old != channel => Err(Damage::at(
                offset,
                format!("channel {} is defined twice, differently", channel.id),
            )),
            Some(_) => Ok(()),
            None => {
                self.channels.insert(channel.id, channel.clone());
                Ok(())
            }
        }
    }

    /// The schema of a channel, when it has one and it is known.
    pub(crate) fn schema_of(&self, channel: &Channel) -> Option<&KnownSchema> {
        self.schemas.get(&channel.schema_id)
    }
}
