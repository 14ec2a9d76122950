//! Where the bytes go: `--port PATH` or `--tcp HOST:PORT`, with the serial settings.

use crate::CliError;
use clap::Args;
use si_core::driver::Transport;
use si_core::{Parity, SerialSettings};

/// Options every command that talks to a line shares.
#[derive(Debug, Clone, Args)]
pub struct Connection {
    /// Serial port, e.g. /dev/ttyUSB0 or COM3.
    #[arg(long, global = true, conflicts_with = "tcp", env = "SI_PORT")]
    pub port: Option<String>,
    /// TCP serial device server, e.g. 192.0.2.10:4001 (raw TCP mode).
    #[arg(long, global = true, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
    /// Baud rate: 110, 300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 76800, 115200.
    #[arg(long, global = true, default_value_t = 9600)]
    pub baud: u32,
    /// Data bits: 7 or 8.
    #[arg(long, global = true, default_value_t = 8)]
    pub data_bits: u8,
    /// Parity: none, even, odd, mark, space (the manuals' "any" is space).
    #[arg(long, global = true, default_value = "even")]
    pub parity: String,
    /// Stop bits: 1 or 2.
    #[arg(long, global = true, default_value_t = 1)]
    pub stop_bits: u8,
}

impl Connection {
    /// The validated character format, with one of the manuals' twelve baud rates.
    pub fn settings(&self) -> Result<SerialSettings, CliError> {
        self.settings_for(&si_core::BAUD_RATES)
    }

    /// The validated character format, with a baud rate from a protocol's own list (USS adds
    /// 187 500 bit/s).
    pub fn settings_for(&self, rates: &'static [u32]) -> Result<SerialSettings, CliError> {
        let parity: Parity = self.parity.parse()?;
        Ok(SerialSettings::with_rates(
            self.baud,
            self.data_bits,
            parity,
            self.stop_bits,
            rates,
        )?)
    }

    /// Open the port or connect to the device server, with [`settings`](Self::settings).
    pub async fn open(&self) -> Result<Box<dyn Transport>, CliError> {
        self.open_with(&self.settings()?).await
    }

    /// Open the port or connect to the device server with these (already validated) settings.
    pub async fn open_with(
        &self,
        settings: &SerialSettings,
    ) -> Result<Box<dyn Transport>, CliError> {
        match (&self.port, &self.tcp) {
            (Some(path), _) => {
                let port = open_serial(path, settings)?;
                Ok(Box::new(port))
            }
            (None, Some(addr)) => {
                let stream = tokio::net::TcpStream::connect(addr)
                    .await
                    .map_err(|e| CliError::new(format!("cannot connect to {addr}: {e}")))?;
                stream.set_nodelay(true).ok();
                Ok(Box::new(stream))
            }
            (None, None) => Err(CliError::new(
                "no line given: use --port PATH or --tcp HOST:PORT",
            )),
        }
    }
}

fn open_serial(path: &str, s: &SerialSettings) -> Result<tokio_serial::SerialStream, CliError> {
    use tokio_serial::{DataBits, FlowControl, SerialPortBuilderExt, StopBits};
    let parity = match s.parity() {
        Parity::None => tokio_serial::Parity::None,
        Parity::Even => tokio_serial::Parity::Even,
        Parity::Odd => tokio_serial::Parity::Odd,
        Parity::Mark | Parity::Space => {
            return Err(CliError::new(format!(
                "parity {} is not supported by the portable serial API; use none, even or odd",
                s.parity()
            )))
        }
    };
    tokio_serial::new(path, s.baud())
        .data_bits(if s.data_bits() == 7 {
            DataBits::Seven
        } else {
            DataBits::Eight
        })
        .parity(parity)
        .stop_bits(if s.stop_bits() == 2 {
            StopBits::Two
        } else {
            StopBits::One
        })
        .flow_control(FlowControl::None)
        .open_native_async()
        .map_err(|e| CliError::new(format!("cannot open {path}: {e}")))
}
