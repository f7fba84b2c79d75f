//! The CANopen master (CiA 301 NMT master, SDO client, SYNC producer, heartbeat consumer,
//! node guarding master, EMCY consumer; CiA 302-2 boot of each configured node; PDO
//! exchange with supervision), sans-I/O, for up to `N` nodes, `BUF` bytes per SDO transfer.
//!
//! | Module | What | Specification |
//! |---|---|---|
//! | [`config`] | the master's and each node's configuration | CiA 302 0x1F80..0x1F88, gateway 0x8000 + 16n |
//! | [`sdo_client`] | SDO client, expedited and segmented | CiA 301 7.2.4 |
//! | [`nmt_master`] | NMT module control and node guarding frames | CiA 301 7.2.8.3.1 |
//! | [`sync_producer`] | SYNC on its own clock or on external cycle events | CiA 301 7.2.5 |
//! | [`guarding`] | node guarding master (toggle, life time) | CiA 301 7.2.8.3.2.1 |
//! | [`emcy_consumer`] | Emergencies of the nodes | CiA 301 7.2.7 |
//! | [`boot`] | the boot of a node and its error letters | CiA 302-2 |
//! | [`process_data`] | the nodes' PDOs and their supervision | CiA 301 7.2.2 |
//! | [`events`] | what the master reports | - |
//!
//! # Driving it
//!
//! Like [`super::node::CanNode`], from one RTIC task (or any loop), with no blocking and no
//! allocation:
//! - [`Master::start`] once (and again after [`Master::stop`]);
//! - [`Master::receive`] for every frame the controller received (the master needs to see
//!   every frame on the bus: SDO answers, heartbeats, EMCYs and the TPDOs it maps);
//! - [`Master::cycle_event`] at every external cycle event (the gateway's EtherCAT SM2 or
//!   SYNC0 event): every `sync_multiplier`-th makes a SYNC at once;
//! - [`Master::step`] until it returns false, at the latest at [`Master::next_deadline_us`]
//!   and after every [`Master::receive`];
//! - [`Master::pop_tx`] for the frames to send (lowest CAN-ID first);
//! - [`Master::pop_event`] for what happened;
//! - [`Master::set_output`] / [`Master::input`] for the process data.
//!
//! # Bounds
//!
//! Every call does a bounded amount of work, independent of the traffic:
//! - `receive`: one frame; the node is found by its node-ID among `N` places, a TPDO among
//!   `N` x [`config::PDOS_PER_NODE`] places; at most one frame queued.
//! - `step`: one service: a SYNC, the SYNC's supervision pass over the `N` x 4 inputs and
//!   outputs, one RPDO, the master's heartbeat, one heartbeat deadline, one NMT start, or
//!   one service of one node (an SDO timeout, a guard request, a boot timer, the next boot
//!   SDO, a TPDO deadline); finding it looks at each node once. At most two frames queued.
//!   It does nothing while fewer than two places are free in the outbox.
//! - `cycle_event`: at most one frame.
//!
//! # Nodes' lives
//!
//! ```text
//!  start --(reset on start)--> WaitBootup --(boot-up or boot wait over)--> Configuring
//!  Configuring --SDO steps--> WaitHeartbeat / WaitGuard --> (WaitStart) --> Operational
//!  any step fails --> Failed (letter reported; optional nodes retried after retry_ms,
//!                     mandatory ones when they boot up or the application restarts them)
//!  Operational --(heartbeat / guarding loss)--> Lost --(heard again: operational)--> Operational
//!  Operational / Lost --(boot-up, or another state)--> Configuring --> ... (NodeReturned)
//! ```

pub mod boot;
pub mod config;
pub mod emcy_consumer;
pub mod events;
pub mod guarding;
pub mod nmt_master;
pub mod process_data;
pub mod sdo_client;
pub mod sync_producer;

use super::cob;
use super::error_control::{ConsumerEntry, ConsumerEvent, HeartbeatConsumer, HeartbeatProducer};
use super::frame::CanFrame;
use super::nmt::{NmtCommand, NmtState};
use super::outbox::Outbox;
use boot::{BootError, BootOp};
use config::{MasterConfig, NodeConfig, PDOS_PER_NODE};
use emcy_consumer::EmcyLog;
use events::{BootCause, EventQueue, LossCause, MasterEvent};
use guarding::{GuardEvent, GuardMaster};
use process_data::{Input, InputProblem, InputStats, Output};
use sdo_client::{Progress, RequestError, SdoClient, SdoResult};
use sync_producer::SyncProducer;

pub use config::{ConfigError, Identity, PdoConfig, StartupSdo};

/// Frames the master can hold for the controller.
pub const OUTBOX: usize = 32;

/// Events that can wait for the application.
pub const EVENTS: usize = 32;

/// Where a node is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NodePhase {
    /// The place holds no node.
    Unused,
    /// The master is not started.
    Idle,
    /// Waiting for the boot-up message (until the time, µs).
    WaitBootup(u64),
    /// The boot's SDO steps run.
    Configuring,
    /// Waiting for the first heartbeat (until the time).
    WaitHeartbeat(u64),
    /// Waiting for the first guarding answer (until the time).
    WaitGuard(u64),
    /// Configured; waiting for the network's start (all at once).
    WaitStart,
    /// Started: process data run.
    Operational,
    /// Stopped or pre-operational by the application's NMT command.
    Halted,
    /// The boot failed; retried at the time (optional nodes) or not.
    Failed(BootError, Option<u64>),
    /// Lost while operational.
    Lost,
}

impl NodePhase {
    /// True while the node's boot runs.
    pub const fn is_booting(self) -> bool {
        matches!(
            self,
            Self::WaitBootup(_) | Self::Configuring | Self::WaitHeartbeat(_) | Self::WaitGuard(_)
        )
    }
}

/// Why a request of the application was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MasterError {
    /// No such place, or it holds no node.
    NoNode,
    /// No such PDO place.
    NoPdo,
    /// The data do not have the PDO's length.
    Length,
    /// The node's SDO channel is busy (its boot, or another request).
    Busy,
    /// The outbox is full.
    OutboxFull,
}

/// Counters of the master.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MasterStats {
    /// Frames received.
    pub received: u32,
    /// Frames of no configured node or PDO.
    pub ignored: u32,
    /// Frames dropped because the outbox was full.
    pub outbox_overflow: u32,
    /// SYNCs sent.
    pub syncs: u32,
    /// RPDOs sent.
    pub rpdos: u32,
}

/// Who uses a node's SDO channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SdoUser {
    Nobody,
    Boot(u16, BootOp),
    Application,
}

/// The master's state of one node.
#[derive(Debug, Clone)]
struct NodeRuntime<const BUF: usize> {
    phase: NodePhase,
    sdo: SdoClient<BUF>,
    sdo_user: SdoUser,
    /// The next boot step to look at, and whether to issue it.
    next_step: u16,
    step_ready: bool,
    /// The state the node last reported (boot-up, heartbeat, guarding).
    state: Option<NmtState>,
    /// Started at (µs), and whether it has reported operational since.
    started_us: u64,
    confirmed: bool,
    /// Lost since its last operational phase (a NodeReturned is due).
    was_lost: bool,
    last_error: Option<BootError>,
    guard: GuardMaster,
    emcy: EmcyLog,
    /// What the node showed of its identity in its last boot (0 where not read).
    detected: Identity,
    inputs: [Input; PDOS_PER_NODE],
    outputs: [Output; PDOS_PER_NODE],
    /// Outputs to send (bit p: output place p).
    pending: u8,
}

impl<const BUF: usize> NodeRuntime<BUF> {
    fn new(cfg: &NodeConfig, timeout_ms: u16) -> Self {
        Self {
            phase: if cfg.is_used() {
                NodePhase::Idle
            } else {
                NodePhase::Unused
            },
            sdo: SdoClient::new(cfg.node_id, timeout_ms),
            sdo_user: SdoUser::Nobody,
            next_step: 0,
            step_ready: false,
            state: None,
            started_us: 0,
            confirmed: false,
            was_lost: false,
            last_error: None,
            guard: GuardMaster::new(),
            emcy: EmcyLog::default(),
            detected: Identity::default(),
            inputs: [Input::default(); PDOS_PER_NODE],
            outputs: [Output::default(); PDOS_PER_NODE],
            pending: 0,
        }
    }
}

/// The master of up to `N` nodes with `BUF` bytes per SDO transfer.
#[derive(Debug, Clone)]
pub struct Master<const N: usize, const BUF: usize> {
    cfg: MasterConfig,
    nodes: [NodeConfig; N],
    rt: [NodeRuntime<BUF>; N],
    hb_entries: [ConsumerEntry; N],
    heartbeat: HeartbeatConsumer<N>,
    own_heartbeat: HeartbeatProducer,
    sync: SyncProducer,
    outbox: Outbox<OUTBOX>,
    events: EventQueue<EVENTS>,
    started: bool,
    network_started: bool,
    sync_pending: bool,
    cursor: usize,
    stats: MasterStats,
}

const fn us(ms: u16) -> u64 {
    ms as u64 * 1000
}

impl<const N: usize, const BUF: usize> Master<N, BUF> {
    /// A master with `cfg` and the node places `nodes` (checked: the first wrong place and
    /// its problem).
    pub fn new(cfg: MasterConfig, nodes: [NodeConfig; N]) -> Result<Self, (usize, ConfigError)> {
        for (i, n) in nodes.iter().enumerate() {
            n.check(cfg.sync_cob_id).map_err(|e| (i, e))?;
        }
        Ok(Self::with_places(cfg, nodes))
    }

    /// A master with `cfg` and every place empty (to be filled with [`Self::place_mut`]).
    pub fn unconfigured(cfg: MasterConfig) -> Self {
        Self::with_places(cfg, [NodeConfig::EMPTY; N])
    }

    fn with_places(cfg: MasterConfig, nodes: [NodeConfig; N]) -> Self {
        // Places are reported as u8 and outputs pending as 8 bits.
        const { assert!(N <= 255 && PDOS_PER_NODE <= 8) };
        let hb_entries = core::array::from_fn(|i| {
            let n = nodes.get(i).copied().unwrap_or(NodeConfig::EMPTY);
            ConsumerEntry {
                node: if n.uses_heartbeat() { n.node_id } else { 0 },
                time_ms: n.heartbeat_consumer_ms,
            }
        });
        let rt = core::array::from_fn(|i| {
            NodeRuntime::new(
                nodes.get(i).unwrap_or(&NodeConfig::EMPTY),
                cfg.sdo_timeout_ms,
            )
        });
        Self {
            sync: SyncProducer::new(
                cfg.sync_cob_id,
                cfg.sync_period_us,
                cfg.sync_multiplier,
                cfg.sync_overflow,
            ),
            cfg,
            nodes,
            rt,
            hb_entries,
            heartbeat: HeartbeatConsumer::new(),
            own_heartbeat: HeartbeatProducer::new(),
            outbox: Outbox::new(),
            events: EventQueue::new(),
            started: false,
            network_started: false,
            sync_pending: false,
            cursor: 0,
            stats: MasterStats::default(),
        }
    }

    // ------------------------------------------------------------------ queries

    /// The master's configuration.
    pub const fn config(&self) -> &MasterConfig {
        &self.cfg
    }

    /// The configuration of place `slot`.
    pub fn node_config(&self, slot: usize) -> Option<&NodeConfig> {
        self.nodes.get(slot)
    }

    /// True between [`Self::start`] and [`Self::stop`].
    pub const fn is_started(&self) -> bool {
        self.started
    }

    /// Place `slot`'s configuration to change; only while the master is stopped, so no
    /// boot runs on a configuration half written. [`Self::start`] checks every place (as
    /// [`Self::new`] does) and leaves a place that fails its check unused: check them first
    /// with [`Self::check`].
    pub fn place_mut(&mut self, slot: usize) -> Result<&mut NodeConfig, ConfigError> {
        if self.started {
            return Err(ConfigError::Running);
        }
        self.nodes.get_mut(slot).ok_or(ConfigError::NoPlace)
    }

    /// Changes the master's own parameters; only while it is stopped. (A node's SDO timeout
    /// follows at the next [`Self::start`].)
    pub fn set_config(&mut self, cfg: MasterConfig) -> Result<(), ConfigError> {
        if self.started {
            return Err(ConfigError::Running);
        }
        self.cfg = cfg;
        self.sync = SyncProducer::new(
            cfg.sync_cob_id,
            cfg.sync_period_us,
            cfg.sync_multiplier,
            cfg.sync_overflow,
        );
        Ok(())
    }

    /// The first place whose configuration is wrong, and what is wrong with it.
    pub fn check(&self) -> Result<(), (usize, ConfigError)> {
        for (i, n) in self.nodes.iter().enumerate() {
            n.check(self.cfg.sync_cob_id).map_err(|e| (i, e))?;
        }
        Ok(())
    }

    /// What the node of place `slot` showed of its identity (0x1000, 0x1018:01..04) in its
    /// last boot; 0 where the boot did not read it (an identity value not configured, or a
    /// boot that stopped before).
    pub fn detected(&self, slot: usize) -> Option<&Identity> {
        self.rt.get(slot).map(|r| &r.detected)
    }

    /// Where the node of place `slot` is.
    pub fn phase(&self, slot: usize) -> Option<NodePhase> {
        self.rt.get(slot).map(|r| r.phase)
    }

    /// The state the node last reported.
    pub fn reported_state(&self, slot: usize) -> Option<NmtState> {
        self.rt.get(slot).and_then(|r| r.state)
    }

    /// The last boot error of the node (kept after a successful boot, for the diagnosis).
    pub fn last_boot_error(&self, slot: usize) -> Option<BootError> {
        self.rt.get(slot).and_then(|r| r.last_error)
    }

    /// The node's Emergencies.
    pub fn emergencies(&self, slot: usize) -> Option<&EmcyLog> {
        self.rt.get(slot).map(|r| &r.emcy)
    }

    /// Guarding answers of the node whose toggle bit did not alternate.
    pub fn guard_toggle_errors(&self, slot: usize) -> u32 {
        self.rt.get(slot).map_or(0, |r| r.guard.toggle_errors)
    }

    /// The place of node-ID `node`.
    pub fn slot_of(&self, node: u8) -> Option<usize> {
        if node == 0 {
            return None;
        }
        self.nodes.iter().position(|n| n.node_id == node)
    }

    /// True once every mandatory node is operational (seed 002's "input scan complete"
    /// before the gateway may go to OP).
    pub fn all_mandatory_operational(&self) -> bool {
        self.started
            && self
                .nodes
                .iter()
                .zip(self.rt.iter())
                .filter(|(n, _)| n.is_used() && n.mandatory)
                .all(|(_, r)| r.phase == NodePhase::Operational)
    }

    /// Nodes operational.
    pub fn operational(&self) -> usize {
        self.rt
            .iter()
            .filter(|r| r.phase == NodePhase::Operational)
            .count()
    }

    /// The last data of input (TPDO place) `pdo` of place `slot`.
    pub fn input(&self, slot: usize, pdo: usize) -> Option<&[u8]> {
        self.rt.get(slot)?.inputs.get(pdo)?.data()
    }

    /// The counters of input `pdo` of place `slot`.
    pub fn input_stats(&self, slot: usize, pdo: usize) -> Option<InputStats> {
        Some(self.rt.get(slot)?.inputs.get(pdo)?.stats)
    }

    /// RPDO frames sent for output `pdo` of place `slot`.
    pub fn output_sent(&self, slot: usize, pdo: usize) -> u32 {
        self.rt
            .get(slot)
            .and_then(|r| r.outputs.get(pdo))
            .map_or(0, |o| o.sent)
    }

    /// The data an SDO upload the application asked for brought.
    pub fn sdo_data(&self, slot: usize) -> &[u8] {
        self.rt.get(slot).map_or(&[], |r| r.sdo.data())
    }

    /// Counters.
    pub const fn stats(&self) -> MasterStats {
        self.stats
    }

    /// Events dropped because nobody took them in time.
    pub const fn events_dropped(&self) -> u32 {
        self.events.dropped
    }

    // ------------------------------------------------------------------ the application

    /// Sets the data of output (RPDO place) `pdo` of place `slot`; they go out after the
    /// next SYNC (synchronous) or at once if they changed (event-driven).
    pub fn set_output(&mut self, slot: usize, pdo: usize, data: &[u8]) -> Result<(), MasterError> {
        let cfg = self
            .nodes
            .get(slot)
            .filter(|n| n.is_used())
            .ok_or(MasterError::NoNode)?;
        let pc = cfg
            .rpdo
            .get(pdo)
            .copied()
            .flatten()
            .ok_or(MasterError::NoPdo)?;
        let out = self
            .rt
            .get_mut(slot)
            .and_then(|r| r.outputs.get_mut(pdo))
            .ok_or(MasterError::NoPdo)?;
        if out.set(&pc, data) {
            Ok(())
        } else {
            Err(MasterError::Length)
        }
    }

    /// Starts an SDO upload from the node of place `slot`; the end comes as
    /// [`MasterEvent::SdoDone`], the data in [`Master::sdo_data`].
    pub fn sdo_upload(
        &mut self,
        slot: usize,
        index: u16,
        sub: u8,
        now_us: u64,
    ) -> Result<(), MasterError> {
        self.user_sdo(slot, |c| c.upload(index, sub, now_us))
    }

    /// Starts an SDO download to the node of place `slot` (at most `BUF` bytes).
    pub fn sdo_download(
        &mut self,
        slot: usize,
        index: u16,
        sub: u8,
        data: &[u8],
        now_us: u64,
    ) -> Result<(), MasterError> {
        self.user_sdo(slot, |c| c.download(index, sub, data, now_us))
    }

    fn user_sdo(
        &mut self,
        slot: usize,
        start: impl FnOnce(&mut SdoClient<BUF>) -> Result<CanFrame, RequestError>,
    ) -> Result<(), MasterError> {
        let r = self
            .rt
            .get_mut(slot)
            .filter(|r| r.phase != NodePhase::Unused)
            .ok_or(MasterError::NoNode)?;
        if r.phase.is_booting() || r.sdo.busy() {
            return Err(MasterError::Busy);
        }
        if self.outbox.free() == 0 {
            return Err(MasterError::OutboxFull);
        }
        let frame = start(&mut r.sdo).map_err(|e| match e {
            RequestError::Busy => MasterError::Busy,
            RequestError::Length => MasterError::Length,
        })?;
        r.sdo_user = SdoUser::Application;
        self.send(frame);
        Ok(())
    }

    /// Sends an NMT command to `node` (0: all nodes) and follows it in the nodes' phases:
    /// start makes a configured node operational, stop and pre-operational halt it, the
    /// resets boot it again.
    pub fn nmt(&mut self, command: NmtCommand, node: u8, now_us: u64) -> Result<(), MasterError> {
        if self.outbox.free() == 0 {
            return Err(MasterError::OutboxFull);
        }
        if let Some(f) = nmt_master::command_frame(command, node) {
            self.send(f);
        }
        for slot in 0..N {
            let Some(cfg) = self.nodes.get(slot).copied() else {
                continue;
            };
            if !cfg.is_used() || (node != 0 && node != cfg.node_id) {
                continue;
            }
            let phase = self.rt.get(slot).map(|r| r.phase);
            match (command, phase) {
                (NmtCommand::StartRemoteNode, Some(NodePhase::WaitStart)) => {
                    self.go_operational(slot, now_us)
                }
                (NmtCommand::StartRemoteNode, Some(NodePhase::Halted)) => self.resume(slot, now_us),
                (
                    NmtCommand::StopRemoteNode | NmtCommand::EnterPreOperational,
                    Some(NodePhase::Operational | NodePhase::WaitStart),
                ) => self.halt(slot),
                (NmtCommand::ResetNode | NmtCommand::ResetCommunication, Some(p))
                    if self.started && p != NodePhase::Idle =>
                {
                    self.wait_bootup(slot, now_us)
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Boots the node of place `slot` again (a mandatory node after its error).
    pub fn restart(&mut self, slot: usize, now_us: u64) -> Result<(), MasterError> {
        if !self.started || !self.nodes.get(slot).is_some_and(|n| n.is_used()) {
            return Err(MasterError::NoNode);
        }
        self.start_boot(slot, now_us);
        Ok(())
    }

    /// Starts the master at `now_us`: SYNC, its heartbeat, and the boot of every node
    /// (after an NMT reset of communication of all nodes if so configured).
    pub fn start(&mut self, now_us: u64) {
        // The places may have changed while stopped (`place_mut`).
        for ((n, r), hb) in self
            .nodes
            .iter_mut()
            .zip(self.rt.iter_mut())
            .zip(self.hb_entries.iter_mut())
        {
            if n.check(self.cfg.sync_cob_id).is_err() {
                *n = NodeConfig::EMPTY;
            }
            // What was heard of the node before the start stays (an operational node's
            // boot begins with an L).
            *r = NodeRuntime {
                emcy: r.emcy,
                last_error: r.last_error,
                detected: r.detected,
                state: r.state,
                ..NodeRuntime::new(n, self.cfg.sdo_timeout_ms)
            };
            *hb = ConsumerEntry {
                node: if n.uses_heartbeat() { n.node_id } else { 0 },
                time_ms: n.heartbeat_consumer_ms,
            };
        }
        self.started = true;
        self.network_started = false;
        self.sync.start(now_us);
        self.own_heartbeat.sent(now_us, self.cfg.heartbeat_ms);
        if self.cfg.reset_on_start {
            if let Some(f) =
                nmt_master::command_frame(NmtCommand::ResetCommunication, nmt_master::ALL_NODES)
            {
                self.send(f);
            }
        }
        for slot in 0..N {
            if !self.nodes.get(slot).is_some_and(|n| n.is_used()) {
                continue;
            }
            if self.cfg.reset_on_start {
                self.wait_bootup(slot, now_us);
            } else {
                self.start_boot(slot, now_us);
            }
        }
    }

    /// Stops the master: no SYNC, no heartbeat, no boots, no process data; the nodes keep
    /// their state (send an NMT command first to change it).
    pub fn stop(&mut self) {
        self.started = false;
        self.sync_pending = false;
        self.sync = SyncProducer::new(
            self.cfg.sync_cob_id,
            self.cfg.sync_period_us,
            self.cfg.sync_multiplier,
            self.cfg.sync_overflow,
        );
        self.own_heartbeat = HeartbeatProducer::new();
        self.heartbeat.reset();
        for (r, n) in self.rt.iter_mut().zip(self.nodes.iter()) {
            *r = NodeRuntime {
                emcy: r.emcy,
                last_error: r.last_error,
                detected: r.detected,
                ..NodeRuntime::new(n, self.cfg.sdo_timeout_ms)
            };
        }
    }

    /// An external cycle event at `now_us` (EtherCAT SM2 or SYNC0): every
    /// `sync_multiplier`-th sends a SYNC at once; true if this one did.
    pub fn cycle_event(&mut self, now_us: u64) -> bool {
        let _ = now_us;
        if !self.started || !self.sync.cycle_event() {
            return false;
        }
        self.produce_sync();
        true
    }

    /// The next event of the master.
    pub fn pop_event(&mut self) -> Option<MasterEvent> {
        self.events.pop()
    }

    /// The next frame to send (lowest CAN-ID first).
    pub fn pop_tx(&mut self) -> Option<CanFrame> {
        self.outbox.pop()
    }

    /// The frame [`Master::pop_tx`] would give, left in place.
    pub fn peek_tx(&self) -> Option<CanFrame> {
        self.outbox.peek()
    }

    /// Frames waiting for the controller.
    pub fn pending_tx(&self) -> usize {
        self.outbox.len()
    }

    // ------------------------------------------------------------------ internals

    fn send(&mut self, frame: CanFrame) {
        if !self.outbox.push(frame) {
            self.stats.outbox_overflow = self.stats.outbox_overflow.wrapping_add(1);
        }
    }

    fn event(&mut self, event: MasterEvent) {
        self.events.push(event);
    }

    fn ids(&self, slot: usize) -> (u8, u8) {
        (slot as u8, self.nodes.get(slot).map_or(0, |n| n.node_id))
    }

    fn set_phase(&mut self, slot: usize, phase: NodePhase) {
        if let Some(r) = self.rt.get_mut(slot) {
            r.phase = phase;
        }
    }

    fn produce_sync(&mut self) {
        if let Some(f) = self.sync.frame() {
            self.send(f);
            self.stats.syncs = self.stats.syncs.wrapping_add(1);
        }
        self.sync_pending = true;
    }

    /// Stops what runs for a node that is not operational any more.
    fn quiesce(&mut self, slot: usize) {
        if let Some(r) = self.rt.get_mut(slot) {
            for i in r.inputs.iter_mut() {
                i.stop();
            }
            r.pending = 0;
        }
    }

    fn wait_bootup(&mut self, slot: usize, now_us: u64) {
        self.quiesce(slot);
        self.heartbeat.reset_entry(slot);
        let until = now_us + us(self.cfg.boot_wait_ms);
        if let Some(r) = self.rt.get_mut(slot) {
            r.sdo.cancel();
            r.sdo_user = SdoUser::Nobody;
            r.guard.stop();
            r.state = None;
            r.phase = NodePhase::WaitBootup(until);
        }
    }

    /// Begins the boot of a node (CiA 302-2 "boot slave").
    fn start_boot(&mut self, slot: usize, now_us: u64) {
        self.quiesce(slot);
        self.heartbeat.reset_entry(slot);
        let node = self.ids(slot).1;
        let Some(r) = self.rt.get_mut(slot) else {
            return;
        };
        r.sdo.cancel();
        r.sdo_user = SdoUser::Nobody;
        r.guard.stop();
        if r.state == Some(NmtState::Operational) {
            // L: it must not run on a configuration the master did not check.
            self.fail(
                slot,
                BootError::InitiallyOperational,
                0,
                0,
                BootCause::WasOperational,
                now_us,
            );
            if let Some(f) = nmt_master::command_frame(NmtCommand::ResetCommunication, node) {
                self.send(f);
            }
            self.wait_bootup(slot, now_us);
            return;
        }
        r.phase = NodePhase::Configuring;
        r.next_step = 0;
        r.step_ready = true;
    }

    fn fail(
        &mut self,
        slot: usize,
        error: BootError,
        index: u16,
        sub: u8,
        cause: BootCause,
        now_us: u64,
    ) {
        let mandatory = self.nodes.get(slot).is_some_and(|n| n.mandatory);
        let retry = (!mandatory).then(|| now_us + us(self.cfg.retry_ms));
        self.quiesce(slot);
        if let Some(r) = self.rt.get_mut(slot) {
            r.phase = NodePhase::Failed(error, retry);
            r.last_error = Some(error);
            r.guard.stop();
            r.step_ready = false;
        }
        let (slot, node) = self.ids(slot);
        self.event(MasterEvent::BootError {
            slot,
            node,
            error,
            index,
            sub,
            cause,
        });
    }

    /// The SDO steps are done: start error control (CiA 302-2 figure 11).
    fn start_error_control(&mut self, slot: usize, now_us: u64) {
        let Some(cfg) = self.nodes.get(slot).copied() else {
            return;
        };
        if cfg.uses_heartbeat() {
            self.heartbeat.reset_entry(slot);
            self.set_phase(
                slot,
                NodePhase::WaitHeartbeat(now_us + us(cfg.heartbeat_consumer_ms)),
            );
        } else if cfg.uses_guarding() {
            if let Some(r) = self.rt.get_mut(slot) {
                r.guard.start(now_us);
                r.phase = NodePhase::WaitGuard(now_us + us(cfg.guard_time_ms));
            }
        } else {
            self.configured(slot, now_us);
        }
    }

    /// Error control runs: start the node, or wait for the network's start.
    fn configured(&mut self, slot: usize, now_us: u64) {
        if self.cfg.start_all_at_once && !self.network_started {
            self.set_phase(slot, NodePhase::WaitStart);
            let (slot, node) = self.ids(slot);
            self.event(MasterEvent::NodeBooted { slot, node });
            return;
        }
        let node = self.ids(slot).1;
        if let Some(f) = nmt_master::command_frame(NmtCommand::StartRemoteNode, node) {
            self.send(f);
        }
        let (s, node) = self.ids(slot);
        self.event(MasterEvent::NodeBooted { slot: s, node });
        self.go_operational(slot, now_us);
    }

    fn go_operational(&mut self, slot: usize, now_us: u64) {
        let returned = self.rt.get_mut(slot).is_some_and(|r| {
            r.phase = NodePhase::Operational;
            r.started_us = now_us;
            r.confirmed = false;
            for i in r.inputs.iter_mut() {
                i.start(now_us);
            }
            core::mem::take(&mut r.was_lost)
        });
        if returned {
            let (slot, node) = self.ids(slot);
            self.event(MasterEvent::NodeReturned { slot, node });
        }
    }

    /// A halted or lost node runs again without a new boot.
    fn resume(&mut self, slot: usize, now_us: u64) {
        self.go_operational(slot, now_us);
        if let Some(r) = self.rt.get_mut(slot) {
            r.confirmed = true;
        }
    }

    fn halt(&mut self, slot: usize) {
        self.quiesce(slot);
        self.set_phase(slot, NodePhase::Halted);
    }

    fn lose(&mut self, slot: usize, cause: LossCause, now_us: u64) {
        let phase = self.phase(slot);
        if !matches!(
            phase,
            Some(NodePhase::Operational | NodePhase::WaitStart | NodePhase::Halted)
        ) {
            return;
        }
        self.quiesce(slot);
        if let Some(r) = self.rt.get_mut(slot) {
            r.was_lost = true;
        }
        let (s, node) = self.ids(slot);
        self.event(MasterEvent::NodeLost {
            slot: s,
            node,
            cause,
        });
        match cause {
            LossCause::BootUp | LossCause::State(_) => self.start_boot(slot, now_us),
            LossCause::Heartbeat | LossCause::Guarding => self.set_phase(slot, NodePhase::Lost),
        }
    }

    /// A lost node is heard again in state `state`.
    fn heard_again(&mut self, slot: usize, state: Option<NmtState>, now_us: u64) {
        if self.phase(slot) != Some(NodePhase::Lost) {
            return;
        }
        if state == Some(NmtState::Operational) {
            self.resume(slot, now_us);
        } else {
            self.start_boot(slot, now_us);
        }
    }

    // ------------------------------------------------------------------ receiving

    /// A frame from the bus at `now_us`.
    pub fn receive(&mut self, frame: &CanFrame, now_us: u64) {
        self.stats.received = self.stats.received.wrapping_add(1);
        if frame.is_remote() {
            // Remote frames are other masters' requests.
            self.stats.ignored = self.stats.ignored.wrapping_add(1);
            return;
        }
        let id = frame.id();
        let data = frame.data();
        let by_node = |base: u16| id.checked_sub(base).and_then(|n| u8::try_from(n).ok());
        let handled = match id {
            0x081..=0x0FF if id != self.cfg.sync_cob_id => by_node(cob::EMCY)
                .and_then(|n| self.slot_of(n))
                .map(|slot| self.emergency(slot, data))
                .is_some(),
            0x581..=0x5FF => by_node(cob::SDO_TX)
                .and_then(|n| self.slot_of(n))
                .map(|slot| self.sdo_answer(slot, data, now_us))
                .is_some(),
            0x701..=0x77F => by_node(cob::NMT_ERROR_CONTROL)
                .and_then(|n| self.slot_of(n))
                .map(|slot| self.error_control(slot, data, now_us))
                .is_some(),
            _ => self.tpdo(id, data, now_us),
        };
        if !handled {
            self.stats.ignored = self.stats.ignored.wrapping_add(1);
        }
    }

    fn emergency(&mut self, slot: usize, data: &[u8]) {
        let Some(e) = self.rt.get_mut(slot).and_then(|r| r.emcy.receive(data)) else {
            return;
        };
        let (slot, node) = self.ids(slot);
        self.event(MasterEvent::Emergency {
            slot,
            node,
            emergency: e,
        });
    }

    fn sdo_answer(&mut self, slot: usize, data: &[u8], now_us: u64) {
        let Some(p) = self.rt.get_mut(slot).map(|r| r.sdo.receive(data, now_us)) else {
            return;
        };
        self.sdo_progress(slot, p, now_us);
    }

    fn sdo_progress(&mut self, slot: usize, p: Progress, now_us: u64) {
        if let Some(f) = p.send {
            self.send(f);
        }
        let Some(result) = p.done else {
            return;
        };
        let user = self.rt.get_mut(slot).map_or(SdoUser::Nobody, |r| {
            core::mem::replace(&mut r.sdo_user, SdoUser::Nobody)
        });
        match user {
            SdoUser::Boot(k, op) => self.boot_result(slot, k, op, result, now_us),
            SdoUser::Application => {
                let (slot, node) = self.ids(slot);
                self.event(MasterEvent::SdoDone { slot, node, result });
            }
            SdoUser::Nobody => {}
        }
    }

    fn boot_result(&mut self, slot: usize, k: u16, op: BootOp, result: SdoResult, now_us: u64) {
        if self.phase(slot) != Some(NodePhase::Configuring) {
            return;
        }
        let (index, sub) = op.address();
        let failure = match (op, result) {
            (BootOp::Read { check, .. }, Ok(_)) => {
                let actual = self.rt.get(slot).map_or(0, |r| r.sdo.value_u32());
                if let Some(r) = self.rt.get_mut(slot) {
                    let d = &mut r.detected;
                    match (index, sub) {
                        (0x1000, 0) => {
                            *d = Identity {
                                device_type: actual,
                                ..Identity::default()
                            }
                        }
                        (0x1018, 1) => d.vendor_id = actual,
                        (0x1018, 2) => d.product_code = actual,
                        (0x1018, 3) => d.revision = actual,
                        (0x1018, 4) => d.serial = actual,
                        _ => {}
                    }
                }
                check.verdict(actual).map(|e| {
                    (
                        e,
                        BootCause::Mismatch {
                            expected: check.expected(),
                            actual,
                        },
                    )
                })
            }
            (BootOp::Read { check, .. }, Err(f)) => Some((check.failure(), BootCause::Sdo(f))),
            (BootOp::Write { .. }, Ok(_)) | (BootOp::Write { may_fail: true, .. }, Err(_)) => None,
            (BootOp::Write { .. }, Err(f)) => {
                Some((BootError::ConfigurationFailed, BootCause::Sdo(f)))
            }
        };
        match failure {
            Some((error, cause)) => self.fail(slot, error, index, sub, cause, now_us),
            None => {
                if let Some(r) = self.rt.get_mut(slot) {
                    r.next_step = k + 1;
                    r.step_ready = true;
                }
            }
        }
    }

    fn error_control(&mut self, slot: usize, data: &[u8], now_us: u64) {
        let [byte] = *data else {
            return;
        };
        let Some(cfg) = self.nodes.get(slot).copied() else {
            return;
        };
        if byte == 0 {
            return self.boot_up(slot, now_us);
        }
        let state = NmtState::from_code(byte);
        let guarded = cfg.uses_guarding();
        let event = if guarded {
            self.rt.get_mut(slot).and_then(|r| {
                r.state = state;
                r.guard
                    .answer(byte, cfg.life_time_factor)
                    .map(|e| matches!(e, GuardEvent::Resumed))
            })
        } else {
            if let Some(r) = self.rt.get_mut(slot) {
                r.state = state;
            }
            self.heartbeat
                .heard(&self.hb_entries, cfg.node_id, byte, now_us)
                .map(|e| matches!(e, ConsumerEvent::Resumed { .. }))
        };
        if event == Some(true) {
            return self.heard_again(slot, state, now_us);
        }
        match self.phase(slot) {
            Some(NodePhase::WaitHeartbeat(_)) if !guarded => self.configured(slot, now_us),
            Some(NodePhase::WaitGuard(_)) if guarded => self.configured(slot, now_us),
            Some(NodePhase::Operational) => self.check_state(slot, &cfg, state, now_us),
            _ => {}
        }
    }

    /// An operational node reports `state`: another one than operational, once it has
    /// confirmed the start (or had the time to), means it was reset or stopped.
    fn check_state(&mut self, slot: usize, cfg: &NodeConfig, state: Option<NmtState>, now_us: u64) {
        let grace = us(cfg.heartbeat_consumer_ms.max(cfg.guard_time_ms));
        let Some(r) = self.rt.get_mut(slot) else {
            return;
        };
        if state == Some(NmtState::Operational) {
            r.confirmed = true;
            return;
        }
        if !r.confirmed && now_us < r.started_us + grace {
            return;
        }
        if let Some(s) = state {
            self.lose(slot, LossCause::State(s), now_us);
        }
    }

    fn boot_up(&mut self, slot: usize, now_us: u64) {
        let phase = self.phase(slot);
        if let Some(r) = self.rt.get_mut(slot) {
            r.state = Some(NmtState::PreOperational);
        }
        match phase {
            None | Some(NodePhase::Unused | NodePhase::Idle) => {}
            Some(NodePhase::Operational | NodePhase::WaitStart | NodePhase::Halted) => {
                self.lose(slot, LossCause::BootUp, now_us)
            }
            Some(_) => self.start_boot(slot, now_us),
        }
    }

    fn tpdo(&mut self, id: u16, data: &[u8], now_us: u64) -> bool {
        for slot in 0..N {
            let Some(cfg) = self.nodes.get(slot) else {
                continue;
            };
            let Some((p, pc)) = cfg
                .tpdo
                .iter()
                .enumerate()
                .find_map(|(p, t)| t.filter(|t| t.cob_id == id).map(|t| (p, t)))
            else {
                continue;
            };
            let node = cfg.node_id;
            let problem = self
                .rt
                .get_mut(slot)
                .and_then(|r| r.inputs.get_mut(p))
                .and_then(|i| i.receive(&pc, data, now_us));
            if let Some(InputProblem::Length(len)) = problem {
                self.event(MasterEvent::PdoLength {
                    slot: slot as u8,
                    node,
                    pdo: p as u8,
                    len,
                });
            }
            return true;
        }
        false
    }

    // ------------------------------------------------------------------ stepping

    /// One service at `now_us`; true if it did something (call again), false when there is
    /// nothing to do before [`Master::next_deadline_us`].
    pub fn step(&mut self, now_us: u64) -> bool {
        if !self.started || self.outbox.free() < 2 {
            return false;
        }
        if self.sync.due(now_us) {
            self.produce_sync();
            return true;
        }
        if self.sync_pending {
            self.after_sync();
            return true;
        }
        if self.send_output(now_us) {
            return true;
        }
        if self.own_heartbeat.due(now_us) {
            self.own_heartbeat.sent(now_us, self.cfg.heartbeat_ms);
            if let Ok(f) = CanFrame::new(
                cob::NMT_ERROR_CONTROL + u16::from(self.cfg.node_id),
                &[NmtState::Operational.code()],
            ) {
                self.send(f);
            }
            return true;
        }
        if let Some(ConsumerEvent::Lost { node }) = self.heartbeat.check(&self.hb_entries, now_us) {
            if let Some(slot) = self.slot_of(node) {
                self.lose(slot, LossCause::Heartbeat, now_us);
            }
            return true;
        }
        if self.network_start_due() {
            self.network_started = true;
            if let Some(f) =
                nmt_master::command_frame(NmtCommand::StartRemoteNode, nmt_master::ALL_NODES)
            {
                self.send(f);
            }
            for slot in 0..N {
                if self.phase(slot) == Some(NodePhase::WaitStart) {
                    self.go_operational(slot, now_us);
                }
            }
            return true;
        }
        for i in 0..N {
            let slot = (self.cursor + i) % N;
            if self.service_node(slot, now_us) {
                self.cursor = (slot + 1) % N;
                return true;
            }
        }
        false
    }

    /// All-at-once start: no node boots any more and every mandatory one waits for it.
    fn network_start_due(&self) -> bool {
        self.cfg.start_all_at_once
            && !self.network_started
            && self.rt.iter().all(|r| !r.phase.is_booting())
            && self.rt.iter().any(|r| r.phase == NodePhase::WaitStart)
            && self
                .nodes
                .iter()
                .zip(self.rt.iter())
                .filter(|(n, _)| n.is_used() && n.mandatory)
                .all(|(_, r)| matches!(r.phase, NodePhase::WaitStart | NodePhase::Operational))
    }

    /// The SYNC went out: supervise the synchronous inputs, queue the synchronous outputs.
    fn after_sync(&mut self) {
        self.sync_pending = false;
        for slot in 0..N {
            let Some(cfg) = self.nodes.get(slot).copied() else {
                continue;
            };
            let Some(r) = self.rt.get_mut(slot) else {
                continue;
            };
            if r.phase != NodePhase::Operational {
                continue;
            }
            let mut missing = [false; PDOS_PER_NODE];
            for ((i, t), m) in r
                .inputs
                .iter_mut()
                .zip(cfg.tpdo.iter())
                .zip(missing.iter_mut())
            {
                if let Some(t) = t {
                    *m = i.sync(t) == Some(InputProblem::Missing);
                }
            }
            for (p, (o, c)) in r.outputs.iter().zip(cfg.rpdo.iter()).enumerate() {
                if c.is_some_and(|c| o.due_at_sync(&c)) {
                    r.pending |= 1 << p;
                }
            }
            for (p, _) in missing.iter().enumerate().filter(|(_, m)| **m) {
                self.events.push(MasterEvent::PdoMissing {
                    slot: slot as u8,
                    node: cfg.node_id,
                    pdo: p as u8,
                });
            }
        }
    }

    /// Sends one output that is due.
    fn send_output(&mut self, now_us: u64) -> bool {
        for slot in 0..N {
            let Some(cfg) = self.nodes.get(slot) else {
                continue;
            };
            let Some(r) = self.rt.get_mut(slot) else {
                continue;
            };
            if r.pending == 0 {
                continue;
            }
            let p = r.pending.trailing_zeros() as usize;
            r.pending &= !(1 << p);
            let (Some(Some(pc)), Some(o)) = (cfg.rpdo.get(p), r.outputs.get_mut(p)) else {
                return true;
            };
            let frame = o.data().and_then(|d| CanFrame::new(pc.cob_id, d).ok());
            o.sent(pc, now_us);
            if let Some(f) = frame {
                self.stats.rpdos = self.stats.rpdos.wrapping_add(1);
                self.send(f);
            }
            return true;
        }
        false
    }

    /// One service of one node, if one is due.
    fn service_node(&mut self, slot: usize, now_us: u64) -> bool {
        let Some(cfg) = self.nodes.get(slot).copied().filter(|c| c.is_used()) else {
            return false;
        };
        let Some(r) = self.rt.get_mut(slot) else {
            return false;
        };
        // The SDO's timeout.
        if r.sdo.deadline_us().is_some_and(|t| now_us >= t) {
            let p = r.sdo.poll(now_us);
            self.sdo_progress(slot, p, now_us);
            return true;
        }
        // Node guarding.
        let (request, event) = r
            .guard
            .request(now_us, cfg.guard_time_ms, cfg.life_time_factor);
        if request {
            if let Some(f) = nmt_master::guard_request(cfg.node_id) {
                self.send(f);
            }
            if event == Some(GuardEvent::Lost) {
                self.lose(slot, LossCause::Guarding, now_us);
            }
            return true;
        }
        match r.phase {
            NodePhase::WaitBootup(t) if now_us >= t => self.start_boot(slot, now_us),
            NodePhase::WaitHeartbeat(t) if now_us >= t => {
                let e = BootError::HeartbeatMissing;
                self.fail(slot, e, 0, 0, BootCause::Silent, now_us)
            }
            NodePhase::WaitGuard(t) if now_us >= t => {
                let e = BootError::GuardingStateCheck;
                self.fail(slot, e, 0, 0, BootCause::Silent, now_us)
            }
            NodePhase::Failed(_, Some(t)) if now_us >= t => self.start_boot(slot, now_us),
            NodePhase::Configuring if r.step_ready && !r.sdo.busy() => {
                r.step_ready = false;
                let next = boot::next_op(&cfg, r.next_step);
                self.boot_step(slot, next, now_us)
            }
            NodePhase::Operational => return self.service_process_data(slot, &cfg, now_us),
            _ => return false,
        }
        true
    }

    /// Issues the boot's next SDO, or starts error control after the last.
    fn boot_step(&mut self, slot: usize, next: Option<(u16, BootOp)>, now_us: u64) {
        let Some((k, op)) = next else {
            return self.start_error_control(slot, now_us);
        };
        let Some(r) = self.rt.get_mut(slot) else {
            return;
        };
        let started = match op {
            BootOp::Read { index, sub, .. } => r.sdo.upload(index, sub, now_us),
            BootOp::Write {
                index,
                sub,
                value,
                size,
                ..
            } => {
                let bytes = value.to_le_bytes();
                let n = usize::from(size).clamp(1, 4);
                r.sdo
                    .download(index, sub, bytes.get(..n).unwrap_or(&bytes), now_us)
            }
        };
        match started {
            Ok(f) => {
                r.sdo_user = SdoUser::Boot(k, op);
                self.send(f);
            }
            Err(_) => {
                // Only a buffer of fewer than 4 bytes gets here.
                let (index, sub) = op.address();
                let code = crate::abort::SdoAbortCode::OutOfMemory;
                let cause = BootCause::Sdo(sdo_client::SdoFailure::Client(code));
                self.fail(
                    slot,
                    BootError::ConfigurationFailed,
                    index,
                    sub,
                    cause,
                    now_us,
                );
            }
        }
    }

    /// An operational node: the deadlines of its inputs, the event timers of its outputs.
    fn service_process_data(&mut self, slot: usize, cfg: &NodeConfig, now_us: u64) -> bool {
        let Some(r) = self.rt.get_mut(slot) else {
            return false;
        };
        for (p, (i, t)) in r.inputs.iter_mut().zip(cfg.tpdo.iter()).enumerate() {
            if let Some(t) = t {
                if i.check_deadline(t, now_us) == Some(InputProblem::Timeout) {
                    self.events.push(MasterEvent::PdoTimeout {
                        slot: slot as u8,
                        node: cfg.node_id,
                        pdo: p as u8,
                    });
                    return true;
                }
            }
        }
        for (p, (o, c)) in r.outputs.iter().zip(cfg.rpdo.iter()).enumerate() {
            if c.is_some_and(|c| o.due_by_event(&c, now_us)) && r.pending & (1 << p) == 0 {
                r.pending |= 1 << p;
                return true;
            }
        }
        false
    }

    /// The latest time [`Master::step`] must run next (`Some(0)`: at once).
    pub fn next_deadline_us(&self) -> Option<u64> {
        if !self.started {
            return None;
        }
        if self.sync_pending
            || self.network_start_due()
            || self
                .rt
                .iter()
                .any(|r| r.pending != 0 || (r.phase == NodePhase::Configuring && r.step_ready))
        {
            return Some(0);
        }
        let mut next: Option<u64> = None;
        let mut take = |t: Option<u64>| {
            if let Some(t) = t {
                next = Some(next.map_or(t, |n: u64| n.min(t)));
            }
        };
        take(self.sync.next_us());
        take(
            self.own_heartbeat
                .next_us()
                .filter(|_| self.cfg.heartbeat_ms != 0),
        );
        take(self.heartbeat.next_deadline_us(&self.hb_entries));
        for (r, cfg) in self.rt.iter().zip(self.nodes.iter()) {
            take(r.sdo.deadline_us());
            take(r.guard.next_us());
            take(match r.phase {
                NodePhase::WaitBootup(t)
                | NodePhase::WaitHeartbeat(t)
                | NodePhase::WaitGuard(t)
                | NodePhase::Failed(_, Some(t)) => Some(t),
                _ => None,
            });
            if r.phase == NodePhase::Operational {
                for (i, t) in r.inputs.iter().zip(cfg.tpdo.iter()) {
                    take(t.as_ref().and_then(|t| i.deadline_us(t)));
                }
                for (o, c) in r.outputs.iter().zip(cfg.rpdo.iter()) {
                    take(c.as_ref().and_then(|c| o.next_us(c)));
                }
            }
        }
        next
    }
}

#[cfg(test)]
mod tests;
