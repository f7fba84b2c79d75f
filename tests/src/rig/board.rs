//! The virtual board: ESC + DAC + ADC + CAN bus + virtual clock + pcap, with a pluggable
//! PDI-side "CPU" (the firmware's slave application, or a test responder).
//!
//! Frames enter through [`VirtualBoard::exchange`]. Time moves only through the board:
//! each frame advances the clock by its wire time plus `frame_gap_ns`, and
//! [`VirtualBoard::step`] advances it explicitly. The CPU is called in priority order at
//! the virtual time of each event: SYNC0/SYNC1 edges first, then the (level) IRQ line
//! while it stays asserted, then `poll`. Frames the CAN bus delivers to the MCU's CAN
//! controller raise [`PdiCpu::on_can_rx`] at the time the frame ends on the bus.
//!
//! On the wall clock ([`VirtualBoard::follow_wall_clock`], a master outside the process)
//! the ESC keeps its own time, the wall clock's ([`crate::models::shared_esc`]), and frames
//! reach it from another thread without going through the board; the board's clock is the
//! CPU's, which the caller steps towards the wall clock and to which it hands the SYNC edges
//! the ESC produced ([`VirtualBoard::deliver_wall_edge`]).

use crate::models::adc::{Ad7689, AdcSpi, SharedAdc};
use crate::models::can::{CanBus, PortId, SharedCanBus};
use crate::models::dac::{Ad5663, DacSpi, LdacPin, SharedDac};
use crate::models::esc::{Esc, EscConfig, SyncEdge, SyncSignal};
use crate::models::shared_esc::WallClock;
use crate::models::spi::{EscSpi, SharedEsc};
use crate::rig::clock::Clock;
use crate::tools::pcap::PcapWriter;
use std::cell::RefCell;
use std::rc::Rc;
use std::time::Instant;

/// The peripherals as the CPU sees them: cloneable handles on the board's chips.
#[derive(Clone)]
pub struct BoardIo {
    /// The ET1100 SPI port (also gives the IRQ line level).
    pub esc: EscSpi,
    /// The AD5663 SPI port.
    pub dac: DacSpi,
    /// The AD5663 LDAC pin.
    pub ldac: LdacPin,
    /// The AD7689 SPI port.
    pub adc: AdcSpi,
    /// The virtual clock.
    pub clock: Clock,
    /// The MCU's CAN controller: its port on the board's CAN bus.
    pub can: CanPortIo,
}

/// The MCU's CAN controller as the CPU sees it: a port on the bus.
#[derive(Clone)]
pub struct CanPortIo {
    /// The bus.
    pub bus: SharedCanBus,
    /// The controller's port.
    pub port: PortId,
}

impl BoardIo {
    /// Current virtual time (ns).
    pub fn now_ns(&self) -> u64 {
        self.clock.now_ns()
    }
    /// Level of the ESC IRQ line.
    pub fn irq(&self) -> bool {
        self.esc.irq()
    }
}

/// The PDI-side CPU: the firmware's slave application plugged into the board.
///
/// Methods are called in priority order (SYNC0 > IRQ > poll) at the virtual time of the
/// event. A CPU may keep its own clones of the handles in [`BoardIo`] (e.g. owning an
/// `et1100` driver built on an [`EscSpi`]), or use the ones passed in.
pub trait PdiCpu {
    /// A SYNC0 edge (highest priority; the board's SYNC0 line to a timer capture input).
    fn on_sync0(&mut self, _io: &mut BoardIo, _edge: &SyncEdge) {}
    /// A SYNC1 edge.
    fn on_sync1(&mut self, _io: &mut BoardIo, _edge: &SyncEdge) {}
    /// The ESC IRQ line is asserted (level). Called again while it stays asserted.
    fn on_irq(&mut self, _io: &mut BoardIo) {}
    /// The CAN controller received frames (take them from [`BoardIo::can`]).
    fn on_can_rx(&mut self, _io: &mut BoardIo) {}
    /// Background work after every event (lowest priority).
    fn poll(&mut self, _io: &mut BoardIo) {}
    /// The CPU's next timer deadline (virtual ns), e.g. the ADC's conversion timer: the
    /// board stops its clock there and calls [`PdiCpu::on_timer`]. A timer models
    /// hardware (timer + DMA): `poll` is not called after it.
    fn next_timer_ns(&self) -> Option<u64> {
        None
    }
    /// The timer deadline of [`PdiCpu::next_timer_ns`] is reached; the CPU must move the
    /// deadline forward (or return `None`).
    fn on_timer(&mut self, _io: &mut BoardIo) {}
    /// Whether the CPU executes on its own between events (an instruction-level emulation
    /// of the MCU running the firmware image) instead of being called at them. The board
    /// then lets it run up to every instant before its clock moves there
    /// ([`PdiCpu::run_until`]), and does not call `on_irq`/`poll`: such a CPU sees the IRQ
    /// line through its own pins. SYNC edges are still delivered through `on_sync0`/`on_sync1`
    /// (at their time, after `run_until` reached it).
    fn runs_continuously(&self) -> bool {
        false
    }
    /// A continuously running CPU executes up to virtual time `t_ns` (the board's clock is
    /// about to move there).
    fn run_until(&mut self, _io: &mut BoardIo, _t_ns: u64) {}
    /// The earliest virtual time the CPU must run at again on its own (its next event; now
    /// while it is busy): a board on the wall clock that has caught up with it waits until
    /// then unless something from outside comes first. By default none: such a CPU is
    /// stepped when a frame or a SYNC edge comes, and at least every tick of the wait
    /// ([`crate::tools::iface::ServeOptions::tick`]), its timers run in order then.
    fn next_wake_ns(&self, _io: &BoardIo) -> u64 {
        u64::MAX
    }
    /// A continuously running CPU that is asleep (WFI) sleeps on up to `t_ns` unless its own
    /// events wake it first, without looking at its inputs; returns the time it reached. A
    /// board on the wall clock calls it after waiting, so that what arrived meanwhile is seen
    /// at the time it arrived, not at the time the wait began. Others stay where they are.
    fn idle_until(&mut self, io: &mut BoardIo, _t_ns: u64) -> u64 {
        io.now_ns()
    }
    /// The CPU as `Any`, for a test that looks at its own kind of CPU's state.
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
}

/// A CPU that does nothing (an unprogrammed board).
pub struct IdleCpu;

impl PdiCpu for IdleCpu {}

/// Board construction parameters.
#[derive(Clone, Debug)]
pub struct BoardConfig {
    /// The ESC (SII image etc.).
    pub esc: EscConfig,
    /// Virtual time added after every frame on top of its wire time.
    pub frame_gap_ns: u64,
    /// Capture frames into a pcap.
    pub capture: bool,
    /// Bit rate of the CAN bus (bit/s).
    pub can_bit_rate: u32,
    /// How often `on_irq` is called for one event before the board gives up (an IRQ
    /// the CPU never clears).
    pub max_irq_calls: u32,
}

impl BoardConfig {
    /// Defaults around an SII image.
    pub fn new(sii: Vec<u8>) -> Self {
        Self {
            esc: EscConfig::new(sii),
            frame_gap_ns: 10_000,
            capture: true,
            can_bit_rate: DEFAULT_CAN_BIT_RATE,
            max_irq_calls: 64,
        }
    }
}

/// The CAN bit rate of a board unless configured (bit/s).
pub const DEFAULT_CAN_BIT_RATE: u32 = 500_000;

/// Counters of the board.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BoardStats {
    /// Frames exchanged.
    pub frames: u64,
    /// SYNC0 edges delivered.
    pub sync0_edges: u64,
    /// SYNC1 edges delivered.
    pub sync1_edges: u64,
    /// `on_irq` calls.
    pub irq_calls: u64,
    /// Events after which the IRQ line was still asserted after `max_irq_calls`.
    pub irq_stuck: u64,
    /// `on_timer` calls.
    pub timer_calls: u64,
    /// `on_can_rx` calls.
    pub can_rx_calls: u64,
}

/// The virtual board.
pub struct VirtualBoard {
    cfg: BoardConfig,
    clock: Clock,
    esc: SharedEsc,
    dac: SharedDac,
    adc: SharedAdc,
    can: SharedCanBus,
    io: BoardIo,
    cpu: Box<dyn PdiCpu>,
    pcap: Option<PcapWriter>,
    /// The ESC's time follows the wall clock.
    on_wall_clock: bool,
    /// All SYNC edges so far (not kept on the wall clock, which may serve for days).
    pub sync_edges: Vec<SyncEdge>,
    /// Counters.
    pub stats: BoardStats,
}

impl VirtualBoard {
    /// A board with an idle CPU.
    pub fn new(cfg: BoardConfig) -> Self {
        let clock = Clock::new();
        let esc = SharedEsc::new(Esc::new(cfg.esc.clone()));
        let dac = Rc::new(RefCell::new(Ad5663::new(clock.clone())));
        let adc = Rc::new(RefCell::new(Ad7689::new(clock.clone())));
        let can = CanBus::shared(cfg.can_bit_rate);
        let port = can.borrow_mut().attach("board (LPC1754 CAN1)");
        let io = BoardIo {
            esc: EscSpi::new(esc.clone()),
            dac: DacSpi::new(dac.clone()),
            ldac: LdacPin::new(dac.clone()),
            adc: AdcSpi::new(adc.clone()),
            clock: clock.clone(),
            can: CanPortIo {
                bus: can.clone(),
                port,
            },
        };
        let pcap = cfg.capture.then(PcapWriter::new);
        Self {
            cfg,
            clock,
            esc,
            dac,
            adc,
            can,
            io,
            cpu: Box::new(IdleCpu),
            pcap,
            on_wall_clock: false,
            sync_edges: Vec::new(),
            stats: BoardStats::default(),
        }
    }

    /// Installs the PDI-side CPU (returns the previous one).
    pub fn set_cpu(&mut self, cpu: Box<dyn PdiCpu>) -> Box<dyn PdiCpu> {
        std::mem::replace(&mut self.cpu, cpu)
    }

    /// The CPU (downcast with [`PdiCpu::as_any`]).
    pub fn cpu(&self) -> &dyn PdiCpu {
        self.cpu.as_ref()
    }

    /// Handles on the peripherals (for a CPU to keep).
    pub fn io(&self) -> BoardIo {
        self.io.clone()
    }

    /// The ESC model.
    pub fn esc(&self) -> &SharedEsc {
        &self.esc
    }

    /// The DAC model.
    pub fn dac(&self) -> &SharedDac {
        &self.dac
    }

    /// The ADC model.
    pub fn adc(&self) -> &SharedAdc {
        &self.adc
    }

    /// The CAN bus.
    pub fn can(&self) -> &SharedCanBus {
        &self.can
    }

    /// The virtual clock.
    pub fn clock(&self) -> &Clock {
        &self.clock
    }

    /// Current virtual time (ns).
    pub fn now_ns(&self) -> u64 {
        self.clock.now_ns()
    }

    /// The capture so far.
    pub fn pcap(&self) -> Option<&PcapWriter> {
        self.pcap.as_ref()
    }

    /// Takes the capture out of the board (for the thread that serves frames on the wall
    /// clock; give it back with [`VirtualBoard::put_pcap`]).
    pub fn take_pcap(&mut self) -> Option<PcapWriter> {
        self.pcap.take()
    }

    /// Puts a capture (back) into the board.
    pub fn put_pcap(&mut self, pcap: Option<PcapWriter>) {
        self.pcap = pcap;
    }

    /// From now on the ESC keeps the wall clock's time (the board's time at `start` plus the
    /// time elapsed since, divided by `slowdown`: [`WallClock`]), which it returns; its SYNC
    /// edges wait for [`VirtualBoard::take_wall_edges`]. The board's clock stays the CPU's:
    /// the caller steps it towards the wall clock.
    pub fn follow_wall_clock(&mut self, start: Instant, slowdown: u32) -> WallClock {
        let clock = WallClock::new(start, self.now_ns(), slowdown);
        self.esc.follow_wall_clock(clock);
        self.on_wall_clock = true;
        clock
    }

    /// Back to virtual time (after serving on the wall clock; SYNC edges not yet handed to
    /// the CPU are handed to it now).
    pub fn follow_virtual_time(&mut self) {
        for e in self.take_wall_edges() {
            self.deliver_wall_edge(e);
        }
        self.esc.follow_virtual_time();
        self.on_wall_clock = false;
    }

    /// On the wall clock: the SYNC edges the ESC produced (at its time, the wall clock's)
    /// that the CPU has not had yet, in order ([`VirtualBoard::deliver_wall_edge`]).
    pub fn take_wall_edges(&mut self) -> Vec<SyncEdge> {
        self.esc.take_edges()
    }

    /// On the wall clock: SYNC edge `e` reaches the CPU now, at the CPU's time (which its
    /// timer captures as the pin sees the edge arrive; the edge keeps its DC system time).
    pub fn deliver_wall_edge(&mut self, e: SyncEdge) {
        let now = self.now_ns();
        self.deliver(SyncEdge { time_ns: now, ..e });
    }

    /// On the wall clock: the first SYNC edge the ESC produced that the CPU has not had
    /// yet reaches the CPU at the edge's own time, as the pin sees it: an idle CPU sleeps up
    /// to it, one behind runs up to it (exactly: the co-simulated core stops at a waiting
    /// edge's time). False when none waits.
    pub fn deliver_first_wall_edge(&mut self) -> bool {
        let Some(t) = self.esc.first_waiting_edge_ns() else {
            return false;
        };
        self.idle_until(t);
        let v = self.now_ns();
        if v < t {
            self.step(t - v);
        }
        match self.esc.take_first_edge() {
            Some(e) => {
                self.deliver_wall_edge(e);
                true
            }
            None => false,
        }
    }

    /// Whether the board serves on the wall clock.
    pub fn on_wall_clock(&self) -> bool {
        self.on_wall_clock
    }

    /// The earliest virtual time the CPU must run at again on its own
    /// ([`PdiCpu::next_wake_ns`]).
    pub fn cpu_next_wake_ns(&self) -> u64 {
        self.cpu.next_wake_ns(&self.io)
    }

    /// Brings a CPU with nothing to do up to `t_ns`: a continuously running CPU asleep
    /// sleeps on ([`PdiCpu::idle_until`]; the board's clock goes where it got to), a CPU
    /// called at events has its timers run up to there.
    pub fn idle_until(&mut self, t_ns: u64) {
        let now = self.now_ns();
        if t_ns <= now {
            return;
        }
        if !self.cpu.runs_continuously() {
            self.step(t_ns - now);
            return;
        }
        let reached = self.cpu.idle_until(&mut self.io, t_ns).min(t_ns);
        if reached > now {
            self.peripherals_to(reached);
        }
    }

    /// One frame from the master: processed by the ESC, recorded in both directions;
    /// then time advances by the frame's wire time plus the gap, with the CPU running.
    /// Returns the frame as it comes back to the master.
    pub fn exchange(&mut self, frame: &[u8]) -> Vec<u8> {
        self.stats.frames += 1;
        let now = self.now_ns();
        if let Some(p) = self.pcap.as_mut() {
            p.record(now, frame);
        }
        let mut reply = frame.to_vec();
        self.esc.borrow_mut().process_frame(&mut reply);
        let wire = wire_time_ns(frame.len());
        self.advance(wire);
        if let Some(p) = self.pcap.as_mut() {
            p.record(self.clock.now_ns(), &reply);
        }
        self.service();
        self.advance(self.cfg.frame_gap_ns);
        reply
    }

    /// Virtual time one exchange of a `len`-byte frame takes: wire time plus the gap.
    pub fn frame_time_ns(&self, len: usize) -> u64 {
        wire_time_ns(len) + self.cfg.frame_gap_ns
    }

    /// Advances virtual time by `ns` with the CPU running.
    pub fn step(&mut self, ns: u64) {
        self.advance(ns);
        self.service();
    }

    fn advance(&mut self, ns: u64) {
        let target = self.now_ns() + ns;
        loop {
            let sync = if self.on_wall_clock {
                None
            } else {
                self.esc
                    .borrow()
                    .next_sync_edge_ns()
                    .filter(|&t| t <= target)
            };
            let timer = self.cpu.next_timer_ns().filter(|&t| t <= target);
            let can = self.can.borrow().next_event_ns().filter(|&t| t <= target);
            let Some(t) = [sync, timer, can].into_iter().flatten().min() else {
                break;
            };
            self.run_cpu_until(t);
            if can == Some(t) && sync != Some(t) {
                self.peripherals_to(t);
                self.service();
            } else if sync == Some(t) {
                // From the ESC's own time: a continuously running CPU may have moved the
                // board's clock past the edge already (its peripherals act at their time).
                let now = self.esc.borrow().now_ns();
                let edges = self.esc.borrow_mut().advance(t.saturating_sub(now));
                self.clock.set_ns(self.esc.borrow().now_ns());
                for e in edges {
                    self.deliver(e);
                }
                self.bus_to(t);
                self.service();
            } else if let Some(t) = timer {
                self.peripherals_to(t);
                self.stats.timer_calls += 1;
                self.cpu.on_timer(&mut self.io);
                // The ESC raised its IRQ line while time passed (a watchdog, an EEPROM
                // command): the CPU takes the interrupt now, not at the end of the step.
                self.service_irq();
                if self.cpu.next_timer_ns().is_some_and(|n| n <= t) {
                    // A timer that does not move forward would stop time: ignore it
                    // until the next advance.
                    break;
                }
            }
        }
        self.run_cpu_until(target);
        self.peripherals_to(target);
    }

    /// The ESC, the clock and the CAN bus at `t`, with the SYNC edges and received CAN
    /// frames on the way handed to the CPU.
    fn peripherals_to(&mut self, t: u64) {
        // On the wall clock the ESC keeps its own time.
        let edges = if self.on_wall_clock {
            Vec::new()
        } else {
            let now = self.esc.borrow().now_ns();
            self.esc.borrow_mut().advance(t.saturating_sub(now))
        };
        self.clock.set_ns(t);
        for e in edges {
            self.deliver(e);
        }
        self.bus_to(t);
    }

    /// Brings the bus to `t` (the CPU may send at this time) and hands the controller the
    /// frames that ended by then.
    fn bus_to(&mut self, t: u64) {
        self.can.borrow_mut().advance_to(t);
        if self.can.borrow().has_rx(self.io.can.port) {
            self.stats.can_rx_calls += 1;
            self.cpu.on_can_rx(&mut self.io);
        }
    }

    /// Lets a continuously running CPU catch up with the instant the clock moves to next.
    fn run_cpu_until(&mut self, t: u64) {
        if self.cpu.runs_continuously() {
            self.cpu.run_until(&mut self.io, t);
        }
    }

    fn deliver(&mut self, e: SyncEdge) {
        if !self.on_wall_clock {
            self.sync_edges.push(e);
        }
        match e.signal {
            SyncSignal::Sync0 => {
                self.stats.sync0_edges += 1;
                self.cpu.on_sync0(&mut self.io, &e);
            }
            SyncSignal::Sync1 => {
                self.stats.sync1_edges += 1;
                self.cpu.on_sync1(&mut self.io, &e);
            }
        }
    }

    /// Runs the IRQ handler while the line is asserted, then `poll` (a continuously running
    /// CPU serves the line itself).
    fn service(&mut self) {
        if self.cpu.runs_continuously() {
            return;
        }
        self.service_irq();
        self.cpu.poll(&mut self.io);
    }

    /// Runs the IRQ handler while the line is asserted (bounded by `max_irq_calls`; a
    /// continuously running CPU serves the line itself).
    fn service_irq(&mut self) {
        if self.cpu.runs_continuously() {
            return;
        }
        let mut calls = 0;
        while self.esc.borrow().irq() {
            if calls == self.cfg.max_irq_calls {
                self.stats.irq_stuck += 1;
                break;
            }
            calls += 1;
            self.stats.irq_calls += 1;
            self.cpu.on_irq(&mut self.io);
        }
    }
}

/// Wire time of a frame at 100 Mbit/s: 80 ns per byte (padded to 60), plus preamble, FCS and
/// inter-frame gap (24 bytes).
pub fn wire_time_ns(len: usize) -> u64 {
    (len.max(60) as u64 + 24) * 80
}
