//! Receive CR LF-terminated lines with the ASCII driver and answer each with "OK\r\n"
//! ([ET200S SI] §2.8, two end-of-text characters), on a serial port or a serial
//! device server (raw TCP). The port is opened from the driver's own settings
//! (`si_core::port::open`):
//!
//! ```text
//! cargo run --example ascii_serial --features serial -- /dev/ttyUSB0       # or COM3
//! cargo run --example ascii_serial --features serial -- 192.0.2.10:4001    # device server
//! ```

mod common;

use si_serial::ascii::tokio::{Handle, Incoming};
use si_serial::ascii::{Config, EndCriterion};
use si_serial::core::port::PortOptions;

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let target = std::env::args()
        .nth(1)
        .ok_or("usage: ascii_serial PORT|HOST:PORT")?;
    let mut config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        ..Config::default()
    };
    let line = common::open(&target, &config.settings, &PortOptions::default()).await?;
    if line.network {
        // A device server adds latency between characters: be generous.
        config.char_delay = si_serial::core::Duration::from_millis(200);
    }
    let mut port = Handle::spawn(config, line.transport)?;
    loop {
        match port.recv_timed().await? {
            Incoming::Frame { data, at } => {
                println!("{at}: {:?}", String::from_utf8_lossy(&data));
                port.send(&b"OK\r\n"[..]).await?;
            }
            // Parity, framing and BREAK arrive here as the manual's STATUS (serial port, Linux).
            Incoming::Error { status, at } => eprintln!("{at}: receive error {status}"),
        }
    }
}
