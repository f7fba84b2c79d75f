//! The one pin table of the STM32F103VC board (LQFP100), and what follows from it: the GPIO
//! configuration registers, the EXTI line of the ESC's IRQ, the DMA channels of the
//! converters' SPI ports and the interrupt numbers.
//!
//! Functions of the pins (which FSMC, SPI and timer signal a GPIO carries without remap)
//! are RM0008's / the STM32F103xC/D/E datasheet's, as other FSMC boards wire them. The
//! seed gives no pin numbers: the choice of the ESC's IRQ, SYNC0, LDAC and the converters'
//! ports is this board's. **UNCONFIRMED**: the LQFP100 package pin numbers
//! ([`Assignment::package_pin`]) are from memory of the datasheet's pin table, no copy of it
//! was at hand; check them against DS5792 before a layout.
//!
//! Kept free: USART1 on PA9/PA10 (the ROM bootloader's UART, seed 004 programs through it),
//! PA13/PA14 (SWD, for probe-rs). Lost to the FSMC: I2C1 on PB6/PB7 (PB7 is NADV).

/// A GPIO port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Port {
    /// GPIOA.
    A,
    /// GPIOB.
    B,
    /// GPIOC.
    C,
    /// GPIOD.
    D,
    /// GPIOE.
    E,
}

impl Port {
    /// The port's code in AFIO_EXTICRx (PA 0, PB 1, ...).
    pub const fn exti_code(self) -> u32 {
        match self {
            Port::A => 0,
            Port::B => 1,
            Port::C => 2,
            Port::D => 3,
            Port::E => 4,
        }
    }
}

/// A GPIO pin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pin {
    /// Its port.
    pub port: Port,
    /// 0..=15.
    pub number: u8,
}

const fn pin(port: Port, number: u8) -> Pin {
    Pin { port, number }
}

/// How a pin is configured (RM0008 §9.1: the MODE/CNF nibble of GPIOx_CRL/CRH).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Alternate function push-pull, 50 MHz (the FSMC's outputs and data, SPI SCK/MOSI,
    /// timer outputs).
    AfPushPull,
    /// Input without pull (the ESC's and the ADC's push-pull outputs, NWAIT, capture).
    InputFloating,
    /// General purpose output push-pull, 50 MHz.
    OutputPushPull,
    /// Left at reset (input floating): used by the ROM or the debugger, not the firmware.
    Reset,
}

impl Mode {
    /// The 4-bit CNF:MODE field.
    pub const fn nibble(self) -> u32 {
        match self {
            Mode::AfPushPull => 0b1011,
            Mode::InputFloating | Mode::Reset => 0b0100,
            Mode::OutputPushPull => 0b0011,
        }
    }
}

/// An FSMC signal of bank 1 in multiplexed mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FsmcSignal {
    /// DA\[n\]: address (latched) then data.
    Da(u8),
    /// Read strobe (to the ESC's RD).
    Noe,
    /// Write strobe (to the ESC's WR).
    Nwe,
    /// Wait input (from the ESC's BUSY).
    Nwait,
    /// Chip select of bank 1 (to the ESC's CS).
    Ne1,
    /// Low byte lane (to the ESC's ADR\[0\]).
    Nbl0,
    /// High byte lane (to the ESC's BHE).
    Nbl1,
    /// Address valid (through the inverter to the latches' LE).
    Nadv,
}

/// What a pin carries on this board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// The ESC's parallel bus.
    Fsmc(FsmcSignal),
    /// The ESC's IRQ (push-pull active low) on an EXTI line.
    EscIrq,
    /// The ESC's EEPROM_LOADED (the PDI is operational).
    EscEepromLoaded,
    /// The ESC's SYNC0 (push-pull active high) into TIM8_CH1's capture.
    EscSync0,
    /// The AD5663's LDAC from TIM8_CH2 (a one-pulse triggered by SYNC0 can drive it).
    DacLdac,
    /// The AD5663's SYNC (frame), a GPIO: the SPI's NSS does not pulse between frames.
    DacSync,
    /// SPI2 SCK to the AD5663.
    DacSck,
    /// SPI2 MOSI to the AD5663.
    DacDin,
    /// The AD7689's CNV from TIM3_CH3 (PWM at the sample rate).
    AdcCnv,
    /// SPI1 SCK to the AD7689.
    AdcSck,
    /// SPI1 MISO from the AD7689's SDO.
    AdcSdo,
    /// SPI1 MOSI to the AD7689's DIN (the CFG word).
    AdcDin,
    /// SWD data (probe-rs).
    SwdIo,
    /// SWD clock.
    SwClk,
    /// USART1 TX of the ROM bootloader.
    IspTx,
    /// USART1 RX of the ROM bootloader.
    IspRx,
}

/// One line of the pin table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Assignment {
    /// The GPIO.
    pub pin: Pin,
    /// LQFP100 pin number (UNCONFIRMED, see the module).
    pub package_pin: u8,
    /// What it carries.
    pub signal: Signal,
    /// How it is configured.
    pub mode: Mode,
}

const fn a(port: Port, number: u8, package_pin: u8, signal: Signal, mode: Mode) -> Assignment {
    Assignment {
        pin: pin(port, number),
        package_pin,
        signal,
        mode,
    }
}

use FsmcSignal::*;
use Mode::*;
use Port::*;
use Signal::*;

/// The pin table.
pub const PINS: [Assignment; 38] = [
    // FSMC bank 1, multiplexed: DA0..DA15.
    a(D, 14, 61, Fsmc(Da(0)), AfPushPull),
    a(D, 15, 62, Fsmc(Da(1)), AfPushPull),
    a(D, 0, 81, Fsmc(Da(2)), AfPushPull),
    a(D, 1, 82, Fsmc(Da(3)), AfPushPull),
    a(E, 7, 38, Fsmc(Da(4)), AfPushPull),
    a(E, 8, 39, Fsmc(Da(5)), AfPushPull),
    a(E, 9, 40, Fsmc(Da(6)), AfPushPull),
    a(E, 10, 41, Fsmc(Da(7)), AfPushPull),
    a(E, 11, 42, Fsmc(Da(8)), AfPushPull),
    a(E, 12, 43, Fsmc(Da(9)), AfPushPull),
    a(E, 13, 44, Fsmc(Da(10)), AfPushPull),
    a(E, 14, 45, Fsmc(Da(11)), AfPushPull),
    a(E, 15, 46, Fsmc(Da(12)), AfPushPull),
    a(D, 8, 55, Fsmc(Da(13)), AfPushPull),
    a(D, 9, 56, Fsmc(Da(14)), AfPushPull),
    a(D, 10, 57, Fsmc(Da(15)), AfPushPull),
    // FSMC control.
    a(D, 4, 85, Fsmc(Noe), AfPushPull),
    a(D, 5, 86, Fsmc(Nwe), AfPushPull),
    a(D, 6, 87, Fsmc(Nwait), InputFloating),
    a(D, 7, 88, Fsmc(Ne1), AfPushPull),
    a(E, 0, 97, Fsmc(Nbl0), AfPushPull),
    a(E, 1, 98, Fsmc(Nbl1), AfPushPull),
    a(B, 7, 93, Fsmc(Nadv), AfPushPull),
    // The ESC's other pins.
    a(C, 0, 15, EscIrq, InputFloating),
    a(C, 1, 16, EscEepromLoaded, InputFloating),
    a(C, 6, 63, EscSync0, InputFloating),
    // AD5663 on SPI2 (write only), LDAC from TIM8.
    a(C, 7, 64, DacLdac, AfPushPull),
    a(B, 12, 51, DacSync, OutputPushPull),
    a(B, 13, 52, DacSck, AfPushPull),
    a(B, 15, 54, DacDin, AfPushPull),
    // AD7689 on SPI1, CNV from TIM3.
    a(B, 0, 35, AdcCnv, AfPushPull),
    a(A, 5, 30, AdcSck, AfPushPull),
    a(A, 6, 31, AdcSdo, InputFloating),
    a(A, 7, 32, AdcDin, AfPushPull),
    // Debug and the ROM bootloader's UART: left to them.
    a(A, 13, 72, SwdIo, Reset),
    a(A, 14, 76, SwClk, Reset),
    a(A, 9, 68, IspTx, Reset),
    a(A, 10, 69, IspRx, Reset),
];

/// The assignment of `signal`.
pub const fn find(signal: Signal) -> Option<Assignment> {
    let mut i = 0;
    while i < PINS.len() {
        if same_signal(PINS[i].signal, signal) {
            return Some(PINS[i]);
        }
        i += 1;
    }
    None
}

const fn same_signal(x: Signal, y: Signal) -> bool {
    match (x, y) {
        (Fsmc(Da(m)), Fsmc(Da(n))) => m == n,
        (Fsmc(f), Fsmc(g)) => fsmc_code(f) == fsmc_code(g),
        _ => signal_code(x) == signal_code(y),
    }
}

const fn fsmc_code(f: FsmcSignal) -> u8 {
    match f {
        Da(n) => n,
        Noe => 16,
        Nwe => 17,
        Nwait => 18,
        Ne1 => 19,
        Nbl0 => 20,
        Nbl1 => 21,
        Nadv => 22,
    }
}

const fn signal_code(s: Signal) -> u8 {
    match s {
        Fsmc(_) => 0,
        EscIrq => 1,
        EscEepromLoaded => 2,
        EscSync0 => 3,
        DacLdac => 4,
        DacSync => 5,
        DacSck => 6,
        DacDin => 7,
        AdcCnv => 8,
        AdcSck => 9,
        AdcSdo => 10,
        AdcDin => 11,
        SwdIo => 12,
        SwClk => 13,
        IspTx => 14,
        IspRx => 15,
    }
}

/// GPIOx_CRL and GPIOx_CRH of `port`: the table's pins as configured, the others at reset
/// (input floating, 0x4 per pin).
pub const fn port_config(port: Port) -> (u32, u32) {
    let mut cr = [0x4444_4444u32; 2];
    let mut i = 0;
    while i < PINS.len() {
        let p = PINS[i];
        if p.pin.port.exti_code() == port.exti_code() && p.pin.number < 16 {
            let half = (p.pin.number / 8) as usize;
            let shift = (p.pin.number % 8) as u32 * 4;
            cr[half] = cr[half] & !(0xF << shift) | p.mode.nibble() << shift;
        }
        i += 1;
    }
    (cr[0], cr[1])
}

/// The EXTI line of the ESC's IRQ: its pin number (PC0: EXTI0, its own vector).
pub const ESC_IRQ_EXTI_LINE: u8 = match find(EscIrq) {
    Some(p) => p.pin.number,
    None => 0,
};

/// AFIO_EXTICRx (x = line / 4 + 1) and its value routing the ESC's IRQ pin's port to its
/// line (the other lines at reset, port A).
pub const fn esc_irq_exticr() -> (usize, u32) {
    let line = ESC_IRQ_EXTI_LINE as u32;
    let port = match find(EscIrq) {
        Some(p) => p.pin.port.exti_code(),
        None => 0,
    };
    ((line / 4 + 1) as usize, port << ((line % 4) * 4))
}

/// A DMA request of the converters' SPI ports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DmaRequest {
    /// SPI1 RX: the AD7689's results.
    Spi1Rx,
    /// SPI1 TX: the AD7689's CFG words and clocking.
    Spi1Tx,
    /// SPI2 TX: the AD5663's frames.
    Spi2Tx,
}

impl DmaRequest {
    /// The DMA1 channel (1..=7) the request is wired to (RM0008 Table 78, "DMA1 requests
    /// for each channel": SPI1_RX 2, SPI1_TX 3, SPI2_RX 4, SPI2_TX 5).
    pub const fn dma1_channel(self) -> u8 {
        match self {
            DmaRequest::Spi1Rx => 2,
            DmaRequest::Spi1Tx => 3,
            DmaRequest::Spi2Tx => 5,
        }
    }
}

/// The requests the board uses.
pub const DMA_REQUESTS: [DmaRequest; 3] =
    [DmaRequest::Spi1Rx, DmaRequest::Spi1Tx, DmaRequest::Spi2Tx];

/// Interrupt numbers of the STM32F103 high-density line (RM0008 Table 63; the stm32f1 PAC's
/// `Interrupt`) the board uses.
pub mod irq {
    /// EXTI line 0: the ESC's IRQ (PC0).
    pub const EXTI0: u16 = 6;
    /// DMA1 channel 2: SPI1 RX done (an ADC frame read).
    pub const DMA1_CHANNEL2: u16 = 12;
    /// DMA1 channel 5: SPI2 TX done (a DAC frame sent).
    pub const DMA1_CHANNEL5: u16 = 15;
    /// TIM3: the CNV timer.
    pub const TIM3: u16 = 29;
    /// TIM8 capture/compare: the SYNC0 capture.
    pub const TIM8_CC: u16 = 46;
    /// Interrupts of the part (the NVIC's size).
    pub const COUNT: u16 = 60;

    const _: () = assert!(EXTI0 < TIM8_CC && TIM8_CC < COUNT);
}

/// NVIC priority bits of the STM32F1 (the LPC1754 has 5).
pub const NVIC_PRIO_BITS: u8 = 4;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pin_and_package_pin_once() {
        for (i, p) in PINS.iter().enumerate() {
            assert!(p.pin.number < 16 && (1..=100).contains(&p.package_pin));
            for q in &PINS[i + 1..] {
                assert_ne!(p.pin, q.pin, "{:?} twice", p.pin);
                assert_ne!(
                    p.package_pin, q.package_pin,
                    "package pin {}",
                    p.package_pin
                );
                assert!(!same_signal(p.signal, q.signal), "{:?} twice", p.signal);
            }
        }
    }

    #[test]
    fn the_fsmc_bus_is_complete_and_where_rm0008_puts_it() {
        let da = [
            (D, 14),
            (D, 15),
            (D, 0),
            (D, 1),
            (E, 7),
            (E, 8),
            (E, 9),
            (E, 10),
            (E, 11),
            (E, 12),
            (E, 13),
            (E, 14),
            (E, 15),
            (D, 8),
            (D, 9),
            (D, 10),
        ];
        for (n, (port, number)) in da.into_iter().enumerate() {
            let p = find(Fsmc(Da(n as u8))).unwrap();
            assert_eq!((p.pin, p.mode), (pin(port, number), AfPushPull), "DA{n}");
        }
        let control = [
            (Noe, pin(D, 4)),
            (Nwe, pin(D, 5)),
            (Nwait, pin(D, 6)),
            (Ne1, pin(D, 7)),
            (Nbl0, pin(E, 0)),
            (Nbl1, pin(E, 1)),
            (Nadv, pin(B, 7)),
        ];
        for (s, at) in control {
            assert_eq!(find(Fsmc(s)).unwrap().pin, at, "{s:?}");
        }
        // NWAIT is an input; every other FSMC pin an alternate-function output.
        assert_eq!(find(Fsmc(Nwait)).unwrap().mode, InputFloating);
    }

    #[test]
    fn port_configuration_registers() {
        // GPIOD: PD0/1/4/5/7 AF (0xB), PD6 NWAIT input (0x4), PD2/3 reset; PD8..10, 14, 15
        // AF, PD11..13 reset.
        assert_eq!(port_config(D), (0xB4BB_44BB, 0xBB44_4BBB));
        // GPIOE: PE0/1 AF, PE7..15 AF.
        assert_eq!(port_config(E), (0xB444_44BB, 0xBBBB_BBBB));
        // GPIOA: PA5 SCK AF, PA6 SDO input, PA7 DIN AF; PA9/10/13/14 left at reset.
        assert_eq!(port_config(A), (0xB4B4_4444, 0x4444_4444));
        // GPIOB: PB0 CNV AF, PB7 NADV AF; PB12 SYNC output, PB13/15 AF.
        assert_eq!(port_config(B), (0xB444_444B, 0xB4B3_4444));
        // GPIOC: PC0/1/6 inputs, PC7 LDAC AF.
        assert_eq!(port_config(C), (0xB444_4444, 0x4444_4444));
    }

    #[test]
    fn esc_irq_on_exti0_from_port_c() {
        assert_eq!(ESC_IRQ_EXTI_LINE, 0);
        assert_eq!(esc_irq_exticr(), (1, 0x0002));
    }

    #[test]
    fn each_dma_channel_serves_one_request() {
        for (i, r) in DMA_REQUESTS.iter().enumerate() {
            for q in &DMA_REQUESTS[i + 1..] {
                assert_ne!(r.dma1_channel(), q.dma1_channel());
            }
        }
    }
}
