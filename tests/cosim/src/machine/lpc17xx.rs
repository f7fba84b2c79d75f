//! The LPC1754 around the core (UM10360): its peripherals ([`crate::periph`]) on the
//! peripheral bus (the address map of chapter 2), their clocks from SYSCON, the GPDMA and the
//! AHB SRAM, the flash behind the IAP ROM ([`crate::iap`]), and the board wiring of
//! hardware-facts 10.A: which pin, in which PINSEL function, reaches which chip model of the
//! virtual board.
//!
//! Routing is strict: a legacy SPI byte reaches the ET1100 only while SPI_SEL (P0.16, GPIO)
//! is low and P0.15/P0.17/P0.18 carry SCK/MISO/MOSI (function 3); SSP0 frames reach the
//! AD5663 only on P1.20/P1.24 (function 3) while SYNC (P2.2) is low; SSP1 frames reach the
//! AD7689 only on P0.7/P0.8/P0.9 (function 2) while CNV is low; CNV is MAT2.0 only on P0.6
//! function 3; SYNC0 reaches CAP1.0 only on P1.18 function 3; LDAC (P2.3) follows the GPIO
//! in function 0 and PWM1.4 in function 1 (each PWM edge at its own time); CAN1 reaches the
//! board's CAN bus only on P0.0/P0.1 (function 1) at the bus's bit rate. Anything else moves no data
//! and is reported, as is any access to a peripheral whose PCONP bit is off.
//!
//! The core's side (time, events, NVIC, profile, the frames in flight to the board's chips)
//! is [`Cortex`]; each function here that needs it takes it as `cx`.

use super::{Cortex, ResetCause, Stop};
use crate::ahb_sram::AhbSram;
use crate::nvic::irq;
use crate::periph::can::Can;
use crate::periph::gpdma::{After, Gpdma, Transfer};
use crate::periph::gpio::{Gpio, GpioInt};
use crate::periph::pincon::PinConnect;
use crate::periph::pwm::Pwm;
use crate::periph::spi::Spi;
use crate::periph::ssp::Ssp;
use crate::periph::syscon::{Clocked, Syscon, PCONP_RESET};
use crate::periph::timer::Timer;
use crate::periph::wdt::Wdt;
use crate::periph::{Peripheral, Tick};
use lpc17xx_iap::model::FlashModel;
use virtual_board::models::spi::SpiSession;

/// Pins of the board (hardware-facts 10.A).
pub mod pins {
    /// (port, pin).
    pub type Pin = (u8, u8);
    /// ET1100 SPI_CLK / SPI_DO (MISO) / SPI_DI (MOSI): legacy SPI function 3.
    pub const ESC_SCK: Pin = (0, 15);
    /// See [`ESC_SCK`].
    pub const ESC_MISO: Pin = (0, 17);
    /// See [`ESC_SCK`].
    pub const ESC_MOSI: Pin = (0, 18);
    /// ET1100 SPI_SEL (GPIO).
    pub const ESC_SEL: Pin = (0, 16);
    /// ET1100 SPI_IRQ (GPIO input, active low).
    pub const ESC_IRQ: Pin = (0, 22);
    /// ET1100 EEPROM_LOADED (GPIO input).
    pub const ESC_EEPROM_LOADED: Pin = (2, 4);
    /// ET1100 SYNC0 -> CAP1.0 (function 3).
    pub const ESC_SYNC0: Pin = (1, 18);
    /// AD5663 SCLK / DIN on SSP0 (function 3).
    pub const DAC_SCK: Pin = (1, 20);
    /// See [`DAC_SCK`].
    pub const DAC_DIN: Pin = (1, 24);
    /// AD5663 SYNC (GPIO).
    pub const DAC_SYNC: Pin = (2, 2);
    /// AD5663 LDAC: GPIO (function 0) or PWM1.4 (function 1, the oversampling outputs).
    pub const DAC_LDAC: Pin = (2, 3);
    /// The PINSEL function of [`DAC_LDAC`] that is PWM1.4.
    pub const LDAC_PWM_FUNC: u8 = 1;
    /// The PWM1 output on [`DAC_LDAC`].
    pub const LDAC_PWM_OUTPUT: usize = 4;
    /// AD7689 CNV = MAT2.0 (function 3).
    pub const ADC_CNV: Pin = (0, 6);
    /// AD7689 SCK / SDO / DIN on SSP1 (function 2).
    pub const ADC_SCK: Pin = (0, 7);
    /// See [`ADC_SCK`].
    pub const ADC_SDO: Pin = (0, 8);
    /// See [`ADC_SCK`].
    pub const ADC_DIN: Pin = (0, 9);
    /// CAN1 RD1 / TD1 to the transceiver (function 1).
    pub const CAN_RD: Pin = (0, 0);
    /// See [`CAN_RD`].
    pub const CAN_TD: Pin = (0, 1);
}

/// A peripheral slot of the address map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// 0x4000_0000.
    Wdt,
    /// TIMER0 0x4000_4000, TIMER1 0x4000_8000, TIMER2 0x4009_0000, TIMER3 0x4009_4000.
    Timer(usize),
    /// 0x4002_0000.
    Spi,
    /// 0x4002_8000.
    GpioInt,
    /// 0x4002_C000.
    PinConnect,
    /// 0x4003_0000.
    Ssp1,
    /// 0x4008_8000.
    Ssp0,
    /// 0x400F_C000.
    Syscon,
    /// 0x2009_C000.
    Gpio,
    /// 0x5000_4000.
    Gpdma,
    /// CAN1, 0x4004_4000.
    Can1,
    /// PWM1, 0x4001_8000.
    Pwm1,
    /// The CAN acceptance filter registers, 0x4003_C000.
    CanAf,
    /// 0xE000_E000.
    Scs,
    /// A peripheral the co-simulator does not model (its base).
    Unmodelled(u32),
}

impl Region {
    /// The region an APB/AHB slot base maps to.
    pub fn of_base(base: u32) -> Region {
        match base {
            0x4000_0000 => Region::Wdt,
            0x4000_4000 => Region::Timer(0),
            0x4000_8000 => Region::Timer(1),
            0x4009_0000 => Region::Timer(2),
            0x4009_4000 => Region::Timer(3),
            0x4002_0000 => Region::Spi,
            0x4002_8000 => Region::GpioInt,
            0x4002_C000 => Region::PinConnect,
            0x4003_0000 => Region::Ssp1,
            0x4008_8000 => Region::Ssp0,
            0x400F_C000 => Region::Syscon,
            0x2009_C000 => Region::Gpio,
            0x5000_4000 => Region::Gpdma,
            0x4004_4000 => Region::Can1,
            0x4001_8000 => Region::Pwm1,
            0x4003_C000 => Region::CanAf,
            0xE000_E000 => Region::Scs,
            other => Region::Unmodelled(other),
        }
    }

    fn clocked(self) -> Option<Clocked> {
        Some(match self {
            Region::Wdt => Clocked::Wdt,
            Region::Timer(n) => Clocked::Timer(n as u8),
            Region::Spi => Clocked::Spi,
            Region::Ssp0 => Clocked::Ssp0,
            Region::Ssp1 => Clocked::Ssp1,
            Region::Gpio | Region::GpioInt => Clocked::Gpio,
            Region::Gpdma => Clocked::Gpdma,
            Region::Can1 => Clocked::Can1,
            Region::Pwm1 => Clocked::Pwm1,
            _ => return None,
        })
    }
}

/// The LPC1754's peripherals and the board wiring's state on its side.
pub struct Lpc17xx {
    /// SYSCON.
    pub syscon: Syscon,
    pincon: PinConnect,
    gpio: Gpio,
    gpioint: GpioInt,
    spi: Spi,
    ssp0: Ssp,
    /// SSP1 (the AD7689).
    pub ssp1: Ssp,
    /// TIMER0..3 (TIMER1's CAP1.0 captures SYNC0).
    pub timers: [Timer; 4],
    gpdma: Gpdma,
    wdt: Wdt,
    can1: Can,
    /// PWM1 (LDAC in the oversampling output path).
    pub pwm1: Pwm,
    /// The bus's count of frames CAN1's port sent, as far as CAN1 has been told.
    can_sent_seen: u64,
    esc_session: Option<SpiSession>,
    /// PCONP to start from after a reset (tests: what a bootloader leaves).
    pub pconp_at_reset: u32,
    /// The AHB SRAM (the GPDMA's memory) with its watch over samples.
    pub ahb_sram: AhbSram,
    /// The flash and the IAP ROM's state ([`crate::iap`]); the engine's flash mirrors it.
    pub flash: FlashModel,
    /// IAP commands carried out.
    pub iap_calls: u64,
}

impl Lpc17xx {
    /// The chip at power-on on `cx`'s board.
    pub fn new(cx: &Cortex) -> Self {
        let mut l = Self {
            syscon: Syscon::new(PCONP_RESET, 1),
            pincon: PinConnect::new(),
            gpio: Gpio::new(),
            gpioint: GpioInt::new(),
            spi: Spi::new(),
            ssp0: Ssp::new(),
            ssp1: Ssp::new(),
            timers: Default::default(),
            gpdma: Gpdma::new(),
            wdt: Wdt::new(false),
            can1: Can::new(),
            pwm1: Pwm::new(),
            can_sent_seen: 0,
            esc_session: None,
            pconp_at_reset: PCONP_RESET,
            ahb_sram: AhbSram::new(),
            flash: FlashModel::new(),
            iap_calls: 0,
        };
        l.can_sent_seen = l.can_frames_left(cx);
        l
    }

    /// The chip's reset: every peripheral to its reset state (WDTOF kept after a watchdog
    /// reset), the AHB SRAM kept.
    pub fn reset(&mut self, cx: &Cortex, cause: ResetCause) {
        let watchdog = cause == ResetCause::Watchdog;
        // RSID: WDTR b2 after a watchdog reset.
        self.syscon = Syscon::new(self.pconp_at_reset, if watchdog { 4 } else { 0 });
        self.pincon = PinConnect::new();
        self.gpio = Gpio::new();
        self.gpioint = GpioInt::new();
        self.spi = Spi::new();
        self.ssp0 = Ssp::new();
        self.ssp1 = Ssp::new();
        self.timers = Default::default();
        self.gpdma = Gpdma::new();
        self.wdt = Wdt::new(watchdog);
        // Frames the controller queued before the reset count as gone.
        self.can1 = Can::new();
        self.pwm1 = Pwm::new();
        self.can_sent_seen = self.can_frames_left(cx);
    }

    /// Ends the ET1100's SPI session (a reset deselects it).
    pub fn end_session(&mut self, cx: &Cortex) {
        if let Some(s) = self.esc_session.take() {
            cx.io.esc.esc().borrow_mut().spi_end(s);
        }
    }

    /// The CPU clock now.
    pub fn cclk_hz(&self) -> u64 {
        self.syscon.cclk_hz()
    }

    /// SYNC0 captures (CAP1.0) overwritten by the next edge before the CPU read them.
    pub fn sync0_unserved(&self) -> u64 {
        self.timers[1].captures_unread[0]
    }

    /// The next event of the chip's peripherals.
    pub fn next_event(&self) -> Option<u64> {
        [
            self.spi.next_event(),
            self.ssp0.next_event(),
            self.ssp1.next_event(),
            self.timers[0].next_event(),
            self.timers[1].next_event(),
            self.timers[2].next_event(),
            self.timers[3].next_event(),
            self.pwm1.next_event(),
            self.wdt.next_event(),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// Serves the chip's events due now.
    pub fn service(&mut self, cx: &mut Cortex) {
        let t = self.tick_for(cx, Region::Wdt);
        self.wdt.on_event(t);
        if self.wdt.take_reset_request() {
            cx.stop = Some(Stop::Reset(ResetCause::Watchdog));
        }
        let t = self.tick_for(cx, Region::Spi);
        self.spi.on_event(t);
        for n in 0..4 {
            let t = self.tick_for(cx, Region::Timer(n));
            self.timers[n].on_event(t);
        }
        let t = self.tick_for(cx, Region::Pwm1);
        self.pwm1.on_event(t);
        let t = self.tick_for(cx, Region::Ssp0);
        self.ssp0.on_event(t);
        let t = self.tick_for(cx, Region::Ssp1);
        self.ssp1.on_event(t);
        self.can_exchange(cx);
        self.settle(cx);
    }

    /// After any change: frames to the devices, pins, DMA, interrupt lines, schedule.
    pub fn settle(&mut self, cx: &mut Cortex) {
        for _ in 0..16 {
            let mut moved = self.exchange_ssp0(cx);
            moved |= self.exchange_ssp1(cx);
            self.update_cnv(cx);
            moved |= self.run_dma(cx);
            if !moved {
                break;
            }
        }
        self.pwm_ldac(cx);
        self.update_irq_lines(cx);
        cx.reschedule(self.next_event());
    }

    /// A CPU read of the AHB SRAM.
    pub fn ahb_read(&mut self, addr: u32, size: usize) -> u32 {
        let mut b = [0u8; 4];
        self.ahb_sram.cpu_read(addr, &mut b[..size]);
        u32::from_le_bytes(b)
    }

    /// A CPU write to the AHB SRAM.
    pub fn ahb_write(&mut self, addr: u32, size: usize, value: u32) {
        self.ahb_sram.cpu_write(addr, &value.to_le_bytes()[..size]);
    }

    /// A CPU access of `size` bytes at `addr` (sub-word accesses as the APB's byte lanes).
    pub fn cpu_read(&mut self, cx: &mut Cortex, addr: u32, size: usize) -> u32 {
        let base = Self::slot(addr);
        let shift = 8 * (addr & 3);
        let v = self.bus_read_region(cx, base, (addr - base) & !3) >> shift;
        self.settle(cx);
        match size {
            1 => v & 0xFF,
            2 => v & 0xFFFF,
            _ => v,
        }
    }

    /// A CPU write.
    pub fn cpu_write(&mut self, cx: &mut Cortex, addr: u32, size: usize, value: u32) {
        let base = Self::slot(addr);
        let offset = addr - base;
        if Region::of_base(base) == Region::Scs && size < 4 {
            // Byte writes to the priority registers (NVIC IPR, SHPR).
            let effect = cx.scs.write(offset, size, value, cx.cycles);
            if effect.reset_request {
                cx.stop = Some(Stop::Reset(ResetCause::SysResetReq));
            }
            cx.check_preempt = cx.scs.any_pending();
            return;
        }
        let shift = 8 * (addr & 3);
        let mut v = value << shift;
        if size < 4 && Region::of_base(base) == Region::Gpio {
            let lane = (if size == 1 { 0xFFu32 } else { 0xFFFF }) << shift;
            let old = self.bus_read_region(cx, base, offset & !3);
            let reg = offset & 0x1F;
            if matches!(reg, 0x00 | 0x10 | 0x14) {
                v = (old & !lane) | (v & lane);
            }
        }
        self.bus_write_region(cx, base, offset & !3, v);
        self.settle(cx);
    }

    // ------------------------------------------------------------------ clocks and events

    fn tick_for(&self, cx: &Cortex, region: Region) -> Tick {
        Tick {
            now_ns: cx.hw_ns(),
            pclk_hz: region
                .clocked()
                .map_or(self.syscon.cclk_hz(), |c| self.syscon.pclk_hz(c)),
        }
    }
    fn update_irq_lines(&mut self, cx: &mut Cortex) {
        let lines = [
            (irq::WDT, self.wdt.irq()),
            (irq::TIMER0, self.timers[0].irq()),
            (irq::TIMER0 + 1, self.timers[1].irq()),
            (irq::TIMER0 + 2, self.timers[2].irq()),
            (irq::TIMER0 + 3, self.timers[3].irq()),
            (irq::SPI, self.spi.irq()),
            (irq::SSP0, self.ssp0.irq()),
            (irq::SSP1, self.ssp1.irq()),
            (irq::EINT3, self.gpioint.irq()),
            (irq::DMA, self.gpdma.irq()),
            (irq::CAN, self.can1.irq()),
            (irq::PWM1, self.pwm1.irq()),
        ];
        for (n, level) in lines {
            cx.scs.set_line(n, level);
        }
        cx.check_preempt = cx.scs.any_pending();
    }

    // ------------------------------------------------------------------ pins

    fn func(&self, p: pins::Pin) -> u8 {
        self.pincon.func(p.0, p.1)
    }

    fn routed(&mut self, cx: &mut Cortex, what: &str, need: &[(pins::Pin, u8, &str)]) -> bool {
        let mut ok = true;
        for &(p, f, name) in need {
            let have = self.func(p);
            if have != f {
                ok = false;
                cx.report(format!(
                    "{what}: P{}.{} is PINSEL function {have}, not {f} ({name}): the transfer \
                     moves no data",
                    p.0, p.1
                ));
            }
        }
        ok
    }

    /// The GPIO output level of a pin used as GPIO (None: not GPIO or not an output).
    fn gpio_out(&self, p: pins::Pin) -> Option<bool> {
        (self.func(p) == 0 && self.gpio.is_output(p.0, p.1))
            .then(|| self.gpio.level(p.0, p.1, true))
    }

    /// Inputs from the board into the pins: ESC IRQ (active low), EEPROM_LOADED.
    pub fn refresh_inputs(&mut self, cx: &mut Cortex) {
        let (irq, loaded) = {
            let esc = cx.io.esc.esc().borrow();
            (esc.irq(), esc.pdi_operational())
        };
        let (p, n) = pins::ESC_IRQ;
        self.gpio.set_input(p, n, !irq);
        if self.func(pins::ESC_IRQ) == 0 {
            self.gpioint.sample(p, n, !irq);
        }
        let (p, n) = pins::ESC_EEPROM_LOADED;
        self.gpio.set_input(p, n, loaded);
        let level = self.gpioint.irq();
        cx.scs.set_line(irq::EINT3, level);
        self.can_exchange(cx);
        cx.check_preempt |= cx.scs.any_pending();
    }

    // ------------------------------------------------------------------ CAN

    /// The frames CAN1's port has sent plus those still queued at it: where a fresh
    /// controller starts counting.
    fn can_frames_left(&self, cx: &Cortex) -> u64 {
        let bus = cx.io.can.bus.borrow();
        bus.sent(cx.io.can.port) + bus.pending(cx.io.can.port) as u64
    }

    /// Whether CAN1's frames cross to the bus: powered, pins routed, equal CAN clocks, the
    /// bus's bit rate (within 0.5 %).
    fn can_link(&self, cx: &Cortex) -> Result<(), String> {
        if !self.syscon.powered(Clocked::Can1) {
            return Err("CAN1 is not powered (PCONP bit 13)".into());
        }
        for (p, name) in [(pins::CAN_RD, "RD1"), (pins::CAN_TD, "TD1")] {
            let f = self.func(p);
            if f != 1 {
                return Err(format!(
                    "P{}.{} is PINSEL function {f}, not 1 ({name}): CAN1 is not on the bus",
                    p.0, p.1
                ));
            }
        }
        let pclk = self.syscon.pclk_hz(Clocked::Can1);
        if self.syscon.pclk_hz(Clocked::Can2) != pclk
            || self.syscon.pclk_hz(Clocked::CanAcf) != pclk
        {
            return Err(
                "PCLK of CAN1, CAN2 and the acceptance filter differ (UM10360 requires them equal)"
                    .into(),
            );
        }
        let rate = self.can1.bit_rate(pclk);
        let bus = u64::from(cx.io.can.bus.borrow().bit_rate());
        if rate.abs_diff(bus) * 200 > bus {
            return Err(format!(
                "CAN1 runs at {rate} bit/s (BTR at PCLK {pclk} Hz), the bus at {bus} bit/s: no \
                 frame is exchanged"
            ));
        }
        Ok(())
    }

    /// The board's CAN bus up to now: sent frames free their transmit buffers, arrived
    /// frames enter the receive buffer (through the acceptance filter), requested frames go
    /// onto the bus; the interrupt line follows.
    fn can_exchange(&mut self, cx: &mut Cortex) {
        let now = cx.hw_ns();
        let port = cx.io.can.port;
        let bus = cx.io.can.bus.clone();
        bus.borrow_mut().advance_to(now);
        let sent = bus.borrow().sent(port);
        let quiet = sent == self.can_sent_seen
            && !bus.borrow().has_rx(port)
            && !(self.can1.operating() && self.can1.has_requests())
            && self.can1.violations.is_empty();
        if quiet {
            // Nothing crossed (asked after every event of the chip): the line and the
            // schedule only.
            cx.scs.set_line(irq::CAN, self.can1.irq());
            cx.check_preempt |= cx.scs.any_pending();
            cx.reschedule(self.next_event());
            return;
        }
        while self.can_sent_seen < sent {
            self.can_sent_seen += 1;
            self.can1.transmitted();
            cx.traffic.can_sent += 1;
        }
        let mut arrived = Vec::new();
        while let Some((_, frame)) = bus.borrow_mut().receive(port) {
            arrived.push(frame);
        }
        if self.can1.operating() {
            let link = self.can_link(cx);
            if !arrived.is_empty() {
                match link.clone().and_then(|()| self.can1.accepts_all()) {
                    Ok(()) => {
                        for f in &arrived {
                            if self.can1.receive(f) {
                                cx.traffic.can_received += 1;
                            }
                        }
                    }
                    Err(why) => cx.report(format!("CAN frame from the bus not received: {why}")),
                }
            }
            match link {
                Ok(()) => {
                    for f in self.can1.take_requests() {
                        bus.borrow_mut().send(port, f);
                    }
                }
                Err(why) if self.can1.has_requests() => {
                    cx.report(format!("CAN1 transmission does not reach the bus: {why}"));
                }
                Err(_) => {}
            }
        }
        let v: Vec<String> = self.can1.violations.drain(..).collect();
        for m in v {
            cx.report(format!("CAN1: {m}"));
        }
        cx.scs.set_line(irq::CAN, self.can1.irq());
        cx.check_preempt |= cx.scs.any_pending();
        cx.reschedule(self.next_event());
    }

    /// Output pins after a GPIO write: SPI_SEL, SYNC, LDAC edges to the chips.
    fn outputs_changed(&mut self, cx: &mut Cortex) {
        let levels = [
            self.gpio_out(pins::ESC_SEL).unwrap_or(true),
            self.gpio_out(pins::DAC_SYNC).unwrap_or(true),
            if self.func(pins::DAC_LDAC) == pins::LDAC_PWM_FUNC {
                // PWM1.4 drives the pin: its edges come with their times (`pwm_ldac`).
                cx.outputs_last[2]
            } else {
                self.gpio_out(pins::DAC_LDAC).unwrap_or(true)
            },
        ];
        let now = cx.hw_ns();
        cx.io.clock.set_ns(now);
        let [sel, sync, ldac] = levels;
        let [sel0, sync0, ldac0] = cx.outputs_last;
        if sel != sel0 {
            let mut esc = cx.io.esc.esc().borrow_mut();
            if !sel {
                self.esc_session = Some(esc.spi_begin());
            } else if let Some(s) = self.esc_session.take() {
                esc.spi_end(s);
            }
        }
        if sync != sync0 {
            cx.dac_sync(sync);
        }
        if ldac != ldac0 {
            cx.ldac_to(ldac);
        }
        cx.outputs_last = levels;
        self.refresh_inputs(cx);
    }

    /// PWM1.4's edges to LDAC, each at its own time, while P2.3 is PWM1.4 and PCR drives
    /// it (an undriven output leaves the pin high, as at reset).
    fn pwm_ldac(&mut self, cx: &mut Cortex) {
        let edges = std::mem::take(&mut self.pwm1.edges);
        if self.func(pins::DAC_LDAC) != pins::LDAC_PWM_FUNC {
            return;
        }
        if self.pwm1.output(pins::LDAC_PWM_OUTPUT).is_some() {
            for e in edges {
                if usize::from(e.output) == pins::LDAC_PWM_OUTPUT && e.high != cx.outputs_last[2] {
                    cx.io.clock.set_ns(e.time_ns);
                    cx.ldac_to(e.high);
                }
            }
        }
        let level = self.pwm1.output(pins::LDAC_PWM_OUTPUT).unwrap_or(true);
        if level != cx.outputs_last[2] {
            cx.io.clock.set_ns(cx.hw_ns());
            cx.ldac_to(level);
        }
    }

    /// A SYNC0 rising edge from the ESC at the current time.
    pub fn sync0_edge(&mut self, cx: &mut Cortex) {
        if self.func(pins::ESC_SYNC0) != 3 {
            let f = self.func(pins::ESC_SYNC0);
            cx.report(format!(
                "SYNC0 edge: P1.18 is PINSEL function {f}, not 3 (CAP1.0): no capture"
            ));
            return;
        }
        if !self.syscon.powered(Clocked::Timer(1)) {
            cx.report("SYNC0 edge: TIMER1 is not powered (PCONP bit 2): no capture".into());
            return;
        }
        cx.traffic.sync0_captures += 1;
        let t = self.tick_for(cx, Region::Timer(1));
        self.timers[1].capture(t, 0, true);
        self.settle(cx);
    }

    fn spi_byte(&mut self, cx: &mut Cortex) {
        let Some(mosi) = self.spi.take_started() else {
            return;
        };
        if !self.syscon.powered(Clocked::Spi) {
            return;
        }
        let selected = self.esc_session.is_some();
        if !selected {
            self.spi.complete_with(0xFF);
            return;
        }
        let routed = self.routed(
            cx,
            "legacy SPI byte to the ET1100",
            &[
                (pins::ESC_SCK, 3, "SCK"),
                (pins::ESC_MISO, 3, "MISO"),
                (pins::ESC_MOSI, 3, "MOSI"),
            ],
        );
        let esc_mode = cx.io.esc.esc().borrow().peek_u8(0x0150) & 3;
        if self.spi.mode() != esc_mode {
            cx.report(format!(
                "legacy SPI in mode {} but the ET1100 is configured for mode {esc_mode} (0x0150): \
                 the transfer moves no data",
                self.spi.mode()
            ));
        }
        if !routed || self.spi.mode() != esc_mode || self.spi.bits() != 8 {
            self.spi.complete_with(0xFF);
            return;
        }
        let miso = {
            let mut esc = cx.io.esc.esc().borrow_mut();
            let s = self.esc_session.as_mut().expect("selected");
            esc.spi_byte(s, mosi)
        };
        cx.traffic.esc_bytes += 1;
        self.spi.complete_with(miso);
    }

    fn exchange_ssp0(&mut self, cx: &mut Cortex) -> bool {
        let Some(word) = self.ssp0.take_finished() else {
            return false;
        };
        let t = self.tick_for(cx, Region::Ssp0);
        let routed = cx.dac_frame.is_some()
            && self.routed(
                cx,
                "SSP0 frame to the AD5663",
                &[(pins::DAC_SCK, 3, "SCK0"), (pins::DAC_DIN, 3, "MOSI0")],
            );
        if routed {
            if self.ssp0.mode() != 1 && self.ssp0.mode() != 2 {
                cx.report(format!(
                    "SSP0 in SPI mode {}: the AD5663 samples DIN on falling SCLK edges (mode 1 or 2)",
                    self.ssp0.mode()
                ));
            } else {
                cx.dac_word(word, self.ssp0.frame_bits());
            }
        }
        self.ssp0.receive(0);
        self.ssp0.kick(t);
        true
    }

    fn exchange_ssp1(&mut self, cx: &mut Cortex) -> bool {
        let Some(word) = self.ssp1.take_finished() else {
            return false;
        };
        let t = self.tick_for(cx, Region::Ssp1);
        let mut rx = 0;
        let selected = !cx.cnv_high;
        if selected
            && self.routed(
                cx,
                "SSP1 frame to the AD7689",
                &[
                    (pins::ADC_SCK, 2, "SCK1"),
                    (pins::ADC_SDO, 2, "MISO1"),
                    (pins::ADC_DIN, 2, "MOSI1"),
                ],
            )
        {
            if self.ssp1.frame_bits() != 16 || self.ssp1.mode() != 0 {
                cx.report(format!(
                    "SSP1 frames of {} bits in mode {}: the AD7689 read (no busy indicator) \
                     needs 16-bit frames in mode 0",
                    self.ssp1.frame_bits(),
                    self.ssp1.mode()
                ));
            } else {
                rx = cx.adc_read(word);
            }
        }
        self.ssp1.receive(rx);
        self.ssp1.kick(t);
        true
    }

    fn update_cnv(&mut self, cx: &mut Cortex) {
        let high = self.func(pins::ADC_CNV) == 3 && self.timers[2].match_output(0);
        cx.adc_cnv(high);
    }

    // ------------------------------------------------------------------ DMA

    fn dma_requests(&self) -> u32 {
        let mut r = 0;
        if self.ssp0.tx_dma_request() {
            r |= 1;
        }
        if self.ssp0.rx_dma_request() {
            r |= 2;
        }
        if self.ssp1.tx_dma_request() {
            r |= 4;
        }
        if self.ssp1.rx_dma_request() {
            r |= 8;
        }
        let sel = self.syscon.dmareqsel();
        for n in 0..8u32 {
            if sel & (1 << n) != 0 && self.timers[(n / 2) as usize].dma_request((n % 2) as usize) {
                r |= 1 << (8 + n);
            }
        }
        r
    }

    fn run_dma(&mut self, cx: &mut Cortex) -> bool {
        if !self.syscon.powered(Clocked::Gpdma) {
            return false;
        }
        let mut moved = false;
        for _ in 0..64 {
            let Some(x) = self.gpdma.next_transfer(self.dma_requests()) else {
                break;
            };
            moved = true;
            self.dma_move(cx, &x);
            if let Some(line) = x.request {
                if (8..16).contains(&line) {
                    let n = line - 8;
                    self.timers[(n / 2) as usize].clear_dma_request((n % 2) as usize);
                }
            }
            match self.gpdma.transferred(&x) {
                After::LoadItem(at) => {
                    let mut b = [0u8; 16];
                    if self.dma_read(cx, at, &mut b) {
                        let w =
                            |i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
                        self.gpdma.load_item(x.channel, [w(0), w(1), w(2), w(3)]);
                    } else {
                        self.gpdma.error(x.channel);
                    }
                }
                After::Continue | After::Stopped => {}
            }
        }
        moved
    }

    fn dma_reachable(&mut self, cx: &mut Cortex, addr: u32, channel: usize) -> bool {
        // UNCONFIRMED (as the firmware's hw::adc_dma states): the GPDMA reaches the AHB SRAM
        // and the peripherals, not the local SRAM or the flash.
        if (0x1000_0000..0x1000_8000).contains(&addr) || addr < 0x0008_0000 {
            cx.report(format!(
                "GPDMA channel {channel} accessed {addr:#010x} (local SRAM or flash), which the \
                 GPDMA does not reach: bus error"
            ));
            return false;
        }
        true
    }

    fn on_bus(addr: u32) -> bool {
        addr >= 0x4000_0000 || (0x2009_C000..0x200A_0000).contains(&addr)
    }

    fn dma_read(&mut self, cx: &mut Cortex, addr: u32, buf: &mut [u8]) -> bool {
        if Self::on_bus(addr) {
            let base = Self::slot(addr);
            let v = self.bus_read_region(cx, base, (addr - base) & !3);
            let bytes = v.to_le_bytes();
            let n = buf.len();
            buf.copy_from_slice(&bytes[..n]);
            true
        } else if AhbSram::contains(addr, buf.len()) {
            self.ahb_sram.dma_read(addr, buf);
            true
        } else {
            false
        }
    }

    fn dma_move(&mut self, cx: &mut Cortex, x: &Transfer) {
        if !self.dma_reachable(cx, x.src, x.channel) || !self.dma_reachable(cx, x.dst, x.channel) {
            self.gpdma.error(x.channel);
            return;
        }
        let w = x.width as usize;
        let mut buf = [0u8; 4];
        if !self.dma_read(cx, x.src, &mut buf[..w]) {
            self.gpdma.error(x.channel);
            return;
        }
        if Self::on_bus(x.dst) {
            let v = u32::from_le_bytes(buf);
            let base = Self::slot(x.dst);
            self.bus_write_region(cx, base, (x.dst - base) & !3, v);
        } else if AhbSram::contains(x.dst, w) {
            let now = cx.hw_ns();
            self.ahb_sram
                .dma_write(x.dst, &buf[..w], Self::on_bus(x.src), now);
        } else {
            self.gpdma.error(x.channel);
        }
    }

    // ------------------------------------------------------------------ bus

    fn powered(&mut self, cx: &mut Cortex, region: Region) -> bool {
        match region.clocked() {
            Some(c) if !self.syscon.powered(c) => {
                cx.report(format!(
                    "access to {} while its PCONP bit {} is 0: the peripheral does not respond",
                    c.name(),
                    c.pconp_bit().unwrap_or(0)
                ));
                false
            }
            _ => true,
        }
    }

    fn periph(&mut self, region: Region) -> Option<&mut dyn Peripheral> {
        Some(match region {
            Region::Wdt => &mut self.wdt,
            Region::Timer(n) => &mut self.timers[n],
            Region::Spi => &mut self.spi,
            Region::GpioInt => &mut self.gpioint,
            Region::PinConnect => &mut self.pincon,
            Region::Ssp1 => &mut self.ssp1,
            Region::Ssp0 => &mut self.ssp0,
            Region::Syscon => &mut self.syscon,
            Region::Gpio => &mut self.gpio,
            Region::Gpdma => &mut self.gpdma,
            Region::Can1 => &mut self.can1,
            Region::Pwm1 => &mut self.pwm1,
            Region::Scs | Region::CanAf | Region::Unmodelled(_) => return None,
        })
    }

    /// A read by the CPU (or DMA) at `offset` in the slot at `base`.
    pub fn bus_read_region(&mut self, cx: &mut Cortex, base: u32, offset: u32) -> u32 {
        let region = Region::of_base(base);
        if region == Region::Scs {
            return cx.scs.read(offset, cx.cycles);
        }
        if region == Region::CanAf {
            // CANAFMR; the look-up table registers read as zero (table mode is reported).
            return if offset == 0 { self.can1.afmr() } else { 0 };
        }
        if let Region::Unmodelled(b) = region {
            cx.stop = Some(Stop::Fault(format!(
                "read of {:#010x}: a peripheral the co-simulator does not model",
                b + offset
            )));
            return 0;
        }
        if !self.powered(cx, region) {
            return 0;
        }
        if region == Region::Gpio || region == Region::GpioInt {
            self.refresh_inputs(cx);
        }
        let t = self.tick_for(cx, region);
        self.periph(region).map_or(0, |p| p.read(t, offset))
    }

    /// A write by the CPU (or DMA).
    pub fn bus_write_region(&mut self, cx: &mut Cortex, base: u32, offset: u32, value: u32) {
        let region = Region::of_base(base);
        if region == Region::Scs {
            let effect = cx.scs.write(offset, 4, value, cx.cycles);
            if effect.reset_request {
                cx.stop = Some(Stop::Reset(ResetCause::SysResetReq));
            }
            cx.check_preempt = cx.scs.any_pending();
            cx.reschedule(self.next_event());
            return;
        }
        if region == Region::CanAf {
            if offset == 0 {
                self.can1.set_afmr(value);
            } else {
                cx.report(format!(
                    "write of {value:#x} to the CAN acceptance filter's look-up table register \
                     {:#010x}: table mode is not modelled",
                    base + offset
                ));
            }
            return;
        }
        if let Region::Unmodelled(b) = region {
            cx.stop = Some(Stop::Fault(format!(
                "write of {value:#x} to {:#010x}: a peripheral the co-simulator does not model",
                b + offset
            )));
            return;
        }
        if !self.powered(cx, region) {
            return;
        }
        let t = self.tick_for(cx, region);
        if let Some(p) = self.periph(region) {
            p.write(t, offset, value);
        }
        match region {
            Region::Syscon => {
                if self.syscon.take_clock_change() {
                    cx.set_cycle_time(self.syscon.cclk_hz());
                }
                let v: Vec<String> = self.syscon.violations.drain(..).collect();
                for m in v {
                    cx.report(format!("SYSCON: {m}"));
                }
            }
            Region::Spi => {
                self.spi_byte(cx);
                let v: Vec<String> = self.spi.violations.drain(..).collect();
                for m in v {
                    cx.report(format!("SPI: {m}"));
                }
            }
            Region::Gpio => self.outputs_changed(cx),
            Region::Can1 => self.can_exchange(cx),
            Region::Wdt if self.wdt.take_reset_request() => {
                cx.stop = Some(Stop::Reset(ResetCause::Watchdog));
            }
            _ => {}
        }
    }

    /// The slot base of a bus address (16 KB APB slots; the SCS is one 4 KB block).
    fn slot(addr: u32) -> u32 {
        if addr >= 0xE000_0000 {
            addr & !0xFFF
        } else {
            addr & !0x3FFF
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    //! The LPC1754's wiring driven through the bus; the helpers serve the machine's tests too.

    use super::*;
    use crate::image::Image;
    use crate::machine::Machine;
    use std::rc::Rc;
    use virtual_board::rig::board::{BoardConfig, VirtualBoard as Board};

    /// A chip with blank flash on a board (no CPU: the tests drive the bus and the time).
    pub(crate) fn machine() -> (Board, Machine) {
        machine_with_flash(vec![0xFF; 0x8_0000])
    }

    /// A chip whose flash is all NOPs (16-bit: one instruction per 2 bytes).
    pub(crate) fn machine_of_nops() -> (Board, Machine) {
        machine_with_flash([0x00, 0xBF].repeat(0x4_0000))
    }

    pub(crate) fn machine_with_flash(flash: Vec<u8>) -> (Board, Machine) {
        let board = Board::new(BoardConfig::new(vec![0xFF; 2048]));
        let image = Image::bare(crate::chip::Chip::Lpc1754, flash);
        let m = Machine::new(board.io(), Rc::new(image));
        (board, m)
    }

    /// The machine's LPC1754 models.
    pub(crate) fn lpc(m: &Machine) -> &Lpc17xx {
        m.lpc17xx().expect("an LPC1754")
    }

    const PINSEL4: u32 = 0x4002_C010;
    const PCONP: u32 = 0x400F_C0C4;
    const PCLKSEL0: u32 = 0x400F_C1A8;
    const PWM1: u32 = 0x4001_8000;

    /// PWM1 as the oversampling outputs run it: period 100 ticks, PWM1.4 single edge, low
    /// from MR4 = 80 to the period's end, MR4 interrupt; P2.3 in function `func`.
    pub(crate) fn ldac_pwm(m: &mut Machine, func: u32) {
        m.cpu_write(PCONP, 4, PCONP_RESET | 1 << 6);
        m.cpu_write(PCLKSEL0, 4, 1 << 12);
        m.cpu_write(PINSEL4, 4, func << 6);
        m.cpu_write(PWM1 + 0x04, 4, 2);
        m.cpu_write(PWM1 + 0x18, 4, 99);
        m.cpu_write(PWM1 + 0x40, 4, 80);
        m.cpu_write(PWM1 + 0x14, 4, 1 << 1 | 1 << 12);
        m.cpu_write(PWM1 + 0x4C, 4, 1 << 12);
        m.cpu_write(PWM1 + 0x50, 4, 0x11);
        m.cpu_write(PWM1 + 0x04, 4, 1 | 8);
    }

    /// Serves the events up to `t_ns` without a CPU.
    pub(crate) fn run_to(m: &mut Machine, t_ns: u64) {
        while m.next_event_ns() <= t_ns {
            let e = m.next_event_ns();
            m.sleep_until(e);
            m.service_due();
        }
        m.sleep_until(t_ns);
    }

    #[test]
    fn pwm1_4_drives_ldac_on_p2_3_in_function_1_each_edge_at_its_time() {
        let (board, mut m) = machine();
        ldac_pwm(&mut m, 1);
        let start = m.now_ns();
        let tick = 1_000_000_000 / lpc(&m).syscon.pclk_hz(Clocked::Pwm1);
        run_to(&mut m, start + 50 * 100 * tick);
        let dac = board.dac().borrow();
        let all: Vec<u64> = dac
            .ldac_edges
            .iter()
            .filter(|e| e.falling)
            .map(|e| e.time_ns)
            .collect();
        // PWM1.4 is low until the first cycle starts: LDAC falls once when PCR drives the
        // pin (before the first MR0 reset), then once per period.
        assert!(all[0] < start + 100 * tick, "{all:?}");
        let falls = &all[1..];
        assert!(falls.len() >= 48, "{} falling edges", falls.len());
        // One fall per period, each at MR4 of its cycle: on a grid of 100 ticks.
        for t in falls {
            assert_eq!((t - falls[0]) % (100 * tick), 0, "{t}");
        }
        for w in falls.windows(2) {
            assert_eq!(w[1] - w[0], 100 * tick);
        }
        // Low for the last 20 ticks of each cycle.
        let rise = dac
            .ldac_edges
            .iter()
            .find(|e| !e.falling && e.time_ns > falls[0])
            .unwrap();
        assert_eq!(rise.time_ns - falls[0], 20 * tick);
        assert_eq!(m.traffic.ldac_pulses, all.len() as u64);
        assert!(lpc(&m).pwm1.irq(), "MR4 raises PWM1's interrupt");
        assert!(m.reports.is_empty(), "{:?}", m.reports);
    }

    #[test]
    fn pwm1_edges_do_not_reach_ldac_while_p2_3_is_gpio() {
        let (board, mut m) = machine();
        ldac_pwm(&mut m, 0);
        let start = m.now_ns();
        run_to(&mut m, start + 1_000_000);
        assert!(lpc(&m).pwm1.matches[4] > 0, "PWM1 runs");
        assert!(board.dac().borrow().ldac_edges.is_empty());
        assert_eq!(m.traffic.ldac_pulses, 0);
    }
}
