//! The board's virtual clock, shared by all models.

use std::cell::Cell;
use std::rc::Rc;

/// Virtual time in ns, shared between the models of one board.
#[derive(Clone, Debug, Default)]
pub struct Clock(Rc<Cell<u64>>);

impl Clock {
    /// A clock at time 0.
    pub fn new() -> Self {
        Self::default()
    }
    /// Current virtual time (ns).
    pub fn now_ns(&self) -> u64 {
        self.0.get()
    }
    /// Sets the time (monotonic: earlier values are ignored).
    pub fn set_ns(&self, t: u64) {
        if t > self.0.get() {
            self.0.set(t);
        }
    }
    /// Advances the time by `ns`.
    pub fn advance_ns(&self, ns: u64) {
        self.0.set(self.0.get() + ns);
    }
}
