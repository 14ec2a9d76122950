//! The USS polling cycle through USB-serial adapters: with default configs a master
//! and a drive, both behind a 16 ms / 62-byte adapter, keep polling (telegrams of 16 bytes,
//! longer than a 9600 bit/s packet) and finish a parameter job at 9600 and 19 200 bit/s,
//! announced or learnt: the response timeout (20 ms) and the residual run time get the port's
//! allowance. Without the adapter the master still starts its next request exactly one start
//! interval after the response ([USS spec] §5.1.2).

use si_core::{Duration, Instant};
use si_sim::{Simulator, StationId, TraceKind, UsbAdapter};
use si_uss::config::{start_interval, uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::PkwWords;
use si_uss::master::{Event, Master, ParamRequest};

fn rig(baud: u32, adapter: Option<UsbAdapter>) -> (Simulator, StationId<Master>, MasterConfig) {
    let settings = uss_settings(baud).unwrap();
    let mut config = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    config.settings = settings;
    let mut sim = Simulator::new(3);
    let m = sim.add_station("master", settings, Master::new(config.clone()).unwrap());
    let d = sim.add_station(
        "drive1",
        settings,
        Drive::new(DriveConfig::new(settings, 1)).unwrap(),
    );
    sim.connect(m, d);
    if let Some(adapter) = adapter {
        sim.set_adapter(m, adapter).unwrap();
        sim.set_adapter(d, adapter).unwrap();
    }
    sim.with(m, |m, now| m.start(now));
    (sim, m, config)
}

/// 50 polls and one parameter read: every poll answered, nothing rejected, except that the
/// first `grace` cycles may fail.
fn cycle(baud: u32, adapter: UsbAdapter, grace: u64) {
    let (mut sim, m, _) = rig(baud, Some(adapter));
    let what = format!("{baud} bit/s, {adapter:?}");
    let job = sim
        .with(m, |m, now| {
            m.request_parameter(now, 1, ParamRequest::read(700, 0))
        })
        .unwrap();
    let mut responses = 0;
    let mut done = false;
    while responses < 50 {
        assert!(sim.step(), "{what}: the simulation went quiet");
        for e in sim.take_events(m) {
            match e {
                Event::Response { .. } => responses += 1,
                Event::ParameterDone { job: j, .. } if j == job => done = true,
                Event::CycleDone { .. } => {}
                Event::NoAnswer { cycle, .. } | Event::Rejected { cycle, .. } if cycle < grace => {}
                other => panic!("{what}: {other:?}"),
            }
        }
    }
    assert!(done, "{what}: the parameter job never finished");
}

#[test]
fn the_polling_cycle_runs_through_announced_16ms_adapters() {
    for baud in [9_600, 19_200] {
        cycle(baud, UsbAdapter::FTDI_DEFAULT, 0);
    }
}

#[test]
fn the_polling_cycle_runs_through_unannounced_16ms_adapters_after_its_first_poll() {
    // The first poll can go unanswered: before anything was received the master cannot know
    // the port packetises, and the response's STX reaches it two latencies (the drive's adapter
    // and its own) after the request, past the 20 ms response timeout. Its late response is
    // discarded (start interval or unsolicited). From the first multi-byte read on, the
    // master knows, and every poll is answered.
    for baud in [9_600, 19_200] {
        cycle(baud, UsbAdapter::FTDI_DEFAULT.unannounced(), 1);
    }
}

#[test]
fn without_an_adapter_the_next_request_follows_the_response_by_the_start_interval() {
    for baud in [9_600, 19_200] {
        let (mut sim, _, config) = rig(baud, None);
        sim.run_until(Instant::ZERO + Duration::from_millis(500));
        let requests: Vec<Instant> = sim
            .trace()
            .of("master")
            .filter(|e| matches!(e.kind, TraceKind::Tx { .. }))
            .map(|e| e.at)
            .collect();
        let second = requests[1];
        let received = sim.trace().received("master");
        let response_end = received.iter().rfind(|r| r.0 <= second).unwrap().0;
        let expected = response_end + start_interval(&config.settings) + config.cycle_pause;
        assert_eq!(second, expected, "{baud} bit/s");
    }
}
