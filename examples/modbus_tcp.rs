//! Read and write a Modbus RTU slave behind a serial device server (raw TCP) with the async
//! master. Needs the `tokio` feature:
//!
//! `cargo run --example modbus_tcp --features tokio -- 192.0.2.10:4001 1`

#[cfg(feature = "tokio")]
#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    use si_serial::modbus::tokio::MasterHandle;
    use si_serial::modbus::MasterConfig;

    let mut args = std::env::args().skip(1);
    let addr = args.next().unwrap_or_else(|| "127.0.0.1:4001".into());
    let unit: u8 = args.next().unwrap_or_else(|| "1".into()).parse()?;

    let stream = tokio::net::TcpStream::connect(&addr).await?;
    let mut master = MasterHandle::spawn(MasterConfig::default(), stream)?;
    master.write_single_register(unit, 0, 0x1234).await?;
    let regs = master.read_holding_registers(unit, 0, 4).await?;
    println!("holding 0…3: {regs:04X?}");
    match master.read_holding_registers(unit, 60_000, 1).await {
        Ok(r) => println!("holding 60000: {r:?}"),
        // A refused read ends with the manual's STATUS, e.g. 16#0E62 (exception 02).
        Err(e) => println!("holding 60000: {e}"),
    }
    Ok(())
}

#[cfg(not(feature = "tokio"))]
fn main() {
    eprintln!("build with --features tokio");
}
