//! The 3964(R) parameters of Table 2-11 with the manual's defaults and ranges
//! ([ET200S SI] §2.7, Table 2-11, §2.9, [ET200S SI 2005] §2.9.3, Table 2-9,
//! [CP 341] §2.2.2, §2.3.1).
//!
//! A value outside its range is rejected with an error naming the parameter, the range and the
//! value, both by [`Config::validate`] (called by [`Link::new`](crate::Link::new)) and when a
//! configuration is deserialized:
//!
//! ```
//! use si_3964r::Config;
//!
//! let c: Config = serde_json::from_str(r#"{"block_check": false}"#).unwrap();
//! assert_eq!(c.ack_delay.as_millis(), 550); // the manual's QVZ default without block check
//! let e = serde_json::from_str::<Config>(r#"{"char_delay_ms": 5}"#).unwrap_err();
//! assert!(e.to_string().contains("character delay time (ZVZ) = 5 ms is out of range: 20 … 655350 ms"));
//! ```
//!
//! # Readings
//!
//! - **QVZ range.** The ET 200S tables ([ET200S SI] §2.7, Table 2-11, [ET200S SI 2005] §2.9.3,
//!   Table 2-9) give 10 … 655 350 ms, the CP 341 table ([CP 341] §2.2.2, §2.3.1) 20 … 655 350 ms.
//!   This crate speaks for the ET 200S module, so the minimum is 10 ms.
//! - **10 ms steps.** The module stores times as counts of 10 ms ([ET200S SI] §2.7, Table 2-11,
//!   derived); a host has microsecond timers, so any whole millisecond in range is accepted and
//!   used as given.
//! - **QVZ default without block check.** 550 ms (Table 2-11, cp341 Table 2-4), not the 500 ms of
//!   the CP 341 flowchart ([CP 341] `[derived]`). It is the default only when `ack_delay_ms` is not
//!   given (`[derived]`: a default, not a forced value).
//! - **Baud-rate minimums.** The ET 200S manuals require a baud-rate-dependent minimum for ZVZ
//!   and QVZ but give no 3964(R) table (`[derived]`); Table 2-9 belongs to the ASCII driver. The
//!   only 3964(R) table in the sources is the CP 341's ([CP 341] §2.2.2, §2.3.1: 300 bit/s 60 ms,
//!   600 bit/s 40 ms, 1200 bit/s 30 ms, 2400 … 76 800 bit/s 20 ms), so
//!   [`Link::new`](crate::Link::new) applies it through [`Config::validate_for`] where it lies
//!   above the ET 200S range floors, that is at 1200 bit/s and below. The CP 341 has no 110 bit/s;
//!   its 300 bit/s value scaled by 300/110 and rounded up to the 10 ms step gives 170 ms there
//!   (derived).
//! - **Clear receive buffer on startup.** "Clear SI receive buffer at startup", no/yes, default
//!   yes ([ET200S SI] §2.9, Table 2-11; [ET200S SI 2005] §2.9.3, Table 2-9). The timer table of
//!   [ET200S SI] §2.7, Table 2-11 leaves it out. It acts on CPU STOP → RUN (§2.11 "CPU startup …
//!   the receive buffer is cleared if configured"), as for ASCII:
//!   [`Link::restart`](crate::Link::restart) drops the blocks still waiting when it is set and
//!   keeps them (to be delivered again, [ET200S SI] §2.12, Table 2-21 of the 2005 manual) when it
//!   is not.

use crate::frame::Mode;
use serde::{Deserialize, Serialize};
use si_core::{Duration, RangeError, SerialSettings};

/// Which partner yields in an initialization conflict ([ET200S SI] §2.7, Fig. 2-16).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Priority {
    /// Yields: answers the partner's STX with DLE and receives first (the manual's default).
    #[default]
    Low,
    /// Keeps waiting for the partner's DLE.
    High,
}

/// Block wait time: how long the receiver waits for the repetition after its NAK, fixed at 4 s
/// ([ET200S SI] §2.7, Fig. 2-15, Table 2-11).
pub const BLOCK_WAIT: Duration = Duration::from_secs(4);

/// Wait for a free receive buffer after STX, fixed at 400 ms ([ET200S SI] §2.7,
/// receiving: STX with no free buffer; Table 2-11).
pub const BUFFER_WAIT: Duration = Duration::from_millis(400);

/// Range of the character delay time in ms (Table 2-11).
pub const CHAR_DELAY_RANGE: (u32, u32) = (20, 655_350);
/// Range of the acknowledgement delay time in ms (Table 2-11, ET 200S).
pub const ACK_DELAY_RANGE: (u32, u32) = (10, 655_350);
/// Range of both attempt counters (Table 2-11).
pub const ATTEMPTS_RANGE: (u32, u32) = (1, 255);
/// Range of the maximum block length: the ET 200S limit is 200 bytes (S_SEND LEN 1 … 200,
/// [ET200S SI] §2.10, Table 2-13); a host may go up to the 1024 bytes of S7 point-to-point blocks
/// ([CP 440], [Public 3964R]).
pub const MAX_BLOCK_RANGE: (u32, u32) = (1, 1024);
/// Range of the receive buffer, in blocks.
pub const RECEIVE_BUFFER_RANGE: (u32, u32) = (1, 255);

/// The CP 341 minimum of ZVZ and QVZ per baud rate ([CP 341] §2.2.2, §2.3.1), for the rates where
/// it is above the ET 200S range floors; 110 bit/s is derived (see the module docs). Columns: baud,
/// minimum in ms, and the two parameter names the error carries.
const BAUD_MINIMUMS: [(u32, u32, &str, &str); 4] = [
    (
        110,
        170,
        "character delay time (ZVZ) at 110 bit/s",
        "acknowledgement delay time (QVZ) at 110 bit/s",
    ),
    (
        300,
        60,
        "character delay time (ZVZ) at 300 bit/s",
        "acknowledgement delay time (QVZ) at 300 bit/s",
    ),
    (
        600,
        40,
        "character delay time (ZVZ) at 600 bit/s",
        "acknowledgement delay time (QVZ) at 600 bit/s",
    ),
    (
        1200,
        30,
        "character delay time (ZVZ) at 1200 bit/s",
        "acknowledgement delay time (QVZ) at 1200 bit/s",
    ),
];

/// A parameter outside its range: every 3964(R) parameter error is a range error, si-core's
/// one [`RangeError`].
pub type ConfigError = RangeError;

/// The 3964(R) parameters (Table 2-11), plus the two bounds a host needs: the longest block and
/// the receive buffer size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "RawConfig")]
pub struct Config {
    /// Protocol mode: 3964(R) with block check (default) or plain 3964.
    pub block_check: bool,
    /// Priority in an initialization conflict; the partners must differ. Default low.
    pub priority: Priority,
    /// Character delay time ZVZ: the longest gap between two received characters.
    /// 20 … 655 350 ms, default 220 ms. In files `char_delay_ms`.
    #[serde(rename = "char_delay_ms", with = "si_core::time::millis")]
    pub char_delay: Duration,
    /// Acknowledgement delay time QVZ in ms: the longest wait for the partner's DLE after STX and
    /// after DLE ETX. 10 … 655 350 ms, default 2000 ms (550 ms without block check). In files
    /// `ack_delay_ms`.
    #[serde(rename = "ack_delay_ms", with = "si_core::time::millis")]
    pub ack_delay: Duration,
    /// Connection attempts (STX) per transmission attempt, 1 … 255, default 6.
    pub connection_attempts: u8,
    /// Transmission attempts of one block, the first included, 1 … 255, default 6; also the
    /// receiver's limit of receptions of one block (`[derived]`).
    pub transmission_attempts: u8,
    /// Longest block in user-data bytes, sent or received, 1 … 1024, default 200 ([ET200S SI]
    /// §2.10, Table 2-13).
    pub max_block_len: u16,
    /// Received blocks held until the application takes them, 1 … 255, default 5 (the module's
    /// 1024-byte buffer holds five 200-byte blocks, `[derived]`). When it is full, an STX starts
    /// the 400 ms buffer wait.
    pub receive_buffer_blocks: u8,
    /// Clear the receive buffer at CPU startup (STOP → RUN, [`Link::restart`](crate::Link::restart));
    /// default yes ([ET200S SI] §2.9, Table 2-11, [ET200S SI 2005] §2.9.3, Table 2-9).
    pub clear_at_startup: bool,
    /// The line's character format: what the async handle's opener opens the port with and
    /// what the driver times tx-done by. Default 9600 bit/s 8E1, the module's default
    /// ([ET200S SI] §2.9, Table 2-11).
    pub settings: SerialSettings,
}

impl Default for Config {
    /// 3964(R), low priority, ZVZ 220 ms, QVZ 2000 ms, 6 and 6 attempts, 200-byte blocks,
    /// receive buffer cleared at startup, 9600 bit/s 8E1.
    fn default() -> Self {
        Config {
            block_check: true,
            priority: Priority::Low,
            char_delay: Duration::from_millis(220),
            ack_delay: Duration::from_millis(2000),
            connection_attempts: 6,
            transmission_attempts: 6,
            max_block_len: 200,
            receive_buffer_blocks: 5,
            clear_at_startup: true,
            settings: SerialSettings::default(),
        }
    }
}

impl Config {
    /// This config on a line with `settings` ([`Config::settings`]).
    pub fn with_settings(self, settings: SerialSettings) -> Self {
        Config { settings, ..self }
    }

    /// The defaults for plain 3964 (no block check): QVZ 550 ms.
    pub fn without_block_check() -> Self {
        Config {
            block_check: false,
            ack_delay: Duration::from_millis(550),
            ..Config::default()
        }
    }

    /// The defaults for `mode`.
    pub fn for_mode(mode: Mode) -> Self {
        match mode {
            Mode::BlockCheck => Config::default(),
            Mode::NoBlockCheck => Config::without_block_check(),
        }
    }

    /// The protocol mode.
    pub fn mode(&self) -> Mode {
        if self.block_check {
            Mode::BlockCheck
        } else {
            Mode::NoBlockCheck
        }
    }

    /// Checks every parameter against its range; the first error found.
    pub fn validate(&self) -> Result<(), ConfigError> {
        match self.validate_all().into_iter().next() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// [`validate`](Self::validate), then ZVZ and QVZ against the minimum for the line's baud
    /// rate ([CP 341] §2.2.2, §2.3.1, see the module docs).
    ///
    /// ```
    /// use si_3964r::Config;
    /// use si_core::{Parity, SerialSettings};
    ///
    /// let slow = SerialSettings::new(300, 8, Parity::Even, 1).unwrap();
    /// let c = Config { char_delay: si_core::Duration::from_millis(40), ..Config::default() };
    /// assert_eq!(
    ///     c.validate_for(&slow).unwrap_err().to_string(),
    ///     "character delay time (ZVZ) at 300 bit/s = 40 ms is out of range: 60 … 655350 ms"
    /// );
    /// assert!(c.validate_for(&SerialSettings::default()).is_ok());
    /// ```
    pub fn validate_for(&self, settings: &SerialSettings) -> Result<(), ConfigError> {
        self.validate()?;
        let Some(&(_, min, zvz, qvz)) = BAUD_MINIMUMS.iter().find(|m| m.0 == settings.baud())
        else {
            return Ok(());
        };
        let (char_delay, ack_delay) = (self.char_delay.as_millis(), self.ack_delay.as_millis());
        for (parameter, value) in [(zvz, char_delay), (qvz, ack_delay)] {
            if value < u64::from(min) {
                return Err(RangeError::between(
                    parameter,
                    u64::from(min),
                    u64::from(CHAR_DELAY_RANGE.1),
                    " ms",
                    value,
                ));
            }
        }
        Ok(())
    }

    /// Checks every parameter against its range and returns every error, in field order, so
    /// a parameter file with several wrong values is reported in one go.
    pub fn validate_all(&self) -> Vec<ConfigError> {
        [
            check(
                "character delay time (ZVZ)",
                CHAR_DELAY_RANGE,
                " ms",
                self.char_delay.as_millis(),
            ),
            check(
                "acknowledgement delay time (QVZ)",
                ACK_DELAY_RANGE,
                " ms",
                self.ack_delay.as_millis(),
            ),
            check(
                "connection attempts",
                ATTEMPTS_RANGE,
                "",
                self.connection_attempts.into(),
            ),
            check(
                "transmission attempts",
                ATTEMPTS_RANGE,
                "",
                self.transmission_attempts.into(),
            ),
            check(
                "maximum block length",
                MAX_BLOCK_RANGE,
                " bytes",
                self.max_block_len.into(),
            ),
            check(
                "receive buffer",
                RECEIVE_BUFFER_RANGE,
                " blocks",
                self.receive_buffer_blocks.into(),
            ),
        ]
        .into_iter()
        .filter_map(Result::err)
        .collect()
    }
}

fn check(
    parameter: &'static str,
    (min, max): (u32, u32),
    unit: &'static str,
    value: u64,
) -> Result<(), ConfigError> {
    RangeError::check(parameter, (min.into(), max.into()), unit, value)
}

/// The serialized form: every field optional, QVZ defaulting by mode, numbers wide so an
/// out-of-range value is reported as given rather than as a type overflow.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    block_check: Option<bool>,
    priority: Option<Priority>,
    char_delay_ms: Option<u64>,
    ack_delay_ms: Option<u64>,
    connection_attempts: Option<u64>,
    transmission_attempts: Option<u64>,
    max_block_len: Option<u64>,
    receive_buffer_blocks: Option<u64>,
    clear_at_startup: Option<bool>,
    settings: Option<SerialSettings>,
}

impl TryFrom<RawConfig> for Config {
    type Error = ConfigError;
    fn try_from(r: RawConfig) -> Result<Config, ConfigError> {
        let base = if r.block_check.unwrap_or(true) {
            Config::default()
        } else {
            Config::without_block_check()
        };
        let zvz = r.char_delay_ms.unwrap_or(base.char_delay.as_millis());
        let qvz = r.ack_delay_ms.unwrap_or(base.ack_delay.as_millis());
        let con = r
            .connection_attempts
            .unwrap_or(base.connection_attempts.into());
        let tx = r
            .transmission_attempts
            .unwrap_or(base.transmission_attempts.into());
        let max = r.max_block_len.unwrap_or(base.max_block_len.into());
        let buf = r
            .receive_buffer_blocks
            .unwrap_or(base.receive_buffer_blocks.into());
        check("character delay time (ZVZ)", CHAR_DELAY_RANGE, " ms", zvz)?;
        check(
            "acknowledgement delay time (QVZ)",
            ACK_DELAY_RANGE,
            " ms",
            qvz,
        )?;
        check("connection attempts", ATTEMPTS_RANGE, "", con)?;
        check("transmission attempts", ATTEMPTS_RANGE, "", tx)?;
        check("maximum block length", MAX_BLOCK_RANGE, " bytes", max)?;
        check("receive buffer", RECEIVE_BUFFER_RANGE, " blocks", buf)?;
        // Every value is now within a range that fits its field.
        let config = Config {
            block_check: base.block_check,
            priority: r.priority.unwrap_or(base.priority),
            char_delay: Duration::from_millis(zvz),
            ack_delay: Duration::from_millis(qvz),
            connection_attempts: con as u8,
            transmission_attempts: tx as u8,
            max_block_len: max as u16,
            receive_buffer_blocks: buf as u8,
            clear_at_startup: r.clear_at_startup.unwrap_or(base.clear_at_startup),
            settings: r.settings.unwrap_or(base.settings),
        };
        config.validate()?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [CP 341] §2.2.2, §2.3.1: below 2400 bit/s ZVZ and QVZ have a per-baud minimum; at and above
    /// it the ET 200S floors (ZVZ 20 ms, QVZ 10 ms) apply unchanged.
    #[test]
    fn baud_minimums_of_cp341_table_apply_below_2400() {
        use si_core::Parity;
        let at = |baud| SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
        let c = |zvz, qvz| Config {
            char_delay: Duration::from_millis(zvz),
            ack_delay: Duration::from_millis(qvz),
            ..Config::default()
        };
        assert!(c(170, 170).validate_for(&at(110)).is_ok());
        let e = c(170, 160).validate_for(&at(110)).unwrap_err();
        assert_eq!(
            (e.parameter, &*e.range, e.value.as_str()),
            (
                "acknowledgement delay time (QVZ) at 110 bit/s",
                "170 … 655350 ms",
                "160"
            )
        );
        assert!(c(59, 2000).validate_for(&at(300)).is_err());
        assert!(c(40, 40).validate_for(&at(600)).is_ok());
        assert!(c(30, 29).validate_for(&at(1200)).is_err());
        assert!(c(20, 10).validate_for(&at(2400)).is_ok());
        assert!(c(20, 10).validate_for(&at(115_200)).is_ok());
    }

    #[test]
    fn defaults_are_table_2_11() {
        let c = Config::default();
        assert_eq!(c.char_delay, Duration::from_millis(220));
        assert_eq!(c.ack_delay, Duration::from_millis(2000));
        assert_eq!((c.connection_attempts, c.transmission_attempts), (6, 6));
        assert_eq!(c.priority, Priority::Low);
        assert!(c.clear_at_startup, "Table 2-11: default yes");
        assert_eq!(c.mode(), Mode::BlockCheck);
        assert_eq!(
            Config::without_block_check().ack_delay,
            Duration::from_millis(550)
        );
        assert_eq!(
            Config::for_mode(Mode::NoBlockCheck).mode(),
            Mode::NoBlockCheck
        );
        assert_eq!(c.validate(), Ok(()));
    }

    #[test]
    fn out_of_range_names_parameter_range_and_value() {
        let c = Config {
            char_delay: Duration::from_millis(19),
            ..Config::default()
        };
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "character delay time (ZVZ) = 19 ms is out of range: 20 … 655350 ms"
        );
        let c = Config {
            ack_delay: Duration::from_millis(655_351),
            ..Config::default()
        };
        assert!(c.validate().unwrap_err().to_string().contains("(QVZ)"));
        let c = Config {
            connection_attempts: 0,
            ..Config::default()
        };
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "connection attempts = 0 is out of range: 1 … 255"
        );
    }

    #[test]
    fn validate_all_reports_every_error() {
        assert!(Config::default().validate_all().is_empty());
        let c = Config {
            char_delay: Duration::from_millis(19),
            connection_attempts: 0,
            max_block_len: 0,
            ..Config::default()
        };
        let all: Vec<String> = c.validate_all().iter().map(|e| e.to_string()).collect();
        assert_eq!(
            all,
            [
                "character delay time (ZVZ) = 19 ms is out of range: 20 … 655350 ms",
                "connection attempts = 0 is out of range: 1 … 255",
                "maximum block length = 0 bytes is out of range: 1 … 1024 bytes",
            ]
        );
        assert_eq!(c.validate().unwrap_err().to_string(), all[0]);
    }

    #[test]
    fn serde_rejects_out_of_range_and_keeps_defaults() {
        let c: Config = serde_json::from_str("{}").unwrap();
        assert_eq!(c, Config::default());
        let e = serde_json::from_str::<Config>(r#"{"transmission_attempts": 256}"#).unwrap_err();
        assert!(e
            .to_string()
            .contains("transmission attempts = 256 is out of range: 1 … 255"));
        let c: Config = serde_json::from_str(
            r#"{"priority": "high", "ack_delay_ms": 10, "clear_at_startup": false}"#,
        )
        .unwrap();
        assert_eq!(
            (c.priority, c.ack_delay.as_millis(), c.clear_at_startup),
            (Priority::High, 10, false)
        );
        let back: Config = serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
        assert_eq!(back, c);
    }
}
