//! How a line's port is opened: a serial port with the line's character format and RS-485
//! options, or a serial device server (`tcp:HOST:PORT`), then handed to the program's tap
//! (a trace recorder, a frame log) if it gave one.
//!
//! It reads the checked [`Line`]; a program may bring its own transports ([`Connect`]).

use crate::backend::BoxFuture;
use crate::config::{Device, Line};
use crate::port_config::Port;
use crate::Error;
use si_core::driver::{PortFacts, Transport, WithFacts};
use si_core::port::{self, PortOptions, Rs485Mode};
use si_core::{Parity, SerialSettings};
use std::sync::Arc;

/// What a program may do with each port the gateway opens before a line's engine gets it:
/// called with the line's protocol name (`modbus`, `uss`, `rk512`, `3964r`) and settings,
/// it returns the transport the engine is to use (the same one, or one wrapped in a
/// recording or logging tap). An error is the line's port failing to open.
pub type Tap = Arc<
    dyn Fn(&'static str, &SerialSettings, Box<dyn Transport>) -> Result<Box<dyn Transport>, Error>
        + Send
        + Sync,
>;

/// A program's own way to reach a line's device, instead of a serial port or device server:
/// called with the line and its checked settings, it returns the line's transport (an
/// in-memory pipe in a test, a transport the program made). The tap still applies.
pub type Connect = Arc<
    dyn Fn(&Line, &SerialSettings) -> BoxFuture<'static, Result<Box<dyn Transport>, Error>>
        + Send
        + Sync,
>;

/// The options of opening that are the program's, not a line's.
#[derive(Clone, Default)]
pub struct Opening {
    /// The program's way to reach every line's device, if not the ports and device servers
    /// the lines name.
    pub connect: Option<Connect>,
    /// Do not put serial ports in line-error mode (Linux PARMRK): parity, framing and BREAK
    /// are then not reported.
    pub no_line_errors: bool,
    /// The program's tap on each port, if any.
    pub tap: Option<Tap>,
}

impl std::fmt::Debug for Opening {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Opening")
            .field("no_line_errors", &self.no_line_errors)
            .field("connect", &self.connect.is_some())
            .field("tap", &self.tap.is_some())
            .finish()
    }
}

/// Line `l`'s character format, with a baud rate from `rates` (a protocol's own list: USS adds
/// 187 500 bit/s); a value outside is a configuration error.
pub fn settings(l: &Line, rates: &'static [u32]) -> Result<SerialSettings, Error> {
    let l = port(l)?;
    let parity: Parity = l
        .parity
        .parse()
        .map_err(|e: si_core::SettingsError| Error::Config(e.to_string()))?;
    SerialSettings::with_rates(l.baud, l.data_bits, parity, l.stop_bits, rates)
        .map_err(|e| Error::Config(e.to_string()))
}

/// Open line `l`'s port or connect to its device server with `settings` (already checked),
/// then hand it to the program's tap for `protocol`.
pub async fn open(
    l: &Line,
    settings: &SerialSettings,
    protocol: &'static str,
    opening: &Opening,
) -> Result<Box<dyn Transport>, Error> {
    if let Some(connect) = &opening.connect {
        let transport = connect(l, settings).await?;
        return match &opening.tap {
            Some(tap) => tap(protocol, settings, transport),
            None => Ok(transport),
        };
    }
    let l = port(l)?;
    let transport: Box<dyn Transport> = match &l.device {
        Device::Port(path) => Box::new(
            port::open(path, settings, &port_options(l, opening)?)
                .map_err(|e| Error::Port(e.to_string()))?,
        ),
        Device::Tcp(addr) => {
            let stream = port::device_server(addr)
                .await
                .map_err(|e| Error::Port(e.to_string()))?;
            Box::new(WithFacts {
                inner: stream,
                facts: PortFacts {
                    local_echo: l.local_echo,
                    rx_latency: l.rx_latency,
                    ..PortFacts::default()
                },
            })
        }
    };
    match &opening.tap {
        Some(tap) => tap(protocol, settings, transport),
        None => Ok(transport),
    }
}

/// Line `l`'s port (every line the gateway opens has one).
fn port(l: &Line) -> Result<&Port, Error> {
    l.port.as_ref().ok_or_else(|| {
        Error::Config(format!(
            "line {}: no port (a line of the program's own kind)",
            l.name
        ))
    })
}

/// The serial port options of port `l` (its RS-485 mode and names checked with the file).
fn port_options(l: &Port, opening: &Opening) -> Result<PortOptions, Error> {
    let (before, after) = l.rs485_delays;
    let rs485 = match l.rs485.as_deref() {
        None => None,
        Some(name) => {
            let mode: Rs485Mode = name.parse().map_err(|e| Error::Config(format!("{e}")))?;
            Some(
                mode.control(l.rs485_file.clone(), before, after)
                    .map_err(|e| Error::Config(e.to_string()))?,
            )
        }
    };
    Ok(PortOptions {
        latency_timer: l.latency_timer,
        rx_latency: l.rx_latency,
        rs485,
        local_echo: l.local_echo,
        no_line_errors: opening.no_line_errors,
    })
}
