//! The 16-bit STATUS word of the S7 function blocks.
//!
//! [ET200S SI] §2.13 (Fig. 2-25/2-26): bits 15–13 reserved, bits 12–8 event class,
//! bits 7–0 event number; "the numbering is identical for all FBs". A PLC programmer reads it as
//! `W#16#0708`; we print it as `16#0708` followed by the manual's text.
//!
//! Each protocol crate declares the codes of its manual tables with [`status_codes!`](crate::status_codes):
//! named constants carrying the manual's meaning, remedy and source, plus a catalog slice. That is
//! how a crate "registers" its texts, without any global state. A `Status` built from a bare number
//! ([`Status::from_code`]) can be looked up in a crate's catalog with [`Status::lookup`].

use core::fmt;
use serde::{Deserialize, Serialize};

/// What the manual says about one STATUS code.
#[derive(Debug, PartialEq, Eq)]
pub struct StatusInfo {
    /// The code, e.g. `0x0708`.
    pub code: u16,
    /// The meaning, as the manual's table gives it.
    pub meaning: &'static str,
    /// What the manual tells the user to do.
    pub remedy: &'static str,
    /// Where the code is specified (manual table or spec section).
    pub source: &'static str,
}

/// A STATUS word: event class and event number, with the manual's text when known.
///
/// Two statuses are equal when their codes are equal; the text is documentation.
#[derive(Clone, Copy)]
pub struct Status {
    code: u16,
    info: Option<&'static StatusInfo>,
    /// A remedy that fits this occurrence better than the manual's (see
    /// [`Status::with_remedy`]).
    remedy: Option<&'static str>,
}

impl Status {
    /// "No error" (0000H).
    pub const OK: Status = Status::known(&OK_INFO);

    /// A status described by a catalog entry.
    pub const fn known(info: &'static StatusInfo) -> Status {
        Status {
            code: info.code,
            info: Some(info),
            remedy: None,
        }
    }

    /// A status from its bare code, without text (look it up with [`Status::lookup`]).
    pub const fn from_code(code: u16) -> Status {
        Status {
            code,
            info: None,
            remedy: None,
        }
    }

    /// The code from `catalogs`, with its text if one of them describes it.
    pub fn lookup(code: u16, catalogs: &[&[Status]]) -> Status {
        catalogs
            .iter()
            .flat_map(|c| c.iter())
            .find(|s| s.code == code)
            .copied()
            .unwrap_or(Status::from_code(code))
    }

    /// The 16-bit word.
    pub const fn code(self) -> u16 {
        self.code
    }

    /// Event class (bits 12–8), e.g. 07H "send error", 08H "receive error".
    pub const fn class(self) -> u8 {
        ((self.code >> 8) & 0x1F) as u8
    }

    /// Event number (bits 7–0).
    pub const fn number(self) -> u8 {
        (self.code & 0xFF) as u8
    }

    /// True for 0000H.
    pub const fn is_ok(self) -> bool {
        self.code == 0
    }

    /// The manual's description, if this status carries one.
    pub const fn info(self) -> Option<&'static StatusInfo> {
        self.info
    }

    /// The same STATUS (code, class, number and meaning unchanged) with a remedy that fits
    /// this occurrence better than the manual's: an engine that knows why the error happened
    /// here says so (for example [`crate::delivery::Delivery::annotate`]: a USB adapter's
    /// latency rather than "check the slave").
    pub const fn with_remedy(self, remedy: &'static str) -> Status {
        Status {
            remedy: Some(remedy),
            ..self
        }
    }

    /// This STATUS with its text: itself when it has one, else what `lookup` (a protocol
    /// crate's catalog lookup) says for its code, keeping the remedy given for this occurrence
    /// ([`Status::with_remedy`]). For a STATUS that lost its text on the way, as a bare code
    /// read back from JSON.
    pub fn described_by(self, lookup: impl FnOnce(u16) -> Status) -> Status {
        if self.info.is_some() {
            return self;
        }
        Status {
            remedy: self.remedy,
            ..lookup(self.code)
        }
    }

    /// What the user should do: the remedy given for this occurrence, else the manual's.
    pub fn remedy(self) -> Option<&'static str> {
        self.remedy.or(self.info.map(|i| i.remedy))
    }
}

static OK_INFO: StatusInfo = StatusInfo {
    code: 0x0000,
    meaning: "no error",
    remedy: "-",
    source: "[ET200S SI] §2.13, Table 2-28",
};

impl PartialEq for Status {
    fn eq(&self, other: &Status) -> bool {
        self.code == other.code
    }
}
impl Eq for Status {}

impl core::hash::Hash for Status {
    fn hash<H: core::hash::Hasher>(&self, state: &mut H) {
        self.code.hash(state);
    }
}

impl fmt::Display for Status {
    /// `16#0708 wait for XON or CTS = ON timed out`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "16#{:04X}", self.code)?;
        if let Some(info) = self.info {
            write!(f, " {}", info.meaning)?;
        }
        Ok(())
    }
}

/// A STATUS is an error a user program can propagate with `?` into `Box<dyn Error>`: every
/// handle's error carries one (`Error::status()`), and its `Display` names code and meaning.
impl std::error::Error for Status {}

impl fmt::Debug for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Status(16#{:04X})", self.code)
    }
}

impl Serialize for Status {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u16(self.code)
    }
}

impl<'de> Deserialize<'de> for Status {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        u16::deserialize(d).map(Status::from_code)
    }
}

/// Declares a protocol's STATUS codes: one documented constant per code and a catalog slice for
/// [`Status::lookup`]. Every crate writes its manual tables with it, so text, remedy and source
/// section live in one place.
///
/// ```
/// si_core::status_codes! {
///     /// My protocol's codes.
///     pub static CATALOG;
///     pub const XON_TIMEOUT = 0x0708 {
///         meaning: "wait for XON or CTS = ON timed out",
///         remedy: "check the partner",
///         source: "[ET200S SI] §2.13, Table 2-28",
///     }
/// }
/// assert_eq!(XON_TIMEOUT.code(), 0x0708);
/// assert_eq!(si_core::Status::lookup(0x0708, &[CATALOG]).to_string(),
///            "16#0708 wait for XON or CTS = ON timed out");
/// ```
#[macro_export]
macro_rules! status_codes {
    (
        $(#[$cmeta:meta])* $cvis:vis static $catalog:ident;
        $(
            $vis:vis const $name:ident = $code:literal {
                meaning: $meaning:literal, remedy: $remedy:literal, source: $source:literal $(,)?
            }
        )*
    ) => {
        $(
            #[doc = concat!("`", stringify!($code), "`: ", $meaning, ".\n\nRemedy: ", $remedy, ". (", $source, ")")]
            $vis const $name: $crate::Status = $crate::Status::known(&$crate::StatusInfo {
                code: $code,
                meaning: $meaning,
                remedy: $remedy,
                source: $source,
            });
        )*
        $(#[$cmeta])*
        $cvis static $catalog: &[$crate::Status] = &[$($name),*];
    };
}

/// Codes of class 1EH ("module–CPU communication errors"), 05H and 0BH that every driver shares
/// ([ET200S SI] §2.13, Table 2-28).
pub mod common {
    crate::status_codes! {
        /// Every code of this module, in table order.
        pub static CATALOG;
        pub const NOT_POSSIBLE_IN_MODE = 0x0502 {
            meaning: "job not possible in the module's current mode",
            remedy: "evaluate the diagnostic interrupt and fix the cause",
            source: "[ET200S SI] §2.13, Table 2-28",
        }
        pub const BUFFER_TWO_THIRDS_FULL = 0x0B01 {
            meaning: "receive buffer more than 2/3 full",
            remedy: "none needed; call the receive FB more often",
            source: "[ET200S SI] §2.13, Table 2-28",
        }
        pub const ABORTED_BY_RESET = 0x1E0D {
            meaning: "job aborted by a cold restart, warm restart or reset",
            remedy: "none needed; start the job again",
            source: "[ET200S SI] §2.13, Table 2-28",
        }
        pub const PARAMETER_OUT_OF_RANGE = 0x1E20 {
            meaning: "FB parameter out of range",
            remedy: "bring the FB input within range",
            source: "[ET200S SI] §2.13, Table 2-28",
        }
        pub const INVALID_LEN = 0x1E41 {
            meaning: "invalid number of bytes in the FB's LEN",
            remedy: "use 1 … 200",
            source: "[ET200S SI] §2.13, Table 2-28",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn class_and_number_follow_fig_2_25() {
        // [ET200S SI] §2.13, Fig. 2-25/2-26 example: W#16#1E0D = class 1EH, number 0DH.
        let s = common::ABORTED_BY_RESET;
        assert_eq!(s.class(), 0x1E);
        assert_eq!(s.number(), 0x0D);
        // Bits 15–13 are reserved and not part of the class.
        assert_eq!(Status::from_code(0xFF01).class(), 0x1F);
    }

    #[test]
    fn display_is_s7_style_with_text() {
        assert_eq!(
            common::BUFFER_TWO_THIRDS_FULL.to_string(),
            "16#0B01 receive buffer more than 2/3 full"
        );
        assert_eq!(Status::from_code(0x0708).to_string(), "16#0708");
        assert_eq!(Status::OK.to_string(), "16#0000 no error");
    }

    #[test]
    fn an_occurrence_remedy_replaces_the_manuals_and_changes_nothing_else() {
        let s = common::INVALID_LEN.with_remedy("send less");
        assert_eq!(s, common::INVALID_LEN);
        assert_eq!(s.to_string(), common::INVALID_LEN.to_string());
        assert_eq!(s.remedy(), Some("send less"));
        assert_eq!(common::INVALID_LEN.remedy(), Some("use 1 … 200"));
    }

    #[test]
    fn lookup_finds_text_and_equality_ignores_it() {
        let s = Status::lookup(0x1E41, &[common::CATALOG]);
        assert_eq!(s.info().unwrap().remedy, "use 1 … 200");
        assert_eq!(s, Status::from_code(0x1E41));
        assert!(Status::lookup(0x7777, &[common::CATALOG]).info().is_none());
    }

    #[test]
    fn described_by_fills_in_the_text_and_keeps_the_occurrences_remedy() {
        let lookup = |code| Status::lookup(code, &[common::CATALOG]);
        let known = common::BUFFER_TWO_THIRDS_FULL;
        let bare = Status::from_code(known.code()).with_remedy("read faster");
        let described = bare.described_by(lookup);
        assert_eq!(described.info(), known.info());
        assert_eq!(described.remedy(), Some("read faster"));
        assert_eq!(
            Status::from_code(known.code())
                .described_by(lookup)
                .remedy(),
            known.remedy()
        );
        // A STATUS with its text is kept as it is; an unknown code stays bare.
        let never = |_| panic!("not looked up");
        assert_eq!(known.described_by(never).info(), known.info());
        assert!(Status::from_code(0x7777)
            .described_by(lookup)
            .info()
            .is_none());
    }
}
