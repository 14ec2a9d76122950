//! The 3964(R) link under arbitrary bytes, timing, line errors and send commands: no panic,
//! frames never longer than a doubled maximum block, received blocks within the maximum, and
//! every send job ends exactly once (done or failed with a STATUS).
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_3964r::{Config, Event, Link, Priority};
use si_core::SerialSettings;
use si_fuzz::{Harness, Input};

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let flags = input.u8();
    let config = Config {
        block_check: flags & 1 == 0,
        priority: if flags & 2 == 0 {
            Priority::Low
        } else {
            Priority::High
        },
        max_block_len: 64,
        ..Config::default()
    };
    let Ok(mut link) = Link::new(config.with_settings(SerialSettings::default())) else {
        return;
    };
    if flags & 4 != 0 {
        // Behind a port that declared its latency (a USB adapter).
        si_core::Engine::set_rx_latency(&mut link, si_core::Duration::from_millis(16));
    }
    let mut h = Harness::new(link, 2 * 64 + 3);
    let mut on_event = |h: &mut Harness<Link>, e: Event| match e {
        Event::Sent { job } | Event::SendFailed { job, .. } => h.completed(job.0),
        Event::Received { len } => {
            assert!(len <= 64);
            let now = h.now;
            let block = h.engine.take_block(now).expect("a reported block is there");
            assert_eq!(block.len(), len);
        }
        Event::ReceiveError(_) => {}
    };
    let mut command = |h: &mut Harness<Link>, _: u8, args: &[u8]| {
        let now = h.now;
        if let Ok(job) = h.engine.send(now, args.to_vec()) {
            h.started(job.0);
        }
    };
    h.run(&mut input, &mut command, &mut on_event);
    h.finish(&mut on_event);
});
