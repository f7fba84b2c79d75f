//! In-process EtherCAT master rig: ethercrab's PDU loop wired to a [`VirtualBoard`]
//! without any network interface (see `docs/masters.md`).
//!
//! ```text
//! static STORAGE: PduStorage<16, { PduStorage::element_size(1100) }> = PduStorage::new();
//! let (tx, rx, pdu_loop) = STORAGE.try_split().unwrap();
//! let board = Rc::new(RefCell::new(VirtualBoard::new(cfg)));
//! let md = MainDevice::new(pdu_loop, timeouts, config);
//! futures_lite::future::block_on(futures_lite::future::or(
//!     async { /* use md */ },
//!     virtual_board::rig::master::tx_rx_task(board.clone(), tx, rx),
//! ));
//! ```

use crate::rig::board::VirtualBoard;
use ethercrab::{MainDevice, MainDeviceConfig, PduRx, PduStorage, PduTx, Timeouts};
use std::cell::RefCell;
use std::future::Future;
use std::rc::Rc;
use std::task::Poll;
use std::time::Duration;

/// A board shared between the rig and the test.
pub type SharedBoard = Rc<RefCell<VirtualBoard>>;

/// ethercrab's timeouts for a master driving a board in process.
///
/// ethercrab measures its timeouts on the wall clock, while the board runs on virtual time
/// and answers every frame at once: a timeout can only fire when the test thread is not
/// scheduled, which on a loaded CI machine happens for longer than ethercrab's defaults
/// (10 ms for an EEPROM read, 30 ms for a PDU: seen as a spurious `Timeout(Eeprom)` in
/// about 1 of 30 runs). Here they only guard against a hang, so they are generous. Nothing
/// the board does depends on them.
pub fn in_process_timeouts() -> Timeouts {
    Timeouts {
        state_transition: Duration::from_secs(10),
        pdu: Duration::from_secs(2),
        eeprom: Duration::from_secs(2),
        wait_loop_delay: Duration::from_micros(100),
        mailbox_echo: Duration::from_secs(2),
        mailbox_response: Duration::from_secs(5),
    }
}

/// The PDU storage of the in-process master: 16 frames of up to 1100 bytes.
pub type Storage = PduStorage<16, { PduStorage::element_size(1100) }>;

/// A master on `storage` with [`in_process_timeouts`] and `dc_static_sync_iterations`
/// (0: no DC static drift compensation), and the two halves of its PDU loop for
/// [`tx_rx_task`].
pub fn main_device(
    storage: &Storage,
    dc_static_sync_iterations: u32,
) -> (MainDevice<'_>, PduTx<'_>, PduRx<'_>) {
    let (tx, rx, pdu_loop) = storage.try_split().expect("split once");
    let md = MainDevice::new(
        pdu_loop,
        in_process_timeouts(),
        MainDeviceConfig {
            dc_static_sync_iterations,
            ..Default::default()
        },
    );
    (md, tx, rx)
}

/// Moves every sendable frame through the board and hands the reply back to ethercrab.
/// Never completes: race it against the master's work (`futures_lite::future::or`).
pub fn tx_rx_task<'sto, T>(
    board: SharedBoard,
    mut tx: PduTx<'sto>,
    mut rx: PduRx<'sto>,
) -> impl Future<Output = T> + 'sto {
    std::future::poll_fn(move |cx| {
        tx.replace_waker(cx.waker());
        while let Some(frame) = tx.next_sendable_frame() {
            let mut reply = None;
            let sent = frame.send_blocking(|bytes| {
                reply = Some(board.borrow_mut().exchange(bytes));
                Ok(bytes.len())
            });
            if sent.is_err() {
                continue;
            }
            if let Some(reply) = reply {
                // A reply ethercrab does not match (e.g. a frame it already timed out)
                // is dropped, as a real NIC would.
                let _ = rx.receive_frame(&reply);
            }
        }
        Poll::Pending
    })
}
