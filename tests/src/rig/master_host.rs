//! coe-core's CANopen master ([`Master`]) on a port of a [`CanBus`], as the gateway will
//! run it: every frame of the bus into [`Master::receive`] at its end time, [`Master::step`]
//! until it has nothing left, and its frames into a controller with three transmit buffers
//! (the LPC1754's CAN1). Processing takes no bus time here: figures measured with it are
//! the bus's, not the MCU's.
//!
//! [`CanNetwork`] runs the master and in-process slaves ([`InProcessSlave`]) on one bus in
//! virtual time, from event to event (a frame's end, a node's timer, the master's timer,
//! the caller's cycle), so the scenarios' timing comes from the bits on the wire.

use crate::models::can::{CanBus, PortId};
use crate::rig::can_slave::{InProcessSlave, TX_BUFFERS};
use coe_core::canopen::master::events::MasterEvent;
use coe_core::canopen::master::Master;

/// The master the tests run: 16 places, 32-byte SDO transfers.
pub type TestMaster = Master<16, 32>;

/// A master on a port.
pub struct MasterOnBus {
    /// The master.
    pub master: TestMaster,
    /// Its port.
    pub port: PortId,
    /// Every event, with the bus time (ns) it came at.
    pub events: Vec<(u64, MasterEvent)>,
}

impl MasterOnBus {
    /// Attaches `master` to `bus`.
    pub fn attach(bus: &mut CanBus, master: TestMaster) -> Self {
        let port = bus.attach("CANopen master (coe-core)");
        Self {
            master,
            port,
            events: Vec::new(),
        }
    }

    /// Takes the frames the bus delivered, steps the master at `now_ns`, fills the transmit
    /// buffers, collects the events.
    pub fn service(&mut self, bus: &mut CanBus, now_ns: u64) {
        while let Some((t, f)) = bus.receive(self.port) {
            self.master.receive(&f, t / 1000);
            self.drain(bus, t);
        }
        self.drain(bus, now_ns);
    }

    fn drain(&mut self, bus: &mut CanBus, now_ns: u64) {
        while self.master.step(now_ns / 1000) {
            self.fill(bus);
        }
        self.fill(bus);
        while let Some(e) = self.master.pop_event() {
            self.events.push((now_ns, e));
        }
    }

    /// Moves frames from the outbox into free transmit buffers.
    pub fn fill(&mut self, bus: &mut CanBus) {
        while bus.pending(self.port) < TX_BUFFERS {
            let Some(f) = self.master.pop_tx() else { break };
            bus.send(self.port, f);
        }
    }

    /// When the master's timers want it next (ns), if later than `now_ns` (work it cannot
    /// do now waits for the bus: a frame's end wakes it).
    pub fn next_ns(&self, now_ns: u64) -> Option<u64> {
        self.master
            .next_deadline_us()
            .map(|t| t * 1000)
            .filter(|t| *t > now_ns)
    }

    /// The events since `from` (an index into [`MasterOnBus::events`]).
    pub fn events_since(&self, from: usize) -> Vec<MasterEvent> {
        self.events.iter().skip(from).map(|(_, e)| *e).collect()
    }
}

/// The master and in-process slaves on one bus, in virtual time.
pub struct CanNetwork {
    /// The bus.
    pub bus: CanBus,
    /// The master.
    pub master: MasterOnBus,
    /// The slaves.
    pub slaves: Vec<InProcessSlave>,
    now_ns: u64,
}

impl CanNetwork {
    /// A bus at `bit_rate` with `master` on it.
    pub fn new(bit_rate: u32, master: TestMaster) -> Self {
        let mut bus = CanBus::new(bit_rate);
        let master = MasterOnBus::attach(&mut bus, master);
        Self {
            bus,
            master,
            slaves: Vec::new(),
            now_ns: 0,
        }
    }

    /// The bus time (ns).
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// The slave with `node_id`.
    pub fn slave(&mut self, node_id: u8) -> &mut InProcessSlave {
        let i = self
            .slaves
            .iter()
            .position(|s| s.node.node_id() == node_id)
            .unwrap_or_else(|| panic!("no slave {node_id}"));
        &mut self.slaves[i]
    }

    /// Powers slave `node_id` off or on.
    pub fn power(&mut self, node_id: u8, on: bool) {
        let i = self
            .slaves
            .iter()
            .position(|s| s.node.node_id() == node_id)
            .unwrap_or_else(|| panic!("no slave {node_id}"));
        self.slaves[i].power(&mut self.bus, on);
    }

    /// Everyone serves the present instant.
    fn service(&mut self) {
        // Until nothing moves: a slave's answer can wake the master at the same instant
        // only through the bus, which takes time, so one round suffices; two are cheap.
        for _ in 0..2 {
            self.master.service(&mut self.bus, self.now_ns);
            for s in self.slaves.iter_mut() {
                s.service(&mut self.bus, self.now_ns);
            }
        }
    }

    /// Runs to `until_ns`; `cycle` is called at each multiple of `cycle_ns` (0: none) with
    /// the network and the cycle's number, before anyone serves that instant.
    pub fn run(
        &mut self,
        until_ns: u64,
        cycle_ns: u64,
        cycle: &mut dyn FnMut(&mut CanNetwork, u64),
    ) {
        self.service();
        let next_cycle = |now: u64| (cycle_ns != 0).then(|| (now / cycle_ns + 1) * cycle_ns);
        while self.now_ns < until_ns {
            let now = self.now_ns;
            let next = [
                self.bus.next_event_ns(),
                self.master.next_ns(now),
                next_cycle(now),
                Some(until_ns),
            ]
            .into_iter()
            .chain(self.slaves.iter().map(|s| s.next_ns(now)))
            .flatten()
            .filter(|t| *t > now)
            .min()
            .unwrap_or(until_ns);
            self.bus.advance_to(next);
            self.now_ns = next;
            if cycle_ns != 0 && next % cycle_ns == 0 {
                cycle(self, next / cycle_ns);
            }
            self.service();
        }
    }

    /// Runs to `until_ns` without a cycle.
    pub fn run_to(&mut self, until_ns: u64) {
        self.run(until_ns, 0, &mut |_, _| {});
    }
}
