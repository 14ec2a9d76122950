//! The Modbus master under arbitrary responses, timing and line errors, with requests built
//! from fuzzer bytes: no panic, frames within the ADU maximum, every accepted request ends in
//! exactly one Completed or Failed event; frames ended by the gap or (host extension) by their
//! predicted length, as the first byte picks.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_core::Instant;
use si_fuzz::{Harness, Input};
use si_modbus::frame::{decode_request, Request, MAX_ADU};
use si_modbus::{FrameEnd, Master, MasterConfig, MasterEvent};

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let frame_end = if input.u8() & 1 == 1 {
        FrameEnd::Length
    } else {
        FrameEnd::Gap
    };
    let Ok(master) = Master::new(MasterConfig::default()) else {
        return;
    };
    let master = master.with_frame_end(frame_end);
    let mut h = Harness::new(master, MAX_ADU);
    let mut jobs = 0u64;
    let mut on_event = |h: &mut Harness<Master>, e: MasterEvent| match e {
        MasterEvent::Completed(_) | MasterEvent::Failed { .. } => {
            let job = *h.open.iter().next().expect("a completion without a job");
            h.completed(job);
        }
        MasterEvent::Diagnostic(_) => {}
    };
    let mut command = |h: &mut Harness<Master>, selector: u8, args: &[u8]| {
        let now: Instant = h.now;
        let request = match decode_request(args) {
            Ok((_, r)) => r,
            Err(_) => Request::ReadHoldingRegisters {
                address: u16::from(selector),
                quantity: u16::from(selector % 130),
            },
        };
        if h.engine.request(now, selector % 4, &request).is_ok() {
            jobs += 1;
            h.started(jobs);
        }
    };
    h.run(&mut input, &mut command, &mut on_event);
    h.finish(&mut on_event);
});
