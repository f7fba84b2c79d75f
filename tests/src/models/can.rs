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
//! Every frame is acknowledged: the model has no error frames, no bus-off and no ACK
//! errors (at least one other node, the CAN adapter of the master, is assumed on the bus).

use coe_core::canopen::CanFrame;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

/// A bus shared by the board and the tools.
pub type SharedCanBus = Rc<RefCell<CanBus>>;

/// A port on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PortId(usize);

#[derive(Debug)]
struct Port {
    name: String,
    attached: bool,
    tx: VecDeque<CanFrame>,
    rx: VecDeque<(u64, CanFrame)>,
    sent: u64,
}

/// A frame on the bus: who sent it and when it ends.
#[derive(Clone, Copy, Debug)]
struct OnBus {
    frame: CanFrame,
    from: usize,
    end_ns: u64,
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

    /// The name a port was attached with.
    pub fn port_name(&self, port: PortId) -> &str {
        self.ports.get(port.0).map_or("?", |p| p.name.as_str())
    }

    /// Queues a frame at `port` (sent in the order queued).
    pub fn send(&mut self, port: PortId, frame: CanFrame) {
        if let Some(p) = self.ports.get_mut(port.0).filter(|p| p.attached) {
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
        if let Some(p) = self.ports.get_mut(from) {
            p.tx.pop_front();
        }
        let start = self.idle_from_ns.max(self.now_ns);
        self.on_bus = Some(OnBus {
            frame,
            from,
            end_ns: start + self.frame_ns(&frame),
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
            self.stats.frames += 1;
            self.stats.bits += u64::from(b.frame.bits_on_wire());
            self.log.push((b.end_ns, PortId(b.from), b.frame));
            for (i, p) in self.ports.iter_mut().enumerate() {
                if i == b.from {
                    p.sent += 1;
                } else if p.attached {
                    p.rx.push_back((b.end_ns, b.frame));
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
