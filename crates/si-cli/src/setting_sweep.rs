//! The line settings a scan or probe tries: `--bauds 9600,19200 --parities even,none`, every
//! combination, the rest of the character format from the line flags.

use crate::error::CliError;
use clap::Args;
use si_core::{Parity, SerialSettings};

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
        si_core::port::settings_sweep(&bauds, &parities, (data_bits, base.stop_bits()), rates)
            .map_err(CliError::bad_argument)
    }
}
