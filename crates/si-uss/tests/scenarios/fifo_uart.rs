//! The USS master behind a 16550-type FIFO UART (si-sim's [`FifoUart`], announcing nothing, as
//! a `ttyS` port under the tokio driver) with default configs, the drive on the line directly:
//! at every trigger level, at 9600 and 19 200 bit/s, every poll is answered from the first on
//! and a parameter job finishes ([USS spec] §5.1.2: the response timeout and the residual run
//! time get the port's allowance while the port is taken to hold bytes).

use si_sim::{FifoUart, Simulator};
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::PkwWords;
use si_uss::master::{Event, Master, ParamRequest};

fn cycle(baud: u32, uart: FifoUart) {
    let settings = uss_settings(baud).unwrap();
    let mut config = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    config.settings = settings;
    let mut sim = Simulator::new(5).without_trace();
    let m = sim.add_station("master", settings, Master::new(config).unwrap());
    let d = sim.add_station(
        "drive1",
        settings,
        Drive::new(DriveConfig::new(settings, 1)).unwrap(),
    );
    sim.connect(m, d);
    sim.set_uart(m, uart).unwrap();
    sim.with(m, |m, now| m.start(now));
    let what = format!("{baud} bit/s, trigger {}", uart.trigger);
    let job = sim
        .with(m, |m, now| {
            m.request_parameter(now, 1, ParamRequest::read(700, 0))
        })
        .unwrap();
    let (mut responses, mut done) = (0, false);
    while responses < 50 {
        assert!(sim.step(), "{what}: the simulation went quiet");
        for e in sim.take_events(m) {
            match e {
                Event::Response { .. } => responses += 1,
                Event::ParameterDone { job: j, .. } if j == job => done = true,
                Event::CycleDone { .. } => {}
                other => panic!("{what}: {other:?}"),
            }
        }
    }
    assert!(done, "{what}: the parameter job never finished");
}

#[test]
fn a_master_behind_a_fifo_uart_polls_from_the_first_cycle_at_every_trigger_level() {
    for baud in [9_600, 19_200] {
        for trigger in FifoUart::TRIGGERS {
            cycle(baud, FifoUart::LINUX_16550A.with_trigger(trigger));
        }
    }
}
