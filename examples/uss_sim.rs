//! A USS master polling three simulated drives on an RS-485 bus, in virtual time: drive 2 is
//! switched off, the cycle goes on; meanwhile a parameter of drive 3 (P1082) is written.
//!
//! `cargo run --example uss_sim`

use si_serial::core::{Duration, Instant};
use si_serial::sim::Simulator;
use si_serial::uss::config::{uss_settings, MasterConfig, PollEntry};
use si_serial::uss::drive::{stw, Drive, DriveConfig};
use si_serial::uss::frame::PkwWords;
use si_serial::uss::master::{Event, Master, ParamRequest, Width};

fn main() {
    let settings = uss_settings(9_600).expect("9600 8E1 is a USS format");
    let mut config = MasterConfig::new(
        [1, 2, 3]
            .iter()
            .map(|&a| PollEntry::new(a, PkwWords::Four, 2))
            .collect(),
    );
    config.settings = settings;
    config.local_echo = true; // on the RS-485 bus we hear ourselves

    let mut sim = Simulator::new(1);
    let master = sim.add_station(
        "master",
        settings,
        Master::new(config).expect("valid config"),
    );
    let mut bus = vec![master.index()];
    for address in [1, 2, 3] {
        let drive = DriveConfig {
            local_echo: true,
            ..DriveConfig::new(settings, address)
        };
        let id = sim.add_station(
            &format!("drive{address}"),
            settings,
            Drive::new(drive).unwrap(),
        );
        if address == 2 {
            sim.silence(id, Instant::ZERO);
        }
        bus.push(id.index());
    }
    sim.bus(&bus);

    sim.with(master, |m, now| {
        m.start(now);
        m.set_control(1, &[stw::RUN, 1500]).unwrap();
        m.request_parameter(now, 3, ParamRequest::write(1082, 0, 120, Width::Word))
            .unwrap();
    });
    sim.run_for(Duration::from_millis(500));

    for event in sim.take_events(master) {
        match event {
            Event::Response {
                cycle,
                address,
                net,
            } => println!(
                "cycle {cycle}: drive {address} ZSW {:04X} HIW {}",
                net.pzd.first().unwrap_or(0),
                net.pzd.second().unwrap_or(0)
            ),
            Event::NoAnswer { cycle, address } => {
                println!("cycle {cycle}: node {address} does not answer")
            }
            Event::ParameterDone {
                address, response, ..
            } => println!(
                "drive {address}: P{} = {} written",
                response.pke.pnu(),
                response.value()
            ),
            other => println!("{other:?}"),
        }
    }
    println!("counters: {:?}", sim.engine(master).counters());
}
