//! The keys of a `kind = "uss"` line: its drives and their net-data structure, checked into a
//! si-uss master configuration.
//!
//! Ranges from the USS master ([Modbus/USS] §3.7.6, Table 3-31, [USS spec] §4.3): bus addresses
//! 0–31, 0–16 PZD words, 0/3/4/variable PKW words, WDH 0–32 767 PKW repetitions (`retries`,
//! default 20), response timeout 1 ms–10 s (default the USS spec's 20 ms). Every other
//! `si_uss::config::MasterConfig::validate` finding is reported under its own name.

use crate::port_config::{check_baud, line_file};
use si_core::RangeError;
use si_uss::config::{ConfigError, MasterConfig, PollEntry, RESPONSE_DELAY_MAX, USS_BAUD_RATES};
use si_uss::frame::PkwWords;

/// Highest USS bus address ([USS spec] §4.3).
pub const MAX_ADDRESS: u8 = 31;
/// Most PZD words of a drive ([Modbus/USS] §3.7.6, Table 3-31).
pub const MAX_PZD_WORDS: u8 = 16;

line_file! {
    /// One `[[line]]` of kind `uss`, as written.
    pub struct UssFile {
        /// The drives' bus addresses (0–31) in the order of `units`, e.g. `"0,5"`; default:
        /// each unit id is its drive's address.
        pub drives: Option<String>,
        /// PZD words per drive (0–16, default 2: STW/HSW out, ZSW/HIW in).
        pub pzd_words: Option<u8>,
        /// PKW words per drive (0, 3, 4 or 127 = variable; default 4).
        pub pkw_words: Option<u8>,
        /// PKW repetitions WDH (default 20).
        pub retries: Option<u8>,
        /// Response timeout (ms, 1–10 000, default the USS spec's 20 ms).
        pub response_timeout_ms: Option<u32>,
    }
}

/// A checked USS line: which unit id is which drive, and the master that polls them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UssLine {
    /// `(unit id, bus address)` of each drive, in polling order.
    pub drives: Vec<(u8, u8)>,
    /// PZD words per drive.
    pub pzd_words: u8,
    /// The master's configuration (its serial settings are filled in when the port opens).
    pub master: MasterConfig,
}

impl UssFile {
    /// Check the line's own keys for its unit ids `units` (the shared keys are checked by
    /// the caller).
    pub fn check(&self, units: &[u8]) -> Result<UssLine, RangeError> {
        let addresses = match self.drives.as_deref() {
            Some(text) => parse_addresses(text, units.len())?,
            None => units.to_vec(),
        };
        for &a in &addresses {
            let key = if self.drives.is_some() {
                "drives"
            } else {
                "units"
            };
            RangeError::check(key, (0, MAX_ADDRESS), " (USS bus address)", a)?;
        }
        check_baud(self.baud.unwrap_or(9600), &USS_BAUD_RATES)?;
        let pzd_words = self.pzd_words.unwrap_or(2);
        RangeError::check("pzd_words", (0, MAX_PZD_WORDS), "", pzd_words)?;
        let pkw_count = self.pkw_words.unwrap_or(4);
        let pkw = PkwWords::from_count(pkw_count)
            .ok_or_else(|| RangeError::new("pkw_words", "0, 3, 4 or 127", "", pkw_count))?;
        let mut master = MasterConfig::new(
            addresses
                .iter()
                .map(|&a| PollEntry::new(a, pkw, pzd_words))
                .collect(),
        );
        let timeout_ms = self
            .response_timeout_ms
            .unwrap_or(RESPONSE_DELAY_MAX.as_millis() as u32);
        RangeError::check("response_timeout_ms", (1, 10_000), " ms", timeout_ms)?;
        master.response_timeout = si_core::Duration::from_millis(timeout_ms.into());
        master.retries = self.retries.map_or(20, u16::from);
        // `local_echo` is the port's (the line opens with it and drops our own bytes there);
        // the master dropping them again would eat the first bytes of each answer.
        master.local_echo = false;
        master.validate().map_err(|e| match e {
            ConfigError::OutOfRange(r) => r,
            other => RangeError::new("drives", "each address once", "", other),
        })?;
        Ok(UssLine {
            drives: units.iter().copied().zip(addresses).collect(),
            pzd_words,
            master,
        })
    }
}

/// `"0,5"`: one bus address per unit id.
fn parse_addresses(text: &str, count: usize) -> Result<Vec<u8>, RangeError> {
    let bad = || {
        RangeError::new(
            "drives",
            format!("{count} bus address(es) 0 … 31, one per unit id, e.g. 0,5"),
            "",
            format!("{text:?}"),
        )
    };
    let addresses = text
        .split(',')
        .map(|a| a.trim().parse::<u8>().map_err(|_| bad()))
        .collect::<Result<Vec<u8>, _>>()?;
    if addresses.len() != count {
        return Err(bad());
    }
    Ok(addresses)
}
