//! The hand-over between the gateway image's SYNC0 task and its PDI task: the SYNC0 edges
//! (count and time, for the slave application's cycle monitor), whether the cycle's outputs
//! had come before the edge (DC mode), and the DC mode itself. Lock-free: shared by
//! reference between the priorities.

use crate::stacks::ethercat::sync::Sync0Counts;
use crate::stacks::ethercat::CycleStage;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// The gateway's cycle hand-over.
#[derive(Debug, Default)]
pub struct CycleMarks {
    edges: AtomicU32,
    without_outputs: AtomicU32,
    last_edge_lo: AtomicU32,
    fresh_outputs: AtomicBool,
    dc: AtomicBool,
}

impl CycleMarks {
    /// No edge yet, not in DC mode.
    pub const fn new() -> Self {
        Self {
            edges: AtomicU32::new(0),
            without_outputs: AtomicU32::new(0),
            last_edge_lo: AtomicU32::new(0),
            fresh_outputs: AtomicBool::new(false),
            dc: AtomicBool::new(false),
        }
    }

    /// A SYNC0 edge captured at `captured_ns` (the SYNC0 task); in DC mode an edge that
    /// found no outputs of its cycle is counted.
    pub fn record_sync0(&self, captured_ns: u64) {
        let fresh = self.fresh_outputs.swap(false, Ordering::AcqRel);
        if self.dc.load(Ordering::Acquire) && !fresh {
            let n = self.without_outputs.load(Ordering::Relaxed);
            self.without_outputs
                .store(n.wrapping_add(1), Ordering::Release);
        }
        self.last_edge_lo
            .store(captured_ns as u32, Ordering::Release);
        let n = self.edges.load(Ordering::Relaxed);
        self.edges.store(n.wrapping_add(1), Ordering::Release);
    }

    /// The outputs of a cycle were handed to the CAN master (the PDI task).
    pub fn outputs_taken(&self) {
        self.fresh_outputs.store(true, Ordering::Release);
    }
}

impl CycleStage for CycleMarks {
    fn sync0_counts(&self) -> Sync0Counts {
        Sync0Counts {
            edges: self.edges.load(Ordering::Acquire),
            without_outputs: self.without_outputs.load(Ordering::Acquire),
            last_edge_lo: self.last_edge_lo.load(Ordering::Acquire),
        }
    }

    fn set_dc_mode(&self, dc: bool) {
        self.dc.store(dc, Ordering::Release);
    }

    fn dc_mode(&self) -> bool {
        self.dc.load(Ordering::Acquire)
    }

    /// The gateway has no output stage to wait for: its fault reaction is done when it
    /// returns.
    fn fault_waiting(&self) -> bool {
        false
    }
}
