//! Read CR LF-terminated lines from a serial device server (raw TCP) with the ASCII driver and
//! answer each with "OK\r\n" (et200s-si-3964r-ascii.md §6.3, two end-of-text characters).
//!
//! `cargo run --example ascii_tcp --features tokio -- 192.0.2.10:4001`

#[cfg(feature = "tokio")]
#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    use si_serial::ascii::tokio::{AsciiHandle, Incoming};
    use si_serial::ascii::{Config, EndCriterion};

    let addr = std::env::args()
        .nth(1)
        .ok_or("usage: ascii_tcp HOST:PORT")?;
    let stream = tokio::net::TcpStream::connect(&addr).await?;
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        // A device server adds latency between characters: be generous.
        char_delay_ms: 200,
        ..Config::default()
    };
    let mut port = AsciiHandle::spawn(config, stream)?;
    loop {
        match port.next().await? {
            Incoming::Frame { data, at } => {
                println!("{at}: {:?}", String::from_utf8_lossy(&data));
                port.send(&b"OK\r\n"[..]).await?;
            }
            Incoming::Error { status, at } => eprintln!("{at}: receive error {status}"),
        }
    }
}

#[cfg(not(feature = "tokio"))]
fn main() {
    eprintln!("this example needs the async driver: cargo run --example ascii_tcp --features tokio -- HOST:PORT");
}
