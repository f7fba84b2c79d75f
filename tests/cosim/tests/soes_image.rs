//! SYSTEM TEST: SOES (the C stack, built for the thesis board from ../shared/peers/soes
//! with the port in tests/soes) on the co-simulated LPC1754, driven by ethercrab in
//! process: INIT -> PRE-OP -> SAFE-OP -> OP with DC SYNC0, then DC cycles in which every
//! SYNC0 edge latches the pair the frame before it carried into the AD5663 and the AI
//! values are the AD7689's inputs (the bench's criteria, `DcCheck`).
//!
//! `cargo xtask test` builds the SOES image first and passes it in `SOES_IMAGE`; without it
//! the test looks for `cargo xtask peer soes`'s output and fails, saying so, when missing.

use lpc1754_cosim::bench::dc_run_program;
use lpc1754_cosim::peer::soes;

#[test]
fn soes_reaches_op_with_ethercrab_and_latches_every_dc_pair() {
    let image = soes::load().unwrap();
    assert!(
        image.boot_rom_check().is_ok(),
        "the boot ROM starts the image"
    );
    let run = dc_run_program(&soes::program(&image).unwrap(), 1_000_000, 300, false, None).unwrap();
    let facts = &run.after;
    assert!(
        facts.fault.is_none() && facts.reports.is_empty(),
        "{}",
        facts.summary()
    );
    assert!(
        run.check.sustained(),
        "{:?}\n{}",
        run.check,
        facts.summary()
    );
    assert_eq!(run.check.edges, 300);
    assert!(facts.cclk_hz == 100_000_000, "PLL0 at 100 MHz");
}
