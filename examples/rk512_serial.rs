//! SEND to and FETCH from an RK 512 partner (a CP 341, an ET 200S SI module) on a serial port
//! or a serial device server (raw TCP):
//!
//! ```text
//! cargo run --example rk512_serial --features serial -- /dev/ttyUSB0      # or COM3
//! cargo run --example rk512_serial --features serial -- 192.0.2.10:4001   # device server
//! ```
//!
//! Without hardware: `si --port /dev/pts/4 rk512 serve` on one end of a pty pair.

mod common;

use si_serial::core::port::PortOptions;
use si_serial::r3964::Priority;
use si_serial::rk512::frame::{Address, Coordination};
use si_serial::rk512::tokio::Handle;
use si_serial::rk512::Config;

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let target = std::env::args()
        .nth(1)
        .ok_or("usage: rk512_serial PORT|HOST:PORT")?;
    let mut config = Config::default(); // 9600 8E1 (config.link.settings): for port and engine
    config.link.priority = Priority::High; // the PLC side usually keeps the default, low
    let line = common::open(&target, &config.link.settings, &PortOptions::default()).await?;
    let station = Handle::spawn(config, line.transport)?;

    let db10 = Address::Db { db: 10, dw: 0 };
    match station
        .send(db10, Coordination::NONE, vec![0x12, 0x34, 0x56, 0x78])
        .await
    {
        Ok(()) => println!("SEND DB10.DW0: done"),
        // A failed job ends with the STATUS, e.g. 16#0903 (DB missing at the partner).
        Err(status) => println!("SEND DB10.DW0: {status}"),
    }
    match station.fetch(db10, Coordination::NONE, 4).await {
        Ok(data) => println!("FETCH DB10.DW0: {data:02X?}"),
        Err(status) => println!("FETCH DB10.DW0: {status}"),
    }
    Ok(())
}
