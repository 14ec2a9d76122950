//! The counting-allocator harness of every `tests/no_alloc.rs`.
//!
//! Linking this crate into a test binary makes [`stats_alloc`]'s instrumented system allocator
//! that binary's global allocator (a `#[global_allocator]` may live in any one crate of the
//! graph). The allocator itself only adds atomic counters; [`assert_no_alloc`] reads them
//! around the steady-state work.
//!
//! Tests that count run without libtest's harness (`harness = false` in the crate's
//! `[[test]]` entry): the harness's own threads would allocate while we count.

use stats_alloc::{StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

pub use stats_alloc::{Region, Stats};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

/// A region that counts every allocation from now on ([`Region::change`] reads them): for
/// measurements other than "none at all" (memory per simulated link, say).
pub fn region() -> Region<'static, System> {
    Region::new(GLOBAL)
}

/// Runs `work` and returns its result with what it allocated.
pub fn counted<R>(work: impl FnOnce() -> R) -> (R, Stats) {
    let region = region();
    let result = work();
    (result, region.change())
}

/// Runs `work` and fails (panics) if it allocated or reallocated anything; `what` names the
/// work in the message. Returns what `work` returned, for checks after the counted part.
pub fn assert_no_alloc<R>(what: &str, work: impl FnOnce() -> R) -> R {
    let (result, stats) = counted(work);
    assert_eq!(
        (stats.allocations, stats.reallocations),
        (0, 0),
        "allocations in {what}: {stats:?}"
    );
    result
}

// The passing case is not unit-tested here: libtest's threads allocate while a test counts.
// Every crate's tests/no_alloc.rs, run without the harness, exercises it.
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_allocation_is_counted() {
        let (v, stats) = counted(|| vec![1u8; 64]);
        assert_eq!(v.len(), 64);
        assert!(stats.allocations >= 1);
    }

    #[test]
    #[should_panic(expected = "allocations in a vector")]
    fn an_allocation_fails_the_assertion() {
        assert_no_alloc("a vector", || vec![1u8; 64]);
    }
}
