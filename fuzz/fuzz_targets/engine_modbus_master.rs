//! The Modbus master under arbitrary responses, timing and line errors, with requests built
//! from fuzzer bytes: no panic, frames within the ADU maximum, every accepted request ends in
//! exactly one Completed or Failed event; frames ended by the gap or (host extension) by their
//! predicted length, as the first byte picks; on the interface it picks (RS-485 skips leading
//! garbage), and behind a port whose latency it may declare (a USB adapter).
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_core::{Duration, Engine, Instant, Interface};
use si_fuzz::{Harness, Input};
use si_modbus::frame::{decode_request, Request, MAX_ADU};
use si_modbus::{FrameEnd, Master, MasterConfig, MasterEvent};

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let flags = input.u8();
    let frame_end = if flags & 1 == 1 {
        FrameEnd::Length
    } else {
        FrameEnd::Gap
    };
    let interface = match (flags >> 1) & 3 {
        0 => Interface::Rs232,
        1 => Interface::Rs422,
        _ => Interface::Rs485,
    };
    let Ok(master) = Master::new(MasterConfig::default()) else {
        return;
    };
    let mut master = master.with_frame_end(frame_end).with_interface(interface);
    if flags & 0x08 != 0 {
        master.set_rx_latency(Duration::from_millis(u64::from(input.u8())));
    }
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
