//! The independent watchdog (IWDG, on the ~40 kHz LSI): resets the chip when the tick task
//! (the lowest priority) does not feed it within about 100 ms.

use super::{pac, read, write};

/// Period between feeds (ms): the tick feeds it every 10 ms.
pub const FEED_PERIOD_MS: u32 = 10;

/// IWDG_KR keys.
const KEY_START: u16 = 0xCCCC;
const KEY_UNLOCK: u16 = 0x5555;
const KEY_FEED: u16 = 0xAAAA;
/// Prescaler /32: 1.25 kHz from the nominal 40 kHz LSI (30..60 kHz: 67..133 ms below).
const PR_DIV32: u16 = 3;
/// 100 ms at 1.25 kHz.
const RELOAD: u16 = 125;
/// RCC_CSR: reset by the IWDG; remove the reset flags.
const IWDGRSTF: u32 = 1 << 29;
const RMVF: u32 = 1 << 24;

/// The watchdog (owner: the tick task).
pub struct Watchdog {
    iwdg: pac::IWDG,
    caused_reset: bool,
}

impl Watchdog {
    /// Reads and clears the reset cause; not started.
    pub fn new(iwdg: pac::IWDG, rcc: &pac::rcc::RegisterBlock) -> Self {
        let caused_reset = read(rcc.csr()) & IWDGRSTF != 0;
        write(rcc.csr(), read(rcc.csr()) | RMVF);
        Self { iwdg, caused_reset }
    }

    /// Whether the last reset was the watchdog's.
    pub fn caused_reset(&self) -> bool {
        self.caused_reset
    }

    /// Starts it (it cannot be stopped).
    pub fn start(&mut self) {
        write(self.iwdg.kr(), KEY_START);
        write(self.iwdg.kr(), KEY_UNLOCK);
        write(self.iwdg.pr(), PR_DIV32);
        write(self.iwdg.rlr(), RELOAD);
        write(self.iwdg.kr(), KEY_FEED);
    }

    /// Feeds it.
    pub fn feed(&mut self) {
        write(self.iwdg.kr(), KEY_FEED);
    }
}
