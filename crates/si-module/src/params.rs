//! Module parameters: one typed structure per driver, with every field, range and default of
//! the manual's parameter tables, read from and written to TOML or JSON.
//!
//! | Driver | Structure | Tables |
//! |---|---|---|
//! | ASCII | [`AsciiParams`] | [ET200S SI 2005] (Table 2-8), [ET200S SI] §2.9 (Table 2-10) |
//! | 3964(R) | [`R3964Params`] | [ET200S SI 2005] §2.9.3 (Table 2-9), [ET200S SI] §2.9 (Table 2-11) |
//! | Modbus master | [`ModbusMasterParams`] | [ET200S SI 2005] Tables 3-18, 3-21 (Table 3-18), [Modbus/USS] §3.4.3 (Table 3-17) |
//! | Modbus slave | [`ModbusSlaveParams`] | [ET200S SI 2005] Tables 3-18, 3-21 (Table 3-21), [Modbus/USS] §3.5.4 (Table 3-20) |
//! | USS master | [`UssMasterParams`] | [ET200S SI 2005] §3.8 (Table 3-78), [Modbus/USS] §3.7.2, §3.7.6, Table 3-31 |
//!
//! The protocol parameters are the protocol crates' own configuration types
//! ([`si_ascii::Config`], [`si_3964r::Config`], [`si_modbus::config::MasterConfig`] and
//! [`SlaveConfig`], [`si_uss::config::MasterConfig`]), so the
//! values that configure a simulated module ([`DriverParams::module_config`]) are the ones a
//! host engine runs with. This module adds the module-level fields those types do not carry
//! (diagnostic interrupt, BREAK detection, interface, receive-line initial state, …).
//!
//! # The file
//!
//! One flat table per file, tagged by `driver`; every key but `driver` is optional and defaults
//! to the manual's value:
//!
//! ```toml
//! driver = "ascii"            # ascii, 3964r, modbus-master, modbus-slave, uss-master
//! interface = "rs422"
//! baud = 19200
//! end_criterion = "end-chars"
//! end_char_1 = 13
//! end_char_2 = 10
//! ```
//!
//! The keys, with the manual's ranges and defaults (host-side extensions of the protocol crates
//! are marked *host*):
//!
//! | Key | Drivers | Values | Default |
//! |---|---|---|---|
//! | `diagnostic_interrupt` | all | true/false | false |
//! | `break_detection` | all but USS | true/false | false |
//! | `interface` | all | `rs232`, `rs422`, `rs485` (3964(R): no RS-485; USS: no RS-422) | `rs232` (USS `rs485`) |
//! | `receive_line` | all but USS | RS-422: `ra5v-rb0v`, `ra0v-rb5v`, `inverted`; RS-485: `none`, `ra0v-rb5v` | `ra5v-rb0v` (RS-485 `ra0v-rb5v`) |
//! | `baud` | all | 110, 300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 76800, 115200 | 9600 |
//! | `data_bits` | ASCII, 3964(R) | 7, 8 | 8 |
//! | `stop_bits` | all but USS | 1, 2 | 1 |
//! | `parity` | all but USS | `none`, `odd`, `even`, `any` (Modbus: no `any`) | `even` |
//! | `clear_at_startup` | all but USS | true/false | true |
//! | `flow_control` | ASCII; Modbus | `none`, `xon-xoff`, `rts-cts`, `auto-v24`; Modbus `none`, `auto-v24` | `none` |
//! | `end_criterion` | ASCII | `char-delay`, `end-chars`, `fixed-length` | `char-delay` |
//! | `char_delay_ms` | ASCII | 4 … 65 535, at least the Table 2-7 minimum for the baud rate | 4 |
//! | `end_char_1`, `end_char_2` | ASCII, `end-chars` only | 1 … FFH / 0 … FFH (7FH with 7 data bits; 0 = unused) | 3, 0 |
//! | `frame_length` | ASCII, `fixed-length` only | 1 … 200 | 100 |
//! | `dynamic_frames`, `prevent_overwrite` | ASCII | true/false | true, true |
//! | `xon`, `xoff`, `wait_for_xon_ms` | ASCII | characters; 20 … 655 350 ms in 10 ms steps | 11H, 13H, 2000 |
//! | `wait_for_cts_ms` | ASCII | 20 … 655 350 ms in 10 ms steps | 2000 |
//! | `time_rts_off_ms`, `data_wait_time_ms` | ASCII; Modbus with `flow_control = "auto-v24"` | 0 … 655 350 ms in 10 ms steps | 10, 10 |
//! | `tx_chunk` | ASCII (*host*) | 1 … 200 | 16 |
//! | `block_check` | 3964(R) | true (3964(R)) / false (3964) | true |
//! | `priority` | 3964(R) | `low`, `high` | `low` |
//! | `char_delay_ms` | 3964(R) | 20 … 655 350 | 220 |
//! | `ack_delay_ms` | 3964(R) | 10 … 655 350 | 2000 (550 without block check) |
//! | `connection_attempts`, `transmission_attempts` | 3964(R) | 1 … 255 | 6, 6 |
//! | `max_block_len`, `receive_buffer_blocks` | 3964(R) (*host*) | 1 … 1024, 1 … 255 | 200, 5 |
//! | `mode` | Modbus | `normal`, `interference-suppression` | `normal` |
//! | `char_delay_multiplier` | Modbus | 1 … 10 | 1 |
//! | `response_timeout_ms` | Modbus master | 50 … 655 000 | 2000 |
//! | `retries`, `broadcast_turnaround_ms` | Modbus master (*host*) | 0 … 255, ms | 0, 100 |
//! | `address` | Modbus slave | 1 … 255 | 222 (as printed, `[derived]`) |
//! | `local_echo` | Modbus, USS (*host*) | true/false | false |
//! | `polling_list` | USS | 1 … 31 tables `{ address = 0…31, pkw = 0/3/4/127, pzd = 0…16 }` | node 1, PKW 4, PZD 2 |
//! | `pkw_retries` | USS (WDH) | 0 … 32 767 | 20 |
//! | `response_timeout_ms`, `cycle_pause_ms` | USS (*host*) | 1 … 10 000, 0 … 60 000 | 20, 0 |
//!
//! Reading checks the whole file before giving up: [`DriverParams::from_toml_str`] returns
//! every wrong value at once ([`ParamErrors`]), each naming the parameter, its range and the
//! value:
//!
//! ```
//! use si_module::params::DriverParams;
//! let e = DriverParams::from_toml_str(
//!     "driver = \"3964r\"\nbaud = 9601\nchar_delay_ms = 5\nconnection_attempts = 0\n",
//! )
//! .unwrap_err();
//! let lines: Vec<String> = e.iter().map(|e| e.to_string()).collect();
//! assert_eq!(lines, [
//!     "baud = 9601 is not one of: 110, 300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 76800, 115200 (line 2)",
//!     "character delay time (ZVZ) = 5 ms is out of range: 20 … 655350 ms",
//!     "connection attempts = 0 is out of range: 1 … 255",
//! ]);
//! ```
//!
//! # Readings
//!
//! - **Baud rates.** The 2005 manual lists twelve rates (110 … 115 200 bit/s) for every driver
//!   ([ET200S SI 2005] Tables 2-8, 2-9, 3-18, 3-21; technical data, Tables 2-31, 3-86, 3-87); the
//!   2004 Russian manuals stop at 19 200 (3964(R)/ASCII) and 38 400 (Modbus/USS). We accept the
//!   twelve of the 2005 manual, which describes the later modules. USS's 187 500 bit/s is a drive
//!   rate, not a module rate, and is refused here.
//! - **Receive-line initial state.** RS-422 offers R(A) 5 V/R(B) 0 V (BREAK, the default),
//!   R(A) 0 V/R(B) 5 V and inverted; RS-485 offers none and R(A) 0 V/R(B) 5 V (the default), as
//!   in the 2005 tables (the Russian Modbus table gives R(A) 5 V/R(B) 0 V for both). The value is
//!   not used on RS-232C and any value is accepted there.
//! - **Modbus slave interface.** Table 3-21 leaves it out; Table 3-20 of the Russian manual lists
//!   it with the master's values, which we use.
//! - **Modbus parity.** none/odd/even as in the parameter tables; "any" of the technical data
//!   (`[derived]`) is refused.
//! - **USS interface.** Table 3-78 offers RS-232C and RS-485 (default RS-485); Table 3-1 says
//!   RS-485 only (`[derived]`). We follow the parameter table. USS runs 8E1 ([USS spec] §6.1); the
//!   tables have no data-bit, parity or stop-bit parameter, so the file has none.
//! - **Maximum frame length of the simulated module**: the line engines' limits (ASCII 200
//!   bytes, 3964(R) its `max_block_len`, default 200), and 200 for the Modbus/USS module
//!   (`[derived]`).

use crate::diag::Variant;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use si_ascii::config::{EndCriterion, FlowControl, Interface};
use si_core::{Duration, Parity, SerialSettings, BAUD_RATES};
use si_dp_coord::config::{FlowControl as WindowFlowControl, ModuleConfig};
use si_dp_coord::frame::WindowSize;
use si_dp_coord::line::EngineSerial;
use si_dp_coord::module::Module;
use si_modbus::config::{LineConfig, MasterConfig as ModbusMaster, Mode, SlaveConfig};
use si_uss::config::{MasterConfig as UssMaster, PollEntry};
use si_uss::frame::PkwWords;

/// The receive-line initial state of RS-422/RS-485 (Tables 2-8, 2-9, 3-18, 3-21).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ReceiveLine {
    /// R(A) 5 V / R(B) 0 V: BREAK detection and wire-break detection possible (RS-422 default).
    #[serde(rename = "ra5v-rb0v")]
    Ra5vRb0v,
    /// R(A) 0 V / R(B) 5 V (RS-485 default).
    #[serde(rename = "ra0v-rb5v")]
    Ra0vRb5v,
    /// Inverted signal level (RS-422 only, for replacing older parts).
    #[serde(rename = "inverted")]
    Inverted,
    /// No initial state (RS-485 only).
    #[serde(rename = "none")]
    None,
}

const RECEIVE_LINES: [(&str, ReceiveLine); 4] = [
    ("ra5v-rb0v", ReceiveLine::Ra5vRb0v),
    ("ra0v-rb5v", ReceiveLine::Ra0vRb5v),
    ("inverted", ReceiveLine::Inverted),
    ("none", ReceiveLine::None),
];

impl ReceiveLine {
    /// The default for an interface.
    pub const fn default_for(interface: Interface) -> ReceiveLine {
        match interface {
            Interface::Rs485 => ReceiveLine::Ra0vRb5v,
            _ => ReceiveLine::Ra5vRb0v,
        }
    }

    /// Whether the interface offers this state (RS-232C ignores it).
    pub const fn allowed_on(self, interface: Interface) -> bool {
        match interface {
            Interface::Rs232 => true,
            Interface::Rs422 => !matches!(self, ReceiveLine::None),
            Interface::Rs485 => matches!(self, ReceiveLine::None | ReceiveLine::Ra0vRb5v),
        }
    }

    fn name(self) -> &'static str {
        RECEIVE_LINES
            .iter()
            .find(|(_, v)| *v == self)
            .map_or("?", |(n, _)| n)
    }
}

/// ASCII driver (Table 2-8 / 2-10).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AsciiParams {
    /// Diagnostic interrupt on serious errors; default no.
    pub diagnostic_interrupt: bool,
    /// Report BREAK on a line break; default no.
    pub break_detection: bool,
    /// Receive-line initial state (RS-422/485).
    pub receive_line: ReceiveLine,
    /// Interface, character format, flow control, end criterion, buffer and flow-control
    /// parameters: the ASCII driver's own configuration.
    pub config: si_ascii::Config,
}

impl Default for AsciiParams {
    fn default() -> Self {
        AsciiParams {
            diagnostic_interrupt: false,
            break_detection: false,
            receive_line: ReceiveLine::Ra5vRb0v,
            config: si_ascii::Config::default(),
        }
    }
}

impl AsciiParams {
    /// A simulated module running the ASCII driver with these parameters (the configuration of
    /// [`si_dp_coord::engines::ascii_module_config`]): the same values a host's ASCII link runs with.
    pub fn simulated_module(
        &self,
        window: WindowSize,
    ) -> Result<Module<EngineSerial<si_ascii::Link>>, ParamErrors> {
        let link = si_ascii::Link::new(self.config).map_err(|e| one("config", e))?;
        let cfg = si_dp_coord::engines::ascii_module_config(window, &self.config);
        Module::new(cfg, si_dp_coord::engines::ascii(link)).map_err(|e| one("module", e))
    }
}

impl R3964Params {
    /// A simulated module running 3964(R) with these parameters: the link's `max_block_len` is
    /// the module's frame limit, as in [`si_dp_coord::engines::r3964r_module`].
    pub fn simulated_module(
        &self,
        window: WindowSize,
    ) -> Result<Module<EngineSerial<si_3964r::Link>>, ParamErrors> {
        let link = si_3964r::Link::new(self.config.with_settings(self.settings))
            .map_err(|e| one("config", e))?;
        let cfg = DriverParams::R3964(*self).module_config(window);
        Module::new(cfg, si_dp_coord::engines::r3964r(link)).map_err(|e| one("module", e))
    }
}

fn one(parameter: &str, e: impl ToString) -> ParamErrors {
    ParamErrors(vec![ParamError::new(parameter, e.to_string())])
}

/// 3964(R) driver (Table 2-9 / 2-11).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct R3964Params {
    /// Diagnostic interrupt; default no.
    pub diagnostic_interrupt: bool,
    /// BREAK detection; default no.
    pub break_detection: bool,
    /// RS-232C (default) or RS-422; 3964(R) does not run on RS-485.
    pub interface: Interface,
    /// Receive-line initial state (RS-422).
    pub receive_line: ReceiveLine,
    /// Character format; default 9600 8E1.
    pub settings: SerialSettings,
    /// Protocol mode, priority, ZVZ, QVZ, attempts, clearing the receive buffer at CPU startup:
    /// the 3964(R) link's own configuration.
    pub config: si_3964r::Config,
}

impl Default for R3964Params {
    fn default() -> Self {
        R3964Params {
            diagnostic_interrupt: false,
            break_detection: false,
            interface: Interface::Rs232,
            receive_line: ReceiveLine::Ra5vRb0v,
            settings: SerialSettings::default(),
            config: si_3964r::Config::default(),
        }
    }
}

/// The module-level fields of the Modbus master and slave (Tables 3-18 / 3-21).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModbusModule {
    /// Diagnostic interrupt; default no.
    pub diagnostic_interrupt: bool,
    /// BREAK detection; default no.
    pub break_detection: bool,
    /// Interface; default RS-232C.
    pub interface: Interface,
    /// Receive-line initial state (RS-422/485).
    pub receive_line: ReceiveLine,
    /// None (default) or automatic V.24 control (RS-232C only).
    pub flow_control: FlowControl,
    /// Clear the receive buffer at CPU startup; default yes.
    pub clear_at_startup: bool,
}

impl Default for ModbusModule {
    fn default() -> Self {
        ModbusModule {
            diagnostic_interrupt: false,
            break_detection: false,
            interface: Interface::Rs232,
            receive_line: ReceiveLine::Ra5vRb0v,
            flow_control: FlowControl::None,
            clear_at_startup: true,
        }
    }
}

/// Modbus master (Table 3-18 / 3-17).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ModbusMasterParams {
    /// Module-level fields.
    pub module: ModbusModule,
    /// Character format, mode, multiplier, response time: the Modbus master's configuration.
    pub config: ModbusMaster,
}

/// Modbus slave (Table 3-21 / 3-20).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ModbusSlaveParams {
    /// Module-level fields.
    pub module: ModbusModule,
    /// Character format, mode, multiplier, slave address: the Modbus slave's configuration.
    pub config: SlaveConfig,
}

/// USS master (Table 3-78; polling list and WDH of S_USSI, [Modbus/USS] §3.7.6, Table 3-31).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UssMasterParams {
    /// Diagnostic interrupt; default no.
    pub diagnostic_interrupt: bool,
    /// RS-485 (default) or RS-232C.
    pub interface: Interface,
    /// Baud rate (8E1), polling list, WDH, timeouts: the USS master's configuration.
    pub config: UssMaster,
}

impl Default for UssMasterParams {
    /// One drive, node 1, PKW 4 words and PZD 2 words (the common fixed-length telegram,
    /// [SINAMICS CU240S] p. 178).
    fn default() -> Self {
        UssMasterParams {
            diagnostic_interrupt: false,
            interface: Interface::Rs485,
            config: UssMaster::new(vec![PollEntry::new(1, PkwWords::Four, 2)]),
        }
    }
}

/// The parameters of one module, for one of its drivers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DriverParams {
    /// ASCII driver (3964(R)/ASCII module).
    Ascii(AsciiParams),
    /// 3964(R) driver (3964(R)/ASCII module).
    R3964(R3964Params),
    /// Modbus master (Modbus/USS module).
    ModbusMaster(ModbusMasterParams),
    /// Modbus slave (Modbus/USS module).
    ModbusSlave(ModbusSlaveParams),
    /// USS master (Modbus/USS module).
    UssMaster(UssMasterParams),
}

const DRIVERS: [&str; 5] = [
    "ascii",
    "3964r",
    "modbus-master",
    "modbus-slave",
    "uss-master",
];

/// One parameter that is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{text}")]
pub struct ParamError {
    /// The parameter: the file's key, or the manual's name for checks of the protocol crates.
    pub parameter: String,
    /// One line naming the parameter, its range and the value.
    pub text: String,
}

impl ParamError {
    fn new(parameter: impl Into<String>, text: impl Into<String>) -> Self {
        ParamError {
            parameter: parameter.into(),
            text: text.into(),
        }
    }
}

/// Every wrong parameter of a file, in file order (module-level fields first, then the
/// protocol's).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParamErrors(pub Vec<ParamError>);

impl ParamErrors {
    /// The errors.
    pub fn iter(&self) -> impl Iterator<Item = &ParamError> {
        self.0.iter()
    }

    /// How many.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Never true for an error returned by this module.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl core::fmt::Display for ParamErrors {
    /// One error per line.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            f.write_str(&e.text)?;
        }
        Ok(())
    }
}

impl std::error::Error for ParamErrors {}

// --- reading -------------------------------------------------------------------------------

/// Reads keys of one table, collecting errors instead of stopping at the first.
struct Reader<'a> {
    map: &'a Map<String, Value>,
    used: Vec<&'a str>,
    errors: Vec<ParamError>,
}

fn show(v: &Value) -> String {
    match v {
        Value::String(s) => format!("{s:?}"),
        other => other.to_string(),
    }
}

impl<'a> Reader<'a> {
    fn new(map: &'a Map<String, Value>) -> Self {
        Reader {
            map,
            used: Vec::new(),
            errors: Vec::new(),
        }
    }

    fn get(&mut self, key: &'static str) -> Option<&'a Value> {
        let (k, v) = self.map.get_key_value(key)?;
        self.used.push(k.as_str());
        Some(v)
    }

    fn error(&mut self, key: &str, text: String) {
        self.errors.push(ParamError::new(key, text));
    }

    fn bool(&mut self, key: &'static str, default: bool) -> bool {
        match self.get(key) {
            None => default,
            Some(Value::Bool(b)) => *b,
            Some(v) => {
                self.error(key, format!("{key} = {} must be true or false", show(v)));
                default
            }
        }
    }

    /// An unsigned integer up to `max` (the width of the field it goes into); the range text
    /// names the manual's range for values beyond it.
    fn uint(&mut self, key: &'static str, default: u64, max: u64, range: &str) -> u64 {
        match self.get(key) {
            None => default,
            Some(v) => match v.as_u64() {
                Some(n) if n <= max => n,
                Some(_) => {
                    self.error(key, format!("{key} = {v} is out of range: {range}"));
                    default
                }
                None if v.is_i64() => {
                    self.error(key, format!("{key} = {v} is out of range: {range}"));
                    default
                }
                None => {
                    self.error(
                        key,
                        format!("{key} = {} must be a whole number ({range})", show(v)),
                    );
                    default
                }
            },
        }
    }

    fn choice<T: Copy + PartialEq>(
        &mut self,
        key: &'static str,
        options: &[(&str, T)],
        default: T,
    ) -> T {
        let Some(v) = self.get(key) else {
            return default;
        };
        // Numeric options (baud, data and stop bits) take numbers, named ones strings: a
        // quoted `baud = "9600"` is a type error, not a baud rate.
        let numeric = options.iter().all(|(n, _)| n.parse::<u64>().is_ok());
        let found = match v {
            Value::String(s) if !numeric => options.iter().find(|(n, _)| n == s),
            Value::Number(number) if numeric => {
                let text = number.to_string();
                options.iter().find(|(n, _)| *n == text)
            }
            _ => None,
        };
        let names: Vec<&str> = options.iter().map(|(n, _)| *n).collect();
        match found {
            Some((_, t)) => *t,
            None if numeric && !v.is_number() => {
                self.error(
                    key,
                    format!(
                        "{key} = {} must be a number, one of: {}",
                        show(v),
                        names.join(", ")
                    ),
                );
                default
            }
            None => {
                self.error(
                    key,
                    format!("{key} = {} is not one of: {}", show(v), names.join(", ")),
                );
                default
            }
        }
    }

    /// Errors for the keys nobody read.
    fn finish(mut self, driver: &str) -> Vec<ParamError> {
        let mut unknown: Vec<&String> = self
            .map
            .keys()
            .filter(|k| k.as_str() != "driver" && !self.used.contains(&k.as_str()))
            .collect();
        unknown.sort();
        for k in unknown {
            self.errors.push(ParamError::new(
                k.as_str(),
                format!("{k} is not a parameter of the {driver} driver"),
            ));
        }
        self.errors
    }
}

const INTERFACES: [(&str, Interface); 3] = [
    ("rs232", Interface::Rs232),
    ("rs422", Interface::Rs422),
    ("rs485", Interface::Rs485),
];

const FLOW_CONTROLS: [(&str, FlowControl); 4] = [
    ("none", FlowControl::None),
    ("xon-xoff", FlowControl::XonXoff),
    ("rts-cts", FlowControl::RtsCts),
    ("auto-v24", FlowControl::AutoV24),
];

const PARITIES: [(&str, Parity); 4] = [
    ("none", Parity::None),
    ("odd", Parity::Odd),
    ("even", Parity::Even),
    ("any", Parity::Space),
];

fn name_of<T: PartialEq + Copy>(options: &[(&'static str, T)], value: T) -> &'static str {
    options
        .iter()
        .find(|(_, v)| *v == value)
        .map_or("?", |(n, _)| n)
}

fn bauds() -> Vec<(String, u32)> {
    BAUD_RATES.iter().map(|b| (b.to_string(), *b)).collect()
}

impl Reader<'_> {
    fn baud(&mut self, default: u32) -> u32 {
        let owned = bauds();
        let options: Vec<(&str, u32)> = owned.iter().map(|(n, b)| (n.as_str(), *b)).collect();
        self.choice("baud", &options, default)
    }

    /// Baud, data bits (if the driver has them), stop bits and parity.
    fn settings(&mut self, data_bits: bool, parities: &[(&str, Parity)]) -> SerialSettings {
        let d = SerialSettings::default();
        let baud = self.baud(d.baud());
        let bits = if data_bits {
            self.choice("data_bits", &[("7", 7u8), ("8", 8)], 8)
        } else {
            8
        };
        let stop = self.choice("stop_bits", &[("1", 1u8), ("2", 2)], 1);
        let parity = self.choice("parity", parities, d.parity());
        SerialSettings::new(baud, bits, parity, stop).unwrap_or(d)
    }

    fn interface(&mut self, options: &[(&str, Interface)], default: Interface) -> Interface {
        self.choice("interface", options, default)
    }

    /// The receive-line initial state; whether the interface offers it is checked by
    /// [`DriverParams::check`].
    fn receive_line(&mut self, interface: Interface) -> ReceiveLine {
        self.choice(
            "receive_line",
            &RECEIVE_LINES,
            ReceiveLine::default_for(interface),
        )
    }
}

/// The 1-based line of byte `offset` in `text`.
fn line_at(text: &str, offset: usize) -> usize {
    let before = text.get(..offset).unwrap_or(text);
    before.matches('\n').count() + 1
}

/// The 1-based line where the flat table sets `key` (bare or quoted), if it does.
fn key_line(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|line| {
            let line = line.trim_start();
            let rest = line
                .strip_prefix(key)
                .or_else(|| line.strip_prefix(&format!("\"{key}\"")));
            rest.is_some_and(|r| r.trim_start().starts_with('='))
        })
        .map(|i| i + 1)
}

fn crate_errors<E: ToString>(parameter: impl Fn(&E) -> String, errors: Vec<E>) -> Vec<ParamError> {
    errors
        .into_iter()
        .map(|e| ParamError::new(parameter(&e), e.to_string()))
        .collect()
}

fn ascii_errors(errors: Vec<si_ascii::config::ConfigError>) -> Vec<ParamError> {
    use si_ascii::config::ConfigError as E;
    crate_errors(
        |e: &E| match e {
            E::OutOfRange(range) => range.parameter.into(),
            E::NotAllowed { parameter, .. } => (*parameter).into(),
            E::Settings(_) => "character format".into(),
        },
        errors,
    )
}

fn uss_errors(errors: Vec<si_uss::config::ConfigError>) -> Vec<ParamError> {
    use si_uss::config::ConfigError as E;
    crate_errors(
        |e: &E| match e {
            E::OutOfRange(range) => range.parameter.into(),
            E::ConflictingStructure { .. } => "polling_list".into(),
        },
        errors,
    )
}

fn read_ascii(r: &mut Reader<'_>) -> AsciiParams {
    let d = AsciiParams::default();
    let dc = d.config;
    let diagnostic_interrupt = r.bool("diagnostic_interrupt", false);
    let break_detection = r.bool("break_detection", false);
    let interface = r.interface(&INTERFACES, dc.interface);
    let receive_line = r.receive_line(interface);
    let settings = r.settings(true, &PARITIES);
    let flow_control = r.choice("flow_control", &FLOW_CONTROLS, dc.flow_control);
    let criterion = r.choice(
        "end_criterion",
        &[("char-delay", 0u8), ("end-chars", 1), ("fixed-length", 2)],
        0,
    );
    let char_delay_ms = r.uint("char_delay_ms", 4, u32::MAX.into(), "4 … 65535 ms") as u32;
    let first = r.uint("end_char_1", 3, 0xFF, "01H … FFH (7FH with 7 data bits)") as u8;
    let second = r.uint("end_char_2", 0, 0xFF, "00H … FFH (7FH with 7 data bits)") as u8;
    let len = r.uint("frame_length", 100, u16::MAX.into(), "1 … 200 bytes") as u16;
    let end = match criterion {
        1 => EndCriterion::EndChars { first, second },
        2 => EndCriterion::FixedLength { len },
        _ => EndCriterion::CharDelay,
    };
    // Table 2-8: the end characters apply "in end-character mode only", the frame length "in
    // fixed-length mode only"; a value for the other mode is a mistake worth naming.
    for (key, mode, wanted) in [
        ("end_char_1", "end-chars", 1),
        ("end_char_2", "end-chars", 1),
        ("frame_length", "fixed-length", 2),
    ] {
        if criterion != wanted && r.map.contains_key(key) {
            r.error(
                key,
                format!("{key} applies only with end_criterion = \"{mode}\""),
            );
        }
    }
    let step = "0 … 655350 ms in 10 ms steps";
    let config = si_ascii::Config {
        settings,
        interface,
        flow_control,
        end,
        char_delay: si_core::Duration::from_millis(char_delay_ms.into()),
        dynamic_frames: r.bool("dynamic_frames", dc.dynamic_frames),
        prevent_overwrite: r.bool("prevent_overwrite", dc.prevent_overwrite),
        clear_at_startup: r.bool("clear_at_startup", dc.clear_at_startup),
        max_frame_len: dc.max_frame_len,
        xon_xoff: si_ascii::config::XonXoff {
            xon: r.uint("xon", dc.xon_xoff.xon.into(), 0xFF, "00H … FFH") as u8,
            xoff: r.uint("xoff", dc.xon_xoff.xoff.into(), 0xFF, "00H … FFH") as u8,
            wait_for_xon: si_core::Duration::from_millis(r.uint(
                "wait_for_xon_ms",
                dc.xon_xoff.wait_for_xon.as_millis(),
                u32::MAX.into(),
                step,
            )),
        },
        rts_cts: si_ascii::config::RtsCts {
            wait_for_cts: si_core::Duration::from_millis(r.uint(
                "wait_for_cts_ms",
                dc.rts_cts.wait_for_cts.as_millis(),
                u32::MAX.into(),
                step,
            )),
        },
        auto_v24: si_ascii::config::AutoV24 {
            time_rts_off: si_core::Duration::from_millis(r.uint(
                "time_rts_off_ms",
                dc.auto_v24.time_rts_off.as_millis(),
                u32::MAX.into(),
                step,
            )),
            data_wait_time: si_core::Duration::from_millis(r.uint(
                "data_wait_time_ms",
                dc.auto_v24.data_wait_time.as_millis(),
                u32::MAX.into(),
                step,
            )),
        },
        tx_chunk: r.uint("tx_chunk", dc.tx_chunk.into(), 0xFF, "1 … 200 characters") as u8,
    };
    AsciiParams {
        diagnostic_interrupt,
        break_detection,
        receive_line,
        config,
    }
}

fn read_3964r(r: &mut Reader<'_>) -> R3964Params {
    let d = R3964Params::default();
    let diagnostic_interrupt = r.bool("diagnostic_interrupt", false);
    let break_detection = r.bool("break_detection", false);
    let interface = r.interface(&INTERFACES[..2], d.interface);
    let receive_line = r.receive_line(interface);
    let settings = r.settings(true, &PARITIES);
    let block_check = r.bool("block_check", true);
    let base = if block_check {
        si_3964r::Config::default()
    } else {
        si_3964r::Config::without_block_check()
    };
    let config = si_3964r::Config {
        block_check,
        priority: r.choice(
            "priority",
            &[
                ("low", si_3964r::config::Priority::Low),
                ("high", si_3964r::config::Priority::High),
            ],
            base.priority,
        ),
        char_delay: si_core::Duration::from_millis(r.uint(
            "char_delay_ms",
            base.char_delay.as_millis(),
            u32::MAX.into(),
            "20 … 655350 ms",
        )),
        ack_delay: si_core::Duration::from_millis(r.uint(
            "ack_delay_ms",
            base.ack_delay.as_millis(),
            u32::MAX.into(),
            "10 … 655350 ms",
        )),
        connection_attempts: r.uint(
            "connection_attempts",
            base.connection_attempts.into(),
            0xFF,
            "1 … 255",
        ) as u8,
        transmission_attempts: r.uint(
            "transmission_attempts",
            base.transmission_attempts.into(),
            0xFF,
            "1 … 255",
        ) as u8,
        max_block_len: r.uint(
            "max_block_len",
            base.max_block_len.into(),
            u16::MAX.into(),
            "1 … 1024 bytes",
        ) as u16,
        receive_buffer_blocks: r.uint(
            "receive_buffer_blocks",
            base.receive_buffer_blocks.into(),
            0xFF,
            "1 … 255 blocks",
        ) as u8,
        clear_at_startup: r.bool("clear_at_startup", base.clear_at_startup),
        settings,
    };
    R3964Params {
        diagnostic_interrupt,
        break_detection,
        interface,
        receive_line,
        settings,
        config,
    }
}

fn read_modbus_line(r: &mut Reader<'_>) -> (ModbusModule, LineConfig) {
    let d = ModbusModule::default();
    let diagnostic_interrupt = r.bool("diagnostic_interrupt", false);
    let break_detection = r.bool("break_detection", false);
    let interface = r.interface(&INTERFACES, d.interface);
    let receive_line = r.receive_line(interface);
    let flow_control = r.choice(
        "flow_control",
        &[
            ("none", FlowControl::None),
            ("auto-v24", FlowControl::AutoV24),
        ],
        FlowControl::None,
    );
    let settings = r.settings(false, &PARITIES[..3]);
    let errors_before_mode = r.errors.len();
    let mode = r.choice("mode", &Mode::NAMES, Mode::Normal);
    if let Some(e) = r.errors.get_mut(errors_before_mode) {
        // [Modbus/USS] §3.4.3, §3.5.4, §3.6: the module refuses any other mode with 0E22H and is
        // not ready.
        e.text = format!("{} ({})", e.text, si_modbus::status::INVALID_MODE);
    }
    let line = LineConfig {
        settings,
        mode,
        char_delay_multiplier: r.uint("char_delay_multiplier", 1, 0xFF, "1…10") as u8,
        local_echo: r.bool("local_echo", false),
        // [Modbus/USS] §3.2.2: the flow control's two times, with the ASCII driver's ranges (the
        // Modbus manual gives none).
        auto_v24: (flow_control == FlowControl::AutoV24).then(|| {
            let d = si_core::v24::AutoV24Times::default();
            let step = "0 … 655350 ms in 10 ms steps";
            si_core::v24::AutoV24Times {
                time_rts_off: si_core::Duration::from_millis(r.uint(
                    "time_rts_off_ms",
                    d.time_rts_off.as_millis(),
                    u32::MAX.into(),
                    step,
                )),
                data_wait_time: si_core::Duration::from_millis(r.uint(
                    "data_wait_time_ms",
                    d.data_wait_time.as_millis(),
                    u32::MAX.into(),
                    step,
                )),
            }
        }),
    };
    let module = ModbusModule {
        diagnostic_interrupt,
        break_detection,
        interface,
        receive_line,
        flow_control,
        clear_at_startup: r.bool("clear_at_startup", true),
    };
    (module, line)
}

fn read_modbus_master(r: &mut Reader<'_>) -> ModbusMasterParams {
    let (module, line) = read_modbus_line(r);
    let d = ModbusMaster::default();
    ModbusMasterParams {
        module,
        config: ModbusMaster {
            line,
            response_timeout: si_core::Duration::from_millis(r.uint(
                "response_timeout_ms",
                d.response_timeout.as_millis(),
                u32::MAX.into(),
                "50…655000",
            )),
            retries: r.uint("retries", d.retries.into(), 0xFF, "0 … 255") as u8,
            broadcast_turnaround: si_core::Duration::from_millis(r.uint(
                "broadcast_turnaround_ms",
                d.broadcast_turnaround.as_millis(),
                u32::MAX.into(),
                "0 … 4294967295 ms",
            )),
        },
    }
}

fn read_modbus_slave(r: &mut Reader<'_>) -> ModbusSlaveParams {
    let (module, line) = read_modbus_line(r);
    ModbusSlaveParams {
        module,
        config: SlaveConfig {
            line,
            address: r.uint("address", 222, 0xFF, "1…255") as u8,
        },
    }
}

fn read_polling_list(r: &mut Reader<'_>, default: &[PollEntry]) -> Vec<PollEntry> {
    let Some(v) = r.get("polling_list") else {
        return default.to_vec();
    };
    let Some(items) = v.as_array() else {
        r.error(
            "polling_list",
            "polling_list must be a list of tables {address, pkw, pzd}".into(),
        );
        return default.to_vec();
    };
    let mut list = Vec::with_capacity(items.len().min(si_uss::config::MAX_ENTRIES + 1));
    for (i, item) in items.iter().enumerate() {
        let Some(map) = item.as_object() else {
            r.error(
                "polling_list",
                format!("polling_list[{i}] must be a table {{address, pkw, pzd}}"),
            );
            continue;
        };
        let mut e = Reader::new(map);
        let address = e.uint("address", 0, 0xFF, "0…31") as u8;
        let pkw = e.choice(
            "pkw",
            &[
                ("0", PkwWords::None),
                ("3", PkwWords::Three),
                ("4", PkwWords::Four),
                ("127", PkwWords::Variable),
            ],
            PkwWords::Four,
        );
        let pzd = e.uint("pzd", 2, 0xFF, "0…16") as u8;
        for mut err in e.finish("USS master polling list entry") {
            err.text = format!("polling_list[{i}]: {}", err.text);
            r.errors.push(err);
        }
        list.push(PollEntry::new(address, pkw, pzd));
    }
    list
}

fn read_uss(r: &mut Reader<'_>) -> UssMasterParams {
    let d = UssMasterParams::default();
    let diagnostic_interrupt = r.bool("diagnostic_interrupt", false);
    let interface = r.interface(&[INTERFACES[0], INTERFACES[2]], Interface::Rs485);
    let baud = r.baud(9_600);
    let polling_list = read_polling_list(r, &d.config.polling_list);
    let ms = |n: u64| Duration::from_millis(n);
    let config = UssMaster {
        settings: si_uss::config::uss_settings(baud).unwrap_or(d.config.settings),
        polling_list,
        response_timeout: ms(r.uint("response_timeout_ms", 20, u32::MAX.into(), "1 ms … 10 s")),
        retries: r.uint("pkw_retries", 20, u16::MAX.into(), "0…32767") as u16,
        cycle_pause: ms(r.uint("cycle_pause_ms", 0, u32::MAX.into(), "0 … 60 s")),
        local_echo: r.bool("local_echo", false),
        pkw_after_job: d.config.pkw_after_job,
    };
    UssMasterParams {
        diagnostic_interrupt,
        interface,
        config,
    }
}

impl DriverParams {
    /// Reads a parameter table (the parsed file), checking every value; the error lists every
    /// wrong one.
    pub fn from_value(value: &Value) -> Result<DriverParams, ParamErrors> {
        let Some(map) = value.as_object() else {
            return Err(ParamErrors(vec![ParamError::new(
                "file",
                "the parameters must be a table of key = value pairs",
            )]));
        };
        let mut r = Reader::new(map);
        let driver = match map.get("driver") {
            Some(Value::String(s)) if DRIVERS.contains(&s.as_str()) => s.as_str(),
            Some(v) => {
                return Err(ParamErrors(vec![ParamError::new(
                    "driver",
                    format!("driver = {} is not one of: {}", show(v), DRIVERS.join(", ")),
                )]))
            }
            None => {
                return Err(ParamErrors(vec![ParamError::new(
                    "driver",
                    format!("driver is missing: one of {}", DRIVERS.join(", ")),
                )]))
            }
        };
        let params = match driver {
            "ascii" => DriverParams::Ascii(read_ascii(&mut r)),
            "3964r" => DriverParams::R3964(read_3964r(&mut r)),
            "modbus-master" => DriverParams::ModbusMaster(read_modbus_master(&mut r)),
            "modbus-slave" => DriverParams::ModbusSlave(read_modbus_slave(&mut r)),
            _ => DriverParams::UssMaster(read_uss(&mut r)),
        };
        let mut errors = r.finish(driver);
        errors.extend(params.check());
        if errors.is_empty() {
            Ok(params)
        } else {
            Err(ParamErrors(errors))
        }
    }

    /// Reads a TOML parameter file.
    ///
    /// Each error names the line of its key where the file has one (` (line 3)`), and a file
    /// TOML cannot parse (an integer beyond 64 bits, say) names the line of the fault.
    pub fn from_toml_str(text: &str) -> Result<DriverParams, ParamErrors> {
        let value: Value = toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .map(|span| format!(" (line {})", line_at(text, span.start)))
                .unwrap_or_default();
            ParamErrors(vec![ParamError::new(
                "file",
                format!("not valid TOML: {}{at}", e.message().trim_end()),
            )])
        })?;
        DriverParams::from_value(&value).map_err(|mut errors| {
            for e in &mut errors.0 {
                if let Some(line) = key_line(text, &e.parameter) {
                    e.text.push_str(&format!(" (line {line})"));
                }
            }
            errors
        })
    }

    /// Reads a JSON parameter file.
    pub fn from_json_str(text: &str) -> Result<DriverParams, ParamErrors> {
        let value: Value = serde_json::from_str(text).map_err(|e| {
            ParamErrors(vec![ParamError::new(
                "file",
                format!("not valid JSON: {e}"),
            )])
        })?;
        DriverParams::from_value(&value)
    }

    /// Checks every parameter (module-level combinations and the protocol crate's ranges);
    /// empty when all is well.
    pub fn check(&self) -> Vec<ParamError> {
        let mut errors = Vec::new();
        let mut line = |interface: Interface, receive_line: ReceiveLine| {
            if !receive_line.allowed_on(interface) {
                let allowed: Vec<&str> = RECEIVE_LINES
                    .iter()
                    .filter(|(_, l)| l.allowed_on(interface))
                    .map(|(n, _)| *n)
                    .collect();
                errors.push(ParamError::new(
                    "receive_line",
                    format!(
                        "receive_line = {:?} is not offered on {}: {}",
                        receive_line.name(),
                        name_of(&INTERFACES, interface),
                        allowed.join(", ")
                    ),
                ));
            }
        };
        match self {
            DriverParams::Ascii(p) => {
                line(p.config.interface, p.receive_line);
                errors.extend(ascii_errors(p.config.validate_all()));
            }
            DriverParams::R3964(p) => {
                line(p.interface, p.receive_line);
                if p.interface == Interface::Rs485 {
                    errors.push(ParamError::new(
                        "interface",
                        "interface = \"rs485\" is not one of: rs232, rs422 (3964(R) needs RS-232C or RS-422)",
                    ));
                }
                errors.extend(crate_errors(
                    |e: &si_3964r::config::ConfigError| e.parameter.into(),
                    p.config.validate_all(),
                ));
            }
            DriverParams::ModbusMaster(ModbusMasterParams { module, .. })
            | DriverParams::ModbusSlave(ModbusSlaveParams { module, .. }) => {
                line(module.interface, module.receive_line);
                match module.flow_control {
                    FlowControl::None => {}
                    FlowControl::AutoV24 if module.interface == Interface::Rs232 => {}
                    FlowControl::AutoV24 => errors.push(ParamError::new(
                        "flow_control",
                        "flow_control = \"auto-v24\" needs interface = \"rs232\"",
                    )),
                    other => errors.push(ParamError::new(
                        "flow_control",
                        format!(
                            "flow_control = {:?} is not one of: none, auto-v24",
                            name_of(&FLOW_CONTROLS, other)
                        ),
                    )),
                }
                let (param_errors, parity) = match self {
                    DriverParams::ModbusMaster(p) => {
                        (p.config.validate_all(), p.config.line.settings.parity())
                    }
                    DriverParams::ModbusSlave(p) => {
                        (p.config.validate_all(), p.config.line.settings.parity())
                    }
                    _ => (Vec::new(), Parity::None),
                };
                if !matches!(parity, Parity::None | Parity::Odd | Parity::Even) {
                    errors.push(ParamError::new(
                        "parity",
                        "parity must be one of: none, odd, even (Modbus)",
                    ));
                }
                errors.extend(crate_errors(
                    |e: &si_modbus::config::ConfigError| e.range.parameter.into(),
                    param_errors,
                ));
            }
            DriverParams::UssMaster(p) => {
                if p.interface == Interface::Rs422 {
                    errors.push(ParamError::new(
                        "interface",
                        "interface = \"rs422\" is not one of: rs232, rs485 (USS master)",
                    ));
                }
                errors.extend(uss_errors(p.config.validate_all()));
            }
        }
        errors
    }

    /// The driver's name in the file (`driver = …`).
    pub const fn driver(&self) -> &'static str {
        match self {
            DriverParams::Ascii(_) => "ascii",
            DriverParams::R3964(_) => "3964r",
            DriverParams::ModbusMaster(_) => "modbus-master",
            DriverParams::ModbusSlave(_) => "modbus-slave",
            DriverParams::UssMaster(_) => "uss-master",
        }
    }

    /// Which module runs this driver.
    pub const fn variant(&self) -> Variant {
        match self {
            DriverParams::Ascii(_) | DriverParams::R3964(_) => Variant::R3964Ascii,
            _ => Variant::ModbusUss,
        }
    }

    /// The character format on the line.
    pub fn settings(&self) -> SerialSettings {
        match self {
            DriverParams::Ascii(p) => p.config.settings,
            DriverParams::R3964(p) => p.settings,
            DriverParams::ModbusMaster(p) => p.config.line.settings,
            DriverParams::ModbusSlave(p) => p.config.line.settings,
            DriverParams::UssMaster(p) => p.config.settings,
        }
    }

    /// Whether the receive buffer is cleared at CPU startup ([`si_dp_coord::Module::restart`]).
    pub fn clear_at_startup(&self) -> bool {
        match self {
            DriverParams::Ascii(p) => p.config.clear_at_startup,
            DriverParams::R3964(p) => p.config.clear_at_startup,
            DriverParams::ModbusMaster(p) => p.module.clear_at_startup,
            DriverParams::ModbusSlave(p) => p.module.clear_at_startup,
            DriverParams::UssMaster(_) => true,
        }
    }

    /// The simulated module's window engine configuration for this driver and window size.
    ///
    /// ASCII and 3964(R) take the configuration [`si_dp_coord::engines`] gives their line engines
    /// (frame limit, receive buffer, flow control); the Modbus/USS module has a 200-byte frame
    /// limit (`[derived]`) and accepts the automatic V.24 parameter block when that flow control is
    /// configured.
    pub fn module_config(&self, window: WindowSize) -> ModuleConfig {
        match self {
            DriverParams::Ascii(p) => si_dp_coord::engines::ascii_module_config(window, &p.config),
            DriverParams::R3964(p) => ModuleConfig {
                flow_control: WindowFlowControl::None,
                max_frame_len: usize::from(p.config.max_block_len),
                ..ModuleConfig::new(window)
            },
            DriverParams::ModbusMaster(ModbusMasterParams { module, .. })
            | DriverParams::ModbusSlave(ModbusSlaveParams { module, .. }) => ModuleConfig {
                flow_control: match module.flow_control {
                    FlowControl::AutoV24 => WindowFlowControl::AutoV24,
                    _ => WindowFlowControl::None,
                },
                max_frame_len: 200,
                ..ModuleConfig::new(window)
            },
            DriverParams::UssMaster(_) => ModuleConfig {
                flow_control: WindowFlowControl::None,
                max_frame_len: 200,
                ..ModuleConfig::new(window)
            },
        }
    }

    /// The parameter table, every key written (the inverse of [`from_value`](Self::from_value)).
    pub fn to_value(&self) -> Value {
        let mut m = Map::new();
        let mut put = |k: &str, v: Value| {
            m.insert(k.into(), v);
        };
        put("driver", self.driver().into());
        let settings = |put: &mut dyn FnMut(&str, Value), s: SerialSettings, bits: bool| {
            put("baud", s.baud().into());
            if bits {
                put("data_bits", s.data_bits().into());
            }
            put("stop_bits", s.stop_bits().into());
            put("parity", name_of(&PARITIES, s.parity()).into());
        };
        match self {
            DriverParams::Ascii(p) => {
                let c = &p.config;
                put("diagnostic_interrupt", p.diagnostic_interrupt.into());
                put("break_detection", p.break_detection.into());
                put("interface", name_of(&INTERFACES, c.interface).into());
                put("receive_line", p.receive_line.name().into());
                settings(&mut put, c.settings, true);
                put(
                    "flow_control",
                    name_of(&FLOW_CONTROLS, c.flow_control).into(),
                );
                match c.end {
                    EndCriterion::CharDelay => put("end_criterion", "char-delay".into()),
                    EndCriterion::EndChars { first, second } => {
                        put("end_criterion", "end-chars".into());
                        put("end_char_1", first.into());
                        put("end_char_2", second.into());
                    }
                    EndCriterion::FixedLength { len } => {
                        put("end_criterion", "fixed-length".into());
                        put("frame_length", len.into());
                    }
                }
                put("char_delay_ms", c.char_delay.as_millis().into());
                put("dynamic_frames", c.dynamic_frames.into());
                put("prevent_overwrite", c.prevent_overwrite.into());
                put("clear_at_startup", c.clear_at_startup.into());
                put("xon", c.xon_xoff.xon.into());
                put("xoff", c.xon_xoff.xoff.into());
                put(
                    "wait_for_xon_ms",
                    c.xon_xoff.wait_for_xon.as_millis().into(),
                );
                put("wait_for_cts_ms", c.rts_cts.wait_for_cts.as_millis().into());
                put(
                    "time_rts_off_ms",
                    c.auto_v24.time_rts_off.as_millis().into(),
                );
                put(
                    "data_wait_time_ms",
                    c.auto_v24.data_wait_time.as_millis().into(),
                );
                put("tx_chunk", c.tx_chunk.into());
            }
            DriverParams::R3964(p) => {
                let c = &p.config;
                put("diagnostic_interrupt", p.diagnostic_interrupt.into());
                put("break_detection", p.break_detection.into());
                put("interface", name_of(&INTERFACES, p.interface).into());
                put("receive_line", p.receive_line.name().into());
                settings(&mut put, p.settings, true);
                put("block_check", c.block_check.into());
                put(
                    "priority",
                    match c.priority {
                        si_3964r::config::Priority::Low => "low",
                        si_3964r::config::Priority::High => "high",
                    }
                    .into(),
                );
                put("char_delay_ms", c.char_delay.as_millis().into());
                put("ack_delay_ms", c.ack_delay.as_millis().into());
                put("connection_attempts", c.connection_attempts.into());
                put("transmission_attempts", c.transmission_attempts.into());
                put("max_block_len", c.max_block_len.into());
                put("receive_buffer_blocks", c.receive_buffer_blocks.into());
                put("clear_at_startup", c.clear_at_startup.into());
            }
            DriverParams::ModbusMaster(ModbusMasterParams { module, .. })
            | DriverParams::ModbusSlave(ModbusSlaveParams { module, .. }) => {
                put("diagnostic_interrupt", module.diagnostic_interrupt.into());
                put("break_detection", module.break_detection.into());
                put("interface", name_of(&INTERFACES, module.interface).into());
                put("receive_line", module.receive_line.name().into());
                put(
                    "flow_control",
                    name_of(&FLOW_CONTROLS, module.flow_control).into(),
                );
                put("clear_at_startup", module.clear_at_startup.into());
                let line = match self {
                    DriverParams::ModbusMaster(p) => p.config.line,
                    DriverParams::ModbusSlave(p) => p.config.line,
                    _ => LineConfig::default(),
                };
                settings(&mut put, line.settings, false);
                put("mode", line.mode.name().into());
                put("char_delay_multiplier", line.char_delay_multiplier.into());
                put("local_echo", line.local_echo.into());
                if let Some(t) = line.auto_v24 {
                    put("time_rts_off_ms", t.time_rts_off.as_millis().into());
                    put("data_wait_time_ms", t.data_wait_time.as_millis().into());
                }
                match self {
                    DriverParams::ModbusMaster(p) => {
                        put(
                            "response_timeout_ms",
                            p.config.response_timeout.as_millis().into(),
                        );
                        put("retries", p.config.retries.into());
                        put(
                            "broadcast_turnaround_ms",
                            p.config.broadcast_turnaround.as_millis().into(),
                        );
                    }
                    DriverParams::ModbusSlave(p) => put("address", p.config.address.into()),
                    _ => {}
                }
            }
            DriverParams::UssMaster(p) => {
                let c = &p.config;
                put("diagnostic_interrupt", p.diagnostic_interrupt.into());
                put("interface", name_of(&INTERFACES, p.interface).into());
                put("baud", c.settings.baud().into());
                put(
                    "response_timeout_ms",
                    (c.response_timeout.as_micros() / 1000).into(),
                );
                put("pkw_retries", c.retries.into());
                put("cycle_pause_ms", (c.cycle_pause.as_micros() / 1000).into());
                put("local_echo", c.local_echo.into());
                let list: Vec<Value> = c
                    .polling_list
                    .iter()
                    .map(|e| {
                        let pkw: u8 = match e.pkw {
                            PkwWords::None => 0,
                            PkwWords::Three => 3,
                            PkwWords::Four => 4,
                            PkwWords::Variable => 127,
                        };
                        serde_json::json!({"address": e.address, "pkw": pkw, "pzd": e.pzd_words})
                    })
                    .collect();
                put("polling_list", list.into());
            }
        }
        Value::Object(m)
    }

    /// The parameter file as TOML.
    pub fn to_toml_string(&self) -> String {
        // A map of numbers, strings, booleans and one array of tables always serializes.
        toml::to_string(&self.to_value()).unwrap_or_default()
    }
}

impl Default for DriverParams {
    /// The ASCII driver with the manual's defaults.
    fn default() -> Self {
        DriverParams::Ascii(AsciiParams::default())
    }
}

impl Serialize for DriverParams {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.to_value().serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for DriverParams {
    /// Reads and checks the whole table; the error lists every wrong value, one per line.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let value = Value::deserialize(deserializer)?;
        DriverParams::from_value(&value).map_err(serde::de::Error::custom)
    }
}

impl From<AsciiParams> for DriverParams {
    fn from(p: AsciiParams) -> Self {
        DriverParams::Ascii(p)
    }
}

impl From<R3964Params> for DriverParams {
    fn from(p: R3964Params) -> Self {
        DriverParams::R3964(p)
    }
}

impl From<ModbusMasterParams> for DriverParams {
    fn from(p: ModbusMasterParams) -> Self {
        DriverParams::ModbusMaster(p)
    }
}

impl From<ModbusSlaveParams> for DriverParams {
    fn from(p: ModbusSlaveParams) -> Self {
        DriverParams::ModbusSlave(p)
    }
}

impl From<UssMasterParams> for DriverParams {
    fn from(p: UssMasterParams) -> Self {
        DriverParams::UssMaster(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_of_every_driver_are_valid_and_round_trip() {
        for p in [
            DriverParams::from(AsciiParams::default()),
            R3964Params::default().into(),
            ModbusMasterParams::default().into(),
            ModbusSlaveParams::default().into(),
            UssMasterParams::default().into(),
        ] {
            assert!(p.check().is_empty(), "{:?}", p.check());
            let toml = p.to_toml_string();
            assert_eq!(DriverParams::from_toml_str(&toml), Ok(p.clone()), "{toml}");
            let json = serde_json::to_string(&p).unwrap();
            assert_eq!(serde_json::from_str::<DriverParams>(&json).unwrap(), p);
        }
    }
}
