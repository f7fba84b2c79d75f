//! SYSTEM TEST: both fieldbuses at once, in process on virtual time. ethercrab runs the
//! module in OP (EtherCAT drives the outputs, the default source) while a CANopen master
//! on the board's CAN bus ([`virtual_board::rig::can_master::CanMaster`]) reads the same
//! dictionary over SDO, receives the inputs in SYNC-driven TPDOs, and finds the outputs and
//! the output source held by EtherCAT; then EtherCAT leaves OP, the source moves to CAN and
//! RPDOs drive the DAC, and EtherCAT is refused SAFE-OP with RxPDOs assigned (0x001D).

use coe_core::canopen::{CanFrame, NmtCommand};
use coe_core::SdoAbortCode;
use ethercrab::{std::ethercat_now, MainDevice, MainDeviceConfig, PduStorage};
use firmware::io::analog::scaling::ao_to_dac_code;
use firmware::products::analog_io_can;
use firmware::products::analog_io_can::can::{DEFAULT_NODE_ID as NODE, PROCESS_DATA_SOURCE_INDEX};
use firmware::products::analog_io_can::identity::NAMES;
use futures_lite::future::{block_on, or};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::models::adc::Signal;
use virtual_board::models::esc::regs;
use virtual_board::rig::board::VirtualBoard;
use virtual_board::rig::can_master::{CanMaster, SdoError};
use virtual_board::rig::master::{in_process_timeouts, tx_rx_task};
use virtual_board::tools::sim;

type Board = Rc<RefCell<VirtualBoard>>;

const AI_VOLTS: [f64; 8] = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];

fn ai(volts: f64) -> i16 {
    (volts / 10.0 * 32768.0).round() as i16
}

fn u32_of(v: &[u8]) -> u32 {
    let mut w = [0u8; 4];
    w[..v.len().min(4)].copy_from_slice(&v[..v.len().min(4)]);
    u32::from_le_bytes(w)
}

/// The TPDO data of a SYNC: AI 1..4 on 0x280 + node-ID, AI 5..8 on 0x380 + node-ID.
fn tpdo_inputs(can: &CanMaster, board: &Board) -> Vec<i16> {
    can.sync();
    let mut b = board.borrow_mut();
    let mut values = Vec::new();
    for id in [0x280 + u16::from(NODE), 0x380 + u16::from(NODE)] {
        let f = can
            .wait_for(&mut b, id, 10_000_000)
            .expect("TPDO after the SYNC");
        values.extend(f.data().chunks(2).map(|c| i16::from_le_bytes([c[0], c[1]])));
    }
    values
}

#[test]
fn ethercat_in_op_and_canopen_at_the_same_time() {
    let target = sim::firmware_target_of(&analog_io_can::PRODUCT, NODE).unwrap();
    let board: Board = Rc::new(RefCell::new(target.into_board(|b| b.capture = false)));
    {
        let b = board.borrow();
        let mut adc = b.adc().borrow_mut();
        for (i, v) in AI_VOLTS.iter().enumerate() {
            adc.inputs[i] = Signal::Constant(*v);
        }
    }
    let can = CanMaster::attach(&board.borrow());
    // Boot-up first (the CAN node boots with the board).
    board.borrow_mut().step(1_000_000);
    let boot: Vec<CanFrame> = can.take().into_iter().map(|(_, f)| f).collect();
    assert_eq!(
        boot,
        [CanFrame::new(0x700 + u16::from(NODE), &[0]).unwrap()]
    );

    let storage = Box::new(PduStorage::<16, { PduStorage::element_size(1100) }>::new());
    let (tx, rx, pdu_loop) = storage.try_split().unwrap();
    let md = MainDevice::new(
        pdu_loop,
        in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations: 50,
            ..Default::default()
        },
    );
    block_on(or(
        async {
            let group = md.init_single_group::<2, 64>(ethercat_now).await.unwrap();
            let group = group.into_op(&md).await.expect("EtherCAT OP");

            // CAN, while EtherCAT is in OP: the same dictionary over SDO.
            {
                let mut b = board.borrow_mut();
                let up = |b: &mut VirtualBoard, i, s| can.upload(b, NODE, i, s).unwrap();
                assert_eq!(u32_of(&up(&mut b, 0x1000, 0)), 0x000C_0191);
                assert_eq!(
                    up(&mut b, 0x1008, 0),
                    NAMES.device_name.as_bytes(),
                    "segmented"
                );
                assert_eq!(
                    u32_of(&up(&mut b, 0x1C12, 1)),
                    0x1600,
                    "EtherCAT's objects too"
                );
                // The source cannot move while EtherCAT runs process data.
                assert_eq!(
                    can.download(&mut b, NODE, PROCESS_DATA_SOURCE_INDEX, 0, &[1]),
                    Err(SdoError::Abort(SdoAbortCode::DeviceState))
                );
                // Nor the PDO configuration EtherCAT runs on.
                assert_eq!(
                    can.download(&mut b, NODE, 0x1A01, 0, &[0]),
                    Err(SdoError::Abort(SdoAbortCode::DeviceState))
                );
                // TPDOs every SYNC.
                can.download(&mut b, NODE, 0x1801, 2, &[1]).unwrap();
                can.download(&mut b, NODE, 0x1802, 2, &[1]).unwrap();
                can.nmt(NmtCommand::StartRemoteNode, NODE);
                b.step(1_000_000);
            }
            for _ in 0..10 {
                {
                    let sd = group.subdevice(&md, 0).unwrap();
                    let mut o = sd.outputs_raw_mut();
                    o[0..2].copy_from_slice(&0x1000i16.to_le_bytes());
                    o[2..4].copy_from_slice(&0x2000i16.to_le_bytes());
                }
                group.tx_rx(&md).await.unwrap();
                let t = board.borrow().now_ns() + 200_000;
                let now = board.borrow().now_ns();
                board.borrow_mut().step(t - now);
            }
            // The inputs on CAN are what EtherCAT's cycle published.
            let sd = group.subdevice(&md, 0).unwrap();
            let img = sd.inputs_raw().to_vec();
            let ecat: Vec<i16> = img
                .chunks(2)
                .map(|c| i16::from_le_bytes([c[0], c[1]]))
                .collect();
            let on_can = tpdo_inputs(&can, &board);
            assert_eq!(on_can, ecat[..8]);
            for (v, volts) in on_can.iter().zip(AI_VOLTS) {
                assert!(
                    (i32::from(*v) - i32::from(ai(volts))).abs() <= 1,
                    "{on_can:?}"
                );
            }
            // RPDOs are dropped: EtherCAT drives the outputs.
            can.send(CanFrame::new(0x300 + u16::from(NODE), &[0, 0x30, 0, 0x30]).unwrap());
            board.borrow_mut().step(1_000_000);
            assert_eq!(
                board.borrow().dac().borrow().dac,
                [ao_to_dac_code(0x1000), ao_to_dac_code(0x2000)]
            );

            // EtherCAT leaves OP (outputs to their fault values, 0); CAN takes the outputs.
            let group = group.into_safe_op(&md).await.unwrap();
            let group = group.into_pre_op(&md).await.unwrap();
            {
                let mut b = board.borrow_mut();
                can.nmt(NmtCommand::EnterPreOperational, NODE);
                b.step(1_000_000);
                can.download(&mut b, NODE, PROCESS_DATA_SOURCE_INDEX, 0, &[1])
                    .unwrap();
                can.nmt(NmtCommand::StartRemoteNode, NODE);
                b.step(1_000_000);
                can.send(CanFrame::new(0x300 + u16::from(NODE), &[0, 0x30, 0, 0x10]).unwrap());
                b.step(1_000_000);
                assert_eq!(
                    b.dac().borrow().dac,
                    [ao_to_dac_code(0x3000), ao_to_dac_code(0x1000)],
                    "the RPDO drove the DAC"
                );
            }
            // EtherCAT with RxPDOs assigned is refused SAFE-OP: PRE-OP + error, 0x001D.
            let sd = group.subdevice(&md, 0).unwrap();
            sd.register_write(0x0120u16, 0x0004u16).await.unwrap();
            let b = board.borrow();
            let esc = b.esc().borrow();
            assert_eq!(
                (
                    esc.peek_u16(regs::AL_STATUS),
                    esc.peek_u16(regs::AL_STATUS_CODE)
                ),
                (0x0012, 0x001D)
            );
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    let b = board.borrow();
    let stats = b.can().borrow().stats.clone();
    assert!(stats.frames > 20, "{stats:?}");
}
