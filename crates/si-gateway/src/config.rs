//! The gateway's configuration: a TOML file (`--config`) or the flags of the common case (one
//! line), checked into [`Gateway`] with every value in range.
//!
//! Ranges and defaults: the response timeout is the module's "Response Time", 50–655 000 ms
//! ([Modbus/USS] §3.4.3, Table 3-17, the range `si_modbus::MasterConfig::validate` checks);
//! retries, the pause between requests, the connection limit and the idle timeout have no
//! module counterpart (the module has no retries, [Modbus/USS] §3.4.3, Table 3-17) and follow
//! mbusd, the gateway si is measured against (mbusd's `src/conn.h`: `DEFAULT_MAXTRY` 3 tries = 2
//! retries, `MAX_MAXTRY` 15, `DEFAULT_RQSTPAUSE` 100 ms, `MAX_RQSTPAUSE` 10 000 ms,
//! `DEFAULT_RESPWAIT` 500 ms, `DEFAULT_MAXCONN` 32, `MAX_CONNTIMEOUT` 1000 s). mbusd's pause is
//! 1–10 000 ms; we also allow 0 (no pause).

use serde::Deserialize;
use si_core::port::Rs485Mode;
use si_core::RangeError;
use std::fmt;

/// The line kinds a `[[line]]` may be: Modbus RTU slaves, USS drives ([`super::uss_config`]),
/// an RK 512 partner ([`super::rk512_config`]) or a plain 3964(R) partner
/// ([`super::r3964_config`]).
pub const LINE_KINDS: &str = "modbus-rtu, uss, rk512 or 3964r";

/// Default request queue length per line.
pub const DEFAULT_QUEUE: usize = 32;
/// The longest request queue per line: bounded memory whatever the file says.
pub const MAX_QUEUE: usize = 1024;
/// The most connections a gateway accepts (a host limit; mbusd's `MAX_MAXCONN` is 128).
pub const MAX_CONNECTIONS: usize = 1024;

/// The whole file, as written (before checking).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct File {
    /// TCP address listened on, e.g. `127.0.0.1:5020`.
    pub listen: Option<String>,
    /// Connections served at once.
    pub max_connections: Option<usize>,
    /// A connection silent this long is closed (0–1000 s, 0: never; default 60).
    pub idle_timeout_s: Option<u64>,
    /// The unit id that answers the gateway's counters as input registers.
    pub diagnostic_unit: Option<u8>,
    /// Answer a broadcast request with its echo once sent (mbusd's `-b`); default: no answer.
    #[serde(default)]
    pub reply_on_broadcast: bool,
    /// A line whose device cannot be opened at start starts down and is reopened like a line
    /// whose port closed ([`super::reopen`]), instead of stopping the gateway (the default,
    /// so that a wrong path is reported at once).
    #[serde(default)]
    pub allow_down_at_start: bool,
    /// Serve Prometheus metrics over HTTP at `GET /metrics` on this address (default: none;
    /// `super::metrics_http`).
    pub metrics_listen: Option<String>,
    /// Accept raw RTU frames (address, PDU, CRC) over TCP on this address, routed like the
    /// top-level `listen`'s Modbus TCP requests (default: none; `super::rtu_listener`).
    pub rtu_over_tcp_listen: Option<String>,
    /// The serial lines.
    #[serde(default, rename = "line")]
    pub lines: Vec<LineFile>,
}

/// One `[[line]]`, as written.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineFile {
    /// `modbus-rtu` (the default); see [`LINE_KINDS`].
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
    /// Retries after a timeout or a corrupt answer.
    pub retries: Option<u8>,
    /// Pause between the end of one request and the next (ms).
    pub pause_ms: Option<u64>,
    /// Response timeout (ms).
    pub response_timeout_ms: Option<u32>,
    /// Forward broadcasts (unit 0) to this line.
    #[serde(default)]
    pub broadcast: bool,
    /// Requests waiting for this line at most; one more is refused with exception 06.
    pub queue: Option<usize>,
    /// `modbus-rtu`: the character delay multiplier 1–10, end-of-frame gap = table value × it
    /// ([Modbus/USS] §3.3.5, Table 3-11; default 1).
    pub char_delay_multiplier: Option<u8>,
    /// `modbus-rtu`: `gap` (the module's: an answer ends after the end-of-frame gap, the
    /// default) or `length` (host extension: also at the length its header predicts, once its
    /// CRC checks).
    pub frame_end: Option<String>,
    /// `modbus-rtu`: the silence that ends a frame and precedes a request: `spec` (the Modbus
    /// specification's t3.5, 1.75 ms at 19200 bit/s and above, [Modbus serial] §2.5.1.1; the
    /// default) or `module` (the module's Table 3-11 gap × `char_delay_multiplier`,
    /// [Modbus/USS] §3.3.5; the default when `char_delay_multiplier` is given).
    pub frame_gap: Option<String>,
    /// `modbus-rtu`: after a slave did not answer, the next request waits until the line has
    /// been silent this long, 0–655000 ms (default: the line's response timeout; 0: off), and
    /// what arrives meanwhile is discarded and counted, so a late answer never reaches another
    /// request (si-modbus's quiet guard, bounded by this + the longest response).
    pub quiet_after_timeout_ms: Option<u32>,
    /// `modbus-rtu`: failed requests in a row that demote a unit, 0–255 (default 3; 0: never
    /// demoted; [`super::demotion`]).
    pub demote_after: Option<u32>,
    /// `modbus-rtu`: how long a demoted unit's requests are answered 0BH at once before one
    /// probes it, 1–3 600 000 ms (default 30 000).
    pub demote_for_ms: Option<u64>,
    /// A listening address of its own (`[[line]]`s naming the same address share it): this
    /// line's units are reached there and not on the top-level `listen`, and need to be
    /// unique only among the lines on that address ([`super::faces`]).
    pub listen: Option<String>,
    /// `uss`: the drives' bus addresses (0–31) in the order of `units`, e.g. `"0,5"`;
    /// default: each unit id is its drive's address.
    pub drives: Option<String>,
    /// `uss`: PZD words per drive (0–16, default 2: STW/HSW out, ZSW/HIW in).
    pub pzd_words: Option<u8>,
    /// `uss`: PKW words per drive (0, 3, 4 or 127 = variable; default 4).
    pub pkw_words: Option<u8>,
    /// `rk512`: `active` (default) or `passive` ([`super::rk512_config`] has every rk512 key).
    pub role: Option<String>,
    /// `rk512`, `3964r`: 3964(R) priority, `high` or `low`.
    pub priority: Option<String>,
    /// `rk512`, `3964r`: 3964R with block check (default), or plain 3964.
    pub block_check: Option<bool>,
    /// `rk512`, `3964r`: acknowledgement delay time QVZ (ms).
    pub ack_delay_ms: Option<u32>,
    /// `rk512`: the partner's CPU number 1–4 (header byte 10).
    pub cpu: Option<u8>,
    /// `rk512`: header byte 6 counts `words` (default) or `bytes`.
    pub dw_unit: Option<String>,
    /// `rk512`: S_MODB's conversion DB (`[line.conversion]`).
    pub conversion: Option<si_modbus::simatic::ConversionDb>,
    /// `rk512`: FETCH the `refresh` areas this often (ms; 0: on demand).
    pub refresh_ms: Option<u64>,
    /// `rk512`: the refresh image's areas, e.g. `["DB6:0-99", "MB500-531"]`.
    pub refresh: Option<Vec<String>>,
    /// `rk512`, passive: the gateway's own memory (`[line.memory]`).
    pub memory: Option<si_core::memory::MemorySizes>,
}

/// A checked gateway configuration.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Gateway {
    /// Listen address.
    pub listen: String,
    /// Connections served at once.
    pub max_connections: usize,
    /// Idle timeout (`None`: never).
    pub idle_timeout: Option<std::time::Duration>,
    /// The diagnostic unit, if any.
    pub diagnostic_unit: Option<u8>,
    /// Echo a broadcast once sent.
    pub reply_on_broadcast: bool,
    /// Lines that cannot be opened at start start down.
    pub allow_down_at_start: bool,
    /// The Prometheus metrics address, if any.
    pub metrics_listen: Option<String>,
    /// The RTU-over-TCP address, if any.
    pub rtu_over_tcp_listen: Option<String>,
    /// The lines, in file order.
    pub lines: Vec<Line>,
}

/// A checked Modbus RTU line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Line {
    /// Name.
    pub name: String,
    /// Port path, or the device server's `HOST:PORT` in `tcp`.
    pub device: Device,
    /// Baud rate.
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
    pub rs485_file: Option<std::path::PathBuf>,
    /// RS-485 delays before and after (ms).
    pub rs485_delays_ms: (u64, u64),
    /// The port hears its own transmission.
    pub local_echo: bool,
    /// USB latency timer (ms).
    pub latency_timer_ms: Option<u64>,
    /// The port's delivery latency declared to the engine (ms).
    pub rx_latency_ms: Option<u64>,
    /// Unit ids routed here (1–255).
    pub units: Vec<u8>,
    /// Retries.
    pub retries: u8,
    /// Pause between requests.
    pub pause: std::time::Duration,
    /// Response timeout (ms).
    pub response_timeout_ms: u32,
    /// Broadcasts forwarded.
    pub broadcast: bool,
    /// Queue length.
    pub queue: usize,
    /// Modbus RTU framing (defaults for other kinds, which do not use it).
    pub rtu: RtuFraming,
    /// Auto-demotion of units that stop answering (Modbus RTU lines only).
    pub demotion: super::demotion::DemotionConfig,
    /// What is on the line.
    pub kind: Kind,
    /// Its own listening address (`None`: the gateway's `listen`).
    pub listen: Option<String>,
}

/// How a Modbus RTU line's master recognises the end of an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtuFraming {
    /// fMUL 1–10 ([Modbus/USS] §3.3.5, Table 3-11).
    pub char_delay_multiplier: u8,
    /// At the gap, or also at the predicted length.
    pub frame_end: si_modbus::FrameEnd,
    /// The specification's t3.5 (`true`) or the module's gap.
    pub spec_gap: bool,
    /// Silence kept after a timeout before the next request, in ms (`None`: the line's
    /// response timeout).
    pub quiet_after_timeout_ms: Option<u32>,
}

impl Default for RtuFraming {
    fn default() -> Self {
        RtuFraming {
            char_delay_multiplier: 1,
            frame_end: si_modbus::FrameEnd::Gap,
            spec_gap: true,
            quiet_after_timeout_ms: None,
        }
    }
}

/// What a line's units are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Kind {
    /// Modbus RTU slaves: requests are forwarded.
    ModbusRtu,
    /// USS drives polled by a USS master: requests are served from their PZD and a parameter
    /// window ([`super::uss`]).
    Uss(super::uss_config::UssLine),
    /// An RK 512 partner: requests become FETCH and SEND jobs, or are served from the
    /// gateway's own memory in the passive role ([`super::rk512`]).
    Rk512(Box<super::rk512_config::Rk512Line>),
    /// A plain 3964(R) partner: the latest block received as input registers, a register
    /// write sends a block ([`super::r3964`]).
    R3964(si_3964r::Config),
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

/// A configuration error: which line (if any), which key, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// `line 2 (meters)`, or `None` for a top-level key.
    pub line: Option<String>,
    /// The key, its range and the value given.
    pub range: RangeError,
}

/// The longest line of a configuration error, in characters: a line's worth of text, enough
/// for the key, its range and the start of its value. `[derived]`: our choice.
pub const MAX_ERROR_LINE: usize = 300;

/// `text` with each line cut to [`MAX_ERROR_LINE`] characters, marked with `…`: a value of
/// any size gives an error of a line's worth.
pub fn cut(text: &str) -> String {
    text.lines()
        .map(|line| match line.char_indices().nth(MAX_ERROR_LINE) {
            Some((end, _)) => format!("{}…", &line[..end]),
            None => line.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.line {
            Some(line) => write!(f, "gateway config, {line}: {}", self.range),
            None => write!(f, "gateway config: {}", self.range),
        }
    }
}

impl std::error::Error for ConfigError {}

impl File {
    /// Parse TOML text (the tests' shortcut; `si gateway` reads its file through
    /// `si_core::config_file`, whose errors name the file, line and key).
    pub fn from_toml(text: &str) -> Result<File, String> {
        toml::from_str(text).map_err(|e| format!("gateway config: {e}"))
    }

    /// Check every value and fill in the defaults.
    pub fn check(&self) -> Result<Gateway, ConfigError> {
        let top = |range| ConfigError { line: None, range };
        let listen = self
            .listen
            .clone()
            .unwrap_or_else(|| "127.0.0.1:502".to_string());
        let max_connections = self
            .max_connections
            .unwrap_or(si_modbus::tokio::tcp::DEFAULT_MAX_CONNECTIONS);
        RangeError::check("max_connections", (1, MAX_CONNECTIONS), "", max_connections)
            .map_err(top)?;
        let idle_timeout = match self.idle_timeout_s {
            Some(0) => None,
            Some(s) => {
                RangeError::check("idle_timeout_s", (0, 1000), " s", s).map_err(top)?;
                Some(std::time::Duration::from_secs(s))
            }
            None => Some(si_modbus::tokio::tcp::DEFAULT_IDLE_TIMEOUT),
        };
        if let Some(u) = self.diagnostic_unit {
            RangeError::check("diagnostic_unit", (1, 255), "", u).map_err(top)?;
        }
        if self.lines.is_empty() {
            return Err(top(RangeError::new(
                "line",
                "at least one [[line]]",
                "",
                "none",
            )));
        }
        let mut lines: Vec<Line> = Vec::with_capacity(self.lines.len());
        // The line owning each unit id, per listening address (`None`: the top-level one).
        let mut owners: std::collections::HashMap<Option<String>, [Option<usize>; 256]> =
            std::collections::HashMap::new();
        for (i, l) in self.lines.iter().enumerate() {
            let name = l.name.clone().unwrap_or_else(|| format!("line{}", i + 1));
            let at = format!("line {} ({name})", i + 1);
            let err = |range| ConfigError {
                line: Some(at.clone()),
                range,
            };
            let mut line = l.check(name.clone()).map_err(err)?;
            if line.listen.as_ref() == Some(&listen) {
                line.listen = None;
            }
            let owner = owners.entry(line.listen.clone()).or_insert([None; 256]);
            for &u in &line.units {
                if let Some(other) = owner[u as usize] {
                    return Err(err(RangeError::new(
                        "units",
                        format!("unit ids not served by {}", lines[other].name),
                        "",
                        u,
                    )));
                }
                if Some(u) == self.diagnostic_unit {
                    return Err(err(RangeError::new(
                        "units",
                        "unit ids other than diagnostic_unit",
                        "",
                        u,
                    )));
                }
                owner[u as usize] = Some(i);
            }
            if lines.iter().any(|other| other.name == line.name) {
                return Err(err(RangeError::new(
                    "name",
                    "a name no other [[line]] has",
                    "",
                    format!("{:?}", line.name),
                )));
            }
            lines.push(line);
        }
        Ok(Gateway {
            listen,
            max_connections,
            idle_timeout,
            diagnostic_unit: self.diagnostic_unit,
            reply_on_broadcast: self.reply_on_broadcast,
            allow_down_at_start: self.allow_down_at_start,
            metrics_listen: self.metrics_listen.clone(),
            rtu_over_tcp_listen: self.rtu_over_tcp_listen.clone(),
            lines,
        })
    }
}

impl LineFile {
    /// Check one line (the caller names it in the error).
    fn check(&self, name: String) -> Result<Line, RangeError> {
        let kind = self.kind.as_deref().unwrap_or("modbus-rtu");
        if !matches!(kind, "modbus-rtu" | "uss" | "rk512" | "3964r") {
            return Err(RangeError::new("kind", LINE_KINDS, "", kind));
        }
        if kind != "modbus-rtu" {
            refuse_keys(
                &[
                    ("demote_after", self.demote_after.is_some()),
                    ("demote_for_ms", self.demote_for_ms.is_some()),
                ],
                "a key of modbus-rtu lines",
                format!("set on a {kind} line"),
            )?;
        }
        let device =
            self.device.as_deref().map(Device::parse).ok_or_else(|| {
                RangeError::new("device", "a port path or tcp:HOST:PORT", "", "none")
            })?;
        let units = parse_units(self.units.as_deref().unwrap_or(""))?;
        if let Some(ms) = self.rx_latency_ms.filter(|&ms| ms > 255) {
            return Err(RangeError::new("rx_latency_ms", "0 … 255 ms", " ms", ms));
        }
        if kind == "rk512" {
            return self.check_rk512(name, device, units);
        }
        self.refuse_rk512_keys(kind)?;
        if kind != "modbus-rtu" {
            refuse_keys(
                &[
                    (
                        "char_delay_multiplier",
                        self.char_delay_multiplier.is_some(),
                    ),
                    ("frame_end", self.frame_end.is_some()),
                    ("frame_gap", self.frame_gap.is_some()),
                    (
                        "quiet_after_timeout_ms",
                        self.quiet_after_timeout_ms.is_some(),
                    ),
                ],
                "a key of modbus-rtu lines",
                format!("set on a {kind} line"),
            )?;
        }
        if kind == "3964r" {
            return self.check_3964r(name, device, units);
        }
        if kind == "uss" {
            return self.check_uss(name, device, units);
        }
        refuse_keys(
            &[
                ("drives", self.drives.is_some()),
                ("pzd_words", self.pzd_words.is_some()),
                ("pkw_words", self.pkw_words.is_some()),
            ],
            "a key of uss lines",
            format!("set on a {kind} line"),
        )?;
        let retries = self.retries.unwrap_or(2);
        RangeError::check("retries", (0, 15), "", retries)?;
        let pause_ms = self.pause_ms.unwrap_or(100);
        RangeError::check("pause_ms", (0, 10_000), " ms", pause_ms)?;
        let response_timeout_ms = self.response_timeout_ms.unwrap_or(500);
        RangeError::check(
            "response_timeout_ms",
            (50, 655_000),
            " ms",
            response_timeout_ms,
        )?;
        let queue = self.queue.unwrap_or(DEFAULT_QUEUE);
        RangeError::check("queue", (1, MAX_QUEUE), "", queue)?;
        let baud = self.baud.unwrap_or(9600);
        if !si_core::BAUD_RATES.contains(&baud) {
            return Err(RangeError::new(
                "baud",
                format!("{:?}", si_core::BAUD_RATES),
                " bit/s",
                baud,
            ));
        }
        self.check_rs485()?;
        Ok(Line {
            retries,
            pause: std::time::Duration::from_millis(pause_ms),
            response_timeout_ms,
            broadcast: self.broadcast,
            queue,
            rtu: self.rtu_framing()?,
            demotion: self.demotion()?,
            ..self.port_line(name, device, units, Kind::ModbusRtu)
        })
    }
}

impl LineFile {
    /// Line `name` with its port keys (defaults filled in) and no retries, pause or queue:
    /// each kind sets those it has.
    pub(super) fn port_line(
        &self,
        name: String,
        device: Device,
        units: Vec<u8>,
        kind: Kind,
    ) -> Line {
        Line {
            name,
            device,
            baud: self.baud.unwrap_or(9600),
            data_bits: self.data_bits.unwrap_or(8),
            parity: self.parity.clone().unwrap_or_else(|| "even".to_string()),
            stop_bits: self.stop_bits.unwrap_or(1),
            rs485: self.rs485.clone(),
            rs485_file: self.rs485_file.clone(),
            rs485_delays_ms: (
                self.rs485_delay_before_ms.unwrap_or(0),
                self.rs485_delay_after_ms.unwrap_or(0),
            ),
            local_echo: self.local_echo,
            latency_timer_ms: self.latency_timer_ms,
            rx_latency_ms: self.rx_latency_ms,
            units,
            retries: 0,
            pause: std::time::Duration::ZERO,
            response_timeout_ms: 0,
            broadcast: false,
            queue: 1,
            rtu: RtuFraming::default(),
            demotion: super::demotion::DemotionConfig::default(),
            kind,
            listen: self.listen.clone(),
        }
    }

    /// `demote_after` and `demote_for_ms`, checked. The ranges are ours `[derived]`: up to 255
    /// failures, up to an hour demoted.
    fn demotion(&self) -> Result<super::demotion::DemotionConfig, RangeError> {
        let mut d = super::demotion::DemotionConfig::default();
        if let Some(n) = self.demote_after {
            RangeError::check("demote_after", (0, 255), "", n)?;
            d.demote_after = n;
        }
        if let Some(ms) = self.demote_for_ms {
            RangeError::check("demote_for_ms", (1, 3_600_000), " ms", ms)?;
            d.demote_for = si_core::Duration::from_millis(ms);
        }
        Ok(d)
    }

    /// `char_delay_multiplier` and `frame_end`, checked (the ranges of `si modbus`'s flags).
    fn rtu_framing(&self) -> Result<RtuFraming, RangeError> {
        let char_delay_multiplier = self.char_delay_multiplier.unwrap_or(1);
        RangeError::check("char_delay_multiplier", (1, 10), "", char_delay_multiplier)?;
        let frame_end = match self.frame_end.as_deref() {
            None | Some("gap") => si_modbus::FrameEnd::Gap,
            Some("length") => si_modbus::FrameEnd::Length,
            Some(other) => return Err(RangeError::new("frame_end", "gap or length", "", other)),
        };
        let spec_gap = match (self.frame_gap.as_deref(), self.char_delay_multiplier) {
            (None, None) | (Some("spec"), None) => true,
            (None | Some("module"), _) => false,
            (Some("spec"), Some(_)) => {
                return Err(RangeError::new(
                    "frame_gap",
                    "module where char_delay_multiplier is given",
                    "",
                    "spec",
                ))
            }
            (Some(other), _) => {
                return Err(RangeError::new("frame_gap", "spec or module", "", other))
            }
        };
        if let Some(q) = self.quiet_after_timeout_ms {
            RangeError::check("quiet_after_timeout_ms", (0, 655_000), " ms", q)?;
        }
        Ok(RtuFraming {
            char_delay_multiplier,
            frame_end,
            spec_gap,
            quiet_after_timeout_ms: self.quiet_after_timeout_ms,
        })
    }

    /// The RS-485 mode, if given, is one we know (the `--rs485` names), and `rs485_file` is
    /// given exactly when the mode writes a file.
    pub(super) fn check_rs485(&self) -> Result<(), RangeError> {
        // A device server switches its own line: these are serial port options (refused by
        // the port too, but here as a configuration error, never a line down for ever).
        if self
            .device
            .as_deref()
            .is_some_and(|d| d.starts_with("tcp:"))
        {
            refuse_keys(
                &[
                    ("rs485", self.rs485.is_some()),
                    ("latency_timer_ms", self.latency_timer_ms.is_some()),
                ],
                "a serial port's key (a device server switches its own line)",
                "set on a tcp: device".to_owned(),
            )?;
        }
        let mode = match self.rs485.as_deref() {
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

/// The first of `keys` given (`(name, given)`) as an error: `range` says where it belongs.
pub(super) fn refuse_keys(
    keys: &[(&'static str, bool)],
    range: &'static str,
    value: String,
) -> Result<(), RangeError> {
    match keys.iter().find(|(_, given)| *given) {
        Some((key, _)) => Err(RangeError::new(key, range, "", value)),
        None => Ok(()),
    }
}

/// `"1-10,12"` → the unit ids 1–10 and 12 (each 1–255; unit 0 is the broadcast, see
/// `broadcast`). At least one unit, or the line would serve nothing.
pub fn parse_units(text: &str) -> Result<Vec<u8>, RangeError> {
    const RANGE: &str = "unit ids 1 … 255 as a list of N or N-M, e.g. 1-10,12";
    si_core::address_list::parse(text, 1, 255)
        .ok_or_else(|| RangeError::new("units", RANGE, "", format!("{text:?}")))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The checked gateway of TOML `text`, or the error's text.
    pub(crate) fn check(text: &str) -> Result<Gateway, String> {
        File::from_toml(text)?.check().map_err(|e| e.to_string())
    }

    /// Whether a line with `char_delay_multiplier = 2` keeps the specification's gap.
    fn g_multiplied(base: &str) -> bool {
        let g = check(&format!("{base}char_delay_multiplier = 2\n")).unwrap();
        g.lines[0].rtu.spec_gap
    }

    #[test]
    fn a_full_file_is_read_with_defaults_filled_in() {
        let g = check(
            r#"
            listen = "127.0.0.1:5020"
            diagnostic_unit = 247
            [[line]]
            name = "meters"
            device = "tcp:127.0.0.1:4001"
            units = "1-3, 7"
            broadcast = true
            "#,
        )
        .unwrap();
        assert_eq!(g.max_connections, 32);
        let l = &g.lines[0];
        assert_eq!(l.units, [1, 2, 3, 7]);
        assert_eq!(l.device, Device::Tcp("127.0.0.1:4001".into()));
        assert_eq!((l.retries, l.response_timeout_ms, l.queue), (2, 500, 32));
        assert_eq!(l.pause.as_millis(), 100);
    }

    #[test]
    fn errors_name_the_line_the_key_and_the_value() {
        let base = "[[line]]\nname = \"m\"\ndevice = \"/dev/null\"\nunits = \"1\"\n";
        let e = check(&format!("{base}retries = 20\n")).unwrap_err();
        assert_eq!(
            e,
            "gateway config, line 1 (m): retries = 20 is out of range: 0 … 15"
        );
        let e = check(&format!("{base}response_timeout_ms = 10\n")).unwrap_err();
        assert!(e.contains("line 1 (m): response_timeout_ms = 10 ms"), "{e}");
        let e = check("[[line]]\ndevice = \"/dev/null\"\nunits = \"0-3\"\n").unwrap_err();
        assert!(e.contains("line 1 (line1): units = \"0-3\""), "{e}");
        let e = check(&format!("{base}kind = \"profibus\"\n")).unwrap_err();
        assert!(
            e.contains("kind = profibus is out of range: modbus-rtu, uss, rk512 or 3964r"),
            "{e}"
        );
        let e = check(&format!("max_connections = 0\n{base}")).unwrap_err();
        assert!(e.starts_with("gateway config: max_connections = 0"), "{e}");
        let e = check(&format!("{base}{base}")).unwrap_err();
        assert!(e.contains("line 2 (m): units = 1"), "{e}");
        let e = check(&format!("{base}speed = 1\n")).unwrap_err();
        assert!(e.contains("speed"), "unknown keys are refused: {e}");
    }

    #[test]
    fn serial_port_keys_are_refused_on_a_device_server_line() {
        let base = "[[line]]\nname = \"m\"\ndevice = \"tcp:127.0.0.1:4001\"\nunits = \"1\"\n";
        let e = check(&format!("{base}rs485 = \"rts\"\n")).unwrap_err();
        assert!(e.contains("rs485 = set on a tcp: device"), "{e}");
        let e = check(&format!("{base}kind = \"uss\"\nlatency_timer_ms = 1\n")).unwrap_err();
        assert!(e.contains("latency_timer_ms = set on a tcp: device"), "{e}");
    }

    #[test]
    fn rtu_framing_keys_are_checked_and_belong_to_modbus_rtu_lines() {
        let base = "[[line]]\nname = \"m\"\ndevice = \"/dev/null\"\nunits = \"1\"\n";
        let g = check(&format!(
            "{base}char_delay_multiplier = 3\nframe_end = \"length\"\n"
        ));
        let rtu = g.unwrap().lines[0].rtu;
        assert_eq!(rtu.char_delay_multiplier, 3);
        assert_eq!(rtu.frame_end, si_modbus::FrameEnd::Length);
        let e = check(&format!("{base}char_delay_multiplier = 11\n")).unwrap_err();
        assert!(
            e.contains("char_delay_multiplier = 11 is out of range: 1 … 10"),
            "{e}"
        );
        assert!(
            check(base).unwrap().lines[0].rtu.spec_gap,
            "t3.5 by default"
        );
        let module = check(&format!("{base}frame_gap = \"module\"\n")).unwrap();
        assert!(!module.lines[0].rtu.spec_gap);
        assert!(
            !g_multiplied(base),
            "a multiplier asks for the module's gap"
        );
        let e = check(&format!(
            "{base}frame_gap = \"spec\"\nchar_delay_multiplier = 2\n"
        ))
        .unwrap_err();
        assert!(
            e.contains("frame_gap = spec is out of range: module where"),
            "{e}"
        );
        let e = check(&format!("{base}frame_gap = \"t35\"\n")).unwrap_err();
        assert!(
            e.contains("frame_gap = t35 is out of range: spec or module"),
            "{e}"
        );
        let q = check(&format!("{base}quiet_after_timeout_ms = 0\n")).unwrap();
        assert_eq!(q.lines[0].rtu.quiet_after_timeout_ms, Some(0));
        let e = check(&format!("{base}quiet_after_timeout_ms = 700000\n")).unwrap_err();
        assert!(
            e.contains("quiet_after_timeout_ms = 700000 ms is out of range: 0 … 655000"),
            "{e}"
        );
        let e = check(&format!("{base}frame_end = \"predicted\"\n")).unwrap_err();
        assert!(
            e.contains("frame_end = predicted is out of range: gap or length"),
            "{e}"
        );
        let e = check(&format!("{base}kind = \"uss\"\nframe_end = \"gap\"\n")).unwrap_err();
        assert!(e.contains("frame_end = set on a uss line"), "{e}");
    }

    #[test]
    fn the_diagnostic_unit_is_not_routed_to_a_line() {
        let e =
            check("diagnostic_unit = 5\n[[line]]\ndevice = \"x\"\nunits = \"1-10\"\n").unwrap_err();
        assert!(e.contains("units = 5"), "{e}");
    }
}
