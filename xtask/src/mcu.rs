//! What the tools need to know of a board's microcontroller (`firmware::platform::board::Mcu`):
//! which binary is its image, its memory map, and how a probe reaches it.

use crate::image::{MemoryMap, LPC1754_MAP, STM32F103VC_MAP};
use firmware::platform::board::Mcu;

/// The tools' facts of one microcontroller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct McuTools {
    /// The firmware binary that is its application image.
    pub bin: &'static str,
    /// Its flash and SRAM.
    pub map: MemoryMap,
    /// probe-rs's chip name.
    pub probe_rs_chip: &'static str,
    /// Whether probe-rs knows the chip itself (else our target description and flash
    /// algorithm, `xtask/flash-algo`).
    pub probe_rs_builtin: bool,
    /// OpenOCD's target script.
    pub openocd_target: &'static str,
}

/// The facts of `mcu`.
pub const fn of(mcu: Mcu) -> McuTools {
    match mcu {
        Mcu::Lpc1754 => McuTools {
            bin: crate::build::BIN,
            map: LPC1754_MAP,
            probe_rs_chip: crate::target_desc::CHIP,
            probe_rs_builtin: false,
            openocd_target: "target/lpc17xx.cfg",
        },
        Mcu::Stm32f103vc => McuTools {
            bin: "application-stm32f103",
            map: STM32F103VC_MAP,
            // probe-rs's built-in STM32F1 series target (its flash algorithm included).
            probe_rs_chip: "STM32F103VC",
            probe_rs_builtin: true,
            openocd_target: "target/stm32f1x.cfg",
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_product_has_its_binary_and_map() {
        for p in firmware::products::PRODUCTS {
            let t = of(p.board.mcu());
            assert!(t.map.flash.len >= u64::from(p.budget.flash), "{}", p.name);
            // The firmware's Cargo.toml has the binary.
            let manifest = include_str!("../../firmware/Cargo.toml");
            assert!(
                manifest.contains(&format!("name = \"{}\"", t.bin)),
                "{}",
                t.bin
            );
        }
        assert_eq!(of(Mcu::Stm32f103vc).map.flash.start, 0x0800_0000);
    }
}
