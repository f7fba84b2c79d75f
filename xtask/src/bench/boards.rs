//! Both boards side by side (docs/book/stm32-cosim.md): the STM32F103 product's image swept on
//! the co-simulated STM32F103 exactly as group 7 sweeps the LPC1754 image, whose figures it
//! reuses (`lpc1754-cosim boards --lpc-figures`), as a table of the shortest sustained DC
//! cycle, SYNC0 -> LDAC and the CPU load there.

use crate::build;
use crate::util::Result;
use firmware::platform::board::Mcu;
use std::path::Path;

/// Builds the STM32 product's image and returns the table's lines; `lpc_figures`: group 7's
/// JSON.
pub fn lines(quick: bool, lpc_figures: &Path) -> Result<Vec<String>> {
    let product = firmware::products::PRODUCTS
        .iter()
        .copied()
        .find(|p| p.board.mcu() == Mcu::Stm32f103vc)
        .ok_or("no STM32F103 product")?;
    let out = build::build(&build::Args::of(product))?;
    let figures = lpc_figures.display().to_string();
    let mut args = vec!["boards", "--lpc-figures", figures.as_str()];
    if quick {
        args.push("--quick");
    }
    super::cosim_cmd::lines(&args, &out.elf)
}
