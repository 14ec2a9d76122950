//! Step the line simulator while a job runs and fail when it outlives its bound ("A
//! bound on every job"), for tests that run an engine against a [`NoisePeer`](crate::noise::NoisePeer)
//! on [`Simulator`].

use si_core::Instant;
use si_sim::Simulator;

/// Steps `sim` one happening at a time while `busy` holds (a job is running) and returns the
/// instant it stopped holding. Panics when it still holds after `limit` (the job outlived its
/// bound) or when nothing is scheduled any more although it holds (the job hangs).
pub fn run_while(
    sim: &mut Simulator,
    limit: Instant,
    mut busy: impl FnMut(&Simulator) -> bool,
) -> Instant {
    while busy(sim) {
        assert!(
            sim.now() <= limit,
            "the job still runs at {} (bound {limit})",
            sim.now()
        );
        assert!(
            sim.step(),
            "the job runs with nothing scheduled at {}",
            sim.now()
        );
    }
    assert!(
        sim.now() <= limit,
        "the job ended at {}, after its bound {limit}",
        sim.now()
    );
    sim.now()
}
