//! A mutex with priority inheritance (a POSIX mutex with `PTHREAD_PRIO_INHERIT`): a thread
//! that holds it runs at the priority of the highest thread waiting for it.
//!
//! The board on a network interface needs it: the frame-answering thread (real-time, high)
//! and the CPU's thread (real-time, low) share the ESC model. Were the CPU's thread to hold
//! the lock while a third thread of middle priority runs on its core (a master's cyclic
//! task, busy-waiting for the very reply the answering thread cannot give), the frame would
//! wait for that thread: a priority inversion, the reply late by milliseconds. With
//! inheritance the holder runs at once and lets go. Uncontended, locking stays in user space.
//!
//! The mutex is of the error-checking kind: a thread that locks it a second time gets a
//! panic naming the problem instead of waiting for itself.

use std::cell::UnsafeCell;
use std::ops::{Deref, DerefMut};

/// A mutex with priority inheritance around a `T`.
pub struct PiMutex<T> {
    /// Boxed: a POSIX mutex must not move once initialised.
    raw: Box<UnsafeCell<libc::pthread_mutex_t>>,
    data: UnsafeCell<T>,
}

// SAFETY: the data is only reached through a guard, which exists while the mutex is held
// (one thread at a time); `T: Send` lets the data move between those threads.
unsafe impl<T: Send> Send for PiMutex<T> {}
// SAFETY: as above.
unsafe impl<T: Send> Sync for PiMutex<T> {}

/// The locked data; unlocks when dropped.
pub struct PiGuard<'a, T> {
    mutex: &'a PiMutex<T>,
}

impl<T> PiMutex<T> {
    /// A mutex around `data`.
    pub fn new(data: T) -> Self {
        // SAFETY: a zeroed pthread_mutex_t is overwritten by pthread_mutex_init below; the
        // attribute object is initialised, used and destroyed here.
        unsafe {
            let raw = Box::new(UnsafeCell::new(std::mem::zeroed::<libc::pthread_mutex_t>()));
            let mut attr: libc::pthread_mutexattr_t = std::mem::zeroed();
            libc::pthread_mutexattr_init(&mut attr);
            libc::pthread_mutexattr_setprotocol(&mut attr, libc::PTHREAD_PRIO_INHERIT);
            libc::pthread_mutexattr_settype(&mut attr, libc::PTHREAD_MUTEX_ERRORCHECK);
            let r = libc::pthread_mutex_init(raw.get(), &attr);
            libc::pthread_mutexattr_destroy(&mut attr);
            assert_eq!(r, 0, "pthread_mutex_init: {r}");
            Self {
                raw,
                data: UnsafeCell::new(data),
            }
        }
    }

    /// Locks, waiting for the holder (which runs at this thread's priority meanwhile).
    pub fn lock(&self) -> PiGuard<'_, T> {
        // SAFETY: an initialised mutex that does not move.
        let r = unsafe { libc::pthread_mutex_lock(self.raw.get()) };
        assert_ne!(r, libc::EDEADLK, "the mutex is locked twice by one thread");
        assert_eq!(r, 0, "pthread_mutex_lock: {r}");
        PiGuard { mutex: self }
    }
}

impl<T> Drop for PiMutex<T> {
    fn drop(&mut self) {
        // SAFETY: no guard exists (they borrow the mutex); the mutex is unlocked.
        unsafe { libc::pthread_mutex_destroy(self.raw.get()) };
    }
}

impl<T> Deref for PiGuard<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        // SAFETY: the guard holds the lock.
        unsafe { &*self.mutex.data.get() }
    }
}

impl<T> DerefMut for PiGuard<'_, T> {
    fn deref_mut(&mut self) -> &mut T {
        // SAFETY: the guard holds the lock, and `&mut self` makes this the only reference.
        unsafe { &mut *self.mutex.data.get() }
    }
}

impl<T> Drop for PiGuard<'_, T> {
    fn drop(&mut self) {
        // SAFETY: this thread holds the lock.
        unsafe { libc::pthread_mutex_unlock(self.mutex.raw.get()) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn threads_take_turns_and_see_each_others_writes() {
        let m = Arc::new(PiMutex::new(0u64));
        let threads: Vec<_> = (0..4)
            .map(|_| {
                let m = m.clone();
                std::thread::spawn(move || {
                    for _ in 0..10_000 {
                        *m.lock() += 1;
                    }
                })
            })
            .collect();
        for t in threads {
            t.join().unwrap();
        }
        assert_eq!(*m.lock(), 40_000);
    }

    #[test]
    #[should_panic(expected = "locked twice by one thread")]
    fn locking_twice_in_one_thread_is_a_clear_failure() {
        let m = PiMutex::new(());
        let _a = m.lock();
        let _b = m.lock();
    }
}
