//! SYSTEM TEST: coe-core's CANopen master on the virtual CAN bus with the project's own CAN
//! node (coe-core's `CanNode`, in process) as slaves, in virtual time: boot-up with the
//! identity check, remote PDO configuration and its read-back, all nodes operational, data
//! both ways, a missing mandatory node, wrong identities, a node lost in operation (by
//! heartbeat, by node guarding, by bus-off) and taken back, and the two seed scenarios,
//! whose figures come from the bus model's bits on the wire at the bit rate.
//!
//! The same master against slaves nobody here wrote (durand, python-canopen) is
//! `system_can_master_python.rs`.

use coe_core::canopen::master::boot::BootError;
use coe_core::canopen::master::config::{Identity, MasterConfig, NodeConfig, PdoConfig};
use coe_core::canopen::master::events::{BootCause, LossCause, MasterEvent};
use coe_core::canopen::master::NodePhase;
use coe_core::canopen::NmtState;
use coe_core::pdo::PdoEntry;
use virtual_board::models::can::PortFault;
use virtual_board::rig::can_slave::{InProcessSlave, SlaveIdentity};
use virtual_board::rig::master_host::{CanNetwork, TestMaster};

const MS: u64 = 1_000_000;

fn identity(node: u8) -> SlaveIdentity {
    SlaveIdentity {
        device_type: 0x0002_0192,
        vendor_id: 0x0000_ABCD,
        product_code: 0x0000_0640,
        revision: 0x0001_0002,
        serial: 1000 + u32::from(node),
    }
}

fn expected(node: u8) -> Identity {
    let id = identity(node);
    Identity {
        device_type: id.device_type,
        vendor_id: id.vendor_id,
        product_code: id.product_code,
        revision: id.revision,
        serial: id.serial,
    }
}

/// A servo axis (seed 001): RPDO 1 controlword + target position, TPDO 1 statusword +
/// position, both on every SYNC; heartbeat.
fn axis(node: u8) -> NodeConfig {
    let mut n = NodeConfig::new(node);
    n.identity = expected(node);
    n.mandatory = true;
    n.rpdo[0] = Some(PdoConfig::new(
        1,
        0x200 + u16::from(node),
        1,
        &[PdoEntry::new(0x6040, 0, 16), PdoEntry::new(0x607A, 0, 32)],
    ));
    n.tpdo[0] = Some(PdoConfig::new(
        1,
        0x180 + u16::from(node),
        1,
        &[PdoEntry::new(0x6041, 0, 16), PdoEntry::new(0x6064, 0, 32)],
    ));
    n.heartbeat_producer_ms = 50;
    n.heartbeat_consumer_ms = 120;
    n
}

/// A generic I/O node (seed 002): 16 bytes in on TPDO 1 and 2, 8 bytes out on RPDO 1.
fn io_node(node: u8) -> NodeConfig {
    let bytes = |index: u16, from: u8| -> Vec<PdoEntry> {
        (from..from + 8)
            .map(|s| PdoEntry::new(index, s, 8))
            .collect()
    };
    let mut n = NodeConfig::new(node);
    n.identity = expected(node);
    n.mandatory = true;
    n.tpdo[0] = Some(PdoConfig::new(
        1,
        0x180 + u16::from(node),
        1,
        &bytes(0x2000, 1),
    ));
    n.tpdo[1] = Some(PdoConfig::new(
        2,
        0x280 + u16::from(node),
        1,
        &bytes(0x2000, 9),
    ));
    n.rpdo[0] = Some(PdoConfig::new(
        1,
        0x200 + u16::from(node),
        1,
        &bytes(0x2100, 1),
    ));
    n.heartbeat_producer_ms = 100;
    n.heartbeat_consumer_ms = 250;
    n
}

fn master(cfg: MasterConfig, nodes: &[NodeConfig]) -> TestMaster {
    let mut places = [NodeConfig::EMPTY; 16];
    places[..nodes.len()].copy_from_slice(nodes);
    TestMaster::new(cfg, places).unwrap()
}

fn network(bit_rate: u32, cfg: MasterConfig, nodes: &[NodeConfig], present: &[u8]) -> CanNetwork {
    let mut net = CanNetwork::new(bit_rate, master(cfg, nodes));
    for &id in present {
        let s = InProcessSlave::attach(&mut net.bus, id, identity(id));
        net.slaves.push(s);
    }
    net
}

fn boot_letters(events: &[MasterEvent]) -> Vec<(u8, char)> {
    events
        .iter()
        .filter_map(|e| match e {
            MasterEvent::BootError { node, error, .. } => Some((*node, error.letter())),
            _ => None,
        })
        .collect()
}

fn booted(events: &[MasterEvent]) -> Vec<u8> {
    events
        .iter()
        .filter_map(|e| match e {
            MasterEvent::NodeBooted { node, .. } => Some(*node),
            _ => None,
        })
        .collect()
}

#[test]
fn boot_configuration_read_back_and_data_both_ways() {
    let cfg = MasterConfig {
        sync_period_us: 10_000,
        ..MasterConfig::default()
    };
    let mut net = network(500_000, cfg, &[axis(2), io_node(3), axis(4)], &[2, 3, 4]);
    net.master.master.start(0);
    net.run_to(2_000 * MS);
    let events = net.master.events_since(0);
    assert_eq!(boot_letters(&events), [], "{events:?}");
    let mut b = booted(&events);
    b.sort();
    assert_eq!(b, [2, 3, 4]);
    let boot_done = net.master.events.iter().map(|(t, _)| *t).max().unwrap();
    println!(
        "3 nodes booted at 500 kbit/s (identity, PDOs with read-back, heartbeat) in {:.1} ms",
        boot_done as f64 / 1e6
    );
    assert!(net.master.master.all_mandatory_operational());
    for id in [2, 3, 4] {
        assert_eq!(net.slave(id).state(), NmtState::Operational, "node {id}");
    }
    // What the master wrote is in the nodes (the node's own objects, read here).
    let p = net.slave(3).node.params();
    assert_eq!(p.tpdo[1].cob_id.can_id(), 0x283);
    assert!(p.tpdo[1].is_valid() && p.tpdo[0].is_valid() && p.rpdo[0].is_valid());
    assert!(!p.tpdo[2].is_valid() && !p.rpdo[1].is_valid());
    assert_eq!(p.heartbeat_ms, 100);
    // Data both ways: outputs to node 3 and axis 2, inputs from all.
    net.slave(3).dev.inputs = core::array::from_fn(|i| 0xA0 + i as u8);
    net.slave(2).dev.controlword = 0;
    net.master
        .master
        .set_output(1, 0, &[1, 2, 3, 4, 5, 6, 7, 8])
        .unwrap();
    net.master
        .master
        .set_output(0, 0, &[0x0F, 0, 0x40, 0xE2, 0x01, 0])
        .unwrap();
    let t = net.now_ns();
    net.run_to(t + 50 * MS);
    assert_eq!(net.slave(3).dev.outputs[..8], [1, 2, 3, 4, 5, 6, 7, 8]);
    assert_eq!(net.slave(2).dev.controlword, 0x0F);
    let m = &net.master.master;
    assert_eq!(
        m.input(1, 0),
        Some(&[0xA0, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6, 0xA7][..])
    );
    assert_eq!(
        m.input(1, 1),
        Some(&[0xA8, 0xA9, 0xAA, 0xAB, 0xAC, 0xAD, 0xAE, 0xAF][..])
    );
    // Statusword 0x0027 (operation enabled), position = target 123456 = 0x0001E240.
    assert_eq!(m.input(0, 0), Some(&[0x27, 0, 0x40, 0xE2, 0x01, 0][..]));
    assert_eq!(
        net.master.events.len(),
        events.len(),
        "no event in operation"
    );
}

#[test]
fn a_missing_mandatory_node_and_wrong_identities_name_their_letter() {
    let mut wrong_vendor = axis(3);
    wrong_vendor.identity.vendor_id = 0x1111;
    let mut wrong_serial = axis(4);
    wrong_serial.identity.serial = 7;
    wrong_serial.mandatory = false;
    let cfg = MasterConfig {
        start_all_at_once: true,
        ..MasterConfig::default()
    };
    // Node 5 is configured but absent.
    let mut net = network(
        1_000_000,
        cfg,
        &[axis(2), wrong_vendor, wrong_serial, axis(5)],
        &[2, 3, 4],
    );
    net.master.master.start(0);
    net.run_to(1_000 * MS);
    let events = net.master.events_since(0);
    let mut letters = boot_letters(&events);
    letters.sort();
    assert_eq!(letters[..3], [(3, 'D'), (4, 'O'), (5, 'B')], "{events:?}");
    let cause = events.iter().find_map(|e| match e {
        MasterEvent::BootError {
            node: 3,
            cause,
            index,
            sub,
            ..
        } => Some((*index, *sub, *cause)),
        _ => None,
    });
    assert_eq!(
        cause,
        Some((
            0x1018,
            1,
            BootCause::Mismatch {
                expected: 0x1111,
                actual: 0xABCD
            }
        ))
    );
    // Mandatory nodes missing: the network is not started (the gateway stays out of OP).
    let m = &net.master.master;
    assert!(!m.all_mandatory_operational());
    assert_eq!(m.phase(0), Some(NodePhase::WaitStart));
    assert_eq!(
        m.phase(3),
        Some(NodePhase::Failed(BootError::NoDeviceType, None))
    );
    assert_eq!(net.slave(2).state(), NmtState::PreOperational);
    // The optional node with the wrong serial number is retried (and fails again).
    let o_count = boot_letters(&events).iter().filter(|l| l.0 == 4).count();
    assert!(o_count >= 1);
    // Node 5 is powered on late: its boot-up makes the master boot it; node 3 is restarted
    // by the application with a corrected expectation... not possible: its configuration
    // is fixed; so the network still waits for node 3.
    let s = InProcessSlave::attach(&mut net.bus, 5, identity(5));
    net.slaves.push(s);
    let t = net.now_ns();
    net.run_to(t + 500 * MS);
    assert_eq!(
        net.master.master.phase(3),
        Some(NodePhase::WaitStart),
        "node 5 booted"
    );
    assert_eq!(
        net.slave(5).state(),
        NmtState::PreOperational,
        "not started"
    );
}

/// The detection of a lost node and its return, three ways.
#[test]
fn a_node_lost_in_operation_is_detected_and_taken_back() {
    let mut guarded = axis(3);
    guarded.heartbeat_producer_ms = 0;
    guarded.heartbeat_consumer_ms = 0;
    guarded.guard_time_ms = 20;
    guarded.life_time_factor = 3;
    let cfg = MasterConfig {
        sync_period_us: 2_000,
        ..MasterConfig::default()
    };
    let mut net = network(1_000_000, cfg, &[axis(2), guarded, axis(4)], &[2, 3, 4]);
    net.master.master.start(0);
    net.run_to(500 * MS);
    assert_eq!(net.master.master.operational(), 3);
    let lost = |net: &CanNetwork, from: usize| -> Vec<(u64, MasterEvent)> {
        net.master.events[from..]
            .iter()
            .filter(|(_, e)| {
                matches!(
                    e,
                    MasterEvent::NodeLost { .. } | MasterEvent::NodeReturned { .. }
                )
            })
            .copied()
            .collect()
    };

    // Heartbeat: node 2 loses its power.
    let from = net.master.events.len();
    let t0 = net.now_ns();
    net.power(2, false);
    net.run_to(t0 + 300 * MS);
    let l = lost(&net, from);
    assert!(
        matches!(
            l[0].1,
            MasterEvent::NodeLost {
                node: 2,
                cause: LossCause::Heartbeat,
                ..
            }
        ),
        "{l:?}"
    );
    println!(
        "heartbeat loss (producer 50 ms, consumer 120 ms) detected {:.1} ms after the power went",
        (l[0].0 - t0) as f64 / 1e6
    );
    assert!(l[0].0 - t0 <= 120 * MS);
    assert!(net
        .master
        .events_since(from)
        .iter()
        .any(|e| matches!(e, MasterEvent::PdoMissing { node: 2, .. })));
    // It comes back: boot-up, configured again, returned.
    let from = net.master.events.len();
    net.power(2, true);
    let t1 = net.now_ns();
    net.run_to(t1 + 300 * MS);
    let ev = net.master.events_since(from);
    assert!(
        ev.contains(&MasterEvent::NodeReturned { slot: 0, node: 2 }),
        "{ev:?}"
    );
    assert_eq!(net.slave(2).state(), NmtState::Operational);

    // Node guarding: node 3 (RTR every 20 ms, life time factor 3).
    let from = net.master.events.len();
    let t0 = net.now_ns();
    net.power(3, false);
    net.run_to(t0 + 200 * MS);
    let l = lost(&net, from);
    assert!(
        matches!(
            l[0].1,
            MasterEvent::NodeLost {
                node: 3,
                cause: LossCause::Guarding,
                ..
            }
        ),
        "{l:?}"
    );
    println!(
        "guarding loss (guard time 20 ms x 3) detected {:.1} ms after the power went",
        (l[0].0 - t0) as f64 / 1e6
    );
    assert!(l[0].0 - t0 <= 80 * MS);
    net.power(3, true);
    let t1 = net.now_ns();
    net.run_to(t1 + 300 * MS);
    assert!(net
        .master
        .events_since(from)
        .contains(&MasterEvent::NodeReturned { slot: 1, node: 3 }));
    assert_eq!(net.slave(3).state(), NmtState::Operational);
    assert_eq!(net.master.master.guard_toggle_errors(1), 0);

    // Bus-off: node 4's transmitter breaks; the controller goes bus-off; mended and
    // recovered, the node goes on where it was (operational): returned without a boot.
    let from = net.master.events.len();
    let port = net.slave(4).port;
    let t0 = net.now_ns();
    net.bus.set_fault(port, Some(PortFault::Corrupt));
    net.run_to(t0 + 300 * MS);
    assert_eq!(
        net.bus.error_state(port),
        virtual_board::models::can::ErrorState::BusOff
    );
    let l = lost(&net, from);
    assert!(
        matches!(
            l[0].1,
            MasterEvent::NodeLost {
                node: 4,
                cause: LossCause::Heartbeat,
                ..
            }
        ),
        "{l:?}"
    );
    println!(
        "bus-off node: {} error frames, loss detected {:.1} ms after the fault",
        net.bus.stats.error_frames,
        (l[0].0 - t0) as f64 / 1e6
    );
    net.bus.set_fault(port, None);
    net.bus.recover(port);
    let t1 = net.now_ns();
    net.run_to(t1 + 300 * MS);
    let ev = net.master.events_since(from);
    assert!(
        ev.contains(&MasterEvent::NodeReturned { slot: 2, node: 4 }),
        "{ev:?}"
    );
    assert!(!booted(&ev).contains(&4), "no new boot: {ev:?}");
    assert_eq!(net.master.master.operational(), 3);
}

/// The bus time of a frame that ended at `end` (its start).
fn start_of(net: &CanNetwork, end: u64, f: &coe_core::canopen::CanFrame) -> u64 {
    end - net.bus.frame_ns(f)
}

/// Seed 002: 10 nodes x 16 bytes in (two TPDOs each) and 8 bytes out (one RPDO) at
/// 1 Mbit/s, one SYNC per 5 ms cycle. The full refresh is the time from the SYNC's start
/// to the end of the cycle's last PDO on the bus: every input is new in the master and
/// every output is in its node by then. The seed polled and needed 40 ms.
#[test]
fn seed_002_ten_nodes_refresh_within_5_ms_at_1_mbit() {
    const CYCLES: u64 = 1_000;
    const CYCLE_NS: u64 = 5 * MS;
    let nodes: Vec<NodeConfig> = (1..=10).map(io_node).collect();
    let ids: Vec<u8> = (1..=10).collect();
    let cfg = MasterConfig {
        sync_multiplier: 1,
        ..MasterConfig::default()
    };
    let mut net = network(1_000_000, cfg, &nodes, &ids);
    net.master.master.start(0);
    net.run_to(1_000 * MS);
    assert_eq!(net.master.master.operational(), 10);
    let boot_end = net.master.events.iter().map(|(t, _)| *t).max().unwrap();
    let log_from = net.bus.log.len();
    let events_from = net.master.events.len();
    let t_start = net.now_ns();
    let first_cycle = t_start / CYCLE_NS + 1;
    let mut checked = 0u64;
    net.run(t_start + CYCLES * CYCLE_NS, CYCLE_NS, &mut |net, k| {
        // The previous cycle's data arrived whole: inputs of cycle k-1 in the master.
        if k > first_cycle + 1 {
            let want = (k - 1) as u8;
            for slot in 0..10 {
                assert_eq!(net.master.master.input(slot, 0).unwrap()[0], want);
                assert_eq!(net.master.master.input(slot, 1).unwrap()[7], want);
            }
            for s in &net.slaves {
                assert_eq!(
                    s.dev.outputs[0],
                    (k - 2) as u8,
                    "outputs of cycle k-2 applied"
                );
            }
            checked += 1;
        }
        for s in net.slaves.iter_mut() {
            s.dev.inputs = [k as u8; 16];
        }
        for slot in 0..10 {
            net.master
                .master
                .set_output(slot, 0, &[k as u8; 8])
                .unwrap();
        }
        assert!(net.master.master.cycle_event(net.now_ns() / 1000));
    });
    assert!(checked >= CYCLES - 3);
    // Per cycle: SYNC start -> end of the last PDO.
    let log = &net.bus.log[log_from..];
    let mut refresh: Vec<u64> = Vec::new();
    let mut sync_start = None;
    let mut last_end = 0;
    let mut frames_per_cycle = Vec::new();
    let mut n = 0;
    for (end, _, f) in log {
        if f.id() == 0x080 {
            if let Some(s) = sync_start {
                refresh.push(last_end - s);
                frames_per_cycle.push(n);
            }
            sync_start = Some(start_of(&net, *end, f));
            n = 1;
        } else if (0x181..0x300).contains(&f.id()) {
            last_end = *end;
            n += 1;
        }
    }
    let mean = refresh.iter().sum::<u64>() as f64 / refresh.len() as f64 / 1e3;
    let max = *refresh.iter().max().unwrap() as f64 / 1e3;
    let load = net.bus.load(t_start, net.now_ns());
    println!(
        "seed 002: 10 nodes x 16 B in + 8 B out at 1 Mbit/s, {} frames per cycle: full refresh \
         mean {mean:.0} us, max {max:.0} us over {} cycles (seed: 40 ms polled); bus load {:.0} % \
         at a 5 ms cycle; boot of the 10 nodes {:.0} ms",
        frames_per_cycle[0],
        refresh.len(),
        load * 100.0,
        boot_end as f64 / 1e6
    );
    assert!(
        frames_per_cycle.iter().all(|n| *n == 31),
        "SYNC + 20 TPDOs + 10 RPDOs"
    );
    assert!(max <= 5_000.0, "full refresh {max} us");
    let problems: Vec<MasterEvent> = net.master.events_since(events_from);
    assert_eq!(problems, [], "no PDO missing, no node lost");
}

/// Seed 001: 4 servo axes with CiA 402-style PDOs on a 2 ms SYNC made from a 1 ms external
/// cycle (multiplier 2), 10 000 cycles at 1 Mbit/s: every setpoint reaches its axis.
#[test]
fn seed_001_four_axes_on_a_2_ms_sync_miss_no_setpoint() {
    const SYNCS: u64 = 10_000;
    const EVENT_NS: u64 = MS;
    let nodes: Vec<NodeConfig> = (1..=4).map(axis).collect();
    let cfg = MasterConfig {
        sync_multiplier: 2,
        ..MasterConfig::default()
    };
    let mut net = network(1_000_000, cfg, &nodes, &[1, 2, 3, 4]);
    net.master.master.start(0);
    net.run_to(1_000 * MS);
    assert_eq!(net.master.master.operational(), 4);
    // Enable the axes: shutdown, switch on, enable operation (one SYNC each, and one more).
    let t = net.now_ns();
    let mut sync_events: Vec<u64> = Vec::new();
    let mut step = 0u32;
    net.run(t + 20 * MS, EVENT_NS, &mut |net, k| {
        let cw: u16 = match step / 4 {
            0 => 0x06,
            1 => 0x07,
            _ => 0x0F,
        };
        step += 1;
        for slot in 0..4 {
            let mut d = [0u8; 6];
            d[..2].copy_from_slice(&cw.to_le_bytes());
            net.master.master.set_output(slot, 0, &d).unwrap();
        }
        let _ = k;
        net.master.master.cycle_event(net.now_ns() / 1000);
    });
    for s in &net.slaves {
        assert_eq!(s.dev.statusword, 0x0027, "operation enabled");
    }
    let log_from = net.bus.log.len();
    let events_from = net.master.events.len();
    let t_start = net.now_ns();
    let mut target = 0i32;
    let mut lag_errors = 0u64;
    net.run(t_start + 2 * SYNCS * EVENT_NS, EVENT_NS, &mut |net, _| {
        // The interpolator's next setpoint, then the EtherCAT cycle event.
        let next = target + 1;
        for slot in 0..4 {
            let mut d = [0u8; 6];
            d[..2].copy_from_slice(&0x0Fu16.to_le_bytes());
            d[2..].copy_from_slice(&(next * 100 + slot as i32).to_le_bytes());
            net.master.master.set_output(slot, 0, &d).unwrap();
        }
        if net.master.master.cycle_event(net.now_ns() / 1000) {
            target = next;
            sync_events.push(net.now_ns());
            // The position reported after the last SYNC is the setpoint of two cycles ago.
            for slot in 0..4usize {
                if let Some(i) = net.master.master.input(slot, 0) {
                    let pos = i32::from_le_bytes(i[2..6].try_into().unwrap());
                    if target > 3 && pos != (target - 2) * 100 + slot as i32 {
                        lag_errors += 1;
                    }
                }
            }
        }
    });
    assert_eq!(sync_events.len() as u64, SYNCS);
    // The last SYNC's frames reach the axes.
    let t = net.now_ns();
    net.run_to(t + EVENT_NS);
    // Every axis applied every setpoint, in order, once.
    let mut missed = 0;
    for (slot, s) in net.slaves.iter().enumerate() {
        let got: Vec<i32> = s
            .dev
            .setpoints
            .iter()
            .filter(|v| **v >= 100)
            .copied()
            .collect();
        let want: Vec<i32> = (1..SYNCS as i32).map(|k| k * 100 + slot as i32).collect();
        let gaps: Vec<&i32> = want.iter().filter(|w| !got.contains(w)).collect();
        missed += gaps.len();
        assert!(
            got == want,
            "axis {}: {} setpoints applied of {}, missing {:?}",
            slot + 1,
            got.len(),
            want.len(),
            &gaps[..gaps.len().min(5)]
        );
    }
    // SYNC jitter against the cycle event, and the cycle's bus time.
    let log = &net.bus.log[log_from..];
    let syncs: Vec<u64> = log
        .iter()
        .filter(|(_, _, f)| f.id() == 0x080)
        .map(|(end, _, f)| start_of(&net, *end, f))
        .filter(|t| *t > t_start)
        .collect();
    assert_eq!(syncs.len(), sync_events.len());
    let jitter: Vec<u64> = syncs
        .iter()
        .zip(sync_events.iter())
        .map(|(s, e)| s - e)
        .collect();
    let mut busy = Vec::new();
    let mut last = (0u64, 0u64);
    for (end, _, f) in log {
        if f.id() == 0x080 {
            if last.0 != 0 {
                busy.push(last.1 - last.0);
            }
            last = (start_of(&net, *end, f), *end);
        } else if (0x181..0x280).contains(&f.id()) {
            last.1 = *end;
        }
    }
    let load = net.bus.load(t_start, net.now_ns());
    println!(
        "seed 001: 4 axes, SYNC every 2 ms (1 ms cycle event x 2) at 1 Mbit/s, {SYNCS} cycles: \
         {missed} missed setpoints; SYNC start after the cycle event max {} us; SYNC -> last \
         PDO max {:.0} us; bus load {:.0} %",
        jitter.iter().max().unwrap() / 1000,
        *busy.iter().max().unwrap() as f64 / 1e3,
        load * 100.0
    );
    assert_eq!(missed, 0);
    assert_eq!(lag_errors, 0, "positions follow two cycles behind");
    assert_eq!(net.master.events_since(events_from), []);
}
