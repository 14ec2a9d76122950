//! Three protocols, three handles that look alike (a user program of 15 lines): send one block
//! over 3964(R), read one Modbus holding register from unit 1, read parameter P700 of USS
//! drive 3, all at 9600 bit/s 8E1 (every config's default), every error propagated with `?`.
//!
//! ```text
//! cargo run --example three_protocols --features serial -- /dev/ttyS0 /dev/ttyS1 /dev/ttyS2
//! ```
//!
//! Each handle is opened from its config and a path (the port takes the config's own line
//! settings), and its verbs return `Result<_, si_xxx::tokio::Error>`, which converts into
//! `Box<dyn Error>` (a failed job's error shows the manual's STATUS with its text).
//! `crates/si-cli/tests/pty/three_protocols_example.rs` runs this program against `si`
//! serving the three partners.

use si_serial::modbus::tokio::Client as _; // Modbus function codes (RTU and TCP alike)
use si_serial::uss::config::{MasterConfig as UssConfig, PollEntry};
use si_serial::{modbus, r3964, uss};
use std::error::Error;

const USAGE: &str = "usage: three_protocols PORT_3964R PORT_MODBUS PORT_USS";

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn Error>> {
    let port = |i: usize| std::env::args().nth(i).ok_or(USAGE);
    let uss = UssConfig::new(vec![PollEntry::new(3, uss::frame::PkwWords::Four, 2)]);
    let link = r3964::tokio::Handle::open(Default::default(), &port(1)?)?;
    let plc = modbus::tokio::Master::open(Default::default(), &port(2)?)?;
    let drives = uss::tokio::Handle::open(uss, &port(3)?)?;
    link.send(&b"hello"[..]).await?;
    println!("3964(R): sent 5 bytes");
    let register = plc.read_holding_registers(1, 0, 1).await?[0];
    println!("Modbus: unit 1 register 0 = {register:04X}");
    let p700 = drives.read_parameter(3, 700, 0).await?;
    println!("USS: drive 3 P700 = {p700}");
    Ok(())
}
