//! SEND to and FETCH from an RK 512 partner behind a serial device server (raw TCP), with the
//! async handle. Needs the `tokio` feature:
//!
//! ```text
//! cargo run --example rk512_tcp --features tokio -- 192.0.2.10:4001
//! ```
//!
//! Try it without hardware against `si rk512 serve` on one end of a pty pair and a TCP bridge
//! (`socat TCP-LISTEN:4001 /dev/pts/N,raw,echo=0`).

#[cfg(feature = "tokio")]
#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    use si_serial::core::SerialSettings;
    use si_serial::r3964::Priority;
    use si_serial::rk512::frame::{Address, Coordination};
    use si_serial::rk512::tokio::Rk512;
    use si_serial::rk512::Config;

    let addr = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "127.0.0.1:4001".into());
    let stream = tokio::net::TcpStream::connect(&addr).await?;
    let mut config = Config::default();
    config.link.priority = Priority::High; // the PLC side usually keeps the default, low
    let station = Rk512::spawn(config, SerialSettings::default(), None, stream)?;

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

#[cfg(not(feature = "tokio"))]
fn main() {
    eprintln!("this example needs the tokio feature: --features tokio");
}
