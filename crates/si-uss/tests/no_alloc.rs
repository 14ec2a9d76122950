//! Zero heap allocations per telegram in steady state (the si-core contract, ARCHITECTURE.md):
//! the USS master polls a simulated drive under a counting global allocator. Telegrams are cut
//! from transmit buffers the engines keep (`split().freeze()`), reclaimed once dropped.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use si_core::{Duration, Instant};
use si_sim::Pair;
use si_testkit::alloc::assert_no_alloc;
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::PkwWords;
use si_uss::Master;

fn main() {
    steady_state_polling_does_not_allocate();
    println!("no_alloc: 10 s of polling allocates nothing: ok");
}

fn steady_state_polling_does_not_allocate() {
    let settings = uss_settings(19_200).unwrap();
    let mut config = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    config.settings = settings;
    let master = Master::new(config).unwrap();
    let drive = Drive::new(DriveConfig::new(settings, 1)).unwrap();
    let mut pair = Pair::new(master, drive);
    let now = pair.now;
    pair.a.start(now);
    pair.run_until(Instant::from_micros(1_000_000)); // warm up
    let before = *pair.a.counters();
    assert_no_alloc("10 s of polling", || {
        for _ in 0..10 {
            let now = pair.now;
            pair.a.set_control(1, &[0x047F, 0x2000]).unwrap();
            pair.run_until(now + Duration::from_secs(1));
        }
    });
    let after = *pair.a.counters();
    let answered = after.ok - before.ok;
    assert!(answered > 500, "only {answered} telegrams answered");
    assert_eq!(after.rejected, before.rejected);
}
