//! Host tests of the gateway's logic: the dictionary and the device description (ESI, SII),
//! the 0x8000 family and 0xF800 in the master's places, the PDO assignment and the images,
//! the diagnosis history's bytes, and the ESM coupling. The gateway against CANopen nodes
//! on the bus model is `tests/tests/system_gateway.rs`.

use super::application::Gateway;
use super::device::DEVICE;
use super::diagnosis::{DiagEvent, DiagHistory, DiagMessage, NodeState};
use super::od::*;
use super::process_image::{self, default_assignments};
use coe_core::canopen::master::boot::BootError;
use coe_core::canopen::master::events::LossCause;
use coe_core::od::{ObjectAccess, Value};
use coe_core::pdo::PdoDirection;
use coe_core::{AlState, AlStatusCode, SdoAbortCode};
use std::string::String;
use std::vec::Vec;

fn read(g: &mut Gateway, index: u16, sub: u8) -> Vec<u8> {
    let mut buf = [0u8; 128];
    let n = g.read(index, sub, &mut buf).expect("readable");
    buf[..n].to_vec()
}

fn read_u32(g: &mut Gateway, index: u16, sub: u8) -> u32 {
    let b = read(g, index, sub);
    let mut w = [0u8; 4];
    w[..b.len().min(4)].copy_from_slice(&b[..b.len().min(4)]);
    u32::from_le_bytes(w)
}

fn write(g: &mut Gateway, index: u16, sub: u8, data: &[u8]) -> Result<(), SdoAbortCode> {
    g.write(index, sub, data, AlState::PreOp)
}

#[test]
fn the_description_validates_and_gives_esi_and_sii() {
    assert_eq!(DEVICE.validate(), Ok(()));
    let mut xml = String::new();
    coe_core::esi::write_esi(&DEVICE, &mut xml).expect("ESI");
    assert!(xml.contains("CANGW-8"));
    assert!(xml.contains("#x8010"), "node 2's configuration object");
    let mut sii = [0u8; 2048];
    let n = coe_core::sii::generate(&DEVICE, &mut sii).expect("SII");
    assert!(n > 64);
    // Against the ETG.2000 schema where the schema and xmllint are at hand (as `cargo
    // xtask esi` does it; CI has both).
    let schema = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/vectors/esi-schema/EtherCATInfo.xsd"
    );
    let have_xmllint = std::process::Command::new("xmllint")
        .arg("--version")
        .output()
        .is_ok();
    if std::path::Path::new(schema).exists() && have_xmllint {
        let path = std::env::temp_dir().join(std::format!("cangw-{}.xml", std::process::id()));
        std::fs::write(&path, &xml).expect("temp file");
        let out = std::process::Command::new("xmllint")
            .args(["--noout", "--schema", schema])
            .arg(&path)
            .output()
            .expect("xmllint runs");
        let _ = std::fs::remove_file(&path);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn modules_sit_at_their_distance() {
    assert_eq!(module_of(0x6000), Some((0, INPUTS_BASE)));
    assert_eq!(module_of(0x6070), Some((7, INPUTS_BASE)));
    assert_eq!(module_of(0x8012), Some((1, RPDO_MAP_BASE)));
    assert_eq!(module_of(0xA030), Some((3, DIAG_BASE)));
    assert_eq!(module_of(0x6080), None, "a ninth place");
    assert_eq!(module_of(0x8003), None, "no start-up SDO object");
    assert_eq!(module_of(0x1600), None);
    for n in 0..MAX_NODES as u16 {
        for base in [
            INPUTS_BASE,
            OUTPUTS_BASE,
            CONFIG_BASE,
            TPDO_MAP_BASE,
            RPDO_MAP_BASE,
            DIAG_BASE,
        ] {
            assert!(OD.find(base + 16 * n).is_some(), "{:#06x}", base + 16 * n);
        }
    }
    let mut g = Gateway::new();
    assert_eq!(read_u32(&mut g, MDP_INDEX, 1), 0x10);
    assert_eq!(read_u32(&mut g, MDP_INDEX, 2), MAX_NODES as u32);
    assert_eq!(read_u32(&mut g, 0x1000, 0), DEVICE_TYPE);
}

#[test]
fn the_default_image_is_every_node_and_the_status() {
    let rx: Vec<u32> = DEVICE.assigned_pdos(PdoDirection::Rx).collect();
    let tx: Vec<u32> = DEVICE.assigned_pdos(PdoDirection::Tx).collect();
    assert_eq!(rx, (0..8).map(|n| 0x1600 + n).collect::<Vec<_>>());
    assert_eq!(tx[0], 0x1A80);
    assert_eq!(tx[1..], (0..8).map(|n| 0x1A00 + n).collect::<Vec<_>>());
    let (rx, tx) = default_assignments();
    assert_eq!(rx.image_len(), 128);
    assert_eq!(tx.image_len(), 132);
    // The fixed mappings: node 2's TxPDO maps 0x6020:01..04, 32 bits each.
    let mut g = Gateway::new();
    assert_eq!(read_u32(&mut g, 0x1A02, 0), 4);
    assert_eq!(read_u32(&mut g, 0x1A02, 1), 0x6020_0120);
    assert_eq!(read_u32(&mut g, 0x1A02, 4), 0x6020_0420);
    assert_eq!(read_u32(&mut g, 0x1605, 2), 0x7050_0220);
    assert_eq!(read_u32(&mut g, STATUS_TXPDO, 1), 0xF100_0110);
}

#[test]
fn the_assignment_is_written_as_etg1020_has_it() {
    let mut g = Gateway::new();
    assert_eq!(
        write(&mut g, 0x1C13, 1, &0x1A80u16.to_le_bytes()),
        Err(SdoAbortCode::DeviceState)
    );
    write(&mut g, 0x1C13, 0, &[0]).unwrap();
    write(&mut g, 0x1C13, 1, &0x1A80u16.to_le_bytes()).unwrap();
    write(&mut g, 0x1C13, 2, &0x1A03u16.to_le_bytes()).unwrap();
    assert_eq!(
        write(&mut g, 0x1C13, 3, &0x1A08u16.to_le_bytes()),
        Err(SdoAbortCode::ValueRangeExceeded),
        "no ninth node"
    );
    assert_eq!(
        write(&mut g, 0x1C13, 3, &0x1603u16.to_le_bytes()),
        Err(SdoAbortCode::ValueRangeExceeded),
        "an RxPDO"
    );
    write(&mut g, 0x1C13, 3, &0x1A03u16.to_le_bytes()).unwrap();
    assert_eq!(
        write(&mut g, 0x1C13, 0, &[3]),
        Err(SdoAbortCode::ParameterIncompatible),
        "twice"
    );
    write(&mut g, 0x1C13, 0, &[2]).unwrap();
    assert_eq!(read(&mut g, 0x1C13, 0), [2]);
    write(&mut g, 0x1C12, 0, &[0]).unwrap();
    use coe_core::device::{SmRole, SyncManagerDesc};
    use et1100::SyncManager;
    let sm = |start: u16, len: u16, control: u8| SyncManager {
        start,
        length: len,
        control,
        status: 0,
        activate: 1,
        pdi_control: 0,
    };
    let e2 = SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, 128, 0x64);
    let e3 = SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1400, 132, 0x20);
    let (mut rx, mut tx) = default_assignments();
    rx.write(0, &[0]).unwrap();
    tx.write(0, &[0]).unwrap();
    tx.write(1, &0x1A80u16.to_le_bytes()).unwrap();
    tx.write(2, &0x1A03u16.to_le_bytes()).unwrap();
    tx.write(0, &[2]).unwrap();
    // Status 4 B + node 3's 16 B in; no outputs: SM2 off.
    assert_eq!(
        process_image::check(
            &rx,
            &tx,
            &sm(0x1100, 0, 0x64),
            &sm(0x1400, 20, 0x20),
            &e2,
            &e3
        ),
        Ok(())
    );
    assert_eq!(
        process_image::check(
            &rx,
            &tx,
            &sm(0x1100, 0, 0x64),
            &sm(0x1400, 132, 0x20),
            &e2,
            &e3
        ),
        Err(AlStatusCode::InvalidInputConfiguration)
    );
}

/// A node configured over SDO the way a master does it in PREOP, read back, and what the
/// CANopen master gets from it.
#[test]
fn a_node_is_configured_in_the_0x8000_family() {
    let mut g = Gateway::new();
    let cfg = CONFIG_BASE + 0x20; // place 2
    write(&mut g, cfg, config_sub::NODE_ID, &[5]).unwrap();
    write(&mut g, cfg, config_sub::VENDOR_ID, &0xABCDu32.to_le_bytes()).unwrap();
    write(
        &mut g,
        cfg,
        config_sub::FLAGS,
        &FLAG_MANDATORY.to_le_bytes(),
    )
    .unwrap();
    assert_eq!(
        write(&mut g, cfg, config_sub::FLAGS, &0x80u16.to_le_bytes()),
        Err(SdoAbortCode::ValueRangeExceeded)
    );
    write(
        &mut g,
        cfg,
        config_sub::HEARTBEAT_CONSUMER,
        &100u16.to_le_bytes(),
    )
    .unwrap();
    write(
        &mut g,
        cfg,
        config_sub::HEARTBEAT_PRODUCER,
        &40u16.to_le_bytes(),
    )
    .unwrap();
    // TPDO 1 on the node's default COB-ID, TPDO 2 not used; RPDO 1 on an own COB-ID.
    write(&mut g, cfg, config_sub::TPDO1_COB_ID, &0u32.to_le_bytes()).unwrap();
    write(
        &mut g,
        cfg,
        config_sub::RPDO1_COB_ID,
        &0x305u32.to_le_bytes(),
    )
    .unwrap();
    write(&mut g, cfg, config_sub::RPDO1_TYPE, &[1]).unwrap();
    assert_eq!(
        write(&mut g, cfg, config_sub::RPDO1_TYPE, &[250]),
        Err(SdoAbortCode::ValueRangeExceeded)
    );
    let tmap = TPDO_MAP_BASE + 0x20;
    write(&mut g, tmap, 1, &0x2000_0108u32.to_le_bytes()).unwrap();
    write(&mut g, tmap, 2, &0x2000_0208u32.to_le_bytes()).unwrap();
    assert_eq!(
        write(&mut g, tmap, 4, &0x2000_0408u32.to_le_bytes()),
        Err(SdoAbortCode::ValueRangeExceeded),
        "a gap"
    );
    assert_eq!(
        write(&mut g, tmap, 3, &0x2000_0340u32.to_le_bytes()),
        Err(SdoAbortCode::PdoLengthExceeded)
    );
    let rmap = RPDO_MAP_BASE + 0x20;
    write(&mut g, rmap, 1, &0x2100_0120u32.to_le_bytes()).unwrap();
    // Read back.
    assert_eq!(read(&mut g, cfg, config_sub::NODE_ID), [5]);
    assert_eq!(read_u32(&mut g, cfg, config_sub::FLAGS), 1);
    assert_eq!(
        read_u32(&mut g, cfg, config_sub::TPDO2_COB_ID),
        COB_ID_NOT_VALID
    );
    assert_eq!(read_u32(&mut g, tmap, 2), 0x2000_0208);
    assert_eq!(read_u32(&mut g, tmap, 3), 0);
    assert_eq!(
        read_u32(&mut g, CONFIGURED_MODULES_INDEX, 3),
        0,
        "no product code set"
    );
    // What the master boots.
    let mut place = *g.master.node_config(2).unwrap();
    super::network::prepare_place(&mut place);
    let t = place.tpdo[0].unwrap();
    assert_eq!((t.number, t.cob_id, t.len()), (1, 0x185, 2));
    let r = place.rpdo[0].unwrap();
    assert_eq!((r.number, r.cob_id, r.transmission_type), (1, 0x305, 1));
    assert!(place.tpdo[1].is_none() && place.rpdo[1].is_none());
    assert_eq!(place.check(0x80), Ok(()));
    assert!(place.mandatory && place.uses_heartbeat());
    // 0xF800.
    write(&mut g, MASTER_INDEX, master_sub::SYNC_MULTIPLIER, &[2]).unwrap();
    write(
        &mut g,
        MASTER_INDEX,
        master_sub::POLICIES,
        &POLICY_LOST_MANDATORY_AL_ERROR.to_le_bytes(),
    )
    .unwrap();
    assert_eq!(
        read_u32(&mut g, MASTER_INDEX, master_sub::SYNC_MULTIPLIER),
        2
    );
    assert_eq!(read_u32(&mut g, MASTER_INDEX, master_sub::POLICIES), 2);
    assert_eq!(read_u32(&mut g, MASTER_INDEX, master_sub::BIT_RATE), 1000);
    assert_eq!(
        write(
            &mut g,
            MASTER_INDEX,
            master_sub::SYNC_COB_ID,
            &0x800u32.to_le_bytes()
        ),
        Err(SdoAbortCode::ValueRangeExceeded)
    );
}

#[test]
fn diagnosis_messages_have_the_etg1020_layout() {
    let m = DiagMessage {
        event: DiagEvent::Lost(LossCause::Heartbeat),
        node: 5,
        time_ns: 0x0102_0304_0506_0708,
    };
    let mut buf = [0u8; DIAG_MESSAGE_BYTES];
    let n = m.render(&mut buf).unwrap();
    let text = DiagEvent::Lost(LossCause::Heartbeat).text().as_bytes();
    let mut want = Vec::new();
    want.extend_from_slice(&0x0000_E800u32.to_le_bytes()); // Diag Code
    want.extend_from_slice(&[0x02, 0x02]); // error, two parameters
    want.extend_from_slice(&0x4001u16.to_le_bytes()); // Text ID
    want.extend_from_slice(&0x0102_0304_0506_0708u64.to_le_bytes());
    want.extend_from_slice(&[0x05, 0x00, 5]); // UNSIGNED8 node-ID
    want.extend_from_slice(&(0x2000u16 | text.len() as u16).to_le_bytes());
    want.extend_from_slice(text);
    assert_eq!(&buf[..n], &want[..]);
    assert!(n <= DIAG_MESSAGE_BYTES);
    // Every message fits its entry.
    for e in [
        DiagEvent::Booted,
        DiagEvent::BootError(BootError::InitiallyOperational),
        DiagEvent::BootError(BootError::SerialNumberMismatch),
        DiagEvent::Lost(LossCause::State(coe_core::canopen::NmtState::Stopped)),
        DiagEvent::TpdoTimeout,
    ] {
        let m = DiagMessage {
            event: e,
            node: 1,
            time_ns: 0,
        };
        assert!(m.render(&mut buf).is_ok(), "{e:?}");
    }
    assert_eq!(
        DiagEvent::BootError(BootError::NoDeviceType).text_id(),
        0x4142
    );
}

#[test]
fn the_history_overwrites_and_is_acknowledged() {
    let mut h = DiagHistory::new();
    let mut buf = [0u8; 64];
    assert_eq!(h.newest(), 0);
    assert_eq!(h.read(4, &mut buf), Ok(1));
    assert_eq!(buf[0], 0);
    assert_eq!(h.read(6, &mut buf), Ok(0), "an empty slot");
    assert_eq!(
        h.read(6 + DIAG_MESSAGES as u8, &mut buf),
        Err(SdoAbortCode::SubindexDoesNotExist)
    );
    for i in 0..(DIAG_MESSAGES as u8 + 2) {
        h.push(DiagMessage {
            event: DiagEvent::Booted,
            node: i + 1,
            time_ns: u64::from(i),
        });
    }
    // Ten messages in eight slots: the newest (node 10) in slot 2 (sub 7).
    assert_eq!(h.newest(), 7);
    assert_eq!(h.message(7).map(|m| m.node), Some(10));
    assert_eq!(
        h.iter().map(|m| m.node).collect::<Vec<_>>(),
        (3..=10).collect::<Vec<_>>()
    );
    assert!(h.new_available());
    assert_eq!(h.write(3, &[30]), Err(SdoAbortCode::ValueRangeExceeded));
    h.write(3, &[7]).unwrap();
    assert!(!h.new_available());
    h.push(DiagMessage {
        event: DiagEvent::Returned,
        node: 3,
        time_ns: 11,
    });
    assert!(h.new_available());
    assert_eq!(h.write(1, &[1]), Err(SdoAbortCode::WriteOfReadOnly));
}

#[test]
fn node_states_follow_the_el6751_codes() {
    use coe_core::canopen::master::NodePhase;
    assert_eq!(NodeState::of(NodePhase::Operational, false).code(), 0);
    assert_eq!(NodeState::of(NodePhase::Unused, false).code(), 1);
    assert_eq!(
        NodeState::of(NodePhase::Failed(BootError::NoDeviceType, None), false).code(),
        2
    );
    assert_eq!(
        NodeState::of(
            NodePhase::Failed(BootError::ProductCodeMismatch, None),
            false
        ),
        NodeState::WrongIdentity
    );
    assert_eq!(
        NodeState::of(
            NodePhase::Failed(BootError::ConfigurationFailed, None),
            false
        )
        .code(),
        5
    );
    assert_eq!(NodeState::of(NodePhase::Configuring, false).code(), 8);
    assert_eq!(NodeState::of(NodePhase::Operational, true).code(), 22);
}

/// OP waits for the mandatory nodes; without one configured it is allowed at once.
#[test]
fn op_needs_every_mandatory_node() {
    use crate::stacks::ethercat::Application;
    let mut g = Gateway::new();
    assert_eq!(
        g.check_op(),
        Err(AlStatusCode::NoValidInputs),
        "master not started"
    );
    g.master.start(0);
    assert_eq!(g.check_op(), Ok(()), "no mandatory node");
    g.master.stop();
    write(&mut g, CONFIG_BASE, config_sub::NODE_ID, &[9]).unwrap();
    write(
        &mut g,
        CONFIG_BASE,
        config_sub::FLAGS,
        &FLAG_MANDATORY.to_le_bytes(),
    )
    .unwrap();
    g.master.start(0);
    assert_eq!(g.check_op(), Err(AlStatusCode::NoValidInputs));
    assert_eq!(g.op_fault(), None, "the policy is off");
    assert_eq!(
        read(&mut g, DIAG_BASE, diag_sub::STATE),
        [NodeState::Booting.code()]
    );
    assert_eq!(
        g.write(CONFIG_BASE, config_sub::NODE_ID, &[3], AlState::PreOp),
        Err(SdoAbortCode::DeviceState),
        "the master runs"
    );
    let _ = Value::Uint(0);
}

/// Any bytes to any entry in any state, and reads of every entry: an answer or an abort,
/// never a panic; the master's places stay what its check accepts or the start leaves
/// them unused.
#[test]
fn any_write_to_any_entry_is_answered() {
    use crate::stacks::ethercat::Application;
    let patterns: [&[u8]; 7] = [
        &[],
        &[0],
        &[0xFF],
        &[1, 0],
        &[0xFF, 0xFF],
        &[0x05, 0x01, 0x00, 0x60],
        &[0xFF; 9],
    ];
    for state in [AlState::PreOp, AlState::SafeOp, AlState::Op] {
        let mut g = Gateway::new();
        let mut buf = [0u8; 128];
        for object in OD.iter() {
            for sub in 0..=object.max_subindex().saturating_add(1) {
                for p in patterns {
                    let _ = g.write(object.index, sub, p, state);
                }
                let _ = g.read(object.index, sub, &mut buf);
                let _ = g.read(object.index, sub, &mut buf[..1]);
            }
        }
        g.master.start(0);
        g.can_call(None, 1_000_000);
        let _ = g.check_op();
        let _ = g.input_image();
    }
}
