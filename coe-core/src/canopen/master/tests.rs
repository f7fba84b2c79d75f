//! The master against scripted nodes on a frame-exact loop (the system tests put it
//! against independent slaves on the virtual bus).

use super::*;
use crate::pdo::PdoEntry;
use std::collections::BTreeMap;
use std::vec::Vec;

/// A scripted node: an object dictionary of numbers, the NMT state, heartbeat or guarding.
struct FakeNode {
    id: u8,
    od: BTreeMap<(u16, u8), (u32, u8)>,
    state: NmtState,
    alive: bool,
    toggle: bool,
    /// Writes to these are accepted and not stored (a read-back mismatch).
    ignore_writes: Vec<(u16, u8)>,
    next_hb_us: Option<u64>,
}

impl FakeNode {
    fn new(id: u8) -> Self {
        let mut od = BTreeMap::new();
        od.insert((0x1000, 0), (0x0002_0192, 4));
        od.insert((0x1018, 1), (0x0000_1234, 4));
        od.insert((0x1018, 2), (0x0000_0640, 4));
        od.insert((0x1018, 3), (0x0001_0000, 4));
        od.insert((0x1018, 4), (0x0000_0042, 4));
        od.insert((0x1017, 0), (0, 2));
        od.insert((0x100C, 0), (0, 2));
        od.insert((0x100D, 0), (0, 1));
        for i in 0..4u16 {
            for (base, map) in [(0x1400u16, 0x1600u16), (0x1800, 0x1A00)] {
                for sub in 1..=5u8 {
                    od.insert((base + i, sub), (0, if sub == 1 { 4 } else { 2 }));
                }
                for sub in 0..=8u8 {
                    od.insert((map + i, sub), (0, if sub == 0 { 1 } else { 4 }));
                }
            }
        }
        Self {
            id,
            od,
            state: NmtState::PreOperational,
            alive: true,
            toggle: false,
            ignore_writes: Vec::new(),
            next_hb_us: None,
        }
    }

    fn hb_ms(&self) -> u64 {
        u64::from(self.od.get(&(0x1017, 0)).map_or(0, |v| v.0))
    }

    fn frame(&self, base: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(base + u16::from(self.id), data).unwrap()
    }

    fn boot_up(&mut self, now_us: u64) -> CanFrame {
        self.state = NmtState::PreOperational;
        self.toggle = false;
        self.next_hb_us = None;
        let _ = now_us;
        self.frame(0x700, &[0])
    }

    /// Answers a frame of the bus.
    fn hear(&mut self, f: &CanFrame, now_us: u64) -> Vec<CanFrame> {
        if !self.alive {
            return Vec::new();
        }
        let id = f.id();
        let d = f.data();
        if id == 0 && d.len() == 2 && (d[1] == 0 || d[1] == self.id) {
            match d[0] {
                0x01 => self.state = NmtState::Operational,
                0x02 => self.state = NmtState::Stopped,
                0x80 => self.state = NmtState::PreOperational,
                0x81 | 0x82 => return std::vec![self.boot_up(now_us)],
                _ => {}
            }
            return Vec::new();
        }
        if f.is_remote() && id == 0x700 + u16::from(self.id) {
            let b = self.state.code() | if self.toggle { 0x80 } else { 0 };
            self.toggle = !self.toggle;
            return std::vec![self.frame(0x700, &[b])];
        }
        if id == 0x600 + u16::from(self.id) && d.len() == 8 {
            let index = u16::from_le_bytes([d[1], d[2]]);
            let sub = d[3];
            let mux = [d[1], d[2], d[3]];
            let abort = |code: u32| {
                let c = code.to_le_bytes();
                std::vec![self.frame(
                    0x580,
                    &[0x80, mux[0], mux[1], mux[2], c[0], c[1], c[2], c[3]]
                )]
            };
            return match d[0] >> 5 {
                2 => match self.od.get(&(index, sub)) {
                    Some(&(v, size)) => {
                        let b = v.to_le_bytes();
                        let cmd = 0x43 | ((4 - size) << 2);
                        std::vec![self.frame(
                            0x580,
                            &[cmd, mux[0], mux[1], mux[2], b[0], b[1], b[2], b[3]]
                        )]
                    }
                    None => abort(0x0602_0000),
                },
                1 if d[0] & 0x02 != 0 => {
                    let n = 4 - ((d[0] >> 2) & 3);
                    let mut b = [0u8; 4];
                    b[..usize::from(n)].copy_from_slice(&d[4..4 + usize::from(n)]);
                    let v = u32::from_le_bytes(b);
                    if !self.od.contains_key(&(index, sub)) {
                        return abort(0x0602_0000);
                    }
                    if !self.ignore_writes.contains(&(index, sub)) {
                        self.od.insert((index, sub), (v, n));
                    }
                    if (index, sub) == (0x1017, 0) {
                        self.next_hb_us = (v != 0).then_some(now_us);
                    }
                    std::vec![self.frame(0x580, &[0x60, mux[0], mux[1], mux[2], 0, 0, 0, 0])]
                }
                _ => abort(0x0504_0001),
            };
        }
        Vec::new()
    }

    /// Frames the node's own timers make.
    fn tick(&mut self, now_us: u64) -> Vec<CanFrame> {
        let mut out = Vec::new();
        if !self.alive {
            return out;
        }
        if let Some(t) = self.next_hb_us.filter(|t| now_us >= *t) {
            out.push(self.frame(0x700, &[self.state.code()]));
            self.next_hb_us = Some(t + self.hb_ms() * 1000);
        }
        out
    }
}

type M = Master<4, 16>;

/// The master and its nodes, with every frame in the order it went out.
struct Net {
    m: M,
    nodes: Vec<FakeNode>,
    now: u64,
    log: Vec<(u64, CanFrame)>,
    events: Vec<MasterEvent>,
    /// Frames the nodes send in every SYNC (by node-ID).
    on_sync: BTreeMap<u8, Vec<CanFrame>>,
    sync_id: u16,
}

impl Net {
    fn new(cfg: MasterConfig, places: [NodeConfig; 4], nodes: Vec<FakeNode>) -> Self {
        Self {
            m: M::new(cfg, places).unwrap(),
            nodes,
            now: 0,
            log: Vec::new(),
            events: Vec::new(),
            on_sync: BTreeMap::new(),
            sync_id: cfg.sync_cob_id,
        }
    }

    fn node(&mut self, id: u8) -> &mut FakeNode {
        self.nodes.iter_mut().find(|n| n.id == id).unwrap()
    }

    /// Delivers frames until nothing moves at this instant.
    fn settle(&mut self) {
        for _ in 0..10_000 {
            let mut moved = false;
            while self.m.step(self.now) {
                moved = true;
            }
            // (frame, from the master)
            let mut wire: Vec<(CanFrame, bool)> = Vec::new();
            while let Some(f) = self.m.pop_tx() {
                wire.push((f, true));
            }
            for n in self.nodes.iter_mut() {
                for f in n.tick(self.now) {
                    wire.push((f, false));
                }
            }
            let mut i = 0;
            while i < wire.len() {
                let (f, from_master) = wire[i];
                self.log.push((self.now, f));
                moved = true;
                if from_master {
                    let mut answers = Vec::new();
                    for n in self.nodes.iter_mut() {
                        answers.extend(n.hear(&f, self.now).into_iter().map(|a| (a, false)));
                    }
                    if f.id() == self.sync_id {
                        for (id, frames) in &self.on_sync {
                            let running = self.nodes.iter().any(|n| {
                                n.id == *id && n.alive && n.state == NmtState::Operational
                            });
                            if running {
                                answers.extend(frames.iter().map(|a| (*a, false)));
                            }
                        }
                    }
                    wire.extend(answers);
                } else {
                    self.m.receive(&f, self.now);
                    while let Some(f) = self.m.pop_tx() {
                        wire.push((f, true));
                    }
                }
                i += 1;
            }
            while let Some(e) = self.m.pop_event() {
                self.events.push(e);
            }
            if !moved {
                return;
            }
        }
        panic!("the network does not settle");
    }

    /// Runs to `t` µs in steps of 100 µs.
    fn run_to(&mut self, t: u64) {
        while self.now < t {
            self.settle();
            self.now += 100;
        }
        self.settle();
    }

    fn sdo_frames(&self) -> Vec<[u8; 8]> {
        self.log
            .iter()
            .filter(|(_, f)| (0x601..0x680).contains(&f.id()))
            .map(|(_, f)| f.data().try_into().unwrap())
            .collect()
    }

    fn take_events(&mut self) -> Vec<MasterEvent> {
        core::mem::take(&mut self.events)
    }
}

fn axis(id: u8) -> NodeConfig {
    let mut n = NodeConfig::new(id);
    n.identity = Identity {
        device_type: 0x0002_0192,
        vendor_id: 0x1234,
        ..Identity::default()
    };
    n.rpdo[0] = Some(PdoConfig::new(
        1,
        0x200 + u16::from(id),
        1,
        &[PdoEntry::new(0x6040, 0, 16), PdoEntry::new(0x607A, 0, 32)],
    ));
    n.tpdo[0] = Some(PdoConfig::new(
        1,
        0x180 + u16::from(id),
        1,
        &[PdoEntry::new(0x6041, 0, 16), PdoEntry::new(0x6064, 0, 32)],
    ));
    n.heartbeat_producer_ms = 10;
    n.heartbeat_consumer_ms = 30;
    n
}

fn places(list: &[NodeConfig]) -> [NodeConfig; 4] {
    let mut p = [NodeConfig::EMPTY; 4];
    p[..list.len()].copy_from_slice(list);
    p
}

fn booted(slot: u8, node: u8) -> MasterEvent {
    MasterEvent::NodeBooted { slot, node }
}

#[test]
fn boot_with_identity_check_configuration_and_read_back() {
    let mut net = Net::new(
        MasterConfig::default(),
        places(&[axis(3)]),
        std::vec![FakeNode::new(3)],
    );
    net.m.start(0);
    net.run_to(100_000);
    assert_eq!(net.take_events(), [booted(0, 3)]);
    assert_eq!(net.m.phase(0), Some(NodePhase::Operational));
    assert_eq!(net.node(3).state, NmtState::Operational);
    // The first frame resets every node; the last starts node 3.
    let nmt: Vec<[u8; 2]> = net
        .log
        .iter()
        .filter(|(_, f)| f.id() == 0)
        .map(|(_, f)| f.data().try_into().unwrap())
        .collect();
    assert_eq!(nmt, [[0x82, 0x00], [0x01, 0x03]]);
    let sdo = net.sdo_frames();
    // Golden frames: the identity uploads, the first PDO writes, the last read-back.
    assert_eq!(sdo[0], [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    assert_eq!(sdo[1], [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    assert_eq!(sdo[2], [0x23, 0x00, 0x14, 0x01, 0x03, 0x02, 0x00, 0x80]);
    assert_eq!(sdo[3], [0x2F, 0x00, 0x14, 0x02, 0x01, 0, 0, 0]);
    assert_eq!(sdo[4], [0x2F, 0x00, 0x16, 0x00, 0x00, 0, 0, 0]);
    assert_eq!(sdo[5], [0x23, 0x00, 0x16, 0x01, 0x10, 0x00, 0x40, 0x60]);
    assert_eq!(*sdo.last().unwrap(), [0x40, 0x00, 0x1A, 0x02, 0, 0, 0, 0]);
    // Identity 2, per PDO 7 writes and 5 read-backs, 0x1017.
    assert_eq!(sdo.len(), 2 + 2 * 7 + 1 + 2 * 5);
    // The node holds what was written.
    let n = net.node(3);
    assert_eq!(n.od[&(0x1A00, 2)].0, 0x6064_0020);
    assert_eq!(n.od[&(0x1800, 1)].0, 0x183);
    assert_eq!(n.od[&(0x1017, 0)].0, 10);
    assert!(net.m.all_mandatory_operational());
}

#[test]
fn identity_errors_name_their_letter() {
    for (key, letter) in [
        ((0x1000u16, 0u8), 'C'),
        ((0x1018, 1), 'D'),
        ((0x1018, 2), 'M'),
        ((0x1018, 3), 'N'),
        ((0x1018, 4), 'O'),
    ] {
        let mut cfg = axis(3);
        cfg.identity = Identity {
            device_type: 0x0002_0192,
            vendor_id: 0x1234,
            product_code: 0x640,
            revision: 0x0001_0000,
            serial: 0x42,
        };
        let mut node = FakeNode::new(3);
        node.od.get_mut(&key).unwrap().0 ^= 1;
        let mut net = Net::new(MasterConfig::default(), places(&[cfg]), std::vec![node]);
        net.m.start(0);
        net.run_to(50_000);
        let ev = net.take_events();
        let MasterEvent::BootError {
            error,
            index,
            sub,
            cause,
            ..
        } = ev[0]
        else {
            panic!("{ev:?}");
        };
        assert_eq!(error.letter(), letter);
        assert_eq!((index, sub), key);
        assert!(matches!(cause, BootCause::Mismatch { .. }));
        assert_eq!(net.m.last_boot_error(0), Some(error));
    }
}

#[test]
fn a_missing_mandatory_node_is_b_and_not_retried_an_optional_one_is() {
    let mut mandatory = axis(3);
    mandatory.mandatory = true;
    let optional = axis(4);
    let mut a = FakeNode::new(3);
    a.alive = false;
    let mut b = FakeNode::new(4);
    b.alive = false;
    let cfg = MasterConfig {
        start_all_at_once: true,
        ..MasterConfig::default()
    };
    let mut net = Net::new(cfg, places(&[mandatory, optional]), std::vec![a, b]);
    net.m.start(0);
    // Boot wait 500 ms, then 100 ms SDO timeout.
    net.run_to(700_000);
    let ev = net.take_events();
    let letters: Vec<(u8, char)> = ev
        .iter()
        .filter_map(|e| match e {
            MasterEvent::BootError {
                node, error, cause, ..
            } => {
                assert!(matches!(cause, BootCause::Sdo(f) if f.is_timeout()));
                Some((*node, error.letter()))
            }
            _ => None,
        })
        .collect();
    assert_eq!(letters, [(3, 'B'), (4, 'B')]);
    // The SDO timeout went out as an abort 0x05040000.
    assert!(net
        .sdo_frames()
        .contains(&[0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]));
    assert_eq!(
        net.m.phase(0),
        Some(NodePhase::Failed(BootError::NoDeviceType, None))
    );
    assert!(!net.m.all_mandatory_operational());
    // The optional node is retried every second; it comes and boots.
    net.node(4).alive = true;
    net.run_to(1_800_000);
    assert!(net.take_events().contains(&booted(1, 4)));
    assert_eq!(
        net.m.phase(1),
        Some(NodePhase::WaitStart),
        "network not started"
    );
    assert_eq!(net.node(4).state, NmtState::PreOperational);
    // The mandatory one boots up on its own: now the network starts, with one broadcast.
    net.node(3).alive = true;
    let f = net.node(3).boot_up(0);
    net.m.receive(&f, net.now);
    net.run_to(2_000_000);
    assert!(net.take_events().contains(&booted(0, 3)));
    assert!(net.m.all_mandatory_operational());
    assert!(net
        .log
        .iter()
        .any(|(_, f)| f.id() == 0 && f.data() == [0x01, 0x00]));
    assert_eq!(net.node(4).state, NmtState::Operational);
}

#[test]
fn configuration_errors_are_j_and_heartbeat_errors_k() {
    // The node refuses the transmission type: J with the server's abort.
    let mut node = FakeNode::new(3);
    node.od.remove(&(0x1800, 2));
    let mut net = Net::new(MasterConfig::default(), places(&[axis(3)]), std::vec![node]);
    net.m.start(0);
    net.run_to(50_000);
    assert_eq!(
        net.take_events(),
        [MasterEvent::BootError {
            slot: 0,
            node: 3,
            error: BootError::ConfigurationFailed,
            index: 0x1800,
            sub: 2,
            cause: BootCause::Sdo(sdo_client::SdoFailure::Server(
                crate::SdoAbortCode::ObjectDoesNotExist
            )),
        }]
    );
    // It takes the value but keeps the old one: the read-back finds it.
    let mut node = FakeNode::new(3);
    node.ignore_writes.push((0x1A00, 2));
    let mut net = Net::new(MasterConfig::default(), places(&[axis(3)]), std::vec![node]);
    net.m.start(0);
    net.run_to(50_000);
    assert_eq!(
        net.take_events(),
        [MasterEvent::BootError {
            slot: 0,
            node: 3,
            error: BootError::ConfigurationFailed,
            index: 0x1A00,
            sub: 2,
            cause: BootCause::Mismatch {
                expected: 0x6064_0020,
                actual: 0
            },
        }]
    );
    // No heartbeat after the configuration: K.
    let mut cfg = axis(3);
    cfg.heartbeat_producer_ms = 0;
    let mut net = Net::new(
        MasterConfig::default(),
        places(&[cfg]),
        std::vec![FakeNode::new(3)],
    );
    net.m.start(0);
    net.run_to(100_000);
    let ev = net.take_events();
    assert!(
        matches!(
            ev[..],
            [MasterEvent::BootError {
                error: BootError::HeartbeatMissing,
                ..
            }]
        ),
        "{ev:?}"
    );
}

#[test]
fn a_node_already_operational_is_l_and_reset() {
    let cfg = MasterConfig {
        reset_on_start: false,
        ..MasterConfig::default()
    };
    let mut net = Net::new(cfg, places(&[axis(3)]), std::vec![FakeNode::new(3)]);
    // Heard operational before the master starts.
    net.m.receive(&CanFrame::new(0x703, &[5]).unwrap(), 0);
    net.m.start(0);
    net.run_to(100_000);
    let ev = net.take_events();
    assert!(
        matches!(
            ev[0],
            MasterEvent::BootError {
                error: BootError::InitiallyOperational,
                ..
            }
        ),
        "{ev:?}"
    );
    assert!(net
        .log
        .iter()
        .any(|(_, f)| f.id() == 0 && f.data() == [0x82, 0x03]));
    assert_eq!(ev[1], booted(0, 3), "booted after its reset");
}

#[test]
fn heartbeat_loss_and_return() {
    let mut net = Net::new(
        MasterConfig::default(),
        places(&[axis(3)]),
        std::vec![FakeNode::new(3)],
    );
    net.m.start(0);
    net.run_to(100_000);
    net.take_events();
    // Silent: lost after the consumer time.
    net.node(3).alive = false;
    net.run_to(150_000);
    assert_eq!(
        net.take_events(),
        [MasterEvent::NodeLost {
            slot: 0,
            node: 3,
            cause: LossCause::Heartbeat
        }]
    );
    assert_eq!(net.m.phase(0), Some(NodePhase::Lost));
    // Back without a reset (a cable): operational at once.
    net.node(3).alive = true;
    net.run_to(200_000);
    assert_eq!(
        net.take_events(),
        [MasterEvent::NodeReturned { slot: 0, node: 3 }]
    );
    // A reset node: it boots up, is configured again and returns.
    net.node(3).od.insert((0x1A00, 2), (0, 4));
    let f = net.node(3).boot_up(0);
    net.m.receive(&f, net.now);
    net.run_to(300_000);
    assert_eq!(
        net.take_events(),
        [
            MasterEvent::NodeLost {
                slot: 0,
                node: 3,
                cause: LossCause::BootUp
            },
            booted(0, 3),
            MasterEvent::NodeReturned { slot: 0, node: 3 },
        ]
    );
    assert_eq!(
        net.node(3).od[&(0x1A00, 2)].0,
        0x6064_0020,
        "configured again"
    );
    assert_eq!(net.node(3).state, NmtState::Operational);
}

#[test]
fn node_guarding_loss_and_return() {
    let mut cfg = axis(3);
    cfg.heartbeat_producer_ms = 0;
    cfg.heartbeat_consumer_ms = 0;
    cfg.guard_time_ms = 10;
    cfg.life_time_factor = 3;
    let mut net = Net::new(
        MasterConfig::default(),
        places(&[cfg]),
        std::vec![FakeNode::new(3)],
    );
    net.m.start(0);
    net.run_to(100_000);
    assert_eq!(net.take_events(), [booted(0, 3)]);
    let n = net.node(3);
    assert_eq!((n.od[&(0x100C, 0)].0, n.od[&(0x100D, 0)].0), (10, 3));
    let rtr = net
        .log
        .iter()
        .filter(|(_, f)| f.is_remote() && f.id() == 0x703)
        .count();
    assert!((6..=11).contains(&rtr), "{rtr} guard requests");
    net.node(3).alive = false;
    let t = net.now;
    net.run_to(t + 50_000);
    assert_eq!(
        net.take_events(),
        [MasterEvent::NodeLost {
            slot: 0,
            node: 3,
            cause: LossCause::Guarding
        }]
    );
    net.node(3).alive = true;
    net.run_to(t + 80_000);
    assert_eq!(
        net.take_events(),
        [MasterEvent::NodeReturned { slot: 0, node: 3 }]
    );
    assert_eq!(net.m.guard_toggle_errors(0), 0);
}

#[test]
fn sync_outputs_inputs_and_their_supervision() {
    let cfg = MasterConfig {
        sync_period_us: 2_000,
        ..MasterConfig::default()
    };
    let mut net = Net::new(cfg, places(&[axis(3)]), std::vec![FakeNode::new(3)]);
    net.m.start(0);
    net.run_to(100_000);
    net.take_events();
    net.m.set_output(0, 0, &[0x0F, 0, 1, 2, 3, 4]).unwrap();
    assert_eq!(net.m.set_output(0, 0, &[1]), Err(MasterError::Length));
    assert_eq!(net.m.set_output(0, 1, &[1]), Err(MasterError::NoPdo));
    net.on_sync.insert(
        3,
        std::vec![CanFrame::new(0x183, &[0x37, 0x02, 9, 8, 7, 6]).unwrap()],
    );
    let t = net.now;
    net.run_to(t + 10_000);
    // SYNC then the RPDO, every 2 ms.
    let after: Vec<u16> = net
        .log
        .iter()
        .filter(|(at, f)| *at > t && (f.id() == 0x80 || f.id() == 0x203))
        .map(|(_, f)| f.id())
        .collect();
    assert_eq!(
        after,
        [0x80, 0x203, 0x80, 0x203, 0x80, 0x203, 0x80, 0x203, 0x80, 0x203]
    );
    assert_eq!(net.m.input(0, 0), Some(&[0x37u8, 0x02, 9, 8, 7, 6][..]));
    assert!(net.take_events().is_empty());
    // The TPDO stops: missing at the next SYNC, reported once, counted each time.
    net.on_sync.clear();
    net.run_to(t + 20_000);
    let ev = net.take_events();
    assert_eq!(
        ev,
        [MasterEvent::PdoMissing {
            slot: 0,
            node: 3,
            pdo: 0
        }]
    );
    assert!(net.m.input_stats(0, 0).unwrap().missing >= 4);
    // A short one.
    net.m.receive(&CanFrame::new(0x183, &[1]).unwrap(), net.now);
    net.settle();
    assert_eq!(
        net.take_events(),
        [MasterEvent::PdoLength {
            slot: 0,
            node: 3,
            pdo: 0,
            len: 1
        }]
    );
    // Cycle events: one SYNC per 2 events.
    let cfg = MasterConfig {
        sync_multiplier: 2,
        ..MasterConfig::default()
    };
    let mut m = M::new(cfg, places(&[])).unwrap();
    assert!(!m.cycle_event(0), "not started");
    m.start(0);
    let made: Vec<bool> = (0..4).map(|i| m.cycle_event(i)).collect();
    assert_eq!(made, [false, true, false, true]);
    let syncs = std::iter::from_fn(|| m.pop_tx())
        .filter(|f| f.id() == 0x80)
        .count();
    assert_eq!(syncs, 2);
}

#[test]
fn event_driven_pdos_and_emergencies() {
    let mut cfg = axis(3);
    let mut t = cfg.tpdo[0].unwrap();
    t.transmission_type = 255;
    t.deadline_ms = 20;
    cfg.tpdo[0] = Some(t);
    let mut r = cfg.rpdo[0].unwrap();
    r.transmission_type = 255;
    r.event_timer_ms = 5;
    cfg.rpdo[0] = Some(r);
    let mut net = Net::new(
        MasterConfig::default(),
        places(&[cfg]),
        std::vec![FakeNode::new(3)],
    );
    net.m.start(0);
    net.run_to(100_000);
    net.take_events();
    let t0 = net.now;
    assert!(
        net.m.input_stats(0, 0).unwrap().timeouts >= 1,
        "nothing came since the start"
    );
    let tpdo = CanFrame::new(0x183, &[1, 0, 2, 0, 0, 0]).unwrap();
    net.m.receive(&tpdo, t0);
    net.m.set_output(0, 0, &[1, 2, 3, 4, 5, 6]).unwrap();
    net.run_to(t0 + 12_000);
    let rpdos = net
        .log
        .iter()
        .filter(|(at, f)| *at >= t0 && f.id() == 0x203)
        .count();
    assert_eq!(rpdos, 3, "at once, then every 5 ms");
    net.run_to(t0 + 25_000);
    assert_eq!(
        net.take_events(),
        [MasterEvent::PdoTimeout {
            slot: 0,
            node: 3,
            pdo: 0
        }]
    );
    net.m.receive(
        &CanFrame::new(0x83, &[0x30, 0x81, 0x11, 3, 0, 0, 0, 0]).unwrap(),
        net.now,
    );
    let ev = net.m.pop_event().unwrap();
    let MasterEvent::Emergency {
        node: 3, emergency, ..
    } = ev
    else {
        panic!("{ev:?}");
    };
    assert_eq!(emergency.error_code, 0x8130);
    assert_eq!(net.m.emergencies(0).unwrap().count, 1);
}

#[test]
fn application_sdo_and_nmt() {
    let mut net = Net::new(
        MasterConfig::default(),
        places(&[axis(3)]),
        std::vec![FakeNode::new(3)],
    );
    net.m.start(0);
    assert_eq!(
        net.m.sdo_upload(0, 0x1018, 4, 0),
        Err(MasterError::Busy),
        "boot runs"
    );
    net.run_to(100_000);
    net.take_events();
    net.m.sdo_upload(0, 0x1018, 4, net.now).unwrap();
    net.settle();
    assert_eq!(
        net.take_events(),
        [MasterEvent::SdoDone {
            slot: 0,
            node: 3,
            result: Ok(4)
        }]
    );
    assert_eq!(net.m.sdo_data(0), &[0x42, 0, 0, 0]);
    assert_eq!(net.m.sdo_upload(3, 0, 0, 0), Err(MasterError::NoNode));
    net.m.nmt(NmtCommand::StopRemoteNode, 3, net.now).unwrap();
    net.settle();
    assert_eq!(net.m.phase(0), Some(NodePhase::Halted));
    assert_eq!(net.node(3).state, NmtState::Stopped);
    net.m.nmt(NmtCommand::StartRemoteNode, 0, net.now).unwrap();
    net.settle();
    assert_eq!(net.m.phase(0), Some(NodePhase::Operational));
    net.m
        .nmt(NmtCommand::ResetCommunication, 3, net.now)
        .unwrap();
    let t = net.now;
    net.run_to(t + 100_000);
    assert_eq!(net.take_events(), [booted(0, 3)], "reset and booted again");
}

#[test]
fn bad_configurations_are_refused() {
    let mut bad = axis(3);
    bad.tpdo[1] = bad.tpdo[0];
    assert_eq!(
        M::new(MasterConfig::default(), places(&[axis(4), bad])).unwrap_err(),
        (1, ConfigError::DuplicateCobId)
    );
}

#[test]
fn places_change_only_while_stopped_and_the_identity_seen_is_kept() {
    let mut net = Net::new(
        MasterConfig::default(),
        places(&[]),
        std::vec![FakeNode::new(3), FakeNode::new(4)],
    );
    assert_eq!(net.m.place_mut(4).err(), Some(ConfigError::NoPlace));
    assert_eq!(net.m.phase(0), Some(NodePhase::Unused));
    let mut bad = axis(4);
    bad.tpdo[1] = bad.tpdo[0];
    *net.m.place_mut(1).unwrap() = bad;
    assert_eq!(net.m.check(), Err((1, ConfigError::DuplicateCobId)));
    let mut node = axis(3);
    node.identity.product_code = 0x0640;
    node.identity.serial = 0x42;
    *net.m.place_mut(0).unwrap() = node;
    net.m.start(0);
    assert!(net.m.is_started());
    assert_eq!(net.m.place_mut(0).err(), Some(ConfigError::Running));
    // The wrong place is left unused; the other boots.
    assert_eq!(net.m.phase(1), Some(NodePhase::Unused));
    assert_eq!(net.m.node_config(1), Some(&NodeConfig::EMPTY));
    net.run_to(100_000);
    assert_eq!(net.take_events(), [booted(0, 3)]);
    // Read: device type, vendor (configured), product and serial (configured); the
    // revision was not asked for.
    assert_eq!(
        net.m.detected(0),
        Some(&Identity {
            device_type: 0x0002_0192,
            vendor_id: 0x1234,
            product_code: 0x0640,
            revision: 0,
            serial: 0x42,
        })
    );
    assert_eq!(
        net.m.set_config(MasterConfig::default()),
        Err(ConfigError::Running)
    );
    net.m.stop();
    assert_eq!(net.m.detected(0).map(|d| d.vendor_id), Some(0x1234));
    let cfg = MasterConfig {
        sync_period_us: 5_000,
        ..MasterConfig::default()
    };
    assert_eq!(net.m.set_config(cfg), Ok(()));
    assert_eq!(net.m.config().sync_period_us, 5_000);
    // Another node in the place: it boots after the next start.
    *net.m.place_mut(0).unwrap() = axis(4);
    net.m.start(net.now);
    let from = net.now;
    net.run_to(net.now + 100_000);
    // Booted; the new parameters run: SYNCs every 5 ms, and node 4 (which sends no TPDO
    // here) misses its synchronous TPDO.
    let ev = net.take_events();
    assert_eq!(ev[0], booted(0, 4));
    assert!(
        matches!(ev[1], MasterEvent::PdoMissing { node: 4, .. }),
        "{ev:?}"
    );
    let syncs: Vec<u64> = net
        .log
        .iter()
        .filter(|(t, f)| *t >= from && f.id() == 0x80)
        .map(|(t, _)| *t)
        .collect();
    assert!(syncs.windows(2).all(|w| w[1] - w[0] == 5_000), "{syncs:?}");
    assert!(syncs.len() >= 10);
    assert_eq!(net.m.phase(0), Some(NodePhase::Operational));
}

/// What one instance of the master takes in RAM (the gateway chooses N and BUF).
#[test]
fn footprint() {
    let size = core::mem::size_of::<Master<16, 16>>();
    std::println!(
        "Master<16, 16>: {size} B (NodeConfig {} B, per node runtime {} B)",
        core::mem::size_of::<NodeConfig>(),
        core::mem::size_of::<NodeRuntime<16>>()
    );
    assert!(size < 20 * 1024);
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    fn frame() -> impl Strategy<Value = CanFrame> {
        (
            0u16..0x800,
            proptest::collection::vec(any::<u8>(), 0..=8),
            any::<bool>(),
        )
            .prop_map(|(id, data, rtr)| {
                if rtr {
                    CanFrame::remote(id, data.len() as u8).unwrap()
                } else {
                    CanFrame::new(id, &data).unwrap()
                }
            })
    }

    fn biased_frame() -> impl Strategy<Value = CanFrame> {
        prop_oneof![
            frame(),
            (0x580u16..0x588, proptest::array::uniform8(any::<u8>()))
                .prop_map(|(id, d)| CanFrame::new(id, &d).unwrap()),
            (0x700u16..0x708, any::<u8>()).prop_map(|(id, b)| CanFrame::new(id, &[b]).unwrap()),
        ]
    }

    proptest! {
        /// Random frames at random times never panic, every call ends, and step runs
        /// out of work in a bounded number of calls.
        #[test]
        fn random_frames(frames in proptest::collection::vec((biased_frame(), 0u64..5_000), 0..200)) {
            let mut g = axis(4);
            g.heartbeat_consumer_ms = 0;
            g.guard_time_ms = 5;
            g.life_time_factor = 2;
            let cfg = MasterConfig { sync_period_us: 1_000, ..MasterConfig::default() };
            let mut m = M::new(cfg, places(&[axis(3), g, axis(5)])).unwrap();
            m.start(0);
            let mut now = 0u64;
            for (f, dt) in frames {
                now += dt;
                m.receive(&f, now);
                let mut n = 0;
                while m.step(now) {
                    n += 1;
                    prop_assert!(n < 1_000, "step does not run out of work");
                    while m.pop_tx().is_some() {}
                }
                while m.pop_tx().is_some() {}
                while m.pop_event().is_some() {}
                let _ = m.next_deadline_us();
            }
        }
    }
}
