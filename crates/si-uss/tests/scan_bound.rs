//! A scan's announced time holds on a noisy line: a batch of `si uss scan` (the master as
//! [`Scan::batch_master`] builds it, one probe per node, one telegram each) against a line that
//! garbles or never goes quiet ends, in the engine's own time, within [`batch_bound`], the
//! batch's share of what the scan announces. The noise makes a batch last longer than the
//! response timeout plus a valid answer's characters per telegram.

use si_core::{Duration, Instant};
use si_testkit::noise::{facing, issue_patterns, Facing};
use si_uss::config::{uss_settings, PollEntry};
use si_uss::frame::PkwWords;
use si_uss::master::Event;
use si_uss::scan::{batch_bound, Scan, CYCLES};

#[test]
fn a_batch_ends_within_its_bound_under_every_noise() {
    let settings = uss_settings(9_600).unwrap();
    let entries: Vec<PollEntry> = (0..4)
        .map(|a| PollEntry::new(a, PkwWords::Four, 2))
        .collect();
    let scan = Scan::new(&entries, &[settings], Duration::from_millis(20)).unwrap();
    let [c] = scan.batches() else {
        panic!("one batch")
    };
    let bound = batch_bound(c, Duration::ZERO);
    let mut worst = Duration::ZERO;
    for pattern in issue_patterns(settings.char_time()) {
        let (master, jobs) = Scan::batch_master(c).unwrap();
        let Facing {
            mut sim, engine: m, ..
        } = facing(6, settings, master, pattern);
        // Noise first, so the batch starts on a busy line.
        sim.run_until(Instant::from_micros(50_000));
        let start = sim.now();
        sim.with(m, |e, now| e.start(now));
        let mut open = jobs.len();
        let mut last = start;
        while open > 0 && sim.now().saturating_since(start) <= bound.saturating_mul(3) {
            let at = sim.now();
            assert!(
                sim.step(),
                "{}: the line stopped with probes open",
                pattern.name
            );
            let at = sim.now().max(at);
            for e in sim.take_events(m) {
                if let Event::ParameterDone { job, .. } | Event::ParameterFailed { job, .. } = e {
                    if jobs.iter().any(|(j, _)| *j == job) {
                        open -= 1;
                        last = at;
                    }
                }
            }
        }
        assert_eq!(
            open, 0,
            "{}: probes still open at 3 × {bound}",
            pattern.name
        );
        let took = last.saturating_since(start);
        assert!(took <= bound, "{}: {took} > {bound}", pattern.name);
        worst = worst.max(took);
    }
    // The scan's former bound: per telegram the start interval, the request, the response
    // timeout and a valid answer in its residual run time (16 characters of 4 PKW + 2 PZD).
    let chars: u64 = 4 + 12;
    let telegram = settings.chars_time(2 + chars + (3 * chars).div_ceil(2)) + c.response_timeout;
    let former = telegram.saturating_mul(entries.len() as u64 * CYCLES);
    assert!(worst > former, "worst {worst}, the former bound {former}");
}
