//! The gateway as the application of the EtherCAT slave application ([`Gateway`]): the
//! CANopen master (`coe_core::canopen::master`) on CAN1 behind the modular dictionary of
//! [`super::od`], and the CAN task's host ([`CanHost`] for the slave application, so the
//! Emergencies of CAN events go out on the EtherCAT mailbox).
//!
//! The EtherCAT state machine drives the CAN network (seed 002's order, the EL6751's):
//! - PREOP: the master is stopped; the EtherCAT master configures the nodes (0x8000
//!   family) and the master (0xF800) over SDO.
//! - PREOP -> SAFEOP: the process image is checked against SM2 / SM3 and the configuration
//!   against the master's rules (0x0026 "inconsistent settings" otherwise); the master
//!   starts at the CAN task's next call: the network reset, then each node's CiA 302-2 boot
//!   (identity, PDO configuration with read-back, error control, start). The transition
//!   does not wait for the boots; the inputs show them (0xF100:01 / :02 in TxPDO 0x1A80,
//!   0xA000 + 16n:01).
//! - SAFEOP -> OP: only once every mandatory node is operational (seed 002: "the inputs are
//!   scanned first"); else refused with 0x0070 "module ident list mismatch" if a mandatory
//!   node is another device than configured, or 0x0018 "no valid inputs".
//! - OP: outputs go to the nodes' RPDOs at every SM2 event, a SYNC per `sync multiplier`
//!   EtherCAT cycles (at the SM2 event, in DC mode at SYNC0); TPDOs fill the inputs. A node
//!   lost raises an Emergency (0x8130, data: node-ID, place) and a 0x10F3 message; with the
//!   policy bit 0xF800:0A.1 a mandatory node lost takes the gateway to SAFEOP + error
//!   (0x0018). A node that comes back is configured and started again by the master.
//! - Leaving OP (or a fault): the nodes' outputs go to 0; leaving SAFEOP stops the master.

use super::diagnosis::{DiagEvent, DiagHistory, DiagMessage, NodeState};
use super::layout::{MAX_INPUT_IMAGE, MAX_OUTPUT_IMAGE};
use super::network::{self, Policies};
use super::od::{
    self, diag_sub, status_sub, BIT_RATE, CONFIGURED_MODULES_INDEX, CONFIG_BASE, DATA_WORDS,
    DETECTED_MODULES_INDEX, DIAG_HISTORY_INDEX, INPUTS_BASE, MASTER_INDEX, MAX_NODES, NODE_BYTES,
    NODE_PDOS, OUTPUTS_BASE, RPDO_MAP_BASE, STATUS_INDEX, TPDO_MAP_BASE,
};
use super::process_image::{self, Block, RxAssignment, TxAssignment};
use super::stage::CycleMarks;
use super::sync::GatewayFigures;
use crate::stacks::canopen::micros as us;
use crate::stacks::canopen::task::CanHost;
use crate::stacks::canopen::window::CallKind;
use crate::stacks::diagnostics::{Diagnostics, ERR_COMMUNICATION};
use crate::stacks::entry_bytes::put_le;
use crate::stacks::ethercat::sync::{SyncMode, SyncMonitor, SyncObject};
use crate::stacks::ethercat::{Application, Effects, SlaveApp};
use coe_core::canopen::master::events::MasterEvent;
use coe_core::canopen::master::{Master, NodePhase};
use coe_core::canopen::CanFrame;
use coe_core::device::SyncManagerDesc;
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::sdo_server::Emergency;
use coe_core::{AlState, AlStatusCode, SdoAbortCode};
use et1100::SyncManager;
use heapless::Deque;

/// Bytes per SDO transfer of the master (the boot's values are at most 4 bytes).
pub const SDO_BUF: usize = 16;

/// The CANopen master of the gateway.
pub type CanMaster = Master<MAX_NODES, SDO_BUF>;

/// Emergency code of a lost node (CiA 301: life guard or heartbeat error).
pub const EMCY_NODE_LOST: u16 = 0x8130;

/// Master steps one CAN task call runs at most (each bounded, `coe_core::canopen::master`).
pub const STEPS_PER_CALL: usize = 8;

/// Emergencies of CAN events waiting for the EtherCAT mailbox.
const EMERGENCIES: usize = 4;

/// What the gateway counts per node place beyond the master's own records.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeCounters {
    /// Times lost.
    pub lost: u16,
    /// Emergencies received and the last one's code.
    pub emcy_count: u16,
    /// The last Emergency's error code.
    pub emcy_code: u16,
    /// A synchronous TPDO is missing since the last good one.
    pub tpdo_missing: bool,
}

/// The gateway's application.
pub struct Gateway {
    /// The CANopen master.
    pub master: CanMaster,
    policies: Policies,
    rx: RxAssignment,
    tx: TxAssignment,
    output_image: [u8; MAX_OUTPUT_IMAGE],
    input_image: [u8; MAX_INPUT_IMAGE],
    /// The nodes' output data as last set (0x7000 + 16n).
    outputs: [[u8; NODE_BYTES]; MAX_NODES],
    diag: Diagnostics,
    /// 0x10F3.
    pub history: DiagHistory,
    sync: SyncMonitor<GatewayFigures>,
    /// Per place.
    pub counters: [NodeCounters; MAX_NODES],
    /// Per place: the object of the last failed boot step (index << 16 | sub << 8).
    boot_objects: [u32; MAX_NODES],
    /// The ESM is in SAFEOP or OP.
    running: bool,
    /// The master starts at the CAN task's next call.
    start_pending: bool,
    /// The master had more work at the end of the last call.
    more_work: bool,
    now_ns: u64,
    emergencies: Deque<Emergency, EMERGENCIES>,
    /// Frames the CAN task's inbox lost (the image adds them).
    pub inbox_overruns: u32,
}

impl Default for Gateway {
    fn default() -> Self {
        Self::new()
    }
}

/// A little-endian number of 1..=4 bytes.
fn value_of(data: &[u8]) -> Result<u32, SdoAbortCode> {
    if data.is_empty() || data.len() > 4 {
        return Err(SdoAbortCode::LengthMismatch);
    }
    let mut b = [0u8; 4];
    b.get_mut(..data.len())
        .ok_or(SdoAbortCode::LengthMismatch)?
        .copy_from_slice(data);
    Ok(u32::from_le_bytes(b))
}

impl Gateway {
    /// The gateway at power-up: no node configured, the default assignments.
    pub fn new() -> Self {
        let (rx, tx) = process_image::default_assignments();
        Self {
            master: CanMaster::unconfigured(network::default_master_config()),
            boot_objects: [0; MAX_NODES],
            policies: Policies::default(),
            rx,
            tx,
            output_image: [0; MAX_OUTPUT_IMAGE],
            input_image: [0; MAX_INPUT_IMAGE],
            outputs: [[0; NODE_BYTES]; MAX_NODES],
            diag: Diagnostics::new(),
            history: DiagHistory::new(),
            sync: SyncMonitor::new(),
            counters: [NodeCounters::default(); MAX_NODES],
            running: false,
            start_pending: false,
            more_work: false,
            now_ns: 0,
            emergencies: Deque::new(),
            inbox_overruns: 0,
        }
    }

    /// The state of place `n` (0xA000 + 16n:01).
    pub fn node_state(&self, n: usize) -> NodeState {
        let phase = self.master.phase(n).unwrap_or(NodePhase::Unused);
        let missing = self.counters.get(n).is_some_and(|c| c.tpdo_missing);
        NodeState::of(phase, missing)
    }

    /// Bit n: place n operational; bit n: place n configured and not operational.
    pub fn node_bits(&self) -> (u16, u16) {
        let mut ok = 0u16;
        let mut bad = 0u16;
        for n in 0..MAX_NODES {
            match self.master.phase(n) {
                Some(NodePhase::Operational) => ok |= 1 << n,
                Some(NodePhase::Unused) | None => {}
                Some(_) => bad |= 1 << n,
            }
        }
        (ok, bad)
    }

    /// One call of the CAN task at `now_ns`: a received `frame` into the master, the
    /// master started if the ESM asked for it, then up to [`STEPS_PER_CALL`] steps and
    /// its events into the diagnosis.
    pub fn can_call(&mut self, frame: Option<&CanFrame>, now_ns: u64) {
        self.now_ns = now_ns;
        let now = us(now_ns);
        if core::mem::take(&mut self.start_pending) {
            self.master.start(now);
        }
        if let Some(f) = frame {
            self.master.receive(f, now);
        }
        self.more_work = false;
        for _ in 0..STEPS_PER_CALL {
            self.more_work = self.master.step(now);
            if !self.more_work {
                break;
            }
        }
        while let Some(e) = self.master.pop_event() {
            self.on_event(e);
        }
    }

    /// True if the master has work for another call now.
    pub fn work_waiting(&self, now_ns: u64) -> bool {
        self.more_work
            || self.start_pending
            || self
                .master
                .next_deadline_us()
                .is_some_and(|t| t <= us(now_ns))
    }

    /// The next Emergency of a CAN event for the EtherCAT mailbox.
    pub fn pop_emergency(&mut self) -> Option<Emergency> {
        self.emergencies.pop_front()
    }

    fn record(&mut self, event: DiagEvent, node: u8) {
        self.history.push(DiagMessage {
            event,
            node,
            time_ns: self.now_ns,
        });
    }

    fn emergency(&mut self, e: Emergency) {
        if self.emergencies.push_back(e).is_err() {
            // The oldest goes: the newest state of the network gets through.
            self.emergencies.pop_front();
            let _ = self.emergencies.push_back(e);
        }
    }

    fn on_event(&mut self, event: MasterEvent) {
        match event {
            MasterEvent::NodeBooted { slot, node } => {
                if let Some(c) = self.counters.get_mut(usize::from(slot)) {
                    c.tpdo_missing = false;
                }
                self.record(DiagEvent::Booted, node);
            }
            MasterEvent::BootError {
                slot,
                node,
                error,
                index,
                sub,
                ..
            } => {
                if let Some(o) = self.boot_objects.get_mut(usize::from(slot)) {
                    *o = u32::from(index) << 16 | u32::from(sub) << 8;
                }
                self.record(DiagEvent::BootError(error), node);
            }
            MasterEvent::NodeLost { slot, node, cause } => {
                if let Some(c) = self.counters.get_mut(usize::from(slot)) {
                    c.lost = c.lost.wrapping_add(1);
                }
                self.record(DiagEvent::Lost(cause), node);
                let e = self
                    .diag
                    .raise(ERR_COMMUNICATION, EMCY_NODE_LOST, [node, slot, 0, 0, 0]);
                self.emergency(e);
            }
            MasterEvent::NodeReturned { slot, node } => {
                if let Some(c) = self.counters.get_mut(usize::from(slot)) {
                    c.tpdo_missing = false;
                }
                self.record(DiagEvent::Returned, node);
                let lost = (0..MAX_NODES).any(|n| self.master.phase(n) == Some(NodePhase::Lost));
                if !lost {
                    if let Some(e) = self.diag.clear(ERR_COMMUNICATION) {
                        self.emergency(e);
                    }
                }
            }
            MasterEvent::Emergency {
                slot,
                node,
                emergency,
            } => {
                if let Some(c) = self.counters.get_mut(usize::from(slot)) {
                    c.emcy_count = c.emcy_count.wrapping_add(1);
                    c.emcy_code = emergency.error_code;
                }
                if emergency.error_code != 0 {
                    self.record(DiagEvent::Emergency(emergency.error_code), node);
                }
            }
            MasterEvent::PdoMissing { slot, node, .. } => {
                if let Some(c) = self.counters.get_mut(usize::from(slot)) {
                    c.tpdo_missing = true;
                }
                self.record(DiagEvent::TpdoMissing, node);
            }
            MasterEvent::PdoLength { node, .. } => self.record(DiagEvent::TpdoLength, node),
            MasterEvent::PdoTimeout { node, .. } => self.record(DiagEvent::TpdoTimeout, node),
            MasterEvent::SdoDone { .. } => {}
        }
    }

    /// Place `n`'s outputs to the master's RPDOs (those its configuration has).
    fn send_outputs(&mut self, n: usize) {
        let Some(cfg) = self.master.node_config(n).copied() else {
            return;
        };
        let Some(data) = self.outputs.get(n).copied() else {
            return;
        };
        for (k, pdo) in cfg.rpdo.iter().take(NODE_PDOS).enumerate() {
            if let Some(p) = pdo {
                if let Some(bytes) = data.get(k * 8..k * 8 + p.len()) {
                    let _ = self.master.set_output(n, k, bytes);
                }
            }
        }
    }

    fn read_node(
        &self,
        n: usize,
        base: u16,
        sub: u8,
        buf: &mut [u8],
    ) -> Result<usize, SdoAbortCode> {
        let cfg = self
            .master
            .node_config(n)
            .ok_or(SdoAbortCode::ObjectDoesNotExist)?;
        let (value, len) = match base {
            INPUTS_BASE | OUTPUTS_BASE if sub == 0 => (DATA_WORDS as u32, 1),
            INPUTS_BASE => {
                let w = data_word(sub)?;
                let k = w / 2;
                let mut bytes = [0u8; 8];
                if let Some(d) = self.master.input(n, k) {
                    let len = d.len().min(8);
                    bytes[..len].copy_from_slice(&d[..len]);
                }
                let at = (w % 2) * 4;
                (
                    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]),
                    4,
                )
            }
            OUTPUTS_BASE => {
                let w = data_word(sub)?;
                let d = self
                    .outputs
                    .get(n)
                    .ok_or(SdoAbortCode::ObjectDoesNotExist)?;
                let b = d
                    .get(w * 4..w * 4 + 4)
                    .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
                (u32::from_le_bytes([b[0], b[1], b[2], b[3]]), 4)
            }
            CONFIG_BASE => network::read_config(cfg, sub)?,
            TPDO_MAP_BASE => network::read_map(cfg, true, sub)?,
            RPDO_MAP_BASE => network::read_map(cfg, false, sub)?,
            _ => self.read_diag(n, sub)?,
        };
        put_le(buf, value, len)
    }

    fn read_diag(&self, n: usize, sub: u8) -> Result<(u32, usize), SdoAbortCode> {
        use diag_sub::*;
        let c = self.counters.get(n).copied().unwrap_or_default();
        let error = self.master.last_boot_error(n);
        let stats = |f: fn(&coe_core::canopen::master::process_data::InputStats) -> u32| {
            (0..NODE_PDOS)
                .filter_map(|k| self.master.input_stats(n, k))
                .map(|s| f(&s))
                .fold(0u32, u32::wrapping_add)
        };
        Ok(match sub {
            0 => (u32::from(LAST), 1),
            STATE => (u32::from(self.node_state(n).code()), 1),
            BOOT_ERROR => (error.map_or(0, |e| e.letter() as u32), 1),
            BOOT_ERROR_OBJECT => (self.boot_error_object(n), 4),
            EMCY_CODE => (u32::from(c.emcy_code), 2),
            EMCY_COUNT => (u32::from(c.emcy_count), 2),
            LOST_COUNT => (u32::from(c.lost), 2),
            TPDO_MISSED => (stats(|s| s.missing), 4),
            TPDO_BAD_LENGTH => (stats(|s| s.length_errors), 4),
            _ => return Err(SdoAbortCode::SubindexDoesNotExist),
        })
    }

    /// The object of the last failed boot step of place `n` (kept from its event).
    fn boot_error_object(&self, n: usize) -> u32 {
        self.boot_objects.get(n).copied().unwrap_or(0)
    }
}

/// The word (0-based) of a node data object's sub 1..=4.
fn data_word(sub: u8) -> Result<usize, SdoAbortCode> {
    crate::stacks::entry_bytes::channel(sub, DATA_WORDS)
}

impl ObjectAccess for Gateway {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        if let Some((n, base)) = od::module_of(index) {
            return self.read_node(n, base, sub, buf);
        }
        let (value, len): (u32, usize) = match (index, sub) {
            (0x1001, 0) => (self.diag.register().into(), 1),
            (0x1003, 0) => (self.diag.history.len().into(), 1),
            (0x1003, _) => (self.diag.history.get(sub)?, 4),
            (0x10F1, 0) => (2, 1),
            (0x10F1, 1) => (self.diag.local_error_reaction, 4),
            (0x10F1, 2) => (self.sync.error_limit().into(), 2),
            (0x1C12, _) => return self.rx.read(sub, buf),
            (0x1C13, _) => return self.tx.read(sub, buf),
            (0x1C32, _) => return self.sync.read(SyncObject::Outputs, sub, buf),
            (0x1C33, _) => {
                let image_bytes = self.tx.image_len();
                return self.sync.read(SyncObject::Inputs { image_bytes }, sub, buf);
            }
            (DIAG_HISTORY_INDEX, 1..) => return self.history.read(sub, buf),
            (CONFIGURED_MODULES_INDEX, 1..) => {
                let n = usize::from(sub) - 1;
                let cfg = self
                    .master
                    .node_config(n)
                    .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
                (
                    if cfg.is_used() {
                        cfg.identity.product_code
                    } else {
                        0
                    },
                    4,
                )
            }
            (DETECTED_MODULES_INDEX, 1..) => {
                let n = usize::from(sub) - 1;
                let d = self
                    .master
                    .detected(n)
                    .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
                (d.product_code, 4)
            }
            (STATUS_INDEX, 1..) => {
                let (ok, bad) = self.node_bits();
                let stats = self.master.stats();
                match sub {
                    status_sub::OPERATIONAL => (ok.into(), 2),
                    status_sub::FAULTY => (bad.into(), 2),
                    status_sub::RECEIVED => (stats.received, 4),
                    status_sub::SYNCS => (stats.syncs, 4),
                    status_sub::RPDOS => (stats.rpdos, 4),
                    status_sub::OVERRUNS => {
                        (stats.outbox_overflow.wrapping_add(self.inbox_overruns), 4)
                    }
                    _ => return Err(SdoAbortCode::SubindexDoesNotExist),
                }
            }
            (MASTER_INDEX, _) => {
                network::read_master(self.master.config(), self.policies, BIT_RATE, sub)?
            }
            _ => return read_default(index, sub, buf),
        };
        put_le(buf, value, len)
    }

    fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        if let Some((n, base)) = od::module_of(index) {
            return self.write_node(n, base, sub, data);
        }
        match (index, sub) {
            (0x1003, _) => self.diag.history.write(sub, data),
            (0x10F1, 1) => {
                self.diag.local_error_reaction = value_of(data)?;
                Ok(())
            }
            (0x10F1, 2) => {
                self.sync.set_error_limit(value_of(data)? as u16);
                Ok(())
            }
            (0x1C12 | 0x1C13 | 0x1C32 | 0x1C33, _) if state != AlState::PreOp && sub <= 2 => {
                Err(SdoAbortCode::DeviceState)
            }
            (0x1C12, _) => self.rx.write(sub, data),
            (0x1C13, _) => self.tx.write(sub, data),
            (0x1C32, _) => self.sync.write(false, sub, data),
            (0x1C33, _) => self.sync.write(true, sub, data),
            (DIAG_HISTORY_INDEX, _) => self.history.write(sub, data),
            (MASTER_INDEX, _) => {
                let mut cfg = *self.master.config();
                network::write_master(&mut cfg, &mut self.policies, sub, value_of(data)?)?;
                self.master
                    .set_config(cfg)
                    .map_err(|_| SdoAbortCode::DeviceState)
            }
            _ => {
                od::OD.entry(index, sub)?;
                Err(SdoAbortCode::CannotStore)
            }
        }
    }

    fn is_rx_mapped(&self, index: u16, sub: u8) -> bool {
        match od::module_of(index) {
            Some((n, OUTPUTS_BASE)) => {
                sub != 0 && self.rx.pdos().contains(&(od::RXPDO_BASE + n as u16))
            }
            _ => false,
        }
    }
}

impl Gateway {
    fn write_node(
        &mut self,
        n: usize,
        base: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<(), SdoAbortCode> {
        let v = value_of(data)?;
        match base {
            OUTPUTS_BASE => {
                let w = data_word(sub)?;
                let d = self
                    .outputs
                    .get_mut(n)
                    .ok_or(SdoAbortCode::ObjectDoesNotExist)?;
                if let Some(b) = d.get_mut(w * 4..w * 4 + 4) {
                    b.copy_from_slice(&v.to_le_bytes());
                }
                self.send_outputs(n);
                Ok(())
            }
            CONFIG_BASE | TPDO_MAP_BASE | RPDO_MAP_BASE => {
                let cfg = self
                    .master
                    .place_mut(n)
                    .map_err(|_| SdoAbortCode::DeviceState)?;
                match base {
                    CONFIG_BASE => network::write_config(cfg, sub, v),
                    TPDO_MAP_BASE => network::write_map(cfg, true, sub, v),
                    _ => network::write_map(cfg, false, sub, v),
                }
            }
            _ => Err(SdoAbortCode::WriteOfReadOnly),
        }
    }

    /// PREOP -> SAFEOP: the places ready for the master and checked; the start follows at
    /// the CAN task's next call.
    fn prepare_network(&mut self) -> Result<(), AlStatusCode> {
        for n in 0..MAX_NODES {
            if let Ok(cfg) = self.master.place_mut(n) {
                network::prepare_place(cfg);
            }
        }
        if self.master.check().is_err() {
            return Err(AlStatusCode::InconsistentSettings);
        }
        self.start_pending = true;
        Ok(())
    }

    /// Every node's outputs to 0 (the fault values) and sent so.
    fn zero_outputs(&mut self) {
        self.outputs = [[0; NODE_BYTES]; MAX_NODES];
        if self.master.is_started() {
            for n in 0..MAX_NODES {
                self.send_outputs(n);
            }
        }
    }
}

/// An entry's default from the dictionary (0 where none is given).
fn read_default(index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
    let (object, entry) = od::OD.entry(index, sub)?;
    let entry = object.resolve(entry);
    let written = entry
        .default()
        .encode(entry.data_type(), entry.bit_len, buf)
        .ok_or(SdoAbortCode::OutOfMemory)?;
    if written == 0 && !entry.data_type().is_variable_length() {
        let len = entry.byte_len();
        let out = buf.get_mut(..len).ok_or(SdoAbortCode::OutOfMemory)?;
        out.fill(0);
        return Ok(len);
    }
    Ok(written)
}

impl Application for Gateway {
    type Stage = CycleMarks;
    type Figures = GatewayFigures;
    type OutputBuffer = [u8; MAX_OUTPUT_IMAGE];

    fn output_buffer() -> [u8; MAX_OUTPUT_IMAGE] {
        [0; MAX_OUTPUT_IMAGE]
    }

    fn od(&self) -> &'static ObjectDictionary {
        &od::OD
    }

    fn diagnostics(&mut self) -> &mut Diagnostics {
        &mut self.diag
    }

    fn sync(&self) -> &SyncMonitor<GatewayFigures> {
        &self.sync
    }

    fn sync_mut(&mut self) -> &mut SyncMonitor<GatewayFigures> {
        &mut self.sync
    }

    fn with_objects<R>(
        &mut self,
        _: &CycleMarks,
        now_ns: u64,
        serve: impl FnOnce(&mut dyn ObjectAccess) -> R,
    ) -> R {
        if now_ns != 0 {
            self.now_ns = now_ns;
        }
        serve(self)
    }

    fn after_mailbox(&mut self, _: bool, _: &CycleMarks) -> Effects {
        Effects::default()
    }

    /// Leaving SAFEOP stops the master (the nodes keep their state; the next start resets
    /// them).
    fn set_running(&mut self, running: bool) {
        if !running {
            self.start_pending = false;
            if self.running || self.master.is_started() {
                self.master.stop();
            }
        }
        self.running = running;
    }

    fn enter_fault(&mut self, _: &CycleMarks) {
        self.zero_outputs();
    }

    fn output_len(&self) -> usize {
        self.rx.image_len()
    }

    fn prepare(
        &mut self,
        sm2: &SyncManager,
        sm3: &SyncManager,
        expect2: &SyncManagerDesc,
        expect3: &SyncManagerDesc,
    ) -> Result<(), AlStatusCode> {
        process_image::check(&self.rx, &self.tx, sm2, sm3, expect2, expect3)?;
        self.prepare_network()?;
        self.input_image = [0; MAX_INPUT_IMAGE];
        Ok(())
    }

    fn check_op(&mut self) -> Result<(), AlStatusCode> {
        if self.master.all_mandatory_operational() {
            return Ok(());
        }
        let wrong_device = (0..MAX_NODES).any(|n| {
            self.master.node_config(n).is_some_and(|c| c.mandatory)
                && self.node_state(n) == NodeState::WrongIdentity
        });
        Err(if wrong_device {
            AlStatusCode::ModuleIdentListMismatch
        } else {
            AlStatusCode::NoValidInputs
        })
    }

    fn op_fault(&mut self) -> Option<AlStatusCode> {
        (self.policies.lost_mandatory_al_error && !self.master.all_mandatory_operational())
            .then_some(AlStatusCode::NoValidInputs)
    }

    fn output_image(&mut self) -> &mut [u8] {
        let len = self.rx.image_len();
        self.output_image.get_mut(..len).unwrap_or(&mut [])
    }

    /// The cycle's outputs to the nodes' RPDOs (sent after the cycle's SYNC).
    fn take_outputs(&mut self, stage: &CycleMarks) -> Effects {
        let mut at = 0;
        for i in 0..self.rx.pdos().len() {
            let block = self.rx.blocks().nth(i);
            if let Some(Block::Node(n)) = block {
                if let (Some(src), Some(dst)) = (
                    self.output_image.get(at..at + NODE_BYTES),
                    self.outputs.get_mut(n),
                ) {
                    dst.copy_from_slice(src);
                }
                self.send_outputs(n);
                at += NODE_BYTES;
            }
        }
        stage.outputs_taken();
        Effects::default()
    }

    fn input_image(&mut self) -> Option<&[u8]> {
        let (ok, bad) = self.node_bits();
        let mut at = 0;
        for i in 0..self.tx.pdos().len() {
            let Some(block) = self.tx.blocks().nth(i) else {
                continue;
            };
            let len = block.bytes();
            let Some(dst) = self.input_image.get_mut(at..at + len) else {
                break;
            };
            match block {
                Block::Status => {
                    dst[..2].copy_from_slice(&ok.to_le_bytes());
                    dst[2..4].copy_from_slice(&bad.to_le_bytes());
                }
                Block::Node(n) => {
                    for k in 0..NODE_PDOS {
                        let half = &mut dst[k * 8..k * 8 + 8];
                        match self.master.input(n, k) {
                            Some(d) => {
                                let l = d.len().min(8);
                                half[..l].copy_from_slice(&d[..l]);
                                half[l..].fill(0);
                            }
                            None => half.fill(0),
                        }
                    }
                }
            }
            at += len;
        }
        self.input_image.get(..at)
    }

    /// SM-synchronous and free run: the CAN cycle starts at the SM2 event.
    #[inline(always)]
    fn on_output_event(&mut self, now_ns: u64) {
        if self.sync.mode() != SyncMode::DcSync0 {
            self.master.cycle_event(us(now_ns));
        }
    }

    /// DC: the CAN cycle starts at the SYNC0 edge.
    fn on_cycle_polled(&mut self, _: &Self::Stage, now_ns: u64, edge_lo: Option<u32>) {
        if edge_lo.is_some() && self.sync.mode() == SyncMode::DcSync0 {
            self.master.cycle_event(us(now_ns));
        }
    }
}

/// The CAN task's host: the slave application with the gateway, so the Emergencies of CAN
/// events go out on the EtherCAT mailbox. The gateway has no DC-critical output of its
/// own, so every call is admitted at once.
impl CanHost for SlaveApp<Gateway> {
    type Stage = CycleMarks;

    fn call_kind(&self, frame: Option<&CanFrame>) -> CallKind {
        match frame {
            Some(_) => CallKind::Other,
            None => CallKind::Timers,
        }
    }

    fn has_steps(&self) -> bool {
        self.application().more_work
    }

    fn admit(&mut self, _: CallKind, _: u64) -> bool {
        true
    }

    fn call(&mut self, frame: Option<&CanFrame>, _: &CycleMarks, now_ns: u64) -> bool {
        self.application_mut().can_call(frame, now_ns);
        while let Some(e) = self.application_mut().pop_emergency() {
            self.emergency(e);
        }
        false
    }

    fn peek_tx(&self) -> Option<CanFrame> {
        self.application().master.peek_tx()
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        self.application_mut().master.pop_tx()
    }
}
