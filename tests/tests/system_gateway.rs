//! SYSTEM TEST: the `can-gateway` product's logic (`firmware::products::can_gateway`: the
//! modular dictionary, the ESM coupling, coe-core's CANopen master behind it) on the virtual
//! CAN bus with the project's own CANopen node (coe-core's `CanNode`, in process) as slaves,
//! in virtual time. The EtherCAT side is the application interface the slave application
//! calls: SDO writes of the 0x8000 family in PREOP as TwinCAT writes them for an EL6751,
//! PREOP -> SAFEOP (`prepare` with the SyncManagers of the layout), SAFEOP -> OP
//! (`check_op`), and per EtherCAT cycle the output image, `take_outputs`, the SM2 event and
//! the input image.
//!
//! Shown: boot-up of four nodes with identity check and remote PDO configuration, OP only
//! when the mandatory nodes run, data both ways through the process image; a missing
//! mandatory node (0x0018, node state 2, letter B in 0xA000 and 0x10F3) and a wrong one
//! (0x0070, letter M); a node lost in OP (Emergency 0x8130, 0x10F3 message, optional AL
//! error) and taken back; the seed 002 case through the gateway with its figures.
//!
//! The image of the gateway is not built yet (over the application slot), so neither a
//! real EtherCAT master nor the co-simulator is in this test: see docs/book/gateway.md.

use coe_core::od::ObjectAccess;
use coe_core::sdo_server::Emergency;
use coe_core::{AlState, AlStatusCode};
use et1100::SyncManager;
use firmware::products::can_gateway::application::{Gateway, EMCY_NODE_LOST};
use firmware::products::can_gateway::diagnosis::NodeState;
use firmware::products::can_gateway::layout::SYNC_MANAGERS;
use firmware::products::can_gateway::od::*;
use firmware::products::can_gateway::stage::CycleMarks;
use firmware::stacks::ethercat::Application;
use virtual_board::models::can::{CanBus, PortId};
use virtual_board::rig::can_slave::{InProcessSlave, SlaveIdentity, TX_BUFFERS};

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

/// The gateway on a port of the bus, as its CAN task serves it: every received frame into
/// a call, then calls while the master has work, its frames into three transmit buffers.
struct GatewayOnBus {
    gw: Box<Gateway>,
    port: PortId,
    stage: CycleMarks,
    emergencies: Vec<(u64, Emergency)>,
}

impl GatewayOnBus {
    fn fill(&mut self, bus: &mut CanBus) {
        while bus.pending(self.port) < TX_BUFFERS {
            let Some(f) = self.gw.master.pop_tx() else {
                break;
            };
            bus.send(self.port, f);
        }
    }

    fn service(&mut self, bus: &mut CanBus, now_ns: u64) {
        while let Some((t, f)) = bus.receive(self.port) {
            self.gw.can_call(Some(&f), t);
            self.fill(bus);
        }
        for _ in 0..64 {
            self.gw.can_call(None, now_ns);
            self.fill(bus);
            if !self.gw.work_waiting(now_ns) {
                break;
            }
        }
        while let Some(e) = self.gw.pop_emergency() {
            self.emergencies.push((now_ns, e));
        }
    }

    fn next_ns(&self, now_ns: u64) -> Option<u64> {
        self.gw
            .master
            .next_deadline_us()
            .map(|t| t * 1000)
            .filter(|t| *t > now_ns)
    }
}

struct Rig {
    bus: CanBus,
    gw: GatewayOnBus,
    slaves: Vec<InProcessSlave>,
    now_ns: u64,
}

impl Rig {
    fn new(bit_rate: u32, present: &[u8]) -> Self {
        let mut bus = CanBus::new(bit_rate);
        let port = bus.attach("can-gateway");
        let slaves = present
            .iter()
            .map(|&id| InProcessSlave::attach(&mut bus, id, identity(id)))
            .collect();
        Self {
            bus,
            gw: GatewayOnBus {
                gw: Box::new(Gateway::new()),
                port,
                stage: CycleMarks::new(),
                emergencies: Vec::new(),
            },
            slaves,
            now_ns: 0,
        }
    }

    fn g(&mut self) -> &mut Gateway {
        &mut self.gw.gw
    }

    fn slave(&mut self, id: u8) -> &mut InProcessSlave {
        self.slaves
            .iter_mut()
            .find(|s| s.node.node_id() == id)
            .expect("slave")
    }

    fn power(&mut self, id: u8, on: bool) {
        let i = self
            .slaves
            .iter()
            .position(|s| s.node.node_id() == id)
            .expect("slave");
        self.slaves[i].power(&mut self.bus, on);
    }

    fn service(&mut self) {
        for _ in 0..2 {
            self.gw.service(&mut self.bus, self.now_ns);
            for s in self.slaves.iter_mut() {
                s.service(&mut self.bus, self.now_ns);
            }
        }
    }

    /// Runs to `until_ns`; `cycle` at each multiple of `cycle_ns` (an EtherCAT cycle).
    fn run(&mut self, until_ns: u64, cycle_ns: u64, cycle: &mut dyn FnMut(&mut Rig, u64)) {
        self.service();
        while self.now_ns < until_ns {
            let now = self.now_ns;
            let next = [
                self.bus.next_event_ns(),
                self.gw.next_ns(now),
                (cycle_ns != 0).then(|| (now / cycle_ns + 1) * cycle_ns),
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

    fn run_to(&mut self, until_ns: u64) {
        self.run(until_ns, 0, &mut |_, _| {});
    }

    /// An SDO download in PREOP, as the EtherCAT master sends it.
    fn sdo(&mut self, index: u16, sub: u8, data: &[u8]) {
        self.g()
            .write(index, sub, data, AlState::PreOp)
            .unwrap_or_else(|e| panic!("{index:#06x}:{sub}: {e:?}"));
    }

    fn upload(&mut self, index: u16, sub: u8) -> Vec<u8> {
        let mut buf = [0u8; 128];
        let n = self.g().read(index, sub, &mut buf).expect("readable");
        buf[..n].to_vec()
    }

    fn upload_u32(&mut self, index: u16, sub: u8) -> u32 {
        let b = self.upload(index, sub);
        let mut w = [0u8; 4];
        w[..b.len().min(4)].copy_from_slice(&b[..b.len().min(4)]);
        u32::from_le_bytes(w)
    }

    /// Place `place`: a generic I/O node (16 bytes in on TPDO 1 + 2, 16 out on RPDO 1 + 2,
    /// each byte one mapped object), its identity, heartbeat 100 ms watched at 250 ms.
    fn configure_io(&mut self, place: u16, node: u8, mandatory: bool, product_code: u32) {
        let cfg = CONFIG_BASE + place * 16;
        let id = identity(node);
        self.sdo(cfg, config_sub::NODE_ID, &[node]);
        self.sdo(cfg, config_sub::DEVICE_TYPE, &id.device_type.to_le_bytes());
        self.sdo(cfg, config_sub::VENDOR_ID, &id.vendor_id.to_le_bytes());
        self.sdo(cfg, config_sub::PRODUCT_CODE, &product_code.to_le_bytes());
        self.sdo(cfg, config_sub::FLAGS, &u16::from(mandatory).to_le_bytes());
        self.sdo(cfg, config_sub::HEARTBEAT_CONSUMER, &250u16.to_le_bytes());
        self.sdo(cfg, config_sub::HEARTBEAT_PRODUCER, &100u16.to_le_bytes());
        for sub in [
            config_sub::TPDO1_COB_ID,
            config_sub::TPDO2_COB_ID,
            config_sub::RPDO1_COB_ID,
            config_sub::RPDO2_COB_ID,
        ] {
            self.sdo(cfg, sub, &0u32.to_le_bytes());
        }
        for s in 1..=16u8 {
            let entry = |index: u32| (index << 16 | u32::from(s) << 8 | 8).to_le_bytes();
            self.sdo(TPDO_MAP_BASE + place * 16, s, &entry(0x2000));
            self.sdo(RPDO_MAP_BASE + place * 16, s, &entry(0x2100));
        }
    }

    /// PREOP -> SAFEOP with the whole image (the default assignment).
    fn enter_safeop(&mut self) {
        let sm = |d: &coe_core::device::SyncManagerDesc| SyncManager {
            start: d.start,
            length: d.len,
            control: d.control,
            status: 0,
            activate: 1,
            pdi_control: 0,
        };
        let [_, _, e2, e3] = SYNC_MANAGERS;
        let g = self.g();
        g.prepare(&sm(&e2), &sm(&e3), &e2, &e3).expect("SAFEOP");
        g.set_running(true);
    }

    /// One EtherCAT cycle: `outputs` to place `n`'s 16 bytes, the SM2 event; the input
    /// image as SM3 gets it.
    fn ethercat_cycle(&mut self, outputs: &[(usize, [u8; 16])]) -> Vec<u8> {
        let now = self.now_ns;
        let g = &mut self.gw.gw;
        let image = g.output_image();
        for (n, data) in outputs {
            image[n * 16..n * 16 + 16].copy_from_slice(data);
        }
        g.take_outputs(&self.gw.stage);
        g.on_output_event(now);
        let inputs = g.input_image().expect("inputs").to_vec();
        self.service();
        inputs
    }

    fn node_bits(inputs: &[u8]) -> (u16, u16) {
        (
            u16::from_le_bytes([inputs[0], inputs[1]]),
            u16::from_le_bytes([inputs[2], inputs[3]]),
        )
    }

    /// The newest 0x10F3 message: (Text ID, node-ID, text).
    fn newest_message(&mut self) -> (u16, u8, String) {
        let sub = self.upload(DIAG_HISTORY_INDEX, 2)[0];
        assert!(sub >= 6, "a message");
        let m = self.upload(DIAG_HISTORY_INDEX, sub);
        let text_len = usize::from(u16::from_le_bytes([m[19], m[20]]) & 0x0FFF);
        (
            u16::from_le_bytes([m[6], m[7]]),
            m[18],
            String::from_utf8(m[21..21 + text_len].to_vec()).unwrap(),
        )
    }
}

const NODES: [u8; 4] = [2, 3, 5, 9];

fn four_nodes(present: &[u8]) -> Rig {
    let mut rig = Rig::new(500_000, present);
    for (place, node) in NODES.iter().enumerate() {
        rig.configure_io(place as u16, *node, true, identity(*node).product_code);
    }
    rig
}

#[test]
fn four_nodes_boot_and_exchange_data_both_ways_in_op() {
    let mut rig = four_nodes(&NODES);
    assert_eq!(
        rig.g().check_op(),
        Err(AlStatusCode::NoValidInputs),
        "PREOP"
    );
    rig.enter_safeop();
    // The boots run after the transition; OP waits for them.
    rig.run_to(rig.now_ns + MS);
    assert_eq!(rig.g().check_op(), Err(AlStatusCode::NoValidInputs));
    assert_eq!(
        rig.upload(DIAG_BASE, diag_sub::STATE),
        [NodeState::Booting.code()]
    );
    rig.run_to(2_000 * MS);
    assert_eq!(rig.g().master.operational(), 4);
    assert_eq!(rig.g().check_op(), Ok(()));
    for (place, node) in NODES.iter().enumerate() {
        assert_eq!(
            rig.upload(DIAG_BASE + place as u16 * 16, diag_sub::STATE),
            [0]
        );
        assert_eq!(
            rig.upload_u32(DETECTED_MODULES_INDEX, place as u8 + 1),
            identity(*node).product_code
        );
        assert_eq!(
            rig.slave(*node).state(),
            coe_core::canopen::NmtState::Operational
        );
    }
    // Each boot left a message.
    let (text_id, _, text) = rig.newest_message();
    assert_eq!(text_id, 0x1001, "{text}");
    // Data both ways: the nodes' inputs in the process image, the image's outputs at the
    // nodes, one CAN cycle (SYNC) per EtherCAT cycle.
    let mut seen = 0;
    rig.run(rig.now_ns + 200 * MS, 5 * MS, &mut |rig, k| {
        for (i, node) in NODES.iter().enumerate() {
            rig.slave(*node).dev.inputs = [k as u8 ^ i as u8; 16];
        }
        let outputs: Vec<(usize, [u8; 16])> = (0..4)
            .map(|n| (n, [(k as u8).wrapping_add(n as u8); 16]))
            .collect();
        let inputs = rig.ethercat_cycle(&outputs);
        assert_eq!(Rig::node_bits(&inputs), (0x000F, 0));
        if k % 4 == 0 {
            // The SYNC of cycle k-1 made the TPDOs that came during it; the RPDOs of cycle
            // k-2 came during it and were applied at its SYNC (synchronous PDOs).
            for i in 0..4usize {
                let data = &inputs[STATUS_BYTES + i * 16..STATUS_BYTES + i * 16 + 16];
                assert_eq!(data, [(k - 1) as u8 ^ i as u8; 16], "node place {i}");
            }
            for (i, node) in NODES.iter().enumerate() {
                assert_eq!(
                    rig.slave(*node).dev.outputs,
                    [((k - 2) as u8).wrapping_add(i as u8); 16]
                );
            }
            seen += 1;
        }
    });
    assert!(seen >= 8);
    assert!(rig.gw.emergencies.is_empty(), "{:?}", rig.gw.emergencies);
    assert_eq!(rig.upload_u32(STATUS_INDEX, status_sub::OVERRUNS), 0);
}

#[test]
fn a_missing_or_wrong_mandatory_node_keeps_the_gateway_out_of_op() {
    // Node 9 is not on the bus.
    let mut rig = four_nodes(&[2, 3, 5]);
    rig.enter_safeop();
    rig.run_to(2_000 * MS);
    assert_eq!(rig.g().master.operational(), 3);
    assert_eq!(rig.g().check_op(), Err(AlStatusCode::NoValidInputs));
    let diag = DIAG_BASE + 3 * 16;
    assert_eq!(
        rig.upload(diag, diag_sub::STATE),
        [NodeState::NotFound.code()]
    );
    assert_eq!(rig.upload(diag, diag_sub::BOOT_ERROR), [b'B']);
    assert_eq!(
        rig.upload_u32(diag, diag_sub::BOOT_ERROR_OBJECT),
        0x1000_0000
    );
    let inputs = rig.ethercat_cycle(&[]);
    assert_eq!(Rig::node_bits(&inputs), (0b0111, 0b1000));
    let messages: Vec<(u16, u8)> = (6..6 + DIAG_MESSAGES as u8)
        .filter_map(|s| {
            let m = rig.upload(DIAG_HISTORY_INDEX, s);
            (m.len() > 18).then(|| (u16::from_le_bytes([m[6], m[7]]), m[18]))
        })
        .collect();
    assert!(
        messages.contains(&(0x4142, 9)),
        "B for node 9: {messages:?}"
    );

    // Node 5 answers but is another product: M, and 0x0070.
    let mut rig = four_nodes(&NODES);
    rig.configure_io(2, 5, true, 0x0000_0999);
    rig.enter_safeop();
    rig.run_to(2_000 * MS);
    assert_eq!(
        rig.g().check_op(),
        Err(AlStatusCode::ModuleIdentListMismatch)
    );
    assert_eq!(
        rig.upload(DIAG_BASE + 2 * 16, diag_sub::STATE),
        [NodeState::WrongIdentity.code()]
    );
    assert_eq!(rig.upload(DIAG_BASE + 2 * 16, diag_sub::BOOT_ERROR), [b'M']);
    assert_eq!(rig.upload_u32(CONFIGURED_MODULES_INDEX, 3), 0x999);
    assert_eq!(rig.upload_u32(DETECTED_MODULES_INDEX, 3), 0x640);
    // An optional node may be missing: OP.
    let mut rig = four_nodes(&[2, 3, 5]);
    rig.sdo(CONFIG_BASE + 3 * 16, config_sub::FLAGS, &0u16.to_le_bytes());
    rig.enter_safeop();
    rig.run_to(2_000 * MS);
    assert_eq!(rig.g().check_op(), Ok(()));
}

#[test]
fn a_node_lost_in_op_is_reported_and_taken_back() {
    let mut rig = four_nodes(&NODES);
    rig.sdo(
        MASTER_INDEX,
        master_sub::POLICIES,
        &POLICY_LOST_MANDATORY_AL_ERROR.to_le_bytes(),
    );
    rig.enter_safeop();
    rig.run_to(2_000 * MS);
    assert_eq!(rig.g().check_op(), Ok(()));
    assert_eq!(rig.g().op_fault(), None);
    let lost_at = rig.now_ns;
    rig.power(5, false);
    let mut lost_seen = None;
    rig.run(lost_at + 600 * MS, 5 * MS, &mut |rig, _| {
        let inputs = rig.ethercat_cycle(&[]);
        if lost_seen.is_none() && Rig::node_bits(&inputs).1 != 0 {
            lost_seen = Some(rig.now_ns);
        }
    });
    let detect = lost_seen.expect("the status shows the loss") - lost_at;
    // The Emergency on the EtherCAT mailbox, the diagnosis, the AL error.
    let (t, e) = rig.gw.emergencies[0];
    assert_eq!(e.error_code, EMCY_NODE_LOST);
    assert_eq!(e.data[..2], [5, 2], "node-ID, place");
    assert_eq!(e.error_register & 0x10, 0x10, "communication error");
    assert_eq!(rig.upload(0x1001, 0)[0] & 0x10, 0x10);
    let (text_id, node, text) = rig.newest_message();
    assert_eq!((text_id, node), (0x4001, 5));
    assert_eq!(text, "CAN node lost: no heartbeat");
    assert_eq!(
        rig.upload(DIAG_BASE + 2 * 16, diag_sub::STATE),
        [NodeState::Lost.code()]
    );
    assert_eq!(rig.upload_u32(DIAG_BASE + 2 * 16, diag_sub::LOST_COUNT), 1);
    assert_eq!(rig.g().op_fault(), Some(AlStatusCode::NoValidInputs));
    println!(
        "node lost (heartbeat 100 ms, consumer 250 ms): Emergency {:.0} ms, status bit {:.0} ms after the power went",
        (t - lost_at) as f64 / 1e6,
        detect as f64 / 1e6
    );
    assert!(t - lost_at <= 260 * MS && detect <= 262 * MS);
    // Back: the master boots it again and starts it; the error clears.
    rig.power(5, true);
    rig.run(rig.now_ns + 1_000 * MS, 5 * MS, &mut |rig, _| {
        rig.ethercat_cycle(&[]);
    });
    assert_eq!(rig.upload(DIAG_BASE + 2 * 16, diag_sub::STATE), [0]);
    assert_eq!(rig.g().check_op(), Ok(()));
    assert_eq!(rig.g().op_fault(), None);
    assert_eq!(rig.upload(0x1001, 0), [0]);
    let last = rig.gw.emergencies.last().unwrap().1;
    assert_eq!(last.error_code, 0, "error reset");
    let (text_id, node, _) = rig.newest_message();
    assert_eq!((text_id, node), (0x1002, 5), "returned");
    // And its data flow again.
    rig.slave(5).dev.inputs = [0x5A; 16];
    rig.run(rig.now_ns + 20 * MS, 5 * MS, &mut |rig, _| {
        rig.ethercat_cycle(&[]);
    });
    let inputs = rig.ethercat_cycle(&[]);
    assert_eq!(inputs[STATUS_BYTES + 32..STATUS_BYTES + 48], [0x5A; 16]);
}

/// Seed 002 through the gateway: every place (8 nodes) with 16 bytes in and 16 out at
/// 1 Mbit/s, one SYNC per EtherCAT cycle of 5 ms. Figures: the full refresh (SYNC start to
/// the end of the cycle's last PDO), CAN -> EtherCAT latency (a TPDO's end on the bus to
/// the EtherCAT cycle whose inputs carry it), EtherCAT -> CAN latency (the SM2 event to the
/// end of the node's RPDOs), bus load.
#[test]
fn seed_002_eight_nodes_through_the_gateway() {
    const CYCLE_NS: u64 = 5 * MS;
    let ids: Vec<u8> = (1..=8).collect();
    let mut rig = Rig::new(1_000_000, &ids);
    for (place, node) in ids.iter().enumerate() {
        rig.configure_io(place as u16, *node, true, identity(*node).product_code);
    }
    rig.enter_safeop();
    rig.run_to(2_000 * MS);
    assert_eq!(rig.g().check_op(), Ok(()));
    let log_from = rig.bus.log.len();
    let t0 = rig.now_ns;
    let mut cycles: Vec<(u64, u64)> = Vec::new(); // (cycle time, value written)
    let mut seen_in: Vec<(u64, u8)> = Vec::new(); // (cycle time, value first seen)
    rig.run(t0 + 1_000 * CYCLE_NS, CYCLE_NS, &mut |rig, k| {
        for s in rig.slaves.iter_mut() {
            s.dev.inputs = [k as u8; 16];
        }
        let outputs: Vec<(usize, [u8; 16])> = (0..8).map(|n| (n, [k as u8; 16])).collect();
        let now = rig.now_ns;
        let inputs = rig.ethercat_cycle(&outputs);
        cycles.push((now, k));
        let v = inputs[STATUS_BYTES];
        if seen_in.last().is_none_or(|(_, last)| *last != v) {
            seen_in.push((now, v));
        }
    });
    // The bus log: per cycle the SYNC start, the last PDO's end; each TPDO's end.
    let log = &rig.bus.log[log_from..];
    let mut refresh = Vec::new();
    let mut sync_start: Option<u64> = None;
    let mut last_end = 0;
    let mut tpdo_end_of_value: Vec<(u8, u64)> = Vec::new();
    let mut rpdo_latency = Vec::new();
    for (end, _, f) in log {
        let id = f.id();
        if id == 0x080 {
            if let Some(s) = sync_start {
                refresh.push(last_end - s);
            }
            sync_start = Some(end - rig.bus.frame_ns(f));
        } else if (0x181..0x400).contains(&id) {
            last_end = *end;
            if (0x281..0x289).contains(&id) && id == 0x288 {
                // The last node's TPDO 2: the end of the cycle's inputs.
                tpdo_end_of_value.push((f.data()[0], *end));
            }
            if id == 0x308 {
                // The last node's RPDO 2: the cycle's outputs are out; from the SM2 event
                // of the cycle whose value it carries.
                let v = f.data()[0];
                let before = |(t, k): &&(u64, u64)| *t <= *end && *k as u8 == v;
                if let Some((t, _)) = cycles.iter().rev().find(before) {
                    rpdo_latency.push(end - t);
                }
            }
        }
    }
    // CAN -> EtherCAT: from the end of the TPDO that completes a value to the first cycle
    // whose inputs carry it.
    let mut latency = Vec::new();
    for (v, end) in &tpdo_end_of_value {
        if let Some((t, _)) = seen_in.iter().find(|(t, seen)| seen == v && t >= end) {
            latency.push(t - end);
        }
    }
    let stats = |v: &[u64]| {
        let mean = v.iter().sum::<u64>() as f64 / v.len() as f64 / 1e3;
        let max = *v.iter().max().unwrap() as f64 / 1e3;
        (mean, max)
    };
    let (r_mean, r_max) = stats(&refresh);
    let (l_mean, l_max) = stats(&latency);
    let (o_mean, o_max) = stats(&rpdo_latency);
    let load = rig.bus.load(t0, rig.now_ns);
    println!(
        "seed 002 through the gateway: 8 nodes x 16 B in + 16 B out at 1 Mbit/s, EtherCAT cycle 5 ms: \
         full refresh mean {r_mean:.0} us, max {r_max:.0} us over {} cycles; CAN -> EtherCAT \
         mean {l_mean:.0} us, max {l_max:.0} us ({} values); EtherCAT -> CAN (SM2 event to the \
         last RPDO's end) mean {o_mean:.0} us, max {o_max:.0} us; bus load {:.0} %",
        refresh.len(),
        latency.len(),
        load * 100.0
    );
    assert!(refresh.len() >= 990 && latency.len() >= 990);
    assert!(r_max <= 5_000.0, "full refresh {r_max} us");
    // Within one EtherCAT cycle of its arrival (the CAN cycle runs inside the EtherCAT
    // cycle): at most two cycles.
    assert!(l_max <= 5_000.0, "CAN -> EtherCAT {l_max} us");
    assert!(rig.gw.emergencies.is_empty());
    assert_eq!(rig.upload_u32(DIAG_BASE, diag_sub::TPDO_MISSED), 0);
}
