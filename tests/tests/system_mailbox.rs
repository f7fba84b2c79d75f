//! SYSTEM TESTS of the mailbox link as masters use it, beyond what a master's SDO API does:
//! replies left unread, the repeat request, state changes in between. ethercrab (in process)
//! brings the virtual board with the firmware's slave application to PRE-OP; the rest is raw
//! mailbox access ([`virtual_board::rig::sdo_client::MailboxClient`]).

use ethercrab::{std::ethercat_now, MainDevice, MainDeviceConfig, PduStorage, SubDeviceRef};
use firmware::products::analog_io::device::DEVICE;
use futures_lite::future::{block_on, or};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::rig::board::{BoardConfig, VirtualBoard};
use virtual_board::rig::master::{in_process_timeouts, tx_rx_task};
use virtual_board::rig::sdo_client::{
    expedited_upload, sdo_request, MailboxClient, MAILBOX_TYPE_COE,
};
use virtual_board::tools::sim;

type Board = Rc<RefCell<VirtualBoard>>;

const MBX: usize = 128;

fn firmware_board() -> Board {
    let target = sim::firmware_target().expect("firmware target");
    let board = Rc::new(RefCell::new(VirtualBoard::new(BoardConfig::new(
        target.sii,
    ))));
    let cpu = (target.make_cpu)(board.borrow().io());
    board.borrow_mut().set_cpu(cpu);
    board
}

fn master(
    storage: &PduStorage<16, { PduStorage::element_size(1100) }>,
) -> (MainDevice<'_>, ethercrab::PduTx<'_>, ethercrab::PduRx<'_>) {
    let (tx, rx, pdu_loop) = storage.try_split().expect("split once");
    let md = MainDevice::new(
        pdu_loop,
        in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations: 0,
            ..Default::default()
        },
    );
    (md, tx, rx)
}

fn client() -> MailboxClient<MBX> {
    let (out, inp) = (DEVICE.sync_managers[0], DEVICE.sync_managers[1]);
    assert_eq!((out.len, inp.len), (MBX as u16, MBX as u16));
    MailboxClient::new(out.start, inp.start, 1)
}

/// Requests an AL state by writing AL control and waits for AL status to show it.
async fn request_state<S>(sd: &SubDeviceRef<'_, S>, state: u16) {
    sd.register_write(0x0120u16, state).await.unwrap();
    for _ in 0..2000 {
        let status: u16 = sd.register_read(0x0130u16).await.unwrap();
        if status & 0x1F == state {
            return;
        }
    }
    panic!("AL state {state:#x} not reached");
}

/// An expedited SDO upload request for `index:sub`.
fn upload(index: u16, sub: u8) -> [u8; 10] {
    let [lo, hi] = index.to_le_bytes();
    sdo_request([0x40, lo, hi, sub, 0, 0, 0, 0])
}

/// `(index, sub, data)` of an expedited upload response.
fn expedited(frame: &[u8]) -> (u16, u8, Vec<u8>) {
    expedited_upload(frame).unwrap()
}

/// Issue 14 section 1: a master leaves an SDO reply unread after having used the repeat
/// request (SM1 repeat request and the slave's acknowledge both 1), goes PREOP -> INIT,
/// rewrites the mailbox SyncManagers in INIT with activate = 0x01 (repeat bit 0) as masters
/// do, and goes INIT -> PREOP. The reply from before INIT answers nothing: the read mailbox
/// must be empty after INIT -> PREOP (and stay so), the repeat toggle state is taken from
/// SM1, and the mailbox works from there: a new request gets its own reply, and a repeat
/// request returns that reply.
#[test]
fn state_cycle_leaves_no_stale_reply_and_takes_the_repeat_state_from_sm1() {
    let board = firmware_board();
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage);
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            let sd = group.subdevice(&md, 0).unwrap();
            let mut mbx = client();

            // A request, its reply, and the repeat request: SM1 repeat bit and ack are now 1.
            assert!(mbx
                .send(&sd, MAILBOX_TYPE_COE, &upload(0x1000, 0))
                .await
                .unwrap());
            let first = mbx.read(&sd).await.unwrap();
            assert_eq!(
                expedited(&first),
                (0x1000, 0, 0x000C_0191u32.to_le_bytes().to_vec())
            );
            let repeated = mbx.repeat(&sd).await.unwrap();
            assert_eq!(
                repeated, first,
                "the repeat returns the identical last reply"
            );
            let activate: u8 = sd.register_read(0x080Eu16).await.unwrap();
            let ack: u8 = sd.register_read(0x080Fu16).await.unwrap();
            assert_eq!((activate & 0x02, ack & 0x02), (0x02, 0x02));

            // A second request whose reply the master leaves unread.
            assert!(mbx
                .send(&sd, MAILBOX_TYPE_COE, &upload(0x1018, 1))
                .await
                .unwrap());
            let mut waited = 0;
            while !mbx.reply_waiting(&sd).await.unwrap() {
                waited += 1;
                assert!(waited < 2000, "no reply to the second request");
            }

            // PREOP -> INIT; the mailbox SyncManagers rewritten in INIT with activate 0x01.
            request_state(&sd, 0x01).await;
            for (n, sm) in DEVICE.sync_managers.iter().enumerate().take(2) {
                let mut regs = [0u8; 8];
                regs[0..2].copy_from_slice(&sm.start.to_le_bytes());
                regs[2..4].copy_from_slice(&sm.len.to_le_bytes());
                regs[4] = sm.control;
                regs[6] = 0x01;
                sd.register_write(0x0800 + 8 * n as u16, regs)
                    .await
                    .unwrap();
            }
            request_state(&sd, 0x02).await;

            // Nothing from before INIT comes out, however long the master waits.
            for _ in 0..200 {
                assert!(
                    !mbx.reply_waiting(&sd).await.unwrap(),
                    "the read mailbox holds a reply from before INIT"
                );
            }
            let ack: u8 = sd.register_read(0x080Fu16).await.unwrap();
            assert_eq!(
                ack & 0x02,
                0,
                "the repeat acknowledge follows SM1's repeat bit"
            );

            // The mailbox works: a new request, its reply, and a repeat of that reply.
            assert!(mbx
                .send(&sd, MAILBOX_TYPE_COE, &upload(0x1018, 2))
                .await
                .unwrap());
            let reply = mbx.read(&sd).await.unwrap();
            assert_eq!(expedited(&reply).0, 0x1018);
            assert_eq!(expedited(&reply).1, 2);
            assert_eq!(mbx.repeat(&sd).await.unwrap(), reply);
            assert!(!mbx.reply_waiting(&sd).await.unwrap());
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
}
