//! Bring-up of the STM32 board in order: clocks, the peripherals' clocks, the pin table,
//! then each part on its pins. The only place that takes the PAC's peripherals apart.

use super::clocks::{self, ClockError};
use super::esc::{self, Esc, EscIrq};
use super::gpio::{self, pin_of, InPin};
use super::sync0::{self, Sync0Capture};
use super::{adc::AdcHw, dac, dac::Dac, pac, time, wdt::Watchdog};
use firmware::platform::stm32f1::pins::Signal;
use firmware::stacks::ethercat::pdi_task::EEPROM_WAIT_MS;

/// The board's parts, each for its task.
pub struct Board {
    pub esc: Esc,
    pub esc_irq: EscIrq,
    pub esc_eeprom_loaded: InPin,
    pub sync0: Sync0Capture,
    pub dac: Dac,
    pub adc: AdcHw,
    pub wdt: Watchdog,
}

/// Brings the board up; the clock error, if any (the board then runs on the 8 MHz HSI:
/// every time derived from 72 MHz is then wrong by 9x, which the log says).
pub fn init(
    dp: pac::Peripherals,
    dcb: &mut cortex_m::peripheral::DCB,
    dwt: &mut cortex_m::peripheral::DWT,
) -> (Board, Result<(), ClockError>) {
    let clock = clocks::init(&dp.RCC, &dp.FLASH);
    clocks::enable_peripherals(&dp.RCC);
    time::init(dcb, dwt);
    gpio::configure_all();
    let esc = esc::init(dp.FSMC);
    let esc_irq = EscIrq::new(dp.EXTI, &dp.AFIO);
    let (sync0, ldac) = sync0::init(dp.TIM8);
    let board = Board {
        esc,
        esc_irq,
        esc_eeprom_loaded: InPin::new(pin_of(Signal::EscEepromLoaded)),
        sync0,
        dac: dac::new(dp.SPI2, ldac),
        adc: AdcHw::new(dp.TIM3, dp.SPI1, dp.DMA1),
        wdt: Watchdog::new(dp.IWDG, &dp.RCC),
    };
    (board, clock)
}

/// Waits for EEPROM_LOADED (the ESC's PDI works only after its EEPROM is loaded), at most
/// `EEPROM_WAIT_MS` on the time base. `false` on timeout; the PDI task then starts the
/// application when the pin rises. Call from `init` (the watchdog is not running yet).
pub fn wait_esc_eeprom_loaded(pin: &InPin) -> bool {
    let limit = u64::from(EEPROM_WAIT_MS) * 1_000_000;
    let start = time::now_ns();
    // Polled without a pause (nothing else runs yet): the wait ends on the time base's
    // limit, not up to a cycle-counted delay after it.
    while !pin.is_high() {
        if time::now_ns().wrapping_sub(start) >= limit {
            return false;
        }
    }
    true
}
