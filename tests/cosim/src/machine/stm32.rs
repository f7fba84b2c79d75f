//! The STM32F103 board's wiring (seed 004's board, `firmware::platform::stm32f1::pins` on the
//! chip side): the address decode of RM0008's memory map onto the [`crate::stm32`] models,
//! their clocks from RCC, and which pin, configured how, reaches which chip of the virtual
//! board.
//!
//! Routing is strict, as on the LPC1754: FSMC bank 1 reaches the ET1100's µC PDI through the
//! address latch only while every FSMC pin is an alternate-function output (NWAIT PD6 an
//! input) and BCR1 suits the bus (16 bit, multiplexed, PSRAM/NOR, WAITPOL = BUSY's polarity);
//! SPI2 frames reach the AD5663 only on PB13/PB15 (AF) while SYNC (PB12, GPIO output) is low,
//! in mode 1 or 2; SPI1 frames reach the AD7689 only on PA5/PA7 (AF) with PA6 an input while
//! CNV is low, 16 bits in mode 0; CNV is TIM3_CH3 on PB0 (AF); LDAC is TIM8_CH2 on PC7 (AF)
//! or the GPIO; SYNC0 is captured by TIM8_CH1 only with PC6 an input; the ESC's IRQ reaches
//! EXTI0 through AFIO_EXTICR1. A peripheral whose RCC enable bit is 0 does not respond, and
//! an address no model decodes stops the core.

use super::{Cortex, ResetCause, Stop};
use crate::periph::{ns_to_ticks, Tick};
use crate::stm32::gpio::{Pin, PinMode};
use crate::stm32::rcc::{Enable, ResetFlags};
use crate::stm32::{base, dwt, irq, Stm32f103};
use virtual_board::models::esc::parallel::{AddressLatch, BusTiming, ParallelPort};

/// Pins of the board (port A..E = 0..4, pin).
pub mod pins {
    use super::Pin;
    /// FSMC DA0..DA15 (PD14, PD15, PD0, PD1, PE7..PE15, PD8..PD10), NOE PD4, NWE PD5, NE1
    /// PD7, NBL0 PE0, NBL1 PE1, NADV PB7: alternate-function outputs.
    pub const FSMC_OUTPUTS: [Pin; 22] = [
        (3, 14),
        (3, 15),
        (3, 0),
        (3, 1),
        (4, 7),
        (4, 8),
        (4, 9),
        (4, 10),
        (4, 11),
        (4, 12),
        (4, 13),
        (4, 14),
        (4, 15),
        (3, 8),
        (3, 9),
        (3, 10),
        (3, 4),
        (3, 5),
        (3, 7),
        (4, 0),
        (4, 1),
        (1, 7),
    ];
    /// NWAIT (the ESC's BUSY): an input.
    pub const FSMC_NWAIT: Pin = (3, 6);
    /// The ESC's IRQ (EXTI0) and EEPROM_LOADED.
    pub const ESC_IRQ: Pin = (2, 0);
    /// See [`ESC_IRQ`].
    pub const ESC_EEPROM_LOADED: Pin = (2, 1);
    /// SYNC0 -> TIM8_CH1.
    pub const ESC_SYNC0: Pin = (2, 6);
    /// AD5663: SPI2 SCK, MOSI; SYNC (GPIO); LDAC (TIM8_CH2).
    pub const DAC_SCK: Pin = (1, 13);
    /// See [`DAC_SCK`].
    pub const DAC_DIN: Pin = (1, 15);
    /// See [`DAC_SCK`].
    pub const DAC_SYNC: Pin = (1, 12);
    /// See [`DAC_SCK`].
    pub const DAC_LDAC: Pin = (2, 7);
    /// AD7689: SPI1 SCK, MISO, MOSI; CNV (TIM3_CH3).
    pub const ADC_SCK: Pin = (0, 5);
    /// See [`ADC_SCK`].
    pub const ADC_SDO: Pin = (0, 6);
    /// See [`ADC_SCK`].
    pub const ADC_DIN: Pin = (0, 7);
    /// See [`ADC_SCK`].
    pub const ADC_CNV: Pin = (1, 0);
}

/// The chip and the board parts next to it (the ESC's µC pins, the latch).
pub struct Stm32Parts {
    /// The peripherals.
    pub chip: Stm32f103,
    /// The ET1100's µC PDI pins (BUSY timing and counters).
    pub esc_port: ParallelPort,
    latch: AddressLatch,
    /// When the FSMC is free again (the last access's turnaround ends).
    bus_free_ns: u64,
    /// FSMC accesses and the time they took (ns), the core stalled.
    pub fsmc_accesses: u64,
    /// See [`Stm32Parts::fsmc_accesses`].
    pub fsmc_ns: u64,
}

impl Stm32Parts {
    /// The chip at power-on with the ESC's BUSY `timing`.
    pub fn new(timing: BusTiming) -> Self {
        Self {
            chip: Stm32f103::new(crate::stm32::sram::Sram::new()),
            esc_port: ParallelPort::new(timing),
            latch: AddressLatch::default(),
            bus_free_ns: 0,
            fsmc_accesses: 0,
            fsmc_ns: 0,
        }
    }
}

/// A peripheral of the decode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Block {
    Tim3,
    Iwdg,
    Spi2,
    Afio,
    Exti,
    Gpio(usize),
    Spi1,
    Tim8,
    Dma1,
    Rcc,
    Flash,
}

impl Block {
    fn of(addr: u32) -> Option<(Block, u32)> {
        let slot = addr & !0x3FF;
        let b = match slot {
            base::TIM3 => Block::Tim3,
            base::IWDG => Block::Iwdg,
            base::SPI2 => Block::Spi2,
            base::AFIO => Block::Afio,
            base::EXTI => Block::Exti,
            s if (base::GPIOA..base::GPIOA + 5 * 0x400).contains(&s) => {
                Block::Gpio(((s - base::GPIOA) / 0x400) as usize)
            }
            base::SPI1 => Block::Spi1,
            base::TIM8 => Block::Tim8,
            base::DMA1 => Block::Dma1,
            base::RCC => Block::Rcc,
            base::FLASH => Block::Flash,
            _ => return None,
        };
        Some((b, addr - slot))
    }

    fn clock(self) -> Option<Enable> {
        Some(match self {
            Block::Tim3 => Enable::Apb1(1),
            Block::Spi2 => Enable::Apb1(14),
            Block::Afio => Enable::Apb2(0),
            Block::Gpio(n) => Enable::Apb2(2 + n as u8),
            Block::Spi1 => Enable::Apb2(12),
            Block::Tim8 => Enable::Apb2(13),
            Block::Dma1 => Enable::Ahb(0),
            Block::Flash => Enable::Ahb(4),
            Block::Iwdg | Block::Exti | Block::Rcc => return None,
        })
    }
}

impl Stm32Parts {
    /// HCLK of the STM32F103 now.
    pub fn hclk_hz(&self) -> u64 {
        self.chip.rcc.hclk_hz()
    }

    fn tick(&self, cx: &Cortex, block: Block) -> Tick {
        let rcc = &self.chip.rcc;
        Tick {
            now_ns: cx.hw_ns(),
            pclk_hz: match block {
                Block::Tim3 => rcc.apb1_timer_hz(),
                Block::Tim8 => rcc.apb2_timer_hz(),
                Block::Spi1 => rcc.pclk2_hz(),
                Block::Spi2 => rcc.pclk1_hz(),
                _ => rcc.hclk_hz(),
            },
        }
    }

    /// The chip's reset: every peripheral to its reset state (the reset flags in RCC_CSR),
    /// the SRAM kept.
    pub fn reset(&mut self, cause: ResetCause) {
        let flags = match cause {
            ResetCause::Watchdog => ResetFlags::IWDG,
            ResetCause::SysResetReq => ResetFlags::SOFTWARE,
        };
        let sram = self.chip.sram.clone();
        self.chip = Stm32f103::after_reset(sram, flags);
        self.bus_free_ns = 0;
    }

    /// The next event of the chip's peripherals.
    pub fn next_event(&self) -> Option<u64> {
        let c = &self.chip;
        [
            c.tim3.next_event(),
            c.tim8.next_event(),
            c.spi1.next_event(),
            c.spi2.next_event(),
            c.iwdg.next_event(),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// Serves the chip's events due now.
    pub fn service(&mut self, cx: &mut Cortex) {
        let now = cx.hw_ns();
        let t3 = self.tick(cx, Block::Tim3);
        let t8 = self.tick(cx, Block::Tim8);
        let s1 = self.tick(cx, Block::Spi1);
        let s2 = self.tick(cx, Block::Spi2);
        let c = &mut self.chip;
        c.tim3.on_event(t3);
        c.tim8.on_event(t8);
        c.spi1.on_event(s1);
        c.spi2.on_event(s2);
        c.iwdg.on_event(now);
        if c.iwdg.take_reset_request() {
            cx.stop = Some(Stop::Reset(ResetCause::Watchdog));
        }
        self.settle(cx);
    }

    /// After any change: frames to the devices, CNV and LDAC, DMA, interrupt lines,
    /// schedule.
    pub fn settle(&mut self, cx: &mut Cortex) {
        for _ in 0..16 {
            let mut moved = self.spi1_frame(cx);
            moved |= self.spi2_frame(cx);
            self.cnv(cx);
            moved |= self.dma(cx);
            if !moved {
                break;
            }
        }
        self.ldac(cx);
        self.irq_lines(cx);
        cx.reschedule(self.next_event());
    }

    fn irq_lines(&mut self, cx: &mut Cortex) {
        let c = &self.chip;
        let mut lines = vec![
            (irq::EXTI0, c.exti.irq(0)),
            (irq::TIM3, c.tim3.irq()),
            (irq::TIM8_CC, c.tim8.irq_cc()),
            (irq::SPI1, c.spi1.irq()),
            (irq::SPI2, c.spi2.irq()),
        ];
        for n in 0..7 {
            lines.push((irq::DMA1_CHANNEL1 + n as u32, c.dma1.irq(n)));
        }
        for (n, level) in lines {
            cx.scs.set_line(n, level);
        }
        cx.check_preempt = cx.scs.any_pending();
    }

    /// Inputs from the board: the ESC's IRQ (active low) and EEPROM_LOADED, into the pins
    /// and EXTI.
    pub fn refresh_inputs(&mut self, cx: &mut Cortex) {
        let (irq_asserted, loaded) = {
            let esc = cx.io.esc.esc().borrow();
            (esc.irq(), esc.pdi_operational())
        };
        let c = &mut self.chip;
        c.gpio.set_input(pins::ESC_IRQ, !irq_asserted);
        c.gpio.set_input(pins::ESC_EEPROM_LOADED, loaded);
        for line in 0..16u8 {
            let port = c.gpio.exti_port(line);
            if port < 5 {
                let level = c.gpio.level((port, line));
                c.exti.input(u32::from(line), level);
            }
        }
        let level = c.exti.irq(0);
        cx.scs.set_line(irq::EXTI0, level);
        cx.check_preempt |= cx.scs.any_pending();
    }

    /// A SYNC0 rising edge from the ESC now: TIM8_CH1's capture.
    pub fn sync0_edge(&mut self, cx: &mut Cortex) {
        if self.chip.gpio.mode(pins::ESC_SYNC0) != PinMode::Input {
            cx.report("SYNC0 edge: PC6 is not an input (TIM8_CH1): no capture".into());
            return;
        }
        if !self.chip.rcc.enabled(Enable::Apb2(13)) {
            cx.report("SYNC0 edge: TIM8 is not clocked (RCC_APB2ENR bit 13): no capture".into());
            return;
        }
        let t = self.tick(cx, Block::Tim8);
        if self.chip.tim8.capture(t, 0, true) {
            cx.traffic.sync0_captures += 1;
        }
        self.settle(cx);
    }

    /// SYNC0 captures overwritten before the CPU read them.
    pub fn sync0_unserved(&self) -> u64 {
        self.chip.tim8.overcaptures
    }

    fn is_alt(&self, p: Pin) -> bool {
        self.chip.gpio.mode(p) == PinMode::AltOutput
    }

    fn routed(
        &mut self,
        cx: &mut Cortex,
        what: &str,
        alt: &[(Pin, &str)],
        inputs: &[(Pin, &str)],
    ) -> bool {
        let mut ok = true;
        for &(p, name) in alt {
            if !self.is_alt(p) {
                ok = false;
                cx.report(format!(
                    "{what}: P{}{} is not an alternate-function output ({name}): the transfer \
                     moves no data",
                    (b'A' + p.0) as char,
                    p.1
                ));
            }
        }
        for &(p, name) in inputs {
            if self.chip.gpio.mode(p) != PinMode::Input {
                ok = false;
                cx.report(format!(
                    "{what}: P{}{} is not an input ({name}): the transfer moves no data",
                    (b'A' + p.0) as char,
                    p.1
                ));
            }
        }
        ok
    }

    fn spi1_frame(&mut self, cx: &mut Cortex) -> bool {
        let Some(word) = self.chip.spi1.take_finished() else {
            return false;
        };
        let t = self.tick(cx, Block::Spi1);
        let mut rx = 0;
        if !cx.cnv_high
            && self.routed(
                cx,
                "SPI1 frame to the AD7689",
                &[(pins::ADC_SCK, "SCK"), (pins::ADC_DIN, "MOSI")],
                &[(pins::ADC_SDO, "MISO")],
            )
        {
            let (bits, mode) = (self.chip.spi1.frame_bits(), self.chip.spi1.mode());
            if bits != 16 || mode != 0 {
                cx.report(format!(
                    "SPI1 frames of {bits} bits in mode {mode}: the AD7689 read (no busy \
                     indicator) needs 16-bit frames in mode 0"
                ));
            } else {
                rx = cx.adc_read(word);
            }
        }
        self.chip.spi1.complete(t, rx);
        true
    }

    fn spi2_frame(&mut self, cx: &mut Cortex) -> bool {
        let Some(word) = self.chip.spi2.take_finished() else {
            return false;
        };
        let t = self.tick(cx, Block::Spi2);
        let routed = cx.dac_frame.is_some()
            && self.routed(
                cx,
                "SPI2 frame to the AD5663",
                &[(pins::DAC_SCK, "SCK"), (pins::DAC_DIN, "MOSI")],
                &[],
            );
        if routed {
            let mode = self.chip.spi2.mode();
            if mode != 1 && mode != 2 {
                cx.report(format!(
                    "SPI2 in SPI mode {mode}: the AD5663 samples DIN on falling SCLK edges \
                     (mode 1 or 2)"
                ));
            } else {
                cx.dac_word(word, self.chip.spi2.frame_bits());
            }
        }
        self.chip.spi2.complete(t, 0);
        true
    }

    fn cnv(&mut self, cx: &mut Cortex) {
        let now = cx.hw_ns();
        let c = &self.chip;
        let high = self.is_alt(pins::ADC_CNV)
            && c.rcc.enabled(Enable::Apb1(1))
            && c.tim3.output(2, now) == Some(true);
        cx.adc_cnv(high);
    }

    fn ldac(&mut self, cx: &mut Cortex) {
        let now = cx.hw_ns();
        let level = match self.chip.gpio.mode(pins::DAC_LDAC) {
            PinMode::AltOutput => self.chip.tim8.output(1, now),
            PinMode::Output => Some(self.chip.gpio.level(pins::DAC_LDAC)),
            _ => None,
        }
        // Undriven, LDAC's pull-up holds it high (UNCONFIRMED: the board's resistor).
        .unwrap_or(true);
        if level != cx.outputs_last[2] {
            cx.io.clock.set_ns(now);
            cx.ldac_to(level);
        }
    }

    /// PB12 (the AD5663's SYNC) after a GPIO write.
    fn outputs_changed(&mut self, cx: &mut Cortex) {
        let c = &self.chip;
        let sync = c.gpio.mode(pins::DAC_SYNC) != PinMode::Output || c.gpio.level(pins::DAC_SYNC);
        if sync != cx.outputs_last[1] {
            cx.io.clock.set_ns(cx.hw_ns());
            cx.dac_sync(sync);
            cx.outputs_last[1] = sync;
        }
        self.ldac(cx);
        self.refresh_inputs(cx);
    }

    fn dma_requests(&self) -> u32 {
        let c = &self.chip;
        let mut r = 0;
        if c.spi1.rx_dma_request() || c.tim3.dma_request(2) {
            r |= 1 << 1;
        }
        if c.spi1.tx_dma_request() || c.tim3.dma_request(3) {
            r |= 1 << 2;
        }
        if c.spi2.rx_dma_request() {
            r |= 1 << 3;
        }
        if c.spi2.tx_dma_request() {
            r |= 1 << 4;
        }
        r
    }

    fn dma(&mut self, cx: &mut Cortex) -> bool {
        if !self.chip.rcc.enabled(Enable::Ahb(0)) {
            return false;
        }
        let mut moved = false;
        for _ in 0..64 {
            let requests = self.dma_requests();
            let Some(x) = self.chip.dma1.next_transfer(requests) else {
                break;
            };
            moved = true;
            match x.channel {
                1 => self.chip.tim3.clear_dma_request(2),
                2 => self.chip.tim3.clear_dma_request(3),
                _ => {}
            }
            let value = self.dma_read(cx, x.src, x.src_bytes);
            let ok = match value {
                Some(v) => self.dma_write(cx, x.dst, x.dst_bytes, v),
                None => false,
            };
            if ok {
                self.chip.dma1.transferred(&x);
            } else {
                cx.report(format!(
                    "DMA1 channel {}: {:#010x} -> {:#010x} is not SRAM or a peripheral: \
                     transfer error",
                    x.channel + 1,
                    x.src,
                    x.dst
                ));
                self.chip.dma1.error(&x);
            }
        }
        moved
    }

    fn dma_read(&mut self, cx: &mut Cortex, addr: u32, n: usize) -> Option<u32> {
        let mut b = [0u8; 4];
        if self.chip.sram.contains(addr, n as u32) {
            self.chip.sram.read(addr, &mut b[..n]);
            return Some(u32::from_le_bytes(b));
        }
        let (p, s) = base::PERIPHERALS;
        if (p..p + s).contains(&addr) {
            let v = self.periph_read(cx, addr & !3) >> (8 * (addr & 3));
            return Some(v & if n == 4 { u32::MAX } else { (1 << (8 * n)) - 1 });
        }
        None
    }

    fn dma_write(&mut self, cx: &mut Cortex, addr: u32, n: usize, value: u32) -> bool {
        if self.chip.sram.contains(addr, n as u32) {
            self.chip.sram.write(addr, &value.to_le_bytes()[..n]);
            return true;
        }
        let (p, s) = base::PERIPHERALS;
        if (p..p + s).contains(&addr) {
            self.periph_write(cx, addr & !3, value << (8 * (addr & 3)));
            return true;
        }
        false
    }

    fn clocked(&mut self, cx: &mut Cortex, block: Block) -> bool {
        match block.clock() {
            Some(e) if !self.chip.rcc.enabled(e) => {
                cx.report(format!(
                    "access to {block:?} while {} is 0: the peripheral does not respond",
                    e.name()
                ));
                false
            }
            _ => true,
        }
    }

    fn unmodelled(&mut self, cx: &mut Cortex, addr: u32, write: Option<u32>) {
        cx.stop = Some(Stop::Fault(match write {
            Some(v) => format!(
                "write of {v:#x} to {addr:#010x}: a peripheral the co-simulator does not model"
            ),
            None => format!("read of {addr:#010x}: a peripheral the co-simulator does not model"),
        }));
    }

    fn periph_read(&mut self, cx: &mut Cortex, addr: u32) -> u32 {
        let Some((block, off)) = Block::of(addr) else {
            self.unmodelled(cx, addr, None);
            return 0;
        };
        if !self.clocked(cx, block) {
            return 0;
        }
        if matches!(block, Block::Gpio(_) | Block::Exti) {
            self.refresh_inputs(cx);
        }
        let t = self.tick(cx, block);
        if block == Block::Rcc {
            // A switch requested before its source was ready happens when it is.
            let v = self.chip.rcc.read(t, off);
            self.rcc_changed(cx);
            return v;
        }
        let c = &mut self.chip;
        match block {
            Block::Tim3 => c.tim3.read(t, off),
            Block::Tim8 => c.tim8.read(t, off),
            Block::Iwdg => c.iwdg.read(off),
            Block::Spi1 => c.spi1.read(t, off),
            Block::Spi2 => c.spi2.read(t, off),
            Block::Afio => c.gpio.afio_read(off),
            Block::Exti => c.exti.read(off),
            Block::Gpio(n) => c.gpio.read(n, off),
            Block::Dma1 => c.dma1.read(off),
            Block::Rcc => 0,
            Block::Flash => c.flash.read(off),
        }
    }

    /// After an RCC access: its rule violations reported; a clock switch sets the CPU's
    /// cycle time and checks the flash wait states.
    fn rcc_changed(&mut self, cx: &mut Cortex) {
        let c = &mut self.chip;
        let changed = c.rcc.take_clock_change();
        let v: Vec<String> = c.rcc.violations.drain(..).collect();
        for m in v {
            cx.report(format!("RCC: {m}"));
        }
        if changed {
            cx.set_cycle_time(self.hclk_hz());
            self.check_wait_states(cx);
        }
    }

    fn periph_write(&mut self, cx: &mut Cortex, addr: u32, value: u32) {
        let Some((block, off)) = Block::of(addr) else {
            self.unmodelled(cx, addr, Some(value));
            return;
        };
        if !self.clocked(cx, block) {
            return;
        }
        let t = self.tick(cx, block);
        let now = t.now_ns;
        let c = &mut self.chip;
        let mut problem = None;
        match block {
            Block::Tim3 => c.tim3.write(t, off, value),
            Block::Tim8 => c.tim8.write(t, off, value),
            Block::Iwdg => {
                if c.iwdg.write(now, off, value) {
                    c.rcc.start_lsi();
                }
            }
            Block::Spi1 => c.spi1.write(t, off, value),
            Block::Spi2 => c.spi2.write(t, off, value),
            Block::Afio => c.gpio.afio_write(off, value),
            Block::Exti => c.exti.write(off, value),
            Block::Gpio(n) => c.gpio.write(n, off, value),
            Block::Dma1 => problem = c.dma1.write(off, value).err(),
            Block::Rcc => c.rcc.write(t, off, value),
            Block::Flash => problem = c.flash.write(off, value).err(),
        }
        if let Some(p) = problem {
            cx.report(p);
        }
        match block {
            Block::Rcc => self.rcc_changed(cx),
            Block::Flash => self.check_wait_states(cx),
            Block::Gpio(_) => self.outputs_changed(cx),
            Block::Afio | Block::Exti => self.refresh_inputs(cx),
            _ => {}
        }
    }

    fn check_wait_states(&mut self, cx: &mut Cortex) {
        let c = &self.chip;
        let sysclk = c.rcc.sysclk_hz();
        let need = crate::stm32::flash::FlashAcr::needed(sysclk);
        if c.flash.latency() < need {
            let have = c.flash.latency();
            cx.report(format!(
                "FLASH_ACR: {have} wait states at SYSCLK {sysclk} Hz ({need} needed, RM0008 \
                 3.3.3): the core reads wrong instructions"
            ));
        }
    }

    /// The FSMC pins and bank 1's settings: `Ok` when an access reaches the ESC.
    fn fsmc_routed(&mut self, cx: &mut Cortex) -> bool {
        let outputs: Vec<(Pin, &str)> = pins::FSMC_OUTPUTS.iter().map(|&p| (p, "FSMC")).collect();
        let routed = self.routed(
            cx,
            "FSMC access to the ET1100",
            &outputs,
            &[(pins::FSMC_NWAIT, "NWAIT")],
        );
        let busy_high = cx.io.esc.esc().borrow().peek_u8(0x0150) & 2 != 0;
        let problems = self.chip.fsmc.check(busy_high);
        let ok = routed && problems.is_empty();
        for p in problems {
            cx.report(format!("{p}: the access moves no data"));
        }
        ok
    }

    /// One 16-bit bus cycle of bank 1 at ESC address `offset` (NBL0/NBL1 pin levels), a
    /// read or a write of `data`; the data read, the core stalled for the cycle.
    fn fsmc_cycle(
        &mut self,
        cx: &mut Cortex,
        offset: u16,
        nbl: (bool, bool),
        data: Option<u16>,
    ) -> u16 {
        let hclk = self.hclk_hz();
        let cycle = self.chip.fsmc.cycle(hclk, data.is_some());
        let wait = self.chip.fsmc.bank1_async_wait();
        let now = cx.hw_ns();
        let esc = cx.io.esc.esc().clone();
        let start = now.max(self.bus_free_ns);
        self.latch.address_phase(offset >> 1);
        let (adr, bhe) = self.latch.esc_pins(nbl.0, nbl.1);
        let at = start + cycle.address_ns;
        let access = {
            let mut e = esc.borrow_mut();
            match data {
                None => self.esc_port.read(&mut e, at, cycle.strobe_ns, adr, bhe),
                Some(d) => self
                    .esc_port
                    .write(&mut e, at, cycle.strobe_ns, adr, bhe, d),
            }
        };
        // Without ASYNCWAIT the FSMC ends the strobe after DATAST whatever BUSY says.
        let end = if wait {
            access.end_ns
        } else {
            at + cycle.strobe_ns
        };
        let free = end + cycle.turnaround_ns;
        self.bus_free_ns = free;
        self.fsmc_accesses += 1;
        self.fsmc_ns += free - start;
        if !wait && access.busy_ns > cycle.strobe_ns {
            cx.report(format!(
                "FSMC access at ESC {offset:#06x}: BUSY for {} ns but DATAST is {} ns and \
                 ASYNCWAIT is off: the FSMC took the data before the ESC was ready",
                access.busy_ns, cycle.strobe_ns
            ));
        }
        // The core waits for the whole cycle (the write buffer is not modelled).
        let stall = ns_to_ticks(free - now, hclk);
        cx.add_cycles(stall);
        access.data
    }

    fn bank_access(&mut self, cx: &mut Cortex, addr: u32, size: usize, write: Option<u32>) -> u32 {
        if !self.chip.rcc.enabled(Enable::Ahb(8)) {
            cx.report(
                "access to FSMC bank 1 while RCC_AHBENR.FSMCEN is 0: the FSMC does not respond"
                    .into(),
            );
            return 0;
        }
        if !self.chip.fsmc.bank1_enabled() {
            cx.stop = Some(Stop::Fault(format!(
                "access to {addr:#010x}: FSMC bank 1 is disabled (BCR1.MBKEN 0): bus fault"
            )));
            return 0;
        }
        if write.is_some() && !self.chip.fsmc.bank1_writable() {
            cx.stop = Some(Stop::Fault(format!(
                "write to {addr:#010x}: FSMC bank 1 has WREN 0: bus fault (RM0008 21.5)"
            )));
            return 0;
        }
        if !self.fsmc_routed(cx) {
            return 0;
        }
        let offset = (addr - base::FSMC_BANK1.0) as u16;
        let v = self.bank_cycles(cx, offset, size, write);
        // An access may release or raise the ESC's IRQ (AL event reads, SM buffers): EXTI
        // sees each level it takes.
        self.refresh_inputs(cx);
        v
    }

    /// The bus cycles of one CPU access of `size` bytes at ESC address `offset`.
    fn bank_cycles(
        &mut self,
        cx: &mut Cortex,
        offset: u16,
        size: usize,
        write: Option<u32>,
    ) -> u32 {
        match (size, write) {
            (1, None) => {
                // A byte read is a halfword read on a 16-bit bank (both NBL low).
                let [lo, hi] = self
                    .fsmc_cycle(cx, offset & !1, (false, false), None)
                    .to_le_bytes();
                u32::from(if offset & 1 == 0 { lo } else { hi })
            }
            (1, Some(v)) => {
                let odd = offset & 1 == 1;
                let b = v as u8;
                let d = if odd {
                    u16::from_le_bytes([!b, b])
                } else {
                    u16::from_le_bytes([b, !b])
                };
                self.fsmc_cycle(cx, offset, (odd, !odd), Some(d));
                0
            }
            (2, w) => u32::from(self.fsmc_cycle(cx, offset, (false, false), w.map(|v| v as u16))),
            (_, w) => {
                // A 32-bit access: two halfword cycles, the lower address first.
                let lo = self.fsmc_cycle(cx, offset, (false, false), w.map(|v| v as u16));
                let hi = self.fsmc_cycle(
                    cx,
                    offset.wrapping_add(2),
                    (false, false),
                    w.map(|v| (v >> 16) as u16),
                );
                u32::from(lo) | u32::from(hi) << 16
            }
        }
    }

    /// A CPU read of `size` bytes at `addr`.
    pub fn cpu_read(&mut self, cx: &mut Cortex, addr: u32, size: usize) -> u32 {
        let shift = 8 * (addr & 3);
        let mask = if size == 4 {
            u32::MAX
        } else {
            (1 << (8 * size)) - 1
        };
        let (bank, len) = base::FSMC_BANK1;
        let v = if (bank..bank + len).contains(&addr) {
            return self.bank_access(cx, addr, size, None);
        } else if addr >= base::SCS {
            let off = (addr - base::SCS) & !3;
            if off == dwt::DEMCR {
                self.chip.dwt.demcr()
            } else {
                cx.scs.read(off, cx.cycles)
            }
        } else if addr >= base::DWT {
            self.chip.dwt.read(cx.cycles, (addr - base::DWT) & !3)
        } else if addr >= base::FSMC_REGS {
            self.chip.fsmc.read((addr - base::FSMC_REGS) & !3)
        } else {
            self.periph_read(cx, addr & !3)
        };
        self.settle(cx);
        (v >> shift) & mask
    }

    /// A CPU write.
    pub fn cpu_write(&mut self, cx: &mut Cortex, addr: u32, size: usize, value: u32) {
        let (bank, len) = base::FSMC_BANK1;
        if (bank..bank + len).contains(&addr) {
            self.bank_access(cx, addr, size, Some(value));
        } else if addr >= base::SCS {
            let off = addr - base::SCS;
            if off & !3 == dwt::DEMCR {
                let cycles = cx.cycles;
                self.chip.dwt.write_demcr(cycles, value);
            } else {
                let effect = cx.scs.write(off, size, value, cx.cycles);
                if effect.reset_request {
                    cx.stop = Some(Stop::Reset(ResetCause::SysResetReq));
                }
                cx.check_preempt = cx.scs.any_pending();
            }
        } else if addr >= base::DWT {
            let cycles = cx.cycles;
            if !self.chip.dwt.write(cycles, (addr - base::DWT) & !3, value) {
                self.unmodelled(cx, addr, Some(value));
            }
        } else if addr >= base::FSMC_REGS {
            if let Err(e) = self.chip.fsmc.write((addr - base::FSMC_REGS) & !3, value) {
                cx.stop = Some(Stop::Fault(e));
            }
        } else {
            // Sub-word writes land in their lanes (BSRR's reset half by a halfword write).
            self.periph_write(cx, addr & !3, value << (8 * (addr & 3)));
        }
        self.settle(cx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chip::Chip;
    use crate::image::Image;
    use crate::machine::Machine;
    use std::rc::Rc;
    use virtual_board::rig::board::{BoardConfig, VirtualBoard as Board};

    /// An STM32F103 with blank flash on a board (no CPU: the tests drive the bus).
    fn machine() -> (Board, Machine) {
        let board = Board::new(BoardConfig::new(vec![0xFF; 2048]));
        let chip = Chip::Stm32f103;
        let image = Image::bare(chip, vec![0xFF; chip.flash().len as usize]);
        let m = Machine::new(board.io(), Rc::new(image));
        (board, m)
    }

    #[test]
    fn an_address_no_model_decodes_stops_the_core() {
        let (_board, mut m) = machine();
        // USART2 (0x4000_4400) is not modelled.
        m.cpu_read(0x4000_4400, 4);
        assert!(
            matches!(&m.stop, Some(Stop::Fault(f)) if f.contains("does not model")),
            "{:?}",
            m.stop
        );
        m.stop = None;
        m.cpu_write(0xA000_0060, 4, 1);
        assert!(matches!(&m.stop, Some(Stop::Fault(f)) if f.contains("NAND")));
    }

    #[test]
    fn unclocked_peripherals_do_not_respond_and_a_disabled_bank_faults() {
        let (_board, mut m) = machine();
        // SPI1 before RCC_APB2ENR.SPI1EN.
        m.cpu_write(base::SPI1, 2, 0x0344);
        assert_eq!(m.cpu_read(base::SPI1, 2), 0);
        assert!(
            m.reports
                .iter()
                .any(|r| r.message.contains("Spi1 while RCC_APB2ENR bit 12 is 0")),
            "{:?}",
            m.reports
        );
        m.cpu_write(base::RCC + 0x18, 4, 1 << 12);
        m.cpu_write(base::SPI1, 2, 0x0344);
        assert_eq!(m.cpu_read(base::SPI1, 2), 0x0344);
        // The ESC's bank with the FSMC unclocked: no response, reported.
        assert_eq!(m.cpu_read(base::FSMC_BANK1.0 + 0x130, 2), 0);
        assert!(m
            .reports
            .iter()
            .any(|r| r.message.contains("RCC_AHBENR.FSMCEN is 0")));
        // FSMC clocked, bank 1 disabled: a bus fault.
        m.cpu_write(base::RCC + 0x14, 4, 1 << 8);
        m.cpu_write(base::FSMC_REGS, 4, 0x30DA);
        m.cpu_read(base::FSMC_BANK1.0 + 0x130, 2);
        assert!(matches!(&m.stop, Some(Stop::Fault(f)) if f.contains("MBKEN")));
    }

    #[test]
    fn the_clock_switch_sets_the_cpu_clock_and_too_few_wait_states_are_reported() {
        let (_board, mut m) = machine();
        assert_eq!(m.cclk_hz(), 8_000_000, "HSI");
        m.cpu_write(base::RCC, 4, 0x83 | 1 << 16 | 1 << 24);
        m.cpu_write(base::RCC + 0x04, 4, 0x001D_0402);
        let t = m.now_ns() + crate::stm32::unconfirmed::HSE_STARTUP_NS + 1_000_000;
        m.sleep_until(t);
        assert_eq!(m.cpu_read(base::RCC + 0x04, 4) >> 2 & 3, 2, "SWS = PLL");
        assert_eq!(m.cclk_hz(), 72_000_000);
        // FLASH_ACR still at 0 wait states.
        assert!(
            m.reports
                .iter()
                .any(|r| r.message.contains("0 wait states at SYSCLK 72000000")),
            "{:?}",
            m.reports
        );
    }
}
