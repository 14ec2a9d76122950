//! What the bus scans and probes over a list of line settings have in common (`si modbus
//! scan`, `si uss scan`, `si 3964r probe`): the settings they try ([`settings`]), what they
//! report for each station and setting ([`Found`], [`Answer`]), why they stop early
//! ([`SweepError`]), and the longest they take ([`total`], [`OPEN_SLACK`]). What a probe sends,
//! how its outcome reads and how long it may take at one setting stay with each protocol's
//! crate; the sweep itself needs no port, so this module needs no feature.

use crate::{Duration, Parity, SerialSettings, SettingsError, Status};

/// Every combination of `bauds` and `parities` (rates outer, parities inner, in the order
/// given), with `data_bits` and `stop_bits`; each rate must be one of `rates`, the rates the
/// protocol allows.
pub fn settings(
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

/// Opening and closing the port for one line setting, beyond what the protocol's own bound
/// for that setting counts `[derived]`.
pub const OPEN_SLACK: Duration = Duration::from_millis(300);

/// The longest a sweep takes: each setting's own bound (`per_setting`, what the protocol's
/// probes at that setting may take once the port is open) plus [`OPEN_SLACK`] each.
pub fn total(per_setting: impl IntoIterator<Item = Duration>) -> Duration {
    per_setting
        .into_iter()
        .fold(Duration::ZERO, |sum, d| sum + d + OPEN_SLACK)
}

/// What one probe of an addressed station (a Modbus unit, a USS node) found; each protocol's
/// crate says how its outcome reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// A valid answer (an error answer included): a station at this address and these line
    /// settings.
    Present,
    /// Something came back that was not a valid answer, with the STATUS it gave: a device may
    /// be there at other line settings, or two answered at once.
    Garbled(Status),
    /// No answer within the response time.
    Absent,
}

/// A station that answered something at one line setting. `S` names the station (its address,
/// `u8`; `()` for a point-to-point partner, which has none), `A` what it answered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Found<S, A> {
    /// The station.
    pub station: S,
    /// The line settings it answered at.
    pub settings: SerialSettings,
    /// What it answered.
    pub answer: A,
}

/// Why a sweep stopped before its end: the caller's `open` failed (`E`), or the protocol's
/// run at an opened line did (`P`).
#[derive(Debug, thiserror::Error)]
pub enum SweepError<E, P> {
    /// The caller could not open the line for a setting.
    #[error("{0}")]
    Open(E),
    /// The protocol's probe failed otherwise than with an answer.
    #[error("{0}")]
    Run(P),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rate_meets_every_parity_and_a_rate_outside_the_list_is_refused() {
        let all = settings(
            &[9600, 19200],
            &[Parity::Even, Parity::None],
            (8, 1),
            &crate::BAUD_RATES,
        )
        .unwrap();
        assert_eq!(all.len(), 4);
        assert_eq!(all[1].parity(), Parity::None);
        assert_eq!(all[2].baud(), 19200);
        assert!(settings(&[12345], &[Parity::Even], (8, 1), &crate::BAUD_RATES).is_err());
    }

    #[test]
    fn the_total_adds_the_opening_to_every_settings_bound() {
        let ms = Duration::from_millis;
        assert_eq!(total([]), Duration::ZERO);
        assert_eq!(total([ms(10), ms(20)]), ms(30) + OPEN_SLACK + OPEN_SLACK);
    }
}
