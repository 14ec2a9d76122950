//! Shared by the `_serial` examples: the line their first argument names, a serial port
//! (`/dev/ttyUSB0`, `COM3`) opened with `si_core::port::open`, or a serial device server in raw
//! TCP mode (`192.0.2.10:4001`).
//!
//! Each example is its own crate and uses only part of this.
#![allow(dead_code)]

use si_serial::core::driver::Transport;
use si_serial::core::port::{self, PortOptions};
use si_serial::core::SerialSettings;

/// The opened line.
pub struct Line {
    /// The port or the TCP stream.
    pub transport: Box<dyn Transport>,
    /// It is a device server on the network: engines should allow for its packing latency.
    pub network: bool,
}

/// Open `target` with the line format `settings` (a device server is set up on its own web
/// page; the format must match there).
pub async fn open(
    target: &str,
    settings: &SerialSettings,
    options: &PortOptions,
) -> std::io::Result<Line> {
    let is_tcp = !target.starts_with('/')
        && target
            .rsplit_once(':')
            .is_some_and(|(_, port)| port.parse::<u16>().is_ok());
    if is_tcp {
        let stream = tokio::net::TcpStream::connect(target).await?;
        stream.set_nodelay(true)?;
        return Ok(Line {
            transport: Box::new(stream),
            network: true,
        });
    }
    Ok(Line {
        transport: Box::new(port::open(target, settings, options)?),
        network: false,
    })
}
