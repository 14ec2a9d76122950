//! Two 3964(R) stations exchange blocks on the deterministic line simulator, including an
//! initialization conflict and a corrupted character that the BCC catches.
//!
//! ```text
//! cargo run --example 3964r_sim
//! ```

use si_serial::core::{Duration, SerialSettings};
use si_serial::r3964::{Config, Event, Link, Priority};
use si_serial::sim::Simulator;

fn main() {
    let line = SerialSettings::default(); // 9600 bit/s, 8 data bits, even parity, 1 stop bit
    let mut sim = Simulator::new(2024);
    // The partners must have different priorities ([ET200S SI] §2.7, Fig. 2-16).
    let plc_config = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let plc = sim.add_station(
        "PLC",
        line,
        Link::new(plc_config.with_settings(line)).expect("valid config"),
    );
    let host = sim.add_station(
        "host",
        line,
        Link::new(Config::default().with_settings(line)).expect("valid config"),
    );
    sim.connect(plc, host);

    // Both want to send at the same instant: the low-priority host yields, receives, then sends.
    sim.with(plc, |link, now| link.send(now, &b"tank level 73 %"[..]))
        .expect("no job running");
    sim.with(host, |link, now| link.send(now, &b"valve 4 open"[..]))
        .expect("no job running");
    sim.run_for(Duration::from_secs(1));

    // A bit of the next block is flipped on its way to the host: BCC error, NAK, repetition.
    sim.corrupt_received(host, 3, 0x20);
    sim.with(plc, |link, now| link.send(now, &b"pump 2 running"[..]))
        .expect("no job running");
    sim.run_for(Duration::from_secs(1));

    print!("{}", sim.trace());
    for (name, station) in [("PLC", plc), ("host", host)] {
        for event in sim.take_events(station) {
            match event {
                Event::Sent { job } => println!("{name}: {job} acknowledged"),
                Event::SendFailed { job, status } => println!("{name}: {job} failed: {status}"),
                Event::ReceiveError(status) => println!("{name}: receive error {status}"),
                Event::Received { .. } => {
                    let block = sim
                        .with(station, |link, now| link.take_block(now))
                        .expect("a received block waits in the buffer");
                    println!("{name}: received {:?}", String::from_utf8_lossy(&block));
                }
            }
        }
    }
}
