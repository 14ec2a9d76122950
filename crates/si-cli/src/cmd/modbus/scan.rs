//! `si modbus scan`: which units answer, at which line settings. The scan is si-modbus's
//! (`si_modbus::tokio::scan`: one harmless read per unit and setting, one try, the response
//! time of the config); this prints the longest it can take before the first request and each
//! unit found, and Ctrl-C stops it at once with what was found so far.

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_core::SerialSettings;
use si_modbus::scan::Answer;
use si_modbus::tokio::scan::{Found, Scan, ScanError};
use si_modbus::MasterConfig;

/// `si modbus scan` arguments.
#[derive(Debug, Clone, Args)]
pub struct ScanArgs {
    /// The units to ask: a range (1-247) or a list (1,2,10-20).
    #[arg(long, default_value = "1-247", value_name = "UNITS")]
    units: String,
    #[command(flatten)]
    sweep: crate::setting_sweep::Sweep,
    /// The response time in ms: how long each unit is given to start its answer
    /// ([Modbus/USS] §3.4.3, Table 3-17; default 2000, the master's).
    #[arg(long, value_name = "MS")]
    response_timeout_ms: Option<u32>,
}

impl ScanArgs {
    /// Run the scan (`si_modbus::tokio::scan`), printing what it finds.
    pub async fn run(&self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let units = parse_units(&self.units)?;
        let mut config = MasterConfig::default();
        if let Some(ms) = self.response_timeout_ms {
            config.response_timeout = si_core::Duration::from_millis(u64::from(ms));
        }
        let scan = Scan::new(config, self.settings(conn)?, units.clone())
            .map_err(CliError::bad_argument)?;
        let bound = scan.bound();
        crate::setting_sweep::announce(
            out,
            "scanning",
            Some(("unit", units.len())),
            scan.settings(),
            bound,
            serde_json::json!({"scan": "modbus"}),
        );
        let mut present = 0;
        let run = scan.run(
            |s| async move { conn.open_with(&s).await },
            |f| {
                present += usize::from(f.answer == Answer::Present);
                print_found(&f, out);
            },
        );
        // Ctrl-C drops the scan at once: the summary must be out before the process's own
        // Ctrl-C handling ends it.
        let interrupted = tokio::select! {
            r = run => {
                r.map_err(|e| match e {
                    ScanError::Open(e) => e,
                    ScanError::Run(e) => CliError::new(e.to_string()),
                })?;
                false
            }
            _ = tokio::signal::ctrl_c() => true,
        };
        crate::setting_sweep::summary(out, present, "unit", interrupted)
    }

    /// Every combination of the baud rates and parities asked for, the rest of the character
    /// format from the line flags.
    fn settings(&self, conn: &Connection) -> Result<Vec<SerialSettings>, CliError> {
        // Modbus RTU characters have 8 data bits ([Modbus serial] §2.5.1).
        self.sweep
            .settings(conn.settings()?, 8, &si_core::BAUD_RATES)
    }
}

/// `unit 5  19200 8N1  answered`.
fn print_found(f: &Found, out: &Output) {
    let (what, status) = match f.answer {
        Answer::Present => ("answered".to_owned(), None),
        Answer::Garbled(s) => (
            format!("something answered, garbled ({s}): another setting, or two at once?"),
            Some(format!("{:04X}", s.code())),
        ),
        Answer::Absent => ("no answer".to_owned(), None),
    };
    out.line(
        &format!("unit {:<3}  {}  {what}", f.station, f.settings),
        serde_json::json!({
            "unit": f.station,
            "settings": f.settings.to_string(),
            "answered": f.answer == Answer::Present,
            "status": status,
        }),
    );
}

/// `1-247`, `1,2,10-20`: the units in order, each once; 1–247 ([Modbus serial] §2.2: 0 is
/// the broadcast, 248–255 reserved).
fn parse_units(text: &str) -> Result<Vec<u8>, CliError> {
    crate::address_list::parse(text, 1, 247).ok_or_else(|| {
        CliError::usage(format!(
            "--units {text:?}: give units 1-247 as a range (1-247) or a list (1,2,10-20)"
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_are_ranges_and_lists_within_1_to_247() {
        assert_eq!(parse_units("1-3,2,10").unwrap(), vec![1, 2, 3, 10]);
        assert_eq!(parse_units("1-247").unwrap().len(), 247);
        for bad in ["0-5", "1-248", "5-1", "x"] {
            assert!(parse_units(bad).is_err(), "{bad}");
        }
    }
}
