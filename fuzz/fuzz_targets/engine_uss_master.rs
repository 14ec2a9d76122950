//! The USS master polling three drives under arbitrary answers, timing and line errors, with
//! parameter jobs from the fuzzer: no panic, telegrams within the maximum, every parameter job
//! ends exactly once.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_fuzz::{Harness, Input};
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::frame::{PkwWords, MAX_TELEGRAM};
use si_uss::{Event, Master, ParamRequest};

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let mut config = MasterConfig::new(vec![
        PollEntry::new(1, PkwWords::Four, 2),
        PollEntry::new(2, PkwWords::Three, 0),
        PollEntry::new(3, PkwWords::Variable, 6),
    ]);
    config.settings = uss_settings(19_200).unwrap();
    let flags = input.u8();
    config.local_echo = flags & 1 == 1;
    let Ok(mut master) = Master::new(config) else {
        return;
    };
    if flags & 2 != 0 {
        // Behind a port that declared its latency (a USB adapter).
        si_core::Engine::set_rx_latency(&mut master, si_core::Duration::from_millis(16));
    }
    master.start(si_core::Instant::ZERO);
    let mut h = Harness::new(master, MAX_TELEGRAM);
    let mut on_event = |h: &mut Harness<Master>, e: Event| match e {
        Event::ParameterDone { job, .. } | Event::ParameterFailed { job, .. } => h.completed(job.0),
        _ => {}
    };
    let mut command = |h: &mut Harness<Master>, selector: u8, args: &[u8]| {
        let now = h.now;
        let value = args
            .iter()
            .fold(0u32, |v, &b| v.rotate_left(8) ^ u32::from(b));
        let request = ParamRequest {
            task: selector & 0x0F,
            param: si_uss::ParamAddress {
                number: u16::from(selector) * 7,
                index: selector >> 4,
            },
            value,
        };
        if let Ok(job) = h.engine.request_parameter(now, selector % 4, request) {
            h.started(job.0);
        }
    };
    h.run(&mut input, &mut command, &mut on_event);
    h.finish(&mut on_event);
});
