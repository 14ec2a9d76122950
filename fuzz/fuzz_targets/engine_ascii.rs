//! The ASCII link under arbitrary bytes, timing, line errors, modem signals and send commands,
//! for every end criterion and flow control: no panic, the frame buffer never over its 1024
//! bytes, every send job ends exactly once.
#![no_main]
use bytes::Bytes;
use libfuzzer_sys::fuzz_target;
use si_ascii::{Config, EndCriterion, Event, FlowControl, Link};
use si_fuzz::{Harness, Input};

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let flags = input.u8();
    let config = Config {
        end: match flags % 3 {
            0 => EndCriterion::CharDelay,
            1 => EndCriterion::EndChars {
                first: b'\r',
                second: b'\n',
            },
            _ => EndCriterion::FixedLength { len: 16 },
        },
        flow_control: match (flags >> 2) % 4 {
            0 => FlowControl::None,
            1 => FlowControl::XonXoff,
            2 => FlowControl::RtsCts,
            _ => FlowControl::AutoV24,
        },
        prevent_overwrite: flags & 0x10 != 0,
        dynamic_frames: flags & 0x20 != 0,
        // The ET 200S 1SI's 200 bytes, or the CP 341's 1024 that fill the whole buffer.
        ..Config::for_module(if flags & 0x80 != 0 {
            si_core::ModulePreset::Cp341
        } else {
            si_core::ModulePreset::Et200s1Si
        })
    };
    let Ok(mut link) = Link::new(config) else {
        return;
    };
    if flags & 0x40 != 0 {
        // Behind a port that declared its latency (a USB adapter).
        si_core::Engine::set_rx_latency(&mut link, si_core::Duration::from_millis(16));
    }
    let mut h = Harness::new(link, 1024);
    let mut frame = [0u8; 1024];
    let mut on_event = |h: &mut Harness<Link>, e: Event| match e {
        Event::Sent { job, .. } | Event::SendFailed { job, .. } => h.completed(u64::from(job.0)),
        Event::Received { .. } | Event::ReceiveError { .. } => {}
    };
    let mut command = |h: &mut Harness<Link>, selector: u8, args: &[u8]| {
        let now = h.now;
        if selector & 1 == 0 {
            if let Ok(job) = h.engine.send(now, Bytes::copy_from_slice(args)) {
                h.started(u64::from(job.0));
            }
        } else if let Some(n) = h.engine.read_frame(now, &mut frame) {
            assert!(n <= 1024);
        }
        assert!(h.engine.buffer().fill() <= h.engine.buffer().capacity());
    };
    h.run(&mut input, &mut command, &mut on_event);
    h.finish(&mut on_event);
});
