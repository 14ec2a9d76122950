//! Send a block with 3964(R) over a serial port and print what the partner sends back.
//!
//! ```text
//! stty -F /dev/ttyUSB0 9600 cs8 parenb -parodd -cstopb raw -echo   # 9600 8E1, raw
//! cargo run --example 3964r_serial --features tokio -- /dev/ttyUSB0 "hello PLC"
//! ```
//!
//! The port is opened as two plain files bridged to the link by two threads, so this example
//! needs nothing beyond tokio; set its speed and format with `stty` first. The `si` command line
//! (`si --port /dev/ttyUSB0 3964r send …`) opens and configures ports itself.

/// Bridge a tty to an in-memory pipe with two plain threads (blocking reads and writes), so
/// this example needs nothing beyond tokio's core; the link runs on the other end of the pipe.
#[cfg(feature = "tokio")]
fn bridge(path: &str) -> std::io::Result<tokio::io::DuplexStream> {
    use std::io::{Read, Write};
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    let mut tty_in = std::fs::File::open(path)?;
    let mut tty_out = std::fs::OpenOptions::new().write(true).open(path)?;
    let (link_end, bridge_end) = tokio::io::duplex(4096);
    let (mut from_link, mut to_link) = tokio::io::split(bridge_end);
    let rt = tokio::runtime::Handle::current();
    let rt2 = rt.clone();
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while let Ok(n) = tty_in.read(&mut buf) {
            if n == 0 || rt.block_on(to_link.write_all(&buf[..n])).is_err() {
                break;
            }
        }
    });
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while let Ok(n) = rt2.block_on(from_link.read(&mut buf)) {
            if n == 0 || tty_out.write_all(&buf[..n]).is_err() {
                break;
            }
        }
    });
    Ok(link_end)
}

#[cfg(feature = "tokio")]
#[tokio::main(flavor = "multi_thread", worker_threads = 1)]
async fn main() {
    use si_serial::core::SerialSettings;
    use si_serial::r3964::tokio::Link3964r;
    use si_serial::r3964::Config;

    let mut args = std::env::args().skip(1);
    let (Some(path), Some(text)) = (args.next(), args.next()) else {
        eprintln!("usage: 3964r_serial PORT TEXT");
        std::process::exit(2);
    };
    let port = match bridge(&path) {
        Ok(port) => port,
        Err(e) => {
            eprintln!("cannot open {path}: {e}");
            std::process::exit(1);
        }
    };
    // Must match the stty settings; used for the engine's own transmit times.
    let line = SerialSettings::default();
    let mut link = Link3964r::spawn(Config::default(), line, port).expect("valid config");
    match link.send(text.into_bytes()).await {
        Ok(()) => println!("sent, the partner acknowledged with DLE"),
        Err(status) => {
            eprintln!("send failed: {status}");
            std::process::exit(1);
        }
    }
    println!("waiting for a block from the partner (Ctrl-C to stop)…");
    if let Some(block) = link.recv().await {
        println!("received {:?}", String::from_utf8_lossy(&block));
    }
    // The bridge thread's blocking read would keep the process alive: leave directly.
    std::process::exit(0);
}

#[cfg(not(feature = "tokio"))]
fn main() {
    eprintln!("build with --features tokio");
}
