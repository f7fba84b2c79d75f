//! Output oversampling's hardware (docs/book/oversampling.md, section 4): PWM1 clocks the
//! AD5663's LDAC and Timer1's MR1 the frames.
//!
//! - **LDAC = PWM1.4 on P2.3** (PINSEL function 1, the board's LDAC wire): single edge,
//!   period P = T/n ticks, low for the last [`LDAC_LOW_TICKS`] ticks of each period; the
//!   falling edge latches both channels at once, to the PCLK tick, with no CPU.
//! - **Frames after each edge**: Timer1 (the time base, same PCLK) interrupts 1 us after
//!   every LDAC edge (MR1) and the SYNC0 task writes the next update into the input
//!   registers (two 24-bit frames on SSP0, LDAC register 0: nothing changes until the
//!   next edge). A timer-driven path instead of a DMA ring: no board wire moves (SYNC stays
//!   a GPIO on P2.2), at the cost of one interrupt per update (the bench measures it).
//! - **Lock**: at each SYNC0 edge the PWM's phase at the captured edge is measured (TC of
//!   both timers read back to back) and one period is corrected ([`GridLock`]); the grid
//!   starts aligned to the edge it starts at.
//!
//! Outside output oversampling P2.3 is the GPIO LDAC of `hw::dac` and PWM1 is stopped.
//! UNCONFIRMED (UM10360 does not say it in these words; the co-simulator's PWM1 model
//! follows it): a TC written while the counter is stopped is where it starts, and the first
//! PWM cycle starts at the first MR0 reset (PWM1.4 low until then: one LDAC fall when the
//! pin switches, which latches the input registers as they are).

use super::timers::{Sync0Capture, TICK_NS};
use firmware::io::analog::output_blocks::{Grid, GridLock, UpdatePlayer};
use firmware::io::analog::outputs::{DacPair, OutputStage};
use lpc17xx_pac as pac;

/// PWM1's registers (UM10360 24.6; the PAC's PWM1 block lacks MR0..MR3).
const PWM1: usize = 0x4001_8000;
const IR: usize = 0x00;
const TCR: usize = 0x04;
const TC: usize = 0x08;
const PR: usize = 0x0C;
const MCR: usize = 0x14;
const MR0: usize = 0x18;
const MR4: usize = 0x40;
const PCR: usize = 0x4C;
const LER: usize = 0x50;
const TCR_ENABLE: u32 = 1;
const TCR_RESET: u32 = 2;
const TCR_PWM: u32 = 8;
/// MCR: reset on MR0.
const MCR_MR0R: u32 = 1 << 1;
/// PCR: PWM1.4 output enabled (single edge).
const PCR_ENA4: u32 = 1 << 12;
/// LER: MR0 and MR4 shadows latch at the next cycle start.
const LER_MR0: u32 = 1 << 0;
const LER_MR4: u32 = 1 << 4;
/// PINSEL4 (P2.0..P2.15), P2.3's field: 00 GPIO, 01 PWM1.4.
const PINSEL4: usize = 0x4002_C010;
const P2_3_SHIFT: u32 = 6;
/// The update interrupt comes this long after the LDAC edge (ticks): LDAC is high again
/// (its low time is 200 ns) before the frames start.
const UPDATE_DELAY_TICKS: u32 = 100;

fn write(offset: usize, value: u32) {
    // SAFETY: a PWM1 register of UM10360 24.6 (the grid owns PWM1: `LdacGrid::new` takes
    // the PAC's singleton).
    unsafe { core::ptr::write_volatile((PWM1 + offset) as *mut u32, value) }
}

fn read(offset: usize) -> u32 {
    // SAFETY: as in `write`; reads of these registers have no side effect.
    unsafe { core::ptr::read_volatile((PWM1 + offset) as *const u32) }
}

/// P2.3 to PINSEL function `func` (0 GPIO, 1 PWM1.4).
fn ldac_pin_function(func: u32) {
    let sel = PINSEL4 as *mut u32;
    // SAFETY: PINSEL4's P2.3 field only; the pin map (`hw::board`) configured the rest at
    // start-up and nothing else writes PINSEL4 afterwards (the SYNC0 task owns the grid).
    unsafe {
        let v = core::ptr::read_volatile(sel) & !(0b11 << P2_3_SHIFT);
        core::ptr::write_volatile(sel, v | func << P2_3_SHIFT);
    }
}

/// The LDAC grid and its update player (owner: the SYNC0/DAC task).
pub struct LdacGrid {
    /// The grid running (`Grid::OFF`: stopped, P2.3 a GPIO).
    grid: Grid,
    lock: GridLock,
    player: UpdatePlayer,
    /// Ticks of Timer1 at the last SYNC0 edge, and the updates since.
    edge_ticks: u32,
    updates: u32,
}

impl LdacGrid {
    /// Stopped. PWM1 is powered and clocked by `hw::clocks`.
    pub fn new(_pwm: pac::PWM1) -> Self {
        Self {
            grid: Grid::OFF,
            lock: GridLock::new(1),
            player: UpdatePlayer::new(1),
            edge_ticks: 0,
            updates: 0,
        }
    }

    /// A SYNC0 edge captured at `edge_ns` (the time base) while the stage asks for `grid`:
    /// starts, stops or locks the grid. Returns whether it runs: then the caller serves the
    /// edge's update at once ([`Self::on_update`]), which schedules the next.
    pub fn on_sync0(&mut self, sync0: &mut Sync0Capture, grid: Grid, edge_ns: u64) -> bool {
        let edge_ticks = (edge_ns as u32) / TICK_NS as u32;
        let period = grid.period;
        if grid != self.grid {
            if grid == Grid::OFF {
                self.stop(sync0);
                return false;
            }
            self.start(grid, edge_ticks, sync0);
        } else if period != 0 {
            // TC of both timers back to back: PWM1's TC at the captured edge.
            let since = sync0.ticks().wrapping_sub(edge_ticks);
            let tc = read(TC);
            let at_edge = (tc % period + period - since % period) % period;
            if let Some(mr0) = self.lock.on_edge(at_edge) {
                write(MR0, mr0);
                write(LER, LER_MR0);
            }
        } else {
            return false;
        }
        self.player.on_sync0();
        self.edge_ticks = edge_ticks;
        self.updates = 0;
        true
    }

    /// After LDAC edge k of the cycle (0: the SYNC0 edge, served by the SYNC0 task itself;
    /// then the update interrupts): schedules the interrupt after edge k + 1 while the
    /// cycle has one (the next cycle's come from its SYNC0 edge) and returns the pair to
    /// write into the input registers (`None`: write nothing, the outputs hold).
    pub fn on_update(&mut self, sync0: &mut Sync0Capture, stage: &OutputStage) -> Option<DacPair> {
        let grid = self.grid;
        if grid == Grid::OFF || self.updates >= grid.updates {
            return None;
        }
        if let Some(mr0) = self.lock.restore(read(LER) & LER_MR0 == 0) {
            write(MR0, mr0);
            write(LER, LER_MR0);
        }
        self.updates += 1;
        if self.updates < grid.updates {
            let next = self
                .edge_ticks
                .wrapping_add(self.updates.wrapping_mul(grid.period))
                .wrapping_add(UPDATE_DELAY_TICKS);
            sync0.schedule_update(next);
        }
        let pair = self
            .player
            .after_edge(&stage.blocks, stage.sync0_counts().edges)?;
        stage.record_applied(pair);
        Some(pair)
    }

    /// Starts PWM1 with its falling edges on the grid of the edge at `edge_ticks`.
    fn start(&mut self, grid: Grid, edge_ticks: u32, sync0: &Sync0Capture) {
        let period = grid.period;
        self.grid = grid;
        self.lock = GridLock::new(period);
        self.player = UpdatePlayer::new(grid.updates);
        write(TCR, TCR_RESET);
        write(PR, 0);
        write(MR0, self.lock.mr0());
        write(MR4, self.lock.mr4());
        write(MCR, MCR_MR0R);
        write(PCR, PCR_ENA4);
        write(LER, LER_MR0 | LER_MR4);
        write(TCR, 0);
        // TC = MR4 at the edge: the falls lie on edge + k P (the next lock trims the
        // instructions between this read and the enable).
        let since = sync0.ticks().wrapping_sub(edge_ticks);
        write(TC, (self.lock.mr4() + since % period) % period);
        write(TCR, TCR_ENABLE | TCR_PWM);
        ldac_pin_function(1);
    }

    fn stop(&mut self, sync0: &mut Sync0Capture) {
        ldac_pin_function(0);
        write(TCR, TCR_RESET);
        write(MCR, 0);
        write(IR, 0x73F);
        sync0.stop_updates();
        self.grid = Grid::OFF;
    }
}
