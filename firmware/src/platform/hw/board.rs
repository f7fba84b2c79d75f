//! THE pin map of the board (hardware-facts 10.A), in one place, and the board bring-up.
//!
//! Every pin is checked at compile time against the LPC1754FBD80 (LQFP80) "present" list of
//! hardware-facts section 7: a pin that the 80-pin package does not bond out (P0.4/5,
//! P0.19-21, P0.23/24, P0.27/28, P1.16/17, P1.21, P1.27, P2.11-13, ...) fails the build, and so
//! does a pin used twice or the ISP pin P2.10.
//!
//! | function                | pin   | PINSEL fn | notes                                          |
//! |-------------------------|-------|-----------|------------------------------------------------|
//! | ET1100 SPI_CLK          | P0.15 | 3 SCK     | legacy SPI exists only on P0.15-18             |
//! | ET1100 SPI_SEL          | P0.16 | 0 GPIO out| idle high, held low for a whole access         |
//! | ET1100 SPI_DO -> MCU    | P0.17 | 3 MISO    |                                                |
//! | ET1100 SPI_DI <- MCU    | P0.18 | 3 MOSI    | mode 3, 12.5 MHz                               |
//! | ET1100 SPI_IRQ          | P0.22 | 0 GPIO in | falling-edge GPIO IRQ (EINT3 vector), pull-up  |
//! | ET1100 SYNC0            | P1.18 | 3 CAP1.0  | Timer1 capture on the rising edge (TIMER1 IRQ) |
//! | ET1100 EEPROM_LOADED    | P2.4  | 0 GPIO in | PDI alive                                      |
//! | AD5663 SCLK             | P1.20 | 3 SCK0    | SSP0, mode 1, 25 MHz                           |
//! | AD5663 (no SDO)         | P1.23 | 3 MISO0   | unused input of SSP0                           |
//! | AD5663 DIN              | P1.24 | 3 MOSI0   |                                                |
//! | AD5663 SYNC             | P2.2  | 0 GPIO out| idle high (SSEL0 P1.21 is absent on LQFP80)    |
//! | AD5663 LDAC             | P2.3  | 0 GPIO out| idle high, pulsed low at SYNC0; 1 PWM1.4 with output oversampling (`hw::ldac_grid`) |
//! | AD5663 CLR              | P2.6  | 0 GPIO out| held high                                      |
//! | AD7689 CNV              | P0.6  | 3 MAT2.0  | Timer2 match output                            |
//! | AD7689 SCK              | P0.7  | 2 SCK1    | SSP1, mode 0, 16.7 MHz, 16-bit frames          |
//! | AD7689 SDO              | P0.8  | 2 MISO1   |                                                |
//! | AD7689 DIN              | P0.9  | 2 MOSI1   |                                                |
//! | UART0 TXD0 / RXD0       | P0.2/3| 1         | debug / ISP UART (pins only)                   |
//! | CAN1 RD1 / TD1          | P0.0/1| 1         | to the CAN transceiver (UNCONFIRMED: the thesis board has none; see below) |
//!
//! CAN1: UM10360 routes RD1/TD1 to P0.0/P0.1 (function 01) or P0.21/P0.22 (function 11);
//! on LQFP80 P0.21 is not bonded out and P0.22 is the ESC IRQ, so P0.0/P0.1 it is (they
//! are also I2C1, which the board does not use: the CAT1025 sits on I2C2). CAN2 would be
//! P2.7/P2.8 (P0.4/P0.5 are absent on LQFP80). The thesis board has no CAN transceiver:
//! UNCONFIRMED, a board for CAN needs one (e.g. a 3.3 V TJA1051T/3 or SN65HVD230) on
//! P0.0/P0.1.
//!
//! Reserved, not configured (left at reset: GPIO input with pull-up): **P2.10** (ISP entry
//! at reset, pull-up/button only, never an IRQ input), P1.19 (CAP1.1, spare for
//! SYNC1/LATCH1), P0.10/P0.11 (I2C2 to the CAT1025 supervisor; needs open-drain PINMODE_OD
//! when used).

use super::adc::AdcHw;
use super::can::CanPort;
use super::clocks::{self, ClockError, Clocks};
use super::cs_device::CsDevice;
use super::dac::{Dac, LdacPin};
use super::delay::CycleDelay;
use super::esc::{self, Esc};
use super::gpio::{InPin, OutPin, Pin};
use super::gpio_irq::EscIrq;
use super::spi::LegacySpi;
use super::ssp::{Ssp, SspConfig};
use super::timers::Sync0Capture;
use super::wdt::Watchdog;
use embedded_hal::delay::DelayNs;
use firmware::stacks::ethercat::pdi_task::EEPROM_WAIT_MS;
use lpc17xx_pac as pac;

/// PINMODE (2 bits per pin): the pad's resistor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pull {
    /// 00: pull-up (reset value).
    Up = 0b00,
    /// 10: neither pull-up nor pull-down.
    None = 0b10,
    /// 11: pull-down.
    Down = 0b11,
}

/// One row of the pin map: pin, PINSEL function 0..=3, pad resistor.
#[derive(Debug, Clone, Copy)]
pub struct PinFunction {
    /// The pin.
    pub pin: Pin,
    /// PINSEL function (0 = GPIO).
    pub func: u8,
    /// PINMODE.
    pub pull: Pull,
}

const fn f(port: u8, pin: u8, func: u8, pull: Pull) -> PinFunction {
    PinFunction {
        pin: Pin::new(port, pin),
        func,
        pull,
    }
}

/// ET1100 SPI_SEL (GPIO chip select).
pub const ESC_CS: Pin = Pin::new(0, 16);
/// ET1100 SPI_IRQ (active low).
pub const ESC_IRQ: Pin = Pin::new(0, 22);
/// ET1100 EEPROM_LOADED.
pub const ESC_EEPROM_LOADED: Pin = Pin::new(2, 4);
/// ET1100 SYNC0 -> CAP1.0.
pub const ESC_SYNC0: Pin = Pin::new(1, 18);
/// AD5663 SYNC (GPIO frame select).
pub const DAC_SYNC: Pin = Pin::new(2, 2);
/// AD5663 LDAC.
pub const DAC_LDAC: Pin = Pin::new(2, 3);
/// AD5663 CLR.
pub const DAC_CLR: Pin = Pin::new(2, 6);
/// AD7689 CNV = MAT2.0.
pub const ADC_CNV: Pin = Pin::new(0, 6);
/// The ISP entry pin: sampled by the boot ROM at reset; never used by the firmware.
pub const ISP: Pin = Pin::new(2, 10);

/// The rows of [`PIN_MAP`] that belong to the ET1100 (its SPI, IRQ, SYNC0, EEPROM_LOADED).
pub const ESC_PINS: usize = 7;

/// The pins the firmware configures, with their PINSEL function and pad resistor.
pub const PIN_MAP: [PinFunction; 20] = [
    // ET1100 on the legacy SPI (the only pins it has).
    f(0, 15, 3, Pull::None), // SCK
    f(0, 16, 0, Pull::None), // SPI_SEL, GPIO out
    f(0, 17, 3, Pull::Up),   // MISO
    f(0, 18, 3, Pull::None), // MOSI
    f(0, 22, 0, Pull::Up),   // SPI_IRQ, GPIO in, falling edge
    f(1, 18, 3, Pull::Down), // SYNC0 -> CAP1.0 (active high)
    f(2, 4, 0, Pull::Down),  // EEPROM_LOADED, GPIO in
    // AD5663 on SSP0.
    f(1, 20, 3, Pull::None), // SCK0
    f(1, 23, 3, Pull::Up),   // MISO0 (the DAC has no SDO)
    f(1, 24, 3, Pull::None), // MOSI0
    f(2, 2, 0, Pull::None),  // SYNC, GPIO out
    f(2, 3, 0, Pull::None),  // LDAC, GPIO out
    f(2, 6, 0, Pull::None),  // CLR, GPIO out
    // AD7689 on SSP1, CNV from Timer2.
    f(0, 6, 3, Pull::None), // MAT2.0 = CNV
    f(0, 7, 2, Pull::None), // SCK1
    f(0, 8, 2, Pull::Up),   // MISO1 (SDO)
    f(0, 9, 2, Pull::None), // MOSI1 (DIN)
    // UART0 (debug / ISP): TXD0 only here, RXD0 below.
    f(0, 2, 1, Pull::None),
    // CAN1 to the transceiver.
    f(0, 0, 1, Pull::Up),   // RD1
    f(0, 1, 1, Pull::None), // TD1
];

/// Pins bonded out on the LQFP80 package, one mask per port P0..P4 (hardware-facts 7):
/// P0.0-3, 6-11, 15-18, 22, 25, 26, 29, 30; P1.0, 1, 4, 8-10, 14, 15, 18-20, 22-26, 28-31;
/// P2.0-10; none of P3; P4.28, 29. 52 pins in total.
pub const LQFP80_PRESENT: [u32; 5] = [0x6647_8FCF, 0xF7DC_C713, 0x0000_07FF, 0, 0x3000_0000];

/// The PINSEL function of `pin` in [`PIN_MAP`] (4 = not in the map).
pub const fn func_of(pin: Pin) -> u8 {
    let mut i = 0;
    while i < PIN_MAP.len() {
        if PIN_MAP[i].pin.port == pin.port && PIN_MAP[i].pin.pin == pin.pin {
            return PIN_MAP[i].func;
        }
        i += 1;
    }
    4
}

/// Whether the LQFP80 package bonds out `pin`.
pub const fn present(pin: Pin) -> bool {
    pin.port < 5 && pin.pin < 32 && LQFP80_PRESENT[pin.port as usize] & (1 << pin.pin) != 0
}

// Compile-time checks of the pin map: every pin exists on LQFP80, none is used twice, the
// ISP pin is not used, and the functions are 0..=3. (RXD0 P0.3 is configured separately.)
const _: () = {
    let mut total = 0;
    let mut port = 0;
    while port < 5 {
        total += LQFP80_PRESENT[port].count_ones();
        port += 1;
    }
    assert!(total == 52, "the LQFP80 has 52 GPIO pins");
    let mut i = 0;
    while i < PIN_MAP.len() {
        let p = PIN_MAP[i].pin;
        assert!(
            present(p),
            "pin map uses a pin that LQFP80 does not bond out"
        );
        assert!(PIN_MAP[i].func <= 3, "PINSEL functions are 0..=3");
        assert!(
            !(p.port == ISP.port && p.pin == ISP.pin),
            "P2.10 is the ISP pin"
        );
        let mut j = i + 1;
        while j < PIN_MAP.len() {
            let q = PIN_MAP[j].pin;
            assert!(!(p.port == q.port && p.pin == q.pin), "pin used twice");
            j += 1;
        }
        i += 1;
    }
    assert!(present(UART0_RX.pin));
    // The named pins carry the function the drivers expect.
    assert!(func_of(ESC_CS) == 0 && func_of(ESC_IRQ) == 0 && func_of(ESC_EEPROM_LOADED) == 0);
    assert!(func_of(ESC_SYNC0) == 3, "SYNC0 must be CAP1.0 (P1.18 fn 3)");
    assert!(func_of(DAC_SYNC) == 0 && func_of(DAC_LDAC) == 0 && func_of(DAC_CLR) == 0);
    assert!(func_of(ADC_CNV) == 3, "CNV must be MAT2.0 (P0.6 fn 3)");
    // The bootloader configures the first ESC_PINS rows: the ET1100's, ending with
    // EEPROM_LOADED.
    let last = PIN_MAP[ESC_PINS - 1].pin;
    assert!(last.port == ESC_EEPROM_LOADED.port && last.pin == ESC_EEPROM_LOADED.pin);
    assert!(PIN_MAP[1].pin.port == ESC_CS.port && PIN_MAP[1].pin.pin == ESC_CS.pin);
    assert!(present(ISP));
    // The absent pins the design avoids on purpose.
    assert!(
        !present(Pin::new(1, 21)),
        "SSEL0 on P1.21 is absent on LQFP80"
    );
    assert!(!present(Pin::new(2, 11)) && !present(Pin::new(2, 12)) && !present(Pin::new(2, 13)));
};

/// UART0 RXD0 (kept apart from [`PIN_MAP`] only to keep its length readable).
pub const UART0_RX: PinFunction = f(0, 3, 1, Pull::Up);

const PINSEL_BASE: usize = 0x4002_C000;
const PINMODE_OFFSET: usize = 0x40;

/// Writes PINSEL and PINMODE of one pin.
fn apply(_pincon: &pac::PINCONNECT, pf: PinFunction) {
    let index = usize::from(pf.pin.port) * 2 + usize::from(pf.pin.pin / 16);
    let shift = u32::from(pf.pin.pin % 16) * 2;
    let sel = (PINSEL_BASE + 4 * index) as *mut u32;
    let mode = (PINSEL_BASE + PINMODE_OFFSET + 4 * index) as *mut u32;
    // SAFETY: PINSELn/PINMODEn of an existing pin (checked at compile time above); the
    // caller owns PINCONNECT, and this runs in init with interrupts off.
    unsafe {
        let v = core::ptr::read_volatile(sel) & !(0b11 << shift);
        core::ptr::write_volatile(sel, v | u32::from(pf.func) << shift);
        let v = core::ptr::read_volatile(mode) & !(0b11 << shift);
        core::ptr::write_volatile(mode, v | (pf.pull as u32) << shift);
    }
}

/// What the tasks receive: each bus and line with its single owner.
pub struct Board {
    /// The clock setup actually reached.
    pub clocks: Clocks,
    /// The ET1100 (PDI task).
    pub esc: Esc,
    /// The ESC IRQ line (PDI task).
    pub esc_irq: EscIrq,
    /// EEPROM_LOADED (the ESC's PDI is operational).
    pub esc_eeprom_loaded: InPin,
    /// SYNC0 capture and the time base (SYNC0 task).
    pub sync0: Sync0Capture,
    /// The AD5663 with its LDAC pin (SYNC0/DAC task).
    pub dac: Dac,
    /// The AD7689 conversion engine: CNV timer + SSP1 (sampler task).
    pub adc: AdcHw,
    /// The MCU watchdog (feeder task).
    pub wdt: Watchdog,
    /// PWM1 for the LDAC grid of output oversampling (SYNC0/DAC task).
    pub pwm1: pac::PWM1,
    /// CAN1, not started (the CAN task's, in a product with a CANopen node).
    pub can: CanPort,
}

/// Errors of the board bring-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum BoardError {
    /// PLL0 did not lock: the CPU runs on the 4 MHz IRC and every peripheral clock is 25x
    /// slower than configured.
    Clock(ClockError),
}

/// Brings the board up: clocks (100 MHz), power and clocks of the peripherals, the pin map,
/// the buses and timers. Peripherals not listed here stay in their reset state.
pub fn init(dp: pac::Peripherals) -> (Board, Result<(), BoardError>) {
    let clock_result = clocks::init(&dp.SYSCON);
    let clocks = clocks::current(&dp.SYSCON);
    clocks::enable_peripherals(&dp.SYSCON);

    for pf in PIN_MAP {
        apply(&dp.PINCONNECT, pf);
    }
    apply(&dp.PINCONNECT, UART0_RX);

    let esc_cs = OutPin::new(ESC_CS, true);
    let dac_sync = OutPin::new(DAC_SYNC, true);
    let dac_ldac = OutPin::new(DAC_LDAC, true);
    let _dac_clr = OutPin::new(DAC_CLR, true); // held high for ever: never clear

    let spi = LegacySpi::new(dp.SPI);
    let esc = esc::new(CsDevice::new(spi, esc_cs));
    let esc_irq = EscIrq::new(dp.GPIOINT, InPin::new(ESC_IRQ));

    let ssp0 = Ssp::new(dp.SSP0, SspConfig::AD5663);
    let dac = Dac::new(CsDevice::new(ssp0, dac_sync), LdacPin::new(dac_ldac))
        .unwrap_or_else(|e| match e {});
    let ssp1 = Ssp::new(dp.SSP1, SspConfig::AD7689);
    let adc = AdcHw::new(dp.TIMER2, ssp1, dp.GPDMA);
    let sync0 = Sync0Capture::new(dp.TIMER1);
    let wdt = Watchdog::new(dp.WDT);
    let can = CanPort {
        can: dp.CAN1,
        af: dp.CANAF,
    };

    let board = Board {
        clocks,
        esc,
        esc_irq,
        esc_eeprom_loaded: InPin::new(ESC_EEPROM_LOADED),
        sync0,
        dac,
        adc,
        wdt,
        pwm1: dp.PWM1,
        can,
    };
    (board, clock_result.map_err(BoardError::Clock))
}

/// What the bootloader uses of the board: the ESC and its EEPROM_LOADED line. (Only the
/// bootloader, which includes this hardware layer too, builds one.)
#[allow(dead_code)]
pub struct BootBoard {
    /// The ET1100.
    pub esc: Esc,
    /// EEPROM_LOADED (the ESC's PDI is operational).
    pub esc_eeprom_loaded: InPin,
    /// SPI_IRQ (active low; the bootloader's idle wait ends on its falling edge).
    pub esc_irq: InPin,
}

/// Brings up what the bootloader needs after [`clocks::init`]: the ESC's pins of the pin map
/// (its first [`ESC_PINS`] rows) and the legacy SPI (powered at reset, PCONP bit 8). Nothing
/// else is touched: the DAC keeps driving what it drove, the ADC and timers stay in reset.
#[allow(dead_code)]
pub fn init_bootloader(pincon: &pac::PINCONNECT, spi: pac::SPI) -> BootBoard {
    for pf in PIN_MAP.iter().take(ESC_PINS) {
        apply(pincon, *pf);
    }
    let esc_cs = OutPin::new(ESC_CS, true);
    BootBoard {
        esc: esc::new(CsDevice::new(LegacySpi::new(spi), esc_cs)),
        esc_eeprom_loaded: InPin::new(ESC_EEPROM_LOADED),
        esc_irq: InPin::new(ESC_IRQ),
    }
}

/// How long [`wait_esc_eeprom_loaded`] waits: [`EEPROM_WAIT_MS`], the bound the virtual
/// board's model of init uses too.
const ESC_EEPROM_WAIT_NS: u64 = EEPROM_WAIT_MS as u64 * 1_000_000;

/// Time between two polls of EEPROM_LOADED in [`wait_esc_eeprom_loaded`].
const ESC_EEPROM_POLL_NS: u32 = 100_000;

/// Waits for EEPROM_LOADED (the ESC's PDI works only after its EEPROM has been loaded), at
/// most [`EEPROM_WAIT_MS`] on the Timer1 time base, polling every 100 us. `false` on
/// timeout; the PDI task then starts the application when the pin rises. Call from `init`
/// (the MCU watchdog is not running yet).
///
/// The time base is Timer1's counter (`time`, started by [`init`]), not a count of delay
/// loops, whose cycles per iteration depend on the core and the flash. Should the timer not
/// count, the number of polls still ends the wait: each poll delays at least
/// [`ESC_EEPROM_POLL_NS`], so the count never cuts the timed wait short. Without PLL0 the
/// timer and the CPU run slower and the wait is longer, still bounded.
pub fn wait_esc_eeprom_loaded(pin: &InPin, time: &Sync0Capture) -> bool {
    const POLLS: u64 = ESC_EEPROM_WAIT_NS / ESC_EEPROM_POLL_NS as u64;
    let start = time.now_ns();
    for _ in 0..POLLS {
        if pin.is_high() {
            return true;
        }
        if time.now_ns().wrapping_sub(start) >= ESC_EEPROM_WAIT_NS {
            break;
        }
        CycleDelay.delay_ns(ESC_EEPROM_POLL_NS);
    }
    pin.is_high()
}
