//! A host and a PLC speak RK 512 on the deterministic line simulator: the host SENDs 200 bytes
//! to DB10 (two telegrams), FETCHes them back, and then runs into the PLC's coordination flag
//! ([CP 341] §2.2.3).
//!
//! ```text
//! cargo run --example rk512_sim
//! ```

use si_serial::core::memory::Area;
use si_serial::core::{Duration, Instant, SerialSettings};
use si_serial::r3964::Priority;
use si_serial::rk512::frame::{Address, Coordination};
use si_serial::rk512::passive::ServerConfig;
use si_serial::rk512::{Config, Event, Station};
use si_serial::sim::Simulator;

fn main() {
    let line = SerialSettings::default(); // 9600 8E1
                                          // The 3964(R) partners underneath must have different priorities.
    let mut host_config = Config::default();
    host_config.link.priority = Priority::High;
    let mut plc_memory = ServerConfig::default();
    plc_memory.memory.dbs.insert(10, 512);

    let mut sim = Simulator::new(7);
    let host = sim.add_station(
        "host",
        line,
        Station::new(host_config.with_settings(line)).expect("valid config"),
    );
    let plc = sim.add_station(
        "PLC",
        line,
        Station::serving(Config::default().with_settings(line), &plc_memory).expect("valid config"),
    );
    sim.connect(host, plc);

    let db10 = Address::Db { db: 10, dw: 0 };
    let km = Coordination::flag(20, 3); // M 20.3 at the PLC
    let data: Vec<u8> = (0..200u8).collect();
    let run = |sim: &mut Simulator| {
        // Until the host's job has ended, then a little longer for the last acknowledgement.
        while sim.engine(host).is_busy() {
            sim.run_for(Duration::from_millis(10));
        }
        sim.run_for(Duration::from_millis(100));
        for event in sim.take_events(host) {
            match event {
                Event::Done { job, data } if data.is_empty() => println!("host: {job} done"),
                Event::Done { job, data } => {
                    println!(
                        "host: {job} fetched {} bytes: {:02X?}…",
                        data.len(),
                        &data[..8]
                    )
                }
                Event::Failed { job, status } => println!("host: {job} failed: {status}"),
                other => println!("host: {other:?}"),
            }
        }
        for event in sim.take_events(plc) {
            println!("PLC:  {event:?}");
        }
    };

    sim.with(host, |s, now| s.send(now, db10, km, data.clone()))
        .expect("job accepted");
    run(&mut sim);
    sim.with(host, |s, now| s.fetch(now, db10, Coordination::NONE, 200))
        .expect("job accepted");
    run(&mut sim);
    // M 20.3 is still set (the PLC program has not consumed the data): refused with 16#0909.
    sim.with(host, |s, now| s.send(now, db10, km, vec![0xAA, 0x55]))
        .expect("job accepted");
    run(&mut sim);
    // The PLC program takes the data and resets the flag; now the SEND goes through.
    sim.with(plc, |s, _| {
        s.server_mut()
            .memory_mut()
            .set_bit(Area::Flags, 20, 3, false)
            .expect("M 20.3 exists")
    });
    sim.with(host, |s, now| s.send(now, db10, km, vec![0xAA, 0x55]))
        .expect("job accepted");
    run(&mut sim);
    let word = sim.engine(plc).server().memory().word(Area::Db(10), 0);
    println!("PLC:  DB10.DBW0 = {:04X}", word.expect("DB10 exists"));
    println!("virtual time used: {}", sim.now() - Instant::ZERO);
}
