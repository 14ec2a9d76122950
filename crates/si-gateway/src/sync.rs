//! Locking the gateway's shared state (counters, queues, images).
//!
//! A leaf module: it imports nothing of the crate.

use std::sync::{Mutex, MutexGuard};

/// Lock, taking over a lock poisoned by a panicking holder (the data are plain counters and
/// images, whole after any one write).
pub fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
