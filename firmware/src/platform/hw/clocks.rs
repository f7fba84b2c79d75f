//! Clocks: 12 MHz crystal -> PLL0 (M = 100, N = 6, FCCO = 400 MHz) -> CCLKCFG = 3 -> 100 MHz
//! (UM10360 chapter 4, hardware-facts section 7; the Keil/CMSIS `system_LPC17xx.c` values).
//!
//! Order (UM10360 4.5.13, "PLL0 setup sequence"): flash wait states first (FLASHCFG, so the
//! flash keeps up when the clock rises), PCLKSEL while PLL0 is still disconnected, main
//! oscillator on and stable, then disconnect/disable PLL0, select the source, configure, enable,
//! divide, wait for lock, connect. Each PLL0CON/PLL0CFG write takes effect only after the feed
//! sequence 0xAA, 0x55. Both waits (OSCSTAT, PLOCK0) are bounded; without the crystal PLL0 runs
//! from the 4 MHz IRC (M = 75, N = 2, FCCO = 300 MHz, CCLKCFG = 2 -> 100 MHz, +-1 %); without
//! lock the CPU stays on the IRC and the error is returned.

use firmware::platform::div::div_u64_u32;
use lpc17xx_pac as pac;

/// The CPU clock this module configures.
pub const CCLK_HZ: u32 = 100_000_000;

/// Crystal frequency of the board.
pub const XTAL_HZ: u32 = 12_000_000;

/// Internal RC oscillator frequency.
pub const IRC_HZ: u32 = 4_000_000;

/// FLASHCFG: FLASHTIM = 4 (5 CPU clocks, up to 100 MHz) in bits 15:12; the low bits keep
/// their reset value 0x03A as UM10360 4.9 requires.
const FLASHCFG_100MHZ: u32 = 0x403A;
/// FLASHCFG safe value for any clock (6 CPU clocks).
const FLASHCFG_SAFE: u32 = 0x503A;

/// PLL0CFG = (N - 1) << 16 | (M - 1): crystal, M = 100, N = 6 -> 2 * 100 * 12 / 6 = 400 MHz.
const PLL0CFG_XTAL: u32 = (5 << 16) | 99;
/// IRC: M = 75, N = 2 -> 2 * 75 * 4 / 2 = 300 MHz.
const PLL0CFG_IRC: u32 = (1 << 16) | 74;
/// CCLKCFG = divider - 1.
const CCLKCFG_XTAL: u32 = 3; // 400 / 4 = 100 MHz
const CCLKCFG_IRC: u32 = 2; // 300 / 3 = 100 MHz

/// CCLK from PLL0 for the input `fin_hz`, a PLL0CFG/PLL0STAT value (M - 1 in bits 14:0,
/// N - 1 in bits 23:16) and a CCLKCFG value: FCCO = 2 * M * Fin / N, CCLK = FCCO / (CCLKCFG + 1).
const fn pll0_cclk_hz(fin_hz: u32, cfg: u32, cclkcfg: u32) -> u32 {
    let m = (cfg & 0x7FFF) as u64 + 1;
    let n = ((cfg >> 16) & 0xFF) + 1;
    let div = (cclkcfg & 0xFF) + 1;
    // floor(floor(x / n) / div) == floor(x / (n * div)); n * div <= 2^16.
    div_u64_u32(2 * m * fin_hz as u64, n * div) as u32
}

/// FCCO of a configuration (must be 275..=550 MHz, UM10360 4.5.10).
const fn pll0_fcco_hz(fin_hz: u32, cfg: u32) -> u32 {
    pll0_cclk_hz(fin_hz, cfg, 0)
}

// Both configurations give 100 MHz with FCCO in range.
const _: () = assert!(pll0_cclk_hz(XTAL_HZ, PLL0CFG_XTAL, CCLKCFG_XTAL) == CCLK_HZ);
const _: () = assert!(pll0_cclk_hz(IRC_HZ, PLL0CFG_IRC, CCLKCFG_IRC) == CCLK_HZ);
const _: () = assert!(pll0_fcco_hz(XTAL_HZ, PLL0CFG_XTAL) == 400_000_000);
const _: () = assert!(pll0_fcco_hz(IRC_HZ, PLL0CFG_IRC) == 300_000_000);
const _: () = {
    let (a, b) = (
        pll0_fcco_hz(XTAL_HZ, PLL0CFG_XTAL),
        pll0_fcco_hz(IRC_HZ, PLL0CFG_IRC),
    );
    assert!(a >= 275_000_000 && a <= 550_000_000 && b >= 275_000_000 && b <= 550_000_000);
};

const SCS_OSCEN: u32 = 1 << 5;
const SCS_OSCSTAT: u32 = 1 << 6;
const PLL0STAT_PLLE: u32 = 1 << 24;
const PLL0STAT_PLLC: u32 = 1 << 25;
const PLL0STAT_PLOCK: u32 = 1 << 26;
const PLL0CON_ENABLE: u32 = 1;
const PLL0CON_CONNECT: u32 = 2;

/// Poll budget for OSCSTAT: each read is a few cycles at 4 MHz; the crystal starts in about
/// 1 ms, 100 000 polls are > 50 ms.
const OSC_POLLS: u32 = 100_000;
/// Poll budget for PLOCK0 (lock takes ~100 us).
const LOCK_POLLS: u32 = 100_000;

/// Why the 100 MHz setup did not complete.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ClockError {
    /// PLL0 did not lock within the poll budget: CPU on the 4 MHz IRC.
    PllLockTimeout,
}

/// Which oscillator feeds PLL0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ClockSource {
    /// The 12 MHz crystal.
    Crystal,
    /// The internal RC oscillator (the crystal did not start).
    Irc,
}

/// The clock setup in effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct Clocks {
    /// Source of PLL0 (or of CCLK when PLL0 is not connected).
    pub source: ClockSource,
    /// Whether PLL0 is connected.
    pub pll_connected: bool,
    /// CPU clock in Hz.
    pub cclk_hz: u32,
}

fn feed(syscon: &pac::SYSCON) {
    // SAFETY: the feed register accepts any value; 0xAA then 0x55 commits PLL0CON/CFG.
    syscon.pll0feed.write(|w| unsafe { w.bits(0xAA) });
    syscon.pll0feed.write(|w| unsafe { w.bits(0x55) });
}

fn pll0con(syscon: &pac::SYSCON, value: u32) {
    // SAFETY: PLL0CON bits 0 (enable) and 1 (connect); committed by the feed.
    syscon.pll0con.write(|w| unsafe { w.bits(value) });
    feed(syscon);
}

fn wait(mut done: impl FnMut() -> bool, polls: u32) -> bool {
    for _ in 0..polls {
        if done() {
            return true;
        }
    }
    false
}

/// Sets up 100 MHz from the crystal (or the IRC). Call once, first thing in `init`, with
/// interrupts off (RTIC's init runs so).
pub fn init(syscon: &pac::SYSCON) -> Result<(), ClockError> {
    // Wait states for the final clock before raising it (safe value during the switch).
    // SAFETY (all raw writes below): documented register values of UM10360 chapter 4.
    syscon.flashcfg.write(|w| unsafe { w.bits(FLASHCFG_SAFE) });

    // Peripheral clocks = CCLK / 1 for SPI, SSP0, SSP1, TIMER1, TIMER2, PWM1, CAN1/CAN2/ACF
    // (PCLKSEL 01; the three CAN clocks must be equal, UM10360 4.7.3); set while PLL0 is
    // disconnected (UM10360 4.7.3 note / errata: PCLKSELx must not change with PLL0
    // connected). WDT keeps its own clock (IRC).
    let sel0 = syscon.pclksel0.read().bits();
    let sel0 = (sel0
        & !((0b11 << 4)
            | (0b11 << 12)
            | (0b11 << 16)
            | (0b11 << 20)
            | (0b11 << 26)
            | (0b11 << 28)
            | (0b11 << 30)))
        | (0b01 << 4) // TIMER1
        | (0b01 << 12) // PWM1 (LDAC grid, same ticks as TIMER1)
        | (0b01 << 16) // SPI
        | (0b01 << 20) // SSP1
        | (0b01 << 26) // CAN1
        | (0b01 << 28) // CAN2 (unused, but equal to CAN1)
        | (0b01 << 30); // CAN acceptance filter
    let sel1 = syscon.pclksel1.read().bits();
    let sel1 = (sel1 & !((0b11 << 10) | (0b11 << 12))) | (0b01 << 10) // SSP0
        | (0b01 << 12); // TIMER2

    // Disconnect and disable PLL0 if a debugger or bootloader left it running.
    let stat = syscon.pll0stat.read().bits();
    if stat & PLL0STAT_PLLC != 0 {
        pll0con(syscon, PLL0CON_ENABLE);
    }
    if stat & PLL0STAT_PLLE != 0 {
        pll0con(syscon, 0);
    }
    syscon.cclkcfg.write(|w| unsafe { w.bits(0) }); // CCLK = PLL0 input (IRC) / 1
    syscon.pclksel0.write(|w| unsafe { w.bits(sel0) });
    syscon.pclksel1.write(|w| unsafe { w.bits(sel1) });

    // Main oscillator, range 1-20 MHz (OSCRANGE = 0).
    syscon.scs.write(|w| unsafe { w.bits(SCS_OSCEN) });
    let crystal = wait(|| syscon.scs.read().bits() & SCS_OSCSTAT != 0, OSC_POLLS);
    let (clksrc, cfg, div) = if crystal {
        (1, PLL0CFG_XTAL, CCLKCFG_XTAL)
    } else {
        (0, PLL0CFG_IRC, CCLKCFG_IRC)
    };
    syscon.clksrcsel.write(|w| unsafe { w.bits(clksrc) });
    syscon.pll0cfg.write(|w| unsafe { w.bits(cfg) });
    feed(syscon);
    pll0con(syscon, PLL0CON_ENABLE);
    syscon.cclkcfg.write(|w| unsafe { w.bits(div) });
    if !wait(
        || syscon.pll0stat.read().bits() & PLL0STAT_PLOCK != 0,
        LOCK_POLLS,
    ) {
        pll0con(syscon, 0);
        syscon.cclkcfg.write(|w| unsafe { w.bits(0) });
        return Err(ClockError::PllLockTimeout);
    }
    pll0con(syscon, PLL0CON_ENABLE | PLL0CON_CONNECT);
    let connected = wait(
        || {
            syscon.pll0stat.read().bits() & (PLL0STAT_PLLE | PLL0STAT_PLLC)
                == PLL0STAT_PLLE | PLL0STAT_PLLC
        },
        LOCK_POLLS,
    );
    if !connected {
        return Err(ClockError::PllLockTimeout);
    }
    syscon
        .flashcfg
        .write(|w| unsafe { w.bits(FLASHCFG_100MHZ) });
    Ok(())
}

/// The clock setup in effect (read back from the registers).
pub fn current(syscon: &pac::SYSCON) -> Clocks {
    let stat = syscon.pll0stat.read().bits();
    let pll_connected = stat & (PLL0STAT_PLLE | PLL0STAT_PLLC) == PLL0STAT_PLLE | PLL0STAT_PLLC;
    let source = if syscon.clksrcsel.read().bits() & 0b11 == 1 {
        ClockSource::Crystal
    } else {
        ClockSource::Irc
    };
    let fin = match source {
        ClockSource::Crystal => XTAL_HZ,
        ClockSource::Irc => IRC_HZ,
    };
    let cclkcfg = syscon.cclkcfg.read().bits();
    let cclk_hz = if pll_connected {
        pll0_cclk_hz(fin, stat, cclkcfg)
    } else {
        fin / ((cclkcfg & 0xFF) + 1)
    };
    Clocks {
        source,
        pll_connected,
        cclk_hz,
    }
}

/// Powers the peripherals the firmware uses (PCONP): TIMER1 b2, PWM1 b6, SPI b8, SSP1 b10,
/// CAN1 b13, GPIO b15, SSP0 b21, TIMER2 b22. The rest keep their reset state.
pub fn enable_peripherals(syscon: &pac::SYSCON) {
    const BITS: u32 =
        (1 << 2) | (1 << 6) | (1 << 8) | (1 << 10) | (1 << 13) | (1 << 15) | (1 << 21) | (1 << 22);
    // SAFETY: PCONP power bits; setting them only powers blocks up.
    syscon
        .pconp
        .modify(|r, w| unsafe { w.bits(r.bits() | BITS) });
}
