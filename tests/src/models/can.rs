//! A CAN bus (ISO 11898-1 classical frames, 11-bit identifiers) on the board's virtual time.
//!
//! Nodes attach through ports ([`CanBus::attach`]). A port queues frames to send; when the
//! bus is idle, every port with a frame waiting takes part in arbitration, and the lowest
//! identifier wins (a data frame wins against a remote frame of the same identifier: the
//! RTR bit is recessive). The winning frame occupies the bus for its length on the wire
//! ([`CanFrame::bits_on_wire`]: stuff bits, CRC, ACK, end of frame and intermission) at the
//! configured bit rate, then every other port receives it, time-stamped with the end of
//! the frame. The losers try again at the next idle bus.
//!
//! Every frame is acknowledged (at least one other node, the CAN adapter of the master, is
//! assumed on the bus). Faults are injected per port ([`CanBus::set_fault`]): a port whose
//! transmitter is broken ([`PortFault::Corrupt`]) has every frame it starts destroyed by an
//! error frame (ISO 11898-1 10.4.4: the error flag comes after the bit that went wrong,
//! here the end of the arbitration field; 6 bits of flag, 8 of delimiter and 3 of
//! intermission follow). Its transmit error counter rises by 8 per error and every other
//! port's receive error counter by 1 (fault confinement, ISO 11898-1 12.1.4); above 127 it
//! is error passive, above 255 bus-off: it sends nothing and its queue is dropped, until
//! [`CanBus::recover`] (the controller's recovery after 128 x 11 recessive bits, which
//! software starts on the LPC1754). Like a real controller the port retransmits a
//! destroyed frame at once.

use coe_core::canopen::CanFrame;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

/// A bus shared by the board and the tools.
pub type SharedCanBus = Rc<RefCell<CanBus>>;

/// A port on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PortId(usize);

/// A fault of a port's transceiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PortFault {
    /// Every frame the port sends is destroyed by an error frame.
    Corrupt,
}

/// The fault confinement state of a port (ISO 11898-1 12.1.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorState {
    /// Both error counters below 128.
    Active,
    /// An error counter at 128 or above.
    Passive,
    /// The transmit error counter went above 255: off the bus.
    BusOff,
}

#[derive(Debug)]
struct Port {
    name: String,
    attached: bool,
    tx: VecDeque<CanFrame>,
    rx: VecDeque<(u64, CanFrame)>,
    sent: u64,
    fault: Option<PortFault>,
    tec: u32,
    rec: u32,
    bus_off: bool,
}

/// Bits of an error frame after the faulty bit: error flag 6, delimiter 8, intermission 3.
pub const ERROR_FRAME_BITS: u64 = 17;
/// Bits from the start of frame to the end of the arbitration field (11-bit identifier).
const ARBITRATION_BITS: u64 = 13;

/// A frame on the bus: who sent it and when it ends.
#[derive(Clone, Copy, Debug)]
struct OnBus {
    frame: CanFrame,
    from: usize,
    end_ns: u64,
    /// Destroyed by an error frame (ends at `end_ns`, nobody receives it).
    error: bool,
}

/// Counters of the bus.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BusStats {
    /// Frames transmitted.
    pub frames: u64,
    /// Bits transmitted (with stuff bits and intermission).
    pub bits: u64,
    /// Arbitrations a frame lost to a higher-priority one.
    pub arbitration_lost: u64,
    /// Error frames (each destroyed a frame).
    pub error_frames: u64,
    /// Bits of the destroyed frames and their error frames.
    pub error_bits: u64,
}

/// The bus.
#[derive(Debug)]
pub struct CanBus {
    bit_rate: u32,
    now_ns: u64,
    idle_from_ns: u64,
    ports: Vec<Port>,
    on_bus: Option<OnBus>,
    /// Every frame in bus order: end time, sender port, frame.
    pub log: Vec<(u64, PortId, CanFrame)>,
    /// Counters.
    pub stats: BusStats,
}

impl CanBus {
    /// An idle bus at `bit_rate` bit/s (any positive rate).
    pub fn new(bit_rate: u32) -> Self {
        Self {
            bit_rate: bit_rate.max(1),
            now_ns: 0,
            idle_from_ns: 0,
            ports: Vec::new(),
            on_bus: None,
            log: Vec::new(),
            stats: BusStats::default(),
        }
    }

    /// A shared bus.
    pub fn shared(bit_rate: u32) -> SharedCanBus {
        Rc::new(RefCell::new(Self::new(bit_rate)))
    }

    /// The bit rate (bit/s).
    pub fn bit_rate(&self) -> u32 {
        self.bit_rate
    }

    /// The bus time (ns).
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Nanoseconds `frame` occupies the bus.
    pub fn frame_ns(&self, frame: &CanFrame) -> u64 {
        u64::from(frame.bits_on_wire()) * 1_000_000_000 / u64::from(self.bit_rate)
    }

    /// Attaches a node.
    pub fn attach(&mut self, name: &str) -> PortId {
        self.ports.push(Port {
            name: name.to_string(),
            attached: true,
            tx: VecDeque::new(),
            rx: VecDeque::new(),
            sent: 0,
            fault: None,
            tec: 0,
            rec: 0,
            bus_off: false,
        });
        PortId(self.ports.len() - 1)
    }

    /// Takes a node off the bus: what it queued is dropped and it receives nothing more
    /// (a client that disconnected).
    pub fn detach(&mut self, port: PortId) {
        if let Some(p) = self.ports.get_mut(port.0) {
            p.attached = false;
            p.tx.clear();
            p.rx.clear();
        }
    }

    /// Breaks (or, with `None`, mends) the transceiver of `port`.
    pub fn set_fault(&mut self, port: PortId, fault: Option<PortFault>) {
        if let Some(p) = self.ports.get_mut(port.0) {
            p.fault = fault;
        }
    }

    /// The fault confinement state of `port`.
    pub fn error_state(&self, port: PortId) -> ErrorState {
        match self.ports.get(port.0) {
            Some(p) if p.bus_off => ErrorState::BusOff,
            Some(p) if p.tec >= 128 || p.rec >= 128 => ErrorState::Passive,
            _ => ErrorState::Active,
        }
    }

    /// The transmit and receive error counters of `port`.
    pub fn error_counters(&self, port: PortId) -> (u32, u32) {
        self.ports.get(port.0).map_or((0, 0), |p| (p.tec, p.rec))
    }

    /// Bus-off recovery of `port`: back on the bus with both counters at 0.
    pub fn recover(&mut self, port: PortId) {
        if let Some(p) = self.ports.get_mut(port.0) {
            p.bus_off = false;
            p.tec = 0;
            p.rec = 0;
        }
    }

    /// The name a port was attached with.
    pub fn port_name(&self, port: PortId) -> &str {
        self.ports.get(port.0).map_or("?", |p| p.name.as_str())
    }

    /// Queues a frame at `port` (sent in the order queued).
    pub fn send(&mut self, port: PortId, frame: CanFrame) {
        if let Some(p) = self
            .ports
            .get_mut(port.0)
            .filter(|p| p.attached && !p.bus_off)
        {
            p.tx.push_back(frame);
        }
        if self.on_bus.is_none() {
            self.idle_from_ns = self.idle_from_ns.max(self.now_ns);
            self.arbitrate();
        }
    }

    /// Frames queued at `port` and not yet on the bus.
    pub fn pending(&self, port: PortId) -> usize {
        self.ports.get(port.0).map_or(0, |p| p.tx.len())
    }

    /// Frames `port` has sent.
    pub fn sent(&self, port: PortId) -> u64 {
        self.ports.get(port.0).map_or(0, |p| p.sent)
    }

    /// The next frame `port` received: end time of the frame and the frame.
    pub fn receive(&mut self, port: PortId) -> Option<(u64, CanFrame)> {
        self.ports.get_mut(port.0)?.rx.pop_front()
    }

    /// True if `port` has received frames waiting.
    pub fn has_rx(&self, port: PortId) -> bool {
        self.ports.get(port.0).is_some_and(|p| !p.rx.is_empty())
    }

    /// When the frame on the bus ends (the next time something happens).
    pub fn next_event_ns(&self) -> Option<u64> {
        self.on_bus.map(|b| b.end_ns)
    }

    /// Starts the next frame if the bus is idle and one waits: lowest identifier first,
    /// data before remote on the same identifier, then the lowest port.
    fn arbitrate(&mut self) {
        if self.on_bus.is_some() {
            return;
        }
        let contenders: Vec<(usize, CanFrame)> = self
            .ports
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.tx.front().map(|f| (i, *f)))
            .collect();
        let Some(&(from, frame)) = contenders
            .iter()
            .min_by_key(|(i, f)| (f.id(), f.is_remote(), *i))
        else {
            return;
        };
        self.stats.arbitration_lost += contenders.len() as u64 - 1;
        let start = self.idle_from_ns.max(self.now_ns);
        let broken = self
            .ports
            .get(from)
            .is_some_and(|p| p.fault == Some(PortFault::Corrupt));
        // A destroyed frame stays queued: the controller sends it again.
        if !broken {
            if let Some(p) = self.ports.get_mut(from) {
                p.tx.pop_front();
            }
        }
        let len_ns = if broken {
            (ARBITRATION_BITS + ERROR_FRAME_BITS) * 1_000_000_000 / u64::from(self.bit_rate)
        } else {
            self.frame_ns(&frame)
        };
        self.on_bus = Some(OnBus {
            frame,
            from,
            end_ns: start + len_ns,
            error: broken,
        });
    }

    /// Advances the bus to `t_ns`, delivering every frame that ends by then. Returns the
    /// number of frames delivered.
    pub fn advance_to(&mut self, t_ns: u64) -> usize {
        let mut delivered = 0;
        while let Some(b) = self.on_bus.filter(|b| b.end_ns <= t_ns) {
            self.now_ns = b.end_ns;
            self.on_bus = None;
            self.idle_from_ns = b.end_ns;
            if b.error {
                self.error_frame(b.from);
                self.arbitrate();
                continue;
            }
            self.stats.frames += 1;
            self.stats.bits += u64::from(b.frame.bits_on_wire());
            self.log.push((b.end_ns, PortId(b.from), b.frame));
            for (i, p) in self.ports.iter_mut().enumerate() {
                if i == b.from {
                    p.sent += 1;
                    p.tec = p.tec.saturating_sub(1);
                } else if p.attached && !p.bus_off {
                    p.rx.push_back((b.end_ns, b.frame));
                    p.rec = p.rec.saturating_sub(1);
                }
            }
            delivered += 1;
            self.arbitrate();
        }
        self.now_ns = self.now_ns.max(t_ns);
        if self.on_bus.is_none() {
            self.idle_from_ns = self.idle_from_ns.max(self.now_ns);
        }
        delivered
    }

    /// The error frame that destroyed a frame of port `from`: the error counters move, and
    /// a transmitter above 255 goes bus-off.
    fn error_frame(&mut self, from: usize) {
        self.stats.error_frames += 1;
        self.stats.error_bits += ARBITRATION_BITS + ERROR_FRAME_BITS;
        for (i, p) in self.ports.iter_mut().enumerate() {
            if i == from {
                p.tec += 8;
                if p.tec > 255 {
                    p.bus_off = true;
                    p.tx.clear();
                }
            } else if p.attached && !p.bus_off {
                p.rec = (p.rec + 1).min(255);
            }
        }
    }

    /// Bus load over `[from_ns, to_ns]` from the log: the share of the time frames
    /// occupied the bus.
    pub fn load(&self, from_ns: u64, to_ns: u64) -> f64 {
        if to_ns <= from_ns {
            return 0.0;
        }
        let busy: u64 = self
            .log
            .iter()
            .filter(|(end, _, _)| (from_ns..=to_ns).contains(end))
            .map(|(_, _, f)| self.frame_ns(f))
            .sum();
        busy as f64 / (to_ns - from_ns) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(id: u16) -> CanFrame {
        CanFrame::new(id, &[0x11, 0x22]).unwrap()
    }

    #[test]
    fn arbitration_takes_the_lowest_identifier_and_the_loser_retries() {
        let mut bus = CanBus::new(500_000);
        let a = bus.attach("a");
        let b = bus.attach("b");
        let c = bus.attach("c");
        // a starts alone; b and c queue while a's frame is on the bus.
        bus.send(a, f(0x300));
        bus.send(b, f(0x200));
        bus.send(c, f(0x100));
        bus.send(b, CanFrame::remote(0x080, 0).unwrap());
        bus.send(c, f(0x080));
        bus.advance_to(1_000_000);
        let order: Vec<(u16, bool)> = bus
            .log
            .iter()
            .map(|(_, _, f)| (f.id(), f.is_remote()))
            .collect();
        // After 0x300: b offers 0x200 and c 0x100 (queues are in order): 0x100 wins, then
        // c offers 0x080 data, b still 0x200: 0x080, then 0x200, then b's remote 0x080.
        assert_eq!(
            order,
            vec![
                (0x300, false),
                (0x100, false),
                (0x080, false),
                (0x200, false),
                (0x080, true)
            ]
        );
        assert_eq!(bus.stats.arbitration_lost, 2);
        // Nobody receives its own frame; everybody else gets all.
        assert_eq!(std::iter::from_fn(|| bus.receive(a)).count(), 4);
        assert_eq!(bus.sent(b), 2);
    }

    #[test]
    fn a_broken_transmitter_goes_bus_off_and_recovers() {
        let mut bus = CanBus::new(1_000_000);
        let a = bus.attach("a");
        let b = bus.attach("b");
        bus.set_fault(a, Some(PortFault::Corrupt));
        bus.send(a, f(0x100));
        bus.send(b, f(0x200));
        bus.advance_to(100_000_000);
        // 32 error frames (8 each: 256 > 255), each 30 bits; then b's frame goes out.
        assert_eq!(bus.stats.error_frames, 32);
        assert_eq!(bus.error_state(a), ErrorState::BusOff);
        assert_eq!(bus.error_counters(b), (0, 32), "32 error frames seen");
        assert_eq!(bus.stats.frames, 1);
        assert_eq!(bus.log[0].0, 32 * 30_000 + bus.frame_ns(&f(0x200)));
        assert!(!bus.has_rx(b), "b received nothing of a's");
        // Bus-off: a sends nothing; after recovery with a mended transceiver it does.
        bus.send(a, f(0x101));
        assert_eq!(bus.pending(a), 0);
        bus.set_fault(a, None);
        bus.recover(a);
        assert_eq!(bus.error_state(a), ErrorState::Active);
        bus.send(a, f(0x101));
        bus.advance_to(200_000_000);
        assert_eq!(bus.receive(b).map(|(_, f)| f.id()), Some(0x101));
        // Error passive between 128 and 255.
        bus.set_fault(a, Some(PortFault::Corrupt));
        bus.send(a, f(0x102));
        bus.advance_to(200_000_000 + 16 * 30_000);
        assert_eq!(bus.error_state(a), ErrorState::Passive);
    }

    #[test]
    fn frames_take_their_time_on_the_wire() {
        let mut bus = CanBus::new(500_000);
        let a = bus.attach("a");
        let b = bus.attach("b");
        let frame = CanFrame::new(0x185, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap();
        let bits = u64::from(frame.bits_on_wire());
        assert_eq!(bus.frame_ns(&frame), bits * 2000);
        bus.send(a, frame);
        assert_eq!(bus.next_event_ns(), Some(bits * 2000));
        assert_eq!(bus.advance_to(bits * 2000 - 1), 0);
        assert!(!bus.has_rx(b));
        assert_eq!(bus.advance_to(bits * 2000), 1);
        assert_eq!(bus.receive(b), Some((bits * 2000, frame)));
        // Back to back: the next frame starts when the bus is free.
        bus.send(a, frame);
        bus.send(a, frame);
        bus.advance_to(10_000_000);
        let t = bits * 2000;
        let ends: Vec<u64> = bus.log.iter().map(|(end, _, _)| *end).collect();
        assert_eq!(ends, vec![t, 2 * t, 3 * t]);
        assert!((bus.load(0, 3 * t) - 1.0).abs() < 1e-9);
    }
}
