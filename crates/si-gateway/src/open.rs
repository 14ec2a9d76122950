//! How a line's port is opened: a serial port with the line's character format and RS-485
//! options, or a serial device server (`tcp:HOST:PORT`), then handed to the program's tap
//! (a trace recorder, a frame log) if it gave one.
//!
//! A leaf module of the opening: it reads the checked [`Line`] and imports nothing else of the
//! crate but the error type.

use crate::config::{Device, Line};
use crate::Error;
use si_core::driver::{PortFacts, Transport, WithFacts};
use si_core::port::{self, PortOptions, Rs485Mode};
use si_core::{Duration, Parity, SerialSettings};
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

/// The options of opening that are the program's, not a line's.
#[derive(Clone, Default)]
pub struct Opening {
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
            .field("tap", &self.tap.is_some())
            .finish()
    }
}

/// Line `l`'s character format, with a baud rate from `rates` (a protocol's own list: USS adds
/// 187 500 bit/s); a value outside is a configuration error.
pub fn settings(l: &Line, rates: &'static [u32]) -> Result<SerialSettings, Error> {
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
                    rx_latency: l.rx_latency_ms.map(Duration::from_millis),
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

/// The serial port options of line `l` (its RS-485 mode and names checked with the file).
fn port_options(l: &Line, opening: &Opening) -> Result<PortOptions, Error> {
    let (before, after) = l.rs485_delays_ms;
    let rs485 = match l.rs485.as_deref() {
        None => None,
        Some(name) => {
            let mode: Rs485Mode = name.parse().map_err(|e| Error::Config(format!("{e}")))?;
            Some(
                mode.control(
                    l.rs485_file.clone(),
                    Duration::from_millis(before),
                    Duration::from_millis(after),
                )
                .map_err(|e| Error::Config(e.to_string()))?,
            )
        }
    };
    Ok(PortOptions {
        latency_timer: l.latency_timer_ms.map(Duration::from_millis),
        rx_latency: l.rx_latency_ms.map(Duration::from_millis),
        rs485,
        local_echo: l.local_echo,
        no_line_errors: opening.no_line_errors,
    })
}
