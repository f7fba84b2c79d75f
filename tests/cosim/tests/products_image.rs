//! SYSTEM TEST ON EVERY PRODUCT'S IMAGE: each product's release programs (its board's
//! bootloader and its application, as `cargo xtask build` made them beside the default
//! product's, `lpc1754_cosim::run::image_path_of`) boot on the co-simulated LPC1754, and a
//! real master (ethercrab, in process) reads the product's identity from the SII and over
//! SDO and brings it to OP, where the process data run with the DAC loaded from the
//! master's outputs. The long image tests run once, on the default product
//! (`system_image.rs`); the CAN product's node is `can_image.rs`'s.

mod common;

use common::boot_to_op;
use firmware::products::PRODUCTS;

#[test]
fn every_product_image_boots_shows_its_identity_and_reaches_op() {
    // The STM32F103 product's run is stm32_image.rs's (with its DC cycles).
    for product in PRODUCTS
        .iter()
        .filter(|p| p.board.mcu() == firmware::platform::board::Mcu::Lpc1754)
    {
        let value = 0x2000;
        let (dac, _) = boot_to_op(product, value);
        assert_eq!(
            dac,
            firmware::io::analog::scaling::ao_to_dac_code(value),
            "{}: AO 1 on the DAC",
            product.name
        );
    }
}
