//! SYSTEM TEST ON THE IMAGE: the firmware update of the release programs (issue 13) on the
//! LPC1754 co-simulator: the real application resets into the real bootloader on a
//! master's INIT -> BOOT, the bootloader takes an update file over FoE into the staging
//! area through the IAP ROM (the `lpc17xx-iap` flash model), and its reset sequence
//! installs it and starts the new application. Files with a bad CRC, truncated, for
//! another board or for a product the board cannot run (the CAN product's file on the
//! board without the CAN transceiver) are refused first, and the old application still runs
//! after them. One product is updated into another where the board can run both: the CAN
//! product's board takes the default product's release file (`docs/book/products.md`).
//!
//! The new application is the release application with another software version: the
//! version string (0x100A) patched in its image and the update header made for the patched
//! image, so the update is seen in what the running firmware answers. The image is the one
//! `cargo xtask build` made (`cargo xtask test` passes it in `LPC1754_IMAGE`); a missing
//! image fails the test, it never skips it.

mod common;

use coe_core::device::MemoryWindow;
use coe_core::wire::FoeErrorCode;
use common::new_update_file;
use ethercrab::std::ethercat_now;
use firmware::platform::boot::header::{Header, HeaderRepr, Target};
use firmware::platform::boot::layout::{APP_SLOT, HEADER_BLOCK, STAGING};
use firmware::products::analog_io::device::DEVICE;
use firmware::products::analog_io::identity::{NAMES, UPDATE_TARGET};
use firmware::products::analog_io::layout::BOOTSTRAP_MAILBOX;
use firmware::products::{analog_io, analog_io_can};
use futures_lite::future::{block_on, or};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::image::Image;
use lpc1754_cosim::machine::ResetCause;
use lpc1754_cosim::run::{
    image_path, image_path_of, image_target, load_image, load_image_of, CosimHandle,
};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::rig::board::VirtualBoard;
use virtual_board::rig::foe_client::{
    configure_mailbox, enter_boot, request_state, FoeClient, FoeFailure,
};
use virtual_board::rig::master::{main_device, tx_rx_task, Storage};
use virtual_board::rig::sdo_client::SdoClient;

type Board = Rc<RefCell<VirtualBoard>>;

/// The software version of the patched application (as long as the release version, so
/// the string is replaced in place).
const NEW_VERSION: &str = "9.8.7";

fn image_board() -> (Board, CosimHandle) {
    board_of(load_image().expect("the release image"))
}

fn board_of(image: Image) -> (Board, CosimHandle) {
    let (target, handle) = image_target(image, Options::default()).expect("boot ROM checks");
    let board = Rc::new(RefCell::new(target.into_board(|_| {})));
    (board, handle)
}

/// The header of the application slot in the co-simulator's flash.
fn slot_header(handle: &CosimHandle) -> Option<HeaderRepr> {
    let flash = handle.with(|c| c.flash()).expect("co-simulator built");
    let start = APP_SLOT.start as usize;
    HeaderRepr::parse(&Header::new_unchecked(
        &flash[start..start + HEADER_BLOCK as usize],
    ))
    .ok()
}

/// The standard mailbox's SyncManager `n` (0 out, 1 in).
fn standard(n: usize) -> MemoryWindow {
    let sm = DEVICE.sync_managers[n];
    MemoryWindow::new(sm.start, sm.len)
}

/// INIT -> PRE-OP, asked again while the bootloader installs a file and starts the
/// application (IAP erase and copy).
async fn preop<S>(sd: &ethercrab::SubDeviceRef<'_, S>) {
    let mut preop = request_state(sd, 0x02).await;
    for _ in 0..20 {
        if preop.is_ok() {
            break;
        }
        preop = request_state(sd, 0x02).await;
    }
    preop.unwrap();
}

/// An SDO client on the standard mailbox, its counter from 1: one per start of an
/// application.
fn sdo_client() -> SdoClient<128> {
    let (out, inp) = (DEVICE.sync_managers[0], DEVICE.sync_managers[1]);
    SdoClient::new(out.start, inp.start, 1)
}

/// The software version (0x100A) as the running application answers it.
async fn software_version<S>(sd: &ethercrab::SubDeviceRef<'_, S>) -> String {
    let up = sdo_client().upload(sd, 0x100A, 0).await.unwrap();
    String::from_utf8(up.data).unwrap()
}

/// The product code (0x1018:02) and the device name (0x1008) as the running application
/// answers them.
async fn identity<S>(sd: &ethercrab::SubDeviceRef<'_, S>) -> (u32, String) {
    let mut client = sdo_client();
    let code = client.upload(sd, 0x1018, 2).await.unwrap().data;
    let name = client.upload(sd, 0x1008, 0).await.unwrap().data;
    (
        u32::from_le_bytes(code[..4].try_into().unwrap()),
        String::from_utf8(name).unwrap(),
    )
}

#[test]
fn foe_update_of_the_release_programs() {
    let new = new_update_file(NEW_VERSION, &UPDATE_TARGET);
    let mut bad_crc = new.clone();
    let last = bad_crc.len() - 1;
    bad_crc[last] ^= 0x01;
    let truncated = new[..new.len() - 1000].to_vec();
    let other_board = new_update_file(
        NEW_VERSION,
        &Target {
            board: UPDATE_TARGET.board + 1,
            ..UPDATE_TARGET
        },
    );
    // The CAN product's release file: the same board design, but it needs the CAN
    // transceiver this board does not have.
    let can_product = read_update_file(analog_io_can::PRODUCT.name);
    let (board, handle) = image_board();
    let storage = Box::new(Storage::new());
    let (md, tx, rx) = main_device(&storage, 0);
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            let sd = group.subdevice(&md, 0).unwrap();
            assert_eq!(software_version(&sd).await, NAMES.software_version);

            // INIT -> BOOT: the application resets into the bootloader, which takes BOOT.
            enter_boot(&sd, BOOTSTRAP_MAILBOX.0, BOOTSTRAP_MAILBOX.1)
                .await
                .unwrap();
            let resets = handle.with(|c| c.facts().resets).unwrap();
            assert_eq!(
                resets.iter().map(|r| r.0).collect::<Vec<_>>(),
                [ResetCause::SysResetReq]
            );
            let mut foe = FoeClient::<{ BOOTSTRAP_MAILBOX.0.len as usize }>::new(
                BOOTSTRAP_MAILBOX.0.start,
                BOOTSTRAP_MAILBOX.1.start,
            );
            for (file, expected) in [
                (&bad_crc, (FoeErrorCode::InvalidChecksum, "image CRC wrong")),
                (&truncated, (FoeErrorCode::InvalidChecksum, "truncated")),
                (&other_board, (FoeErrorCode::InvalidFirmware, "other board")),
                (
                    &can_product,
                    (FoeErrorCode::InvalidFirmware, "board lacks a part"),
                ),
            ] {
                match foe.write(&sd, "analog-io.efw", 0, file).await {
                    Err(FoeFailure::Refused { code, text, .. }) => {
                        assert_eq!((code, text.as_str()), expected)
                    }
                    other => panic!("{expected:?}: {other:?}"),
                }
            }
            // BOOT -> INIT after the refused files: the old application still runs.
            request_state(&sd, 0x01).await.unwrap();
            configure_mailbox(&sd, standard(0), standard(1))
                .await
                .unwrap();
            preop(&sd).await;
            assert_eq!(software_version(&sd).await, NAMES.software_version);
            request_state(&sd, 0x01).await.unwrap();
            enter_boot(&sd, BOOTSTRAP_MAILBOX.0, BOOTSTRAP_MAILBOX.1)
                .await
                .unwrap();

            let t0 = board.borrow().now_ns();
            foe.write(&sd, "analog-io.efw", 0, &new).await.unwrap();
            let t1 = board.borrow().now_ns();
            eprintln!(
                "FoE write of {} B: {:.1} ms of virtual time",
                new.len(),
                (t1 - t0) as f64 / 1e6
            );
            let old = slot_header(&handle).expect("the release application");
            assert_eq!(old.version_str(), Some(NAMES.software_version));

            // BOOT -> INIT: the bootloader resets; its reset sequence installs the file and
            // starts the new application, which comes up in INIT and takes PRE-OP.
            request_state(&sd, 0x01).await.unwrap();
            configure_mailbox(&sd, standard(0), standard(1))
                .await
                .unwrap();
            preop(&sd).await;
            eprintln!(
                "BOOT -> INIT to PRE-OP of the new application (installation included): \
                 {:.1} ms of virtual time",
                (board.borrow().now_ns() - t1) as f64 / 1e6
            );
            assert_eq!(software_version(&sd).await, NEW_VERSION);
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    let installed = slot_header(&handle).expect("an application");
    assert_eq!(installed.version_str(), Some(NEW_VERSION));
    let facts = handle.with(|c| c.facts()).unwrap();
    eprintln!("{}", facts.summary());
    assert_eq!(
        facts.resets.iter().map(|r| r.0).collect::<Vec<_>>(),
        // Into the bootloader, out of it after the refused files, into it again, out of it
        // with the new application.
        [ResetCause::SysResetReq; 4],
        "{}",
        facts.summary()
    );
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
    let spi = board.borrow().esc().borrow().spi_stats.clone();
    assert_eq!(spi.errors, 0, "ET1100 SPI protocol errors");
}

/// A product's release update file (`cargo xtask build`).
fn read_update_file(product: &str) -> Vec<u8> {
    let path = image_path_of(product).with_extension("efw");
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One product updated into another on the same board: the CAN product's image (its
/// bootloader built for the board with the CAN transceiver) takes the default product's
/// release file over FoE, and the application answering afterwards is the default
/// product's (its product code in 0x1018:02 and its device name), while the bootloader and
/// the SII stay the board's.
#[test]
fn the_can_board_takes_the_default_products_update() {
    let file = read_update_file(analog_io::PRODUCT.name);
    assert_eq!(
        image_path().with_extension("efw"),
        image_path_of(analog_io::PRODUCT.name).with_extension("efw")
    );
    let (board, handle) =
        board_of(load_image_of(analog_io_can::PRODUCT.name).expect("the CAN image"));
    let storage = Box::new(Storage::new());
    let (md, tx, rx) = main_device(&storage, 0);
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            let sd = group.subdevice(&md, 0).unwrap();
            let names = analog_io_can::identity::NAMES;
            assert_eq!(
                identity(&sd).await,
                (
                    analog_io_can::identity::IDENTITY.product_code,
                    names.device_name.into()
                )
            );
            enter_boot(&sd, BOOTSTRAP_MAILBOX.0, BOOTSTRAP_MAILBOX.1)
                .await
                .unwrap();
            let mut foe = FoeClient::<{ BOOTSTRAP_MAILBOX.0.len as usize }>::new(
                BOOTSTRAP_MAILBOX.0.start,
                BOOTSTRAP_MAILBOX.1.start,
            );
            foe.write(&sd, "analog-io.efw", 0, &file).await.unwrap();
            request_state(&sd, 0x01).await.unwrap();
            configure_mailbox(&sd, standard(0), standard(1))
                .await
                .unwrap();
            preop(&sd).await;
            assert_eq!(
                identity(&sd).await,
                (
                    analog_io::identity::IDENTITY.product_code,
                    analog_io::identity::NAMES.device_name.into()
                )
            );
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    let installed = slot_header(&handle).expect("an application");
    assert_eq!(
        installed.product_code,
        analog_io::identity::IDENTITY.product_code
    );
    let facts = handle.with(|c| c.facts()).unwrap();
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
}

/// A staged update installed by the bootloader at reset while the co-simulator stops the
/// core at every block (steps of 10 ns, about one instruction, as a board with much traffic
/// would in places): every IAP command is carried out once, however often the run stops at
/// the ROM's entry, and the new application is installed.
#[test]
fn a_staged_update_is_installed_with_the_run_stopped_at_every_block() {
    let new = new_update_file(NEW_VERSION, &UPDATE_TARGET);
    let mut image = load_image().expect("the release image");
    let at = STAGING.start as usize;
    image.flash[at..at + new.len()].copy_from_slice(&new);
    let (board, handle) = board_of(image);
    // The installation (two image checks, the slot erased and written) takes about 15 ms of
    // virtual time; the IAP ROM's own time is not modelled.
    for _ in 0..2_500_000 {
        board.borrow_mut().step(10);
    }
    let facts = handle.with(|c| c.facts()).unwrap();
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
    let installed = slot_header(&handle).expect("an application");
    assert_eq!(installed.version_str(), Some(NEW_VERSION));
}
