use std::{
  collections::BTreeMap,
  sync::{Arc, RwLock, RwLockReadGuard, RwLockWriteGuard},
  time::Instant,
};

use chrono::Utc;
#[allow(unused_imports)]
use log::{debug, error, info, trace, warn};

use crate::{
  dds::{
    participant::DomainParticipant,
    qos::HasQoSPolicy,
    statusevents::{DomainParticipantStatusEvent, LostReason, StatusChannelSender},
    topic::{Topic, TopicDescription},
  },
  rtps::{
    reader::ReaderIngredients, rtps_reader_proxy::RtpsReaderProxy,
    rtps_writer_proxy::RtpsWriterProxy,
  },
  structure::{
    duration::Duration,
    entity::RTPSEntity,
    guid::{EntityId, GuidPrefix, GUID},
  },
};
use super::{
  sedp_messages::{
    topics_inconsistent, DiscoveredReaderData, DiscoveredTopicData, DiscoveredWriterData,
    ParticipantMessageData, ReaderProxy, SubscriptionBuiltinTopicData, TopicBuiltinTopicData,
    WriterProxy,
  },
  spdp_participant_data::SpdpDiscoveredParticipantData,
};
#[cfg(not(feature = "security"))]
use crate::no_security::EndpointSecurityInfo;
#[cfg(feature = "security")]
use crate::{discovery::secure_discovery::AuthenticationStatus, security::EndpointSecurityInfo};

// If remote participant does not specify lease duration, how long silence
// until we pronounce it dead.
const DEFAULT_PARTICIPANT_LEASE_DURATION: Duration = Duration::from_secs(60);

// How much longer to wait than lease duration before pronouncing lost.
const PARTICIPANT_LEASE_DURATION_TOLERANCE: Duration = Duration::from_secs(0);

// Patched for grasp_orient (0016-bounded-remote-participants.patch): the longest lease honoured.
// A participant announcing a longer (or infinite) one is still dropped after 5 minutes of
// silence, so participants that announced themselves once cannot hold the places of
// max_remote_participants for good. Live participants announce themselves much more often
// (Fast DDS every 3 s by default, with a lease of 20 s).
const MAX_HONOURED_LEASE_DURATION: Duration = Duration::from_secs(300);
// How often, at most, the participants ignored for want of room are reported at warn level.
const REFUSAL_WARNING_INTERVAL: std::time::Duration = std::time::Duration::from_secs(10);
// Patched for grasp_orient (0018-bounded-discovery-bytes.patch): what a map entry costs beyond
// its record (its key and its share of a B-tree node, whose entries are the record's size plus
// the key's), counted with the record in DiscoveryDB::held_bytes.
const ENTRY_OVERHEAD_BYTES: usize = 64;

fn participant_bytes(d: &SpdpDiscoveredParticipantData) -> usize {
  // The record, and its entry in participant_last_life_signs.
  d.held_bytes() + 2 * ENTRY_OVERHEAD_BYTES
}

fn reader_bytes(d: &DiscoveredReaderData) -> usize {
  d.held_bytes() + ENTRY_OVERHEAD_BYTES
}

fn writer_bytes(d: &DiscoveredWriterData) -> usize {
  d.held_bytes() + ENTRY_OVERHEAD_BYTES
}

fn topic_entry_bytes(d: &DiscoveredTopicData) -> usize {
  d.held_bytes() + ENTRY_OVERHEAD_BYTES
}

// A topic's own entry in `topics`: its name (the key) and the map of its sources.
fn topic_name_bytes(name: &str) -> usize {
  name.len()
    + std::mem::size_of::<BTreeMap<GUID, (DiscoveredVia, DiscoveredTopicData)>>()
    + ENTRY_OVERHEAD_BYTES
}

// TODO: Let DiscoveryDB itself become thread-safe and support smaller-scope
// lock
pub(crate) struct DiscoveryDB {
  my_guid: GUID,
  participant_proxies: BTreeMap<GuidPrefix, SpdpDiscoveredParticipantData>,
  participant_last_life_signs: BTreeMap<GuidPrefix, Instant>,
  // Patched for grasp_orient (0016-bounded-remote-participants.patch): the most remote
  // participants kept, how many new ones were ignored for want of room, and when that was last
  // reported at warn level.
  max_remote_participants: usize,
  participants_ignored: u64,
  ignored_reported_at: Option<Instant>,
  // Patched for grasp_orient (0018-bounded-discovery-bytes.patch): the most bytes the records
  // of participant_proxies, external_topic_readers and _writers (and their attics) and topics
  // may hold together, what they hold, how many records were refused for want of room, and
  // when that was last reported at warn level.
  max_discovery_bytes: usize,
  held_bytes: usize,
  records_refused: u64,
  refused_reported_at: Option<Instant>,

  // Authentication statuses of participants
  #[cfg(feature = "security")]
  authentication_statuses: BTreeMap<GuidPrefix, AuthenticationStatus>,

  // local writer proxies for topics (topic name acts as key)
  local_topic_writers: BTreeMap<GUID, DiscoveredWriterData>,
  // local reader proxies for topics (topic name acts as key)
  local_topic_readers: BTreeMap<GUID, DiscoveredReaderData>,

  // remote readers and writers (via discovery)
  external_topic_readers: BTreeMap<GUID, DiscoveredReaderData>,
  external_topic_writers: BTreeMap<GUID, DiscoveredWriterData>,

  // These are "attic" storages for readers and writers whose participant
  // was lost due to time-out. If we have a
  external_topic_readers_attic: BTreeMap<GUID, DiscoveredReaderData>,
  external_topic_writers_attic: BTreeMap<GUID, DiscoveredWriterData>,

  // Database of topic updates:
  // Outer level key is topic name
  // Inner key is topic data sender.
  topics: BTreeMap<String, BTreeMap<GUID, (DiscoveredVia, DiscoveredTopicData)>>,

  // sender for notifying (potential) waiters in participant.find_topic() call
  topic_updated_sender: std::sync::mpsc::SyncSender<()>,

  participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,
}

// How did we discover this topic
#[derive(PartialEq, Eq, Clone, Copy, Debug)]
pub(crate) enum DiscoveredVia {
  Topic,        // explicitly, via the topic topic (does this actually occur?)
  Publication,  // we discovered there is a writer on this topic
  Subscription, // we discovered a reader on this topic
  SelfDefined,  // not discovered, but defined by the local DomainParticipant
}

// Returns the bytes (as `bytes` counts them) of the records in `to` that moved ones replaced.
fn move_by_guid_prefix<D>(
  guid_prefix: GuidPrefix,
  from: &mut BTreeMap<GUID, D>,
  to: &mut BTreeMap<GUID, D>,
  bytes: impl Fn(&D) -> usize,
) -> usize {
  let to_move: Vec<GUID> = from.range(guid_prefix.range()).map(|(g, _)| *g).collect();
  let mut replaced = 0;
  for guid in to_move {
    if let Some(d) = from.remove(&guid) {
      replaced += to.insert(guid, d).map_or(0, |old| bytes(&old));
    }
  }
  replaced
}

pub(crate) fn discovery_db_read(
  discovery_db: &Arc<RwLock<DiscoveryDB>>,
) -> RwLockReadGuard<'_, DiscoveryDB> {
  match discovery_db.read() {
    Ok(db) => db,
    Err(e) => panic!("RustDDS internal bug: DiscoveryDB is poisoned after a prior panic: {e:?}."),
  }
}

pub(crate) fn discovery_db_write(
  discovery_db: &Arc<RwLock<DiscoveryDB>>,
) -> RwLockWriteGuard<'_, DiscoveryDB> {
  match discovery_db.write() {
    Ok(db) => db,
    Err(e) => panic!("RustDDS internal bug: DiscoveryDB is poisoned after a prior panic: {e:?}."),
  }
}

impl DiscoveryDB {
  pub fn new(
    my_guid: GUID,
    topic_updated_sender: std::sync::mpsc::SyncSender<()>,
    participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,
  ) -> Self {
    Self {
      my_guid,
      participant_proxies: BTreeMap::new(),
      participant_last_life_signs: BTreeMap::new(),
      max_remote_participants: crate::DomainParticipantBuilder::DEFAULT_MAX_REMOTE_PARTICIPANTS,
      participants_ignored: 0,
      ignored_reported_at: None,
      max_discovery_bytes: crate::DomainParticipantBuilder::DEFAULT_MAX_DISCOVERY_BYTES,
      held_bytes: 0,
      records_refused: 0,
      refused_reported_at: None,
      #[cfg(feature = "security")]
      authentication_statuses: BTreeMap::new(),
      local_topic_writers: BTreeMap::new(),
      local_topic_readers: BTreeMap::new(),
      external_topic_readers: BTreeMap::new(),
      external_topic_writers: BTreeMap::new(),
      external_topic_readers_attic: BTreeMap::new(),
      external_topic_writers_attic: BTreeMap::new(),
      topics: BTreeMap::new(),
      topic_updated_sender,
      participant_status_sender,
    }
  }

  fn send_participant_status(&self, event: DomainParticipantStatusEvent) {
    self
      .participant_status_sender
      .try_send(event)
      .unwrap_or_else(|e| error!("Cannot report participant status: {e:?}"));
  }

  /// The most remote participants this database keeps (participant-builder
  /// `max_remote_participants`).
  pub fn set_max_remote_participants(&mut self, count: usize) {
    self.max_remote_participants = count;
  }

  /// The most bytes the records of remote participants, endpoints and topics may hold
  /// together (participant-builder `max_discovery_bytes`).
  pub fn set_max_discovery_bytes(&mut self, bytes: usize) {
    self.max_discovery_bytes = bytes;
  }

  /// What the records of participants, external endpoints (and their attics) and topics hold,
  /// in bytes: their sizes, the heap they own, and ENTRY_OVERHEAD_BYTES per map entry.
  #[cfg(test)]
  fn held_bytes(&self) -> usize {
    self.held_bytes
  }

  // held_bytes counted again from the maps: the count kept as they change must equal it.
  #[cfg(test)]
  fn recounted_bytes(&self) -> usize {
    self
      .participant_proxies
      .values()
      .map(participant_bytes)
      .sum::<usize>()
      + self
        .external_topic_readers
        .values()
        .map(reader_bytes)
        .sum::<usize>()
      + self
        .external_topic_readers_attic
        .values()
        .map(reader_bytes)
        .sum::<usize>()
      + self
        .external_topic_writers
        .values()
        .map(writer_bytes)
        .sum::<usize>()
      + self
        .external_topic_writers_attic
        .values()
        .map(writer_bytes)
        .sum::<usize>()
      + self
        .topics
        .iter()
        .map(|(name, t)| {
          topic_name_bytes(name) + t.values().map(|(_, d)| topic_entry_bytes(d)).sum::<usize>()
        })
        .sum::<usize>()
  }

  /// Whether a record of `needed` bytes, replacing one of `freed` bytes, fits within
  /// max_discovery_bytes. Endpoints in the attics (of participants whose lease expired) are
  /// dropped first, oldest GUIDs first, to make room: they only speed up a rediscovery, and
  /// would otherwise hold the room for good.
  fn make_room(&mut self, freed: usize, needed: usize) -> bool {
    loop {
      if self.held_bytes.saturating_sub(freed) + needed <= self.max_discovery_bytes {
        return true;
      }
      if let Some((_, d)) = self.external_topic_readers_attic.pop_first() {
        self.held_bytes = self.held_bytes.saturating_sub(reader_bytes(&d));
      } else if let Some((_, d)) = self.external_topic_writers_attic.pop_first() {
        self.held_bytes = self.held_bytes.saturating_sub(writer_bytes(&d));
      } else {
        return false;
      }
    }
  }

  // Counts a record refused by make_room, and says so at warn level at most every
  // REFUSAL_WARNING_INTERVAL.
  fn refuse_for_room(&mut self, what: &str, guid: GUID, needed: usize) {
    self.records_refused += 1;
    let now = Instant::now();
    if self
      .refused_reported_at
      .is_none_or(|at| now.duration_since(at) >= REFUSAL_WARNING_INTERVAL)
    {
      self.refused_reported_at = Some(now);
      warn!(
        target: crate::LIMITS_LOG_TARGET,
        "Discovery holds at most {} bytes ({} held): {what} {guid:?} of {needed} bytes ignored \
         ({} records ignored so far)",
        self.max_discovery_bytes, self.held_bytes, self.records_refused
      );
    } else {
      debug!("Discovery record {what} {guid:?} ignored: no room");
    }
  }

  fn remote_participant_count(&self) -> usize {
    self.participant_proxies.len()
      - usize::from(self.participant_proxies.contains_key(&self.my_guid.prefix))
  }

  /// Whether SPDP data of `guid_prefix` is taken in: a participant already known, this
  /// participant itself, or a new one while fewer than max_remote_participants are known. A
  /// new one beyond that is ignored and counted; the count is logged at warn level at most
  /// every REFUSAL_WARNING_INTERVAL.
  pub fn admits_participant(&mut self, guid_prefix: GuidPrefix) -> bool {
    if guid_prefix == self.my_guid.prefix
      || self.participant_proxies.contains_key(&guid_prefix)
      || self.remote_participant_count() < self.max_remote_participants
    {
      return true;
    }
    self.participants_ignored += 1;
    let now = Instant::now();
    if self
      .ignored_reported_at
      .is_none_or(|at| now.duration_since(at) >= REFUSAL_WARNING_INTERVAL)
    {
      self.ignored_reported_at = Some(now);
      warn!(
        target: crate::LIMITS_LOG_TARGET,
        "Discovery keeps at most {} remote participants: {guid_prefix:?} ignored ({} new \
         participants ignored so far)",
        self.max_remote_participants, self.participants_ignored
      );
    } else {
      debug!("Remote participant {guid_prefix:?} ignored: no room");
    }
    false
  }

  // Returns if participant was previously unknown. Patched for grasp_orient
  // (0016-bounded-remote-participants.patch): a new participant the database has no room for
  // (admits_participant) is not taken in, and false is returned. And
  // (0018-bounded-discovery-bytes.patch): data of a remote participant that does not fit within
  // max_discovery_bytes is not taken in either (a known participant keeps its earlier data
  // and is marked alive).
  pub fn update_participant(&mut self, data: &SpdpDiscoveredParticipantData) -> bool {
    debug!("update_participant: {:?}", data);
    let guid = data.participant_guid;
    if !self.admits_participant(guid.prefix) {
      return false;
    }

    // sanity check
    if guid.entity_id != EntityId::PARTICIPANT {
      error!("Discovered participant GUID entity_id is not for participant: {guid:?}");
      // Maybe we should discard the participant here?
      return false;
    }

    // We allow discovery to discover self, since our discovery readers
    // will receive our own announcements via broadcast. If we do not recognize
    // our own participant, there is confusion about unknown writers on the
    // discovery topics.
    //
    // if guid == self.my_guid {
    //   debug!("DiscoveryDB discovered self. Skipping.");
    //   return
    // }

    let needed = participant_bytes(data);
    let freed = self
      .participant_proxies
      .get(&guid.prefix)
      .map_or(0, participant_bytes);
    if guid.prefix != self.my_guid.prefix && !self.make_room(freed, needed) {
      self.refuse_for_room("participant", guid, needed);
      self.participant_is_alive(guid.prefix);
      return false;
    }

    let mut new_participant = false;
    if !self.participant_proxies.contains_key(&guid.prefix) {
      info!("New remote participant: {:?}", data);
      new_participant = true;
      if guid == self.my_guid {
        info!("Remote participant {guid:?} is myself, but some reflection is good.");
        new_participant = false;
      }

      // This may be a rediscovery: Participant lease time timed out, but then
      // came back, e.g. by network outage. We then restore readers/writers from
      // attic to discovery DB.
      let replaced = move_by_guid_prefix(
        guid.prefix,
        &mut self.external_topic_readers_attic,
        &mut self.external_topic_readers,
        reader_bytes,
      ) + move_by_guid_prefix(
        guid.prefix,
        &mut self.external_topic_writers_attic,
        &mut self.external_topic_writers,
        writer_bytes,
      );
      self.held_bytes = self.held_bytes.saturating_sub(replaced);
    }

    // In any case:
    // Update SpdpDiscoveredParticipantData to DB
    self.held_bytes = self.held_bytes.saturating_sub(freed) + needed;
    self.participant_proxies.insert(guid.prefix, data.clone());
    // Timestamp last life sign fro participant
    self
      .participant_last_life_signs
      .insert(guid.prefix, Instant::now());

    new_participant
  }

  pub fn participant_is_alive(&mut self, guid_prefix: GuidPrefix) {
    if let Some(ts) = self.participant_last_life_signs.get_mut(&guid_prefix) {
      let now = Instant::now();
      if now.duration_since(*ts) > std::time::Duration::from_secs(1) {
        debug!("Participant alive update for {guid_prefix:?}, but no full update.");
      }
      *ts = now;
    } else {
      info!(
        "Participant alive update for unknown {guid_prefix:?}. This is normal, if the message \
         does not repeat."
      );
    }
  }

  // active_disposal means that we received a discovery message announcing the
  // disposal of the participant. active_disposal=false means that the
  // participant timed out.
  pub fn remove_participant(&mut self, guid_prefix: GuidPrefix, active_disposal: bool) {
    info!("removing participant {guid_prefix:?}");
    if let Some(d) = self.participant_proxies.remove(&guid_prefix) {
      self.held_bytes = self.held_bytes.saturating_sub(participant_bytes(&d));
    }
    self.participant_last_life_signs.remove(&guid_prefix);
    #[cfg(feature = "security")]
    self.authentication_statuses.remove(&guid_prefix);

    if active_disposal {
      self.remove_topic_reader_with_prefix(guid_prefix);
      self.remove_topic_writer_with_prefix(guid_prefix);
    } else {
      // move to attic
      let replaced = move_by_guid_prefix(
        guid_prefix,
        &mut self.external_topic_readers,
        &mut self.external_topic_readers_attic,
        reader_bytes,
      ) + move_by_guid_prefix(
        guid_prefix,
        &mut self.external_topic_writers,
        &mut self.external_topic_writers_attic,
        writer_bytes,
      );
      self.held_bytes = self.held_bytes.saturating_sub(replaced);
    }
  }

  pub fn find_participant_proxy(
    &self,
    guid_prefix: GuidPrefix,
  ) -> Option<&SpdpDiscoveredParticipantData> {
    self.participant_proxies.get(&guid_prefix)
  }

  fn remove_topic_reader_with_prefix(&mut self, guid_prefix: GuidPrefix) {
    // TODO: Implement this using .drain_filter() in BTreeMap once it lands in
    // stable.
    let to_remove: Vec<GUID> = self
      .external_topic_readers
      .range(guid_prefix.range())
      .map(|(g, _)| *g)
      .collect();
    for guid in to_remove {
      self.remove_topic_reader(guid);
    }
  }

  pub fn remove_topic_reader(&mut self, guid: GUID) {
    info!("remove_topic_reader {guid:?}");
    if let Some(d) = self.external_topic_readers.remove(&guid) {
      self.held_bytes = self.held_bytes.saturating_sub(reader_bytes(&d));
    }
  }

  #[cfg(feature = "security")]
  pub fn get_topic_reader(&self, guid: &GUID) -> Option<&DiscoveredReaderData> {
    self.external_topic_readers.get(guid)
  }

  #[cfg(feature = "security")]
  pub fn get_topic_writer(&self, guid: &GUID) -> Option<&DiscoveredWriterData> {
    self.external_topic_writers.get(guid)
  }

  fn remove_topic_writer_with_prefix(&mut self, guid_prefix: GuidPrefix) {
    // TODO: Implement this using .drain_filter() in BTreeMap once it lands in
    // stable.
    let to_remove: Vec<GUID> = self
      .external_topic_writers
      .range(guid_prefix.range())
      .map(|(g, _)| *g)
      .collect();
    for guid in to_remove {
      self.remove_topic_writer(guid);
    }
  }

  pub fn remove_topic_writer(&mut self, guid: GUID) {
    if let Some(d) = self.external_topic_writers.remove(&guid) {
      self.held_bytes = self.held_bytes.saturating_sub(writer_bytes(&d));
    }
  }

  // Delete participant proxies, if we have not heard of them within
  // lease_duration
  pub fn participant_cleanup(&mut self) -> Vec<(GuidPrefix, LostReason)> {
    let inow = Instant::now();

    let mut to_remove = Vec::new();
    // TODO: We are not cleaning up liast_life_signs table, but that should not be a
    // problem, except for a slight memory leak.
    for (&guid, sp) in &self.participant_proxies {
      let lease_duration = sp
        .lease_duration
        .unwrap_or(DEFAULT_PARTICIPANT_LEASE_DURATION)
        .min(MAX_HONOURED_LEASE_DURATION);
      // let lease_duration = lease_duration + lease_duration; // double it
      match self.participant_last_life_signs.get(&guid) {
        Some(&last_life) => {
          // keep, if duration not exceeded
          let elapsed = Duration::from_std(inow.duration_since(last_life));
          if elapsed <= lease_duration + PARTICIPANT_LEASE_DURATION_TOLERANCE {
            // No timeout yet, we keep this, so do nothing.
          } else {
            info!(
              "participant cleanup - deleting participant proxy {guid:?}. lease_duration = \
               {lease_duration:?} elapsed = {elapsed:?}"
            );
            to_remove.push((
              guid,
              LostReason::Timeout {
                lease: lease_duration,
                elapsed,
              },
            ));
          }
        }
        None => {
          error!("Participant {guid:?} not in last_life_signs table?");
        }
      } // match
    } // for

    for (guid, _) in &to_remove {
      self.remove_participant(*guid, false); // false = removed due to timeout
    }

    to_remove
  }

  fn topic_has_writers_or_readers(&self, topic_name: &str) -> bool {
    // TODO: This entire function has silly implementation.
    // We should really have a separate map from Topic to Readers & Writers
    if self
      .local_topic_readers
      .iter()
      .any(|(_, p)| p.subscription_topic_data.topic_name() == topic_name)
    {
      return true;
    }

    if self
      .local_topic_writers
      .iter()
      .any(|(_, p)| p.publication_topic_data.topic_name == topic_name)
    {
      return true;
    }

    if self
      .external_topic_readers
      .values()
      .any(|p| p.subscription_topic_data.topic_name() == topic_name)
    {
      return true;
    }

    if self
      .external_topic_writers
      .values()
      .any(|p| p.publication_topic_data.topic_name == topic_name)
    {
      return true;
    }

    false
  }

  pub fn topic_cleanup(&mut self) {
    // removing topics that have no readers or writers
    let dead_topics: Vec<_> = self
      .topics
      .keys()
      .filter(|tn| !self.topic_has_writers_or_readers(tn))
      .cloned()
      .collect();
    for dt in &dead_topics {
      if let Some(t) = self.topics.remove(dt) {
        let bytes =
          topic_name_bytes(dt) + t.values().map(|(_, d)| topic_entry_bytes(d)).sum::<usize>();
        self.held_bytes = self.held_bytes.saturating_sub(bytes);
      }
    }
  }

  pub fn update_local_topic_writer(&mut self, writer: DiscoveredWriterData) {
    self
      .local_topic_writers
      .insert(writer.writer_proxy.remote_writer_guid, writer);
  }

  pub fn remove_local_topic_writer(&mut self, guid: GUID) {
    self.local_topic_writers.remove(&guid);
  }

  // TODO: This is silly. Returns one of the parameters cloned, or None
  // TODO: Why are we here checking if discovery db already has this? What about
  // reader proxies in writers?

  // Here we make updates when a new Reader is found via Discovery.
  // * It may be one of our own.
  // * We may have seen it before.
  //
  // In case DiscoveredReaderData does not have locators, we try to get
  // them from the remote participant.
  //
  // The topic is updated to the topics table.
  //
  // Patched for grasp_orient (0018-bounded-discovery-bytes.patch): a reader whose record (and
  // its topic's) does not fit within max_discovery_bytes is not taken in, and None is returned.
  pub fn update_subscription(
    &mut self,
    data: &DiscoveredReaderData,
  ) -> Option<DiscoveredReaderData> {
    let guid = data.reader_proxy.remote_reader_guid;

    // fill in the default locators from participant, in case DRD did not provide
    // any
    let default_locator_lists = self
      .find_participant_proxy(guid.prefix)
      .map(|pp| {
        debug!("Added participant locators to Reader {guid:?}");
        (
          pp.default_unicast_locators.clone(),
          pp.default_multicast_locators.clone(),
        )
      })
      .unwrap_or_else(|| {
        if guid.prefix != GuidPrefix::UNKNOWN {
          // This is normal, since we might not know about the participant yet.
          debug!(
            "No remote participant known for {:?}\nSearched with {:?} in {:?}",
            data,
            guid.prefix,
            self.participant_proxies.keys()
          );
        }
        (Vec::default(), Vec::default())
      });

    // Build enriched data with participant's default locators filled in, so that
    // later lookups via readers_on_topic() return usable locator information.
    let enriched = DiscoveredReaderData {
      reader_proxy: ReaderProxy::from(RtpsReaderProxy::from_discovered_reader_data(
        data,
        &default_locator_lists.0,
        &default_locator_lists.1,
      )),
      ..data.clone()
    };

    let topic = DiscoveredTopicData::new(Utc::now(), data.subscription_topic_data.to_topic_data());
    let needed = reader_bytes(&enriched) + self.topic_bytes_needed(&topic, guid);
    let freed = self
      .external_topic_readers
      .get(&guid)
      .map_or(0, reader_bytes);
    if !self.make_room(freed, needed) {
      self.refuse_for_room("reader", guid, needed);
      return None;
    }
    self.held_bytes = self.held_bytes.saturating_sub(freed) + reader_bytes(&enriched);
    self.external_topic_readers.insert(guid, enriched.clone());
    debug!("External reader: {enriched:?}");

    // Now the topic update:
    self.update_topic_data(&topic, guid, DiscoveredVia::Subscription);

    // TODO: Lookup the topic in DB, data sent by the same participant that sent the
    // reader update. If there is a DiscoveredVia::Topic record, use QosPolicies
    // from that record and modify by QoS given in the DRD.

    Some(enriched)
  }

  // TODO: This is silly. Returns one of the parameters cloned, or None
  //
  // Patched for grasp_orient (0018-bounded-discovery-bytes.patch): a writer whose record (and
  // its topic's) does not fit within max_discovery_bytes is not taken in, and None is returned.
  pub fn update_publication(
    &mut self,
    data: &DiscoveredWriterData,
  ) -> Option<DiscoveredWriterData> {
    let guid = data.writer_proxy.remote_writer_guid;

    // fill in the default locators from participant, in case DRD did not provide
    // any
    let default_locator_lists = self
      .find_participant_proxy(guid.prefix)
      .map(|pp| {
        debug!("Added participant locators to Writer {guid:?}");
        (
          pp.default_unicast_locators.clone(),
          pp.default_multicast_locators.clone(),
        )
      })
      .unwrap_or_else(|| {
        if guid.prefix != GuidPrefix::UNKNOWN {
          // This is normal, since we might not know about the participant yet.
          debug!(
            "No remote participant known for {:?}\nSearched with {:?} in {:?}",
            data,
            guid.prefix,
            self.participant_proxies.keys()
          );
        }
        (Vec::default(), Vec::default())
      });

    // Build enriched data with participant's default locators filled in, so that
    // later lookups via writers_on_topic() return usable locator information.
    let enriched = DiscoveredWriterData {
      writer_proxy: WriterProxy::from(RtpsWriterProxy::from_discovered_writer_data(
        data,
        &default_locator_lists.0,
        &default_locator_lists.1,
      )),
      ..data.clone()
    };

    let topic = DiscoveredTopicData::new(Utc::now(), data.publication_topic_data.to_topic_data());
    let needed = writer_bytes(&enriched) + self.topic_bytes_needed(&topic, guid);
    let freed = self
      .external_topic_writers
      .get(&guid)
      .map_or(0, writer_bytes);
    if !self.make_room(freed, needed) {
      self.refuse_for_room("writer", guid, needed);
      return None;
    }
    self.held_bytes = self.held_bytes.saturating_sub(freed) + writer_bytes(&enriched);
    self.external_topic_writers.insert(guid, enriched.clone());
    debug!("External writer: {enriched:?}");

    // Now the topic update:
    self.update_topic_data(&topic, guid, DiscoveredVia::Publication);

    Some(enriched)
  }

  // The bytes update_topic_data(dtd, updater, ..) adds when it makes a new entry: the entry,
  // and the topic's own when the name is new. An entry it replaces (its updater's, which only
  // DiscoveredVia::Topic replaces) is not counted.
  fn topic_bytes_needed(&self, dtd: &DiscoveredTopicData, updater: GUID) -> usize {
    match self.topics.get(&dtd.topic_data.name) {
      Some(t) if t.contains_key(&updater) => 0,
      Some(_) => topic_entry_bytes(dtd),
      None => topic_entry_bytes(dtd) + topic_name_bytes(&dtd.topic_data.name),
    }
  }

  // This is for local participant updating the topic table
  pub fn update_topic_data_p(&mut self, topic: &Topic) {
    let topic_data = DiscoveredTopicData::new(
      Utc::now(),
      TopicBuiltinTopicData::new(
        None,
        topic.name(),
        topic.get_type().name().to_owned(),
        &topic.qos(),
      ),
    );
    self.update_topic_data(&topic_data, self.my_guid, DiscoveredVia::SelfDefined);
  }

  // Topic update sends notifications, in case someone was waiting to find a
  // topic. Return value indicates whether the topic (name) was new to us. This
  // is used to add
  pub fn update_topic_data(
    &mut self,
    dtd: &DiscoveredTopicData,
    updater: GUID,
    discovered_via: DiscoveredVia,
  ) {
    trace!("Update topic data: {:?}", dtd);
    // Patched for grasp_orient (0018-bounded-discovery-bytes.patch): a new entry from a remote
    // updater that does not fit within max_discovery_bytes is not taken in.
    let needed = self.topic_bytes_needed(dtd, updater);
    if updater.prefix != self.my_guid.prefix && !self.make_room(0, needed) {
      self.refuse_for_room("topic entry", updater, needed);
      return;
    }
    let topic_name = dtd.topic_data.name.clone();
    let mut notify = false;
    let mut inconsistency_event_to_send = None;

    if let Some(t) = self.topics.get_mut(&dtd.topic_data.name) {
      if let Some(old_dtd) = t.get_mut(&updater) {
        // already have it from the same source, do some checking(?) and merging
        if !topics_inconsistent(&dtd.topic_data, &old_dtd.1.topic_data) {
          // If this discovery was from Topic topic and the old was not, then update
          // TODO: Why do we have this logic? Where is the spec? Or ant reason for it?
          // Is it even triggered ever?
          if discovered_via == DiscoveredVia::Topic {
            self.held_bytes = self
              .held_bytes
              .saturating_sub(topic_entry_bytes(&old_dtd.1))
              + topic_entry_bytes(dtd);
            *old_dtd = (discovered_via, dtd.clone()); // update QoS
            notify = true;
          } else {
            debug!(
              "Topic {:?} update ignored from {:?}. Already have this.",
              topic_name, updater
            );
            // TODO: Here we could warn about QoS changes.
            //
            // It is normal to have different (but compatible) QoS policies
            // for Reader and Writer. We end up here if the same Participant has
            // both Reader and Writer with different QoS. Also
            // different Readers could have different QoS,
            // as could Writers.
          }
        } else {
          error!(
            "Inconsistent topic update from {:?}: type was: {:?} new type: {:?}",
            updater, old_dtd.1.topic_data.type_name, dtd.topic_data.type_name,
          );
          inconsistency_event_to_send = Some(DomainParticipantStatusEvent::InconsistentTopic {
            previous_topic_data: Box::new((&old_dtd.1.topic_data).into()),
            previous_source: updater,
            discovered_topic_data: Box::new((&dtd.topic_data).into()),
            discovery_source: updater,
          });
        }
      } else {
        for (source_guid, (_via, existing_dtd)) in t.iter() {
          if topics_inconsistent(&existing_dtd.topic_data, &dtd.topic_data) {
            inconsistency_event_to_send = Some(DomainParticipantStatusEvent::InconsistentTopic {
              previous_topic_data: Box::new((&existing_dtd.topic_data).into()),
              previous_source: *source_guid,
              discovered_topic_data: Box::new((&dtd.topic_data).into()),
              discovery_source: updater,
            });
            // Note: There are potentially several sources of inconsistency
            // (loop), but we will report only one of them.
          }
        }
        // We have to topic, but not from this participant
        // TODO: Check that there is agreement about topic type name (at least)
        t.insert(updater, (discovered_via, dtd.clone())); // this should return None
        self.held_bytes += needed;
        notify = true;
      }
    } else {
      // new topic to us
      let mut b = BTreeMap::new();
      b.insert(updater, (discovered_via, dtd.clone()));
      self.topics.insert(topic_name, b);
      self.held_bytes += needed;
      self.send_participant_status(DomainParticipantStatusEvent::TopicDetected {
        name: dtd.topic_data.name.clone(),
        type_name: dtd.topic_data.type_name.clone(),
      });
    };
    if let Some(ev) = inconsistency_event_to_send {
      self.send_participant_status(ev);
    }
    if notify {
      self
        .topic_updated_sender
        .try_send(())
        // It is quite normal for this to fail due to channel full,
        // because usually there is no-one at the other end receiving.
        .unwrap_or_else(|e| trace!("update_topic_data: Notification send failed: {e:?}"));
    }
  }

  // local topic readers

  /// Builds the discovery record of a local reader.
  ///
  /// This locks the participant (`dpi`, for its locators and GUID), so it is
  /// a separate step from [`Self::update_local_topic_reader`]: build the record
  /// first, then take the Discovery DB lock and insert it. The two locks are
  /// not held together. Calling this while holding `discovery_db` could
  /// deadlock against `DomainParticipant::find_topic()`, which holds `dpi`
  /// while reading the DB.
  pub fn local_topic_reader_data(
    domain_participant: &DomainParticipant,
    topic: &Topic,
    reader: &ReaderIngredients,
    sec_info_opt: Option<EndpointSecurityInfo>,
  ) -> DiscoveredReaderData {
    let reader_guid = reader.guid;

    let reader_proxy = RtpsReaderProxy::from_reader(reader, domain_participant);

    let subscription_data = SubscriptionBuiltinTopicData::new(
      reader_guid,
      Some(domain_participant.guid()),
      topic.name(),
      topic.get_type().name().to_string(),
      &reader.qos_policy,
      sec_info_opt,
    );

    // TODO: possibly change content filter to dynamic value
    let content_filter = None;

    DiscoveredReaderData {
      reader_proxy: ReaderProxy::from(reader_proxy),
      subscription_topic_data: subscription_data,
      content_filter,
      user_data: Vec::new(),
    }
  }

  /// Inserts a record built by [`Self::local_topic_reader_data`].
  pub fn update_local_topic_reader(&mut self, discovered_reader_data: DiscoveredReaderData) {
    self.local_topic_readers.insert(
      discovered_reader_data.reader_proxy.remote_reader_guid,
      discovered_reader_data,
    );
  }

  pub fn remove_local_topic_reader(&mut self, guid: GUID) {
    self.local_topic_readers.remove(&guid);
  }

  pub fn get_local_topic_reader(&self, guid: GUID) -> Option<&DiscoveredReaderData> {
    self.local_topic_readers.get(&guid)
  }

  pub fn get_local_topic_writer(&self, guid: GUID) -> Option<&DiscoveredWriterData> {
    self.local_topic_writers.get(&guid)
  }

  pub fn get_all_local_topic_readers(&self) -> impl Iterator<Item = &DiscoveredReaderData> {
    self.local_topic_readers.values()
  }

  pub fn get_all_local_topic_writers(&self) -> impl Iterator<Item = &DiscoveredWriterData> {
    self.local_topic_writers.values()
  }

  pub fn get_all_external_topic_readers(&self) -> impl Iterator<Item = &DiscoveredReaderData> {
    self.external_topic_readers.values()
  }

  pub fn get_all_external_topic_writers(&self) -> impl Iterator<Item = &DiscoveredWriterData> {
    self.external_topic_writers.values()
  }

  // Note:
  // If multiple participants announce the same topic, this will
  // return duplicates, one per announcing participant.
  // The duplicates are not necessarily identical, but may have different QoS.
  pub fn all_user_topics(&self) -> impl Iterator<Item = &DiscoveredTopicData> {
    self
      .topics
      .iter()
      .filter(|(s, _)| !s.starts_with("DCPS"))
      .flat_map(|(_, gm)| gm.values().map(|dtd| &dtd.1))
  }

  // a Topic may have multiple definitions, because there may be multiple
  // participants publishing the topic information.
  // At least the QoS details may be different.
  // This just returns the first one found in the database, which is indexed by
  // GUID.
  pub fn get_topic(&self, topic_name: &str) -> Option<&DiscoveredTopicData> {
    self
      .topics
      .get(topic_name)
      .and_then(|m| m.values().next().map(|t| &t.1))
  }

  pub fn writers_on_topic_and_participant(
    &self,
    topic_name: &str,
    participant: GuidPrefix,
  ) -> Vec<DiscoveredWriterData> {
    let on_participant = self
      .external_topic_writers
      .range(participant.range())
      .map(|(_guid, dwd)| dwd);
    debug!("Writers on participant {participant:?} are {on_participant:?}");
    on_participant
      .filter(|dwd| dwd.publication_topic_data.topic_name == topic_name)
      .cloned()
      .collect()
  }

  pub fn readers_on_topic_and_participant(
    &self,
    topic_name: &str,
    participant: GuidPrefix,
  ) -> Vec<DiscoveredReaderData> {
    self
      .external_topic_readers
      .range(participant.range())
      .map(|(_guid, drd)| drd)
      .filter(|drd| drd.subscription_topic_data.topic_name() == topic_name)
      .cloned()
      .collect()
  }

  pub fn writers_on_topic(&self, topic_name: &str) -> Vec<&DiscoveredWriterData> {
    // Get external & local writers on the topic
    let exernal_writers = self
      .external_topic_writers
      .values()
      .filter(|wd| wd.publication_topic_data.topic_name() == topic_name);
    let local_writers = self
      .local_topic_writers
      .values()
      .filter(|wd| wd.publication_topic_data.topic_name() == topic_name);
    // Combine & return
    let combined: Vec<&DiscoveredWriterData> = exernal_writers.chain(local_writers).collect();
    combined
  }

  pub fn readers_on_topic(&self, topic_name: &str) -> Vec<&DiscoveredReaderData> {
    // Get external & local readers on the topic
    let exernal_readers = self
      .external_topic_readers
      .values()
      .filter(|rd| rd.subscription_topic_data.topic_name() == topic_name);
    let local_readers = self
      .local_topic_readers
      .values()
      .filter(|rd| rd.subscription_topic_data.topic_name() == topic_name);
    // Combine & return
    let combined: Vec<&DiscoveredReaderData> = exernal_readers.chain(local_readers).collect();
    combined
  }

  // // TODO: return iterator somehow?
  #[cfg(test)] // used only for testing
  pub fn get_local_topic_readers<T: TopicDescription>(
    &self,
    topic: &T,
  ) -> Vec<&DiscoveredReaderData> {
    let topic_name = topic.name();
    self
      .local_topic_readers
      .iter()
      .filter(|(_, p)| *p.subscription_topic_data.topic_name() == topic_name)
      .map(|(_, p)| p)
      .collect()
  }

  pub fn update_lease_duration(&mut self, data: &ParticipantMessageData) {
    let now = Instant::now();
    let prefix = data.guid;
    self
      .external_topic_writers
      .range_mut(prefix.range())
      .for_each(|(_guid, p)| p.last_updated = now);
  }

  #[cfg(feature = "security")]
  pub fn get_authentication_status(&self, guid_prefix: GuidPrefix) -> Option<AuthenticationStatus> {
    self.authentication_statuses.get(&guid_prefix).copied()
  }

  #[cfg(feature = "security")]
  pub fn update_authentication_status(
    &mut self,
    guid_prefix: GuidPrefix,
    status: AuthenticationStatus,
  ) {
    self.authentication_statuses.insert(guid_prefix, status);
  }
}

#[cfg(test)]
mod tests {
  use std::{sync::Mutex, time::Duration as StdDuration};

  use byteorder::LittleEndian;

  use super::*;
  use crate::{
    dds::{
      qos::QosPolicies,
      statusevents::{sync_status_channel, DataReaderStatus},
      topic::TopicKind,
      with_key::simpledatareader::ReaderCommand,
    },
    mio_source,
    polling::{wake_channel, LoopWaker},
    serialization::CDRSerializerAdapter,
    structure::guid::*,
    test::{
      random_data::RandomData,
      test_data::{reader_proxy_data, spdp_participant_data, subscription_builtin_topic_data},
      test_domain::test_domain_id,
    },
  };

  #[test]
  fn discdb_participant_operations() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();

    let mut discoverydb = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let mut data = spdp_participant_data().unwrap();
    data.lease_duration = Some(Duration::from(StdDuration::from_secs(1)));

    discoverydb.update_participant(&data);
    assert_eq!(discoverydb.participant_proxies.len(), 1);

    discoverydb.update_participant(&data);
    assert_eq!(discoverydb.participant_proxies.len(), 1);

    std::thread::sleep(StdDuration::from_secs(2));
    discoverydb.participant_cleanup();
    assert!(discoverydb.participant_proxies.is_empty());

    // TODO: more operations tests
  }

  #[test]
  fn remote_participants_beyond_the_bound_are_ignored() {
    // 0016-bounded-remote-participants.patch.
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();
    let mut discoverydb = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    discoverydb.set_max_remote_participants(3);
    let mut data = spdp_participant_data().unwrap();
    for i in 0..10u8 {
      data.participant_guid = GUID::new(GuidPrefix::new(&[i + 1; 12]), EntityId::PARTICIPANT);
      discoverydb.update_participant(&data);
    }
    assert_eq!(
      discoverydb.participant_proxies.len(),
      3,
      "the database took in more remote participants than its bound"
    );
    // A known one is still updated, and a lease too long to honour is cut to 5 minutes.
    data.participant_guid = GUID::new(GuidPrefix::new(&[1; 12]), EntityId::PARTICIPANT);
    data.lease_duration = Some(Duration::from(StdDuration::from_secs(100_000)));
    assert!(discoverydb.admits_participant(data.participant_guid.prefix));
    discoverydb.update_participant(&data);
    let long_ago = Instant::now() - StdDuration::from_secs(301);
    discoverydb
      .participant_last_life_signs
      .insert(data.participant_guid.prefix, long_ago);
    let removed = discoverydb.participant_cleanup();
    assert_eq!(
      removed.len(),
      1,
      "a lease of 100,000 s was honoured past 5 minutes"
    );
    assert!(discoverydb.admits_participant(GuidPrefix::new(&[20; 12])));
  }

  // A remote reader on `prefix` with key `i`, on a topic named "t<i>-" and `name_len` x's.
  fn remote_reader(prefix: GuidPrefix, i: u32, name_len: usize) -> DiscoveredReaderData {
    let mut sub = subscription_builtin_topic_data().unwrap();
    sub.topic_name = format!("t{i}-{}", "x".repeat(name_len));
    let mut proxy = reader_proxy_data().unwrap();
    let [_, a, b, c] = i.to_be_bytes();
    proxy.remote_reader_guid = GUID::new(
      prefix,
      EntityId::new([a, b, c], EntityKind::READER_NO_KEY_USER_DEFINED),
    );
    DiscoveredReaderData {
      reader_proxy: proxy,
      subscription_topic_data: sub,
      content_filter: None,
      user_data: Vec::new(),
    }
  }

  #[test]
  fn discovery_records_beyond_the_byte_bound_are_ignored() {
    // 0018-bounded-discovery-bytes.patch.
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(1024).unwrap();
    let mut db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let mut participant = spdp_participant_data().unwrap();
    let prefix = GuidPrefix::new(&[7; 12]);
    participant.participant_guid = GUID::new(prefix, EntityId::PARTICIPANT);
    db.update_participant(&participant);
    assert_eq!(db.held_bytes(), db.recounted_bytes());
    // Room for the participant and three readers on topics of 10 kB names (each holds its
    // name three times: in its record, its topic's entry and the topic's key).
    let bound = db.held_bytes() + 100_000;
    db.set_max_discovery_bytes(bound);
    let taken = (0..1000)
      .filter(|&i| {
        db.update_subscription(&remote_reader(prefix, i, 10_000))
          .is_some()
      })
      .count();
    assert!(
      db.held_bytes() <= bound,
      "discovery holds {} bytes, more than its bound of {bound} ({taken} of 1000 readers taken)",
      db.held_bytes()
    );
    assert_eq!(taken, 3, "readers of about 30 kB each within 100 kB");
    assert_eq!(db.external_topic_readers.len(), 3);
    assert_eq!(db.records_refused, 997);
    assert_eq!(db.held_bytes(), db.recounted_bytes());
    // A known reader's update replaces its record within the bound.
    assert!(db
      .update_subscription(&remote_reader(prefix, 1, 10_000))
      .is_some());
    assert_eq!(db.held_bytes(), db.recounted_bytes());
    // A reader disposed, and its topic cleaned up, gives its room back.
    db.remove_topic_reader(remote_reader(prefix, 0, 0).reader_proxy.remote_reader_guid);
    db.topic_cleanup();
    assert_eq!(db.held_bytes(), db.recounted_bytes());
    assert!(db
      .update_subscription(&remote_reader(prefix, 2000, 10_000))
      .is_some());
    assert_eq!(db.held_bytes(), db.recounted_bytes());
    // The participant's lease expires: its readers go to the attic, their topics away. The
    // attic's readers make room for another participant's.
    db.remove_participant(prefix, false);
    db.topic_cleanup();
    assert_eq!(db.external_topic_readers_attic.len(), 3);
    assert_eq!(db.held_bytes(), db.recounted_bytes());
    let other = GuidPrefix::new(&[8; 12]);
    participant.participant_guid = GUID::new(other, EntityId::PARTICIPANT);
    db.update_participant(&participant);
    for i in 0..3 {
      assert!(
        db.update_subscription(&remote_reader(other, i, 10_000))
          .is_some(),
        "the attic's readers held the room of a live participant's reader {i}"
      );
    }
    assert!(db.external_topic_readers_attic.is_empty());
    assert!(db.held_bytes() <= bound);
    assert_eq!(db.held_bytes(), db.recounted_bytes());
    // Readers of a participant not taken in are bounded too.
    let unknown = GuidPrefix::new(&[9; 12]);
    assert!(db
      .update_subscription(&remote_reader(unknown, 0, 10_000))
      .is_none());
    assert!(db.held_bytes() <= bound);
  }

  #[test]
  fn discdb_writer_proxies() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();
    let _discoverydb = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let topic_name = String::from("some_topic");
    let type_name = String::from("RandomData");
    let _dreader = DiscoveredReaderData::default(topic_name, type_name);

    // TODO: more tests :)
  }

  #[test]
  fn discdb_subscription_operations() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();

    let mut discovery_db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );

    let domain_participant =
      DomainParticipant::new(test_domain_id(0)).expect("Failed to create publisher");
    let topic = domain_participant
      .create_topic(
        "Foobar".to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();
    let topic2 = domain_participant
      .create_topic(
        "Barfoo".to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();

    let publisher1 = domain_participant
      .create_publisher(&QosPolicies::qos_none())
      .unwrap();
    let dw = publisher1
      .create_datawriter::<RandomData, CDRSerializerAdapter<RandomData, LittleEndian>>(&topic, None)
      .unwrap();

    let writer_data = DiscoveredWriterData::new(&dw, &topic, &domain_participant, None);

    discovery_db.update_local_topic_writer(writer_data);
    assert_eq!(discovery_db.local_topic_writers.len(), 1);

    let publisher2 = domain_participant
      .create_publisher(&QosPolicies::qos_none())
      .unwrap();
    let dw2 = publisher2
      .create_datawriter::<RandomData, CDRSerializerAdapter<RandomData, LittleEndian>>(
        &topic2, None,
      )
      .unwrap();
    let writer_data2 = DiscoveredWriterData::new(&dw2, &topic2, &domain_participant, None);
    discovery_db.update_local_topic_writer(writer_data2);
    assert_eq!(discovery_db.local_topic_writers.len(), 2);

    // creating data
    let reader1 = reader_proxy_data().unwrap();
    let reader1sub = subscription_builtin_topic_data().unwrap();
    // reader1sub.set_key(reader1.remote_reader_guid);
    // reader1sub.set_topic_name(&topic.name());
    let dreader1 = DiscoveredReaderData {
      reader_proxy: reader1.clone(),
      subscription_topic_data: reader1sub.clone(),
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader1);

    let reader2 = reader_proxy_data().unwrap();
    let reader2sub = subscription_builtin_topic_data().unwrap();
    // reader2sub.set_key(reader2.remote_reader_guid);
    // reader2sub.set_topic_name(&topic2.name());
    let dreader2 = DiscoveredReaderData {
      reader_proxy: reader2,
      subscription_topic_data: reader2sub,
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader2);

    let reader3 = reader1;
    let reader3sub = reader1sub;
    let dreader3 = DiscoveredReaderData {
      reader_proxy: reader3,
      subscription_topic_data: reader3sub,
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader3);

    // TODO: there might be a need for different scenarios
  }

  #[test]
  fn discdb_external_endpoint_snapshots() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();

    let mut discovery_db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );

    // Nothing discovered yet.
    assert_eq!(discovery_db.get_all_external_topic_readers().count(), 0);
    assert_eq!(discovery_db.get_all_external_topic_writers().count(), 0);

    // Discover one external Reader via SEDP subscription data.
    let reader = reader_proxy_data().unwrap();
    let reader_sub = subscription_builtin_topic_data().unwrap();
    let dreader = DiscoveredReaderData {
      reader_proxy: reader,
      subscription_topic_data: reader_sub,
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader);

    // Discover one external Writer via SEDP publication data.
    let domain_participant =
      DomainParticipant::new(test_domain_id(0)).expect("Failed to create participant");
    let topic = domain_participant
      .create_topic(
        "Foobar".to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();
    let publisher = domain_participant
      .create_publisher(&QosPolicies::qos_none())
      .unwrap();
    let dw = publisher
      .create_datawriter::<RandomData, CDRSerializerAdapter<RandomData, LittleEndian>>(&topic, None)
      .unwrap();
    let writer_data = DiscoveredWriterData::new(&dw, &topic, &domain_participant, None);
    discovery_db.update_publication(&writer_data);

    // Both accessors return the discovered endpoints as a snapshot.
    let readers = discovery_db
      .get_all_external_topic_readers()
      .cloned()
      .collect::<Vec<_>>();
    let writers = discovery_db
      .get_all_external_topic_writers()
      .cloned()
      .collect::<Vec<_>>();
    assert_eq!(readers.len(), 1);
    assert_eq!(writers.len(), 1);
    assert_eq!(
      readers[0].reader_proxy.remote_reader_guid,
      dreader.reader_proxy.remote_reader_guid
    );
    assert_eq!(
      writers[0].writer_proxy.remote_writer_guid,
      writer_data.writer_proxy.remote_writer_guid
    );
  }

  #[test]
  fn discdb_local_topic_reader() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);

    let dp = DomainParticipant::new(test_domain_id(0)).expect("Failed to create participant");
    let topic = dp
      .create_topic(
        "some topic name".to_string(),
        "Wazzup".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();
    let mut discoverydb = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );

    // Create reader ingredients
    let (notification_sender1, _notification_receiver1) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source1, notification_event_sender1) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker1 = Arc::new(Mutex::new(None));

    let (status_sender1, _status_receiver1) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (_reader_commander1, reader_command_receiver1) =
      wake_channel::<ReaderCommand>(100, &LoopWaker::new());

    let topic_cache =
      dp.dds_cache()
        .write()
        .unwrap()
        .add_new_topic(topic.name(), topic.get_type(), &topic.qos());

    let reader1_ing = ReaderIngredients {
      guid: GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED),
      notification_sender: notification_sender1,
      status_sender: status_sender1,
      topic_name: topic.name(),
      topic_cache_handle: topic_cache.clone(),
      like_stateless: false,
      qos_policy: QosPolicies::qos_none(),
      data_reader_command_receiver: reader_command_receiver1,
      data_reader_waker: data_reader_waker1,
      poll_event_sender: notification_event_sender1,
      security_plugins: None,
      discovery_notify: None,
    };

    // Add the reader to the database and verify the info is updated
    discoverydb.update_local_topic_reader(DiscoveryDB::local_topic_reader_data(
      &dp,
      &topic,
      &reader1_ing,
      None,
    ));
    assert_eq!(discoverydb.local_topic_readers.len(), 1);
    assert_eq!(discoverydb.get_local_topic_readers(&topic).len(), 1);

    // Verify that the info does not change if the reader is added a second time
    discoverydb.update_local_topic_reader(DiscoveryDB::local_topic_reader_data(
      &dp,
      &topic,
      &reader1_ing,
      None,
    ));
    assert_eq!(discoverydb.local_topic_readers.len(), 1);
    assert_eq!(discoverydb.get_local_topic_readers(&topic).len(), 1);

    // Create second reader ingredients for the same topic
    let (notification_sender2, _notification_receiver2) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source2, notification_event_sender2) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker2 = Arc::new(Mutex::new(None));

    let (status_sender2, _status_receiver2) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (_reader_commander2, reader_command_receiver2) =
      wake_channel::<ReaderCommand>(100, &LoopWaker::new());

    let mut guid2 = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    guid2.prefix = GuidPrefix::new(b"Another fake"); // GUID needs to be different in order to be added

    let reader2_ing = ReaderIngredients {
      guid: guid2,
      notification_sender: notification_sender2,
      status_sender: status_sender2,
      topic_name: topic.name(),
      topic_cache_handle: topic_cache,
      like_stateless: false,
      qos_policy: QosPolicies::qos_none(),
      data_reader_command_receiver: reader_command_receiver2,
      data_reader_waker: data_reader_waker2,
      poll_event_sender: notification_event_sender2,
      security_plugins: None,
      discovery_notify: None,
    };

    // Add the second reader to the database and verify the info is updated
    discoverydb.update_local_topic_reader(DiscoveryDB::local_topic_reader_data(
      &dp,
      &topic,
      &reader2_ing,
      None,
    ));
    assert_eq!(discoverydb.get_local_topic_readers(&topic).len(), 2);
    assert_eq!(discoverydb.get_all_local_topic_readers().count(), 2);
  }
}
