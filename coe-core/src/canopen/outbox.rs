//! The frames a CAN protocol machine (the node, the master) holds for its controller, given
//! back in the order arbitration would send them: lowest identifier first, and among equal
//! identifiers the oldest first.

use super::frame::CanFrame;

/// Frames waiting for the controller, each with its queueing number (the order among
/// equal identifiers; no shifting of slots, so no `memmove` on the target).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Outbox<const N: usize> {
    frames: [Option<(u32, CanFrame)>; N],
    next: u32,
    /// Frames queued: the PDI task asks for every activation, without a scan.
    queued: usize,
}

impl<const N: usize> Outbox<N> {
    pub(crate) const fn new() -> Self {
        Self {
            frames: [None; N],
            next: 0,
            queued: 0,
        }
    }

    /// Queues a frame; false if the outbox is full.
    pub(crate) fn push(&mut self, frame: CanFrame) -> bool {
        match self.frames.iter_mut().find(|f| f.is_none()) {
            Some(slot) => {
                *slot = Some((self.next, frame));
                self.next = self.next.wrapping_add(1);
                self.queued += 1;
                true
            }
            None => false,
        }
    }

    /// Where the frame with the lowest identifier (the one that wins arbitration) is; among
    /// equal identifiers the oldest (queueing numbers compared by wrapping difference: at
    /// most `N` apart).
    fn best(&self) -> Option<usize> {
        let mut best: Option<(usize, u16, u32)> = None;
        for (i, f) in self.frames.iter().enumerate() {
            if let Some((seq, f)) = f {
                let better = best.is_none_or(|(_, id, s)| {
                    f.id() < id || (f.id() == id && (seq.wrapping_sub(s) as i32) < 0)
                });
                if better {
                    best = Some((i, f.id(), *seq));
                }
            }
        }
        best.map(|(i, _, _)| i)
    }

    pub(crate) fn peek(&self) -> Option<CanFrame> {
        self.frames
            .get(self.best()?)
            .copied()
            .flatten()
            .map(|(_, f)| f)
    }

    pub(crate) fn pop(&mut self) -> Option<CanFrame> {
        let i = self.best()?;
        let (_, frame) = self.frames.get_mut(i)?.take()?;
        self.queued -= 1;
        Some(frame)
    }

    pub(crate) fn len(&self) -> usize {
        self.queued
    }

    pub(crate) fn clear(&mut self) {
        self.frames = [None; N];
        self.queued = 0;
    }
}

impl<const N: usize> Outbox<N> {
    /// Free places.
    pub(crate) fn free(&self) -> usize {
        N - self.queued
    }
}
