//! Soak: the USS master polling a drive on a faulty line (bit flips, lost and
//! inserted characters) for a day of virtual time, with parameter jobs alternating a write of
//! a sequence number into P2000 and a read of it.
//!
//! What USS can guarantee, asserted: every parameter job ends in exactly one event, done or
//! failed with a STATUS of the manual; nothing goes back in time (a read returns the last
//! acknowledged write or a later attempted one: a write whose answer was lost may still have
//! been executed); the polling cycle goes on; and the line stays usable. The BCC is an XOR
//! ([Modbus/USS] §3.7): two flips of the same bit in one telegram, or a lost and an
//! inserted character, pass it. The simulator's flips keep the parity bit right (a worst case:
//! a real UART's parity check catches every single flip), so a value outside the window is
//! counted as an undetectable corruption, and those must stay rare. The short test runs in every `cargo test`; the day runs with
//! `cargo test --release -p si-uss --test soak -- --ignored`.

use si_core::{Duration, Instant};
use si_sim::{Faults, Simulator};
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::PkwWords;
use si_uss::master::Width;
use si_uss::{Event, JobId, Master, ParamRequest};

struct Outcome {
    done: u64,
    failed: u64,
    reads: u64,
    cycles: u64,
    undetected: u64,
}

fn soak(span: Duration, seed: u64) -> Outcome {
    let settings = uss_settings(19_200).unwrap();
    let mut sim = Simulator::new(seed).without_trace();
    let mut config = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    config.settings = settings;
    let m = sim.add_station("master", settings, Master::new(config).unwrap());
    let d = sim.add_station(
        "drive",
        settings,
        Drive::new(DriveConfig::new(settings, 1)).unwrap(),
    );
    sim.connect(m, d);
    let faults = Faults {
        bit_flip: 0.000_2,
        drop: 0.000_2,
        insert: 0.000_2,
        extra_latency: Duration::ZERO,
    };
    sim.set_faults(m, faults);
    sim.set_faults(d, faults);
    sim.with(m, |m, now| m.start(now));

    let mut seq: u32 = 50_000;
    let (mut acknowledged, mut attempted) = (seq, seq);
    let mut writing = false;
    let mut open: Option<(JobId, bool)> = None;
    let mut out = Outcome {
        done: 0,
        failed: 0,
        reads: 0,
        cycles: 0,
        undetected: 0,
    };
    let end = Instant::ZERO + span;
    while sim.now() < end {
        if open.is_none() {
            writing = !writing;
            let request = if writing {
                seq += 1;
                attempted = seq;
                ParamRequest::write(2000, 0, seq, Width::DoubleWord)
            } else {
                ParamRequest::read(2000, 0)
            };
            let job = sim
                .with(m, |m, now| m.request_parameter(now, 1, request))
                .expect("no job is running");
            open = Some((job, writing));
        }
        sim.run_for(Duration::from_millis(20));
        for event in sim.take_events(m) {
            match event {
                Event::ParameterDone { job, response, .. } => {
                    let (expected, was_write) = open.take().expect("a completion without a job");
                    assert_eq!(job, expected, "a completion for another job");
                    out.done += 1;
                    let value = response.value();
                    if was_write {
                        acknowledged = attempted;
                        if value != attempted {
                            out.undetected += 1;
                        }
                    } else {
                        out.reads += 1;
                        if !(acknowledged..=attempted).contains(&value) {
                            eprintln!(
                                "read {value}, acknowledged {acknowledged}, attempted {attempted}"
                            );
                            out.undetected += 1;
                        }
                    }
                }
                Event::ParameterFailed { job, status, .. } => {
                    let (expected, _) = open.take().expect("a failure without a job");
                    assert_eq!(job, expected, "a failure for another job");
                    assert!(
                        status.code() != 0 && status.info().is_some(),
                        "a failure carries a STATUS of the manual: {status:?}"
                    );
                    out.failed += 1;
                }
                Event::CycleDone { .. } => out.cycles += 1,
                Event::Rejected { status, .. } => assert!(status.code() != 0),
                _ => {}
            }
        }
        sim.take_events(d);
    }
    eprintln!(
        "uss soak {:?}: {} done, {} failed, {} reads, {} cycles, {} undetected, master {:?}",
        span,
        out.done,
        out.failed,
        out.reads,
        out.cycles,
        out.undetected,
        sim.engine(m).counters()
    );
    assert!(
        out.undetected * 100_000 <= out.done,
        "{} undetectable corruptions in {} jobs",
        out.undetected,
        out.done
    );
    assert!(
        out.done > 20 * out.failed,
        "{} done, {} failed",
        out.done,
        out.failed
    );
    out
}

#[test]
fn ten_minutes_of_faults_every_parameter_job_ends_once_and_values_are_consistent() {
    let out = soak(Duration::from_secs(600), 0x5EED);
    assert!(out.reads > 1_000);
    assert!(out.cycles > 10_000);
}

#[test]
#[ignore = "a day of virtual time: run in release (see the module docs)"]
fn a_day_of_faults_every_parameter_job_ends_once_and_values_are_consistent() {
    let out = soak(Duration::from_secs(24 * 3600), 0xDA7);
    assert!(out.reads > 100_000);
}
