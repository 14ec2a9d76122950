//! Many drivers in one process ("Many lines in one process"; BENCHMARKS.md): the
//! tokio driver's precise timer is one thread for all of them, and a deadline fires as exactly
//! with 1,000 drivers waiting as with one.
//!
//! For 1, 100 and 1,000 drivers (each a [`si_core::driver`] over an in-memory pipe, on a
//! two-worker tokio runtime), every round each driver waits a deadline 2 ms ahead (below
//! `PRECISE_LEAD`: the precise timer's range), all at about the same time. Printed before the
//! timings, per fleet size:
//!
//! - the process's threads, and `si-driver-timer` threads among them (one, whatever the size);
//! - memory per driver: heap bytes (counting allocator) and resident memory (`VmRSS`) added
//!   by the fleet after every driver has waited a deadline, divided by its size;
//! - idle CPU: the process's CPU time while every driver waits with no deadline, as a share
//!   of one core (`/proc/self/stat`, 10 ms ticks: measured over 2 s);
//! - lateness of the deadlines (the driver's clock when the engine is told, minus the
//!   deadline; never negative): median, p99 and maximum over all drivers and rounds.
//!
//! Then criterion's `precise_timer_lateness/<drivers>`: its "time" is the **mean lateness of
//! one deadline** in a round, not how long the round took (`iter_custom` returns the summed
//! lateness).
//!
//! The deadlines of a round are armed in a burst, the hardest case for one shared thread;
//! each driver's wake-up also costs the runtime a task poll, so with 1,000 drivers on two
//! cores the lateness is mostly the runtime's.
//!
//! Run: `cargo bench --bench precise_timer`; `cargo test --benches` runs two rounds each and
//! measures idle CPU briefly.

use criterion::{BenchmarkId, Criterion, SamplingMode};
use si_core::driver::{precise_timer_drivers, spawn, DriverOptions, Handle};
use si_core::{Duration, Engine, Instant, Output};
use si_testkit::procfs;
use tokio::io::DuplexStream;

/// How far ahead each deadline is set: inside the precise timer's range.
const AHEAD: Duration = Duration::from_millis(2);

/// Waits the deadline it is given; reports how late it was told.
#[derive(Default)]
struct Deadline {
    at: Option<Instant>,
    late: Option<Duration>,
}

impl Engine for Deadline {
    type Event = Duration;
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
    fn handle_timeout(&mut self, now: Instant) {
        if let Some(at) = self.at.filter(|&at| now >= at) {
            self.at = None;
            self.late = Some(now - at);
        }
    }
    fn poll_output(&mut self) -> Output<Duration> {
        match self.late.take() {
            Some(late) => Output::Event(late),
            None => Output::Wait(self.at),
        }
    }
}

/// `n` drivers over pipes whose other ends stay open.
struct Fleet {
    handles: Vec<Handle<Deadline>>,
    _peers: Vec<DuplexStream>,
}

impl Fleet {
    /// Must run inside the runtime (the drivers are tasks).
    fn new(n: usize) -> Fleet {
        let (handles, _peers) = (0..n)
            .map(|_| {
                let (ours, theirs) = tokio::io::duplex(64);
                let (handle, _task) = spawn(Deadline::default(), ours, DriverOptions::default());
                (handle, theirs)
            })
            .unzip();
        Fleet { handles, _peers }
    }

    /// Every driver waits a deadline [`AHEAD`]; the lateness of each, in driver order.
    async fn round(&mut self) -> Vec<Duration> {
        for handle in &self.handles {
            handle
                .send(|d, now| d.at = Some(now + AHEAD))
                .expect("the driver runs");
        }
        let mut late = Vec::with_capacity(self.handles.len());
        for handle in &mut self.handles {
            late.push(handle.next_event().await.expect("the driver runs"));
        }
        late
    }
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("a tokio runtime")
}

/// The lateness at quantile `q` (0..=1) of sorted values.
fn quantile(sorted: &[Duration], q: f64) -> Duration {
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

/// The table printed before the timings: threads, memory and lateness for `n` drivers.
fn census(rt: &tokio::runtime::Runtime, n: usize, rounds: usize, idle_for: std::time::Duration) {
    let rss_before = procfs::rss_bytes().unwrap_or(0);
    let region = si_testkit::alloc::region();
    let mut fleet = rt.block_on(async { Fleet::new(n) });
    let mut late = rt.block_on(fleet.round());
    let heap = region.change();
    let heap =
        heap.bytes_allocated as f64 - heap.bytes_deallocated as f64 + heap.bytes_reallocated as f64;
    let rss = procfs::rss_bytes().unwrap_or(0).saturating_sub(rss_before);
    let (threads, timers) = (procfs::threads(), procfs::threads_named("si-driver-timer"));
    let seated = precise_timer_drivers();
    let idle = idle_cpu(idle_for);
    for _ in 1..rounds {
        late.extend(rt.block_on(fleet.round()));
    }
    late.sort();
    println!(
        "precise_timer_{n}_drivers: threads {} (si-driver-timer {}, used by {seated} drivers), \
         {:.1} KiB heap and {:.1} KiB RSS per driver, idle CPU {}, \
         lateness median {} p99 {} max {} ({} deadlines)",
        threads.map_or("?".into(), |t| t.to_string()),
        timers.map_or("?".into(), |t| t.to_string()),
        heap / n as f64 / 1024.0,
        rss as f64 / n as f64 / 1024.0,
        idle.map_or("?".into(), |share| format!("{:.2} %", share * 100.0)),
        quantile(&late, 0.5),
        quantile(&late, 0.99),
        quantile(&late, 1.0),
        late.len(),
    );
    drop(fleet);
}

/// The process's CPU time over `span` of wall time, as a share of one core (the drivers are
/// idle meanwhile: nothing to send, no deadline).
fn idle_cpu(span: std::time::Duration) -> Option<f64> {
    let before = procfs::cpu_time()?;
    std::thread::sleep(span);
    let used = procfs::cpu_time()? - before;
    Some(used.as_secs_f64() / span.as_secs_f64())
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` does not: a quick pass there.
    let benching = std::env::args().any(|a| a == "--bench");
    let (rounds, idle_for) = if benching {
        (100, std::time::Duration::from_secs(2))
    } else {
        (2, std::time::Duration::from_millis(50))
    };
    let rt = runtime();
    for n in [1, 100, 1000] {
        census(&rt, n, rounds, idle_for);
    }

    // The returned "time" is lateness (tens to hundreds of µs), while a round takes 2 ms and
    // more: short warm-up and measurement budgets keep the wall time to seconds, and equal
    // samples (flat sampling) suit so few iterations.
    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(std::time::Duration::from_millis(20))
        .measurement_time(std::time::Duration::from_millis(300))
        .configure_from_args();
    let mut group = c.benchmark_group("precise_timer_lateness");
    group.sampling_mode(SamplingMode::Flat);
    for n in [1, 100, 1000] {
        let mut fleet = rt.block_on(async { Fleet::new(n) });
        group.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter_custom(|iters| {
                let mut total = std::time::Duration::ZERO;
                for _ in 0..iters {
                    let late = rt.block_on(fleet.round());
                    let sum: u64 = late.iter().map(|l| l.as_micros()).sum();
                    total += std::time::Duration::from_micros(sum / late.len() as u64);
                }
                total
            })
        });
    }
    group.finish();
    c.final_summary();
}
