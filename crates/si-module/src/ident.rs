//! Identification data I&M0 (DS 231) and I&M1 (DS 232): the 64-byte records of the SI module.
//!
//! [ET200S SI 2005] §2.9.4 (Tables 2-10/2-11; chapter 3 refers to the same
//! pages): "all ID data records are 64 bytes long". Each record is a 10-byte header and 54 bytes
//! of identification data:
//!
//! | Bytes | Field | Coding |
//! |---|---|---|
//! | 0–1 | SZL ID | F1 11H |
//! | 2–3 | index | 00 01H (I&M0) or 00 02H (I&M1) |
//! | 4–5 | length of the ID data | 00 38H (56: the index below plus 54 data bytes) |
//! | 6–7 | number of blocks with ID data | 00 01H |
//! | 8–9 | index | the same index again |
//! | 10–63 | ID data of that index | 54 bytes, see [`Im0`] and [`Im1`] |
//!
//! Numbers are MSB first. Texts are visible ASCII characters (20H … 7EH), left-aligned and padded
//! with blanks, as I&M texts are; decoding also accepts 00H padding and strips both.
//!
//! # Readings
//!
//! - **Order number suffix.** The availability note prints "…-0AE0", the device-name field
//!   "…-0AB0" (`[derived]`); the default device name uses the order numbers of [ET200S SI 2005]
//!   §2.1, 6ES7 138-4DF01-0AB0 and 6ES7 138-4DF11-0AB0.
//! - **Software revision** (4 bytes, "firmware version"): coded as in PROFIBUS I&M, a prefix
//!   character ('V' released) and three numbers (functional, bug fix, internal).
//! - **I&M version** is 00 00H as printed (a PROFIBUS I&M device would say 01 01H).
//!
//! # Hand-written, not nom
//!
//! Hand-written because a nom version (commit 261d487 in the history) was longer and
//! no faster: a record is checked to be 64 bytes first, so the fields are read at the offsets
//! the table gives and no read can fail; nom's field tuples hid those offsets, which the text
//! errors report, and needed an error mapping that cannot happen (293 → 306 code lines;
//! `module_im0_decode` 73.5 → 77.2 ns, within noise).

use crate::diag::Variant;
use serde::{Deserialize, Serialize};

/// Length of every record.
pub const RECORD_LEN: usize = 64;
/// Length of the record header.
pub const HEADER_LEN: usize = 10;
/// Identification data bytes per index (Table 2-10: 2 + 20 + 16 + 2 + 4 + 2 + 2 + 2 + 2 + 2; Table
/// 2-11: 32 + 22).
pub const DATA_LEN: usize = 54;
/// SZL ID of the identification records.
pub const SZL_ID: u16 = 0xF111;
/// Manufacturer ID of Siemens AG.
pub const SIEMENS: u16 = 0x002A;
/// Longest plant designation (HID).
pub const HID_LEN: usize = 32;
/// Longest location designation (OKZ).
pub const LOCATION_LEN: usize = 22;
/// Device name (order number) field size.
pub const ORDER_NUMBER_LEN: usize = 20;
/// Serial number field size.
pub const SERIAL_LEN: usize = 16;

/// Which record: index 1 (DS 231, I&M0) or index 2 (DS 232, I&M1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Index {
    /// Index 1, data record 231, read-only: I&M0.
    Im0,
    /// Index 2, data record 232, read/write: I&M1.
    Im1,
}

impl Index {
    /// The index number in the header.
    pub const fn number(self) -> u16 {
        match self {
            Index::Im0 => 1,
            Index::Im1 => 2,
        }
    }

    /// The data record number.
    pub const fn record(self) -> u8 {
        match self {
            Index::Im0 => 231,
            Index::Im1 => 232,
        }
    }
}

/// A firmware version: prefix character and three numbers (`V1.2.3`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SoftwareRevision {
    /// 'V' released, 'R' revision, 'P' prototype, 'U' under test, 'T' test.
    pub prefix: u8,
    /// Functional enhancement.
    pub functional: u8,
    /// Bug fix.
    pub bug_fix: u8,
    /// Internal change.
    pub internal: u8,
}

impl Default for SoftwareRevision {
    /// V1.0.0.
    fn default() -> Self {
        SoftwareRevision {
            prefix: b'V',
            functional: 1,
            bug_fix: 0,
            internal: 0,
        }
    }
}

impl core::fmt::Display for SoftwareRevision {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let p = if self.prefix.is_ascii_graphic() {
            char::from(self.prefix)
        } else {
            '?'
        };
        write!(
            f,
            "{p}{}.{}.{}",
            self.functional, self.bug_fix, self.internal
        )
    }
}

/// I&M0, DS 231 (Table 2-10): read-only identification.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Im0 {
    /// Manufacturer ID, 002AH = Siemens AG.
    pub manufacturer: u16,
    /// Device name: the order number, at most 20 characters.
    pub order_number: String,
    /// Serial number, at most 16 characters, unique per module.
    pub serial_number: String,
    /// Hardware revision (product version).
    pub hardware_revision: u16,
    /// Software (firmware) revision.
    pub software_revision: SoftwareRevision,
    /// Revision counter ("statistic version"); not supported by the module, 0.
    pub revision_counter: u16,
    /// PROFILE_ID, F600H (internal, for DP).
    pub profile_id: u16,
    /// Profile-specific type, 0004H (communication module).
    pub profile_specific_type: u16,
    /// I&M version, 00 00H as printed.
    pub im_version: [u8; 2],
    /// I&M records supported, 0001H (I&M0 and I&M1).
    pub im_supported: u16,
}

impl Im0 {
    /// The manual's values for a module variant with this serial number.
    pub fn for_variant(variant: Variant, serial_number: &str) -> Im0 {
        Im0 {
            manufacturer: SIEMENS,
            order_number: match variant {
                Variant::R3964Ascii => "6ES7 138-4DF01-0AB0",
                Variant::ModbusUss => "6ES7 138-4DF11-0AB0",
            }
            .into(),
            serial_number: serial_number.into(),
            hardware_revision: 1,
            software_revision: SoftwareRevision::default(),
            revision_counter: 0,
            profile_id: 0xF600,
            profile_specific_type: 0x0004,
            im_version: [0, 0],
            im_supported: 0x0001,
        }
    }

    /// The 64-byte DS 231 record.
    pub fn encode(&self) -> Result<[u8; RECORD_LEN], ImError> {
        let mut r = header(Index::Im0);
        let d = &mut r[HEADER_LEN..];
        d[0..2].copy_from_slice(&self.manufacturer.to_be_bytes());
        put_text(
            &mut d[2..22],
            "device name (order number)",
            &self.order_number,
        )?;
        put_text(&mut d[22..38], "serial number", &self.serial_number)?;
        d[38..40].copy_from_slice(&self.hardware_revision.to_be_bytes());
        let s = self.software_revision;
        d[40..44].copy_from_slice(&[s.prefix, s.functional, s.bug_fix, s.internal]);
        d[44..46].copy_from_slice(&self.revision_counter.to_be_bytes());
        d[46..48].copy_from_slice(&self.profile_id.to_be_bytes());
        d[48..50].copy_from_slice(&self.profile_specific_type.to_be_bytes());
        d[50..52].copy_from_slice(&self.im_version);
        d[52..54].copy_from_slice(&self.im_supported.to_be_bytes());
        Ok(r)
    }

    /// Decodes a DS 231 record.
    pub fn decode(bytes: &[u8]) -> Result<Im0, ImError> {
        let d = check_header(bytes, Index::Im0)?;
        let word = |at: usize| u16::from_be_bytes([d[at], d[at + 1]]);
        Ok(Im0 {
            manufacturer: word(0),
            order_number: get_text(d, 2, 20, "device name (order number)")?,
            serial_number: get_text(d, 22, 16, "serial number")?,
            hardware_revision: word(38),
            software_revision: SoftwareRevision {
                prefix: d[40],
                functional: d[41],
                bug_fix: d[42],
                internal: d[43],
            },
            revision_counter: word(44),
            profile_id: word(46),
            profile_specific_type: word(48),
            im_version: [d[50], d[51]],
            im_supported: word(52),
        })
    }
}

/// I&M1, DS 232 (Table 2-11): the plant's designations, read/write.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Im1 {
    /// Higher-level designation (HID, plant designation), at most 32 characters.
    pub hid: String,
    /// Location designation (OKZ), at most 22 characters.
    pub location: String,
}

impl Im1 {
    /// Both designations, checked against their length limits and character set.
    pub fn new(hid: &str, location: &str) -> Result<Im1, ImError> {
        let im1 = Im1 {
            hid: hid.into(),
            location: location.into(),
        };
        im1.encode()?;
        Ok(im1)
    }

    /// The 64-byte DS 232 record.
    pub fn encode(&self) -> Result<[u8; RECORD_LEN], ImError> {
        let mut r = header(Index::Im1);
        put_text(
            &mut r[HEADER_LEN..HEADER_LEN + HID_LEN],
            "plant designation (HID)",
            &self.hid,
        )?;
        put_text(
            &mut r[HEADER_LEN + HID_LEN..],
            "location designation (OKZ)",
            &self.location,
        )?;
        Ok(r)
    }

    /// Decodes a DS 232 record.
    pub fn decode(bytes: &[u8]) -> Result<Im1, ImError> {
        let d = check_header(bytes, Index::Im1)?;
        Ok(Im1 {
            hid: get_text(d, 0, HID_LEN, "plant designation (HID)")?,
            location: get_text(d, HID_LEN, LOCATION_LEN, "location designation (OKZ)")?,
        })
    }
}

/// Either record, as found in the header's index.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Record {
    /// DS 231.
    Im0(Im0),
    /// DS 232.
    Im1(Im1),
}

impl Record {
    /// Decodes a record of either index.
    pub fn decode(bytes: &[u8]) -> Result<Record, ImError> {
        match bytes.get(2..4) {
            Some([0, 2]) => Im1::decode(bytes).map(Record::Im1),
            _ => Im0::decode(bytes).map(Record::Im0),
        }
    }

    /// The 64-byte record.
    pub fn encode(&self) -> Result<[u8; RECORD_LEN], ImError> {
        match self {
            Record::Im0(r) => r.encode(),
            Record::Im1(r) => r.encode(),
        }
    }
}

/// Why a record could not be encoded or decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImError {
    /// The record is not 64 bytes.
    #[error("an identification record is 64 bytes, got {len}")]
    Length {
        /// The length given.
        len: usize,
    },
    /// A header field with the wrong value.
    #[error("header {field} at offset {offset} must be {expected:04X}H, got {found:04X}H")]
    Header {
        /// The field.
        field: &'static str,
        /// Its offset in the record.
        offset: usize,
        /// The value the manual gives.
        expected: u16,
        /// The value found.
        found: u16,
    },
    /// A text longer than its field.
    #[error("{field} is {len} characters long, at most {max} allowed")]
    TooLong {
        /// The field.
        field: &'static str,
        /// The text's length in characters.
        len: usize,
        /// The field size.
        max: usize,
    },
    /// A character I&M texts cannot carry (visible ASCII 20H … 7EH only).
    #[error("{field}: character {found:?} at position {position} is not visible ASCII")]
    Character {
        /// The field.
        field: &'static str,
        /// The character.
        found: char,
        /// Its position in the text (from 1) or its offset in the record.
        position: usize,
    },
}

fn header(index: Index) -> [u8; RECORD_LEN] {
    let mut r = [0u8; RECORD_LEN];
    let n = index.number().to_be_bytes();
    r[0..2].copy_from_slice(&SZL_ID.to_be_bytes());
    r[2..4].copy_from_slice(&n);
    r[4..6].copy_from_slice(&((DATA_LEN + 2) as u16).to_be_bytes());
    r[6..8].copy_from_slice(&1u16.to_be_bytes());
    r[8..10].copy_from_slice(&n);
    r
}

fn check_header(bytes: &[u8], index: Index) -> Result<&[u8], ImError> {
    if bytes.len() != RECORD_LEN {
        return Err(ImError::Length { len: bytes.len() });
    }
    let want = header(index);
    let fields = [
        ("SZL ID", 0),
        ("index", 2),
        ("length of the ID data", 4),
        ("number of blocks", 6),
        ("block index", 8),
    ];
    for (field, offset) in fields {
        let found = u16::from_be_bytes([bytes[offset], bytes[offset + 1]]);
        let expected = u16::from_be_bytes([want[offset], want[offset + 1]]);
        if found != expected {
            return Err(ImError::Header {
                field,
                offset,
                expected,
                found,
            });
        }
    }
    Ok(&bytes[HEADER_LEN..])
}

fn put_text(field_bytes: &mut [u8], field: &'static str, text: &str) -> Result<(), ImError> {
    for (i, c) in text.chars().enumerate() {
        if !(' '..='~').contains(&c) {
            return Err(ImError::Character {
                field,
                found: c,
                position: i + 1,
            });
        }
    }
    let len = text.chars().count();
    if len > field_bytes.len() {
        return Err(ImError::TooLong {
            field,
            len,
            max: field_bytes.len(),
        });
    }
    field_bytes.fill(b' ');
    field_bytes[..len].copy_from_slice(text.as_bytes());
    Ok(())
}

fn get_text(data: &[u8], at: usize, len: usize, field: &'static str) -> Result<String, ImError> {
    let raw = &data[at..at + len];
    let end = raw
        .iter()
        .rposition(|&b| b != b' ' && b != 0)
        .map_or(0, |i| i + 1);
    let mut s = String::with_capacity(end);
    for (i, &b) in raw[..end].iter().enumerate() {
        if !(0x20..=0x7E).contains(&b) {
            return Err(ImError::Character {
                field,
                found: char::from(b),
                position: HEADER_LEN + at + i,
            });
        }
        s.push(char::from(b));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_table_2_10() {
        let r = Im1::default().encode().unwrap();
        assert_eq!(
            r[..10],
            [0xF1, 0x11, 0x00, 0x02, 0x00, 0x38, 0x00, 0x01, 0x00, 0x02]
        );
        assert!(r[10..].iter().all(|&b| b == b' '));
    }
}
