//! SYSTEM TEST ON EVERY PRODUCT'S IMAGE: each product's release programs (its board's
//! bootloader and its application, as `cargo xtask build` made them beside the default
//! product's, `lpc1754_cosim::run::image_path_of`) boot on the co-simulated LPC1754, and a
//! real master (ethercrab, in process) reads the product's identity from the SII and over
//! SDO and brings it to OP, where the process data run with the DAC loaded from the
//! master's outputs. The long image tests run once, on the default product
//! (`system_image.rs`); the CAN product's node is `can_image.rs`'s.

use ethercrab::{std::ethercat_now, PduStorage, SubDeviceState};
use firmware::products::{Product, PRODUCTS};
use futures_lite::future::{block_on, or};
use lpc1754_cosim::bench::{al_status, master, step_to};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_target, load_image_of};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::rig::master::tx_rx_task;

/// Boots `product`'s image, reads its identity and walks it to OP; the DAC code of AO 1
/// after `value` went out in the process data.
fn boot_to_op(product: &'static Product, value: i16) -> u16 {
    let image = load_image_of(product.name).expect("the product's release image");
    assert_eq!(
        image.product().map(|p| p.name),
        Some(product.name),
        "the update file in the slot is the product's"
    );
    let (target, handle) = image_target(image, Options::default()).expect("boot ROM checks");
    let board = Rc::new(RefCell::new(target.into_board(|_| {})));
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage).unwrap();
    let names = product.device.names;
    let identity = product.device.identity;
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            {
                let sd = group.subdevice(&md, 0).unwrap();
                assert_eq!(sd.status().await.unwrap().0, SubDeviceState::PreOp);
                assert_eq!(sd.name(), names.order_code, "SII name");
                assert_eq!(sd.identity().product_id, identity.product_code, "SII");
                assert_eq!(
                    sd.sdo_read::<u32>(0x1018, 2).await.unwrap(),
                    identity.product_code,
                    "the running application's 0x1018:02"
                );
                let name: heapless::String<64> = sd.sdo_read(0x1008, 0).await.unwrap();
                assert_eq!(name.as_str(), names.device_name);
                // The CANopen objects are the CAN product's alone.
                let heartbeat = sd.sdo_read::<u16>(0x1017, 0).await;
                assert_eq!(heartbeat.is_ok(), product.can.is_some(), "0x1017");
            }
            let group = group.into_op(&md).await.expect("OP");
            for _ in 0..50 {
                {
                    let sd = group.subdevice(&md, 0).unwrap();
                    let mut o = sd.outputs_raw_mut();
                    o[..2].copy_from_slice(&value.to_le_bytes());
                }
                group.tx_rx(&md).await.expect("cycle");
                let t = board.borrow().now_ns() + 1_000_000;
                step_to(&board, t);
            }
            assert_eq!(al_status(&board), (0x0008, 0), "OP, no error");
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    let facts = handle.with(|c| c.facts()).expect("co-simulator built");
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
    let b = board.borrow();
    assert_eq!(
        b.esc().borrow().spi_stats.errors,
        0,
        "ET1100 SPI protocol errors"
    );
    let dac = b.dac().borrow().dac[0];
    dac
}

#[test]
fn every_product_image_boots_shows_its_identity_and_reaches_op() {
    // The co-simulator models the LPC1754 only.
    for product in PRODUCTS
        .iter()
        .filter(|p| p.board.mcu() == firmware::platform::board::Mcu::Lpc1754)
    {
        let value = 0x2000;
        let dac = boot_to_op(product, value);
        assert_eq!(
            dac,
            firmware::io::analog::scaling::ao_to_dac_code(value),
            "{}: AO 1 on the DAC",
            product.name
        );
    }
}
