//! SYSTEM TESTS ON THE STM32 IMAGE: the `analog-io-stm32` release ELF (`cargo xtask build
//! --product analog-io-stm32`, beside the default product's) runs from reset on the
//! co-simulated STM32F103 (`lpc1754_cosim::stm32`: RCC, FLASH_ACR, GPIO/AFIO, EXTI, TIM3/8,
//! SPI1/2, DMA1, IWDG, DWT, and FSMC bank 1 on the ET1100 model's µC front end), and
//! ethercrab (in process) drives it with the LPC1754 image tests' helpers: the identity and
//! OP with process data to the DAC (`common::boot_to_op`); SOEM drives it over a veth pair.
//! The system tests of `system_image.rs` run on this image too (its module `stm32f103`).

mod common;

use lpc1754_cosim::chip::Chip;
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_target, load_image_of};
use std::path::PathBuf;
use virtual_board::tools::iface::pysoem_missing;
use virtual_board::tools::sim::tshark;

#[test]
fn stm32_image_boots_shows_its_identity_and_reaches_op() {
    let product = common::stm32_product();
    assert_eq!(product.device.identity.product_code, 0xF103);
    let image = load_image_of(product.name).expect("the product's release ELF");
    assert_eq!(image.chip, Chip::Stm32f103, "linked for the STM32's flash");
    let value = 0x2000;
    let (dac, board) = common::boot_to_op(product, value);
    assert_eq!(
        dac,
        firmware::io::analog::scaling::ao_to_dac_code(value),
        "AO 1 on the DAC"
    );
    let b = board.borrow();
    assert_eq!(
        b.esc().borrow().spi_stats.transactions,
        0,
        "the ESC is on the FSMC, not on SPI"
    );
}

/// SOEM (pysoem, `scripts/pysoem_master.py`, in its own process) drives the STM32 image
/// served on a veth pair, as `iface_pysoem.rs` drives the LPC1754's: the SII, SDO identity,
/// DC, the mapping, SAFE-OP, OP with 2 000 exchanges in step with SYNC0, the cycle monitor,
/// the SM watchdog (0x001B), SDO Information, INIT; the capture decodes cleanly. The board
/// runs [`common::BOARD_SLOWDOWN`] times slower than the wall clock, as the LPC1754's does.
#[test]
#[ignore = "needs root, iproute2 (ip), python3 with pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_drives_the_stm32_image_over_a_veth_pair() {
    if let Some(why) = pysoem_missing() {
        panic!("this test cannot run here: {why}");
    }
    const CYCLES: u32 = 2000;
    let product = common::stm32_product();
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scripts/pysoem_master.py");
    let slowdown = common::BOARD_SLOWDOWN;
    let runs = vec![vec![
        CYCLES.to_string().into(),
        "--slowdown".into(),
        slowdown.to_string().into(),
    ]];
    let o = common::unless_the_master_was_late(|| {
        let (script, runs) = (script.clone(), runs.clone());
        std::thread::spawn(move || {
            common::run_script_against_with(
                || image_target(load_image_of(product.name)?, Options::default()),
                script,
                runs,
                "iface-pysoem-stm32.pcap",
                120.0,
                common::Serving {
                    slowdown,
                    ..Default::default()
                },
            )
        })
        .join()
        .expect("namespace thread")
        .unwrap()
    });
    let step = |name| common::step(&o.lines, name);
    assert!(
        o.script_ok,
        "pysoem failed: {:?}\n{}\n{}",
        o.lines, o.stderr, o.facts
    );
    assert!(o.clean, "{}", o.facts);
    assert_eq!(step("sii")["name"], product.device.names.group_type);
    let identity: Vec<u64> = serde_json::from_value(step("sdo")["identity"].clone()).unwrap();
    assert_eq!(identity[1], 0xF103, "the product code over SDO");
    let map = step("config_map");
    assert_eq!(
        (map["outputs"].as_u64(), map["inputs"].as_u64()),
        (Some(4), Some(16))
    );
    assert_eq!(step("safeop")["sync_mode"], 2, "DC SYNC0 mode");
    let pd = step("process_data");
    common::assert_every_exchange_answered(pd, CYCLES);
    assert_eq!(pd["state"], 8, "still in OP after the exchanges");
    assert_eq!(step("sync_monitor")["sync_error"], 0);
    let wd = step("watchdog");
    assert_eq!(
        (wd["state"].as_u64(), wd["al_status_code"].as_u64()),
        (Some(0x14), Some(0x1B))
    );
    assert_eq!(step("init")["state"], 1, "{:?}", o.lines);
    tshark::assert_clean(&o.pcap);
}
