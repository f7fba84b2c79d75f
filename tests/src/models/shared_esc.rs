//! The ESC model as the board's threads share it: the thread that answers frames on a
//! network interface and the thread that runs the CPU both reach the one [`Esc`] through a
//! lock, as the ET1100's EtherCAT and PDI sides reach its one memory.
//!
//! In process (one thread, virtual time) the lock is never contended and the ESC's time is
//! moved by the board ([`Esc::advance`]). On the wall clock ([`SharedEsc::follow_wall_clock`])
//! the ESC keeps its own time, as the chip does with its own crystal: every lock first brings
//! it to the time elapsed on the wall clock ([`WallClock`], slowed down or not), whoever
//! takes it (a frame, an SPI byte, the board), so a frame is answered from the ESC's state at
//! its arrival without waiting for the CPU, and DC system time, SYNC edges, the SM watchdog
//! and EEPROM busy times run at the clock's speed. The SYNC edges this produces wait in the
//! ESC for the board to hand them to the CPU ([`SharedEsc::take_edges`]).

use crate::models::esc::{Esc, SyncEdge};
use crate::rig::pi_mutex::{PiGuard, PiMutex};
use std::ops::{Deref, DerefMut};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A handle on the ESC model; clones share it, across threads too. The lock inherits
/// priority ([`PiMutex`]): the frame-answering thread never waits on a holder that a
/// thread of middle priority keeps from running.
#[derive(Clone)]
pub struct SharedEsc(Arc<PiMutex<Held>>);

struct Held {
    esc: Esc,
    wall: Option<WallClock>,
    edges: Vec<SyncEdge>,
}

/// The board's time on the wall clock: `at_start_ns` at `start`, then the time elapsed,
/// divided by `slowdown` (1: real time). A board slowed down N times is the module a master
/// sees at full speed when the master's own cycle and timeouts are N times as long: a
/// co-simulator slower than real time then keeps up with its clock.
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    start: Instant,
    at_start_ns: u64,
    slowdown: u32,
}

impl WallClock {
    /// `at_start_ns` (board time) at `start`; `slowdown` wall nanoseconds per board
    /// nanosecond from then on (at least 1).
    pub fn new(start: Instant, at_start_ns: u64, slowdown: u32) -> Self {
        Self {
            start,
            at_start_ns,
            slowdown: slowdown.max(1),
        }
    }

    /// The board's time now.
    pub fn now_ns(&self) -> u64 {
        self.at(Instant::now())
    }

    /// The board's time at wall time `at` (`at_start_ns` before the start).
    pub fn at(&self, at: Instant) -> u64 {
        let elapsed = at.saturating_duration_since(self.start).as_nanos() as u64;
        self.at_start_ns + elapsed / u64::from(self.slowdown)
    }

    /// The wall time `board_ns` of board time takes.
    pub fn wall_time(&self, board_ns: u64) -> Duration {
        Duration::from_nanos(board_ns.saturating_mul(u64::from(self.slowdown)))
    }

    /// The board time that passes in wall time `wall`.
    pub fn board_time(&self, wall: Duration) -> u64 {
        (wall.as_nanos() / u128::from(self.slowdown)).min(u128::from(u64::MAX)) as u64
    }

    /// When the clock started (wall).
    pub fn start(&self) -> Instant {
        self.start
    }

    /// Wall nanoseconds per board nanosecond.
    pub fn slowdown(&self) -> u32 {
        self.slowdown
    }
}

/// The locked ESC (dereferences to [`Esc`]); the lock is released when it is dropped.
pub struct EscGuard<'a> {
    held: PiGuard<'a, Held>,
}

impl Deref for EscGuard<'_> {
    type Target = Esc;
    fn deref(&self) -> &Esc {
        &self.held.esc
    }
}

impl DerefMut for EscGuard<'_> {
    fn deref_mut(&mut self) -> &mut Esc {
        &mut self.held.esc
    }
}

impl SharedEsc {
    /// Shares `esc`, on the board's virtual time.
    pub fn new(esc: Esc) -> Self {
        Self(Arc::new(PiMutex::new(Held {
            esc,
            wall: None,
            edges: Vec::new(),
        })))
    }

    /// Locks the ESC (on the wall clock: brought to the wall clock's time first). The name
    /// and [`SharedEsc::borrow_mut`] are the `RefCell` ones the board's code grew up with:
    /// both take the same lock, and a thread must not hold two guards at once.
    pub fn borrow(&self) -> EscGuard<'_> {
        let mut g = EscGuard {
            held: self.0.lock(),
        };
        if let Some(wall) = g.held.wall {
            let (now, t) = (g.held.esc.now_ns(), wall.now_ns());
            if t > now {
                let edges = g.held.esc.advance(t - now);
                g.held.edges.extend(edges);
            }
        }
        g
    }

    /// See [`SharedEsc::borrow`] (the same lock).
    pub fn borrow_mut(&self) -> EscGuard<'_> {
        self.borrow()
    }

    /// From now on the ESC's time follows the wall clock `clock` (the ESC is brought to its
    /// start first if it is behind). Its SYNC edges collect for [`SharedEsc::take_edges`].
    pub fn follow_wall_clock(&self, clock: WallClock) {
        let mut g = self.borrow();
        let now = g.now_ns();
        if clock.at_start_ns > now {
            let edges = g.advance(clock.at_start_ns - now);
            g.held.edges.extend(edges);
        }
        g.held.wall = Some(clock);
    }

    /// Back to the board's virtual time (the ESC keeps the time it reached).
    pub fn follow_virtual_time(&self) {
        self.borrow().held.wall = None;
    }

    /// Whether the ESC's time follows the wall clock.
    pub fn on_wall_clock(&self) -> bool {
        self.borrow().held.wall.is_some()
    }

    /// Whether SYNC edges the ESC produced on the wall clock wait to be taken, and when (ESC
    /// time) the next one comes, both at once after bringing the ESC to the wall clock's time.
    pub fn wall_edges(&self) -> (bool, Option<u64>) {
        let g = self.borrow();
        (!g.held.edges.is_empty(), g.next_sync_edge_ns())
    }

    /// The SYNC edges the ESC produced on the wall clock since the last call, in order.
    pub fn take_edges(&self) -> Vec<SyncEdge> {
        std::mem::take(&mut self.borrow().held.edges)
    }

    /// The first SYNC edge produced on the wall clock that waits to be taken, taken.
    pub fn take_first_edge(&self) -> Option<SyncEdge> {
        let mut g = self.borrow();
        (!g.held.edges.is_empty()).then(|| g.held.edges.remove(0))
    }

    /// When (ESC time) the first SYNC edge that waits to be taken came.
    pub fn first_waiting_edge_ns(&self) -> Option<u64> {
        self.borrow().held.edges.first().map(|e| e.time_ns)
    }

    /// Whether a SYNC edge comes at `t_ns` or at most `within_ns` after it: the ESC's next
    /// one, or one produced on the wall clock that waits to be taken. A CPU stepped up to
    /// such a time stops there exactly (not at the end of the instruction block that
    /// reaches it, which could pass the edge).
    pub fn sync_edge_near(&self, t_ns: u64, within_ns: u64) -> bool {
        let g = self.borrow();
        let near = |e: u64| (t_ns..=t_ns.saturating_add(within_ns)).contains(&e);
        g.next_sync_edge_ns().is_some_and(near) || g.held.edges.iter().any(|e| near(e.time_ns))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::esc::{regs, EscConfig};

    fn esc() -> SharedEsc {
        SharedEsc::new(Esc::new(EscConfig::new(
            crate::rig::sii_builder::minimal_io_device(),
        )))
    }

    #[test]
    fn on_the_wall_clock_every_lock_brings_the_esc_to_the_time_elapsed() {
        let esc = esc();
        esc.borrow_mut().advance(5_000);
        let start = Instant::now();
        esc.follow_wall_clock(WallClock::new(start, 5_000, 1));
        std::thread::sleep(Duration::from_millis(2));
        let t = esc.borrow().now_ns();
        let elapsed = start.elapsed().as_nanos() as u64;
        assert!(t >= 5_000 + 2_000_000 && t <= 5_000 + elapsed, "{t}");
        esc.follow_virtual_time();
        let t2 = esc.borrow().now_ns();
        std::thread::sleep(Duration::from_millis(1));
        assert_eq!(esc.borrow().now_ns(), t2, "virtual time stands still");
    }

    #[test]
    fn a_slowed_down_clock_runs_that_many_times_slower_than_the_wall_clock() {
        let start = Instant::now();
        let clock = WallClock::new(start, 7, 10);
        assert_eq!(clock.at(start + Duration::from_millis(5)), 7 + 500_000);
        assert_eq!(
            clock.at(start - Duration::from_millis(1)),
            7,
            "not before its start"
        );
        assert_eq!(clock.wall_time(500_000), Duration::from_millis(5));
        assert_eq!(clock.board_time(Duration::from_millis(5)), 500_000);
        assert_eq!(WallClock::new(start, 0, 0).slowdown(), 1, "never stopped");
        let esc = esc();
        esc.follow_wall_clock(WallClock::new(start, 0, 10));
        std::thread::sleep(Duration::from_millis(4));
        let t = esc.borrow().now_ns();
        let elapsed = start.elapsed().as_nanos() as u64;
        assert!(
            t >= 400_000 && t <= elapsed / 10,
            "{t} ns of ESC time in {elapsed} ns"
        );
    }

    #[test]
    fn sync_edges_of_the_wall_clock_wait_for_the_board() {
        let esc = esc();
        {
            let mut e = esc.borrow_mut();
            // SYNC0 every 100 us from system time 0 (the local clock starts at 1 ms).
            e.ecat_write(regs::DC_SYNC0_CYCLE, &100_000u32.to_le_bytes());
            let start = e.dc_system_time() + 100_000;
            e.ecat_write(regs::DC_START_TIME, &start.to_le_bytes());
            e.ecat_write(regs::DC_ACTIVATION, &[0x03]);
        }
        esc.follow_wall_clock(WallClock::new(Instant::now(), 0, 1));
        std::thread::sleep(Duration::from_millis(2));
        let edges = esc.take_edges();
        assert!(edges.len() >= 15, "{} edges", edges.len());
        assert!(edges
            .windows(2)
            .all(|w| w[1].time_ns - w[0].time_ns == 100_000));
        assert!(esc.take_edges().len() <= 1, "taken once");
    }

    #[test]
    fn another_thread_answers_while_this_one_does_not_hold_the_lock() {
        let esc = esc();
        let other = esc.clone();
        let t = std::thread::spawn(move || other.borrow_mut().ecat_write(0x0F80, &[0x5A]));
        t.join().unwrap();
        assert_eq!(esc.borrow().peek_u8(0x0F80), 0x5A);
    }

    #[test]
    #[should_panic(expected = "locked twice by one thread")]
    fn locking_twice_in_one_thread_is_a_clear_failure() {
        let esc = esc();
        let _a = esc.borrow();
        let _b = esc.borrow();
    }
}
