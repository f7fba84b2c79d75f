//! The CANopen node: NMT slave, error control, SDO server, PDOs, SYNC consumer and EMCY
//! producer of one device, on the object dictionary the application already serves.
//!
//! The node is driven by three calls, all non-blocking and panic-free:
//! - [`CanNode::receive`] for every frame the CAN controller received;
//! - [`CanNode::poll`] at [`CanNode::next_deadline_us`] at the latest (and after
//!   [`CanNode::receive`]): timers, boot-up, queued Emergencies;
//! - [`CanNode::pop_tx`] to take the frames to send, highest priority (lowest identifier)
//!   first.
//!
//! The application is a [`CanApplication`]: the [`ObjectAccess`] of the dictionary's values
//! plus the few decisions that belong to the device profile (who drives the outputs, what a
//! fault does to them, the error register). The node serves the CAN communication objects
//! itself ([`super::params`]); [`CanNode::access`] gives the combined access for another
//! transport's SDO server (the CoE mailbox), so both fieldbuses see one dictionary.
//!
//! # Who drives the outputs
//!
//! The mapping parameters (0x1600.., 0x1A00..) are shared with the EtherCAT side. The
//! application says whether CAN is the process-data source
//! ([`CanApplication::can_owns_outputs`]). When it is:
//! - RPDOs write the mapped objects and [`CanApplication::apply_outputs`] makes them take
//!   effect; the CAN fault reaction acts on the outputs ([`CanApplication::outputs_fault`]
//!   when the node leaves operational, on a heartbeat or life guarding loss and on an RPDO
//!   deadline);
//! - the mapping of a valid PDO cannot change (CiA 301: make the PDO not valid first;
//!   0x06010000), from either fieldbus.
//!
//! When it is not, RPDOs are received and dropped (counted in [`NodeStats`]), the outputs
//! are not touched, and the mappings follow the EtherCAT side's rules. TPDOs (inputs) are
//! sent in both cases: reading the inputs takes nothing from the other fieldbus.
//!
//! # Errors
//!
//! Communication errors raise bit 4 of 0x1001 through the application and go out as EMCY:
//! 0x8130 heartbeat or life guarding loss (data byte 0: the node-ID, 0 for life guarding),
//! 0x8100 SYNC timeout, 0x8240 SYNC of the wrong length, 0x8210 RPDO shorter than mapped,
//! 0x8220 RPDO longer than mapped or a TPDO mapped beyond 64 bits, 0x8250 RPDO deadline,
//! 0x8110 frames lost because the transmit queue was full. When the last one clears, the
//! application's error reset goes out. A heartbeat or life guarding loss also applies
//! 0x1029:01 (pre-operational, no change or stopped).
//!
//! # Resets
//!
//! NMT reset communication restores the CAN communication parameters and restarts every
//! protocol; reset node does the same and lets the application restore its own parameters
//! ([`CanApplication::reset`]). Neither resets the MCU or the EtherCAT side.

use super::cob;
use super::emcy::EmcyProducer;
use super::error_control::{
    ConsumerEvent, HeartbeatConsumer, HeartbeatProducer, LifeGuardEvent, NodeGuarding,
};
use super::frame::CanFrame;
use super::nmt::{NmtCommandRepr, NmtSlave, NmtState, NmtTransition, Service};
use super::outbox::Outbox;
use super::params::{self, error_behaviour, Changed, CommDefaults, CommParameters};
use super::pdo::{
    LengthCheck, MappingInfo, PdoData, PdoKind, RpdoRuntime, TpdoRuntime, Transmission,
};
use super::sdo::CanSdoServer;
use super::sync::{SyncConsumer, SyncEvent};
use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::od::{ObjectAccess, ObjectDictionary};
use crate::pdo::{ImageLayout, PdoEntry, PdoMapping};
use crate::sdo_server::machine::SdoContext;
use crate::wire::EmergencyRepr;

/// 0x1001 bit 4: communication error.
pub const ERR_COMMUNICATION: u8 = 0x10;

/// CiA 301 EMCY error codes the node raises.
pub mod emcy_code {
    /// Communication, generic (SYNC timeout).
    pub const SYNC_TIMEOUT: u16 = 0x8100;
    /// CAN overrun: frames lost.
    pub const CAN_OVERRUN: u16 = 0x8110;
    /// Life guard error or heartbeat error.
    pub const HEARTBEAT: u16 = 0x8130;
    /// PDO not processed due to length error.
    pub const PDO_LENGTH: u16 = 0x8210;
    /// PDO length exceeded.
    pub const PDO_LENGTH_EXCEEDED: u16 = 0x8220;
    /// Unexpected SYNC data length.
    pub const SYNC_LENGTH: u16 = 0x8240;
    /// RPDO timeout.
    pub const RPDO_TIMEOUT: u16 = 0x8250;
}

/// Entries a mapping parameter can hold (the node reads at most this many).
pub const MAPPING_ENTRIES: usize = 8;

/// The layout of one CAN PDO.
type Layout = ImageLayout<MAPPING_ENTRIES>;

/// Frames the node can hold for the controller.
pub const OUTBOX: usize = 8;

/// What the node needs of the application besides the object values.
pub trait CanApplication: ObjectAccess {
    /// True if CAN is the process-data source: RPDOs drive the outputs and the CAN fault
    /// reaction applies to them.
    fn can_owns_outputs(&self) -> bool;
    /// The values RPDO processing just wrote (through [`ObjectAccess::write`]) take effect.
    fn apply_outputs(&mut self);
    /// The outputs go to their fault values (CiA 401 0x6443/0x6444).
    fn outputs_fault(&mut self);
    /// True if event-driven TPDOs also go out when their data change (CiA 401 0x6423 for
    /// the analog inputs); else only their event timer sends them.
    fn change_of_state(&self) -> bool {
        false
    }
    /// Sets `bits` (and bit 0) of the error register 0x1001; returns the Emergency that
    /// reports `code` with `data` and the new register.
    fn raise_error(&mut self, bits: u8, code: u16, data: [u8; 5]) -> EmergencyRepr;
    /// Clears `bits` of 0x1001; returns the error reset Emergency (0x0000) if the register
    /// became 0.
    fn clear_error(&mut self, bits: u8) -> Option<EmergencyRepr>;
    /// NMT reset: restore the application's parameters that belong to CAN (the shared PDO
    /// mappings when CAN is the process-data source) and, with `application`, the
    /// application parameters of reset node.
    fn reset(&mut self, application: bool);
}

/// Counters of the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NodeStats {
    /// Frames received.
    pub received: u32,
    /// RPDOs dropped because CAN does not drive the outputs.
    pub rpdo_not_owner: u32,
    /// RPDOs applied.
    pub rpdo_applied: u32,
    /// TPDOs sent.
    pub tpdo_sent: u32,
    /// SYNCs used.
    pub syncs: u32,
    /// Frames dropped because the outbox was full.
    pub outbox_overflow: u32,
}

/// Communication errors the node keeps track of (one bit each).
mod fault {
    pub const HEARTBEAT: u8 = 1 << 0;
    pub const LIFE_GUARD: u8 = 1 << 1;
    pub const SYNC_TIMEOUT: u8 = 1 << 2;
    pub const SYNC_LENGTH: u8 = 1 << 3;
    pub const RPDO_LENGTH: u8 = 1 << 4;
    pub const RPDO_TIMEOUT: u8 = 1 << 5;
    pub const TPDO_LENGTH: u8 = 1 << 6;
    pub const OVERRUN: u8 = 1 << 7;
}

/// What makes TPDOs due: a SYNC (with its counter, if it carries one) or the timers at a
/// time (µs).
#[derive(Debug, Clone, Copy)]
enum TpdoTrigger {
    Sync(Option<u8>),
    Timers(u64),
}

/// What a reset of communication restarts: everything of the node but the SDO server, the
/// outbox, the error bits and the counters; what the object access of the communication
/// parameters needs.
#[derive(Debug, Clone)]
struct Runtime<const R: usize, const T: usize, const HB: usize, const Q: usize> {
    node_id: u8,
    nmt: NmtSlave,
    params: CommParameters<R, T, HB>,
    heartbeat: HeartbeatProducer,
    consumer: HeartbeatConsumer<HB>,
    guarding: NodeGuarding,
    sync: SyncConsumer,
    emcy: EmcyProducer<Q>,
    rpdo: [RpdoRuntime; R],
    tpdo: [TpdoRuntime; T],
    /// RPDO layouts, read when the node enters operational or a PDO becomes valid there
    /// (its mapping cannot change while it is valid and CAN drives the outputs).
    rpdo_layout: [Option<Layout>; R],
    /// PDO work left in steps ([`CanNode::step`]): RPDO layouts to read (bit i: RPDO i)
    /// and TPDOs to send (bit i: TPDO i, its layout read in a step of its own first).
    rpdo_steps: u32,
    tpdo_steps: u32,
    /// The layout of a TPDO between its two steps.
    tpdo_layout: [Option<Layout>; T],
}

/// Milliseconds of `us` modulo 2^32 (the SDO server's wrapping clock), from 32-bit
/// divisions: a `u64` division would link the software 64-bit divide on a Cortex-M3. The
/// high word only contributes its remainder; then two 16-bit digits (each partial value
/// stays below 1000 * 2^16 + 2^16, each digit of the quotient below 2^16).
pub const fn wrapping_ms(us: u64) -> u32 {
    let (hi, lo) = ((us >> 32) as u32, us as u32);
    let rem = hi % 1000;
    let part = (rem << 16) | (lo >> 16);
    let q1 = part / 1000;
    let part = ((part % 1000) << 16) | (lo & 0xFFFF);
    let q0 = part / 1000;
    (q1 << 16) | q0
}

/// The CAN fault reaction: the outputs go to their fault values if CAN drives them.
// Out of line: four fault paths (leaving operational, NMT reset, heartbeat or life
// guarding loss, RPDO deadline) share one copy of the application's reaction.
#[inline(never)]
fn fault_outputs<A: CanApplication + ?Sized>(app: &mut A) {
    if app.can_owns_outputs() {
        app.outputs_fault();
    }
}

/// Writes an RPDO's objects with `layout` (no copy of the layout); true if it was taken.
// Out of line: an event-driven RPDO and the SYNC's pending ones share one copy.
#[inline(never)]
fn unpack<A: CanApplication + ?Sized>(
    stats: &mut NodeStats,
    layout: &Layout,
    data: &[u8],
    app: &mut A,
) -> bool {
    let ok = layout.unpack(data, app, AlState::Op).is_ok();
    if ok {
        stats.rpdo_applied = stats.rpdo_applied.wrapping_add(1);
    }
    ok
}

/// The lowest `n` bits set (one per PDO).
const fn bits(n: usize) -> u32 {
    if n >= 32 {
        u32::MAX
    } else {
        (1 << n) - 1
    }
}

/// Reads mapping parameter `index` through the application.
fn read_mapping<A: ObjectAccess + ?Sized>(
    app: &mut A,
    index: u16,
) -> Option<PdoMapping<MAPPING_ENTRIES>> {
    let mut b = [0u8; 4];
    app.read(index, 0, &mut b).ok()?;
    let count = usize::from(b[0]).min(MAPPING_ENTRIES);
    let mut entries = [PdoEntry::default(); MAPPING_ENTRIES];
    for (sub, e) in (1u8..).zip(entries.iter_mut().take(count)) {
        let n = app.read(index, sub, &mut b).ok()?;
        if n != 4 {
            return None;
        }
        *e = PdoEntry::from_u32(u32::from_le_bytes(b));
    }
    Some(PdoMapping::with_entries(
        index,
        entries.get(..count).unwrap_or(&[]),
    ))
}

/// The layout of PDO `i` of `kind` (None: the mapping is unreadable or not valid).
// Out of line: the RPDO and the TPDO steps share one copy of the layout construction.
#[inline(never)]
fn pdo_layout<A: ObjectAccess + ?Sized>(app: &mut A, kind: PdoKind, i: usize) -> Option<Layout> {
    read_mapping(app, mapping_index(kind, i)).and_then(|m| Layout::of_mapping(&m).ok())
}

/// The mapping of PDO `i` of `kind` as the communication parameter rules need it.
fn mapping_info<A: ObjectAccess + ?Sized>(app: &mut A, kind: PdoKind, i: usize) -> MappingInfo {
    let index = mapping_index(kind, i);
    read_mapping(app, index).map_or(MappingInfo::default(), |m| MappingInfo {
        count: m.count(),
        bits: m.bit_len(),
    })
}

const fn mapping_index(kind: PdoKind, i: usize) -> u16 {
    match kind {
        PdoKind::Rpdo => params::RPDO_MAPPING + i as u16,
        PdoKind::Tpdo => params::TPDO_MAPPING + i as u16,
    }
}

impl<const R: usize, const T: usize, const HB: usize, const Q: usize> Runtime<R, T, HB, Q> {
    /// The runtime of a node that has just (re)started communication.
    fn new(node_id: u8, defaults: &CommDefaults<R, T>) -> Self {
        Self {
            node_id,
            nmt: NmtSlave::new(),
            params: CommParameters::defaults(defaults, node_id),
            heartbeat: HeartbeatProducer::new(),
            consumer: HeartbeatConsumer::new(),
            guarding: NodeGuarding::new(),
            sync: SyncConsumer::new(),
            emcy: EmcyProducer::new(),
            rpdo: [RpdoRuntime::default(); R],
            tpdo: [TpdoRuntime::default(); T],
            rpdo_layout: [None; R],
            rpdo_steps: 0,
            tpdo_steps: 0,
            tpdo_layout: [None; T],
        }
    }

    /// Reads the layout of RPDO `i` (None: not valid, unreadable or not a CAN PDO).
    fn load_rpdo_layout<A: ObjectAccess + ?Sized>(&mut self, app: &mut A, i: usize) {
        let valid = self.params.rpdo.get(i).is_some_and(|c| c.is_valid());
        let layout = if valid {
            pdo_layout(app, PdoKind::Rpdo, i).filter(|l| l.bit_len() <= super::pdo::MAX_PDO_BITS)
        } else {
            None
        };
        if let Some(slot) = self.rpdo_layout.get_mut(i) {
            *slot = layout;
        }
    }

    /// A parameter write took effect: restart what depends on it.
    fn changed<A: ObjectAccess + ?Sized>(&mut self, what: Changed, app: &mut A, now_us: u64) {
        let operational = self.nmt.state() == NmtState::Operational;
        match what {
            Changed::Nothing => {}
            Changed::Heartbeat => self.heartbeat.restart(now_us, self.params.heartbeat_ms),
            Changed::Consumer(i) => self.consumer.reset_entry(i),
            Changed::Sync => self.sync.reset(),
            Changed::Rpdo(i) => {
                if let Some(rt) = self.rpdo.get_mut(i) {
                    *rt = RpdoRuntime::default();
                }
                if operational {
                    self.load_rpdo_layout(app, i);
                }
            }
            Changed::Tpdo(i) => {
                // A transmission queued under the old parameters is dropped.
                self.tpdo_steps &= !(1 << i);
                if let Some(l) = self.tpdo_layout.get_mut(i) {
                    *l = None;
                }
                if let (Some(rt), Some(comm), true) =
                    (self.tpdo.get_mut(i), self.params.tpdo.get(i), operational)
                {
                    rt.start(comm, now_us);
                }
            }
        }
    }

    /// True if the mapping object `index` belongs to a valid CAN PDO while CAN drives the
    /// outputs: it cannot change then.
    fn mapping_locked(&self, index: u16, owner: bool) -> bool {
        owner
            && CommParameters::<R, T, HB>::mapping_of(index)
                .and_then(|(kind, i)| self.params.pdo(kind, i))
                .is_some_and(|c| c.is_valid())
    }
}

/// The object access of a transport's SDO server: the node's communication parameters,
/// everything else from the application, with the shared-mapping rule.
pub struct NodeAccess<
    'a,
    A: CanApplication + ?Sized,
    const R: usize,
    const T: usize,
    const HB: usize,
    const Q: usize,
> {
    rt: &'a mut Runtime<R, T, HB, Q>,
    app: &'a mut A,
    now_us: u64,
    can: bool,
}

impl<
        A: CanApplication + ?Sized,
        const R: usize,
        const T: usize,
        const HB: usize,
        const Q: usize,
    > ObjectAccess for NodeAccess<'_, A, R, T, HB, Q>
{
    fn read(&mut self, index: u16, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        // An object the parameters do not hold is the application's.
        match self.rt.params.read(self.rt.node_id, index, subindex, buf) {
            Err(SdoAbortCode::ObjectDoesNotExist) => self.app.read(index, subindex, buf),
            answer => answer,
        }
    }

    fn write(
        &mut self,
        index: u16,
        subindex: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        let app = &mut *self.app;
        let written = self
            .rt
            .params
            .write(index, subindex, data, |kind, i| mapping_info(app, kind, i));
        // An object the parameters do not hold is the application's.
        match written {
            Ok(what) => {
                self.rt.changed(what, self.app, self.now_us);
                return Ok(());
            }
            Err(SdoAbortCode::ObjectDoesNotExist) => {}
            Err(e) => return Err(e),
        }
        if self.rt.mapping_locked(index, self.app.can_owns_outputs()) {
            return Err(SdoAbortCode::UnsupportedAccess);
        }
        self.app.write(index, subindex, data, state)
    }

    fn is_rx_mapped(&self, index: u16, subindex: u8) -> bool {
        if !self.can {
            return self.app.is_rx_mapped(index, subindex);
        }
        self.app.can_owns_outputs()
            && self.rt.rpdo_layout.iter().flatten().any(|l| {
                l.fields()
                    .iter()
                    .any(|f| f.index == index && f.subindex == subindex)
            })
    }
}

/// A CANopen node with `R` RPDOs, `T` TPDOs, `HB` heartbeat consumer entries, `Q`
/// Emergencies that can wait and an SDO transfer buffer of `BUF` bytes.
#[derive(Debug, Clone)]
pub struct CanNode<
    const R: usize,
    const T: usize,
    const HB: usize,
    const Q: usize,
    const BUF: usize,
> {
    od: &'static ObjectDictionary,
    defaults: &'static CommDefaults<R, T>,
    rt: Runtime<R, T, HB, Q>,
    sdo: CanSdoServer<BUF>,
    outbox: Outbox<OUTBOX>,
    /// Communication errors raised and not yet cleared (bits of `fault`).
    faults: u8,
    stats: NodeStats,
    overflow_reported: u32,
    boot_pending: bool,
}

impl<const R: usize, const T: usize, const HB: usize, const Q: usize, const BUF: usize>
    CanNode<R, T, HB, Q, BUF>
{
    /// A node with node-ID `node_id` (1..=127) on dictionary `od`, its parameters at
    /// `defaults`; it sends its boot-up message at the first [`CanNode::poll`].
    pub fn new(
        node_id: u8,
        od: &'static ObjectDictionary,
        defaults: &'static CommDefaults<R, T>,
    ) -> Self {
        // The PDO steps are bit sets of 32.
        const { assert!(R <= 32 && T <= 32) };
        Self {
            od,
            defaults,
            rt: Runtime::new(node_id, defaults),
            sdo: CanSdoServer::new(),
            outbox: Outbox::new(),
            faults: 0,
            stats: NodeStats::default(),
            overflow_reported: 0,
            boot_pending: true,
        }
    }

    /// The node-ID.
    pub const fn node_id(&self) -> u8 {
        self.rt.node_id
    }

    /// The NMT state.
    pub const fn state(&self) -> NmtState {
        self.rt.nmt.state()
    }

    /// The communication parameters.
    pub const fn params(&self) -> &CommParameters<R, T, HB> {
        &self.rt.params
    }

    /// Counters.
    pub const fn stats(&self) -> NodeStats {
        self.stats
    }

    /// Frames waiting for the controller.
    pub fn pending_tx(&self) -> usize {
        self.outbox.len()
    }

    /// The next frame to send (lowest identifier first).
    pub fn pop_tx(&mut self) -> Option<CanFrame> {
        self.outbox.pop()
    }

    /// True if frames wait for [`CanNode::pop_tx`] (no search for the best one).
    pub fn has_tx(&self) -> bool {
        self.outbox.len() > 0
    }

    /// The frame [`CanNode::pop_tx`] would give, left in place (for a controller that may
    /// have no free buffer).
    pub fn peek_tx(&self) -> Option<CanFrame> {
        self.outbox.peek()
    }

    /// Queues an Emergency of the application (e.g. one the EtherCAT side raised); it goes
    /// out in pre-operational or operational, after the inhibit time.
    pub fn queue_emergency(&mut self, emergency: EmergencyRepr) {
        self.rt.emcy.push(emergency);
    }

    /// The object access for another transport's SDO server at `now_us`.
    pub fn access<'a, A: CanApplication + ?Sized>(
        &'a mut self,
        app: &'a mut A,
        now_us: u64,
    ) -> NodeAccess<'a, A, R, T, HB, Q> {
        NodeAccess {
            rt: &mut self.rt,
            app,
            now_us,
            can: false,
        }
    }

    /// The latest time [`CanNode::poll`] must run next.
    pub fn next_deadline_us(&self) -> Option<u64> {
        if self.boot_pending {
            return Some(0);
        }
        let rt = &self.rt;
        let p = &rt.params;
        let state = rt.nmt.state();
        let mut next: Option<u64> = None;
        let mut take = |t: Option<u64>| {
            if let Some(t) = t {
                next = Some(next.map_or(t, |n| n.min(t)));
            }
        };
        take(rt.heartbeat.next_us().filter(|_| p.heartbeat_ms != 0));
        take(rt.consumer.next_deadline_us(&p.consumers));
        if p.heartbeat_ms == 0 {
            take(rt.guarding.deadline_us(p.guard_time_ms, p.life_factor));
        }
        if state.allows(Service::Emcy) && p.emcy.cob_id.is_valid() {
            take(rt.emcy.next_us());
        }
        if state == NmtState::Operational {
            take(rt.sync.deadline_us(&p.sync));
            for (c, r) in p.rpdo.iter().zip(rt.rpdo.iter()) {
                if c.is_valid() {
                    take(r.deadline_us(c.event_timer_ms));
                }
            }
            for (c, r) in p.tpdo.iter().zip(rt.tpdo.iter()) {
                if c.is_valid() {
                    take(r.next_us(c));
                }
            }
        }
        next
    }

    // ------------------------------------------------------------------ sending

    // Out of line: a dozen callers would each carry a copy of the outbox search.
    #[inline(never)]
    fn send(&mut self, frame: CanFrame) {
        if !self.outbox.push(frame) {
            self.stats.outbox_overflow = self.stats.outbox_overflow.wrapping_add(1);
        }
    }

    fn send_state(&mut self, code: u8) {
        if let Ok(frame) =
            CanFrame::new(cob::NMT_ERROR_CONTROL + u16::from(self.rt.node_id), &[code])
        {
            self.send(frame);
        }
    }

    // ------------------------------------------------------------------ errors

    /// Raises a communication error of kind `kind` (once until it clears); `detail` is the
    /// first two bytes of the EMCY's manufacturer-specific field (the rest 0).
    fn raise<A: CanApplication + ?Sized>(
        &mut self,
        app: &mut A,
        kind: u8,
        code: u16,
        detail: [u8; 2],
    ) {
        if self.faults & kind != 0 {
            return;
        }
        self.faults |= kind;
        let [d0, d1] = detail;
        let e = app.raise_error(ERR_COMMUNICATION, code, [d0, d1, 0, 0, 0]);
        self.rt.emcy.push(e);
    }

    /// Clears a communication error; the error reset goes out when none is left.
    fn clear<A: CanApplication + ?Sized>(&mut self, app: &mut A, kind: u8) {
        if self.faults & kind == 0 {
            return;
        }
        self.faults &= !kind;
        if self.faults == 0 {
            if let Some(e) = app.clear_error(ERR_COMMUNICATION) {
                self.rt.emcy.push(e);
            }
        }
    }

    /// A heartbeat or life guarding loss: EMCY, fault outputs, 0x1029 reaction.
    fn communication_error<A: CanApplication + ?Sized>(
        &mut self,
        app: &mut A,
        kind: u8,
        node: u8,
        now_us: u64,
    ) {
        self.raise(app, kind, emcy_code::HEARTBEAT, [node, 0]);
        fault_outputs(app);
        let to = match (self.rt.params.error_behaviour, self.state()) {
            (error_behaviour::PRE_OPERATIONAL, NmtState::Operational) => NmtState::PreOperational,
            (error_behaviour::STOPPED, _) => NmtState::Stopped,
            _ => return,
        };
        if let Some(t) = self.rt.nmt.enter(to) {
            self.transition(t, app, now_us);
        }
    }

    // ------------------------------------------------------------------ NMT

    fn boot(&mut self, now_us: u64) {
        self.boot_pending = false;
        self.send_state(NmtState::Initialising.code());
        self.rt.nmt.booted();
        self.rt.heartbeat.sent(now_us, self.rt.params.heartbeat_ms);
    }

    fn transition<A: CanApplication + ?Sized>(
        &mut self,
        t: NmtTransition,
        app: &mut A,
        now_us: u64,
    ) {
        match t {
            NmtTransition::Enter { from, to } => {
                if from == NmtState::Operational {
                    fault_outputs(app);
                    for r in self.rt.rpdo.iter_mut() {
                        *r = RpdoRuntime::default();
                    }
                }
                if to == NmtState::Operational {
                    // One layout per step: the node is operational meanwhile, and its
                    // callers finish the steps before the next frame.
                    self.rt.rpdo_layout = [None; R];
                    self.rt.rpdo_steps = bits(R);
                    for (r, c) in self.rt.tpdo.iter_mut().zip(self.rt.params.tpdo.iter()) {
                        r.start(c, now_us);
                    }
                    self.rt.sync.reset();
                }
                if !to.allows(Service::Sdo) {
                    self.sdo.reset();
                }
                // The new state is reported at once, not only with the next heartbeat.
                if self.rt.params.heartbeat_ms != 0 {
                    self.send_state(to.code());
                    self.rt.heartbeat.sent(now_us, self.rt.params.heartbeat_ms);
                }
            }
            NmtTransition::Reset { application } => {
                fault_outputs(app);
                app.reset(application);
                // The reset clears the node's own errors (their Emergencies are dropped with
                // the queue; the error register follows).
                if core::mem::take(&mut self.faults) != 0 {
                    let _ = app.clear_error(ERR_COMMUNICATION);
                }
                // The counters stay.
                self.rt = Runtime::new(self.rt.node_id, self.defaults);
                self.sdo.reset();
                self.outbox.clear();
                self.boot(now_us);
            }
        }
    }

    // ------------------------------------------------------------------ receiving

    /// A frame from the bus at `now_us`.
    pub fn receive<A: CanApplication + ?Sized>(
        &mut self,
        frame: &CanFrame,
        app: &mut A,
        now_us: u64,
    ) {
        self.stats.received = self.stats.received.wrapping_add(1);
        if self.boot_pending {
            self.boot(now_us);
        }
        let id = frame.id();
        let node = self.rt.node_id;
        if id == cob::NMT {
            if let Some(cmd) = NmtCommandRepr::parse(frame.data()) {
                if cmd.addresses(node) {
                    if let Some(t) = self.rt.nmt.command(cmd.command) {
                        self.transition(t, app, now_us);
                    }
                }
            }
            return;
        }
        let state = self.state();
        if id == cob::NMT_ERROR_CONTROL + u16::from(node) {
            if frame.is_remote()
                && self.rt.params.heartbeat_ms == 0
                && state.allows(Service::ErrorControl)
            {
                let (answer, event) = self.rt.guarding.request(state, now_us);
                self.send_state(answer);
                if event == Some(LifeGuardEvent::Resumed) {
                    self.clear(app, fault::LIFE_GUARD);
                }
            }
            return;
        }
        if (cob::NMT_ERROR_CONTROL + 1..=cob::NMT_ERROR_CONTROL + 127).contains(&id)
            && !frame.is_remote()
        {
            if let [code] = *frame.data() {
                let from = (id - cob::NMT_ERROR_CONTROL) as u8;
                let entries = self.rt.params.consumers;
                if let Some(ConsumerEvent::Resumed { .. }) =
                    self.rt.consumer.heard(&entries, from, code, now_us)
                {
                    if !self.rt.consumer.any_lost() {
                        self.clear(app, fault::HEARTBEAT);
                    }
                }
            }
            return;
        }
        if frame.is_remote() {
            return;
        }
        if id == cob::SDO_RX + u16::from(node) {
            if let Some(access_state) = state.access_state() {
                let mut access = NodeAccess {
                    rt: &mut self.rt,
                    app,
                    now_us,
                    can: true,
                };
                let ctx = SdoContext {
                    state: access_state,
                    od: self.od,
                    // As `dyn ObjectAccess`, the type a mailbox server can use too: one
                    // copy of the SDO machine for both transports in an image.
                    app: &mut access as &mut dyn ObjectAccess,
                    now_ms: wrapping_ms(now_us),
                };
                if let Some(reply) = self.sdo.receive(node, frame, ctx) {
                    self.send(reply);
                }
            }
            return;
        }
        if self.rt.params.sync.cob_id.can_id() == id {
            if state.allows(Service::Sync) {
                self.on_sync(frame.data(), app, now_us);
            }
            return;
        }
        if state == NmtState::Operational {
            let hit = self
                .rt
                .params
                .rpdo
                .iter()
                .position(|c| c.is_valid() && c.cob_id.can_id() == id);
            if let Some(i) = hit {
                self.on_rpdo(i, frame.data(), app, now_us);
            }
        }
    }

    fn on_sync<A: CanApplication + ?Sized>(&mut self, data: &[u8], app: &mut A, now_us: u64) {
        let params = self.rt.params.sync;
        let counter = match self.rt.sync.receive(&params, data, now_us) {
            Ok(SyncEvent::Sync(c)) => c,
            Ok(SyncEvent::Resumed(c)) => {
                self.clear(app, fault::SYNC_TIMEOUT);
                c
            }
            Err(_) => {
                let n = data.len() as u8;
                self.raise(app, fault::SYNC_LENGTH, emcy_code::SYNC_LENGTH, [n, 0]);
                return;
            }
        };
        self.clear(app, fault::SYNC_LENGTH);
        if self.state() != NmtState::Operational {
            return;
        }
        self.stats.syncs = self.stats.syncs.wrapping_add(1);
        // Synchronous RPDOs received before this SYNC take effect now.
        let mut applied = false;
        for (r, layout) in self.rt.rpdo.iter_mut().zip(&self.rt.rpdo_layout) {
            if let (Some(data), Some(layout)) = (r.pending.take(), layout) {
                applied |= unpack(&mut self.stats, layout, data.as_slice(), app);
            }
        }
        if applied {
            app.apply_outputs();
        }
        // Then the synchronous TPDOs.
        self.service_tpdos(app, TpdoTrigger::Sync(counter));
    }

    /// Queues the valid TPDOs that `trigger` makes due for [`CanNode::step`] (a SYNC the
    /// synchronous ones, the timers the event-driven ones), after change detection for the
    /// acyclic and event-driven types.
    fn service_tpdos<A: CanApplication + ?Sized>(&mut self, app: &mut A, trigger: TpdoTrigger) {
        let synchronous = matches!(trigger, TpdoTrigger::Sync(_));
        for i in 0..T {
            let Some(comm) = self.rt.params.tpdo.get(i).copied() else {
                continue;
            };
            let kind = comm.transmission();
            if !comm.is_valid() || kind.is_synchronous() != synchronous {
                continue;
            }
            if app.change_of_state() && !matches!(kind, Transmission::SyncCyclic(_)) {
                self.detect_change(i, app);
            }
            let due = self.rt.tpdo.get_mut(i).is_some_and(|r| match trigger {
                TpdoTrigger::Sync(counter) => r.on_sync(&comm, counter),
                TpdoTrigger::Timers(now_us) => r.event_due(&comm, now_us),
            });
            if due {
                self.rt.tpdo_steps |= 1 << i;
            }
        }
    }

    fn on_rpdo<A: CanApplication + ?Sized>(
        &mut self,
        i: usize,
        data: &[u8],
        app: &mut A,
        now_us: u64,
    ) {
        if !app.can_owns_outputs() {
            self.stats.rpdo_not_owner = self.stats.rpdo_not_owner.wrapping_add(1);
            return;
        }
        let Some(Some(layout)) = self.rt.rpdo_layout.get(i) else {
            return;
        };
        let mapping = MappingInfo {
            count: layout.fields().len() as u8,
            bits: layout.bit_len(),
        };
        let Some(comm) = self.rt.params.rpdo.get(i).copied() else {
            return;
        };
        let check = LengthCheck::of(data.len(), mapping);
        let code = match check {
            LengthCheck::TooShort => Some(emcy_code::PDO_LENGTH),
            LengthCheck::TooLong => Some(emcy_code::PDO_LENGTH_EXCEEDED),
            LengthCheck::Exact => None,
        };
        match code {
            Some(code) => {
                let n = data.len() as u8;
                self.raise(app, fault::RPDO_LENGTH, code, [n, i as u8 + 1]);
            }
            None => self.clear(app, fault::RPDO_LENGTH),
        }
        if check == LengthCheck::TooShort {
            return;
        }
        let resumed = self.rt.rpdo.get_mut(i).is_some_and(|r| {
            r.last_us = Some(now_us);
            core::mem::take(&mut r.timed_out)
        });
        if resumed && !self.rt.rpdo.iter().any(|r| r.timed_out) {
            self.clear(app, fault::RPDO_TIMEOUT);
        }
        if comm.transmission().is_synchronous() {
            if let Some(r) = self.rt.rpdo.get_mut(i) {
                r.pending = Some(PdoData::new(data));
            }
            return;
        }
        // The layout again: the error reports above needed the whole node.
        if let Some(Some(layout)) = self.rt.rpdo_layout.get(i) {
            if unpack(&mut self.stats, layout, data, app) {
                app.apply_outputs();
            }
        }
    }

    /// The layout of TPDO `i`, or `None` (unreadable mapping, or longer than 64 bits,
    /// which is reported).
    fn tpdo_layout<A: CanApplication + ?Sized>(&mut self, i: usize, app: &mut A) -> Option<Layout> {
        let layout = pdo_layout(app, PdoKind::Tpdo, i)?;
        if layout.bit_len() > super::pdo::MAX_PDO_BITS {
            let bits = layout.bit_len().min(255) as u8;
            self.raise(
                app,
                fault::TPDO_LENGTH,
                emcy_code::PDO_LENGTH_EXCEEDED,
                [bits, i as u8 + 1],
            );
            return None;
        }
        Some(layout)
    }

    /// The current data of a TPDO with `layout`.
    fn tpdo_data<A: CanApplication + ?Sized>(layout: &Layout, app: &mut A) -> Option<PdoData> {
        let mut data = PdoData {
            bytes: [0; 8],
            len: layout.byte_len() as u8,
        };
        layout.pack(app, &mut data.bytes).ok()?;
        Some(data)
    }

    fn send_tpdo<A: CanApplication + ?Sized>(
        &mut self,
        i: usize,
        layout: &Layout,
        app: &mut A,
        now_us: u64,
    ) {
        let Some(comm) = self.rt.params.tpdo.get(i).copied() else {
            return;
        };
        let Some(data) = Self::tpdo_data(layout, app) else {
            return;
        };
        if let Ok(frame) = CanFrame::new(comm.cob_id.can_id(), data.as_slice()) {
            self.send(frame);
            self.stats.tpdo_sent = self.stats.tpdo_sent.wrapping_add(1);
        }
        if let Some(r) = self.rt.tpdo.get_mut(i) {
            r.sent(&comm, data, now_us);
        }
    }

    /// Change of state: request TPDO `i` if its data differ from the last sent.
    fn detect_change<A: CanApplication + ?Sized>(&mut self, i: usize, app: &mut A) {
        let Some(data) = self
            .tpdo_layout(i, app)
            .and_then(|l| Self::tpdo_data(&l, app))
        else {
            return;
        };
        if let Some(r) = self.rt.tpdo.get_mut(i) {
            if r.last != Some(data) {
                r.requested = true;
            }
        }
    }

    // ------------------------------------------------------------------ steps

    /// True if PDO work waits for [`CanNode::step`] (after an NMT start, a SYNC or an
    /// event-driven TPDO's timer).
    pub const fn has_steps(&self) -> bool {
        self.rt.rpdo_steps | self.rt.tpdo_steps != 0
    }

    /// One step of the PDO work left: an RPDO layout read, a TPDO layout read, or a TPDO
    /// packed and queued; false if none was left. A caller with a deadline runs one per
    /// call, before the next frame (an RPDO needs its layout); [`CanNode::poll`] runs them
    /// all. Outside operational the work is dropped.
    pub fn step<A: CanApplication + ?Sized>(&mut self, app: &mut A, now_us: u64) -> bool {
        let rt = &mut self.rt;
        if rt.nmt.state() != NmtState::Operational {
            rt.rpdo_steps = 0;
            rt.tpdo_steps = 0;
            return false;
        }
        if rt.rpdo_steps != 0 {
            let i = rt.rpdo_steps.trailing_zeros() as usize;
            rt.rpdo_steps &= !(1 << i);
            rt.load_rpdo_layout(app, i);
            return true;
        }
        if rt.tpdo_steps == 0 {
            return false;
        }
        let i = rt.tpdo_steps.trailing_zeros() as usize;
        match rt.tpdo_layout.get_mut(i).and_then(Option::take) {
            Some(layout) => {
                self.rt.tpdo_steps &= !(1 << i);
                self.send_tpdo(i, &layout, app, now_us);
            }
            None => {
                let layout = self.tpdo_layout(i, app);
                match self.rt.tpdo_layout.get_mut(i) {
                    Some(slot) if layout.is_some() => *slot = layout,
                    _ => self.rt.tpdo_steps &= !(1 << i),
                }
            }
        }
        true
    }

    // ------------------------------------------------------------------ timers

    /// Timers and queued work at `now_us`: boot-up, heartbeat, consumer and life guarding
    /// deadlines, SYNC and RPDO deadlines, event-driven TPDOs, Emergencies; then every PDO
    /// step left ([`CanNode::step`]).
    pub fn poll<A: CanApplication + ?Sized>(&mut self, app: &mut A, now_us: u64) {
        self.timers(app, now_us);
        while self.step(app, now_us) {}
    }

    /// [`CanNode::poll`] without the PDO steps, for a caller that runs them one per call.
    pub fn timers<A: CanApplication + ?Sized>(&mut self, app: &mut A, now_us: u64) {
        if self.boot_pending {
            self.boot(now_us);
        }
        // The parameters are read where used, not copied: nothing here changes them.
        let heartbeat_ms = self.rt.params.heartbeat_ms;
        if heartbeat_ms != 0 && self.rt.heartbeat.due(now_us) {
            self.send_state(self.state().code());
            self.rt.heartbeat.sent(now_us, heartbeat_ms);
        }
        while let Some(ConsumerEvent::Lost { node }) =
            self.rt.consumer.check(&self.rt.params.consumers, now_us)
        {
            self.communication_error(app, fault::HEARTBEAT, node, now_us);
        }
        if heartbeat_ms == 0 {
            let (guard_time_ms, life_factor) =
                (self.rt.params.guard_time_ms, self.rt.params.life_factor);
            if let Some(LifeGuardEvent::Lost) =
                self.rt.guarding.check(guard_time_ms, life_factor, now_us)
            {
                self.communication_error(app, fault::LIFE_GUARD, 0, now_us);
            }
        }
        if self.state() == NmtState::Operational {
            if self.rt.sync.timed_out(&self.rt.params.sync, now_us) {
                self.raise(app, fault::SYNC_TIMEOUT, emcy_code::SYNC_TIMEOUT, [0; 2]);
            }
            for i in 0..R {
                let timer = self.rt.params.rpdo.get(i).map_or(0, |c| {
                    if c.is_valid() {
                        c.event_timer_ms
                    } else {
                        0
                    }
                });
                let passed = self
                    .rt
                    .rpdo
                    .get_mut(i)
                    .is_some_and(|r| r.deadline_passed(timer, now_us));
                if passed {
                    self.raise(
                        app,
                        fault::RPDO_TIMEOUT,
                        emcy_code::RPDO_TIMEOUT,
                        [i as u8 + 1, 0],
                    );
                    fault_outputs(app);
                }
            }
            self.service_tpdos(app, TpdoTrigger::Timers(now_us));
        }
        let lost = self.stats.outbox_overflow;
        if lost != self.overflow_reported {
            self.overflow_reported = lost;
            self.raise(app, fault::OVERRUN, emcy_code::CAN_OVERRUN, [0; 2]);
        } else if self.outbox.len() == 0 {
            self.clear(app, fault::OVERRUN);
        }
        if self.state().allows(Service::Emcy) {
            if let Some(frame) = self.rt.emcy.next_frame(&self.rt.params.emcy, now_us) {
                self.send(frame);
            }
        }
    }
}
