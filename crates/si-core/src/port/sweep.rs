//! The line settings a scan or probe tries (`si modbus scan`, `si uss scan`, `si 3964r probe`):
//! every combination of a list of baud rates and parities, the rest of the character format
//! fixed.

use crate::{Parity, SerialSettings, SettingsError};

/// Every combination of `bauds` and `parities` (rates outer, parities inner, in the order
/// given), with `data_bits` and `stop_bits`; each rate must be one of `rates`, the rates the
/// protocol allows.
pub fn settings_sweep(
    bauds: &[u32],
    parities: &[Parity],
    (data_bits, stop_bits): (u8, u8),
    rates: &'static [u32],
) -> Result<Vec<SerialSettings>, SettingsError> {
    let mut all = Vec::with_capacity(bauds.len() * parities.len());
    for &baud in bauds {
        for &parity in parities {
            all.push(SerialSettings::with_rates(
                baud, data_bits, parity, stop_bits, rates,
            )?);
        }
    }
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rate_meets_every_parity_and_a_rate_outside_the_list_is_refused() {
        let all = settings_sweep(
            &[9600, 19200],
            &[Parity::Even, Parity::None],
            (8, 1),
            &crate::BAUD_RATES,
        )
        .unwrap();
        assert_eq!(all.len(), 4);
        assert_eq!(all[1].parity(), Parity::None);
        assert_eq!(all[2].baud(), 19200);
        assert!(settings_sweep(&[12345], &[Parity::Even], (8, 1), &crate::BAUD_RATES).is_err());
    }
}
