use std::{
  collections::BTreeMap,
  fmt, iter,
  rc::Rc,
  sync::{Arc, Mutex, MutexGuard},
  task::Waker,
  time::{Duration as StdDuration, Instant},
};

use mio1::Token;
use log::{debug, error, info, trace, warn};
use enumflags2::BitFlags;
use speedy::Endianness;
#[cfg(feature = "security")]
use speedy::Writable;

use crate::{
  dds::{
    ddsdata::DDSData,
    qos::{policy, HasQoSPolicy, QosPolicies},
    statusevents::{
      CountWithChange, DataReaderStatus, DomainParticipantStatusEvent, StatusChannelSender,
    },
    with_key::{
      datawriter::{WriteOptions, WriteOptionsBuilder},
      simpledatareader::ReaderCommand,
    },
  },
  messages::{
    header::Header,
    protocol_id::ProtocolId,
    protocol_version::ProtocolVersion,
    submessages::{
      elements::{
        inline_qos::InlineQos, parameter_list::ParameterList, serialized_payload::SerializedPayload,
      },
      submessages::*,
    },
    vendor_id::VendorId,
  },
  mio_source,
  network::udp_sender::UDPSender,
  polling::{ReadySender, SharedTimer, WakeReceiver},
  rtps::{
    constant::{
      HEARTBEAT_RESPONSE_DELAY, HEARTBEAT_SUPPRESSION_DURATION, QUIET_POLL_DELAY, QUIET_POLL_MAX,
      QUIET_POLL_SPACING,
    },
    fragment_assembler::{FragmentAssembler, BUILTIN_MAX_SAMPLE_SIZE, DEFAULT_MAX_SAMPLE_SIZE},
    message_receiver::MessageReceiverState,
    rtps_writer_proxy::RtpsWriterProxy,
    timed_event::DpTimerEvent,
    Message,
  },
  structure::{
    cache_change::{CacheChange, ChangeKind},
    dds_cache::TopicCache,
    duration::Duration,
    entity::RTPSEntity,
    guid::{EntityId, GuidPrefix, GUID},
    locator::Locator,
    sequence_number::{FragmentNumber, FragmentNumberSet, SequenceNumber, SequenceNumberSet},
    time::Timestamp,
  },
};
#[cfg(feature = "security")]
use super::Submessage;
#[cfg(feature = "security")]
use crate::security::{security_plugins::SecurityPluginsHandle, SecurityResult};
#[cfg(not(feature = "security"))]
use crate::no_security::SecurityPluginsHandle;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TimedEvent {
  DeadlineMissedCheck,
  // Patched for grasp_orient (0009-heartbeat-response-delay.patch): the heartbeat response
  // delay of this writer's HEARTBEAT has passed; answer it now.
  HeartbeatResponse { writer_guid: GUID },
  // Patched for grasp_orient (0011-quiet-writer-poll.patch): time to see whether this writer
  // has been quiet long enough after DATA to be polled.
  QuietPoll { writer_guid: GUID },
  // Patched for grasp_orient (0015-bounded-fragment-assembly.patch): drop the incomplete
  // fragment assemblies that received nothing for FRAGMENT_ASSEMBLY_TIMEOUT.
  FragmentGc,
}

// Patched for grasp_orient (0011-quiet-writer-poll.patch): per writer, what the reader knows of
// its last activity, for the poll of a writer that went quiet after DATA.
#[derive(Clone, Debug)]
struct QuietPoll {
  last_data: Instant,
  // A HEARTBEAT came QUIET_POLL_DELAY or more after the last DATA: the writer has said what it
  // wrote. One that comes sooner may have been sent just before the writer's next DATA, lost,
  // and so does not end the polls (it still says what is announced).
  heard_heartbeat: bool,
  // The highest sequence number a HEARTBEAT announced (the writer wrote it).
  announced: SequenceNumber,
  // Polls sent since the last DATA, and when the last poll (of any quiet period) went out.
  polls: u32,
  last_poll: Option<Instant>,
  // The writer's messages come from Fast DDS (RTPS vendor id 1.15).
  fast_dds: bool,
  // A QuietPoll timed event is pending for this writer.
  timer_armed: bool,
}

// Patched for grasp_orient (0009-heartbeat-response-delay.patch): what a HEARTBEAT (or several
// merged while the answer waits) asks the reader to answer.
#[derive(Clone, Debug)]
struct HeartbeatToAnswer {
  first_sn: SequenceNumber,
  last_sn: SequenceNumber,
  // Every merged HEARTBEAT had the final flag: answer only if something is missing.
  final_flag_set: bool,
  source_guid_prefix: GuidPrefix,
  reply_locators: Vec<Locator>,
}

// Some pieces necessary to construct a reader.
// These can be sent between threads, whereas a Reader cannot.
pub(crate) struct ReaderIngredients {
  pub guid: GUID,
  pub notification_sender: crate::mio_source::NotificationSender,
  pub status_sender: StatusChannelSender<DataReaderStatus>,
  pub topic_name: String,
  pub(crate) topic_cache_handle: Arc<Mutex<TopicCache>>, /* A handle to the topic cache in DDS
                                                          * cache */
  pub(crate) like_stateless: bool, // Usually false (see like_stateless attribute of Reader)
  pub qos_policy: QosPolicies,
  pub data_reader_command_receiver: WakeReceiver<ReaderCommand>,
  pub(crate) data_reader_waker: Arc<Mutex<Option<Waker>>>,
  pub(crate) poll_event_sender: mio_source::PollEventSender,
  /// When this reader is a built-in discovery reader, cache changes also wake
  /// Discovery's mio 1.2 poll with the reader's discovery token.
  pub(crate) discovery_notify: Option<(ReadySender<mio1::Token>, mio1::Token)>,

  pub(crate) security_plugins: Option<SecurityPluginsHandle>,
}

impl fmt::Debug for ReaderIngredients {
  // Need manual implementation, because channels cannot be Debug formatted.
  fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    f.debug_struct("Reader")
      .field("my_guid", &self.guid)
      .field("topic_name", &self.topic_name)
      .field("qos_policy", &self.qos_policy)
      .finish()
  }
}

pub(crate) struct Reader {
  // Should the instant be sent?
  notification_sender: crate::mio_source::NotificationSender,
  status_sender: StatusChannelSender<DataReaderStatus>,
  udp_sender: Rc<UDPSender>,

  // By default, this reader is a StatefulReader (see RTPS spec section 8.4.12)
  // If like_stateless is true, then the reader mimics the behavior of a StatelessReader
  // This means for example that the reader does not keep track of matched remote writers.
  // This behavior is needed only for a single built-in discovery topic of Secure DDS
  // (topic DCPSParticipantStatelessMessage)
  like_stateless: bool,
  // Reliability Qos. Note that a StatelessReader cannot be Reliable (RTPS Spec: Section 8.4.11.2)
  reliability: policy::Reliability,
  // Reader stores a pointer to a mutex on the topic cache
  topic_cache: Arc<Mutex<TopicCache>>,

  #[cfg(test)]
  seqnum_instant_map: BTreeMap<SequenceNumber, Timestamp>,

  topic_name: String,
  qos_policy: QosPolicies,

  my_guid: GUID,

  // RTPS 2.5 8.4.15.x: how long the reader waits before it answers a HEARTBEAT, and for how
  // long after an answer it ignores HEARTBEATs that announce nothing newer (patched for
  // grasp_orient, 0009-heartbeat-response-delay.patch; both were unused before).
  heartbeat_response_delay: StdDuration,
  heartbeat_suppression_duration: StdDuration,
  // Per writer: the HEARTBEAT answer waiting for its delay, and when the last answer went out
  // with the last_sn it covered.
  heartbeats_to_answer: BTreeMap<GUID, HeartbeatToAnswer>,
  heartbeats_answered: BTreeMap<GUID, (Instant, SequenceNumber)>,
  // Per writer, for the poll of a writer that went quiet after DATA (0011-quiet-writer-poll.patch).
  quiet_polls: BTreeMap<GUID, QuietPoll>,

  received_heartbeat_count: i32,

  fragment_assemblers: BTreeMap<GUID, FragmentAssembler>,
  last_fragment_garbage_collect: Timestamp,
  // Patched for grasp_orient (0015-bounded-fragment-assembly.patch): the largest sample this
  // reader assembles from DATA_FRAGs (a larger claimed sampleSize is dropped unallocated), the
  // most bytes all its incomplete assemblies may hold together, whether a FragmentGc timeout is
  // pending, and when an oversized claim was last logged at warn level.
  max_sample_size: usize,
  assembly_budget: usize,
  fragment_assembly_timeout: Duration,
  fragment_gc_armed: bool,
  oversize_warned_at: Option<Instant>,
  matched_writers: BTreeMap<GUID, RtpsWriterProxy>,
  writer_match_count_total: i32, // total count, never decreases

  requested_deadline_missed_count: i32,
  offered_incompatible_qos_count: i32,

  pub(crate) timed_event_timer: SharedTimer<DpTimerEvent>,
  pub(crate) data_reader_command_receiver: WakeReceiver<ReaderCommand>,
  data_reader_waker: Arc<Mutex<Option<Waker>>>,
  poll_event_sender: mio_source::PollEventSender,
  discovery_notify: Option<(ReadySender<mio1::Token>, mio1::Token)>,

  participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,

  #[allow(dead_code)] // to avoid warning if no security feature
  security_plugins: Option<SecurityPluginsHandle>,
}

// If we are assembling a fragment, but it does not receive any updates
// for this time, the AssemblyBuffer is just dropped.
const FRAGMENT_ASSEMBLY_TIMEOUT: Duration = Duration::from_secs(10);
// minimum interval (max frequency) of AssemblyBuffer GC
const MIN_FRAGMENT_GC_INTERVAL: Duration = Duration::from_secs(2);
// Patched for grasp_orient (0015-bounded-fragment-assembly.patch): what the incomplete
// assemblies of a built-in reader may hold together, 16 samples of the largest size it takes
// (the SPDP reader assembles from any participant, discovered or not); and how often an
// oversized claim is logged at warn level (the others go to debug).
const BUILTIN_ASSEMBLY_BUDGET: usize = 16 * BUILTIN_MAX_SAMPLE_SIZE;
const OVERSIZE_WARNING_INTERVAL: StdDuration = StdDuration::from_secs(10);

impl Reader {
  pub(crate) fn new(
    i: ReaderIngredients,
    udp_sender: Rc<UDPSender>,
    timed_event_timer: SharedTimer<DpTimerEvent>,
    participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,
  ) -> Self {
    // Verify that the topic cache corresponds to the topic of the Reader
    let topic_cache_name = i.topic_cache_handle.lock().unwrap().topic_name();
    if i.topic_name != topic_cache_name {
      panic!(
        "RustDDS internal bug: topic name {} and topic cache name {} differ when creating a Reader",
        i.topic_name, topic_cache_name
      );
    }

    // If reader should be stateless, only BestEffort QoS is supported
    if i.like_stateless && i.qos_policy.is_reliable() {
      panic!("RustDDS internal bug: attempted to create a stateless Reader with Reliable QoS");
    }

    Self {
      notification_sender: i.notification_sender,
      status_sender: i.status_sender,
      udp_sender,
      like_stateless: i.like_stateless,
      reliability: i
        .qos_policy
        .reliability() // use qos specification
        .unwrap_or(policy::Reliability::BestEffort), // or default to BestEffort
      topic_cache: i.topic_cache_handle,
      topic_name: i.topic_name,
      qos_policy: i.qos_policy,

      #[cfg(test)]
      seqnum_instant_map: BTreeMap::new(),
      my_guid: i.guid,

      heartbeat_response_delay: HEARTBEAT_RESPONSE_DELAY,
      heartbeat_suppression_duration: HEARTBEAT_SUPPRESSION_DURATION,
      heartbeats_to_answer: BTreeMap::new(),
      heartbeats_answered: BTreeMap::new(),
      quiet_polls: BTreeMap::new(),
      received_heartbeat_count: 0,
      fragment_assemblers: BTreeMap::new(),
      last_fragment_garbage_collect: Timestamp::now(),
      max_sample_size: if i.guid.entity_id.entity_kind.is_user_defined() {
        DEFAULT_MAX_SAMPLE_SIZE
      } else {
        BUILTIN_MAX_SAMPLE_SIZE
      },
      assembly_budget: if i.guid.entity_id.entity_kind.is_user_defined() {
        Self::user_assembly_budget(DEFAULT_MAX_SAMPLE_SIZE)
      } else {
        BUILTIN_ASSEMBLY_BUDGET
      },
      fragment_assembly_timeout: FRAGMENT_ASSEMBLY_TIMEOUT,
      fragment_gc_armed: false,
      oversize_warned_at: None,
      matched_writers: BTreeMap::new(),
      writer_match_count_total: 0,
      requested_deadline_missed_count: 0,
      offered_incompatible_qos_count: 0,
      timed_event_timer,
      data_reader_command_receiver: i.data_reader_command_receiver,
      data_reader_waker: i.data_reader_waker,
      poll_event_sender: i.poll_event_sender,
      discovery_notify: i.discovery_notify,
      participant_status_sender,

      security_plugins: i.security_plugins,
    }
  }
  // TODO: check if it's necessary to implement different handlers for discovery
  // and user messages

  /// Entity id encoded as a mio token. The internal poll no longer registers
  /// per-reader tokens; the ready queue carries the id instead.
  #[allow(dead_code)]
  pub fn entity_token(&self) -> Token {
    self.guid().entity_id.as_token()
  }

  pub fn set_requested_deadline_check_timer(&mut self) {
    if let Some(deadline) = self.qos_policy.deadline {
      debug!(
        "GUID={:?} set_requested_deadline_check_timer: {:?}",
        self.my_guid,
        deadline.0.to_std()
      );
      self.timed_event_timer.borrow_mut().set_timeout(
        deadline.0.to_std(),
        DpTimerEvent::Reader {
          entity_id: self.my_guid.entity_id,
          event: TimedEvent::DeadlineMissedCheck,
        },
      );
    } else {
      trace!(
        "GUID={:?} - no deadline policy - do not set set_requested_deadline_check_timer",
        self.my_guid
      );
    }
  }

  pub fn send_status_change(&self, change: DataReaderStatus) {
    match self.status_sender.try_send_impl(change) {
      Ok(()) => (), // expected result
      Err(std::sync::mpsc::TrySendError::Full(_)) => {
        // TODO: dead code. `StatusChannelSender::try_send` currently converts a
        // full channel into `Ok(())` (dropping the event), so this arm is never
        // reached. Kept because the handling is correct if `try_send` is ever
        // made to return `Full` again (cf. PR #442).
        trace!("Reader cannot send new status changes, datareader is full.");
        // It is perfectly normal to fail due to full channel, because
        // no-one is required to be listening to these.
      }
      Err(std::sync::mpsc::TrySendError::Disconnected(_)) => {
        // If we get here, our DataReader has died. The Reader should now dispose
        // itself. Or possibly it has lost the receiver object, which is sort of
        // sloppy, but does not necessarily mean the end of the world.
        // TODO: Implement Reader disposal.
        info!("send_status_change - cannot send status, DataReader Disconnected.");
      }
    }
  }

  fn send_participant_status(&self, event: DomainParticipantStatusEvent) {
    self
      .participant_status_sender
      .try_send(event)
      .unwrap_or_else(|e| error!("Cannot report participant status: {e:?}"));
  }

  // The deadline that the DataReader was expecting through its QosPolicy
  // DEADLINE was not respected for a specific instance
  // if statusChange is returned it should be send to DataReader
  // this calculation should be repeated every self.qos_policy.deadline
  fn calculate_if_requested_deadline_is_missed(&mut self) -> Vec<DataReaderStatus> {
    debug!("calculate_if_requested_deadline_is_missed");

    let deadline_duration = match self.qos_policy.deadline {
      None => return vec![],
      Some(policy::Deadline(deadline_duration)) => deadline_duration,
    };

    let mut changes: Vec<DataReaderStatus> = vec![];
    let now = Timestamp::now();
    for writer_proxy in self.matched_writers.values_mut() {
      if let Some(last_change) = writer_proxy.last_change_timestamp() {
        let since_last = now.duration_since(last_change);
        // if time singe last received message is greater than deadline increase status
        // and return notification.
        trace!("Comparing deadlines: {since_last:?} - {deadline_duration:?}");
        if since_last > deadline_duration {
          debug!("Deadline missed: {since_last:?} - {deadline_duration:?}");
          self.requested_deadline_missed_count += 1;
          changes.push(DataReaderStatus::RequestedDeadlineMissed {
            count: CountWithChange::start_from(self.requested_deadline_missed_count, 1),
          });
        }
      } else {
        // no messages received ever so deadline must be missed.
        // TODO: But what if the Reader or WriterProxy was just created?
        self.requested_deadline_missed_count += 1;
        changes.push(DataReaderStatus::RequestedDeadlineMissed {
          count: CountWithChange::start_from(self.requested_deadline_missed_count, 1),
        });
      }
    } // for
    changes
  } // fn

  // Handle a single timed event. The shared timer is drained by the event loop,
  // which dispatches each expired event to the addressed Reader.
  pub fn handle_timed_event(&mut self, event: TimedEvent) {
    match event {
      TimedEvent::DeadlineMissedCheck => {
        self.handle_requested_deadline_event();
        self.set_requested_deadline_check_timer(); // re-prime timer
      }
      TimedEvent::HeartbeatResponse { writer_guid } => {
        if let Some(to_answer) = self.heartbeats_to_answer.remove(&writer_guid) {
          self.answer_heartbeat(writer_guid, &to_answer);
        }
      }
      TimedEvent::QuietPoll { writer_guid } => self.quiet_poll_due(writer_guid),
      TimedEvent::FragmentGc => {
        self.fragment_gc_armed = false;
        self.last_fragment_garbage_collect = Timestamp::now();
        self.collect_expired_fragments();
        self.arm_fragment_gc();
      }
    }
  }

  pub fn process_command(&mut self) {
    trace!("process_command {:?}", self.my_guid);
    loop {
      use std::sync::mpsc::TryRecvError;
      match self.data_reader_command_receiver.try_recv() {
        Ok(ReaderCommand::ResetRequestedDeadlineStatus) => {
          warn!("RESET_REQUESTED_DEADLINE_STATUS not implemented!");
          // TODO: This should be implemented.
        }
        // Disconnected is normal when terminating
        Err(TryRecvError::Disconnected) => {
          trace!("DataReader disconnected");
          break;
        }
        Err(TryRecvError::Empty) => {
          warn!("There was no command. Spurious command event??");
          break;
        }
      }
    }
  }

  fn handle_requested_deadline_event(&mut self) {
    debug!("handle_requested_deadline_event");
    for missed_deadline in self.calculate_if_requested_deadline_is_missed() {
      self.send_status_change(missed_deadline);
    }
  }

  // TODO Used for test/debugging purposes
  #[cfg(test)]
  pub fn history_cache_change_data(&self, sequence_number: SequenceNumber) -> Option<DDSData> {
    let topic_cache = self.acquire_the_topic_cache_guard();
    let cc = self
      .seqnum_instant_map
      .get(&sequence_number)
      .and_then(|i| topic_cache.get_change(i));

    debug!("history cache !!!! {cc:?}");

    cc.map(|cc| cc.data_value.clone())
  }

  // TODO Used for test/debugging purposes
  #[cfg(test)]
  pub fn history_cache_sequence_start_and_end_numbers(&self) -> Vec<SequenceNumber> {
    if self.seqnum_instant_map.is_empty() {
      vec![]
    } else {
      let start = self.seqnum_instant_map.iter().min().unwrap().0;
      let end = self.seqnum_instant_map.iter().max().unwrap().0;
      vec![*start, *end]
    }
  }

  // updates or adds a new writer proxy, doesn't touch changes
  pub fn update_writer_proxy(&mut self, proxy: RtpsWriterProxy, offered_qos: &QosPolicies) {
    if self.like_stateless {
      debug!(
        "Attempted to update writer proxy for stateless reader. Ignoring. topic={:?}",
        self.topic_name
      );
      return;
    }

    debug!("update_writer_proxy topic={:?}", self.topic_name);
    let writer = proxy.remote_writer_guid;

    match offered_qos.compliance_failure_wrt(&self.qos_policy) {
      None => {
        // success, update or insert
        let count_change = self.matched_writer_update(proxy);
        if count_change > 0 {
          self.writer_match_count_total += count_change;
          self.send_status_change(DataReaderStatus::SubscriptionMatched {
            total: CountWithChange::new(self.writer_match_count_total, count_change),
            current: CountWithChange::new(self.matched_writers.len() as i32, count_change),
            writer,
          });
          self.send_participant_status(DomainParticipantStatusEvent::RemoteWriterMatched {
            local_reader: self.my_guid,
            remote_writer: writer,
          });

          info!(
            "Matched new remote writer on topic={:?} writer={:?}",
            self.topic_name, writer
          );

          // The writer may have matched us earlier and sent its HEARTBEAT before we
          // knew it, so that HEARTBEAT was discarded. Without a request the next
          // one comes only after the writer's heartbeat period, and a Reliable
          // reader withholds all samples received in the meantime.
          if self.reliability != policy::Reliability::BestEffort {
            if let Some(mut writer_proxy) = self.matched_writers.remove(&writer) {
              self.send_preemptive_acknack_to(&mut writer_proxy);
              self.matched_writers.insert(writer, writer_proxy);
            }
          }
        }
      }
      Some(bad_policy_id) => {
        // no QoS match.
        self.offered_incompatible_qos_count += 1;
        self.send_status_change(DataReaderStatus::RequestedIncompatibleQos {
          count: CountWithChange::new(self.offered_incompatible_qos_count, 1),
          last_policy_id: bad_policy_id,
          writer,
          requested_qos: Box::new(self.qos_policy.clone()),
          offered_qos: Box::new(offered_qos.clone()),
        });
        self.send_participant_status(DomainParticipantStatusEvent::RemoteWriterQosIncompatible {
          local_reader: self.my_guid,
          remote_writer: writer,
          requested_qos: Box::new(self.qos_policy.clone()),
          offered_qos: Box::new(offered_qos.clone()),
        });

        warn!("update_writer_proxy - QoS mismatch {bad_policy_id:?}");
        info!(
          "update_writer_proxy - QoS mismatch: topic={:?} requested={:?}  offered={:?}",
          self.topic_name, self.qos_policy, offered_qos
        );
      }
    }
  }

  // return value counts how many new proxies were added
  fn matched_writer_update(&mut self, proxy: RtpsWriterProxy) -> i32 {
    if let Some(op) = self.matched_writer_mut(proxy.remote_writer_guid) {
      op.update_contents(proxy);
      0
    } else {
      self.matched_writers.insert(proxy.remote_writer_guid, proxy);
      1
    }
  }

  pub fn remove_writer_proxy(&mut self, writer_guid: GUID) {
    self.heartbeats_to_answer.remove(&writer_guid);
    self.heartbeats_answered.remove(&writer_guid);
    self.quiet_polls.remove(&writer_guid);
    self.fragment_assemblers.remove(&writer_guid);
    if self.matched_writers.contains_key(&writer_guid) {
      self.matched_writers.remove(&writer_guid);
      self
        .acquire_the_topic_cache_guard()
        .forget_reliable_writer(writer_guid);
      #[cfg(feature = "security")]
      if let Some(security_plugins_handle) = &self.security_plugins {
        security_plugins_handle
          .get_plugins()
          .unregister_remote_writer(&self.my_guid, &writer_guid)
          .unwrap_or_else(|e| error!("{e}"));
      }
      self.send_status_change(DataReaderStatus::SubscriptionMatched {
        total: CountWithChange::new(self.writer_match_count_total, 0),
        current: CountWithChange::new(self.matched_writers.len() as i32, -1),
        writer: writer_guid,
      });
    }
  }

  // Entire remote participant was lost.
  // Remove all remote writers belonging to it.
  pub fn participant_lost(&mut self, guid_prefix: GuidPrefix) {
    let lost_writers: Vec<GUID> = self
      .matched_writers
      .range(guid_prefix.range())
      .map(|(g, _)| *g)
      .collect();
    for writer in lost_writers {
      self.remove_writer_proxy(writer);
    }
  }

  pub fn contains_writer(&self, entity_id: EntityId) -> bool {
    if !self.like_stateless {
      self
        .matched_writers
        .iter()
        .any(|(&g, _)| g.entity_id == entity_id)
    } else {
      // Making it explicit: stateless reader does not contain any writers
      false
    }
  }

  #[cfg(test)]
  pub(crate) fn matched_writer_add(
    &mut self,
    remote_writer_guid: GUID,
    remote_group_entity_id: EntityId,
    unicast_locator_list: Vec<Locator>,
    multicast_locator_list: Vec<Locator>,
    qos: &QosPolicies,
  ) {
    let proxy = RtpsWriterProxy::new(
      remote_writer_guid,
      unicast_locator_list,
      multicast_locator_list,
      remote_group_entity_id,
    );
    self.update_writer_proxy(proxy, qos);
  }

  fn matched_writer(&self, remote_writer_guid: GUID) -> Option<&RtpsWriterProxy> {
    self.matched_writers.get(&remote_writer_guid)
  }

  fn matched_writer_mut(&mut self, remote_writer_guid: GUID) -> Option<&mut RtpsWriterProxy> {
    self.matched_writers.get_mut(&remote_writer_guid)
  }

  // handles regular data message and updates history cache
  pub fn handle_data_msg(
    &mut self,
    data: Data,
    data_flags: BitFlags<DATA_Flags>,
    mr_state: &MessageReceiverState,
  ) {
    // trace!("handle_data_msg entry");
    let receive_timestamp = Timestamp::now();

    // parse write_options out of the message
    let mut write_options_b = WriteOptionsBuilder::new();
    // Check if we have s source timestamp
    if let Some(source_timestamp) = mr_state.source_timestamp {
      write_options_b = write_options_b.source_timestamp(source_timestamp);
    }
    // Check if the message specifies a related_sample_identity
    let representation_identifier = DATA_Flags::cdr_representation_identifier(data_flags);
    if let Some(related_sample_identity) =
      data.inline_qos.as_ref().and_then(|inline_qos_parameters| {
        InlineQos::related_sample_identity(inline_qos_parameters, representation_identifier)
          .unwrap_or_else(|e| {
            error!("Deserializing related_sample_identity: {:?}", e);
            None
          })
      })
    {
      write_options_b = write_options_b.related_sample_identity(related_sample_identity);
    }

    let writer_guid = GUID::new_with_prefix_and_id(mr_state.source_guid_prefix, data.writer_id);
    let writer_seq_num = data.writer_sn; // for borrow checker
    // Patched for grasp_orient (0008-nack-on-gap.patch): the highest sequence number received
    // from this writer before this DATA, to see whether it reveals a gap.
    let highest_before = self.gap_watch(writer_guid);

    match self.data_to_dds_data(data, data_flags) {
      Ok(dds_data) => self.process_received_data(
        dds_data,
        receive_timestamp,
        write_options_b.build(),
        writer_guid,
        writer_seq_num,
      ),
      // Patched for grasp_orient (0003-data-without-payload.patch): a DATA without a usable payload
      // (Fast DDS sends a zero-length serialized message as DATA with no payload and no flags)
      // still takes up its sequence number. Dropped here, it was never marked received, so a
      // reliable reader held back every later sample of that writer until the writer's history
      // let go of it. A user topic's reader now gets an empty sample, which fails to decode
      // where the application can see and count it, and the stream goes on.
      Err(e) if self.my_guid.entity_id.entity_kind.is_user_defined() => {
        info!(
          "DATA seq={writer_seq_num:?} from {writer_guid:?} on topic {:?} has no usable payload \
           ({e}); delivered as an empty sample",
          self.topic_name
        );
        let empty = SerializedPayload::new(representation_identifier, Vec::new());
        self.process_received_data(
          DDSData::new(empty),
          receive_timestamp,
          write_options_b.build(),
          writer_guid,
          writer_seq_num,
        );
      }
      Err(e) => debug!("Parsing DATA to DDSData failed: {e}"),
    }
    if let Some(highest) = highest_before {
      if highest > SequenceNumber::zero() && writer_seq_num > highest + SequenceNumber::new(1) {
        self.nack_revealed_gap(writer_guid, writer_seq_num, mr_state);
      }
      self.note_data_for_quiet_poll(writer_guid, mr_state);
    }
  }

  // The highest sequence number received from `writer_guid`, for a reliable stateful reader of
  // a user topic (the ones that NACK a gap at once); None for the others.
  fn gap_watch(&self, writer_guid: GUID) -> Option<SequenceNumber> {
    if self.like_stateless
      || self.reliability == policy::Reliability::BestEffort
      || !self.my_guid.entity_id.entity_kind.is_user_defined()
    {
      return None;
    }
    self
      .matched_writer(writer_guid)
      .map(RtpsWriterProxy::highest_received)
  }

  // A DATA beyond the next expected sequence number proves that the ones between were lost
  // (a writer sends in order): ask for them now with an ACKNACK (final flag set, so no
  // HEARTBEAT is requested), instead of waiting for the writer's next HEARTBEAT, which Fast
  // DDS sends every 3 s. One ACKNACK per gap revealed; if it or the repair is lost, the
  // HEARTBEAT still brings the samples, as before.
  fn nack_revealed_gap(
    &mut self,
    writer_guid: GUID,
    revealed_by: SequenceNumber,
    mr_state: &MessageReceiverState,
  ) {
    let reader_id = self.entity_id();
    let Some(writer_proxy) = self.matched_writer_mut(writer_guid) else {
      return;
    };
    let below = revealed_by - SequenceNumber::new(1);
    let missing = writer_proxy.missing_seqnums(writer_proxy.all_ackable_before(), below);
    let Some(&first_missing) = missing.first() else {
      return;
    };
    let set = missing
      .iter()
      .copied()
      .take_while(|sn| *sn < first_missing + SequenceNumber::new(256))
      .collect();
    let acknack = AckNack {
      reader_id,
      writer_id: writer_guid.entity_id,
      reader_sn_state: SequenceNumberSet::from_base_and_set(first_missing, &set),
      count: writer_proxy.next_ack_nack_sequence_number(),
    };
    let reply_locators = match mr_state.unicast_reply_locator_list {
      [] | [Locator::Invalid] => writer_proxy.unicast_locator_list.clone(),
      others => others.to_vec(),
    };
    debug!(
      "DATA {revealed_by:?} from {writer_guid:?} reveals {} missing from {first_missing:?}: \
       NACK at once. topic={:?}",
      missing.len(),
      self.topic_name
    );
    let flags = BitFlags::<ACKNACK_Flags>::from_flag(ACKNACK_Flags::Endianness)
      | BitFlags::<ACKNACK_Flags>::from_flag(ACKNACK_Flags::Final);
    self.send_acknack_to(
      flags,
      acknack,
      InfoDestination {
        guid_prefix: mr_state.source_guid_prefix,
      },
      &reply_locators,
      writer_guid,
    );
  }

  // Patched for grasp_orient (0011-quiet-writer-poll.patch). A reliable reader learns of a lost
  // DATA from a later DATA (0008) or from the writer's HEARTBEAT. When the lost one is the last
  // of a burst (or the repair of one), no later DATA comes, and Fast DDS's next periodic
  // HEARTBEAT is up to 3 s away; a non-final ACKNACK that only acknowledges does not bring one
  // sooner from Fast DDS, whose periodic HEARTBEAT timer is already running. So a writer that
  // goes quiet after DATA, with no HEARTBEAT since that came QUIET_POLL_DELAY or more after it,
  // is polled (see QUIET_POLL_DELAY for the timing and the bounds). Called for every DATA and
  // DATA_FRAG from a writer of a reliable user topic's reader; nothing is polled before the
  // first DATA (the preemptive ACKNACK is for that).
  fn note_data_for_quiet_poll(&mut self, writer_guid: GUID, mr_state: &MessageReceiverState) {
    let now = Instant::now();
    let fast_dds = mr_state.source_vendor_id == VendorId::EPROSIMA;
    let quiet = self
      .quiet_polls
      .entry(writer_guid)
      .or_insert_with(|| QuietPoll {
        last_data: now,
        heard_heartbeat: false,
        announced: SequenceNumber::zero(),
        polls: 0,
        last_poll: None,
        fast_dds,
        timer_armed: false,
      });
    quiet.last_data = now;
    quiet.heard_heartbeat = false;
    quiet.polls = 0;
    quiet.fast_dds = fast_dds;
    if !quiet.timer_armed {
      quiet.timer_armed = true;
      self.arm_quiet_poll(writer_guid, QUIET_POLL_DELAY);
    }
  }

  fn arm_quiet_poll(&self, writer_guid: GUID, after: StdDuration) {
    self.timed_event_timer.borrow_mut().set_timeout(
      after,
      DpTimerEvent::Reader {
        entity_id: self.my_guid.entity_id,
        event: TimedEvent::QuietPoll { writer_guid },
      },
    );
  }

  // When the next poll of this writer is due: QUIET_POLL_DELAY after the last DATA, then twice
  // as long after each poll; never sooner than QUIET_POLL_SPACING after the last poll.
  fn quiet_poll_due_at(quiet: &QuietPoll) -> Instant {
    let due = match (quiet.polls, quiet.last_poll) {
      (0, _) | (_, None) => quiet.last_data + QUIET_POLL_DELAY,
      (n, Some(last)) => last + QUIET_POLL_DELAY * 2u32.saturating_pow(n.min(16)),
    };
    match quiet.last_poll {
      Some(last) => due.max(last + QUIET_POLL_SPACING),
      None => due,
    }
  }

  fn quiet_poll_due(&mut self, writer_guid: GUID) {
    let Some(quiet) = self.quiet_polls.get_mut(&writer_guid) else {
      return; // the writer was unmatched
    };
    quiet.timer_armed = false;
    let now = Instant::now();
    let mut due = Self::quiet_poll_due_at(quiet);
    // An answer to a HEARTBEAT (waiting, or sent within QUIET_POLL_SPACING) already tells the
    // writer what the reader has: no poll beside it.
    if let Some(&(answered_at, _)) = self.heartbeats_answered.get(&writer_guid) {
      due = due.max(answered_at + QUIET_POLL_SPACING);
    }
    if self.heartbeats_to_answer.contains_key(&writer_guid) {
      due = due.max(now + self.heartbeat_response_delay);
    }
    if now < due {
      quiet.timer_armed = true;
      self.arm_quiet_poll(writer_guid, due - now);
      return;
    }
    let (heard_heartbeat, polls, fast_dds, announced) = (
      quiet.heard_heartbeat,
      quiet.polls,
      quiet.fast_dds,
      quiet.announced,
    );
    let Some(writer_proxy) = self.matched_writers.get(&writer_guid) else {
      return;
    };
    // Only what the writer is known to have written: up to the highest sequence number received
    // or announced by a HEARTBEAT. Never a speculative NACK past that, which a writer may answer
    // with a GAP that would make the reader drop the real sample when it comes.
    let known = writer_proxy.highest_received().max(announced);
    let missing = if writer_proxy.all_ackable_before() <= known {
      writer_proxy.missing_seqnums(writer_proxy.all_ackable_before(), known)
    } else {
      Vec::new()
    };
    if (heard_heartbeat && missing.is_empty()) || polls >= QUIET_POLL_MAX {
      return; // settled, or the writer's HEARTBEAT will do
    }
    self.send_quiet_poll(writer_guid, &missing, fast_dds);
    if let Some(quiet) = self.quiet_polls.get_mut(&writer_guid) {
      quiet.polls += 1;
      quiet.last_poll = Some(now);
      if quiet.polls < QUIET_POLL_MAX {
        let next = Self::quiet_poll_due_at(quiet);
        quiet.timer_armed = true;
        self.arm_quiet_poll(writer_guid, next.saturating_duration_since(now));
      }
    }
  }

  // The poll itself, one ACKNACK with the final flag clear (RTPS 2.5 8.3.7.1: the reader asks
  // for a response; a reader may send an ACKNACK at any time):
  // - something is missing: the reader's state, base at the first missing sequence number and
  //   the missing ones (at most 256) in the set; a writer resends them (GAP for ones it no
  //   longer has). A sample of which fragments arrived is left out of the set (the HEARTBEAT
  //   answer asks for its fragments with a NACK_FRAG).
  // - nothing is missing, Fast DDS writer, VOLATILE reader: bitmapBase 0 and an empty set, what
  //   Fast DDS calls a preemptive ACKNACK: its StatefulWriter::process_acknack answers it with a
  //   HEARTBEAT to this reader at once, which the reader answers (after its heartbeat response
  //   delay) with a NACK of what was lost. The spec requires bitmapBase >= 1 (8.3.5.5), so base 0
  //   is a Fast DDS interoperability convention, sent only to writers whose messages carry
  //   eProsima's vendor id. It acknowledges nothing; for a non-VOLATILE reader Fast DDS takes
  //   base 0 as a request to resend its history, hence VOLATILE only.
  // - nothing is missing, any other writer or reader: base at what the reader can acknowledge
  //   and an empty set. This crate's writer answers it with a HEARTBEAT when the reader has not
  //   acknowledged all it wrote; Cyclone DDS answers a non-final ACKNACK with a HEARTBEAT.
  fn send_quiet_poll(&mut self, writer_guid: GUID, missing: &[SequenceNumber], fast_dds: bool) {
    let reader_id = self.entity_id();
    let volatile = matches!(
      self.qos_policy.durability(),
      None | Some(policy::Durability::Volatile)
    );
    let partial: Vec<SequenceNumber> = missing
      .iter()
      .copied()
      .filter(|sn| self.is_frag_partially_received(writer_guid, *sn))
      .collect();
    let Some(writer_proxy) = self.matched_writers.get_mut(&writer_guid) else {
      return;
    };
    let reader_sn_state = match missing.first() {
      Some(&first_missing) => SequenceNumberSet::from_base_and_set(
        first_missing,
        &missing
          .iter()
          .copied()
          .take_while(|sn| *sn < first_missing + SequenceNumber::new(256))
          .filter(|sn| !partial.contains(sn))
          .collect(),
      ),
      None if fast_dds && volatile => SequenceNumberSet::new_empty(SequenceNumber::zero()),
      None => SequenceNumberSet::new_empty(writer_proxy.all_ackable_before()),
    };
    let acknack = AckNack {
      reader_id,
      writer_id: writer_guid.entity_id,
      reader_sn_state,
      count: writer_proxy.next_ack_nack_sequence_number(),
    };
    let locators = writer_proxy.unicast_locator_list.clone();
    debug!(
      "Writer {writer_guid:?} quiet after DATA: poll {:?}. topic={:?}",
      acknack.reader_sn_state, self.topic_name
    );
    let flags = BitFlags::<ACKNACK_Flags>::from_flag(ACKNACK_Flags::Endianness);
    self.send_acknack_to(
      flags,
      acknack,
      InfoDestination {
        guid_prefix: writer_guid.prefix,
      },
      &locators,
      writer_guid,
    );
  }

  pub fn handle_datafrag_msg(
    &mut self,
    datafrag: &DataFrag,
    datafrag_flags: BitFlags<DATAFRAG_Flags>,
    mr_state: &MessageReceiverState,
  ) {
    let writer_guid = GUID::new_with_prefix_and_id(mr_state.source_guid_prefix, datafrag.writer_id);
    let seq_num = datafrag.writer_sn;
    let receive_timestamp = Timestamp::now();
    //trace!("DATAFRAG received topic={:?}", self.topic_name);
    // Patched for grasp_orient (0011-quiet-writer-poll.patch): a fragment is DATA activity too.
    if self.gap_watch(writer_guid).is_some() {
      self.note_data_for_quiet_poll(writer_guid, mr_state);
    }

    // check if this submessage is expired already
    // TODO: Maybe this check is in the wrong place altogether? It should be
    // done when Datareader fetches data for the application.
    if let (Some(source_timestamp), Some(lifespan)) =
      (mr_state.source_timestamp, self.qos().lifespan)
    {
      let elapsed = receive_timestamp.duration_since(source_timestamp);
      if lifespan.duration < elapsed {
        info!(
          "DataFrag {:?} from {:?} lifespan exceeded. duration={:?} elapsed={:?}",
          seq_num, writer_guid, lifespan.duration, elapsed
        );
        return;
      }
    }

    // parse write_options out of the message
    // TODO: This is almost duplicate code from DATA processing
    let mut write_options_b = WriteOptionsBuilder::new();
    // Check if we have a source timestamp
    if let Some(source_timestamp) = mr_state.source_timestamp {
      write_options_b = write_options_b.source_timestamp(source_timestamp);
    }
    // Check if the message specifies a related_sample_identity
    let representation_identifier = DATAFRAG_Flags::cdr_representation_identifier(datafrag_flags);
    if let Some(related_sample_identity) =
      datafrag
        .inline_qos
        .as_ref()
        .and_then(|inline_qos_parameters| {
          InlineQos::related_sample_identity(inline_qos_parameters, representation_identifier)
            .unwrap_or_else(|e| {
              error!("Deserializing related_sample_identity: {:?}", e);
              None
            })
        })
    {
      write_options_b = write_options_b.related_sample_identity(related_sample_identity);
    }

    // A fragment of a sample already received (a writer re-sends fragments the reader asked
    // for while they were on their way) would open a new assembly buffer that never
    // completes. Such buffers linger until the assembly timeout, and a reliable reader that
    // holds more than MAX_ASSEMBLY_BUFFERS of them evicts the newest one, which is the sample
    // it waits for: no sample could be assembled until the stale ones timed out. So such a
    // fragment is dropped, and with it what was assembled of a sample that became irrelevant
    // (a GAP, a HEARTBEAT's first_sn) while it was being assembled. The participant reader
    // keeps taking duplicates, as handle_data_msg does.
    let already_have = !self.like_stateless
      && self.my_guid.entity_id != EntityId::SPDP_BUILTIN_PARTICIPANT_READER
      && self
        .matched_writer(writer_guid)
        .is_some_and(|writer_proxy| writer_proxy.should_ignore_change(seq_num));
    if already_have {
      trace!("handle_datafrag_msg already have this seq={seq_num:?}");
      if let Some(assembler) = self.fragment_assemblers.get_mut(&writer_guid) {
        assembler.discard(seq_num);
      }
      return;
    }

    // Patched for grasp_orient (0015-bounded-fragment-assembly.patch): assembly only for a writer
    // this reader matched, of a sample no larger than max_sample_size, within the budget.
    let Some(room) = self.assembly_room(writer_guid, datafrag) else {
      return;
    };

    // Feed to fragment assembler ...
    let writer_seq_num = datafrag.writer_sn; // for borrow checker
    let completed_dds_data = self
      .fragment_assembler_mutable(writer_guid, datafrag.fragment_size)
      .new_datafrag(datafrag, datafrag_flags, room);

    // ... and continue processing, if data was completed.
    if let Some(dds_data) = completed_dds_data {
      // Source timestamp (if any) will be the timestamp of the last fragment (that
      // completes the sample).
      self.process_received_data(
        dds_data,
        receive_timestamp,
        write_options_b.build(),
        writer_guid,
        writer_seq_num,
      );
    } else {
      self.garbage_collect_fragments();
      self.arm_fragment_gc();
    }
  }

  /// The largest sample this reader assembles from DATA_FRAGs (built-in readers:
  /// BUILTIN_MAX_SAMPLE_SIZE; user readers: DomainParticipantBuilder::max_sample_size).
  pub(crate) fn set_max_sample_size(&mut self, max_sample_size: usize) {
    self.max_sample_size = max_sample_size;
    self.assembly_budget = Self::user_assembly_budget(max_sample_size);
  }

  // A user reader's incomplete assemblies may hold two samples of the largest size together:
  // one being completed by repairs while the next one arrives.
  const fn user_assembly_budget(max_sample_size: usize) -> usize {
    max_sample_size.saturating_mul(2)
  }

  // How many bytes the assembly of this DATA_FRAG may still grow by, or None when it is
  // dropped before any allocation:
  // - it comes from a writer this reader has not matched. The SPDP reader, whose writers are
  //   never matched (it takes SPDP from any participant), and a stateless reader are the
  //   exceptions; both are built-in readers, bounded by BUILTIN_MAX_SAMPLE_SIZE and
  //   BUILTIN_ASSEMBLY_BUDGET whoever sends.
  // - its sampleSize is above max_sample_size (logged at warn level at most every
  //   OVERSIZE_WARNING_INTERVAL).
  // Otherwise the room is the budget less what all the reader's assemblies hold.
  fn assembly_room(&mut self, writer_guid: GUID, datafrag: &DataFrag) -> Option<usize> {
    let any_writer =
      self.like_stateless || self.my_guid.entity_id == EntityId::SPDP_BUILTIN_PARTICIPANT_READER;
    if !any_writer && !self.matched_writers.contains_key(&writer_guid) {
      debug!(
        "DATA_FRAG from {writer_guid:?}, a writer not matched by {:?}: dropped. topic={:?}",
        self.my_guid, self.topic_name
      );
      return None;
    }
    let claimed = usize::try_from(datafrag.data_size).unwrap_or(usize::MAX);
    if claimed > self.max_sample_size {
      let now = Instant::now();
      let quiet = self
        .oversize_warned_at
        .is_some_and(|at| now.duration_since(at) < OVERSIZE_WARNING_INTERVAL);
      let message = format!(
        "DATA_FRAG from {writer_guid:?} claims a sample of {claimed} bytes, more than the {} this \
         reader assembles: dropped. topic={:?}",
        self.max_sample_size, self.topic_name
      );
      if quiet {
        debug!(target: crate::LIMITS_LOG_TARGET, "{message}");
      } else {
        self.oversize_warned_at = Some(now);
        warn!(target: crate::LIMITS_LOG_TARGET, "{message}");
      }
      // Patched for grasp_orient (0017-oversize-sample-skipped.patch).
      self.skip_sample(writer_guid, datafrag.writer_sn);
      return None;
    }
    let held: usize = self
      .fragment_assemblers
      .values()
      .map(FragmentAssembler::held_bytes)
      .sum();
    Some(self.assembly_budget.saturating_sub(held))
  }

  // A sample this reader never assembles (above max_sample_size), from a writer it matched: its
  // sequence number is taken as irrelevant, as a GAP would say (8.3.7.4), so that a reliable
  // stream goes on with the writer's next samples. Otherwise the writer proxy keeps the hole:
  // the reader asks for the sample again and again (each repair dropped the same way) and
  // delivers nothing later from that writer until the sample leaves the writer's history.
  // Patched for grasp_orient (0017-oversize-sample-skipped.patch).
  fn skip_sample(&mut self, writer_guid: GUID, seq: SequenceNumber) {
    if self.like_stateless {
      return;
    }
    let Some(writer_proxy) = self.matched_writer_mut(writer_guid) else {
      return;
    };
    writer_proxy.set_irrelevant_change(seq);
    let all_ackable_before = writer_proxy.all_ackable_before();
    if let Some(assembler) = self.fragment_assemblers.get_mut(&writer_guid) {
      assembler.discard(seq);
    }
    let marker_moved = self.reliability != policy::Reliability::BestEffort
      && self
        .acquire_the_topic_cache_guard()
        .mark_reliably_received_before(writer_guid, all_ackable_before);
    if marker_moved {
      self.notify_cache_change();
    }
  }

  // One FragmentGc timeout pending while any assembly is incomplete: assemblies are dropped
  // FRAGMENT_ASSEMBLY_TIMEOUT after their last fragment even when no other fragment comes (the
  // garbage collection on the receive path runs only when one does).
  fn arm_fragment_gc(&mut self) {
    if self.fragment_gc_armed
      || self
        .fragment_assemblers
        .values()
        .all(FragmentAssembler::is_idle)
    {
      return;
    }
    self.fragment_gc_armed = true;
    let after = std::cmp::min(MIN_FRAGMENT_GC_INTERVAL, self.fragment_assembly_timeout);
    self.timed_event_timer.borrow_mut().set_timeout(
      after.to_std(),
      DpTimerEvent::Reader {
        entity_id: self.my_guid.entity_id,
        event: TimedEvent::FragmentGc,
      },
    );
  }

  // Drop the assemblies that received nothing for FRAGMENT_ASSEMBLY_TIMEOUT, and the assemblers
  // left with none (a writer's assembler is made again by its next DATA_FRAG).
  fn collect_expired_fragments(&mut self) {
    let expire_before = Timestamp::now() - self.fragment_assembly_timeout;
    for (writer, fa) in &mut self.fragment_assemblers {
      debug!("AssemblyBuffer GC writer {writer:?}");
      fa.garbage_collect_before(expire_before);
    }
    self.fragment_assemblers.retain(|_, fa| !fa.is_idle());
  }

  fn fragment_assembler_mutable(
    &mut self,
    writer_guid: GUID,
    frag_size: u16,
  ) -> &mut FragmentAssembler {
    let reliable = self.reliability != policy::Reliability::BestEffort;
    self
      .fragment_assemblers
      .entry(writer_guid)
      .or_insert_with(|| FragmentAssembler::new(frag_size, reliable))
  }

  fn garbage_collect_fragments(&mut self) {
    // If GC time/packet limit has been exceeded, iterate through
    // fragment assemblers and discard those assembly buffers whose
    // creation / modification timestamps look like it is no longer receiving
    // data and can therefore be discarded.
    let now = Timestamp::now();
    if now - self.last_fragment_garbage_collect > MIN_FRAGMENT_GC_INTERVAL {
      self.last_fragment_garbage_collect = now;

      self.collect_expired_fragments();
    } else {
      trace!("Not yet AssemblyBuffer GC time.");
    }
  }

  fn missing_frags_for(
    &self,
    writer_guid: GUID,
    seq: SequenceNumber,
  ) -> Box<dyn '_ + Iterator<Item = FragmentNumber>> {
    self.fragment_assemblers.get(&writer_guid).map_or_else(
      || Box::new(iter::empty()) as Box<dyn Iterator<Item = FragmentNumber>>,
      |fa| fa.missing_frags_for(seq),
    )
  }

  fn is_frag_partially_received(&self, writer_guid: GUID, seq: SequenceNumber) -> bool {
    self
      .fragment_assemblers
      .get(&writer_guid)
      .is_some_and(|fa| fa.is_partially_received(seq))
  }

  // common parts of processing DATA or a completed DATAFRAG (when all frags are
  // received)
  fn process_received_data(
    &mut self,
    dds_data: DDSData,
    receive_timestamp: Timestamp,
    write_options: WriteOptions,
    writer_guid: GUID,
    writer_sn: SequenceNumber,
  ) {
    trace!(
      "handle_data_msg from {:?} seq={:?} topic={:?} reliability={:?} stateless={:?}",
      writer_guid,
      writer_sn,
      self.topic_name,
      self.reliability,
      self.like_stateless,
    );
    if !self.like_stateless {
      let my_entity_id = self.my_guid.entity_id; // to please borrow checker
      if let Some(writer_proxy) = self.matched_writer_mut(writer_guid) {
        if writer_proxy.should_ignore_change(writer_sn) {
          // change already present
          trace!("handle_data_msg already have this seq={writer_sn:?}");
          if my_entity_id == EntityId::SPDP_BUILTIN_PARTICIPANT_READER {
            debug!("Accepting duplicate message to participant reader.");
            // This is an attempted workaround to eProsima FastRTPS not
            // incrementing sequence numbers. (eProsima shapes demo 2.1.0 from
            // 2021)
          } else {
            return;
          }
        }
        // Add the change and get the instant
        writer_proxy.received_changes_add(writer_sn, receive_timestamp);
      } else {
        // no writer proxy found
        debug!(
          "handle_data_msg in stateful Reader {:?} has no writer proxy for {:?} topic={:?}",
          my_entity_id, writer_guid, self.topic_name,
        );
        // This is normal if the DATA was broadcast, but it was from another topic.
        // We just ignore the data in such a case
        // ... unless it is Discovery traffic.
        if writer_guid.entity_id.entity_kind.is_user_defined() {
          return;
        }
      }
    } else {
      // stateless reader: nothing to do before making cache change
    }

    self.make_cache_change(
      dds_data,
      receive_timestamp,
      write_options,
      writer_guid,
      writer_sn,
    );

    // Add to own track-keeping data structure
    #[cfg(test)]
    self.seqnum_instant_map.insert(writer_sn, receive_timestamp);

    self.notify_cache_change();
  }

  fn data_to_dds_data(
    &self,
    data: Data,
    data_flags: BitFlags<DATA_Flags>,
  ) -> Result<DDSData, String> {
    let representation_identifier = DATA_Flags::cdr_representation_identifier(data_flags);

    match (
      data.serialized_payload,
      data_flags.contains(DATA_Flags::Data),
      data_flags.contains(DATA_Flags::Key),
    ) {
      (Some(serialized_payload), true, false) => {
        // data
        Ok(DDSData::new(
          SerializedPayload::from_bytes(&serialized_payload).map_err(|e| format!("{e:?}"))?,
        ))
      }

      (Some(serialized_payload), false, true) => {
        // key
        Ok(DDSData::new_disposed_by_key(
          Self::deduce_change_kind(&data.inline_qos, false, representation_identifier),
          SerializedPayload::from_bytes(&serialized_payload).map_err(|e| format!("{e:?}"))?,
        ))
      }

      (None, false, false) => {
        // no data, no key. Maybe there is inline QoS?
        // At least we should find key hash, or we do not know WTF the writer is talking
        // about
        let key_hash = if let Some(h) = data.inline_qos.as_ref().and_then(|inline_qos_parameters| {
          InlineQos::key_hash(inline_qos_parameters).unwrap_or_else(|e| {
            error!("Deserializing key_hash: {:?}", e);
            None
          })
        }) {
          Ok(h)
        } else {
          info!("Received DATA that has no payload and no key_hash inline QoS - discarding");
          // Note: This case is normal when handling coherent sets.
          // The coherent set end marker is sent as DATA with no payload and not key, only
          // Inline QoS.
          Err("DATA with no contents".to_string())
        }?;
        // now, let's try to determine what is the dispose reason
        let change_kind =
          Self::deduce_change_kind(&data.inline_qos, false, representation_identifier);
        info!(
          "status change by Inline QoS: topic={:?} change={:?}",
          self.topic_name, change_kind
        );
        Ok(DDSData::new_disposed_by_key_hash(change_kind, key_hash))
      }

      (Some(_), true, true) => {
        // payload cannot be both key and data.
        // RTPS Spec 9.4.5.3.1 Flags in the Submessage Header says
        // "D=1 and K=1 is an invalid combination in this version of the protocol."
        warn!("Got DATA that claims to be both data and key - discarding.");
        Err("Ambiguous data/key received.".to_string())
      }

      (Some(_), false, false) => {
        // data but no data? - this should not be possible
        warn!("make_cache_change - Flags says no data or key, but got payload!");
        Err("DATA message has mystery contents".to_string())
      }
      (None, true, _) | (None, _, true) => {
        warn!("make_cache_change - Where is my SerializedPayload?");
        Err("DATA message contents missing".to_string())
      }
    }
  }

  // helper to work with mutable proxy
  fn with_mutable_writer_proxy<F, U>(&mut self, writer_guid: GUID, worker: F) -> Option<U>
  where
    F: FnOnce(&mut Self, &mut RtpsWriterProxy) -> U,
  {
    match self.matched_writers.remove(&writer_guid) {
      None => {
        error!("Writer proxy {writer_guid:?} not found");
        None
      }
      Some(mut wp) => {
        let res = worker(self, &mut wp);
        let x = self.matched_writers.insert(writer_guid, wp); // re-insert
        if x.is_some() {
          panic!(
            "RustDDS internal bug: with_mutable_writer_proxy worker re-inserted a writer proxy \
             for {writer_guid:?}"
          )
        }
        Some(res)
      }
    }
  }

  // Returns if responding with ACKNACK?
  // TODO: Return value seems to go unused in callers.
  // ...except in test cases, but not sure if this is strictly necessary to have.
  pub fn handle_heartbeat_msg(
    &mut self,
    heartbeat: &Heartbeat,
    final_flag_set: bool,
    mr_state: &MessageReceiverState,
  ) -> bool {
    let writer_guid =
      GUID::new_with_prefix_and_id(mr_state.source_guid_prefix, heartbeat.writer_id);

    if self.reliability == policy::Reliability::BestEffort || self.like_stateless {
      debug!(
        "HEARTBEAT from {:?}, but this Reader is BestEffort or stateless. Ignoring. topic={:?} \
         reader={:?}",
        writer_guid, self.topic_name, self.my_guid
      );
      // BestEffort Reader reacts only to DATA and GAP
      // See RTPS Spec Section "8.4.11 RTPS StatelessReader Behavior":
      // Figure 8.23 - Behavior of the Best-Effort StatefulReader with respect to each
      // matched Writer and
      // Figure 8.22 - Behavior of the Best-Effort StatelessReader
      return false;
    }

    if !self.matched_writers.contains_key(&writer_guid) {
      debug!(
        "HEARTBEAT from {:?}, but no writer proxy available. topic={:?} reader={:?}",
        writer_guid, self.topic_name, self.my_guid
      );
      return false;
    }
    // Patched for grasp_orient (0011-quiet-writer-poll.patch): the writer has said what it wrote,
    // as of a moment QUIET_POLL_DELAY or more after its last DATA arrived. A HEARTBEAT already
    // seen (a duplicate, or one overtaken by a newer one) says nothing new.
    let fresh = self
      .matched_writers
      .get(&writer_guid)
      .is_some_and(|wp| heartbeat.count > wp.received_heartbeat_count);
    if let Some(quiet) = self.quiet_polls.get_mut(&writer_guid).filter(|_| fresh) {
      quiet.heard_heartbeat |= Instant::now() >= quiet.last_data + QUIET_POLL_DELAY;
      quiet.announced = quiet.announced.max(heartbeat.last_sn);
    }
    // sanity check
    if heartbeat.first_sn < SequenceNumber::default() {
      warn!(
        "Writer {:?} advertised SequenceNumbers from {:?} to {:?}!",
        writer_guid, heartbeat.first_sn, heartbeat.last_sn
      );
    }

    let to_answer = self
      .with_mutable_writer_proxy(writer_guid, |this, writer_proxy| {
        // Note: This is worker closure. Use `this` instead of `self`.

        if heartbeat.count <= writer_proxy.received_heartbeat_count {
          // This heartbeat was already seen an processed.
          return None;
        }
        writer_proxy.received_heartbeat_count = heartbeat.count;

        // remove changes until first_sn.
        writer_proxy.irrelevant_changes_up_to(heartbeat.first_sn);

        let marker_moved = this
          .acquire_the_topic_cache_guard()
          .mark_reliably_received_before(writer_guid, writer_proxy.all_ackable_before());
        if marker_moved {
          this.notify_cache_change();
        }

        // See if ACKNACK is needed, and generate one.
        let missing_seqnums = writer_proxy.missing_seqnums(heartbeat.first_sn, heartbeat.last_sn);

        // Interpretation of final flag in RTPS spec
        // 8.4.2.3.1 Readers must respond eventually after receiving a HEARTBEAT with
        // final flag not set
        //
        // Upon receiving a HEARTBEAT Message with final flag not set, the Reader must
        // respond with an ACKNACK Message. The ACKNACK Message may acknowledge
        // having received all the data samples or may indicate that some data
        // samples are missing. The response may be delayed to avoid message storms.

        if missing_seqnums.is_empty() && final_flag_set {
          return None;
        }
        Some(HeartbeatToAnswer {
          first_sn: heartbeat.first_sn,
          last_sn: heartbeat.last_sn,
          final_flag_set,
          source_guid_prefix: mr_state.source_guid_prefix,
          reply_locators: match mr_state.unicast_reply_locator_list {
            [] | [Locator::Invalid] => writer_proxy.unicast_locator_list.clone(),
            //TODO: What is writer_proxy has an empty list?
            others => others.to_vec(),
          },
        })
      }) // worker fn
      .flatten();
    match to_answer {
      Some(to_answer) => self.schedule_heartbeat_answer(writer_guid, to_answer),
      None => false, // no writer_proxy, a HEARTBEAT seen before, or nothing to answer
    }
  } // fn

  // Patched for grasp_orient (0009-heartbeat-response-delay.patch), RTPS 2.5 8.4.15.x: a
  // HEARTBEAT is answered after heartbeat_response_delay, not at once. A writer may announce a
  // sample ahead of its DATA (Fast DDS sends a HEARTBEAT before the first DATA_FRAG of a large
  // sample); answering at once asked for fragments on their way, and the writer sent them twice.
  // HEARTBEATs that come while an answer waits are merged into it. Within
  // heartbeat_suppression_duration of an answer, a HEARTBEAT that announces nothing past what
  // that answer covered is ignored: the repair it would ask for is already on its way. A gap that
  // DATA proves (0008) and the NACK_FRAGs of 0005 are still sent at once. Returns whether an
  // answer is (or will be) sent.
  fn schedule_heartbeat_answer(&mut self, writer_guid: GUID, to_answer: HeartbeatToAnswer) -> bool {
    if let Some(&(answered_at, answered_last_sn)) = self.heartbeats_answered.get(&writer_guid) {
      if answered_at.elapsed() < self.heartbeat_suppression_duration
        && to_answer.last_sn <= answered_last_sn
      {
        trace!("HEARTBEAT from {writer_guid:?} within the suppression duration: ignored");
        return false;
      }
    }
    if self.heartbeat_response_delay.is_zero() {
      self.answer_heartbeat(writer_guid, &to_answer);
      return true;
    }
    match self.heartbeats_to_answer.get_mut(&writer_guid) {
      Some(waiting) => {
        waiting.first_sn = waiting.first_sn.max(to_answer.first_sn);
        waiting.last_sn = waiting.last_sn.max(to_answer.last_sn);
        waiting.final_flag_set &= to_answer.final_flag_set;
        waiting.reply_locators = to_answer.reply_locators;
      }
      None => {
        self.heartbeats_to_answer.insert(writer_guid, to_answer);
        self.timed_event_timer.borrow_mut().set_timeout(
          self.heartbeat_response_delay,
          DpTimerEvent::Reader {
            entity_id: self.my_guid.entity_id,
            event: TimedEvent::HeartbeatResponse { writer_guid },
          },
        );
      }
    }
    true
  }

  // Sends the ACKNACK (and NACK_FRAGs) that answer `to_answer`, from what the reader has now.
  fn answer_heartbeat(&mut self, writer_guid: GUID, to_answer: &HeartbeatToAnswer) {
    if !self.matched_writers.contains_key(&writer_guid) {
      return; // unmatched while the answer waited
    }
    self
      .heartbeats_answered
      .insert(writer_guid, (Instant::now(), to_answer.last_sn));
    self.with_mutable_writer_proxy(writer_guid, |this, writer_proxy| {
      let reader_id = this.entity_id();
      let missing_seqnums = writer_proxy.missing_seqnums(to_answer.first_sn, to_answer.last_sn);
      if missing_seqnums.is_empty() && to_answer.final_flag_set {
        return; // what the HEARTBEAT announced arrived meanwhile
      }
      let mut partially_received = Vec::new();
      // report of what we have.
      // We claim to have received all SNs before "base" and produce a set of missing
      // sequence numbers that are >= base.
      let reader_sn_state = match missing_seqnums.first() {
        Some(&first_missing) => {
          // Here we assume missing_seqnums are returned in order.
          // Limit the set to maximum that can be sent in acknack submessage.

          SequenceNumberSet::from_base_and_set(
            first_missing,
            &missing_seqnums
              .iter()
              .copied()
              .take_while(|sn| sn < &(first_missing + SequenceNumber::new(256)))
              .filter(|sn| {
                if this.is_frag_partially_received(writer_guid, *sn) {
                  partially_received.push(*sn);
                  false
                } else {
                  true
                }
              })
              .collect(),
          )
        }

        // Nothing missing. Report that we have all we have.
        None => SequenceNumberSet::new_empty(writer_proxy.all_ackable_before()),
      };

      let response_ack_nack = AckNack {
        reader_id,
        writer_id: writer_guid.entity_id,
        reader_sn_state,
        count: writer_proxy.next_ack_nack_sequence_number(),
      };

      // Sanity check
      //
      // Wrong. This sanity check is invalid. The condition
      // ack_base > heartbeat.last_sn + 1
      // May be legitimately true, if there are some changes available, and a GAP
      // after that. E.g. HEARTBEAT 1..8 and GAP 9..10. Then acknack_base == 11
      // and 11 > 8 + 1.
      //
      //
      // if response_ack_nack.reader_sn_state.base() > heartbeat.last_sn +
      // SequenceNumber::new(1) {   error!(
      //     "OOPS! AckNack sanity check tripped: HEARTBEAT = {:?} ACKNACK = {:?}
      // missing_seqnums = {:?} all_ackable_before = {:?} writer={:?}",
      //     &heartbeat, &response_ack_nack, missing_seqnums,
      // writer_proxy.all_ackable_before(), writer_guid,   );
      // }

      // The acknack can be sent now or later. The rest of the RTPS message
      // needs to be constructed. p. 48
      let acknack_flags = BitFlags::<ACKNACK_Flags>::from_flag(ACKNACK_Flags::Endianness)
        | BitFlags::<ACKNACK_Flags>::from_flag(ACKNACK_Flags::Final);

      let nackfrag_flags = BitFlags::<NACKFRAG_Flags>::from_flag(NACKFRAG_Flags::Endianness);

      // send NackFrags, if any
      let mut nackfrags = Vec::new();
      for sn in partially_received {
        let count = writer_proxy.next_ack_nack_sequence_number();
        let mut missing_frags = this.missing_frags_for(writer_guid, sn);
        let first_missing = missing_frags.next();
        if let Some(first) = first_missing {
          let missing_frags_set = iter::once(first).chain(missing_frags).collect(); // "undo" the .next() above
          let nf = NackFrag {
            reader_id,
            writer_id: writer_proxy.remote_writer_guid.entity_id,
            writer_sn: sn,
            fragment_number_state: FragmentNumberSet::from_base_and_set(first, &missing_frags_set),
            count,
          };
          nackfrags.push(nf);
        } else {
          error!("The dog ate my missing fragments.");
          // Really, this should not happen, as we are above checking
          // that this SN is really partially (and not fully) received.
        }
      }

      let reply_locators = &to_answer.reply_locators;

      if !nackfrags.is_empty() {
        this.send_nackfrags_to(
          nackfrag_flags,
          nackfrags,
          InfoDestination {
            guid_prefix: to_answer.source_guid_prefix,
          },
          reply_locators,
          writer_guid,
        );
      }

      this.send_acknack_to(
        acknack_flags,
        response_ack_nack,
        InfoDestination {
          guid_prefix: to_answer.source_guid_prefix,
        },
        reply_locators,
        writer_guid,
      );
    });
  }

  pub fn handle_gap_msg(&mut self, gap: &Gap, mr_state: &MessageReceiverState) {
    // ATM all things related to groups is ignored. TODO?

    let writer_guid = GUID::new_with_prefix_and_id(mr_state.source_guid_prefix, gap.writer_id);

    if self.like_stateless {
      debug!(
        "GAP from {:?}, but reader is stateless. Ignoring. topic={:?} reader={:?}",
        writer_guid, self.topic_name, self.my_guid
      );
      return;
    }
    let all_ackable_before;
    {
      let writer_proxy = if let Some(wp) = self.matched_writer_mut(writer_guid) {
        wp
      } else {
        info!(
          "GAP from {:?}, but no writer proxy available. topic={:?} reader={:?}",
          writer_guid, self.topic_name, self.my_guid
        );
        return;
      };

      // Check validity of the GAP message (Section 8.3.8.4.3)
      if gap.gap_start <= SequenceNumber::new(0) {
        debug!(
          "Invalid GAP from {:?}: gap_start={:?} is zero or negative. topic={:?} reader={:?}",
          writer_guid, gap.gap_start, self.topic_name, self.my_guid
        );
        return;
      }
      if gap.gap_list.base() <= SequenceNumber::new(0) {
        debug!(
          "Invalid GAP from {:?}: minimum of gap_list (={:?}) is zero or negative. topic={:?} \
           reader={:?}",
          writer_guid,
          gap.gap_list.base(),
          self.topic_name,
          self.my_guid
        );
        return;
      }
      // TODO: check that maximum(gap_list) - minimum(gap_list) < 256 ?

      // Irrelevant sequence numbers communicated in the Gap message are
      // composed of two groups:
      //   1. All sequence numbers in the range gapStart <= sequence_number <
      // gapList.base
      writer_proxy.irrelevant_changes_range(gap.gap_start, gap.gap_list.base());

      //   2. All the sequence numbers that appear explicitly listed in the gapList.
      //      Note that gapList.base may or may not be included in gapList; its
      //      inclusion is determined by the bitmap, as with the other sequence
      //      numbers
      for seq_num in gap.gap_list.iter() {
        writer_proxy.set_irrelevant_change(seq_num);
      }
      all_ackable_before = writer_proxy.all_ackable_before();
    }

    // Get the topic cache and mark progress
    let marker_moved = self.reliability != policy::Reliability::BestEffort
      && self
        .acquire_the_topic_cache_guard()
        .mark_reliably_received_before(writer_guid, all_ackable_before);

    // Receiving a GAP could make a Reliable stream.
    // E.g. we had #2, but were missing #1. Now GAP says that #1 does not exist.
    // Then a Reliable Datareader
    if marker_moved {
      self.notify_cache_change();
    }
    // able to move forward, i.e. hand over data to application, if
    // we now know that nothing is missng from the past.

    // TODO: If receiving GAP actually moved the reliably received mark forward
    // in the Topic Cache, then we should generate a SAMPLE_LOST status event
    // from our Datareader (DDS Spec Section 2.2.4.1)
    //
    // If the the GAP message contained filteredCount (RTPS spec v2.5 Table
    // 8.43), then some of the not-available messages should not be treated
    // as "lost" but "filtered".
  }

  pub fn handle_heartbeatfrag_msg(
    &mut self,
    heartbeatfrag: &HeartbeatFrag,
    _mr_state: &MessageReceiverState,
  ) {
    info!(
      "HeartbeatFrag handling not implemented. topic={:?}   {:?}",
      self.topic_name, heartbeatfrag
    );
  }

  // This is used to determine exact change kind in case we do not get a data
  // payload in DATA submessage
  fn deduce_change_kind(
    inline_qos: &Option<ParameterList>,
    no_writers: bool,
    representation_identifier: RepresentationIdentifier,
  ) -> ChangeKind {
    match inline_qos.as_ref().and_then(|inline_qos_parameters| {
      InlineQos::status_info(inline_qos_parameters, representation_identifier).map_or_else(
        |e| {
          error!("Deserializing status_info: {:?}", e);
          None
        },
        Some,
      )
    }) {
      Some(si) => si.change_kind(), // get from inline QoS
      // TODO: What if si.change_kind() gives ALIVE ??
      None => {
        if no_writers {
          ChangeKind::NotAliveUnregistered
        } else {
          ChangeKind::NotAliveDisposed
        } // TODO: Is this reasonable default?
      }
    }
  }

  // Convert DATA submessage into a CacheChange and update history cache
  fn make_cache_change(
    &mut self,
    data: DDSData,
    receive_timestamp: Timestamp,
    write_options: WriteOptions,
    writer_guid: GUID,
    writer_sn: SequenceNumber,
  ) {
    let cache_change = CacheChange::new(writer_guid, writer_sn, write_options, data);

    // Get the topic cache
    let mut tc = self.acquire_the_topic_cache_guard();

    tc.add_change(&receive_timestamp, cache_change);
    // Mark seqnums as received if not behaving statelessly. Only a Reliable
    // reader waits for missing samples; a BestEffort marker would stay behind a
    // lost sample for good, and the topic cache would retain everything after it.
    if !self.like_stateless && self.reliability != policy::Reliability::BestEffort {
      self.matched_writer(writer_guid).map(|wp| {
        tc.mark_reliably_received_before(writer_guid, wp.all_ackable_before());
        // Here we do not need to notify waiting DataReader, because
        // the upper call level from here does it.
      });
    }
  }

  // notifies DataReaders (or any listeners that history cache has changed for
  // this reader) likely use of mio channel
  pub fn notify_cache_change(&mut self) {
    // async notify mechanism
    self
      .data_reader_waker
      .lock()
      .unwrap() // TODO: unwrap
      .take() // Take to nullify the reference
      .map(|w| w.wake_by_ref()); // If Some, call wake_by_ref

    // mio-0.8 / mio-1.2 notify for a caller-owned poll.
    self.poll_event_sender.send();

    // Discovery's poll cannot register the mio-0.6 notification channel.
    if let Some((sender, token)) = &self.discovery_notify {
      sender.notify(*token);
    }

    // mio-0.6 notify
    match self.notification_sender.try_send(()) {
      Ok(()) => (),
      Err(std::sync::mpsc::TrySendError::Full(_)) => (),
      // This is harmless. There is a notification in already.
      Err(std::sync::mpsc::TrySendError::Disconnected(_)) => {
        // If we get here, our DataReader has died. The Reader should now
        // dispose itself. TODO: Implement Reader disposal.
      }
    }
  }

  #[cfg(not(feature = "security"))]
  fn encode_and_send(
    &self,
    message: Message,
    _destination_guid: GUID,
    dst_locator_list: &[Locator],
  ) {
    let bytes = match message.write_to_vec_fast(Endianness::LittleEndian) {
      Ok(b) => b,
      Err(e) => {
        error!("Failed to serialize RTPS message for send: {e:?}");
        return;
      }
    };
    let _dummy = message; // consume it to avoid clippy warning
    self
      .udp_sender
      .send_to_locator_list(&bytes, dst_locator_list);
  }

  #[cfg(feature = "security")]
  fn encode_and_send(
    &self,
    message: Message,
    destination_guid: GUID,
    dst_locator_list: &[Locator],
  ) {
    match self.security_encode(message, destination_guid) {
      Ok(message) => {
        let bytes = match message.write_to_vec_with_ctx(Endianness::LittleEndian) {
          Ok(b) => b,
          Err(e) => {
            error!("Failed to serialize RTPS message for send: {e:?}");
            return;
          }
        };
        self
          .udp_sender
          .send_to_locator_list(&bytes, dst_locator_list);
      }
      Err(e) => error!("Failed to send message to writers. Encoding failed: {e:?}"),
    }
  }

  #[cfg(feature = "security")]
  fn security_encode(&self, message: Message, destination_guid: GUID) -> SecurityResult<Message> {
    // If we have security plugins, use them, otherwise pass through
    if let Some(security_plugins_handle) = &self.security_plugins {
      // Get the source GUID
      let source_guid = self.guid();
      // Destructure
      let Message {
        header,
        submessages,
      } = message;

      // Encode submessages
      SecurityResult::<Vec<Vec<Submessage>>>::from_iter(submessages.iter().map(|submessage| {
        security_plugins_handle
          .get_plugins()
          .encode_datareader_submessage(submessage.clone(), &source_guid, &[destination_guid])
          // Convert each encoding output to a Vec of 1 or 3 submessages
          .map(Vec::from)
      }))
      // Flatten and convert back to Message
      .map(|encoded_submessages| Message {
        header,
        submessages: encoded_submessages.concat(),
      })
      // Encode message
      .and_then(|message| {
        // Convert GUIDs to GuidPrefixes
        let source_guid_prefix = source_guid.prefix;
        let destination_guid_prefix = destination_guid.prefix;
        // Encode message
        security_plugins_handle.get_plugins().encode_message(
          message,
          &source_guid_prefix,
          &[destination_guid_prefix],
        )
      })
    } else {
      Ok(message)
    }
  }

  fn send_acknack_to(
    &self,
    flags: BitFlags<ACKNACK_Flags>,
    acknack: AckNack,
    info_dst: InfoDestination,
    dst_locator_list: &[Locator],
    destination_guid: GUID,
  ) {
    let infodst_flags =
      BitFlags::<INFODESTINATION_Flags>::from_flag(INFODESTINATION_Flags::Endianness);

    let mut message = Message::new(Header {
      protocol_id: ProtocolId::default(),
      protocol_version: ProtocolVersion::THIS_IMPLEMENTATION,
      vendor_id: VendorId::THIS_IMPLEMENTATION,
      guid_prefix: self.my_guid.prefix,
    });

    message.add_submessage(info_dst.create_submessage(infodst_flags));

    message.add_submessage(acknack.create_submessage(flags));

    self.encode_and_send(message, destination_guid, dst_locator_list);
  }

  fn send_nackfrags_to(
    &self,
    flags: BitFlags<NACKFRAG_Flags>,
    nackfrags: Vec<NackFrag>,
    info_dst: InfoDestination,
    dst_locator_list: &[Locator],
    destination_guid: GUID,
  ) {
    let infodst_flags =
      BitFlags::<INFODESTINATION_Flags>::from_flag(INFODESTINATION_Flags::Endianness);

    let mut message = Message::new(Header {
      protocol_id: ProtocolId::default(),
      protocol_version: ProtocolVersion::THIS_IMPLEMENTATION,
      vendor_id: VendorId::THIS_IMPLEMENTATION,
      guid_prefix: self.my_guid.prefix,
    });

    message.add_submessage(info_dst.create_submessage(infodst_flags));

    for nf in nackfrags {
      message.add_submessage(nf.create_submessage(flags));
    }

    self.encode_and_send(message, destination_guid, dst_locator_list);
  }

  pub fn send_preemptive_acknacks(&mut self) {
    if self.like_stateless {
      info!(
        "Attempted to send pre-emptive acknacks in a stateless Reader, which does not support \
         them. Ignoring. topic={:?}",
        self.topic_name
      );
      return;
    }

    // Detach the writer proxy set. This is a way to avoid multiple &mut self
    let mut writer_proxies = std::mem::take(&mut self.matched_writers);

    for (_, writer_proxy) in writer_proxies
      .iter_mut()
      .filter(|(_, p)| p.no_changes_received())
    {
      self.send_preemptive_acknack_to(writer_proxy);
    }
    // put writer proxies back
    self.matched_writers = writer_proxies;
  }

  // An ACKNACK without the final flag requests an immediate HEARTBEAT from the
  // writer.
  fn send_preemptive_acknack_to(&self, writer_proxy: &mut RtpsWriterProxy) {
    let flags = BitFlags::<ACKNACK_Flags>::from_flag(ACKNACK_Flags::Endianness);
    let acknack_count = writer_proxy.next_ack_nack_sequence_number();
    let RtpsWriterProxy {
      remote_writer_guid,
      unicast_locator_list,
      ..
    } = writer_proxy;
    self.send_acknack_to(
      flags,
      AckNack {
        reader_id: self.entity_id(),
        writer_id: remote_writer_guid.entity_id,
        reader_sn_state: SequenceNumberSet::new_empty(SequenceNumber::new(1)),
        count: acknack_count,
      },
      InfoDestination {
        guid_prefix: remote_writer_guid.prefix,
      },
      unicast_locator_list,
      *remote_writer_guid,
    );
  }

  pub fn topic_name(&self) -> &String {
    &self.topic_name
  }

  fn acquire_the_topic_cache_guard(&self) -> MutexGuard<'_, TopicCache> {
    self.topic_cache.lock().unwrap_or_else(|e| {
      panic!(
        "RustDDS internal bug: topic cache of topic {} is poisoned after a prior panic: {e}",
        self.topic_name
      )
    })
  }
} // impl Reader

impl HasQoSPolicy for Reader {
  fn qos(&self) -> QosPolicies {
    self.qos_policy.clone()
  }
}

impl RTPSEntity for Reader {
  fn guid(&self) -> GUID {
    self.my_guid
  }
}

impl fmt::Debug for Reader {
  fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    f.debug_struct("Reader")
      .field("notification_sender, dds_cache", &"can't print".to_string())
      .field("topic_name", &self.topic_name)
      .field("my_guid", &self.my_guid)
      .field("heartbeat_response_delay", &self.heartbeat_response_delay)
      .field("received_heartbeat_count", &self.received_heartbeat_count)
      .finish()
  }
}

#[cfg(test)]
mod tests {
  use std::sync::RwLock;

  use crate::{
    dds::{qos::policy::Reliability, statusevents::sync_status_channel, typedesc::TypeDesc},
    polling::{new_shared_timer, wake_channel, LoopWaker},
    structure::{dds_cache::DDSCache, guid::EntityKind},
    QosPolicyBuilder,
  };
  use super::*;

  #[test]
  fn reader_sends_notification_when_receiving_data() {
    // 1. Create a reader
    // Create the DDS cache and a topic
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let qos_policy = QosPolicies::qos_none();

    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );

    // Create notification mechanisms
    // mio-0.6 channel:
    let (notification_sender, notification_receiver) = crate::mio_source::notification_channel(100);
    // mio-0.8 event source and sender:
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    // async notification waker
    let data_reader_waker = Arc::new(Mutex::new(None));

    // Create status channel
    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();

    // Create reader command channel
    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());

    // Then finally create the reader
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let reader_ing = ReaderIngredients {
      guid: reader_guid,
      notification_sender,
      status_sender,
      topic_name: topic_name.to_string(),
      topic_cache_handle,
      like_stateless: false,
      qos_policy,
      data_reader_command_receiver: reader_command_receiver,
      data_reader_waker,
      poll_event_sender: notification_event_sender,
      security_plugins: None,
      discovery_notify: None,
    };
    let mut reader = Reader::new(
      reader_ing,
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );

    // 2. Add info of a matched writer to the reader
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);

    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };

    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &QosPolicies::qos_none(),
    );

    // 3. Create data that the matched writer supposedly sent to the reader
    let data = Data {
      reader_id: reader_guid.entity_id,
      writer_id: writer_guid.entity_id,
      ..Data::default()
    };
    let data_flags = BitFlags::<DATA_Flags>::from_flag(DATA_Flags::Data);

    // 4. Feed the data for the reader to handle
    reader.handle_data_msg(data, data_flags, &mr_state);

    // 5. Verify that the reader sends a notification about the new data
    assert!(
      notification_receiver.try_recv().is_ok(),
      "Reader did not send a notification through the mio-0.6 channel"
    );
    // TODO: Should the other notification mechanisms (mio-0.8 & async) be also
    // checked?
  }

  #[test]
  fn reader_sends_data_to_topic_cache() {
    // 1. Create a reader
    // Create the DDS cache and a topic
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let qos_policy = QosPolicies::qos_none();

    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );

    // Create mechanisms for notifications, statuses & commands
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker = Arc::new(Mutex::new(None));

    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();

    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());

    // Then create the reader
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let reader_ing = ReaderIngredients {
      guid: reader_guid,
      notification_sender,
      status_sender,
      topic_name: topic_name.to_string(),
      topic_cache_handle: topic_cache_handle.clone(),
      like_stateless: false,
      qos_policy,
      data_reader_command_receiver: reader_command_receiver,
      data_reader_waker,
      poll_event_sender: notification_event_sender,
      security_plugins: None,
      discovery_notify: None,
    };
    let mut reader = Reader::new(
      reader_ing,
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );

    // 2. Add info of a matched writer to the reader
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);

    let source_timestamp = Timestamp::INVALID;
    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      source_timestamp: Some(source_timestamp),
      ..Default::default()
    };

    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &QosPolicies::qos_none(),
    );

    // 3. Create data that the matched writer supposedly sent to the reader
    let data = Data {
      reader_id: reader_guid.entity_id,
      writer_id: writer_guid.entity_id,
      ..Data::default()
    };
    let data_flags = BitFlags::<DATA_Flags>::from_flag(DATA_Flags::Data);
    let sequence_num = data.writer_sn;

    // 4. Feed the data for the reader to handle
    reader.handle_data_msg(data.clone(), data_flags, &mr_state);

    // 5. Verify that the reader sent the data to the topic cache
    let topic_cache = topic_cache_handle.lock().unwrap();

    let cc_from_cache = topic_cache
      .get_change(reader.seqnum_instant_map.get(&sequence_num).unwrap())
      .expect("No cache change in topic cache");

    // 6. Verify that the content of the cache change is as expected
    // Construct a cache change with the expected content
    let dds_data = DDSData::new(data.unwrap_serialized_payload());
    let cc_locally_built = CacheChange::new(
      writer_guid,
      sequence_num,
      WriteOptions::from(Some(source_timestamp)),
      dds_data,
    );

    assert_eq!(
      cc_from_cache, &cc_locally_built,
      "The content of the cache change in the topic cache not as expected"
    );
  }

  #[test]
  fn data_without_payload_takes_up_its_sequence_number() {
    // A user topic's reader, as in reader_sends_data_to_topic_cache.
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let qos_policy = QosPolicies::qos_none();
    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();
    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let mut reader = Reader::new(
      ReaderIngredients {
        guid: reader_guid,
        notification_sender,
        status_sender,
        topic_name: topic_name.to_string(),
        topic_cache_handle: topic_cache_handle.clone(),
        like_stateless: false,
        qos_policy,
        data_reader_command_receiver: reader_command_receiver,
        data_reader_waker: Arc::new(Mutex::new(None)),
        poll_event_sender: notification_event_sender,
        security_plugins: None,
        discovery_notify: None,
      },
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };
    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &QosPolicies::qos_none(),
    );

    // Sequence number 1: what Fast DDS sends for a zero-length serialized message (rclpy's
    // publish(b"")): a DATA with no payload and neither the data nor the key flag.
    let empty = Data {
      reader_id: reader_guid.entity_id,
      writer_id: writer_guid.entity_id,
      writer_sn: SequenceNumber::new(1),
      inline_qos: None,
      serialized_payload: None,
    };
    reader.handle_data_msg(empty, BitFlags::<DATA_Flags>::empty(), &mr_state);
    // Sequence number 2: an ordinary sample.
    let data = Data {
      reader_id: reader_guid.entity_id,
      writer_id: writer_guid.entity_id,
      writer_sn: SequenceNumber::new(2),
      ..Data::default()
    };
    reader.handle_data_msg(data, BitFlags::from_flag(DATA_Flags::Data), &mr_state);

    // Both are received: nothing is missing before 3, so no later sample waits for 1.
    let proxy = reader
      .matched_writer(writer_guid)
      .expect("the writer is matched");
    assert_eq!(
      proxy.all_ackable_before(),
      SequenceNumber::new(3),
      "sequence number 1 was never marked received"
    );
    // The application gets sequence number 1 as an empty sample, which it cannot decode.
    let instant = reader
      .seqnum_instant_map
      .get(&SequenceNumber::new(1))
      .expect("sequence number 1 reached the topic cache");
    let topic_cache = topic_cache_handle.lock().unwrap();
    let change = topic_cache
      .get_change(instant)
      .expect("a cache change for sequence number 1");
    assert_eq!(change.sequence_number, SequenceNumber::new(1));
    match &change.data_value {
      DDSData::Data { serialized_payload } => assert!(serialized_payload.value.is_empty()),
      other => panic!("expected an empty sample, got {other:?}"),
    }
  }

  #[test]
  fn a_gap_in_reliable_data_is_nacked_at_once() {
    // A reliable user topic's reader, as in fragments_of_a_received_sample_leave_no_assembly_behind.
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let qos_policy = QosPolicyBuilder::new()
      .reliability(Reliability::Reliable {
        max_blocking_time: Duration::from_millis(100),
      })
      .build();
    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();
    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let mut reader = Reader::new(
      ReaderIngredients {
        guid: reader_guid,
        notification_sender,
        status_sender,
        topic_name: topic_name.to_string(),
        topic_cache_handle,
        like_stateless: false,
        qos_policy: qos_policy.clone(),
        data_reader_command_receiver: reader_command_receiver,
        data_reader_waker: Arc::new(Mutex::new(None)),
        poll_event_sender: notification_event_sender,
        security_plugins: None,
        discovery_notify: None,
      },
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };
    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &qos_policy,
    );
    // ACKNACKs sent since the writer was matched (matching may send a preemptive one).
    let sent = |reader: &Reader| {
      reader
        .matched_writer(writer_guid)
        .expect("the writer is matched")
        .sent_ack_nack_count
    };
    let base = sent(&reader);
    let data = |reader: &mut Reader, sn: i64| {
      let d = Data {
        reader_id: reader_guid.entity_id,
        writer_id: writer_guid.entity_id,
        writer_sn: SequenceNumber::new(sn),
        ..Data::default()
      };
      reader.handle_data_msg(d, BitFlags::from_flag(DATA_Flags::Data), &mr_state);
      sent(reader) - base
    };
    // In order: nothing to ask for.
    assert_eq!(data(&mut reader, 1), 0);
    assert_eq!(data(&mut reader, 2), 0);
    // 3 and 4 lost: 5 proves it, and the reader asks at once.
    assert_eq!(
      data(&mut reader, 5),
      1,
      "no ACKNACK when DATA 5 revealed 3 and 4 missing"
    );
    // 6 follows 5: no new gap, no new ACKNACK; 8 reveals 7.
    assert_eq!(data(&mut reader, 6), 1);
    assert_eq!(data(&mut reader, 8), 2);
    // The repair of 3 reveals nothing.
    assert_eq!(data(&mut reader, 3), 2);
  }

  // A reliable user topic's reader whose writer's reply locator is a socket of the test's, so
  // the ACKNACKs and NACK_FRAGs it sends can be read back (0009-heartbeat-response-delay.patch).
  fn reader_answering_to_a_socket() -> (Reader, GUID, std::net::UdpSocket, SharedTimer<DpTimerEvent>)
  {
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let qos_policy = QosPolicyBuilder::new()
      .reliability(Reliability::Reliable {
        max_blocking_time: Duration::from_millis(100),
      })
      .build();
    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      "test_name".to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();
    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());
    let timer = new_shared_timer();
    let mut reader = Reader::new(
      ReaderIngredients {
        guid: GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED),
        notification_sender,
        status_sender,
        topic_name: "test_name".to_string(),
        topic_cache_handle,
        like_stateless: false,
        qos_policy: qos_policy.clone(),
        data_reader_command_receiver: reader_command_receiver,
        data_reader_waker: Arc::new(Mutex::new(None)),
        poll_event_sender: notification_event_sender,
        security_plugins: None,
        discovery_notify: None,
      },
      Rc::new(UDPSender::new(0).unwrap()),
      timer.clone(),
      participant_status_sender,
    );
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    socket.set_nonblocking(true).unwrap();
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      vec![Locator::from(socket.local_addr().unwrap())],
      vec![],
      &qos_policy,
    );
    (reader, writer_guid, socket, timer)
  }

  // The sequence numbers (and fragments) that the reader's datagrams to `socket` asked for
  // since the last call: (sn, None) for an ACKNACK's, (sn, Some(fragment)) for a NACK_FRAG's;
  // and how many ACKNACKs came.
  fn requests_sent(socket: &std::net::UdpSocket) -> (Vec<(i64, Option<u32>)>, usize) {
    std::thread::sleep(StdDuration::from_millis(20));
    let mut asked = Vec::new();
    let mut acknacks = 0;
    let mut buf = vec![0u8; 65536];
    while let Ok(n) = socket.recv(&mut buf) {
      let message = Message::read_from_buffer(&bytes::Bytes::copy_from_slice(&buf[..n])).unwrap();
      for sub in message.submessages() {
        match sub.body {
          crate::rtps::SubmessageBody::Reader(ReaderSubmessage::AckNack(a, _)) => {
            acknacks += 1;
            asked.extend(a.reader_sn_state.iter().map(|sn| (i64::from(sn), None)));
          }
          crate::rtps::SubmessageBody::Reader(ReaderSubmessage::NackFrag(nf, _)) => {
            let sn = i64::from(nf.writer_sn);
            asked.extend(
              nf.fragment_number_state
                .iter()
                .map(|f| (sn, Some(u32::from(f)))),
            );
          }
          _ => {}
        }
      }
    }
    (asked, acknacks)
  }

  // Runs the reader's timed events that are due.
  fn run_due_timers(reader: &mut Reader, timer: &SharedTimer<DpTimerEvent>) {
    loop {
      let event = timer.borrow_mut().poll();
      match event {
        Some(DpTimerEvent::Reader { event, .. }) => reader.handle_timed_event(event),
        Some(_) => {}
        None => break,
      }
    }
  }

  #[test]
  fn a_sample_announced_ahead_of_its_fragments_is_not_asked_for() {
    // What Fast DDS does with a large sample: a HEARTBEAT announcing it, then its DATA_FRAGs.
    let (mut reader, writer_guid, socket, timer) = reader_answering_to_a_socket();
    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };
    let _preemptive = requests_sent(&socket);
    let reader_id = reader.my_guid.entity_id;
    let heartbeat = |count: i32, last: i64| Heartbeat {
      reader_id,
      writer_id: writer_guid.entity_id,
      first_sn: SequenceNumber::new(1),
      last_sn: SequenceNumber::new(last),
      count,
    };
    assert!(reader.handle_heartbeat_msg(&heartbeat(1, 1), false, &mr_state));
    // Sample 1: 40,000 bytes in 40 fragments of 1,000, arriving after the HEARTBEAT.
    let payload: Vec<u8> = [0x00, 0x01, 0x00, 0x00]
      .into_iter()
      .chain((0..39_996).map(|i| (i % 251) as u8))
      .collect();
    let flags = BitFlags::<DATAFRAG_Flags>::from_flag(DATAFRAG_Flags::Endianness);
    for (i, chunk) in payload.chunks(1000).enumerate() {
      let frag = DataFrag {
        reader_id,
        writer_id: writer_guid.entity_id,
        writer_sn: SequenceNumber::new(1),
        fragment_starting_num: FragmentNumber::new(i as u32 + 1),
        fragments_in_submessage: 1,
        data_size: payload.len() as u32,
        fragment_size: 1000,
        inline_qos: None,
        serialized_payload: bytes::Bytes::copy_from_slice(chunk),
      };
      reader.handle_datafrag_msg(&frag, flags, &mr_state);
      if i == 0 {
        // The first fragment is in, the rest on its way: asking now sends them twice.
        let (asked, _) = requests_sent(&socket);
        assert!(
          asked.is_empty(),
          "the reader asked for {asked:?} while the sample's fragments were on their way"
        );
      }
    }
    assert_eq!(
      reader
        .matched_writer(writer_guid)
        .unwrap()
        .all_ackable_before(),
      SequenceNumber::new(2),
      "the sample was not assembled"
    );
    // The response delay passes: the reader acknowledges the sample and asks for nothing.
    std::thread::sleep(reader.heartbeat_response_delay);
    run_due_timers(&mut reader, &timer);
    // Within the suppression duration, a HEARTBEAT announcing nothing newer is ignored.
    assert!(!reader.handle_heartbeat_msg(&heartbeat(2, 1), false, &mr_state));
    let (asked, acknacks) = requests_sent(&socket);
    assert_eq!(acknacks, 1, "the HEARTBEAT was never answered");
    assert!(asked.is_empty(), "the reader asked for {asked:?}");
    // One that announces a newer sample is answered, after the delay, with what is missing.
    assert!(reader.handle_heartbeat_msg(&heartbeat(3, 2), false, &mr_state));
    std::thread::sleep(reader.heartbeat_response_delay);
    run_due_timers(&mut reader, &timer);
    let (asked, acknacks) = requests_sent(&socket);
    assert_eq!((asked, acknacks), (vec![(2, None)], 1));
  }

  // The ACKNACKs the reader sent to `socket` since the last call: (bitmapBase, the sequence
  // numbers in the set, final flag) each.
  fn acknacks_sent(socket: &std::net::UdpSocket) -> Vec<(i64, Vec<i64>, bool)> {
    std::thread::sleep(StdDuration::from_millis(20));
    let mut acknacks = Vec::new();
    let mut buf = vec![0u8; 65536];
    while let Ok(n) = socket.recv(&mut buf) {
      let message = Message::read_from_buffer(&bytes::Bytes::copy_from_slice(&buf[..n])).unwrap();
      for sub in message.submessages() {
        if let crate::rtps::SubmessageBody::Reader(ReaderSubmessage::AckNack(a, flags)) = sub.body {
          acknacks.push((
            i64::from(a.reader_sn_state.base()),
            a.reader_sn_state.iter().map(i64::from).collect(),
            flags.contains(ACKNACK_Flags::Final),
          ));
        }
      }
    }
    acknacks
  }

  // Waits until the quiet poll due `after` the previous step has had its time, and runs timers.
  fn run_timers_after(reader: &mut Reader, timer: &SharedTimer<DpTimerEvent>, after: StdDuration) {
    std::thread::sleep(after + StdDuration::from_millis(5));
    run_due_timers(reader, timer);
  }

  #[test]
  fn a_writer_quiet_after_data_is_polled() {
    // 0011-quiet-writer-poll.patch. A Fast DDS writer sends DATA 1 to 3, then DATA 4, which is
    // lost, then nothing: no later DATA reveals the loss, and its next HEARTBEAT is 3 s away.
    let (mut reader, writer_guid, socket, timer) = reader_answering_to_a_socket();
    let fast_dds = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      source_vendor_id: VendorId::EPROSIMA,
      ..Default::default()
    };
    let other = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };
    let _preemptive = acknacks_sent(&socket);
    let reader_id = reader.my_guid.entity_id;
    let data = |reader: &mut Reader, sn: i64, mr_state: &MessageReceiverState| {
      let d = Data {
        reader_id,
        writer_id: writer_guid.entity_id,
        writer_sn: SequenceNumber::new(sn),
        ..Data::default()
      };
      reader.handle_data_msg(d, BitFlags::from_flag(DATA_Flags::Data), mr_state);
    };
    let heartbeat = |reader: &mut Reader, count: i32, last: i64| {
      let hb = Heartbeat {
        reader_id,
        writer_id: writer_guid.entity_id,
        first_sn: SequenceNumber::new(1),
        last_sn: SequenceNumber::new(last),
        count,
      };
      reader.handle_heartbeat_msg(&hb, false, &fast_dds);
    };
    for sn in 1..=3 {
      data(&mut reader, sn, &fast_dds);
    }
    run_due_timers(&mut reader, &timer);
    assert_eq!(
      acknacks_sent(&socket),
      vec![],
      "polled while DATA was coming"
    );
    // Quiet for QUIET_POLL_DELAY: a preemptive ACKNACK (base 0, final flag clear), which Fast
    // DDS answers with a HEARTBEAT at once.
    run_timers_after(&mut reader, &timer, QUIET_POLL_DELAY);
    assert_eq!(
      acknacks_sent(&socket),
      vec![(0, vec![], false)],
      "no poll when the writer went quiet after DATA"
    );
    // The HEARTBEAT announces 4; its answer asks for 4 (0009: after the response delay).
    heartbeat(&mut reader, 1, 4);
    run_timers_after(&mut reader, &timer, HEARTBEAT_RESPONSE_DELAY);
    assert_eq!(acknacks_sent(&socket), vec![(4, vec![4], true)]);
    // The repair is lost too: the next poll, twice the delay after the first and no sooner than
    // QUIET_POLL_SPACING after the HEARTBEAT's answer, asks for 4 again.
    run_timers_after(&mut reader, &timer, QUIET_POLL_SPACING + QUIET_POLL_DELAY);
    assert_eq!(
      acknacks_sent(&socket),
      vec![(4, vec![4], false)],
      "the lost repair was not asked for again"
    );
    // The repair comes, and a HEARTBEAT right after it that announces nothing newer. It may
    // have been sent just before a DATA that was lost, so the writer is still polled once.
    // (Both within QUIET_POLL_DELAY of each other, or the test thread stalled: a HEARTBEAT that
    // late counts as the word of a quiet writer, and the ACKNACKs below differ.)
    let at = Instant::now();
    data(&mut reader, 4, &fast_dds);
    heartbeat(&mut reader, 2, 4);
    let stalled = at.elapsed();
    assert!(stalled < QUIET_POLL_DELAY, "the test thread stalled {stalled:?}");
    run_timers_after(&mut reader, &timer, HEARTBEAT_RESPONSE_DELAY);
    let _ack = acknacks_sent(&socket);
    // The same HEARTBEAT again, now QUIET_POLL_DELAY after the DATA: already seen, it says
    // nothing new and does not end the polls either.
    std::thread::sleep(QUIET_POLL_DELAY);
    heartbeat(&mut reader, 2, 4);
    run_timers_after(&mut reader, &timer, QUIET_POLL_DELAY + QUIET_POLL_SPACING);
    assert_eq!(
      acknacks_sent(&socket),
      vec![(0, vec![], false)],
      "a HEARTBEAT right after the repair, or its duplicate, ended the polls"
    );
    // Its answer, a HEARTBEAT from a writer quiet since: settled, no more polls.
    heartbeat(&mut reader, 3, 4);
    run_timers_after(&mut reader, &timer, HEARTBEAT_RESPONSE_DELAY);
    let _ack = acknacks_sent(&socket);
    run_timers_after(&mut reader, &timer, 2 * (QUIET_POLL_DELAY + QUIET_POLL_SPACING));
    assert_eq!(
      acknacks_sent(&socket),
      vec![],
      "polled a writer that had said all it wrote"
    );
    // A writer that never answers is polled QUIET_POLL_MAX times after its last DATA, no more.
    data(&mut reader, 5, &fast_dds);
    let mut polls = 0;
    for _ in 0..16 {
      run_timers_after(&mut reader, &timer, StdDuration::from_millis(95));
      polls += acknacks_sent(&socket).len();
    }
    assert_eq!(
      polls, QUIET_POLL_MAX as usize,
      "polls of a writer that never answers"
    );
    // Another vendor's writer gets a spec-conforming poll: base at what the reader can
    // acknowledge (6), empty set, final flag clear.
    data(&mut reader, 6, &other);
    run_timers_after(&mut reader, &timer, QUIET_POLL_DELAY);
    assert_eq!(acknacks_sent(&socket), vec![(7, vec![], false)]);
    // A HEARTBEAT sent between DATA 7 and DATA 8, which is lost: it announces nothing missing,
    // yet the writer is polled, and the answer reveals 8.
    let at = Instant::now();
    data(&mut reader, 7, &fast_dds);
    heartbeat(&mut reader, 4, 7);
    let stalled = at.elapsed();
    assert!(stalled < QUIET_POLL_DELAY, "the test thread stalled {stalled:?}");
    run_timers_after(&mut reader, &timer, HEARTBEAT_RESPONSE_DELAY);
    let _ack = acknacks_sent(&socket);
    run_timers_after(&mut reader, &timer, QUIET_POLL_DELAY + QUIET_POLL_SPACING);
    assert_eq!(
      acknacks_sent(&socket),
      vec![(0, vec![], false)],
      "a HEARTBEAT right after the last DATA ended the polls"
    );
    heartbeat(&mut reader, 5, 8);
    run_timers_after(&mut reader, &timer, HEARTBEAT_RESPONSE_DELAY);
    assert_eq!(acknacks_sent(&socket), vec![(8, vec![8], true)]);
  }

  #[test]
  fn fragments_of_a_received_sample_leave_no_assembly_behind() {
    // A reliable user topic's reader, as in reader_sends_data_to_topic_cache.
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let qos_policy = QosPolicyBuilder::new()
      .reliability(Reliability::Reliable {
        max_blocking_time: Duration::from_millis(100),
      })
      .build();
    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();
    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let mut reader = Reader::new(
      ReaderIngredients {
        guid: reader_guid,
        notification_sender,
        status_sender,
        topic_name: topic_name.to_string(),
        topic_cache_handle,
        like_stateless: false,
        qos_policy: qos_policy.clone(),
        data_reader_command_receiver: reader_command_receiver,
        data_reader_waker: Arc::new(Mutex::new(None)),
        poll_event_sender: notification_event_sender,
        security_plugins: None,
        discovery_notify: None,
      },
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };
    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &qos_policy,
    );

    // Each sample: 8 bytes (encapsulation header and 4 of data) in two fragments of 4.
    let fragment = |sn: i64, number: u32| DataFrag {
      reader_id: reader_guid.entity_id,
      writer_id: writer_guid.entity_id,
      writer_sn: SequenceNumber::new(sn),
      fragment_starting_num: FragmentNumber::new(number),
      fragments_in_submessage: 1,
      data_size: 8,
      fragment_size: 4,
      inline_qos: None,
      serialized_payload: if number == 1 {
        bytes::Bytes::from_static(&[0x00, 0x01, 0x00, 0x00])
      } else {
        bytes::Bytes::from_static(&[1, 2, 3, 4])
      },
    };
    let flags = BitFlags::<DATAFRAG_Flags>::from_flag(DATAFRAG_Flags::Endianness);
    // Every sample arrives whole, and then its last fragment once more (a writer answering a
    // request that crossed the fragments): more samples than MAX_ASSEMBLY_BUFFERS.
    let samples = 200;
    for sn in 1..=samples {
      reader.handle_datafrag_msg(&fragment(sn, 1), flags, &mr_state);
      reader.handle_datafrag_msg(&fragment(sn, 2), flags, &mr_state);
      reader.handle_datafrag_msg(&fragment(sn, 2), flags, &mr_state);
      assert!(
        !reader.is_frag_partially_received(writer_guid, SequenceNumber::new(sn)),
        "a fragment of received sample {sn} opened an assembly buffer"
      );
    }
    // Every sample was assembled and stored, the last ones too.
    assert_eq!(
      reader
        .matched_writer(writer_guid)
        .expect("the writer is matched")
        .all_ackable_before(),
      SequenceNumber::new(samples + 1),
      "a sample was never assembled"
    );

    // A sample that became irrelevant while it was assembled (a HEARTBEAT's first_sn passed
    // it): its next fragment takes what was assembled with it.
    let next = SequenceNumber::new(samples + 1);
    reader.handle_datafrag_msg(&fragment(samples + 1, 1), flags, &mr_state);
    assert!(reader.is_frag_partially_received(writer_guid, next));
    reader
      .matched_writer_mut(writer_guid)
      .expect("the writer is matched")
      .irrelevant_changes_up_to(SequenceNumber::new(samples + 2));
    reader.handle_datafrag_msg(&fragment(samples + 1, 2), flags, &mr_state);
    assert!(
      !reader.is_frag_partially_received(writer_guid, next),
      "the assembly of a sample that became irrelevant was kept"
    );
  }

  // 0015-bounded-fragment-assembly.patch: one fragment of 1 KiB of a sample claiming
  // `data_size` bytes, sequence number `sn`, fragment `number`.
  fn claiming_fragment(
    reader_id: EntityId,
    writer: GUID,
    sn: i64,
    number: u32,
    data_size: u32,
  ) -> DataFrag {
    DataFrag {
      reader_id,
      writer_id: writer.entity_id,
      writer_sn: SequenceNumber::new(sn),
      fragment_starting_num: FragmentNumber::new(number),
      fragments_in_submessage: 1,
      data_size,
      fragment_size: 1024,
      inline_qos: None,
      serialized_payload: bytes::Bytes::from(vec![0u8; 1024]),
    }
  }

  fn assembly_bytes(reader: &Reader) -> usize {
    reader
      .fragment_assemblers
      .values()
      .map(FragmentAssembler::held_bytes)
      .sum()
  }

  #[test]
  fn fragments_are_assembled_only_from_matched_writers_within_the_bound() {
    // 0015-bounded-fragment-assembly.patch. A user reader with a matched writer.
    let (mut reader, writer_guid, _socket, timer) = reader_answering_to_a_socket();
    let reader_id = reader.my_guid.entity_id;
    let flags = BitFlags::<DATAFRAG_Flags>::from_flag(DATAFRAG_Flags::Endianness);
    let matched = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };
    let feed = |reader: &mut Reader, sn: i64, number: u32, claim: u32| {
      let frag = claiming_fragment(reader_id, writer_guid, sn, number, claim);
      reader.handle_datafrag_msg(&frag, flags, &matched);
    };
    assert_eq!(reader.max_sample_size, DEFAULT_MAX_SAMPLE_SIZE);
    reader.set_max_sample_size(1 << 30);

    // A writer the reader never matched (another participant, same writer entity id, so the
    // message receiver's UNKNOWN-reader dispatch brings it here): nothing is assembled.
    let stranger = GUID::new_with_prefix_and_id(GuidPrefix::new(&[7; 12]), writer_guid.entity_id);
    let from_stranger = MessageReceiverState {
      source_guid_prefix: stranger.prefix,
      ..Default::default()
    };
    let frag = claiming_fragment(reader_id, stranger, 1, 1, 4096);
    reader.handle_datafrag_msg(&frag, flags, &from_stranger);
    assert!(
      reader.fragment_assemblers.is_empty(),
      "a DATA_FRAG from a writer the reader has not matched opened an assembly"
    );

    // A claim above the reader's max_sample_size: dropped, nothing held (sequence number 9: the
    // dropped sample's number is skipped, 0017-oversize-sample-skipped.patch).
    reader.set_max_sample_size(1 << 20);
    feed(&mut reader, 9, 1, u32::MAX);
    assert_eq!(
      assembly_bytes(&reader),
      0,
      "a DATA_FRAG claiming 4 GiB - 1 against a bound of 1 MiB was assembled"
    );

    // A claim within the bound: what is held follows the fragments received, not the claim.
    feed(&mut reader, 1, 1, 1 << 20);
    assert!(reader.is_frag_partially_received(writer_guid, SequenceNumber::new(1)));
    let held = assembly_bytes(&reader);
    assert!(
      held < 4096,
      "one fragment of 1 KiB of a sample claiming 1 MiB holds {held} bytes"
    );

    // The assemblies of one reader hold at most twice its max_sample_size together: the last
    // fragments of two samples fill it, a third sample gets no room.
    feed(&mut reader, 2, 1024, 1 << 20);
    feed(&mut reader, 3, 1024, 1 << 20);
    assert!(reader.is_frag_partially_received(writer_guid, SequenceNumber::new(2)));
    assert!(
      !reader.is_frag_partially_received(writer_guid, SequenceNumber::new(3)),
      "a third sample was taken beyond the assembly budget ({} bytes held)",
      assembly_bytes(&reader)
    );
    assert!(assembly_bytes(&reader) <= 2 << 20);

    // An incomplete assembly is dropped once it received nothing for the assembly timeout,
    // by the reader's own timer: no later fragment is needed to trigger it.
    reader.fragment_assembly_timeout = Duration::from_millis(50);
    reader.fragment_gc_armed = false;
    reader.arm_fragment_gc();
    run_timers_after(&mut reader, &timer, StdDuration::from_millis(60));
    assert!(
      reader.fragment_assemblers.is_empty(),
      "incomplete assemblies outlived the assembly timeout ({} bytes held)",
      assembly_bytes(&reader)
    );

    // A sample within the bound still assembles, whatever order its fragments come in.
    let payload: Vec<u8> = [0x00, 0x01, 0x00, 0x00]
      .into_iter()
      .chain((0..3000u32).map(|i| i as u8))
      .collect();
    for number in [3u32, 1, 2] {
      let start = (number as usize - 1) * 1024;
      let end = (start + 1024).min(payload.len());
      let mut frag = claiming_fragment(reader_id, writer_guid, 4, number, payload.len() as u32);
      frag.serialized_payload = bytes::Bytes::copy_from_slice(&payload[start..end]);
      reader.handle_datafrag_msg(&frag, flags, &matched);
    }
    assert!(!reader.is_frag_partially_received(writer_guid, SequenceNumber::new(4)));
    assert!(
      reader
        .history_cache_change_data(SequenceNumber::new(4))
        .is_some(),
      "the sample within the bound was not assembled"
    );
  }

  #[test]
  fn an_oversize_sample_from_a_matched_writer_is_skipped() {
    // 0017-oversize-sample-skipped.patch. A reliable writer sends sample 1 above the reader's
    // max_sample_size, then sample 2 within it (one fragment).
    let (mut reader, writer_guid, _socket, _timer) = reader_answering_to_a_socket();
    let reader_id = reader.my_guid.entity_id;
    let flags = BitFlags::<DATAFRAG_Flags>::from_flag(DATAFRAG_Flags::Endianness);
    let matched = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };
    reader.set_max_sample_size(1 << 20);
    let oversize = claiming_fragment(reader_id, writer_guid, 1, 1, 2 << 20);
    reader.handle_datafrag_msg(&oversize, flags, &matched);
    let ackable = |reader: &Reader| {
      reader
        .matched_writer(writer_guid)
        .map(RtpsWriterProxy::all_ackable_before)
    };
    assert_eq!(
      ackable(&reader),
      Some(SequenceNumber::new(2)),
      "the dropped oversize sample 1 still holds back the writer's stream"
    );
    let mut small = claiming_fragment(reader_id, writer_guid, 2, 1, 1024);
    small.serialized_payload = bytes::Bytes::from([[0x00, 0x01, 0x00, 0x00].as_slice(), &[7; 1020]].concat());
    reader.handle_datafrag_msg(&small, flags, &matched);
    assert_eq!(ackable(&reader), Some(SequenceNumber::new(3)));
    assert!(reader.history_cache_change_data(SequenceNumber::new(2)).is_some());
    assert_eq!(assembly_bytes(&reader), 0);
  }

  #[test]
  fn the_spdp_reader_assembles_small_samples_from_anyone() {
    // 0015-bounded-fragment-assembly.patch. The SPDP reader matches no writer: it takes
    // fragments from any participant, up to BUILTIN_MAX_SAMPLE_SIZE.
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let qos_policy = QosPolicyBuilder::new()
      .reliability(Reliability::BestEffort)
      .build();
    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      "DCPSParticipant".to_string(),
      TypeDesc::new("SPDPDiscoveredParticipantData".to_string()),
      &qos_policy,
    );
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();
    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());
    let reader_guid = GUID::new_with_prefix_and_id(
      GuidPrefix::new(&[1; 12]),
      EntityId::SPDP_BUILTIN_PARTICIPANT_READER,
    );
    let mut reader = Reader::new(
      ReaderIngredients {
        guid: reader_guid,
        notification_sender,
        status_sender,
        topic_name: "DCPSParticipant".to_string(),
        topic_cache_handle,
        like_stateless: false,
        qos_policy,
        data_reader_command_receiver: reader_command_receiver,
        data_reader_waker: Arc::new(Mutex::new(None)),
        poll_event_sender: notification_event_sender,
        security_plugins: None,
        discovery_notify: None,
      },
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );
    let flags = BitFlags::<DATAFRAG_Flags>::from_flag(DATAFRAG_Flags::Endianness);
    let reader_id = reader_guid.entity_id;
    for (i, claim) in [(1u8, 1u32 << 30), (2, u32::MAX), (3, 1 << 17)] {
      let writer = GUID::new_with_prefix_and_id(
        GuidPrefix::new(&[i; 12]),
        EntityId::SPDP_BUILTIN_PARTICIPANT_WRITER,
      );
      let mr_state = MessageReceiverState {
        source_guid_prefix: writer.prefix,
        ..Default::default()
      };
      let frag = claiming_fragment(reader_id, writer, 1, 1, claim);
      reader.handle_datafrag_msg(&frag, flags, &mr_state);
      assert_eq!(
        assembly_bytes(&reader),
        0,
        "the SPDP reader took a fragment of a sample claiming {claim} bytes"
      );
    }
    let writer = GUID::new_with_prefix_and_id(
      GuidPrefix::new(&[4; 12]),
      EntityId::SPDP_BUILTIN_PARTICIPANT_WRITER,
    );
    let mr_state = MessageReceiverState {
      source_guid_prefix: writer.prefix,
      ..Default::default()
    };
    let frag = claiming_fragment(reader_id, writer, 1, 1, 8192);
    reader.handle_datafrag_msg(&frag, flags, &mr_state);
    assert!(
      reader.is_frag_partially_received(writer, SequenceNumber::new(1)),
      "the SPDP reader did not take a fragment of an 8 kB sample from an undiscovered participant"
    );
  }

  #[test]
  fn reader_handles_heartbeats() {
    // 1. Create a reader for a topic with Reliable QoS
    // Create the DDS cache and the topic
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let reliable_qos = QosPolicyBuilder::new()
      .reliability(Reliability::Reliable {
        max_blocking_time: Duration::from_millis(100),
      })
      .build();

    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &reliable_qos,
    );

    // Create mechanisms for notifications, statuses & commands
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker = Arc::new(Mutex::new(None));

    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();

    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());

    // Then create the reader
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let reader_ing = ReaderIngredients {
      guid: reader_guid,
      notification_sender,
      status_sender,
      topic_name: topic_name.to_string(),
      topic_cache_handle,
      like_stateless: false,
      qos_policy: reliable_qos.clone(),
      data_reader_command_receiver: reader_command_receiver,
      data_reader_waker,
      poll_event_sender: notification_event_sender,
      security_plugins: None,
      discovery_notify: None,
    };
    let mut reader = Reader::new(
      reader_ing,
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );
    // This test is about what is answered, not when: answer at once, suppress nothing.
    reader.heartbeat_response_delay = StdDuration::ZERO;
    reader.heartbeat_suppression_duration = StdDuration::ZERO;

    // 2. Add info of a matched writer to the reader
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);

    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };

    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &reliable_qos,
    );

    // 3. Send an initial heartbeat from the new writer, reader should not respond
    // with acknack first_sn: 1, last_sn: 0 to indicate no samples available
    let hb_new = Heartbeat {
      reader_id: reader.entity_id(),
      writer_id: writer_guid.entity_id,
      first_sn: SequenceNumber::new(1),
      last_sn: SequenceNumber::new(0),
      count: 1,
    };
    assert!(!reader.handle_heartbeat_msg(&hb_new, true, &mr_state)); // should be false, no ack

    // 4. Send the first proper heartbeat, reader should respond with acknack
    let hb_one = Heartbeat {
      reader_id: reader.entity_id(),
      writer_id: writer_guid.entity_id,
      first_sn: SequenceNumber::new(1), // Only one in writers cache
      last_sn: SequenceNumber::new(1),
      count: 2,
    };
    assert!(reader.handle_heartbeat_msg(&hb_one, false, &mr_state)); // Should send an ack_nack

    // 5. Send a duplicate of the first heartbeat, reader should not respond with
    // acknack
    let hb_one2 = hb_one.clone();
    assert!(!reader.handle_heartbeat_msg(&hb_one2, false, &mr_state)); // No acknack

    // 6. Send a second proper heartbeat, reader should respond with acknack
    let hb_2 = Heartbeat {
      reader_id: reader.entity_id(),
      writer_id: writer_guid.entity_id,
      first_sn: SequenceNumber::new(1), // writer has last 2 in cache
      last_sn: SequenceNumber::new(3),  // writer has written 3 samples
      count: 3,
    };
    assert!(reader.handle_heartbeat_msg(&hb_2, false, &mr_state)); // Should send an ack_nack

    // 7. Count of acknack sent should be 3: the preemptive one on match and the
    // two above. The count is verified from the writer proxy
    let writer_proxy = reader
      .matched_writer(writer_guid)
      .expect("Did not find a matched writer");
    assert_eq!(writer_proxy.sent_ack_nack_count, 3);
  }

  #[test]
  fn reader_handles_gaps() {
    // 1. Create a reader
    // Create the DDS cache and a topic
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let qos_policy = QosPolicies::qos_none();

    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );

    // Create mechanisms for notifications, statuses & commands
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker = Arc::new(Mutex::new(None));

    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();

    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());

    // Then create the reader
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let reader_ing = ReaderIngredients {
      guid: reader_guid,
      notification_sender,
      status_sender,
      topic_name: topic_name.to_string(),
      topic_cache_handle,
      like_stateless: false,
      qos_policy,
      data_reader_command_receiver: reader_command_receiver,
      data_reader_waker,
      poll_event_sender: notification_event_sender,
      security_plugins: None,
      discovery_notify: None,
    };
    let mut reader = Reader::new(
      reader_ing,
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );

    // 2. Add info of a matched writer to the reader
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);

    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };

    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &QosPolicies::qos_none(),
    );

    // 3. Feed the reader a gap message which marks sequence numbers 1-2 & 4 as
    // irrelevant
    let gap_start = SequenceNumber::new(1);
    let gap_list_base = SequenceNumber::new(3);
    let mut gap_list = SequenceNumberSet::new(gap_list_base, 7);
    gap_list.test_insert(SequenceNumber::new(4));

    let gap = Gap {
      reader_id: reader.entity_id(),
      writer_id: writer_guid.entity_id,
      gap_start,
      gap_list,
    };
    reader.handle_gap_msg(&gap, &mr_state);

    // 4. Verify that the writer proxy reports seqnums below 3 as ackable
    // This should be the case since seqnums 1-2 were marked as irrelevant
    assert_eq!(
      reader
        .matched_writer(writer_guid)
        .unwrap()
        .all_ackable_before(),
      SequenceNumber::new(3)
    );

    // 5. Feed the reader a data message with sequence number 3
    let data = Data {
      writer_id: writer_guid.entity_id,
      writer_sn: SequenceNumber::new(3),
      ..Default::default()
    };
    let data_flags = BitFlags::<DATA_Flags>::from_flag(DATA_Flags::Data);

    reader.handle_data_msg(data, data_flags, &mr_state);

    // 6. Verify that the writer proxy reports seqnums below 5 as ackable
    // This should be the case since reader received data with seqnum 3 and seqnum 4
    // was marked irrelevant before
    assert_eq!(
      reader
        .matched_writer(writer_guid)
        .unwrap()
        .all_ackable_before(),
      SequenceNumber::new(5)
    );

    // 7. Feed the reader a gap message which marks the sequence number 5 as
    // irrelevant
    let gap_start = SequenceNumber::new(5);
    let gap_list_base = SequenceNumber::new(5);
    let mut gap_list = SequenceNumberSet::new(gap_list_base, 7);
    gap_list.test_insert(SequenceNumber::new(5));

    let gap = Gap {
      reader_id: reader.entity_id(),
      writer_id: writer_guid.entity_id,
      gap_start,
      gap_list,
    };
    reader.handle_gap_msg(&gap, &mr_state);

    // 8. Verify that the writer proxy reports seqnums below 6 as ackable
    assert_eq!(
      reader
        .matched_writer(writer_guid)
        .unwrap()
        .all_ackable_before(),
      SequenceNumber::new(6)
    );
  }

  #[test]
  fn stateless_reader_does_not_contain_writer_proxies() {
    // 1. Create a stateless-like reader
    // Create the DDS cache and a topic
    let dds_cache = Arc::new(RwLock::new(DDSCache::new()));
    let topic_name = "test_name";
    let qos_policy = QosPolicies::builder()
      .reliability(Reliability::BestEffort) // Stateless needs to be BestEffort
      .build();

    let topic_cache_handle = dds_cache.write().unwrap().add_new_topic(
      topic_name.to_string(),
      TypeDesc::new("test_type".to_string()),
      &qos_policy,
    );

    // Create mechanisms for notifications, statuses & commands
    let (notification_sender, _notification_receiver) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source, notification_event_sender) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker = Arc::new(Mutex::new(None));

    let (status_sender, _status_receiver) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (participant_status_sender, _participant_status_receiver) =
      sync_status_channel(16).unwrap();

    let (_reader_command_sender, reader_command_receiver) =
      wake_channel::<ReaderCommand>(10, &LoopWaker::new());

    let like_stateless = true;
    let reader_guid = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let reader_ing = ReaderIngredients {
      guid: reader_guid,
      notification_sender,
      status_sender,
      topic_name: topic_name.to_string(),
      topic_cache_handle,
      like_stateless,
      qos_policy,
      data_reader_command_receiver: reader_command_receiver,
      data_reader_waker,
      poll_event_sender: notification_event_sender,
      security_plugins: None,
      discovery_notify: None,
    };
    let mut reader = Reader::new(
      reader_ing,
      Rc::new(UDPSender::new(0).unwrap()),
      new_shared_timer(),
      participant_status_sender,
    );

    // 2. Attempt to add info of a matched writer to the reader
    let writer_guid = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);

    let mr_state = MessageReceiverState {
      source_guid_prefix: writer_guid.prefix,
      ..Default::default()
    };

    reader.matched_writer_add(
      writer_guid,
      EntityId::UNKNOWN,
      mr_state.unicast_reply_locator_list.to_vec(),
      mr_state.multicast_reply_locator_list.to_vec(),
      &QosPolicies::qos_none(),
    );

    // 3. Verify that the reader does not contain a writer proxy for the writer that
    // we attempted to add
    assert!(reader.matched_writer(writer_guid).is_none());
  }
}
