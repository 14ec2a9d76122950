//! The partner's memory areas by the names a user writes: `"DB10"`, `"DX3"`, `"E"` or `"I"`,
//! `"A"` or `"Q"`, `"M"` or `"F"`, `"T"`, `"Z"` or `"C"` ([CP 341] §2.2.3, Table 2-1), parsed
//! once here for every front end that takes an area as text.
//!
//! ```
//! use si_rk512::area::Area;
//! use si_rk512::frame::Address;
//!
//! let area: Area = "db10".parse().unwrap();
//! assert_eq!(area.at(1), Ok(Address::Db { db: 10, dw: 1 }));
//! assert_eq!("Q".parse::<Area>().unwrap().at(4), Ok(Address::Outputs(4)));
//! assert!("DB256".parse::<Area>().is_err());
//! ```

use crate::frame::{Address, DataType};
use core::fmt;
use core::str::FromStr;

/// A memory area a SEND or FETCH addresses at the partner: the data type of header byte 4
/// and, for a data block, its number in byte 5 ([CP 341] §2.2.3, Table 2-1).
///
/// Names, case-insensitive: `DBn` and `DXn` (n = 0 … 255, the one byte the header has for it);
/// the table's German letters `E`, `A`, `M`, `T`, `Z`; and the English ones `I`, `Q`, `F`, `C`
/// for the same areas (`[derived]`: the English STEP 5/STEP 7 mnemonics, which the table's
/// translation mixes in, e.g. "'C' (5AH)").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Area {
    /// Data block `DBn` (`'D'`).
    Db(u8),
    /// Extended data block `DXn` (`'X'`).
    Dx(u8),
    /// Input bytes, `E` or `I` (`'E'`).
    Inputs,
    /// Output bytes, `A` or `Q` (`'A'`).
    Outputs,
    /// Flag (memory) bytes, `M` or `F` (`'M'`).
    Flags,
    /// Timer cells, `T` (`'T'`).
    Timers,
    /// Counter cells, `Z` or `C` (`'Z'`).
    Counters,
}

impl Area {
    /// Every name [`FromStr`] accepts, as an error message lists them.
    pub const NAMES: &'static str = "DB0 … DB255, DX0 … DX255, E/I, A/Q, M/F, T, Z/C";

    /// The largest start of a data block job: the data word number has one header byte (6).
    pub const MAX_DATA_WORD: u16 = 255;

    /// The data type letter's meaning.
    pub const fn data_type(self) -> DataType {
        match self {
            Area::Db(_) => DataType::Db,
            Area::Dx(_) => DataType::Dx,
            Area::Inputs => DataType::Inputs,
            Area::Outputs => DataType::Outputs,
            Area::Flags => DataType::Flags,
            Area::Timers => DataType::Timers,
            Area::Counters => DataType::Counters,
        }
    }

    /// The largest start the area takes: [`MAX_DATA_WORD`](Self::MAX_DATA_WORD) in a DB or DX,
    /// else 65535 (bytes 5–6).
    pub const fn max_start(self) -> u16 {
        match self {
            Area::Db(_) | Area::Dx(_) => Self::MAX_DATA_WORD,
            _ => u16::MAX,
        }
    }

    /// The address of a job from `start`: the data word number in a DB or DX (0 … 255,
    /// header byte 6), else the byte number (E, A, M) or cell number (T, Z) of bytes 5–6.
    pub fn at(self, start: u16) -> Result<Address, StartOutOfRange> {
        let dw = || {
            u8::try_from(start).map_err(|_| StartOutOfRange {
                area: self,
                start,
                max: self.max_start(),
            })
        };
        Ok(match self {
            Area::Db(db) => Address::Db { db, dw: dw()? },
            Area::Dx(db) => Address::Dx { db, dw: dw()? },
            Area::Inputs => Address::Inputs(start),
            Area::Outputs => Address::Outputs(start),
            Area::Flags => Address::Flags(start),
            Area::Timers => Address::Timers(start),
            Area::Counters => Address::Counters(start),
        })
    }
}

impl fmt::Display for Area {
    /// `DB10`, `DX3`, `E`, `A`, `M`, `T`, `Z`: the manual's letters, which parse back.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Area::Db(n) => write!(f, "DB{n}"),
            Area::Dx(n) => write!(f, "DX{n}"),
            other => write!(f, "{}", char::from(other.data_type().letter())),
        }
    }
}

impl FromStr for Area {
    type Err = UnknownArea;

    fn from_str(name: &str) -> Result<Area, UnknownArea> {
        let upper = name.to_ascii_uppercase();
        let block = |prefix: &str| {
            upper
                .strip_prefix(prefix)
                .filter(|n| n.bytes().all(|b| b.is_ascii_digit()))
                .and_then(|n| n.parse::<u8>().ok())
        };
        if let Some(n) = block("DB") {
            return Ok(Area::Db(n));
        }
        if let Some(n) = block("DX") {
            return Ok(Area::Dx(n));
        }
        match upper.as_str() {
            "E" | "I" => Ok(Area::Inputs),
            "A" | "Q" => Ok(Area::Outputs),
            "M" | "F" => Ok(Area::Flags),
            "T" => Ok(Area::Timers),
            "Z" | "C" => Ok(Area::Counters),
            _ => Err(UnknownArea {
                value: name.to_owned(),
            }),
        }
    }
}

/// A name that is no RK 512 area: the value and the names accepted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("RK 512 area {value:?} is none of {names}", names = Area::NAMES)]
pub struct UnknownArea {
    /// The name as given.
    pub value: String,
}

/// A start beyond what the area's header bytes hold: a data word above 255 in a DB or DX.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("start {start} is out of range for {area}: data word 0 … {max}")]
pub struct StartOutOfRange {
    /// The area addressed.
    pub area: Area,
    /// The start asked for.
    pub start: u16,
    /// The largest start the area takes.
    pub max: u16,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_of_table_2_1_and_its_english_twin_parses() {
        let names = [
            ("E", Area::Inputs),
            ("i", Area::Inputs),
            ("A", Area::Outputs),
            ("Q", Area::Outputs),
            ("M", Area::Flags),
            ("f", Area::Flags),
            ("T", Area::Timers),
            ("Z", Area::Counters),
            ("c", Area::Counters),
            ("DB0", Area::Db(0)),
            ("db10", Area::Db(10)),
            ("DX255", Area::Dx(255)),
        ];
        for (name, area) in names {
            assert_eq!(name.parse::<Area>(), Ok(area), "{name}");
        }
    }

    #[test]
    fn display_gives_the_manuals_letter_and_parses_back() {
        for area in [
            Area::Db(7),
            Area::Dx(3),
            Area::Inputs,
            Area::Outputs,
            Area::Flags,
            Area::Timers,
            Area::Counters,
        ] {
            assert_eq!(area.to_string().parse::<Area>(), Ok(area));
        }
        assert_eq!(Area::Counters.to_string(), "Z");
        assert_eq!(Area::Inputs.data_type().letter(), b'E');
    }

    #[test]
    fn a_wrong_name_is_refused_naming_the_value_and_the_names() {
        for bad in [
            "", "DB", "DB256", "DB-1", "DB+1", "DX 3", "MB", "X", "D10", "IB0",
        ] {
            let err = bad.parse::<Area>().unwrap_err();
            assert_eq!(err.value, bad);
            let text = err.to_string();
            assert!(text.contains(&format!("{bad:?}")), "{text}");
            assert!(text.contains(Area::NAMES), "{text}");
        }
    }

    #[test]
    fn a_data_block_start_is_one_data_word_byte() {
        assert_eq!(Area::Db(1).at(255), Ok(Address::Db { db: 1, dw: 255 }));
        let err = Area::Dx(2).at(256).unwrap_err();
        assert_eq!((err.start, err.max), (256, 255));
        assert_eq!(
            err.to_string(),
            "start 256 is out of range for DX2: data word 0 … 255"
        );
        assert_eq!(Area::Flags.at(65535), Ok(Address::Flags(65535)));
        assert_eq!(
            (Area::Db(1).max_start(), Area::Timers.max_start()),
            (255, 65535)
        );
        assert_eq!(Area::Counters.at(7), Ok(Address::Counters(7)));
    }
}
