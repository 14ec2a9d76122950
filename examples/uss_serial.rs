//! Poll USS drives on a serial port (RS-485) or a serial device server (raw TCP) with the
//! async master and read a parameter:
//!
//! ```text
//! cargo run --example uss_serial --features serial -- /dev/ttyUSB0 1,2          # or COM3
//! cargo run --example uss_serial --features serial -- /dev/ttyUSB0 1 rts        # RTS-switched adapter
//! cargo run --example uss_serial --features serial -- 192.0.2.10:4001 1,2       # device server
//! ```
//!
//! The third argument picks RS-485 direction control: `kernel` (the UART driver's RS-485 mode,
//! Linux) or `rts` (the driver raises RTS around each telegram); leave it out for adapters
//! that switch by themselves. Without hardware: `si uss sim-slave --address 1 --port
//! /dev/pts/4` on one end of a pty pair.

mod common;

use si_serial::core::driver::RtsToggle;
use si_serial::core::port::{PortOptions, Rs485, TxEnable};
use si_serial::core::Duration;
use si_serial::uss::config::{uss_settings, MasterConfig, PollEntry};
use si_serial::uss::frame::PkwWords;
use si_serial::uss::master::Event;
use si_serial::uss::tokio::Handle;

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: uss_serial PORT|HOST:PORT [SLAVES] [kernel|rts]")?;
    let slaves: Vec<u8> = args
        .next()
        .unwrap_or_else(|| "1".into())
        .split(',')
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let rs485 = match args.next().as_deref() {
        Some("kernel") => Some(Rs485::Kernel {
            delay_before: Duration::ZERO,
            delay_after: Duration::ZERO,
        }),
        Some("rts") => Some(Rs485::Driver {
            toggle: RtsToggle::default(),
            output: TxEnable::Rts,
        }),
        Some(other) => return Err(format!("unknown RS-485 mode {other}: kernel or rts").into()),
        None => None,
    };

    let settings = uss_settings(9_600)?;
    let mut config = MasterConfig::new(
        slaves
            .iter()
            .map(|&a| PollEntry::new(a, PkwWords::Four, 2))
            .collect(),
    );
    config.settings = settings;
    let options = PortOptions {
        rs485,
        ..PortOptions::default()
    };
    let line = common::open(&path, &settings, &options).await?;
    if line.network {
        // A device server adds network latency on top of the drive's 20 ms.
        config.response_timeout = Duration::from_millis(100);
    }
    let mut master = Handle::spawn(config, line.transport)?;

    let p700 = master.read_parameter(slaves[0], 700, 0).await?;
    println!("drive {}: P700 = {p700}", slaves[0]);
    master.set_control(slaves[0], vec![0x047E, 0]).await?;
    for _ in 0..(10 * slaves.len()) {
        match master.next_event().await {
            Some(Event::Response { address, net, .. }) => println!(
                "drive {address}: ZSW {:04X} HIW {}",
                net.pzd.first().unwrap_or(0),
                net.pzd.second().unwrap_or(0)
            ),
            Some(Event::NoAnswer { address, .. }) => println!("node {address} does not answer"),
            Some(_) => {}
            None => break,
        }
    }
    Ok(())
}
