//! Serial character format and character timing.
//!
//! The ET 200S SI parameter tables ([ET200S SI 2005] §2.9.3, Table 2-9) offer
//! 110 … 115 200 bit/s in twelve steps, 7 or 8 data bits, 1 or 2 stop bits and parity
//! none/odd/even/"any". Each protocol crate narrows these lists where its manual does.
//!
//! Parity "any" ([ET200S SI] §2.6): the bit is not checked on receive and always
//! sent as 0, which on the wire is space parity; we model it as [`Parity::Space`] plus "don't
//! check", and offer mark parity for partners that need it.

use crate::time::Duration;
use core::fmt;
use serde::{Deserialize, Serialize};

/// The twelve baud rates of the ET 200S SI parameter table ([ET200S SI 2005] §2.9.3, Table 2-9).
pub const BAUD_RATES: [u32; 12] = [
    110, 300, 600, 1_200, 2_400, 4_800, 9_600, 19_200, 38_400, 57_600, 76_800, 115_200,
];

/// Parity bit of a character frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parity {
    /// No parity bit.
    None,
    /// Even parity (the ET 200S default).
    Even,
    /// Odd parity.
    Odd,
    /// Parity bit always 1.
    Mark,
    /// Parity bit always 0. The manuals' "any" parity sends 0 and does not check on receive.
    Space,
}

impl Parity {
    /// Bits the parity adds to a character frame.
    pub const fn bits(self) -> u32 {
        match self {
            Parity::None => 0,
            _ => 1,
        }
    }
}

impl fmt::Display for Parity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Parity::None => "N",
            Parity::Even => "E",
            Parity::Odd => "O",
            Parity::Mark => "M",
            Parity::Space => "S",
        })
    }
}

impl core::str::FromStr for Parity {
    type Err = SettingsError;
    fn from_str(s: &str) -> Result<Self, SettingsError> {
        match s.to_ascii_lowercase().as_str() {
            "none" | "n" => Ok(Parity::None),
            "even" | "e" => Ok(Parity::Even),
            "odd" | "o" => Ok(Parity::Odd),
            "mark" | "m" => Ok(Parity::Mark),
            // The manuals' "any": sent as 0, not checked.
            "space" | "s" | "any" => Ok(Parity::Space),
            _ => Err(SettingsError::Parity(s.to_owned())),
        }
    }
}

/// A setting outside what the manuals allow.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SettingsError {
    /// Baud rate not in the list.
    #[error("baud rate {value} is not one of {allowed:?} bit/s")]
    Baud {
        /// The rejected value.
        value: u32,
        /// The allowed values.
        allowed: &'static [u32],
    },
    /// Data bits other than 7 or 8.
    #[error("data bits {0} out of range: 7 or 8")]
    DataBits(u8),
    /// Stop bits other than 1 or 2.
    #[error("stop bits {0} out of range: 1 or 2")]
    StopBits(u8),
    /// Unknown parity name.
    #[error("parity {0:?} unknown: none, even, odd, mark, space (or any)")]
    Parity(String),
}

/// Character format and speed of a serial line: the "agreed conditions" both partners must share
/// ([ET200S SI] §2.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "RawSettings", into = "RawSettings")]
pub struct SerialSettings {
    baud: u32,
    data_bits: u8,
    parity: Parity,
    stop_bits: u8,
}

#[derive(Serialize, Deserialize)]
struct RawSettings {
    baud: u32,
    data_bits: u8,
    parity: Parity,
    stop_bits: u8,
}

impl TryFrom<RawSettings> for SerialSettings {
    type Error = SettingsError;
    fn try_from(r: RawSettings) -> Result<Self, SettingsError> {
        SerialSettings::new(r.baud, r.data_bits, r.parity, r.stop_bits)
    }
}

impl From<SerialSettings> for RawSettings {
    fn from(s: SerialSettings) -> Self {
        RawSettings {
            baud: s.baud,
            data_bits: s.data_bits,
            parity: s.parity,
            stop_bits: s.stop_bits,
        }
    }
}

impl Default for SerialSettings {
    /// 9600 bit/s, 8 data bits, even parity, 1 stop bit: the manuals' defaults ([ET200S SI 2005]
    /// §2.9.3, Table 2-9).
    fn default() -> Self {
        SerialSettings {
            baud: 9_600,
            data_bits: 8,
            parity: Parity::Even,
            stop_bits: 1,
        }
    }
}

impl SerialSettings {
    /// Validated settings with any of the twelve manual baud rates.
    pub fn new(
        baud: u32,
        data_bits: u8,
        parity: Parity,
        stop_bits: u8,
    ) -> Result<Self, SettingsError> {
        Self::with_rates(baud, data_bits, parity, stop_bits, &BAUD_RATES)
    }

    /// Validated settings whose baud rate must be one of `allowed` (a protocol's narrower list).
    pub fn with_rates(
        baud: u32,
        data_bits: u8,
        parity: Parity,
        stop_bits: u8,
        allowed: &'static [u32],
    ) -> Result<Self, SettingsError> {
        if !allowed.contains(&baud) {
            return Err(SettingsError::Baud {
                value: baud,
                allowed,
            });
        }
        if !(7..=8).contains(&data_bits) {
            return Err(SettingsError::DataBits(data_bits));
        }
        if !(1..=2).contains(&stop_bits) {
            return Err(SettingsError::StopBits(stop_bits));
        }
        Ok(SerialSettings {
            baud,
            data_bits,
            parity,
            stop_bits,
        })
    }

    /// Bits per second.
    pub const fn baud(&self) -> u32 {
        self.baud
    }
    /// Data bits per character (7 or 8).
    pub const fn data_bits(&self) -> u8 {
        self.data_bits
    }
    /// Parity.
    pub const fn parity(&self) -> Parity {
        self.parity
    }
    /// Stop bits (1 or 2).
    pub const fn stop_bits(&self) -> u8 {
        self.stop_bits
    }

    /// Bits one character occupies on the wire: 1 start + data + parity + stop
    /// ([ET200S SI] §2.6: "10-bit or 11-bit frames", 9 … 12 in all combinations the tables allow).
    pub const fn bits_per_char(&self) -> u32 {
        1 + self.data_bits as u32 + self.parity.bits() + self.stop_bits as u32
    }

    /// Time one character occupies on the line, rounded up to a whole microsecond.
    ///
    /// Use [`chars_time`](Self::chars_time) for `n` characters: it rounds once, not `n` times.
    pub const fn char_time(&self) -> Duration {
        self.chars_time(1)
    }

    /// How long after a received character completes the next one may complete when the gap
    /// between them must not exceed `max_gap` (a character delay time, ZVZ / CDT).
    ///
    /// A receiver sees a character only once its stop bit is in, so the next character, which
    /// may *start* up to `max_gap` after this one ended, completes up to one character time
    /// later still; one microsecond (the clock's resolution) more, and the gap was longer than
    /// `max_gap`. A deadline of `now + gap_limit(max_gap)` therefore lets a gap of exactly
    /// `max_gap` pass and catches one of `max_gap` + 1 µs at the moment it is known. The ASCII
    /// and 3964(R) drivers both monitor their character delay time with it.
    pub const fn gap_limit(&self, max_gap: Duration) -> Duration {
        Duration::from_micros(
            max_gap
                .as_micros()
                .saturating_add(self.char_time().as_micros())
                .saturating_add(1),
        )
    }

    /// Time `n` back-to-back characters occupy, `ceil(n × bits × 10⁶ / baud)` µs: exact to the
    /// microsecond with no accumulated rounding, so a simulated byte never arrives early.
    pub const fn chars_time(&self, n: u64) -> Duration {
        let bits = n.saturating_mul(self.bits_per_char() as u64);
        let baud = self.baud as u64;
        Duration::from_micros(bits.saturating_mul(1_000_000).div_ceil(baud))
    }

    /// The mask a receiver applies to a character of this width (0x7F for 7 data bits).
    pub const fn data_mask(&self) -> u8 {
        if self.data_bits == 7 {
            0x7F
        } else {
            0xFF
        }
    }
}

impl fmt::Display for SerialSettings {
    /// `9600 8E1`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {}{}{}",
            self.baud, self.data_bits, self.parity, self.stop_bits
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gap_limit_is_the_gap_plus_one_character_and_a_microsecond() {
        let s = SerialSettings::new(300, 8, Parity::Even, 1).unwrap();
        // 11 bits at 300 bit/s: 36 667 µs per character.
        assert_eq!(
            s.gap_limit(Duration::from_millis(60)).as_micros(),
            60_000 + 36_667 + 1
        );
    }

    #[test]
    fn char_time_counts_start_data_parity_stop() {
        let s = SerialSettings::new(9_600, 8, Parity::Even, 1).unwrap();
        assert_eq!(s.bits_per_char(), 11);
        // 11 / 9600 s = 1145.83 µs, rounded up.
        assert_eq!(s.char_time().as_micros(), 1_146);
        // Ten characters are rounded once: 11 458.33 → 11 459, not 10 × 1146.
        assert_eq!(s.chars_time(10).as_micros(), 11_459);
        let s = SerialSettings::new(115_200, 7, Parity::None, 1).unwrap();
        assert_eq!(s.bits_per_char(), 9);
        let s = SerialSettings::new(110, 8, Parity::Odd, 2).unwrap();
        assert_eq!(s.bits_per_char(), 12);
        assert_eq!(s.char_time().as_micros(), 109_091);
    }

    #[test]
    fn out_of_range_settings_name_the_value() {
        let e = SerialSettings::new(9_601, 8, Parity::Even, 1).unwrap_err();
        assert!(
            e.to_string().starts_with("baud rate 9601 is not one of"),
            "{e}"
        );
        assert_eq!(
            SerialSettings::new(9_600, 6, Parity::Even, 1)
                .unwrap_err()
                .to_string(),
            "data bits 6 out of range: 7 or 8"
        );
        assert_eq!(
            SerialSettings::new(9_600, 8, Parity::Even, 3).unwrap_err(),
            SettingsError::StopBits(3)
        );
        let narrow: &'static [u32] = &[9_600, 19_200];
        assert!(SerialSettings::with_rates(110, 8, Parity::None, 1, narrow).is_err());
    }

    #[test]
    fn any_parity_is_space_and_names_parse() {
        assert_eq!("any".parse::<Parity>().unwrap(), Parity::Space);
        assert_eq!("E".parse::<Parity>().unwrap(), Parity::Even);
        assert!("x".parse::<Parity>().is_err());
    }

    #[test]
    fn serde_validates_on_the_way_in() {
        let s = SerialSettings::default();
        assert_eq!(s.to_string(), "9600 8E1");
        let bad = RawSettings {
            baud: 1,
            data_bits: 8,
            parity: Parity::None,
            stop_bits: 1,
        };
        assert!(SerialSettings::try_from(bad).is_err());
    }
}
