//! The DP window host (the FBs' side) fed arbitrary input windows at arbitrary times, with jobs
//! from the fuzzer: no panic, the output window keeps its size, every job completes once (the
//! job watchdog ends the ones a silent module leaves hanging).
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_core::{Duration, Instant};
use si_dp_coord::{Host, HostConfig, HostEvent, Job, WindowSize};
use si_fuzz::Input;
use std::collections::BTreeSet;

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let window = match input.u8() % 3 {
        0 => WindowSize::Four,
        1 => WindowSize::Eight,
        _ => WindowSize::ThirtyTwo,
    };
    let size = window.bytes();
    let Ok(mut host) = Host::new(HostConfig::new(window)) else {
        return;
    };
    let mut open = BTreeSet::new();
    let mut now = Instant::ZERO;
    let drain = |host: &mut Host, open: &mut BTreeSet<u64>| {
        while let Some(e) = host.poll_event() {
            if let HostEvent::Completed { id, .. } = e {
                assert!(
                    open.remove(&id.0),
                    "job {id:?} completed twice or never started"
                );
            }
        }
    };
    while !input.is_empty() {
        let op = input.u8();
        if op & 0x80 != 0 {
            let job = match op % 4 {
                0 => {
                    let n = usize::from(input.u8());
                    Job::Send(input.take(n).to_vec().into())
                }
                1 => Job::Receive,
                2 => Job::ReadV24,
                _ => Job::WriteV24 {
                    rts: op & 8 != 0,
                    dtr: op & 16 != 0,
                },
            };
            if let Ok(id) = host.submit(job) {
                assert!(open.insert(id.0));
            }
            continue;
        }
        now = now + Duration::from_micros(u64::from(input.u16()) * 10);
        let window_in = input.take(size);
        let out = host.cycle(now, window_in);
        assert_eq!(out.len(), size);
        drain(&mut host, &mut open);
    }
    // A silent module (all-zero input): the watchdog (30 s a job) ends every job, the queued
    // ones (up to 16) one after the other.
    let idle = vec![0u8; size];
    for _ in 0..1_000 {
        now = now + Duration::from_secs(1);
        host.cycle(now, &idle);
        drain(&mut host, &mut open);
    }
    assert!(open.is_empty(), "jobs {open:?} never completed");
});
