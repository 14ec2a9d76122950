//! Poll USS drives through a serial device server (raw TCP) with the async master, and read a
//! parameter. Needs the `tokio` feature:
//!
//! `cargo run --example uss_tcp --features tokio -- 192.0.2.10:4001 1,2`

#[cfg(feature = "tokio")]
#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    use si_serial::core::driver::DriverOptions;
    use si_serial::uss::config::{uss_settings, MasterConfig, PollEntry};
    use si_serial::uss::frame::PkwWords;
    use si_serial::uss::master::{Event, Master, ParamRequest};
    use si_serial::uss::tokio::UssMaster;

    let mut args = std::env::args().skip(1);
    let addr = args.next().unwrap_or_else(|| "127.0.0.1:4001".into());
    let slaves: Vec<u8> = args
        .next()
        .unwrap_or_else(|| "1".into())
        .split(',')
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;

    let settings = uss_settings(9_600)?;
    let mut config = MasterConfig::new(
        slaves
            .iter()
            .map(|&a| PollEntry::new(a, PkwWords::Four, 2))
            .collect(),
    );
    config.settings = settings;
    // A device server adds network latency on top of the drive's 20 ms.
    config.response_timeout = si_serial::core::Duration::from_millis(100);
    let stream = tokio::net::TcpStream::connect(&addr).await?;
    let options = DriverOptions {
        settings: Some(settings),
        ..DriverOptions::default()
    };
    let (mut master, _task) = UssMaster::spawn(Master::new(config)?, stream, options).await?;

    let p = master
        .parameter(slaves[0], ParamRequest::read(700, 0))
        .await?;
    println!("drive {}: P700 = {}", slaves[0], p.value());
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

#[cfg(not(feature = "tokio"))]
fn main() {
    eprintln!("this example needs the tokio feature: cargo run --example uss_tcp --features tokio");
}
