//! The Modbus slave (S_MODB's SIMATIC mapping) under arbitrary requests, timing and line
//! errors: no panic, responses within the ADU maximum, output queue bounded; frames ended by the
//! gap or (host extension) by their predicted length, as the first byte's top bit picks.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_fuzz::{Harness, Input};
use si_modbus::frame::MAX_ADU;
use si_modbus::{FrameEnd, SimaticStore, Slave, SlaveConfig};

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let first = input.u8();
    let address = first % 4 + 1;
    let frame_end = if first & 0x80 != 0 {
        FrameEnd::Length
    } else {
        FrameEnd::Gap
    };
    let config = SlaveConfig {
        address,
        ..SlaveConfig::default()
    };
    let Ok(slave) = Slave::new(config, SimaticStore::example()) else {
        return;
    };
    let mut slave = slave.with_frame_end(frame_end);
    if first & 0x40 != 0 {
        // Behind a port that declared its latency (a USB adapter).
        si_core::Engine::set_rx_latency(&mut slave, si_core::Duration::from_millis(16));
    }
    let mut h = Harness::new(slave, MAX_ADU);
    let mut on_event = |_: &mut Harness<Slave<SimaticStore>>, _| {};
    let mut command = |h: &mut Harness<Slave<SimaticStore>>, _: u8, args: &[u8]| {
        // A whole request in one read, as a fast driver delivers it.
        let now = h.now;
        si_core::Engine::handle_rx(&mut h.engine, now, args);
    };
    h.run(&mut input, &mut command, &mut on_event);
    let deadline = h.deadline;
    if let Some(t) = deadline {
        h.advance(t, &mut on_event);
    }
});
