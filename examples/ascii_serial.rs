//! Receive CR LF-terminated lines with the ASCII driver on a serial port and answer each with
//! "OK\r\n" (et200s-si-3964r-ascii.md §6.3, two end-of-text characters). The port is opened from
//! the driver's own settings (`si_core::port::open`):
//!
//! ```text
//! cargo run --example ascii_serial --features serial -- /dev/ttyUSB0     # or COM3
//! ```

use si_serial::ascii::tokio::{AsciiHandle, Incoming};
use si_serial::ascii::{Config, EndCriterion};
use si_serial::core::port::{self, PortOptions};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: ascii_serial PORT")?;
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        ..Config::default()
    };
    let serial = port::open(&path, &config.settings, &PortOptions::default())?;
    let mut port = AsciiHandle::spawn(config, serial)?;
    loop {
        match port.next().await? {
            Incoming::Frame { data, at } => {
                println!("{at}: {:?}", String::from_utf8_lossy(&data));
                port.send(&b"OK\r\n"[..]).await?;
            }
            // Parity, framing and BREAK arrive here as the manual's STATUS on Linux.
            Incoming::Error { status, at } => eprintln!("{at}: receive error {status}"),
        }
    }
}
