//! Where the image spends its cycles and its stack, per exception (the RTIC tasks are
//! exception handlers) and per function: the figures of the image facts and of
//! `cargo xtask bench`'s image rows.
//!
//! - Every cycle is charged to one *context*: the innermost active exception, or thread mode
//!   (init and idle), or sleep (WFI). Exception entry is charged to the exception entered,
//!   its return to the exception returning, so the own cycles of all contexts add up to the
//!   run's cycles.
//! - Per activation: cycles from entry to return (nested preemptions included) and the stack
//!   it used itself: SP before its frame was stacked minus the lowest SP seen while it was the
//!   innermost exception (its frame included; what nested exceptions push is theirs). The
//!   lowest SP of a block is decoded from its instructions ([`crate::thumb`]), so a push
//!   and pop within one block count too.
//! - Per context and code chain ([`crate::code`]): instructions executed, so a function's
//!   cycles can be told inlined or not.

/// Exception numbers the profile keeps (the LPC17xx has 16 + 35, the STM32F103 16 + 60).
pub const EXCEPTIONS: usize = 80;
/// The context of thread mode.
pub const THREAD: u32 = 0;

/// Figures of one exception (or of thread mode, number 0).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ExceptionStats {
    /// Returns seen (activations completed).
    pub count: u64,
    /// Cycles between entry and return, nested exceptions included, summed.
    pub cycles: u64,
    /// The longest entry-to-return.
    pub max_cycles: u64,
    /// Virtual time (ns) of the longest activation's entry.
    pub max_at_ns: u64,
    /// Cycles of its own code, entry and return (nested exceptions excluded).
    pub own_cycles: u64,
    /// Deepest stack one activation used itself (bytes, its exception frame included).
    pub max_stack: u32,
    /// Virtual time (ns) of the first entry.
    pub first_entry_ns: Option<u64>,
    /// Instructions per chain of the longest activation's own code, most first.
    pub longest_code: Vec<(u32, u64)>,
}

#[derive(Clone, Debug)]
struct Activation {
    exception: u32,
    entry_cycle: u64,
    entry_ns: u64,
    sp_before: u32,
    lowest_sp: u32,
    /// (chain, instructions) of its own blocks, as they ran.
    code: Vec<(u32, u32)>,
}

/// The profile of a run.
#[derive(Clone, Debug)]
pub struct Profile {
    /// Per exception number; index 0 is thread mode.
    pub exceptions: Vec<ExceptionStats>,
    /// Cycles asleep in WFI.
    pub sleep_cycles: u64,
    active: Vec<Activation>,
    thread_top_sp: u32,
    thread_lowest_sp: u32,
    /// Thread mode's lowest SP since the first exception (RTIC's init runs with interrupts
    /// off: what thread mode uses from then on is idle's, which tasks can preempt).
    thread_lowest_sp_with_tasks: Option<u32>,
    /// Instructions per context (exception number) and chain.
    instructions: Vec<Vec<u64>>,
}

impl Profile {
    /// An empty profile; `initial_sp` is thread mode's stack top.
    pub fn new(initial_sp: u32) -> Self {
        Self {
            exceptions: vec![ExceptionStats::default(); EXCEPTIONS],
            sleep_cycles: 0,
            active: Vec::new(),
            thread_top_sp: initial_sp,
            thread_lowest_sp: initial_sp,
            thread_lowest_sp_with_tasks: None,
            instructions: vec![Vec::new(); EXCEPTIONS],
        }
    }

    /// After a reset: nothing is active; the figures so far stay.
    pub fn reset(&mut self) {
        self.active.clear();
    }

    /// The context cycles are charged to now.
    pub fn context(&self) -> u32 {
        self.active.last().map_or(THREAD, |a| a.exception)
    }

    /// `cycles` of the current context.
    pub fn charge(&mut self, cycles: u64) {
        let c = self.context() as usize;
        self.exceptions[c].own_cycles += cycles;
    }

    /// `cycles` asleep.
    pub fn charge_sleep(&mut self, cycles: u64) {
        self.sleep_cycles += cycles;
    }

    /// A block of the current context ran: `runs` are (chain, instructions); `sp` is the
    /// deepest SP it reached.
    pub fn block(&mut self, runs: &[(u32, u32)], sp: u32) {
        if let Some(a) = self.active.last_mut() {
            a.code.extend_from_slice(runs);
        }
        let c = self.context() as usize % EXCEPTIONS;
        let per_chain = &mut self.instructions[c];
        for &(chain, n) in runs {
            let i = chain as usize;
            if i >= per_chain.len() {
                per_chain.resize(i + 1, 0);
            }
            per_chain[i] += u64::from(n);
        }
        self.saw_sp(sp);
    }

    /// SP seen in the current context.
    pub fn saw_sp(&mut self, sp: u32) {
        match self.active.last_mut() {
            Some(a) => a.lowest_sp = a.lowest_sp.min(sp),
            None => {
                self.thread_lowest_sp = self.thread_lowest_sp.min(sp);
                if let Some(low) = self.thread_lowest_sp_with_tasks.as_mut() {
                    *low = (*low).min(sp);
                }
            }
        }
        let thread = &mut self.exceptions[THREAD as usize];
        thread.max_stack = self.thread_top_sp.saturating_sub(self.thread_lowest_sp);
    }

    /// Exception `e` is entered at `cycle` (its entry cycles not yet counted); `sp_before` is
    /// SP before its frame was stacked, `sp_after` the SP its handler starts with.
    pub fn entered(&mut self, e: u32, cycle: u64, now_ns: u64, sp_before: u32, sp_after: u32) {
        if self.active.is_empty() {
            let low = self.thread_lowest_sp_with_tasks.get_or_insert(sp_before);
            *low = (*low).min(sp_before);
        }
        let s = &mut self.exceptions[e as usize % EXCEPTIONS];
        s.first_entry_ns.get_or_insert(now_ns);
        self.active.push(Activation {
            exception: e,
            entry_cycle: cycle,
            entry_ns: now_ns,
            sp_before,
            lowest_sp: sp_after,
            code: Vec::new(),
        });
    }

    /// The innermost exception returns at `cycle` (its return cycles counted); returns the SP
    /// it was entered with (before its frame).
    pub fn returned(&mut self, cycle: u64) -> Option<u32> {
        let a = self.active.pop()?;
        let s = &mut self.exceptions[a.exception as usize % EXCEPTIONS];
        let c = cycle - a.entry_cycle;
        s.count += 1;
        s.cycles += c;
        if c > s.max_cycles {
            s.max_cycles = c;
            s.max_at_ns = a.entry_ns;
            s.longest_code = merged(&a.code);
        }
        s.max_stack = s.max_stack.max(a.sp_before.saturating_sub(a.lowest_sp));
        Some(a.sp_before)
    }

    /// Instructions executed: (context, chain, count) for every count above 0.
    pub fn instructions(&self) -> impl Iterator<Item = (u32, u32, u64)> + '_ {
        self.instructions
            .iter()
            .enumerate()
            .flat_map(|(c, chains)| {
                chains
                    .iter()
                    .enumerate()
                    .filter(|(_, &n)| n > 0)
                    .map(move |(chain, &n)| (c as u32, chain as u32, n))
            })
    }

    /// Deepest stack of thread mode since the first exception (idle's, under the tasks).
    pub fn thread_stack_with_tasks(&self) -> u32 {
        self.thread_lowest_sp_with_tasks
            .map_or(0, |low| self.thread_top_sp.saturating_sub(low))
    }

    /// Total own cycles of all contexts plus sleep.
    pub fn total_cycles(&self) -> u64 {
        self.exceptions.iter().map(|e| e.own_cycles).sum::<u64>() + self.sleep_cycles
    }
}

/// (chain, instructions) runs summed per chain, most first.
fn merged(runs: &[(u32, u32)]) -> Vec<(u32, u64)> {
    let mut sums: std::collections::BTreeMap<u32, u64> = Default::default();
    for &(chain, n) in runs {
        *sums.entry(chain).or_insert(0) += u64::from(n);
    }
    let mut v: Vec<(u32, u64)> = sums.into_iter().collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nested_activations_keep_own_cycles_and_stack_apart() {
        let mut p = Profile::new(0x1000_4000);
        p.block(&[(1, 4)], 0x1000_3F00);
        p.charge(5);
        // EINT3 (37) preempts thread mode at cycle 100 with SP 0x3F00.
        p.entered(37, 100, 1_000, 0x1000_3F00, 0x1000_3EE0);
        p.charge(12);
        p.block(&[(2, 8)], 0x1000_3EC0);
        p.charge(10);
        // TIMER1 (18) preempts EINT3.
        p.entered(18, 130, 1_300, 0x1000_3EC0, 0x1000_3EA0);
        p.charge(12);
        p.block(&[(3, 4)], 0x1000_3E90);
        p.charge(5 + 10);
        p.returned(157);
        p.block(&[(2, 4)], 0x1000_3ED0);
        p.charge(5 + 10);
        p.returned(180);
        let eint3 = &p.exceptions[37];
        assert_eq!((eint3.count, eint3.cycles, eint3.max_cycles), (1, 80, 80));
        assert_eq!(eint3.own_cycles, 12 + 10 + 15);
        assert_eq!(
            eint3.max_stack, 0x40,
            "its frame and its locals, not TIMER1's"
        );
        assert_eq!(eint3.first_entry_ns, Some(1_000));
        assert_eq!(
            eint3.longest_code,
            [(2, 12)],
            "its own blocks, not TIMER1's"
        );
        let t1 = &p.exceptions[18];
        assert_eq!((t1.cycles, t1.own_cycles, t1.max_stack), (27, 27, 0x30));
        assert_eq!(p.exceptions[0].own_cycles, 5);
        assert_eq!(p.exceptions[0].max_stack, 0x100);
        assert_eq!(p.thread_stack_with_tasks(), 0x100);
        p.block(&[(1, 1)], 0x1000_3FF0);
        assert_eq!(p.thread_stack_with_tasks(), 0x100);
        let n: Vec<_> = p.instructions().collect();
        assert_eq!(n, [(0, 1, 5), (18, 3, 4), (37, 2, 12)]);
        assert_eq!(p.total_cycles(), 5 + 37 + 27);
    }
}
