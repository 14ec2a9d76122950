//! A Modbus master and an S_MODB slave on the deterministic line simulator: the slave maps
//! registers to DB6 and coils to M500.0 through the manual's example conversion DB
//! ([Modbus/USS] Table 3-20); one write beyond DB_Max shows an exception.
//!
//! `cargo run --example modbus_sim`

use si_serial::core::{Instant, SerialSettings};
use si_serial::modbus::frame::{Registers, Request};
use si_serial::modbus::{Master, MasterConfig, MasterEvent, SimaticStore, Slave, SlaveConfig};
use si_serial::sim::Simulator;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let settings = SerialSettings::default(); // 9600 8E1, the module's default
    let mut sim = Simulator::new(1);
    let master = sim.add_station("master", settings, Master::new(MasterConfig::default())?);
    let slave_config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    let slave = sim.add_station(
        "slave",
        settings,
        Slave::new(slave_config, SimaticStore::example())?,
    );
    sim.connect(master, slave);

    let jobs = [
        Request::WriteMultipleRegisters {
            address: 0,
            values: Registers::Words(&[0x1234, 0x5678]),
        },
        Request::ReadHoldingRegisters {
            address: 0,
            quantity: 2,
        },
        Request::WriteSingleCoil {
            address: 3,
            value: true,
        },
        // Register 512 is DB7.DBW0, above DB_Max = 6: exception 02, STATUS 16#0E62.
        Request::WriteSingleRegister {
            address: 512,
            value: 1,
        },
    ];
    for job in &jobs {
        sim.with(master, |m, now| m.request(now, 1, job))?;
        // Step the simulation until the job's completion event: its time is when it happened.
        let mut events = Vec::new();
        while events.is_empty() && sim.step() {
            events = sim.take_events(master);
        }
        for event in events {
            match event {
                MasterEvent::Completed(c) => println!("{}: {:?}", sim.now(), c.response()),
                MasterEvent::Failed { status, .. } => println!("{}: failed {status}", sim.now()),
                MasterEvent::Diagnostic(s) => println!("{}: {s}", sim.now()),
            }
        }
    }
    let memory = &sim.engine(slave).store().memory;
    println!(
        "DB6.DBW0 = {:04X}, M500.3 = {}",
        memory.word(si_serial::core::memory::Area::Db(6), 0)?,
        memory.bit(si_serial::core::memory::Area::Flags, 500, 3)?
    );
    assert!(sim.now() > Instant::ZERO);
    Ok(())
}
