//! A fixed-capacity queue of Emergencies waiting to be sent (CiA 301 7.2.7), shared by both
//! transports: the CoE mailbox sends them when the read mailbox is free, the CAN EMCY
//! producer when its inhibit time allows. When the queue is full the oldest one is dropped
//! and counted, so the newest state of the device always gets through.

use crate::wire::EmergencyRepr;

/// Up to `N` Emergencies, oldest first.
#[derive(Debug, Clone)]
pub struct EmergencyQueue<const N: usize> {
    items: [Option<EmergencyRepr>; N],
    head: usize,
    len: usize,
    dropped: u32,
}

impl<const N: usize> Default for EmergencyQueue<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> EmergencyQueue<N> {
    /// An empty queue.
    pub const fn new() -> Self {
        Self {
            items: [None; N],
            head: 0,
            len: 0,
            dropped: 0,
        }
    }

    /// Queues an Emergency; when the queue is full the oldest one is dropped (and counted).
    // Out of line: the raise/clear paths of both fieldbuses would each carry a copy.
    #[inline(never)]
    pub fn push(&mut self, emergency: EmergencyRepr) {
        if N == 0 {
            self.dropped = self.dropped.saturating_add(1);
            return;
        }
        if self.len == N {
            self.head = (self.head + 1) % N;
            self.len -= 1;
            self.dropped = self.dropped.saturating_add(1);
        }
        let tail = (self.head + self.len) % N;
        if let Some(slot) = self.items.get_mut(tail) {
            *slot = Some(emergency);
            self.len += 1;
        }
    }

    /// The oldest Emergency, removed from the queue.
    pub fn pop(&mut self) -> Option<EmergencyRepr> {
        if self.len == 0 || N == 0 {
            return None;
        }
        let item = self.items.get_mut(self.head).and_then(Option::take);
        self.head = (self.head + 1) % N;
        self.len -= 1;
        item
    }

    /// Number of queued Emergencies.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True if nothing waits.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Emergencies dropped because the queue was full.
    pub const fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Drops everything queued (the drop count stays).
    pub fn clear(&mut self) {
        while self.pop().is_some() {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(code: u16) -> EmergencyRepr {
        EmergencyRepr {
            error_code: code,
            error_register: 1,
            data: [0; 5],
        }
    }

    #[test]
    fn fifo_and_overflow_drops_the_oldest() {
        let mut q = EmergencyQueue::<2>::new();
        assert!(q.is_empty());
        q.push(e(1));
        q.push(e(2));
        q.push(e(3));
        assert_eq!(q.len(), 2);
        assert_eq!(q.dropped(), 1);
        assert_eq!(q.pop().map(|x| x.error_code), Some(2));
        assert_eq!(q.pop().map(|x| x.error_code), Some(3));
        assert_eq!(q.pop(), None);
        q.push(e(4));
        q.clear();
        assert!(q.is_empty());
        assert_eq!(q.dropped(), 1);
        let mut none = EmergencyQueue::<0>::new();
        none.push(e(5));
        assert_eq!(none.pop(), None);
        assert_eq!(none.dropped(), 1);
    }
}
