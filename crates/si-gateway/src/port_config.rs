//! The keys every `[[line]]` has, whatever its kind: its name, unit ids, listening address and
//! port (a serial port's path and character format, RS-485 direction control, or a serial
//! device server as `tcp:HOST:PORT`); each kind's file form is declared with them
//! (the crate's `line_file!` macro) and adds its own keys.
//!
//! A leaf module: the kinds' configurations import it, it imports none of them.

use si_core::port::Rs485Mode;
use si_core::Duration;
use si_core::RangeError;
use std::path::PathBuf;

/// Default request queue length per line.
pub const DEFAULT_QUEUE: usize = 32;
/// The longest request queue per line: bounded memory whatever the file says.
pub const MAX_QUEUE: usize = 1024;
/// The longest pause between a line's requests (ms): mbusd's maximum.
pub const MAX_PAUSE_MS: u64 = 10_000;

/// A queued line's `queue` (1 … [`MAX_QUEUE`], default [`DEFAULT_QUEUE`]), checked.
pub fn check_queue(queue: Option<usize>) -> Result<usize, RangeError> {
    let queue = queue.unwrap_or(DEFAULT_QUEUE);
    RangeError::check("queue", (1, MAX_QUEUE), "", queue)?;
    Ok(queue)
}

/// A queued line's `pause_ms` (0 … [`MAX_PAUSE_MS`], the kind's `default_ms` when absent),
/// checked.
pub fn check_pause(
    pause_ms: Option<u64>,
    default_ms: u64,
) -> Result<std::time::Duration, RangeError> {
    let pause_ms = pause_ms.unwrap_or(default_ms);
    RangeError::check("pause_ms", (0, MAX_PAUSE_MS), " ms", pause_ms)?;
    Ok(std::time::Duration::from_millis(pause_ms))
}

/// The response timeouts a Modbus line (RTU or TCP) accepts, in ms: the module's "Response
/// Time", [Modbus/USS] §3.4.3, Table 3-17 (the range `si_modbus::MasterConfig::validate`
/// checks).
pub const RESPONSE_TIMEOUT_MS: (u32, u32) = (50, 655_000);
/// The most retries of a Modbus line (RTU or TCP): mbusd's (`MAX_MAXTRY` 15).
pub const MAX_RETRIES: u8 = 15;

/// A Modbus line's `retries` (0 … [`MAX_RETRIES`]) and `response_timeout_ms`
/// ([`RESPONSE_TIMEOUT_MS`]), each with the kind's default when absent, checked: one check
/// for every Modbus line kind.
pub fn check_exchange(
    retries: Option<u8>,
    default_retries: u8,
    response_timeout_ms: Option<u32>,
    default_timeout_ms: u32,
) -> Result<(u8, Duration), RangeError> {
    let retries = retries.unwrap_or(default_retries);
    RangeError::check("retries", (0, MAX_RETRIES), "", retries)?;
    let timeout = response_timeout_ms.unwrap_or(default_timeout_ms);
    RangeError::check("response_timeout_ms", RESPONSE_TIMEOUT_MS, " ms", timeout)?;
    Ok((retries, Duration::from_millis(timeout.into())))
}

/// Declares a line kind's file form: a struct refusing unknown keys, with the keys every line
/// has (`kind`, `name`, `device`, `baud`, `data_bits`, `parity`, `stop_bits`, `rs485`,
/// `rs485_file`, `rs485_delay_before_ms`, `rs485_delay_after_ms`, `local_echo`,
/// `latency_timer_ms`, `rx_latency_ms`, `units`, `listen`), then the kind's own, and
/// `common()` to read the shared ones.
macro_rules! line_file {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $( $(#[$fmeta:meta])* pub $field:ident : $ty:ty, )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Default, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            /// The line's `kind` as written: the tag that chose this form (read by the file's
            /// reader; absent where the enum's tag took it, or for the default `modbus-rtu`).
            #[serde(default)]
            pub kind: Option<String>,
            /// A name for status lines and errors (default `line<N>`).
            pub name: Option<String>,
            /// Serial port path, or `tcp:HOST:PORT` for a serial device server.
            pub device: Option<String>,
            /// Baud rate (default 9600).
            pub baud: Option<u32>,
            /// Data bits (default 8).
            pub data_bits: Option<u8>,
            /// none, even, odd, mark, space (default even).
            pub parity: Option<String>,
            /// Stop bits (default 1).
            pub stop_bits: Option<u8>,
            /// RS-485 direction control: `kernel`, `rts`, `rts-inverted`, `sysfs`,
            /// `sysfs-inverted` (the `--rs485` names).
            pub rs485: Option<String>,
            /// The file `sysfs`/`sysfs-inverted` write '1'/'0' to (e.g. a GPIO's `value`).
            pub rs485_file: Option<std::path::PathBuf>,
            /// RTS on this long before the first bit (ms).
            pub rs485_delay_before_ms: Option<u64>,
            /// RTS kept on this long after the last bit (ms).
            pub rs485_delay_after_ms: Option<u64>,
            /// The port hears its own transmission.
            #[serde(default)]
            pub local_echo: bool,
            /// USB adapter latency timer (ms).
            pub latency_timer_ms: Option<u64>,
            /// The port's delivery latency declared to the engine (ms, 0–255; `--rx-latency`).
            pub rx_latency_ms: Option<u64>,
            /// Unit ids served by this line: `"1-10,12"`.
            pub units: Option<String>,
            /// A listening address of its own (`[[line]]`s naming the same address share it):
            /// this line's units are reached there and not on the top-level `listen`, and need
            /// to be unique only among the lines on that address ([`crate::faces`]).
            pub listen: Option<String>,
            $( $(#[$fmeta])* pub $field: $ty, )*
        }

        impl $name {
            /// The keys every line has.
            pub fn common(&self) -> $crate::port_config::Common<'_> {
                $crate::port_config::Common {
                    name: self.name.as_deref(),
                    device: self.device.as_deref(),
                    baud: self.baud,
                    data_bits: self.data_bits,
                    parity: self.parity.as_deref(),
                    stop_bits: self.stop_bits,
                    rs485: self.rs485.as_deref(),
                    rs485_file: self.rs485_file.as_ref(),
                    rs485_delay_before_ms: self.rs485_delay_before_ms,
                    rs485_delay_after_ms: self.rs485_delay_after_ms,
                    local_echo: self.local_echo,
                    latency_timer_ms: self.latency_timer_ms,
                    rx_latency_ms: self.rx_latency_ms,
                    units: self.units.as_deref(),
                    listen: self.listen.as_deref(),
                }
            }
        }
    };
}
pub(crate) use line_file;

/// The keys every line has, as written (a `modbus-tcp` line has only `name`, `units` and
/// `listen` of them).
#[derive(Debug, Clone, Copy, Default)]
pub struct Common<'a> {
    /// `name`.
    pub name: Option<&'a str>,
    /// `device`.
    pub device: Option<&'a str>,
    /// `baud`.
    pub baud: Option<u32>,
    /// `data_bits`.
    pub data_bits: Option<u8>,
    /// `parity`.
    pub parity: Option<&'a str>,
    /// `stop_bits`.
    pub stop_bits: Option<u8>,
    /// `rs485`.
    pub rs485: Option<&'a str>,
    /// `rs485_file`.
    pub rs485_file: Option<&'a PathBuf>,
    /// `rs485_delay_before_ms`.
    pub rs485_delay_before_ms: Option<u64>,
    /// `rs485_delay_after_ms`.
    pub rs485_delay_after_ms: Option<u64>,
    /// `local_echo`.
    pub local_echo: bool,
    /// `latency_timer_ms`.
    pub latency_timer_ms: Option<u64>,
    /// `rx_latency_ms`.
    pub rx_latency_ms: Option<u64>,
    /// `units`.
    pub units: Option<&'a str>,
    /// `listen`.
    pub listen: Option<&'a str>,
}

/// Where a line's bytes go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Device {
    /// A serial port.
    Port(String),
    /// A serial device server in raw TCP mode.
    Tcp(String),
}

impl Device {
    /// `tcp:HOST:PORT` or a port path.
    pub fn parse(text: &str) -> Device {
        match text.strip_prefix("tcp:") {
            Some(addr) => Device::Tcp(addr.to_string()),
            None => Device::Port(text.to_string()),
        }
    }
}

/// A line's checked port: where its bytes go and how.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Port {
    /// Port path, or the device server's `HOST:PORT` in `tcp`.
    pub device: Device,
    /// Baud rate (checked by the line's kind, whose protocol has its own list).
    pub baud: u32,
    /// Data bits.
    pub data_bits: u8,
    /// Parity name.
    pub parity: String,
    /// Stop bits.
    pub stop_bits: u8,
    /// RS-485 mode name (`kernel`, `rts`, …: the `--rs485` names, checked).
    pub rs485: Option<String>,
    /// The file a sysfs RS-485 mode writes.
    pub rs485_file: Option<PathBuf>,
    /// RS-485 delays before and after.
    pub rs485_delays: (Duration, Duration),
    /// The port hears its own transmission.
    pub local_echo: bool,
    /// USB latency timer.
    pub latency_timer: Option<Duration>,
    /// The port's delivery latency declared to the engine.
    pub rx_latency: Option<Duration>,
}

impl Common<'_> {
    /// The checked port, defaults filled in; the baud rate is left to the kind.
    pub fn port(&self) -> Result<Port, RangeError> {
        let device = self
            .device
            .map(Device::parse)
            .ok_or_else(|| RangeError::new("device", "a port path or tcp:HOST:PORT", "", "none"))?;
        if let Some(ms) = self.rx_latency_ms.filter(|&ms| ms > 255) {
            return Err(RangeError::new("rx_latency_ms", "0 … 255 ms", " ms", ms));
        }
        self.check_rs485()?;
        Ok(Port {
            device,
            baud: self.baud.unwrap_or(9600),
            data_bits: self.data_bits.unwrap_or(8),
            parity: self.parity.unwrap_or("even").to_string(),
            stop_bits: self.stop_bits.unwrap_or(1),
            rs485: self.rs485.map(str::to_owned),
            rs485_file: self.rs485_file.cloned(),
            rs485_delays: (
                Duration::from_millis(self.rs485_delay_before_ms.unwrap_or(0)),
                Duration::from_millis(self.rs485_delay_after_ms.unwrap_or(0)),
            ),
            local_echo: self.local_echo,
            latency_timer: self.latency_timer_ms.map(Duration::from_millis),
            rx_latency: self.rx_latency_ms.map(Duration::from_millis),
        })
    }

    /// The RS-485 mode, if given, is one we know (the `--rs485` names), and `rs485_file` is
    /// given exactly when the mode writes a file.
    fn check_rs485(&self) -> Result<(), RangeError> {
        // A device server switches its own line: these are serial port options (refused by
        // the port too, but here as a configuration error, never a line down for ever).
        if self.device.is_some_and(|d| d.starts_with("tcp:")) {
            let given = [
                ("rs485", self.rs485.is_some()),
                ("latency_timer_ms", self.latency_timer_ms.is_some()),
            ];
            if let Some((key, _)) = given.iter().find(|(_, g)| *g) {
                return Err(RangeError::new(
                    key,
                    "a serial port's key (a device server switches its own line)",
                    "",
                    "set on a tcp: device",
                ));
            }
        }
        let mode = match self.rs485 {
            Some(name) => Some(name.parse::<Rs485Mode>().map_err(|_| {
                RangeError::new("rs485", Rs485Mode::NAMES, "", format!("{name:?}"))
            })?),
            None => None,
        };
        let wants_file = mode.is_some_and(Rs485Mode::needs_file);
        match &self.rs485_file {
            None if wants_file => Err(RangeError::new(
                "rs485_file",
                "a file path, needed with rs485 = \"sysfs\" or \"sysfs-inverted\"",
                "",
                "missing",
            )),
            Some(file) if !wants_file => Err(RangeError::new(
                "rs485_file",
                "only with rs485 = \"sysfs\" or \"sysfs-inverted\"",
                "",
                format!("{:?}", file.display().to_string()),
            )),
            _ => Ok(()),
        }
    }
}

/// The baud rate `baud` is one of `rates` (the protocol's list).
pub fn check_baud(baud: u32, rates: &[u32]) -> Result<(), RangeError> {
    if rates.contains(&baud) {
        Ok(())
    } else {
        Err(RangeError::new(
            "baud",
            format!("{rates:?}"),
            " bit/s",
            baud,
        ))
    }
}

/// `"1-10,12"` → the unit ids 1–10 and 12 (each 1–255; unit 0 is the broadcast, see
/// `broadcast`). At least one unit, or the line would serve nothing.
pub fn parse_units(text: &str) -> Result<Vec<u8>, RangeError> {
    const RANGE: &str = "unit ids 1 … 255 as a list of N or N-M, e.g. 1-10,12";
    si_core::address_list::parse(text, 1, 255)
        .ok_or_else(|| RangeError::new("units", RANGE, "", format!("{text:?}")))
}

/// A line's `unit_map` (`{ 11 = 1 }`: TCP unit id → the slave's unit id or address),
/// checked: TCP unit ids 1–255, slave addresses 1–247 ([Modbus serial] §2.2: 0 is the
/// broadcast, 248–255 reserved).
pub fn parse_unit_map(
    map: Option<&std::collections::BTreeMap<String, u8>>,
) -> Result<Vec<(u8, u8)>, RangeError> {
    let Some(map) = map else {
        return Ok(Vec::new());
    };
    map.iter()
        .map(|(unit, &address)| {
            let unit = unit
                .trim()
                .parse::<u8>()
                .ok()
                .filter(|&u| u >= 1)
                .ok_or_else(|| {
                    RangeError::new("unit_map", "TCP unit ids 1 … 255", "", format!("{unit:?}"))
                })?;
            RangeError::check("unit_map", (1, 247), " (slave address)", address)?;
            Ok((unit, address))
        })
        .collect()
}
