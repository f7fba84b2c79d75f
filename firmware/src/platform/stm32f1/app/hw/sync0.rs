//! TIM8 at 72 MHz (APB2 timer clock), free running: CH1 captures SYNC0's rising edge (PC6,
//! TI1), CH2 drives the AD5663's LDAC (PC7) by forced output levels, so the pin stays a
//! timer output (a one-pulse triggered by SYNC0 can take it over without rewiring). The
//! DAC task owns both; the capture is placed on the cycle-counter time base (same clock).

use super::{pac, read, time, write};
use core::convert::Infallible;
use firmware::platform::stm32f1::time::{capture_cycles, cycles_to_ns};

/// TIMx_CCMR1: CH1 input capture from TI1 (CC1S 01, no filter, no prescaler) ...
const CC1S_TI1: u32 = 0b01;
/// ... with CH2 forced inactive (OC2M 100: LDAC low) ...
const CCMR1_LDAC_LOW: u32 = CC1S_TI1 | 0b100 << 12;
/// ... or forced active (OC2M 101: LDAC high, its idle level).
const CCMR1_LDAC_HIGH: u32 = CC1S_TI1 | 0b101 << 12;
/// TIMx_CCER: CH1 capture on the rising edge, CH2 output active high.
const CCER: u32 = 1 << 0 | 1 << 4;
/// TIMx_BDTR: main output enable (an advanced timer's outputs stay off without it).
const BDTR_MOE: u32 = 1 << 15;
/// TIMx_DIER: CC1 interrupt.
const DIER_CC1IE: u32 = 1 << 1;
/// TIMx_SR: CC1 captured, CC1 over-captured (an edge lost while the first was unread).
const SR_CC1IF: u32 = 1 << 1;
const SR_CC1OF: u32 = 1 << 9;
/// TIMx_EGR: update (loads PSC/ARR).
const EGR_UG: u32 = 1 << 0;
/// TIMx_CR1: counter enable.
const CR1_CEN: u32 = 1 << 0;

/// What woke the DAC task.
pub enum Tim8Event {
    /// A SYNC0 edge: TIM8's 16-bit capture of it, for [`Sync0Capture::capture_ns`] once
    /// LDAC is done.
    Sync0(u16),
    /// Pended by software (apply or preload outputs).
    Pended,
}

/// SYNC0's capture (owner: the DAC task).
pub struct Sync0Capture {
    tim: pac::TIM8,
}

/// Starts TIM8 (capture armed, LDAC high) and splits it.
pub fn init(tim: pac::TIM8) -> (Sync0Capture, LdacPin) {
    write(tim.psc(), 0);
    write(tim.arr(), 0xFFFF);
    write(tim.ccmr1_input(), CCMR1_LDAC_HIGH);
    write(tim.ccer(), CCER);
    write(tim.bdtr(), BDTR_MOE);
    write(tim.egr(), EGR_UG);
    write(tim.sr(), 0);
    write(tim.dier(), DIER_CC1IE);
    write(tim.cr1(), CR1_CEN);
    (Sync0Capture { tim }, LdacPin(()))
}

impl Sync0Capture {
    /// Reads the capture (which clears its flag) or tells a software pend. Only the
    /// registers: the edge's place on the time base waits until after LDAC.
    pub fn on_interrupt(&mut self) -> Tim8Event {
        if read(self.tim.sr()) & SR_CC1IF == 0 {
            return Tim8Event::Pended;
        }
        let captured = read(self.tim.ccr1()) as u16;
        // rc_w0: clears the over-capture flag only.
        write(self.tim.sr(), !SR_CC1OF & 0xFFFF);
        Tim8Event::Sync0(captured)
    }

    /// The time base (ns) of a capture taken less than 65 536 cycles (0.9 ms) ago: the
    /// counter's 16 bits place it against the time base's cycles now.
    pub fn capture_ns(&self, captured: u16) -> u64 {
        let counter = read(self.tim.cnt()) as u16;
        let now = time::now_cycles();
        cycles_to_ns(capture_cycles(now, counter, captured))
    }
}

/// CPU cycles LDAC stays low: twice the (UNCONFIRMED) minimum pulse width of the driver's
/// `unconfirmed` module.
const LDAC_LOW_CYCLES: u32 = (2
    * ad5663::unconfirmed::LDAC_LOW_MIN_NS
    * (firmware::platform::stm32f1::time::CYCLE_HZ / 1_000_000))
    .div_ceil(1000);

/// The LDAC pin (TIM8_CH2, active low), driven by forcing CH2's output level.
#[derive(Debug)]
pub struct LdacPin(());

impl LdacPin {
    fn ccmr1(value: u32) {
        // SAFETY: TIM8_CCMR1, written whole with CH1's capture bits unchanged; only the DAC
        // task (which owns `Sync0Capture` too) writes it after `init`.
        let tim = unsafe { &*pac::TIM8::ptr() };
        write(tim.ccmr1_input(), value);
    }
}

impl embedded_hal::digital::ErrorType for LdacPin {
    type Error = Infallible;
}

impl embedded_hal::digital::OutputPin for LdacPin {
    #[inline(always)]
    fn set_low(&mut self) -> Result<(), Infallible> {
        Self::ccmr1(CCMR1_LDAC_LOW);
        Ok(())
    }

    /// Waits out the minimum low time first.
    #[inline(always)]
    fn set_high(&mut self) -> Result<(), Infallible> {
        cortex_m::asm::delay(LDAC_LOW_CYCLES);
        Self::ccmr1(CCMR1_LDAC_HIGH);
        Ok(())
    }
}
