//! Write and read holding registers of a Modbus RTU slave with the async master, on a serial
//! port or a serial device server (raw TCP). The line's format is set once, in the master's
//! config, and the port is opened from it (`si_core::port::open`):
//!
//! ```text
//! cargo run --example modbus_serial --features serial -- /dev/ttyUSB0 1      # or COM3
//! cargo run --example modbus_serial --features serial -- 192.0.2.10:4001 1   # device server
//! ```
//!
//! Without hardware: `si --port /dev/pts/4 modbus serve --unit 1` on one end of a pty pair
//! (`socat -d -d pty,raw,echo=0 pty,raw,echo=0`), this example on the other.

mod common;

use si_serial::core::port::PortOptions;
use si_serial::modbus::tokio::{Client as _, Master};
use si_serial::modbus::MasterConfig;

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let target = args
        .next()
        .ok_or("usage: modbus_serial PORT|HOST:PORT [UNIT]")?;
    let unit: u8 = args.next().unwrap_or_else(|| "1".into()).parse()?;

    let config = MasterConfig::default(); // 9600 8E1, the module's defaults
    let line = common::open(&target, &config.line.settings, &PortOptions::default()).await?;
    let master = Master::spawn(config, line.transport)?;
    master.write_single_register(unit, 0, 0x1234).await?;
    let regs = master.read_holding_registers(unit, 0, 4).await?;
    println!("holding 0…3: {regs:04X?}");
    Ok(())
}
