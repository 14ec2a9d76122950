//! The keys of a `kind = "uss"` line: its drives and their net-data structure, checked into a
//! si-uss master configuration.
//!
//! Ranges from the USS master ([Modbus/USS] §3.7.6, Table 3-31, [USS spec] §4.3): bus addresses
//! 0–31, 0–16 PZD words, 0/3/4/variable PKW words, WDH 0–32 767 PKW repetitions (`retries`,
//! default 20), response timeout 1 ms–10 s (default the USS spec's 20 ms). Every other
//! `si_uss::config::MasterConfig::validate` finding is reported under its own name.

use super::config::{Device, Kind, Line, LineFile};
use si_core::RangeError;
use si_uss::config::{ConfigError, MasterConfig, PollEntry, RESPONSE_DELAY_MAX, USS_BAUD_RATES};
use si_uss::frame::PkwWords;

/// Highest USS bus address ([USS spec] §4.3).
pub const MAX_ADDRESS: u8 = 31;
/// Most PZD words of a drive ([Modbus/USS] §3.7.6, Table 3-31).
pub const MAX_PZD_WORDS: u8 = 16;

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

impl LineFile {
    /// Check a `uss` line whose device and unit ids are already read.
    pub(super) fn check_uss(
        &self,
        name: String,
        device: Device,
        units: Vec<u8>,
    ) -> Result<Line, RangeError> {
        if self.broadcast {
            return Err(RangeError::new(
                "broadcast",
                "false on a uss line",
                "",
                true,
            ));
        }
        let addresses = match self.drives.as_deref() {
            Some(text) => parse_addresses(text, units.len())?,
            None => units.clone(),
        };
        for &a in &addresses {
            let key = if self.drives.is_some() {
                "drives"
            } else {
                "units"
            };
            RangeError::check(key, (0, MAX_ADDRESS), " (USS bus address)", a)?;
        }
        let baud = self.baud.unwrap_or(9600);
        if !USS_BAUD_RATES.contains(&baud) {
            let rates = format!("{USS_BAUD_RATES:?}");
            return Err(RangeError::new("baud", rates, " bit/s", baud));
        }
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
        self.check_rs485()?;
        let kind = Kind::Uss(UssLine {
            drives: units.iter().copied().zip(addresses).collect(),
            pzd_words,
            master,
        });
        Ok(Line {
            retries: self.retries.unwrap_or(20),
            response_timeout_ms: timeout_ms,
            ..self.port_line(name, device, units, kind)
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

#[cfg(test)]
mod tests {
    use crate::config::File;

    fn check(keys: &str) -> Result<super::UssLine, String> {
        let text = format!("[[line]]\nname = \"d\"\nkind = \"uss\"\ndevice = \"x\"\n{keys}");
        let g = File::from_toml(&text)?.check().map_err(|e| e.to_string())?;
        match g.lines[0].kind.clone() {
            super::Kind::Uss(u) => Ok(u),
            _ => Err("not a uss line".into()),
        }
    }

    #[test]
    fn drives_are_unit_ids_mapped_to_bus_addresses() {
        let u = check("units = \"5,7\"\n").unwrap();
        assert_eq!(u.drives, [(5, 5), (7, 7)]);
        assert_eq!(u.pzd_words, 2);
        assert_eq!(u.master.response_timeout.as_millis(), 20);
        let u = check("units = \"10-11\"\ndrives = \"0, 31\"\npzd_words = 4\n").unwrap();
        assert_eq!(u.drives, [(10, 0), (11, 31)]);
    }

    #[test]
    fn local_echo_is_dropped_once_by_the_port_not_again_by_the_master() {
        let text = "[[line]]\nkind = \"uss\"\ndevice = \"x\"\nunits = \"1\"\nlocal_echo = true\n";
        let g = File::from_toml(text).unwrap().check().unwrap();
        assert!(g.lines[0].local_echo, "the port filters the echo");
        let super::Kind::Uss(u) = &g.lines[0].kind else {
            panic!("not a uss line")
        };
        assert!(!u.master.local_echo, "and the master does not again");
    }

    #[test]
    fn errors_name_the_key_and_the_value() {
        let e = check("units = \"32\"\n").unwrap_err();
        assert!(
            e.contains("line 1 (d): units = 32 (USS bus address) is out of range: 0 … 31"),
            "{e}"
        );
        let e = check("units = \"1\"\ndrives = \"40\"\n").unwrap_err();
        assert!(e.contains("drives = 40"), "{e}");
        let e = check("units = \"1,2\"\ndrives = \"4\"\n").unwrap_err();
        assert!(e.contains("drives = \"4\""), "{e}");
        let e = check("units = \"1\"\npzd_words = 17\n").unwrap_err();
        assert!(e.contains("pzd_words = 17 is out of range: 0 … 16"), "{e}");
        let e = check("units = \"1\"\npkw_words = 2\n").unwrap_err();
        assert!(e.contains("pkw_words = 2"), "{e}");
        let e = check("units = \"1\"\nbaud = 1234\n").unwrap_err();
        assert!(e.contains("baud = 1234 bit/s"), "{e}");
        let e = check("units = \"1\"\nbroadcast = true\n").unwrap_err();
        assert!(e.contains("broadcast = true"), "{e}");
        let e = check("units = \"1\"\nresponse_timeout_ms = 20000\n").unwrap_err();
        assert!(e.contains("response_timeout_ms = 20000 ms"), "{e}");
        let e = File::from_toml("[[line]]\ndevice = \"x\"\nunits = \"1\"\npzd_words = 2\n")
            .unwrap()
            .check()
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("pzd_words = set on a modbus-rtu line is out of range: a key of uss lines"),
            "{e}"
        );
    }
}
