//! Parameter numbers and their page index: how a number above 1999 reaches the drive
//! ([MM 420] p. 115, [G120 Fieldbus] §5.3: PNU ≥ 2000 through the page index in IND's high byte).
//!
//! PKE has room for PNU bits 0–10, of which a drive uses 0…1999. The rest of the number is the
//! **page** p = number div 2000, carried in IND's high byte; IND's low byte is the sub-index.
//! The MICROMASTER 4 rule (MM420 OI p.115) gives the page's bits 0–3 the unusual weights
//! IND bit 15 = 1, bit 12 = 2, bit 13 = 4, bit 14 = 8; the SINAMICS G120 table (FM 04/2018
//! [Modbus/USS] §3.5.4, Table 3-20) adds 60000 → 74H, which puts page bit 4 into IND bit 10. As one
//! formula ([MM 420] p. 115, [G120 Fieldbus] §5.3, "Encoding rule
//! [inferred from the two sources]"):
//!
//! ```text
//! high byte = (p & 1) << 7 | ((p >> 1) & 7) << 4 | ((p >> 4) & 1) << 2
//! ```
//!
//! | Parameter range | Page | IND high byte |
//! |---|---|---|
//! | 0–1999 | 0 | 00H |
//! | 2000–3999 | 1 | 80H |
//! | 4000–5999 | 2 | 10H |
//! | 6000–7999 | 3 | 90H |
//! | 8000–9999 | 4 | 20H |
//! | 10000–11999 | 5 | A0H |
//! | 20000–21999 | 10 | 50H |
//! | 30000–31999 | 15 | F0H |
//! | 60000–61999 | 30 | 74H |
//!
//! **Range chosen:** 0…61 999 ([`MAX_NUMBER`]), pages 0…30. The last row the sources give is
//! 60000–61999; page 31 (62000–63999) would follow the same formula, but no source shows it, so
//! we do not send it. The pages between the rows (16…29) rest on the formula alone, as the
//! source says ("use a table for anything outside the rows above" is a warning we note here:
//! a drive that disagrees would answer AK 7 error 0, illegal parameter number).
//!
//! ```
//! use si_uss::param::ParamAddress;
//! // [MM 420] p. 115, [G120 Fieldbus] §5.3 worked example: p2029[5] → PNU 29 (PKE 01DH with AK), IND 8005H.
//! let (pnu, ind) = ParamAddress::new(2029, 5).unwrap().split().unwrap();
//! assert_eq!((pnu, ind), (0x01D, 0x8005));
//! assert_eq!(ParamAddress::join(pnu, ind), ParamAddress { number: 2029, index: 5 });
//! ```

use core::fmt;
use serde::{Deserialize, Serialize};
use si_core::RangeError;

/// How many parameter numbers one page holds (PNU 0…1999 of PKE).
pub const PAGE_SIZE: u16 = 2000;
/// The highest parameter number we address: the end of the 60000–61999 row of
/// [MM 420] p. 115, [G120 Fieldbus] §5.3 (see "Range chosen" in the module docs).
pub const MAX_NUMBER: u16 = 61_999;

/// The IND high byte for page `page` (0…31; higher bits are ignored).
pub const fn page_byte(page: u8) -> u8 {
    ((page & 1) << 7) | (((page >> 1) & 7) << 4) | (((page >> 4) & 1) << 2)
}

/// The page an IND high byte selects; bits the rule does not use (IND bits 8, 9 and 11) are
/// ignored.
pub const fn page_of(high: u8) -> u8 {
    ((high >> 7) & 1) | (((high >> 4) & 7) << 1) | (((high >> 2) & 1) << 4)
}

/// A parameter number with its sub-index, as a user writes it (P2010, index 1), and its split
/// into PKE bits 0–10 and IND (page index high, sub-index low).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ParamAddress {
    /// The full parameter number.
    pub number: u16,
    /// The array sub-index (IND low byte).
    pub index: u8,
}

impl ParamAddress {
    /// Largest number the page index reaches ([`MAX_NUMBER`]).
    pub const MAX_NUMBER: u16 = MAX_NUMBER;

    /// A checked address: a number above [`MAX_NUMBER`] is a range error naming the parameter.
    pub fn new(number: u16, index: u8) -> Result<ParamAddress, RangeError> {
        RangeError::check("parameter number (PNU)", (0, MAX_NUMBER), "", number)?;
        Ok(ParamAddress { number, index })
    }

    /// PKE's PNU bits and the IND word, `None` above [`MAX_NUMBER`].
    pub const fn split(self) -> Option<(u16, u16)> {
        if self.number > MAX_NUMBER {
            return None;
        }
        let page = (self.number / PAGE_SIZE) as u8;
        let pnu = self.number % PAGE_SIZE;
        Some((pnu, ((page_byte(page) as u16) << 8) | self.index as u16))
    }

    /// Put a PKE's PNU (bits 0–10) and an IND back together: what a response names. A PNU of
    /// 2000–2047 is read literally (it cannot come from [`split`](Self::split)).
    pub const fn join(pnu: u16, ind: u16) -> ParamAddress {
        let page = page_of((ind >> 8) as u8) as u16;
        ParamAddress {
            // At most 31 × 2000 + 2047 = 64 047: no overflow.
            number: page * PAGE_SIZE + (pnu & 0x7FF),
            index: (ind & 0xFF) as u8,
        }
    }
}

impl fmt::Display for ParamAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "P{}:{}", self.number, self.index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [MM 420] p. 115, [G120 Fieldbus] §5.3 table: first number of the range, page, IND high byte.
    const TABLE: [(u16, u8, u8); 9] = [
        (0, 0, 0x00),
        (2000, 1, 0x80),
        (4000, 2, 0x10),
        (6000, 3, 0x90),
        (8000, 4, 0x20),
        (10000, 5, 0xA0),
        (20000, 10, 0x50),
        (30000, 15, 0xF0),
        (60000, 30, 0x74),
    ];

    #[test]
    fn every_table_row_encodes_and_decodes() {
        for (first, page, high) in TABLE {
            assert_eq!(page_byte(page), high, "page {page}");
            assert_eq!(page_of(high), page, "{high:02X}H");
            for number in [first, first + 1999] {
                let (pnu, ind) = ParamAddress { number, index: 7 }.split().unwrap();
                assert_eq!(pnu, number - first, "P{number}");
                assert_eq!(ind, u16::from(high) << 8 | 7, "P{number}");
                assert_eq!(
                    ParamAddress::join(pnu, ind),
                    ParamAddress { number, index: 7 }
                );
            }
        }
    }

    #[test]
    fn the_mm4_weights_give_the_same_page_below_16() {
        // MM420 OI p.115: PNU2 = IND bit 15 × 1 + bit 12 × 2 + bit 13 × 4 + bit 14 × 8.
        for page in 0..16u8 {
            let ind = u16::from(page_byte(page)) << 8;
            let mm4 =
                (ind >> 15 & 1) + (ind >> 12 & 1) * 2 + (ind >> 13 & 1) * 4 + (ind >> 14 & 1) * 8;
            assert_eq!(mm4, u16::from(page));
        }
    }

    #[test]
    fn every_number_in_range_round_trips_and_beyond_is_a_range_error() {
        for number in 0..=MAX_NUMBER {
            let a = ParamAddress { number, index: 255 };
            let (pnu, ind) = a.split().unwrap();
            assert!(pnu < PAGE_SIZE);
            assert_eq!(ParamAddress::join(pnu, ind), a);
        }
        assert_eq!(
            ParamAddress {
                number: 62_000,
                index: 0
            }
            .split(),
            None
        );
        assert_eq!(
            ParamAddress::new(62_000, 0).unwrap_err().to_string(),
            "parameter number (PNU) = 62000 is out of range: 0 … 61999"
        );
    }

    #[test]
    fn unused_ind_bits_do_not_change_the_page() {
        assert_eq!(page_of(0x80 | 0x0B), 1);
        assert_eq!(ParamAddress::join(5, 0x0B00).number, 5);
    }
}
