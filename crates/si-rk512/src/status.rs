//! RK 512 STATUS codes and the error numbers of reaction telegrams
//! (cp341-3964r-rk512-ascii.md §4.3, §7.2, §7.3).
//!
//! The seed names the RK 512 errors but gives neither the error numbers of byte 4 of a reaction
//! telegram (its §8.4 is missing) nor their event numbers (§8.3 missing). What is used here:
//!
//! - **Class 09H "reaction telegram with error"**: the numbers (09)08H … (09)0DH of the CP 341
//!   09/2008 manual (§7.3, marked external).
//! - **Error numbers in byte 4** ([`ErrorNumber`]): the Siemens numbering as public RK 512
//!   drivers document it (WinCC OA RK 512 driver: 0AH access, 0CH data type, 14H DB/address,
//!   16H third byte, 2AH CPU stopped, 32H coordination flag, 34H length, 36H synchronisation);
//!   the matches with the §7.3 texts (coordination flag ↔ 0909, third byte ↔ 090A, length ↔
//!   090C, synchronisation ↔ 0908, not restarted ↔ 090D, data type = 4th byte ↔ 090B) fix the
//!   mapping. WAGO's different numbers (10H, 12H, public-facts.md §2) are not used.
//! - **Derived:** 0902 and 0903 (access refused; DB or address missing) and 0901 (an error
//!   number this table does not know) are not in the sources: they fill the gaps of class 09H.
//! - **Derived:** The active side's own errors (no reaction within TRES, a bad or
//!   out-of-sequence reaction) are named in §7.2 without numbers; they are given 0810, 0813
//!   and 0814 here, in the receive-error class because they concern what was received.

use si_core::status::common;
use si_core::Status;

si_core::status_codes! {
    /// Every RK 512 code of this crate.
    pub static CATALOG;
    pub const PARTNER_ERROR_UNKNOWN = 0x0901 {
        meaning: "reaction telegram with an error number this table does not list",
        remedy: "look the error number up in the partner's documentation",
        source: "cp341-3964r-rk512-ascii.md §4.3 [derived]",
    }
    pub const PARTNER_ACCESS_DENIED = 0x0902 {
        meaning: "the partner refused the access (error number 0AH)",
        remedy: "check that the partner allows SEND or FETCH for this area",
        source: "cp341-3964r-rk512-ascii.md §4.3 [derived]",
    }
    pub const PARTNER_NO_SUCH_AREA = 0x0903 {
        meaning: "at the partner the DB/DX does not exist or is too short, or the address is outside the area (error number 14H)",
        remedy: "check DB number, start address and length against the partner's memory",
        source: "cp341-3964r-rk512-ascii.md §4.3 [derived]",
    }
    pub const PARTNER_SEQUENCE = 0x0908 {
        meaning: "synchronisation error at the partner: continuation telegram without a first telegram (error number 36H); normal after a restart",
        remedy: "repeat the job",
        source: "cp341-3964r-rk512-ascii.md §7.3",
    }
    pub const PARTNER_LOCKED = 0x0909 {
        meaning: "DB/DX locked at the partner by a coordination flag (error number 32H)",
        remedy: "the partner program must reset the flag after processing the data; then repeat the job",
        source: "cp341-3964r-rk512-ascii.md §7.3, §4.8",
    }
    pub const PARTNER_BAD_COMMAND = 0x090A {
        meaning: "3rd command byte wrong at the partner (error number 16H)",
        remedy: "use SEND 'A', SEND DX 'O' or FETCH 'E'",
        source: "cp341-3964r-rk512-ascii.md §7.3",
    }
    pub const PARTNER_BAD_HEADER = 0x090B {
        meaning: "1st or 4th command byte wrong at the partner: telegram id or data type (error number 0CH)",
        remedy: "check the data type: SEND only to D (or X with 'O')",
        source: "cp341-3964r-rk512-ascii.md §7.3",
    }
    pub const PARTNER_BAD_LENGTH = 0x090C {
        meaning: "wrong total telegram length at the partner (error number 34H)",
        remedy: "check the job length and the partner's telegram limits",
        source: "cp341-3964r-rk512-ascii.md §7.3",
    }
    pub const PARTNER_NOT_RUNNING = 0x090D {
        meaning: "partner not yet restarted: its CPU is in STOP (error number 2AH)",
        remedy: "start the partner CPU, then repeat the job",
        source: "cp341-3964r-rk512-ascii.md §7.3",
    }
    pub const RESPONSE_INVALID = 0x0810 {
        meaning: "reaction telegram malformed: wrong header bytes or wrong amount of data",
        remedy: "check the partner; compare its telegrams with `si frame decode rk512`",
        source: "cp341-3964r-rk512-ascii.md §4.3, §7.2 [derived number]",
    }
    pub const RESPONSE_SEQUENCE = 0x0813 {
        meaning: "telegram out of sequence: a first telegram where a continuation was expected, or a reaction nobody waits for",
        remedy: "repeat the job; check that only one job runs per direction",
        source: "cp341-3964r-rk512-ascii.md §4.7, §7.2 [derived number]",
    }
    pub const RESPONSE_TIMEOUT = 0x0814 {
        meaning: "no reaction (or continuation) telegram within the response monitoring time TRES",
        remedy: "check that the partner runs RK 512 and its CPU is in RUN; raise TRES for slow partners",
        source: "cp341-3964r-rk512-ascii.md §4.7, §7.2 [derived number]",
    }
}

/// Every catalog an RK 512 STATUS can come from (RK 512, 3964(R), common).
pub static CATALOGS: &[&[Status]] = &[CATALOG, si_3964r::status::CATALOG, common::CATALOG];

/// A status from its bare code with the manual's text when it is known.
pub fn lookup(code: u16) -> Status {
    Status::lookup(code, CATALOGS)
}

/// The error numbers of byte 4 of a reaction telegram (§4.3) that this crate sends and
/// understands, each with the STATUS the requesting side reports for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorNumber {
    /// 0AH: access refused (the area is not open for this command).
    AccessDenied,
    /// 0CH: 1st or 4th byte wrong (telegram id, or a data type not allowed here).
    BadHeader,
    /// 14H: DB/DX missing or too short, address outside the area.
    NoSuchArea,
    /// 16H: 3rd byte (command) wrong.
    BadCommand,
    /// 2AH: CPU not restarted (STOP).
    NotRunning,
    /// 32H: destination locked by a coordination flag.
    Locked,
    /// 34H: wrong telegram length.
    BadLength,
    /// 36H: synchronisation (continuation without first telegram).
    Sequence,
}

impl ErrorNumber {
    /// Every number, in table order.
    pub const ALL: [ErrorNumber; 8] = [
        ErrorNumber::AccessDenied,
        ErrorNumber::BadHeader,
        ErrorNumber::NoSuchArea,
        ErrorNumber::BadCommand,
        ErrorNumber::NotRunning,
        ErrorNumber::Locked,
        ErrorNumber::BadLength,
        ErrorNumber::Sequence,
    ];

    /// The byte in the reaction telegram.
    pub const fn code(self) -> u8 {
        match self {
            ErrorNumber::AccessDenied => 0x0A,
            ErrorNumber::BadHeader => 0x0C,
            ErrorNumber::NoSuchArea => 0x14,
            ErrorNumber::BadCommand => 0x16,
            ErrorNumber::NotRunning => 0x2A,
            ErrorNumber::Locked => 0x32,
            ErrorNumber::BadLength => 0x34,
            ErrorNumber::Sequence => 0x36,
        }
    }

    /// The number for a byte, if this table knows it.
    pub fn from_code(code: u8) -> Option<ErrorNumber> {
        ErrorNumber::ALL.into_iter().find(|e| e.code() == code)
    }

    /// The STATUS the requesting side reports.
    pub const fn status(self) -> Status {
        match self {
            ErrorNumber::AccessDenied => PARTNER_ACCESS_DENIED,
            ErrorNumber::BadHeader => PARTNER_BAD_HEADER,
            ErrorNumber::NoSuchArea => PARTNER_NO_SUCH_AREA,
            ErrorNumber::BadCommand => PARTNER_BAD_COMMAND,
            ErrorNumber::NotRunning => PARTNER_NOT_RUNNING,
            ErrorNumber::Locked => PARTNER_LOCKED,
            ErrorNumber::BadLength => PARTNER_BAD_LENGTH,
            ErrorNumber::Sequence => PARTNER_SEQUENCE,
        }
    }
}

/// The STATUS for the error byte of a reaction (`None` for 00H, no error).
pub fn for_error_byte(code: u8) -> Option<Status> {
    match code {
        0 => None,
        c => Some(ErrorNumber::from_code(c).map_or(PARTNER_ERROR_UNKNOWN, ErrorNumber::status)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_error_number_has_its_own_class_09_status() {
        let mut seen = std::collections::HashSet::new();
        for e in ErrorNumber::ALL {
            assert_eq!(ErrorNumber::from_code(e.code()), Some(e));
            assert_eq!(e.status().class(), 0x09);
            assert!(seen.insert(e.status().code()));
            assert_eq!(for_error_byte(e.code()), Some(e.status()));
        }
        assert_eq!(for_error_byte(0), None);
        assert_eq!(for_error_byte(0x77), Some(PARTNER_ERROR_UNKNOWN));
        assert_eq!(
            lookup(0x0909).to_string(),
            "16#0909 DB/DX locked at the partner by a coordination flag (error number 32H)"
        );
        assert_eq!(lookup(0x0703), si_3964r::status::SETUP_TIMEOUT);
    }
}
