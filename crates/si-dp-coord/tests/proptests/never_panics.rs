//! Host and module never panic on arbitrary input windows (any bytes, any length, any timing),
//! stay bounded, and every host job still ends in exactly one completion.

use crate::common;

use bytes::Bytes;

use proptest::prelude::*;
use si_core::{Duration, Instant, Status};
use si_dp_coord::host::{Host, HostEvent, Job, JobId};
use si_dp_coord::module::{LoopbackSerial, Module};
use si_dp_coord::{HostConfig, ModuleConfig, ParamBlock, WindowSize};
use std::collections::HashMap;

fn window_size() -> impl Strategy<Value = WindowSize> {
    prop_oneof![
        Just(WindowSize::Four),
        Just(WindowSize::Eight),
        Just(WindowSize::ThirtyTwo)
    ]
}

/// Mostly windows of the right size with plausible coordination bytes, sometimes anything.
fn windows(size: WindowSize) -> impl Strategy<Value = Vec<(u64, Vec<u8>)>> {
    let n = size.bytes();
    let plausible =
        (0u8..0x80, proptest::collection::vec(any::<u8>(), n - 1)).prop_map(|(c, mut rest)| {
            rest.insert(0, c);
            rest
        });
    let anything = proptest::collection::vec(any::<u8>(), 0..40);
    proptest::collection::vec(
        (0u64..5_000_000, prop_oneof![8 => plausible, 1 => anything]),
        0..300,
    )
}

fn job() -> impl Strategy<Value = Job> {
    prop_oneof![
        proptest::collection::vec(any::<u8>(), 1..300).prop_map(|v| Job::Send(Bytes::from(v))),
        Just(Job::Receive),
        Just(Job::ReadV24),
        (any::<bool>(), any::<bool>()).prop_map(|(rts, dtr)| Job::WriteV24 { rts, dtr }),
        Just(Job::Parameters(ParamBlock::XON_XOFF_DEFAULT)),
        Just(Job::Parameters(ParamBlock::AUTO_V24_DEFAULT)),
    ]
}

fn count_completions(events: &[HostEvent], into: &mut HashMap<JobId, usize>) {
    for e in events {
        if let HostEvent::Completed { id, .. } = e {
            *into.entry(*id).or_default() += 1;
        }
    }
}

/// Either reading of what follows execution number 7 (`[derived]`).
fn exec_wrap() -> impl Strategy<Value = si_dp_coord::ExecWrap> {
    prop_oneof![
        Just(si_dp_coord::ExecWrap::ToOne),
        Just(si_dp_coord::ExecWrap::ToZero)
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn host_never_panics_and_completes_every_job_once(
        size in window_size(),
        auto_receive in any::<bool>(),
        wrap in exec_wrap(),
        jobs in proptest::collection::vec(job(), 0..6),
        inputs in window_size().prop_flat_map(windows),
    ) {
        let cfg = HostConfig { auto_receive, exec_wrap: wrap, ..HostConfig::new(size) };
        let mut host = Host::new(cfg).unwrap();
        let mut ids = Vec::new();
        for j in jobs {
            if let Ok(id) = host.submit(j) {
                ids.push(id);
            }
        }
        let mut now = Instant::ZERO;
        let mut events = Vec::new();
        for (dt, input) in &inputs {
            now += Duration::from_micros(*dt);
            let out = host.cycle(now, input);
            prop_assert_eq!(out.len(), size.bytes());
            prop_assert_eq!(out[0] & 0x80, 0, "bit 7 is reserved");
            events.extend(std::iter::from_fn(|| host.poll_event()));
        }
        // Silence from the module: the watchdog ends whatever is left, one job per period.
        let idle = vec![0u8; size.bytes()];
        for _ in 0..(ids.len() + 2) * 2 {
            now += Duration::from_secs(31);
            host.cycle(now, &idle);
            events.extend(std::iter::from_fn(|| host.poll_event()));
        }
        let mut counts = HashMap::new();
        count_completions(&events, &mut counts);
        for id in &ids {
            prop_assert_eq!(counts.get(id).copied(), Some(1), "job {:?}", id);
        }
        prop_assert!(counts.values().all(|&c| c == 1));
    }

    #[test]
    fn describe_never_panics(size in window_size(), bytes in proptest::collection::vec(any::<u8>(), 32)) {
        use si_dp_coord::frame::{describe, Direction, V24Layout, Window};
        let w = Window::from_bytes(&bytes[..size.bytes()]).unwrap();
        for dir in [Direction::HostToModule, Direction::ModuleToHost] {
            for layout in [V24Layout::LowByte, V24Layout::HighByte] {
                let head = format!("{:02X}H", bytes[0] & 0x7F);
                let text = describe(&w, dir, layout);
                prop_assert!(text.starts_with(&head), "{}", text);
            }
        }
    }

    #[test]
    fn module_never_panics_and_stays_bounded(
        size in window_size(),
        frames in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..300), 0..20),
        errors in proptest::collection::vec(any::<u16>(), 0..5),
        wrap in exec_wrap(),
        outputs in window_size().prop_flat_map(windows),
    ) {
        let cfg = ModuleConfig {
            rx_buffer_bytes: 600,
            rx_buffer_frames: 8,
            exec_wrap: wrap,
            ..ModuleConfig::new(size)
        };
        let mut module = Module::new(cfg, LoopbackSerial::new()).unwrap();
        for f in frames {
            module.serial_mut().inject_frame(f);
        }
        for e in errors {
            module.serial_mut().inject_error(Status::from_code(e));
        }
        let mut now = Instant::ZERO;
        for (dt, output) in &outputs {
            now += Duration::from_micros(*dt);
            let input = module.cycle(now, output);
            prop_assert_eq!(input.len(), size.bytes());
            prop_assert_eq!(input[0] & 0x80, 0, "bit 7 is reserved");
            prop_assert!(module.buffered() <= 9);
        }
    }

    /// A host and a module with random lag, random faults on the exchange and random job mixes:
    /// no panic, every job completes exactly once and none needs the watchdog (liveness), sends
    /// that succeed reach the line intact, failures are only the protocol's own answers.
    #[test]
    fn host_and_module_complete_random_job_mixes(
        size in window_size(),
        seed in any::<u64>(),
        out_of_order_out in 0.0..0.3f64,
        out_of_order_in in 0.0..0.3f64,
        foreign_request in 0.0..0.3f64,
        jobs in proptest::collection::vec(job(), 1..8),
        line_frames in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 1..60), 0..4),
    ) {
        let host = HostConfig { max_frame_len: 300, ..HostConfig::new(size) };
        let mut l = common::link(host, ModuleConfig::new(size), seed);
        l.faults = common::Faults { out_of_order_out, out_of_order_in, foreign_request };
        for f in line_frames {
            l.module.serial_mut().inject_frame(f);
        }
        for j in jobs {
            let sent = if let Job::Send(f) = &j { Some(f.clone()) } else { None };
            let id = l.host.submit(j).unwrap();
            prop_assert!(l.run_until(200_000, |l| l.completion(id).is_some()));
            prop_assert_eq!(l.completions_of(id), 1);
            if let (Some(f), Some(Ok(_))) = (sent, l.completion(id)) {
                prop_assert_eq!(l.module.serial().sent().last(), Some(&f));
            }
        }
        for s in l.failures() {
            prop_assert!(
                [0x050E, 0x0551, 0x0550].contains(&s.code()),
                "unexpected failure {}", s
            );
        }
    }

    /// Chaos: jobs, host resets, module restarts and faults in random order. Every submitted job
    /// still ends exactly once (the watchdog, here 1 s, bounds the waits).
    #[test]
    fn every_job_ends_once_under_resets_and_restarts(
        size in window_size(),
        seed in any::<u64>(),
        actions in proptest::collection::vec((0u8..10, job(), any::<bool>()), 1..40),
    ) {
        let host = HostConfig {
            job_timeout: Some(Duration::from_secs(1)),
            ..HostConfig::new(size)
        };
        let mut l = common::link(host, ModuleConfig::new(size), seed);
        l.faults = common::Faults { out_of_order_out: 0.05, out_of_order_in: 0.05, foreign_request: 0.05 };
        let mut ids = Vec::new();
        for (what, j, flag) in actions {
            match what {
                0 => l.host.reset(),
                1 => l.module.restart(flag),
                2 => l.module.serial_mut().inject_frame(vec![0x42; 1 + usize::from(flag) * 99]),
                _ => {
                    if let Ok(id) = l.host.submit(j) {
                        ids.push(id);
                    }
                }
            }
            for _ in 0..(usize::from(what) * 40) {
                l.step();
            }
        }
        let all_done = |l: &common::Link| ids.iter().all(|id| l.completion(*id).is_some());
        prop_assert!(l.run_until(2_000_000, all_done));
        for id in &ids {
            prop_assert_eq!(l.completions_of(*id), 1);
        }
    }
}
