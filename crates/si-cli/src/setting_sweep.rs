//! The line settings a scan or probe tries: `--bauds 9600,19200 --parities even,none`, every
//! combination, the rest of the character format from the line flags.

use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_core::{Duration, Parity, SerialSettings};

/// `--bauds` and `--parities` of `si modbus scan`, `si uss scan` and `si 3964r probe`.
#[derive(Debug, Clone, Args)]
pub struct Sweep {
    /// The baud rates to try, a list (9600,19200); default: --baud.
    #[arg(
        long = "bauds",
        visible_alias = "baud-rates",
        value_delimiter = ',',
        value_name = "BAUD"
    )]
    bauds: Vec<u32>,
    /// The parities to try, a list (even,none); default: --parity.
    #[arg(long = "parities", value_delimiter = ',', value_name = "PARITY")]
    parities: Vec<String>,
}

impl Sweep {
    /// Every combination of the rates and parities asked for (`base`'s where none are), with
    /// `data_bits` and `base`'s stop bits; `rates` are the baud rates the protocol allows.
    pub fn settings(
        &self,
        base: SerialSettings,
        data_bits: u8,
        rates: &'static [u32],
    ) -> Result<Vec<SerialSettings>, CliError> {
        let bauds = if self.bauds.is_empty() {
            vec![base.baud()]
        } else {
            self.bauds.clone()
        };
        let parities: Vec<Parity> = if self.parities.is_empty() {
            vec![base.parity()]
        } else {
            self.parities
                .iter()
                .map(|p| p.parse().map_err(CliError::bad_argument))
                .collect::<Result<_, _>>()?
        };
        si_core::sweep::settings(&bauds, &parities, (data_bits, base.stop_bits()), rates)
            .map_err(CliError::bad_argument)
    }
}

/// The line a scan or probe prints before its first request: how many stations it asks (`asked`:
/// the noun and the count; none for a probe), at which settings, and the longest it can take.
/// `json` names the run (`{"scan": "modbus"}`); the count, settings and bound are added to it.
pub fn announce(
    out: &Output,
    verb: &str,
    asked: Option<(&str, usize)>,
    settings: &[SerialSettings],
    bound: Duration,
    mut json: serde_json::Value,
) {
    let list: Vec<String> = settings.iter().map(ToString::to_string).collect();
    let stations = asked.map_or(String::new(), |(noun, n)| format!("{n} {noun}(s) at "));
    let text = format!(
        "{verb} {stations}{} line setting(s) ({}): at most {:.1} s",
        list.len(),
        list.join(", "),
        bound.as_micros() as f64 / 1e6
    );
    if let Some((noun, n)) = asked {
        json[format!("{noun}s")] = n.into();
    }
    json["settings"] = list.into();
    json["bound_ms"] = bound.as_millis().into();
    out.line(&text, json);
}

/// The last line of a scan: how many stations answered (`noun`: "unit", "node"), and whether
/// Ctrl-C cut it short (then the error that exits 130).
pub fn summary(
    out: &Output,
    present: usize,
    noun: &str,
    interrupted: bool,
) -> Result<(), CliError> {
    if !out.json {
        let cut = if interrupted { " (interrupted)" } else { "" };
        println!("{present} {noun}(s) answered{cut}");
    }
    if interrupted {
        return Err(CliError::interrupted());
    }
    Ok(())
}
