//! The gateway's configuration: a TOML file (`--config`) or the flags of the common case (one
//! line), checked into [`Config`] with every value in range.
//!
//! Each `[[line]]` is one of the kinds of [`LineFile`], a serde enum tagged by `kind`
//! (`modbus-rtu` where `kind` is left out): each kind has the keys every line has
//! ([`crate::port_config`]) and only its own ([`crate::rtu_config`], [`crate::uss_config`],
//! [`crate::rk512_config`], [`crate::r3964_config`]); a key of another kind, or a misspelt
//! one, is refused as unknown, naming the file, line and key ([`File::read`]).
//!
//! The connection limit and the idle timeout have no module counterpart and follow mbusd,
//! the gateway si is measured against (mbusd's `src/conn.h`: `DEFAULT_MAXCONN` 32,
//! `MAX_CONNTIMEOUT` 1000 s).

use crate::backend::Backend;
use crate::demotion::DemotionConfig;
use crate::port_config::{parse_units, Common, Port};
use crate::r3964_config::R3964File;
use crate::rk512_config::{Rk512File, Rk512Line};
use crate::rtu_config::{RtuFile, RtuFraming};
use crate::tcp_config::{TcpFile, TcpLine};
use crate::uss_config::{UssFile, UssLine};
use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use si_core::RangeError;
use std::fmt;
use std::path::Path;
use std::sync::Arc;

pub use crate::port_config::{Device, DEFAULT_QUEUE, MAX_QUEUE};

/// The line kinds a `[[line]]` may be: Modbus RTU slaves, a Modbus TCP slave, USS drives, an
/// RK 512 partner or a plain 3964(R) partner.
pub const LINE_KINDS: &str = "modbus-rtu, modbus-tcp, uss, rk512 or 3964r";

/// The most connections a gateway accepts (a host limit; mbusd's `MAX_MAXCONN` is 128).
pub const MAX_CONNECTIONS: usize = 1024;

/// The whole file, as written (before checking).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct File {
    /// TCP address listened on, e.g. `127.0.0.1:5020`.
    pub listen: Option<String>,
    /// Connections served at once, on each listening address (the RTU-over-TCP one too).
    pub max_connections: Option<usize>,
    /// A connection silent this long is closed (0–1 000 000 ms, 0: never; default 60 000), on
    /// every listening address (the RTU-over-TCP one too).
    pub idle_timeout_ms: Option<u64>,
    /// The unit id that answers the gateway's counters as input registers.
    pub diagnostic_unit: Option<u8>,
    /// Answer a broadcast request with its echo once sent (mbusd's `-b`); default: no answer.
    #[serde(default)]
    pub reply_on_broadcast: bool,
    /// A line whose device cannot be opened at start starts down and is reopened like a line
    /// whose port closed ([`crate::reopen`]), instead of stopping the gateway (the default,
    /// so that a wrong path is reported at once).
    #[serde(default)]
    pub allow_down_at_start: bool,
    /// Serve Prometheus metrics over HTTP at `GET /metrics` on this address (default: none;
    /// [`crate::metrics_http`]).
    pub metrics_listen: Option<String>,
    /// Accept raw RTU frames (address, PDU, CRC) over TCP on this address, routed like the
    /// top-level `listen`'s Modbus TCP requests (default: none; [`crate::rtu_listener`]).
    pub rtu_over_tcp_listen: Option<String>,
    /// The lines.
    #[serde(default, rename = "line")]
    pub lines: Vec<LineFile>,
}

/// One `[[line]]`, as written: a serde enum tagged by `kind`. (TOML files are read through
/// [`File::read`], which also takes a line without `kind` for `modbus-rtu` and keeps every
/// error's place in the file.)
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind")]
pub enum LineFile {
    /// `modbus-rtu`: Modbus RTU slaves.
    #[serde(rename = "modbus-rtu")]
    ModbusRtu(RtuFile),
    /// `modbus-tcp`: a Modbus TCP slave.
    #[serde(rename = "modbus-tcp")]
    ModbusTcp(TcpFile),
    /// `uss`: USS drives.
    #[serde(rename = "uss")]
    Uss(UssFile),
    /// `rk512`: an RK 512 partner.
    #[serde(rename = "rk512")]
    Rk512(Box<Rk512File>),
    /// `3964r`: a plain 3964(R) partner.
    #[serde(rename = "3964r")]
    R3964(R3964File),
}

impl LineFile {
    /// The keys every line has.
    pub fn common(&self) -> Common<'_> {
        match self {
            LineFile::ModbusRtu(l) => l.common(),
            LineFile::ModbusTcp(l) => Common {
                name: l.name.as_deref(),
                units: l.units.as_deref(),
                listen: l.listen.as_deref(),
                ..Common::default()
            },
            LineFile::Uss(l) => l.common(),
            LineFile::Rk512(l) => l.common(),
            LineFile::R3964(l) => l.common(),
        }
    }
}

/// A checked gateway configuration.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Config {
    /// Listen address.
    pub listen: String,
    /// Connections served at once.
    pub max_connections: usize,
    /// Idle timeout (`None`: never).
    pub idle_timeout: Option<std::time::Duration>,
    /// The unit answering the counters.
    pub diagnostic_unit: Option<u8>,
    /// Echo broadcasts once sent.
    pub reply_on_broadcast: bool,
    /// Lines whose device cannot be opened at start start down.
    pub allow_down_at_start: bool,
    /// The Prometheus metrics address, if any.
    pub metrics_listen: Option<String>,
    /// The RTU-over-TCP address, if any.
    pub rtu_over_tcp_listen: Option<String>,
    /// The lines.
    pub lines: Vec<Line>,
}

/// A checked line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Line {
    /// Name.
    pub name: String,
    /// Its port (`None` only for a line of the program's own kind, [`Kind::Custom`]).
    pub port: Option<Port>,
    /// TCP unit ids routed here (1–255).
    pub units: Vec<u8>,
    /// The TCP unit ids that reach a slave of another address (`unit_map`): unit id →
    /// address; the others reach the slave of their own number.
    pub unit_map: std::collections::BTreeMap<u8, u8>,
    /// Retries.
    pub retries: u8,
    /// Pause between requests.
    pub pause: std::time::Duration,
    /// Response timeout.
    pub response_timeout: std::time::Duration,
    /// Broadcasts forwarded.
    pub broadcast: bool,
    /// Queue length.
    pub queue: usize,
    /// Modbus RTU framing (defaults for other kinds, which do not use it).
    pub rtu: RtuFraming,
    /// Auto-demotion of units that stop answering (Modbus RTU lines; the default for other
    /// kinds, which do not use it).
    pub demotion: DemotionConfig,
    /// What is on the line.
    pub kind: Kind,
    /// Its own listening address (`None`: the gateway's `listen`).
    pub listen: Option<String>,
}

impl Line {
    /// The slave addresses its unit ids reach (through `unit_map`), as its metrics label
    /// units.
    pub fn addresses(&self) -> Vec<u8> {
        let mut a: Vec<u8> = self
            .units
            .iter()
            .map(|u| self.unit_map.get(u).copied().unwrap_or(*u))
            .collect();
        a.sort_unstable();
        a.dedup();
        a
    }

    /// A line of the program's own kind: `units` served by `backend`, on the top-level
    /// address.
    pub fn custom(name: impl Into<String>, units: Vec<u8>, backend: Arc<dyn Backend>) -> Line {
        Line {
            name: name.into(),
            port: None,
            units,
            unit_map: Default::default(),
            retries: 0,
            pause: std::time::Duration::ZERO,
            response_timeout: std::time::Duration::ZERO,
            broadcast: false,
            queue: 1,
            rtu: RtuFraming::default(),
            demotion: DemotionConfig::default(),
            kind: Kind::Custom(Custom(backend)),
            listen: None,
        }
    }
}

/// What a line's units are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Kind {
    /// Modbus RTU slaves: requests are forwarded.
    ModbusRtu,
    /// A Modbus TCP slave: requests are forwarded over one connection ([`crate::tcp_line`]).
    ModbusTcp(TcpLine),
    /// USS drives polled by a USS master: requests are served from their PZD and a parameter
    /// window ([`crate::uss`]).
    Uss(UssLine),
    /// An RK 512 partner: requests become FETCH and SEND jobs, or are served from the
    /// gateway's own memory in the passive role ([`crate::rk512`]).
    Rk512(Box<Rk512Line>),
    /// A plain 3964(R) partner: the latest block received as input registers, a register
    /// write sends a block ([`crate::r3964`]).
    R3964(si_3964r::Config),
    /// The program's own kind: its backend answers (no port of the gateway's).
    Custom(Custom),
}

/// A program's own backend as a line kind: equal only to itself.
#[derive(Clone)]
pub struct Custom(pub Arc<dyn Backend>);

impl fmt::Debug for Custom {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Custom")
    }
}

impl PartialEq for Custom {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Eq for Custom {}

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
    /// Read and check the TOML file `path` through si-core's bounded reader: an error names
    /// the file, then where in it (the TOML line and the key, or the `[[line]]`) and why, on
    /// a line of at most [`MAX_ERROR_LINE`] characters.
    pub fn read(path: &Path) -> Result<Config, crate::Error> {
        let text =
            si_core::config_file::read(path).map_err(|e| crate::Error::Config(e.text().into()))?;
        Self::parse(path, &text)?.check().map_err(|e| {
            crate::Error::Config(format!("{}: {}", path.display(), cut(&e.to_string())))
        })
    }

    /// Parse `text`, the contents of `path`, as TOML: each `[[line]]` by its `kind`, errors
    /// placed at their line and key ([`si_core::config_file::placed`]).
    pub fn parse(path: &Path, text: &str) -> Result<File, crate::Error> {
        let placed = |e: toml::de::Error| {
            let span = e.span().unwrap_or(0..0);
            crate::Error::Config(
                si_core::config_file::placed(path, text, span, None, e.message())
                    .text()
                    .to_owned(),
            )
        };
        let kinds: Kinds = toml::from_str(text).map_err(placed)?;
        let kinds: Vec<String> = kinds
            .line
            .into_iter()
            .map(|l| l.kind.unwrap_or_else(|| "modbus-rtu".to_owned()))
            .collect();
        let de = toml::de::Deserializer::parse(text).map_err(placed)?;
        FileSeed(&kinds).deserialize(de).map_err(placed)
    }

    /// Parse TOML text without a file name (errors say where by `gateway config:`).
    pub fn from_toml(text: &str) -> Result<File, String> {
        Self::parse(Path::new("gateway config"), text).map_err(|e| e.to_string())
    }

    /// Check every value and fill in the defaults.
    pub fn check(&self) -> Result<Config, ConfigError> {
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
        let idle_timeout = match self.idle_timeout_ms {
            Some(0) => None,
            Some(ms) => {
                RangeError::check("idle_timeout_ms", (0, 1_000_000), " ms", ms).map_err(top)?;
                Some(std::time::Duration::from_millis(ms))
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
        for (i, l) in self.lines.iter().enumerate() {
            let name = l
                .common()
                .name
                .map_or_else(|| format!("line{}", i + 1), str::to_owned);
            let err = |range| ConfigError {
                line: Some(format!("line {} ({name})", i + 1)),
                range,
            };
            let mut line = l.check(name.clone()).map_err(err)?;
            if line.listen.as_ref() == Some(&listen) {
                line.listen = None;
            }
            lines.push(line);
        }
        let config = Config {
            listen,
            max_connections,
            idle_timeout,
            diagnostic_unit: self.diagnostic_unit,
            reply_on_broadcast: self.reply_on_broadcast,
            allow_down_at_start: self.allow_down_at_start,
            metrics_listen: self.metrics_listen.clone(),
            rtu_over_tcp_listen: self.rtu_over_tcp_listen.clone(),
            lines,
        };
        config.check_lines()?;
        Ok(config)
    }
}

impl Config {
    /// A configuration listening on `listen`, with the file's defaults (32 connections, idle
    /// connections closed after 60 s) and no line yet: a program adds its lines (of the
    /// built-in kinds from a file's [`LineFile`], or its own with [`Line::custom`]).
    pub fn listening(listen: impl Into<String>) -> Config {
        Config {
            listen: listen.into(),
            max_connections: si_modbus::tokio::tcp::DEFAULT_MAX_CONNECTIONS,
            idle_timeout: Some(si_modbus::tokio::tcp::DEFAULT_IDLE_TIMEOUT),
            diagnostic_unit: None,
            reply_on_broadcast: false,
            allow_down_at_start: false,
            metrics_listen: None,
            rtu_over_tcp_listen: None,
            lines: Vec::new(),
        }
    }

    /// The lines together: names unique, each unit id served by one line per listening
    /// address, none the diagnostic unit. A program that builds or changes a configuration
    /// (a line of its own kind) checks it with this.
    pub fn check_lines(&self) -> Result<(), ConfigError> {
        // The line owning each unit id, per listening address (`None`: the top-level one).
        let mut owners: std::collections::HashMap<Option<&String>, [Option<usize>; 256]> =
            std::collections::HashMap::new();
        for (i, line) in self.lines.iter().enumerate() {
            let err = |range| ConfigError {
                line: Some(format!("line {} ({})", i + 1, line.name)),
                range,
            };
            let owner = owners.entry(line.listen.as_ref()).or_insert([None; 256]);
            for &u in &line.units {
                if let Some(other) = owner[u as usize] {
                    return Err(err(RangeError::new(
                        "units",
                        format!("unit ids not served by {}", self.lines[other].name),
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
            if self.lines[..i].iter().any(|other| other.name == line.name) {
                return Err(err(RangeError::new(
                    "name",
                    "a name no other [[line]] has",
                    "",
                    format!("{:?}", line.name),
                )));
            }
            let queued = matches!(line.kind, Kind::ModbusRtu | Kind::Rk512(_));
            // (A Modbus TCP line has no `broadcast` key: TCP has no broadcast.)
            if line.broadcast && !queued {
                return Err(err(RangeError::new(
                    "broadcast",
                    "false on this kind of line",
                    "",
                    true,
                )));
            }
        }
        Ok(())
    }
}

impl LineFile {
    /// Check one line (the caller names it in the error).
    fn check(&self, name: String) -> Result<Line, RangeError> {
        let common = self.common();
        // A Modbus line may name its units by `unit_map` alone.
        let mapped = match self {
            LineFile::ModbusRtu(l) => l.unit_map.is_some(),
            LineFile::ModbusTcp(l) => l.unit_map.is_some(),
            _ => false,
        };
        let units = match mapped && common.units.is_none() {
            true => Vec::new(),
            false => parse_units(common.units.unwrap_or(""))?,
        };
        let port = match self {
            LineFile::ModbusTcp(_) => None,
            _ => Some(common.port()?),
        };
        let line = Line {
            name,
            port,
            units,
            unit_map: Default::default(),
            retries: 0,
            pause: std::time::Duration::ZERO,
            response_timeout: std::time::Duration::ZERO,
            broadcast: false,
            queue: 1,
            rtu: RtuFraming::default(),
            demotion: DemotionConfig::default(),
            kind: Kind::ModbusRtu,
            listen: common.listen.map(str::to_owned),
        };
        Ok(match self {
            LineFile::ModbusRtu(l) => {
                let rtu = l.check()?;
                Line {
                    units: with_mapped(&line.units, &rtu.unit_map)?,
                    unit_map: rtu.unit_map.iter().copied().collect(),
                    retries: rtu.retries,
                    pause: rtu.pause,
                    response_timeout: rtu.response_timeout,
                    broadcast: rtu.broadcast,
                    queue: rtu.queue,
                    rtu: rtu.framing,
                    demotion: rtu.demotion,
                    ..line
                }
            }
            LineFile::ModbusTcp(l) => {
                let tcp = l.check()?;
                Line {
                    units: with_mapped(&line.units, &tcp.unit_map)?,
                    unit_map: tcp.unit_map.iter().copied().collect(),
                    retries: tcp.client.retries,
                    pause: tcp.pause,
                    response_timeout: tcp.client.response_timeout.into(),
                    queue: tcp.queue,
                    kind: Kind::ModbusTcp(tcp),
                    ..line
                }
            }
            LineFile::Uss(l) => {
                let uss = l.check(&line.units)?;
                Line {
                    retries: l.retries.unwrap_or(20),
                    response_timeout: uss.master.response_timeout.into(),
                    kind: Kind::Uss(uss),
                    ..line
                }
            }
            LineFile::Rk512(l) => {
                let (rk512, queue, pause) = l.check()?;
                Line {
                    response_timeout: rk512.config.response_timeout.into(),
                    queue,
                    pause,
                    kind: Kind::Rk512(Box::new(rk512)),
                    ..line
                }
            }
            LineFile::R3964(l) => Line {
                kind: Kind::R3964(l.check()?),
                ..line
            },
        })
    }
}

/// `units` and the unit ids of `unit_map`, sorted; refused if one is in both, or if there is
/// none.
fn with_mapped(units: &[u8], unit_map: &[(u8, u8)]) -> Result<Vec<u8>, RangeError> {
    let mut all = units.to_vec();
    for &(unit, _) in unit_map {
        if all.contains(&unit) {
            let range = "unit ids not also in units";
            return Err(RangeError::new("unit_map", range, "", unit));
        }
        all.push(unit);
    }
    all.sort_unstable();
    if all.is_empty() {
        return Err(RangeError::new(
            "unit_map",
            "at least one unit id",
            "",
            "{}",
        ));
    }
    Ok(all)
}

/// The first pass over a TOML file: each `[[line]]`'s `kind`, nothing else.
#[derive(Deserialize)]
struct Kinds {
    #[serde(default)]
    line: Vec<KindOf>,
}

/// One `[[line]]`'s `kind`, if written.
#[derive(Deserialize)]
struct KindOf {
    kind: Option<String>,
}

/// The keys of the top level, as the unknown-key error lists them.
const FILE_KEYS: &[&str] = &[
    "listen",
    "max_connections",
    "idle_timeout_ms",
    "diagnostic_unit",
    "reply_on_broadcast",
    "allow_down_at_start",
    "metrics_listen",
    "rtu_over_tcp_listen",
    "line",
];

/// The second pass: the file, each `[[line]]` read as the kind found in the first (so an
/// error keeps its place in the file, which a tagged enum's buffering would lose).
struct FileSeed<'a>(&'a [String]);

impl<'de> DeserializeSeed<'de> for FileSeed<'_> {
    type Value = File;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<File, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for FileSeed<'_> {
    type Value = File;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a gateway configuration")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<File, A::Error> {
        let mut file = File::default();
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "listen" => file.listen = Some(map.next_value()?),
                "max_connections" => file.max_connections = Some(map.next_value()?),
                "idle_timeout_ms" => file.idle_timeout_ms = Some(map.next_value()?),
                "diagnostic_unit" => file.diagnostic_unit = Some(map.next_value()?),
                "reply_on_broadcast" => file.reply_on_broadcast = map.next_value()?,
                "allow_down_at_start" => file.allow_down_at_start = map.next_value()?,
                "metrics_listen" => file.metrics_listen = Some(map.next_value()?),
                "rtu_over_tcp_listen" => file.rtu_over_tcp_listen = Some(map.next_value()?),
                "line" => file.lines = map.next_value_seed(LinesSeed(self.0))?,
                other => return Err(de::Error::unknown_field(other, FILE_KEYS)),
            }
        }
        Ok(file)
    }
}

/// The `[[line]]`s, the i-th read as kind `self.0[i]`.
struct LinesSeed<'a>(&'a [String]);

impl<'de> DeserializeSeed<'de> for LinesSeed<'_> {
    type Value = Vec<LineFile>;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Vec<LineFile>, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for LinesSeed<'_> {
    type Value = Vec<LineFile>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("[[line]] tables")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<LineFile>, A::Error> {
        let mut lines = Vec::with_capacity(self.0.len());
        for kind in self.0 {
            match seq.next_element_seed(LineSeed(kind))? {
                Some(line) => lines.push(line),
                None => break,
            }
        }
        Ok(lines)
    }
}

/// One `[[line]]` of the kind named.
struct LineSeed<'a>(&'a str);

impl<'de> DeserializeSeed<'de> for LineSeed<'_> {
    type Value = LineFile;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<LineFile, D::Error> {
        Ok(match self.0 {
            "modbus-rtu" => LineFile::ModbusRtu(RtuFile::deserialize(d)?),
            "modbus-tcp" => LineFile::ModbusTcp(TcpFile::deserialize(d)?),
            "uss" => LineFile::Uss(UssFile::deserialize(d)?),
            "rk512" => LineFile::Rk512(Box::new(Rk512File::deserialize(d)?)),
            "3964r" => LineFile::R3964(R3964File::deserialize(d)?),
            other => {
                return Err(de::Error::custom(RangeError::new(
                    "kind", LINE_KINDS, "", other,
                )))
            }
        })
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The checked gateway of TOML `text`, or the error's text.
    pub(crate) fn check(text: &str) -> Result<Config, String> {
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
        assert_eq!(
            l.port.as_ref().unwrap().device,
            Device::Tcp("127.0.0.1:4001".into())
        );
        assert_eq!(
            (l.retries, l.response_timeout, l.queue),
            (2, std::time::Duration::from_millis(500), 32)
        );
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
            e.contains(
                "kind = profibus is out of range: modbus-rtu, modbus-tcp, uss, rk512 or 3964r"
            ),
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
    fn the_idle_timeout_is_in_milliseconds() {
        let base = "[[line]]\nname = \"m\"\ndevice = \"/dev/null\"\nunits = \"1\"\n";
        let top = |key: &str| check(&format!("{key}\n{base}")).map(|g| g.idle_timeout);
        let ms = std::time::Duration::from_millis;
        assert_eq!(top("idle_timeout_ms = 1500"), Ok(Some(ms(1500))));
        assert_eq!(top("idle_timeout_ms = 0"), Ok(None));
        assert_eq!(top(""), Ok(Some(ms(60_000))));
        let e = top("idle_timeout_ms = 1000001").unwrap_err();
        assert!(e.contains("idle_timeout_ms = 1000001 ms"), "{e}");
        let e = top("idle_timeout_s = 60").unwrap_err();
        assert!(e.contains("idle_timeout_s"), "the old key is unknown: {e}");
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
            "{base}char_delay_multiplier = 3\nframe_end = \"gap\"\n"
        ));
        let rtu = g.unwrap().lines[0].rtu;
        assert_eq!(rtu.char_delay_multiplier, 3);
        assert_eq!(rtu.frame_end, si_modbus::FrameEnd::Gap);
        assert_eq!(
            check(base).unwrap().lines[0].rtu.frame_end,
            si_modbus::FrameEnd::Length,
            "answers end at their predicted length by default"
        );
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
        assert!(e.contains("unknown field `frame_end`"), "{e}");
    }

    #[test]
    fn demotion_keys_are_checked_and_belong_to_modbus_rtu_lines() {
        let base = "[[line]]\nname = \"m\"\ndevice = \"/dev/null\"\nunits = \"1\"\n";
        let d = check(base).unwrap().lines[0].demotion;
        assert_eq!((d.demote_after, d.demote_for.as_millis()), (3, 30_000));
        let g = check(&format!("{base}demote_after = 0\ndemote_for_ms = 500\n")).unwrap();
        let d = g.lines[0].demotion;
        assert_eq!((d.demote_after, d.demote_for.as_millis()), (0, 500));
        let e = check(&format!("{base}demote_after = 256\n")).unwrap_err();
        assert!(
            e.contains("line 1 (m): demote_after = 256 is out of range: 0 … 255"),
            "{e}"
        );
        let e = check(&format!("{base}demote_for_ms = 0\n")).unwrap_err();
        assert!(e.contains("demote_for_ms = 0 ms is out of range"), "{e}");
        for kind in ["uss", "rk512", "3964r"] {
            let e = check(&format!("{base}kind = \"{kind}\"\ndemote_after = 3\n")).unwrap_err();
            assert!(e.contains("unknown field `demote_after`"), "{kind}: {e}");
        }
        let tcp = "[[line]]\nkind = \"modbus-tcp\"\naddress = \"127.0.0.1:502\"\nunits = \"1\"\n";
        let e = check(&format!("{tcp}demote_for_ms = 5\n")).unwrap_err();
        assert!(e.contains("unknown field `demote_for_ms`"), "{e}");
    }

    #[test]
    fn the_top_level_listeners_are_read() {
        let g = check(
            "metrics_listen = \"127.0.0.1:9100\"\nrtu_over_tcp_listen = \"127.0.0.1:5021\"\n\
             [[line]]\ndevice = \"x\"\nunits = \"1\"\n",
        )
        .unwrap();
        assert_eq!(g.metrics_listen.as_deref(), Some("127.0.0.1:9100"));
        assert_eq!(g.rtu_over_tcp_listen.as_deref(), Some("127.0.0.1:5021"));
    }

    #[test]
    fn the_diagnostic_unit_is_not_routed_to_a_line() {
        let e =
            check("diagnostic_unit = 5\n[[line]]\ndevice = \"x\"\nunits = \"1-10\"\n").unwrap_err();
        assert!(e.contains("units = 5"), "{e}");
    }
}
