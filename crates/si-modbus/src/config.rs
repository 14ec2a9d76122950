//! Parameters of the Modbus master and slave with the manual's ranges and defaults
//! ([Modbus/USS] §3.3.5, Table 3-11, §3.4.3, §3.5.4, Table 3-17, §5.3, Table 3-20).

use crate::status;
use serde::{Deserialize, Serialize};
use si_core::v24::AutoV24Times;
use si_core::{Duration, RangeError, SerialSettings, Status};

/// "Operating mode" ([Modbus/USS] §3.4.3, §3.5.4).
///
/// Read from a name ([`Mode::from_name`], also when deserialized); a name other than the two
/// modes is the manual's 0E22H "invalid operating mode; driver not ready" ([Modbus/USS] §3.4.3,
/// §3.5.4, §3.6).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", try_from = "String")]
pub enum Mode {
    /// Transmission errors and BREAK before or after a message are reported; in the master a
    /// first response byte other than the address gives 0831H.
    #[default]
    Normal,
    /// A message with a UART error or a leading BREAK is ignored silently; a message starts at
    /// a correctly received slave address (leading garbage skipped); errors after the CRC are
    /// ignored.
    InterferenceSuppression,
}

impl Mode {
    /// The two modes by the names parameter files and the serialized form use.
    pub const NAMES: [(&'static str, Mode); 2] = [
        ("normal", Mode::Normal),
        ("interference-suppression", Mode::InterferenceSuppression),
    ];

    /// The name of this mode in [`Mode::NAMES`].
    pub fn name(self) -> &'static str {
        match self {
            Mode::Normal => Mode::NAMES[0].0,
            Mode::InterferenceSuppression => Mode::NAMES[1].0,
        }
    }

    /// The mode called `name`; any other value is refused with 0E22H, as the module refuses
    /// an invalid operating mode and stays not ready ([Modbus/USS] §3.4.3, §3.5.4, §3.6).
    pub fn from_name(name: &str) -> Result<Mode, ConfigError> {
        Mode::NAMES
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, mode)| *mode)
            .ok_or_else(|| {
                ConfigError::new(
                    "operating mode",
                    "normal, interference-suppression",
                    "",
                    format!("{name:?}"),
                    status::INVALID_MODE,
                )
            })
    }
}

impl core::str::FromStr for Mode {
    type Err = ConfigError;

    fn from_str(name: &str) -> Result<Mode, ConfigError> {
        Mode::from_name(name)
    }
}

impl TryFrom<String> for Mode {
    type Error = ConfigError;

    fn try_from(name: String) -> Result<Mode, ConfigError> {
        Mode::from_name(&name)
    }
}

/// How a received frame ends ([Modbus/USS] §3.3.5, Table 3-11, and a host extension).
///
/// The module ends every frame by silence: "a message is complete when no character arrives for
/// 3.5 × character time" ([Modbus/USS] §3.3.5, Table 3-11). That is [`FrameEnd::Gap`],
/// the default, and what this crate does unless told otherwise.
///
/// [`FrameEnd::Length`] is a **host extension, not the manual**: a PC cannot time gaps below a
/// millisecond (its timers fire 0–2 ms late, and a USB adapter or a pseudo-terminal delivers
/// bytes in chunks), so waiting for the 1 ms gap of 57 600–115 200 bit/s costs 2 ms or more per
/// frame. libmodbus and pymodbus therefore end an RTU frame when the length its header predicts
/// has arrived; with `Length` we do the same, but only when the CRC at that length checks, so
/// anything unexpected (an unknown function code, a corrupt frame, garbage) still ends at the
/// gap and is checked and reported exactly as with `Gap`. See [`crate::rx`] for the lengths.
/// A **master** with `Length` also waits out a pause inside a response whose header predicts
/// more bytes (up to [`si_core::delivery::Delivery::assumed_patience`], 64 ms and a character,
/// per pause), as libmodbus and mbusd wait for late bytes: a slow slave or a device server
/// that stalls mid-answer costs time, not a failed job (`crate::rx::Receiver::set_patient`);
/// an answer cut short for good then fails with 0E52H that much later.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrameEnd {
    /// The module's behaviour ([Modbus/USS] §3.3.5, Table 3-11): a frame ends when the line has
    /// been silent for the gap.
    #[default]
    Gap,
    /// Host extension: a frame also ends as soon as it has the length its header predicts and
    /// its CRC checks; otherwise at the gap as with [`FrameEnd::Gap`].
    Length,
}

impl FrameEnd {
    /// The two frame ends by their names (parameter files, the command line).
    pub const NAMES: [&'static str; 2] = ["gap", "length"];
}

impl core::str::FromStr for FrameEnd {
    type Err = String;

    fn from_str(name: &str) -> Result<FrameEnd, String> {
        match name {
            "gap" => Ok(FrameEnd::Gap),
            "length" => Ok(FrameEnd::Length),
            _ => Err(format!("frame end {name:?}: gap or length")),
        }
    }
}

/// The end-of-frame gap tZVZ_TAB for a baud rate ([Modbus/USS] §3.3.5, Table 3-11).
///
/// Table 3-11 of the Modbus/USS manual gives 4 ms at 9600–38 400 bit/s and 3.5 character
/// times (rounded) below: 8, 16, 32, 64, 128 ms. It has no value for 110 bit/s; there we take
/// 364 ms from the 2005 manual's table ([ET200S SI 2005] §3.4, "115 (sic)").
/// The 2005 table also lists 1 ms at 57 600–115 200 bit/s, rates this module does not offer;
/// we use that value for them. Where the two tables disagree (19 200: 4 vs 2 ms; 38 400: 4 vs
/// 1 ms; 600: 64 vs 65 ms; 300: 128 vs 130 ms) we follow the Modbus/USS module's own manual,
/// which is the module this crate reproduces.
pub const fn gap_table(baud: u32) -> Duration {
    Duration::from_millis(match baud {
        0..=110 => 364,
        111..=300 => 128,
        301..=600 => 64,
        601..=1200 => 32,
        1201..=2400 => 16,
        2401..=4800 => 8,
        4801..=38_400 => 4,
        _ => 1,
    })
}

/// A parameter outside the manual's range: si-core's one [`RangeError`] (parameter, range,
/// unit, value), and the STATUS the module would report.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{range} ({status})")]
pub struct ConfigError {
    /// Which parameter, its range and the value given.
    pub range: RangeError,
    /// The module's parameter-assignment STATUS (0E20H–0E23H).
    pub status: Status,
}

impl ConfigError {
    /// `parameter` = `value` (in `unit`) outside `range`, reported with `status`.
    fn new(
        parameter: &'static str,
        range: &'static str,
        unit: &'static str,
        value: impl std::fmt::Display,
        status: Status,
    ) -> ConfigError {
        ConfigError {
            range: RangeError::new(parameter, range, unit, value),
            status,
        }
    }
}

/// The line parameters master and slave share.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LineConfig {
    /// Character format; always 8 data bits ([Modbus/USS] §3.4.3, §3.5.4, §3.9).
    pub settings: SerialSettings,
    /// Operating mode ([Modbus/USS] §3.4.3, §3.5.4).
    pub mode: Mode,
    /// "Character Delay Multiple" fMUL, 1–10: the gap is tZVZ_TAB × fMUL ([Modbus/USS] §3.3.5,
    /// Table 3-11).
    pub char_delay_multiplier: u8,
    /// Extension for RS-485 transceivers that hear their own transmission (and for the
    /// simulator's bus): drop as many received bytes as were sent. Off by default.
    pub local_echo: bool,
    /// Automatic use of the V.24 signals ([Modbus/USS] §3.2.2; RS-232C, half duplex): `None` (the
    /// default) is "no data flow control". The sequence is si-core's ([`si_core::v24`]), shared
    /// with the ASCII driver; the manual gives no ranges ([Modbus/USS] §3.2.2 `[derived]`), so the
    /// ASCII driver's apply.
    pub auto_v24: Option<AutoV24Times>,
}

impl Default for LineConfig {
    fn default() -> Self {
        LineConfig {
            settings: SerialSettings::default(),
            mode: Mode::Normal,
            char_delay_multiplier: 1,
            local_echo: false,
            auto_v24: None,
        }
    }
}

impl LineConfig {
    /// The end-of-frame gap tZVZ = tZVZ_TAB × fMUL ([Modbus/USS] §3.3.5, Table 3-11).
    pub fn gap(&self) -> Duration {
        gap_table(self.settings.baud()).saturating_mul(self.char_delay_multiplier.max(1) as u64)
    }

    /// Check data bits (0E20H) and the multiplier (0E21H).
    ///
    /// The module runs with fMUL = 1 after reporting 0E21H ([Modbus/USS] §3.3.5, Table 3-11); a
    /// library should not silently change a parameter, so we refuse the value and carry 0E21H in
    /// the error. Parity and stop bits are not checked against the manual's "always 11 bits" rule
    /// ([Modbus/USS] §3.4.3, §3.5.4, §3.9 `[derived]`): its own parameter tables allow 10- and
    /// 12-bit frames, and so do we.
    pub fn validate(&self) -> Result<(), ConfigError> {
        first(self.validate_all())
    }

    /// Like [`validate`](Self::validate), but every error, so a parameter file with several
    /// wrong values is reported in one go.
    pub fn validate_all(&self) -> Vec<ConfigError> {
        let mut errors = Vec::new();
        if self.settings.data_bits() != 8 {
            errors.push(ConfigError::new(
                "data bits",
                "8",
                "",
                self.settings.data_bits(),
                status::DATA_BITS_NOT_8,
            ));
        }
        if !(1..=10).contains(&self.char_delay_multiplier) {
            errors.push(ConfigError::new(
                "character delay multiple",
                "1 … 10",
                "",
                self.char_delay_multiplier,
                status::CHAR_DELAY_MULTIPLIER,
            ));
        }
        // No parameter-assignment code for these times ([Modbus/USS] §3.2.2 [derived]): the FB's
        // "parameter out of range".
        errors.extend(
            self.auto_v24
                .iter()
                .flat_map(AutoV24Times::validate_all)
                .map(|range| ConfigError {
                    range,
                    status: si_core::status::common::PARAMETER_OUT_OF_RANGE,
                }),
        );
        errors
    }
}

fn first(errors: Vec<ConfigError>) -> Result<(), ConfigError> {
    match errors.into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Master parameters ([Modbus/USS] §3.4.3, Table 3-17).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MasterConfig {
    /// Line parameters.
    #[serde(flatten)]
    pub line: LineConfig,
    /// "Response Time", 50 ms … 655 000 ms, default 2000 ms: the wait for the *start* of a
    /// response after the request has been sent ([Modbus/USS] §3.4.3, Table 3-17). In files:
    /// `response_timeout_ms`, an integer of milliseconds.
    #[serde(rename = "response_timeout_ms", with = "millis")]
    pub response_timeout: Duration,
    /// Extension (not in the manual, which has no Modbus retries,
    /// [Modbus/USS] §3.4.3, Table 3-17): how often a request
    /// that timed out or came back corrupt (CRC) is sent again before the job fails. Default 0.
    pub retries: u8,
    /// Extension for [Modbus/USS] §3.4 `[derived]` (the manual does not say how long the master waits after a
    /// broadcast): the turnaround delay in ms after the broadcast has left the line before the
    /// job completes. Default 100 ms, the Modbus over serial line guide's lower bound. In
    /// files: `broadcast_turnaround_ms`.
    #[serde(rename = "broadcast_turnaround_ms", with = "millis")]
    pub broadcast_turnaround: Duration,
}

impl Default for MasterConfig {
    fn default() -> Self {
        MasterConfig {
            line: LineConfig::default(),
            response_timeout: Duration::from_millis(2_000),
            retries: 0,
            broadcast_turnaround: Duration::from_millis(100),
        }
    }
}

impl MasterConfig {
    /// Check every range; the error names the parameter.
    pub fn validate(&self) -> Result<(), ConfigError> {
        first(self.validate_all())
    }

    /// Like [`validate`](Self::validate), but every error.
    pub fn validate_all(&self) -> Vec<ConfigError> {
        let mut errors = self.line.validate_all();
        let range = Duration::from_millis(50)..=Duration::from_millis(655_000);
        if !range.contains(&self.response_timeout) {
            errors.push(ConfigError::new(
                "response time",
                "50 … 655000 ms",
                " ms",
                // "49" or "49.500": Duration's Display without its unit.
                self.response_timeout.to_string().trim_end_matches(" ms"),
                status::INVALID_TIMEOUT_OR_ADDRESS,
            ));
        }
        errors
    }

    /// The wire time of the longest frame at this line's character time (start + data +
    /// parity + stop bits, [Modbus/USS] §3.4.3, §3.5.4, §3.9): [`MAX_ADU`](crate::frame::MAX_ADU) =
    /// 264 bytes, the Modbus specification's 256 raised to what the manual's 2040-bit FC15 needs
    /// ([Modbus/USS] §3.3.6, Table 3-12).
    pub fn max_frame_time(&self) -> Duration {
        self.line.settings.chars_time(crate::frame::MAX_ADU as u64)
    }

    /// What a port that hands bytes over in packets may add to any time judged on the host:
    /// the longest latency a USB adapter has plus one character ([`si_core::delivery`]'s
    /// patience at its largest). The bound's margin; zero would do on a byte-by-byte port.
    pub fn port_margin(&self) -> Duration {
        si_core::delivery::MAX_LATENCY + self.line.settings.char_time()
    }

    /// Host bound (the manual's "Response Time" of [Modbus/USS] §3.4.3, Table 3-17 runs only to the
    /// **start** of a response): how long one response may take once it has started, the longest
    /// frame's wire time + the end-of-frame gap tZVZ ([Modbus/USS] §3.3.5, Table 3-11) +
    /// [`port_margin`](Self::port_margin):
    ///
    /// `264 × t_char + tZVZ + (255 ms + t_char)`
    ///
    /// A valid response that started in time is whole by then; bytes still arriving are noise.
    pub fn max_response_duration(&self) -> Duration {
        self.max_frame_time() + self.line.gap() + self.port_margin()
    }

    /// Host bound on one attempt of a job, from its start to its end whatever the line does:
    ///
    /// `hold + send + wait + response`, where
    /// - hold = [`max_response_duration`](Self::max_response_duration): the request waits for
    ///   silence after a frame in progress ([Modbus/USS] §3.3.5, Table 3-11; [`FrameEnd::Length`]
    ///   only) at most this long;
    /// - send = [`max_frame_time`](Self::max_frame_time) + the data output wait time of
    ///   automatic V.24 ([Modbus/USS] §3.2.2) if configured;
    /// - wait = the response time ([Modbus/USS] §3.4.3, Table 3-17) +
    ///   [`port_margin`](Self::port_margin) (the first byte may reach us a port latency late), or
    ///   the broadcast turnaround if that is longer;
    /// - response = [`max_response_duration`](Self::max_response_duration).
    pub fn attempt_bound(&self) -> Duration {
        let cts = self
            .line
            .auto_v24
            .map_or(Duration::ZERO, |t| t.data_wait_time);
        let wait = (self.response_timeout + self.port_margin()).max(self.broadcast_turnaround);
        self.max_response_duration()
            + self.max_frame_time()
            + cts
            + wait
            + self.max_response_duration()
    }

    /// Host bound on a job as a whole: `(retries + 1) ×` [`attempt_bound`](Self::attempt_bound).
    /// Every master job ends with a STATUS by then (0830H if nothing valid came), see the
    /// crate docs, "Bounds".
    pub fn job_bound(&self) -> Duration {
        self.attempt_bound()
            .saturating_mul(u64::from(self.retries) + 1)
    }
}

/// Slave parameters ([Modbus/USS] §3.5.4, Table 3-20).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlaveConfig {
    /// Line parameters.
    #[serde(flatten)]
    pub line: LineConfig,
    /// "Slave address", 1–255, default 222 as printed in Table 3-20.
    ///
    /// The Modbus/USS manual allows 1–255 ([Modbus/USS] §3.3.2), the 2005 manual's table 1–247
    /// ([Modbus/USS] §3.5.4, Table 3-20 `[derived]`). We accept 1–255 because the module does;
    /// 248–255 are reserved in standard Modbus and a standard master may refuse to address them.
    pub address: u8,
}

impl Default for SlaveConfig {
    fn default() -> Self {
        SlaveConfig {
            line: LineConfig::default(),
            address: 222,
        }
    }
}

impl SlaveConfig {
    /// Check every range; address 0 gives 0E23H.
    pub fn validate(&self) -> Result<(), ConfigError> {
        first(self.validate_all())
    }

    /// Like [`validate`](Self::validate), but every error.
    pub fn validate_all(&self) -> Vec<ConfigError> {
        let mut errors = self.line.validate_all();
        if self.address == 0 {
            errors.push(ConfigError::new(
                "slave address",
                "1 … 255",
                "",
                0,
                status::INVALID_TIMEOUT_OR_ADDRESS,
            ));
        }
        errors
    }
}

/// A time in files: an integer of milliseconds (`response_timeout_ms = 500`), the key named
/// `<name>_ms` while the Rust field is a [`Duration`] named by the manual's term.
pub(crate) mod millis {
    use serde::{Deserialize, Deserializer, Serializer};
    use si_core::Duration;

    pub(crate) fn serialize<S: Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(d.as_millis())
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Duration, D::Error> {
        u64::deserialize(d).map(Duration::from_millis)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::Parity;

    #[test]
    fn gap_table_3_11_times_multiplier() {
        for (baud, ms) in [
            (38_400, 4),
            (19_200, 4),
            (9_600, 4),
            (4_800, 8),
            (2_400, 16),
            (1_200, 32),
            (600, 64),
            (300, 128),
            (110, 364),
        ] {
            assert_eq!(gap_table(baud), Duration::from_millis(ms), "{baud}");
        }
        let mut line = LineConfig {
            char_delay_multiplier: 10,
            ..LineConfig::default()
        };
        assert_eq!(line.gap(), Duration::from_millis(40));
        line.char_delay_multiplier = 11;
        assert_eq!(line.validate().unwrap_err().status.code(), 0x0E21);
    }

    #[test]
    fn ranges_name_parameter_and_status() {
        let c = MasterConfig {
            response_timeout: Duration::from_millis(49),
            ..MasterConfig::default()
        };
        let e = c.validate().unwrap_err();
        assert_eq!(e.status.code(), 0x0E23);
        assert!(e
            .to_string()
            .starts_with("response time = 49 ms is out of range: 50 … 655000 ms"));
        let s = SlaveConfig {
            address: 0,
            ..SlaveConfig::default()
        };
        assert_eq!(s.validate().unwrap_err().status.code(), 0x0E23);
        let seven = LineConfig {
            settings: SerialSettings::new(9600, 7, Parity::Even, 1).unwrap(),
            ..LineConfig::default()
        };
        assert_eq!(seven.validate().unwrap_err().status.code(), 0x0E20);
        assert_eq!(SlaveConfig::default().address, 222);
        assert_eq!(
            MasterConfig::default().response_timeout,
            Duration::from_millis(2_000)
        );
    }

    /// [Modbus/USS] §3.4.3, §3.5.4/§3.6: only the two modes; any other value is 0E22H, from a name
    /// and when a configuration is deserialized.
    #[test]
    fn an_invalid_operating_mode_is_0e22h() {
        for (name, mode) in Mode::NAMES {
            assert_eq!(Mode::from_name(name).unwrap(), mode);
            assert_eq!(mode.name(), name);
        }
        let e = Mode::from_name("fast").unwrap_err();
        assert_eq!(e.status.code(), 0x0E22);
        assert_eq!(
            e.to_string(),
            "operating mode = \"fast\" is out of range: normal, interference-suppression \
             (16#0E22 invalid operating mode; driver not ready)"
        );
        let e = serde_json::from_str::<MasterConfig>(r#"{"mode": "fast"}"#).unwrap_err();
        assert!(e.to_string().contains("16#0E22"), "{e}");
        let c: MasterConfig =
            serde_json::from_str(r#"{"mode": "interference-suppression"}"#).unwrap();
        assert_eq!(c.line.mode, Mode::InterferenceSuppression);
        let c: MasterConfig = serde_json::from_str(r#"{"response_timeout_ms": 500}"#).unwrap();
        assert_eq!(c.response_timeout, Duration::from_millis(500));
        let v = serde_json::to_value(c).unwrap();
        assert_eq!(v["response_timeout_ms"], 500);
        assert_eq!(v["broadcast_turnaround_ms"], 100);
        assert_eq!(
            serde_json::to_value(Mode::InterferenceSuppression).unwrap(),
            "interference-suppression"
        );
    }

    #[test]
    fn validate_all_reports_every_error() {
        let c = MasterConfig {
            line: LineConfig {
                settings: SerialSettings::new(9600, 7, Parity::Even, 1).unwrap(),
                char_delay_multiplier: 0,
                ..LineConfig::default()
            },
            response_timeout: Duration::from_millis(655_001),
            ..MasterConfig::default()
        };
        let codes: Vec<u16> = c.validate_all().iter().map(|e| e.status.code()).collect();
        assert_eq!(codes, [0x0E20, 0x0E21, 0x0E23]);
        assert_eq!(c.validate().unwrap_err().status.code(), 0x0E20);
        let s = SlaveConfig {
            address: 0,
            ..SlaveConfig::default()
        };
        assert_eq!(s.validate_all().len(), 1);
        assert!(SlaveConfig::default().validate_all().is_empty());
    }
}
