//! RK 512 parameters: the 3964(R) link underneath, the response monitoring time TRES, the job
//! length limit and the DW-number convention ([CP 341] §2.2.3, Fig. 2-18/2-19, §2.2.2, §2.3.1).
//!
//! ```
//! use si_rk512::Config;
//!
//! let c: Config = serde_json::from_str(r#"{"response_timeout_ms": 5000}"#).unwrap();
//! assert_eq!(c.response_timeout.as_millis(), 5000);
//! assert_eq!(c.link.max_block_len, 200);
//! let bad = Config { response_timeout: si_core::Duration::from_millis(1), ..Config::default() };
//! assert!(bad.validate().unwrap_err().to_string().contains("response monitoring time (TRES)"));
//! ```
//!
//! # Readings
//!
//! - **TRES (`[derived]`).** The prose says 10 s for every rate from 300 to 76 800 bit/s; the
//!   flowcharts say 5, 7 or 10 s "depending on the rate" without breakpoints. The default is the
//!   prose's 10 s, which is never shorter than the flowchart values; it is a setting
//!   (10 … 655 350 ms, the 3964(R) timer range) for partners that expect the shorter values.
//!   TRES runs from the partner's `DLE` for our telegram, so 3964(R) repetitions do not eat it.
//! - **Job length ([CP 341] §2.2.3).** The manual gives no maximum. A job is limited to
//!   [`Config::max_job_len`] bytes (default 1024, the S7 point-to-point block limit of
//!   [CP 440], [Public 3964R]; at most 65 534, what fits the header's 16-bit length without
//!   overflowing a host buffer needlessly).
//! - **DW number ([Public RK 512]).** Fig. 2-13/2-15 give DW1 as `01` and DW100 as `64H`:
//!   byte 6 counts data words, so DBn.DWm starts at byte 2·m ([`DwUnit::Words`]). A Bosch
//!   document shows "DW 64 = 80H", a byte offset; [`DwUnit::Bytes`] serves such partners.
//! - **Counter letter (`[derived]`).** Our telegrams name counters `'Z'` (5AH);
//!   [`CounterLetter::C`] sends `'C'` (43H) instead. Received telegrams may use either.
//! - **Character frame.** RK 512 runs with 8 data bits ([CP 341] §2.2.3); this is the line's
//!   business (`SerialSettings`), not checked here.

use crate::frame::MAX_TELEGRAM_LEN;
use serde::{Deserialize, Serialize};
use si_3964r::ConfigError;
use si_core::Duration;

/// Range of TRES in ms.
pub const RESPONSE_TIMEOUT_RANGE: (u32, u32) = (10, 655_350);
/// Range of the job length limit in bytes.
pub const MAX_JOB_RANGE: (u32, u32) = (2, 65_534);

/// How header byte 6 (the DW number of D/X jobs) becomes a byte offset in the block.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DwUnit {
    /// Byte 6 counts data words: byte offset = 2 × DW (Fig. 2-13, 2-15; the default).
    #[default]
    Words,
    /// Byte 6 is a byte offset (the Bosch example of [Public RK 512]).
    Bytes,
}

impl DwUnit {
    /// The byte offset of data word `dw`.
    pub const fn offset(self, dw: u8) -> u32 {
        match self {
            DwUnit::Words => dw as u32 * 2,
            DwUnit::Bytes => dw as u32,
        }
    }
}

/// The letter our command telegrams use for counters (`[derived]`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CounterLetter {
    /// `'Z'` (5AH), the German letter the table's hex value shows (the default).
    #[default]
    Z,
    /// `'C'` (43H), for a partner that followed the translated table.
    C,
}

impl CounterLetter {
    /// The byte on the wire.
    pub const fn byte(self) -> u8 {
        match self {
            CounterLetter::Z => b'Z',
            CounterLetter::C => b'C',
        }
    }
}

/// The RK 512 parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Config {
    /// The 3964(R) procedure underneath; its `max_block_len` must hold a full telegram
    /// (10 + 128 bytes).
    pub link: si_3964r::Config,
    /// Response monitoring time TRES, 10 … 655 350 ms, default 10 000 ms (`[derived]`). In files
    /// `response_timeout_ms`.
    #[serde(rename = "response_timeout_ms", with = "si_core::time::millis")]
    pub response_timeout: Duration,
    /// Longest job in bytes (SEND data or FETCH result), 2 … 65 534, default 1024.
    pub max_job_len: u32,
    /// How the passive side reads header byte 6 of D/X jobs.
    pub dw_unit: DwUnit,
    /// The counter letter in our command telegrams (received telegrams may use either).
    pub counter_letter: CounterLetter,
}

impl Default for Config {
    /// 3964(R) defaults, TRES 10 s, jobs up to 1024 bytes, DW numbers in words.
    fn default() -> Self {
        Config {
            link: si_3964r::Config::default(),
            response_timeout: Duration::from_millis(10_000),
            max_job_len: 1024,
            dw_unit: DwUnit::Words,
            counter_letter: CounterLetter::Z,
        }
    }
}

impl Config {
    /// This config on a line with `settings` (the 3964(R) link's, [`si_3964r::Config::settings`]).
    pub fn with_settings(mut self, settings: si_core::SerialSettings) -> Self {
        self.link.settings = settings;
        self
    }

    /// Check every parameter against its range; the error names parameter, range and value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.link.validate()?;
        check(
            "response monitoring time (TRES)",
            RESPONSE_TIMEOUT_RANGE,
            " ms",
            u32::try_from(self.response_timeout.as_millis()).unwrap_or(u32::MAX),
        )?;
        check(
            "maximum job length",
            MAX_JOB_RANGE,
            " bytes",
            self.max_job_len,
        )?;
        let min_block = MAX_TELEGRAM_LEN as u32;
        check(
            "maximum block length of the 3964(R) link under RK 512",
            (min_block, si_3964r::config::MAX_BLOCK_RANGE.1),
            " bytes",
            self.link.max_block_len.into(),
        )
    }
}

fn check(
    parameter: &'static str,
    range: (u32, u32),
    unit: &'static str,
    value: u32,
) -> Result<(), ConfigError> {
    si_core::RangeError::check(parameter, range, unit, value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_small_link_blocks_are_refused() {
        Config::default().validate().unwrap();
        let mut c = Config::default();
        c.link.max_block_len = 100;
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "maximum block length of the 3964(R) link under RK 512 = 100 bytes is out of range: 138 … 1024 bytes"
        );
        c = Config {
            max_job_len: 1,
            ..Config::default()
        };
        assert!(c.validate().is_err());
        assert_eq!(DwUnit::Words.offset(100), 200);
        assert_eq!(DwUnit::Bytes.offset(100), 100);
    }
}
