//! Bounded memory: a slave's SIMATIC memory of absurd size is refused with a range
//! error before anything is allocated (si_core::memory::MemorySizes::check), and the largest
//! sizes it accepts stay within the documented total.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use si_core::memory::{Memory, MemorySizes, MAX_DB_BYTES, MAX_TOTAL_BYTES};
use si_testkit::alloc::counted;

fn main() {
    a_4_gib_area_is_refused_before_any_allocation();
    println!("memory_bounds: a 4 GiB area is refused without allocating: ok");
    the_largest_accepted_memory_stays_within_the_total();
    println!("memory_bounds: the largest accepted memory stays within 16 MiB: ok");
}

fn a_4_gib_area_is_refused_before_any_allocation() {
    for area in ["inputs", "outputs", "flags", "timers", "counters", "db"] {
        let mut sizes = MemorySizes::default();
        match area {
            "inputs" => sizes.inputs = u32::MAX,
            "outputs" => sizes.outputs = u32::MAX,
            "flags" => sizes.flags = u32::MAX,
            "timers" => sizes.timers = u32::MAX,
            "counters" => sizes.counters = u32::MAX,
            _ => {
                sizes.dbs.insert(1, u32::MAX);
            }
        }
        let (result, stats) = counted(|| Memory::checked(&sizes).map(|_| ()));
        let e = result.expect_err(area);
        assert_eq!(e.value, u32::MAX.to_string(), "{area}: {e}");
        // The error's own text is the only allocation.
        assert!(
            stats.bytes_allocated < 4096,
            "{area}: {} bytes allocated",
            stats.bytes_allocated
        );
    }
}

fn the_largest_accepted_memory_stays_within_the_total() {
    let per_db = u64::from(MAX_DB_BYTES);
    let fit = (MAX_TOTAL_BYTES / per_db) as u16 - 1;
    let sizes = MemorySizes {
        dbs: (1..=fit).map(|n| (n, MAX_DB_BYTES)).collect(),
        ..MemorySizes::default()
    };
    let (memory, stats) = counted(|| Memory::checked(&sizes));
    assert!(memory.is_ok(), "{:?}", memory.err());
    assert!(stats.bytes_allocated as u64 <= MAX_TOTAL_BYTES + 64 * 1024);
}
