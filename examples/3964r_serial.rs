//! Send a block with 3964(R) over a serial port (or a serial device server, raw TCP) and print
//! what the partner sends back. The port is opened from the line settings the link uses
//! (`si_core::port::open`): no `stty`.
//!
//! ```text
//! cargo run --example 3964r_serial --features serial -- /dev/ttyUSB0 "hello PLC"      # or COM3
//! cargo run --example 3964r_serial --features serial -- 192.0.2.10:4001 "hello PLC"   # device server
//! ```
//!
//! Without hardware: `si --port /dev/pts/4 3964r recv --count 1` on one end of a pty pair.

mod common;

use si_serial::core::port::PortOptions;
use si_serial::r3964::tokio::Handle;
use si_serial::r3964::{Config, Priority};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (Some(path), Some(text)) = (args.next(), args.next()) else {
        return Err("usage: 3964r_serial PORT|HOST:PORT TEXT".into());
    };
    // 9600 8E1 (`config.settings`): set once, for the port and the link.
    let config = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let serial = common::open(&path, &config.settings, &PortOptions::default()).await?;
    let mut link = Handle::spawn(config, serial.transport)?;
    link.send(text.into_bytes()).await?;
    println!("sent, the partner acknowledged with DLE");
    println!("waiting for a block from the partner (Ctrl-C to stop)…");
    let block = link.recv().await?;
    println!("received {:?}", String::from_utf8_lossy(&block));
    Ok(())
}
