//! The models' strictness, tested on patched copies of the release image (issue 12, "Must
//! show"): each mistake a board would punish is reported by the co-simulator, naming the
//! cause.

use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::periph::syscon::PCONP_RESET;
use lpc1754_cosim::run::{image_target, load_image};
use std::cell::RefCell;
use std::rc::Rc;

/// Boots a (patched) image on a board for `ns` and returns the reported messages.
fn reports_after(image: lpc1754_cosim::image::Image, options: Options, ns: u64) -> Vec<String> {
    let (target, handle) = image_target(image, options).expect("boot ROM checks");
    let board = Rc::new(RefCell::new(target.into_board(|_| {})));
    board.borrow_mut().step(ns);
    let facts = handle.with(|c| c.facts()).unwrap();
    assert!(facts.fault.is_none(), "{}", facts.summary());
    facts.reports.into_iter().map(|r| r.message).collect()
}

/// Thumb-2 `MOVW Rd, #imm16` (encoding T3), as stored (two little-endian halfwords).
fn movw(rd: u8, imm16: u16) -> [u8; 4] {
    let (i, imm4) = ((imm16 >> 11) & 1, imm16 >> 12);
    let (imm3, imm8) = ((imm16 >> 8) & 7, imm16 & 0xFF);
    let hw1 = 0xF240 | (i << 10) | imm4;
    let hw2 = (imm3 << 12) | (u16::from(rd) << 8) | imm8;
    let [a, b] = hw1.to_le_bytes();
    let [c, d] = hw2.to_le_bytes();
    [a, b, c, d]
}

/// Replaces the 32-bit constant `from` by `to` in the image's code, where the compiler put
/// it: a literal word (opt-level "z") or, when only the low halfword differs, the `MOVW` of
/// a `MOVW`/`MOVT` pair (opt-level "s" and above).
fn patch_constant(
    image: &mut lpc1754_cosim::image::Image,
    from: u32,
    to: u32,
) -> Result<usize, String> {
    let literal = image.patch_unique(&from.to_le_bytes(), &to.to_le_bytes());
    if literal.is_ok() || from >> 16 != to >> 16 {
        return literal;
    }
    let (lo_from, lo_to) = (from as u16, to as u16);
    (0..=12)
        .find_map(|rd| {
            image
                .patch_unique(&movw(rd, lo_from), &movw(rd, lo_to))
                .ok()
        })
        .ok_or_else(|| {
            format!(
                "{from:#010x}: {}; nor as MOVW r0..r12",
                literal.unwrap_err()
            )
        })
}

#[test]
fn movw_encoding() {
    // `movw r1, #0x8504` as LLVM emits it.
    assert_eq!(movw(1, 0x8504), [0x48, 0xF2, 0x04, 0x51]);
    // `movw r0, #0xffff`: i and imm3 set.
    assert_eq!(movw(0, 0xFFFF), [0x4F, 0xF6, 0xFF, 0x70]);
}

#[test]
fn the_unpatched_image_reports_nothing() {
    let reports = reports_after(load_image().unwrap(), Options::default(), 20_000_000);
    assert!(reports.is_empty(), "{reports:?}");
}

/// A wrong vector checksum (word 0x1C): the boot ROM stays in ISP and the run fails with
/// that message before anything runs.
#[test]
fn corrupted_vector_checksum() {
    let mut image = load_image().unwrap();
    image.flash[0x1C] ^= 0x01;
    let err = image_target(image, Options::default())
        .err()
        .expect("refused");
    assert!(
        err.contains("vector checksum is wrong") && err.contains("stays in ISP"),
        "{err}"
    );
}

/// The pin map with P0.15 in function 2 (SCK0 of SSP0) instead of 3 (SCK of the legacy
/// SPI): the ESC's clock goes elsewhere, no byte reaches the ET1100, and the report names the
/// pin and the function.
#[test]
fn pinsel_routes_the_esc_spi_elsewhere() {
    let mut image = load_image().unwrap();
    // PIN_MAP's first rows as the image stores them: (pull, port, pin, function) per entry
    // (P0.15 SCK: no pull, fn 3; P0.16 SEL: no pull, fn 0).
    image
        .patch_unique(&[2, 0, 15, 3, 2, 0, 16, 0], &[2, 0, 15, 2, 2, 0, 16, 0])
        .expect("the pin map in the image");
    let reports = reports_after(image, Options::default(), 20_000_000);
    assert!(
        reports
            .iter()
            .any(|r| r.contains("legacy SPI byte to the ET1100")
                && r.contains("P0.15 is PINSEL function 2, not 3 (SCK)")
                && r.contains("moves no data")),
        "{reports:?}"
    );
}

/// SSP1's power bit left off: the firmware's PCONP value without bit 10, and PCONP at
/// reset without it too (as a bootloader that powers SSP1 down before starting the
/// application leaves it; from a power-on reset SSP1 is powered). The ADC's port does not
/// respond and the report names the peripheral and the bit.
#[test]
fn ssp1_power_bit_left_off() {
    let mut image = load_image().unwrap();
    // hw::clocks::enable_peripherals' PCONP bits: TIMER1, PWM1, SPI, SSP1, CAN1, GPIO, SSP0,
    // TIMER2.
    let bits: u32 =
        (1 << 2) | (1 << 6) | (1 << 8) | (1 << 10) | (1 << 13) | (1 << 15) | (1 << 21) | (1 << 22);
    patch_constant(&mut image, bits, bits & !(1 << 10)).expect("the PCONP constant in the image");
    let options = Options {
        pconp_at_reset: Some(PCONP_RESET & !(1 << 10)),
        ..Default::default()
    };
    let reports = reports_after(image, options, 20_000_000);
    assert!(
        reports
            .iter()
            .any(|r| r.contains("access to SSP1 while its PCONP bit 10 is 0")
                && r.contains("does not respond")),
        "{reports:?}"
    );
}

/// The STM32 product's release ELF (no bootloader on its board).
fn stm32_image() -> lpc1754_cosim::image::Image {
    let product = firmware::products::PRODUCTS
        .iter()
        .find(|p| p.board.mcu() == firmware::platform::board::Mcu::Stm32f103vc)
        .expect("an STM32 product");
    lpc1754_cosim::run::load_image_of(product.name).expect("the STM32 image")
}

#[test]
fn the_unpatched_stm32_image_reports_nothing() {
    let reports = reports_after(stm32_image(), Options::default(), 20_000_000);
    assert!(reports.is_empty(), "{reports:?}");
}

/// BCR1 without MUXEN (the board plan's 0x90D7): the latch never sees an address, so no
/// access reaches the ET1100 and the report says why.
#[test]
fn stm32_fsmc_not_multiplexed() {
    let mut image = stm32_image();
    patch_constant(&mut image, 0x0000_90D7, 0x0000_90D5).expect("the BCR1 constant");
    let reports = reports_after(image, Options::default(), 20_000_000);
    assert!(
        reports
            .iter()
            .any(|r| r.contains("MUXEN off") && r.contains("moves no data")),
        "{reports:?}"
    );
}
