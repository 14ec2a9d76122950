//! Why the passive side refused a partner's telegram: one class 06H STATUS each
//! ([CP 341 Diag] class 06H), and the error number its reaction carries.
//!
//! # The error number sent for each 06xx: **`[inferred]`**
//!
//! No source says which byte 4 the CP 341 sends when it finds a 06xx error as responder
//! ([CP 341 Diag] `[derived]`, last paragraph). The numbers here are the symmetric choice that
//! paragraph suggests, so a requester built to §2.1 reads back the matching 09xx:
//!
//! | 06xx | byte 4 | the requester reads |
//! |---|---|---|
//! | 0601, 0604, 0605 | 10H | 090B byte 1 or 4 wrong |
//! | 0602, 0603 | 16H | 090A byte 3 wrong |
//! | 0606, 0607, 0608, 0609, 060A | 14H | 0903 area missing or number not allowed (§2.1 offers 14H or 0CH for 0606–0608; 14H, "configuration error, e.g. illegal DB number", is the closer text; 0609/060A `[derived]` alike) |
//! | 060B, 060C, 0610, 0611 | 34H | 090C length wrong (060C `[derived]`: a FETCH with data has the wrong length) |
//! | 060D CPU in STOP | 2AH | 090D not restarted |
//! | 060D command not served here | 0AH | 0902 access refused (`[derived]`: 060D names "receive path not set up") |
//! | 060E | 36H | 0908 sequence |
//! | 060F | 32H | 0909 locked by a coordination flag |
//!
//! Verify against a real CP before relying on these bytes.

use crate::status::{self, ErrorNumber};
use si_core::Status;

/// A partner's telegram the passive side refused, by the 06xx row that names the fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ServeError {
    /// 0601: byte 1 neither 00H nor FFH (also byte 2 not 00H, `[derived]`).
    HeaderId,
    /// 0602: byte 3 not a command letter.
    Command,
    /// 0603: a continuation's byte 3 differs from the first telegram's.
    ContinuationCommand,
    /// 0604: byte 4 not a data type, or a command/type pair not served (SEND 'A' to a type
    /// other than 'D', 'O' to other than 'X').
    DataType,
    /// 0605: a continuation's byte 4 differs from the first telegram's.
    ContinuationDataType,
    /// 0606: the DB/DX does not exist.
    DbNumber,
    /// 0607: the start address lies beyond the area.
    StartAddress,
    /// 0608: length 0, over the job limit, or past the end of the area.
    Length,
    /// 0609: coordination flag bit above 7, or its byte outside the flag area.
    CoordinationFlag,
    /// 060A: CPU number not 0 … 4 or FH.
    CpuNumber,
    /// 060B: a SEND telegram with more or less data than the header announced.
    DataAmount,
    /// 060C: a FETCH command telegram with data.
    FetchWithData,
    /// 060D: the CPU is in STOP.
    Stopped,
    /// 060D: this side does not serve the command (SEND or FETCH closed, or an active-only
    /// station).
    NotServed,
    /// 060E: a continuation without a running job, or a first telegram while one was due.
    Sequence,
    /// 060F: the coordination flag is still set.
    Locked,
    /// 0610: shorter than a header.
    TooShort,
    /// 0611: more than 128 data bytes in one telegram.
    ///
    /// [CP 341 Diag] §8.1 row 0611 reads "actual frame length and header length disagree".
    /// `[derived]` The narrower reading: a SEND telegram whose data disagree with its header's
    /// length is 060B ([`ServeError::DataAmount`]) and a FETCH command with data 060C
    /// ([`ServeError::FetchWithData`]), rows of their own; 0611 is left with the telegram no
    /// header can announce, one with more than 128 data bytes ([CP 341] §2.2.3, at most 128 per
    /// telegram).
    FrameLength,
}

impl ServeError {
    /// Every refusal, in 06xx order.
    pub const ALL: [ServeError; 18] = [
        ServeError::HeaderId,
        ServeError::Command,
        ServeError::ContinuationCommand,
        ServeError::DataType,
        ServeError::ContinuationDataType,
        ServeError::DbNumber,
        ServeError::StartAddress,
        ServeError::Length,
        ServeError::CoordinationFlag,
        ServeError::CpuNumber,
        ServeError::DataAmount,
        ServeError::FetchWithData,
        ServeError::Stopped,
        ServeError::NotServed,
        ServeError::Sequence,
        ServeError::Locked,
        ServeError::TooShort,
        ServeError::FrameLength,
    ];

    /// The class 06H STATUS.
    pub const fn status(self) -> Status {
        match self {
            ServeError::HeaderId => status::HEADER_ID,
            ServeError::Command => status::BAD_COMMAND,
            ServeError::ContinuationCommand => status::CONTINUATION_COMMAND,
            ServeError::DataType => status::BAD_DATA_TYPE,
            ServeError::ContinuationDataType => status::CONTINUATION_DATA_TYPE,
            ServeError::DbNumber => status::BAD_DB_NUMBER,
            ServeError::StartAddress => status::START_TOO_HIGH,
            ServeError::Length => status::BAD_LENGTH,
            ServeError::CoordinationFlag => status::BAD_FLAG,
            ServeError::CpuNumber => status::BAD_CPU_NUMBER,
            ServeError::DataAmount => status::DATA_AMOUNT,
            ServeError::FetchWithData => status::FETCH_WITH_DATA,
            ServeError::Stopped | ServeError::NotServed => status::NOT_READY,
            ServeError::Sequence => status::SEQUENCE,
            ServeError::Locked => status::DB_LOCKED,
            ServeError::TooShort => status::TOO_SHORT,
            ServeError::FrameLength => status::FRAME_LENGTH,
        }
    }

    /// The error number the reaction carries (`[inferred]`, see the module docs).
    pub const fn error_number(self) -> ErrorNumber {
        match self {
            ServeError::HeaderId | ServeError::DataType | ServeError::ContinuationDataType => {
                ErrorNumber::BadHeader
            }
            ServeError::Command | ServeError::ContinuationCommand => ErrorNumber::BadCommand,
            ServeError::DbNumber
            | ServeError::StartAddress
            | ServeError::Length
            | ServeError::CoordinationFlag
            | ServeError::CpuNumber => ErrorNumber::NoSuchArea,
            ServeError::DataAmount
            | ServeError::FetchWithData
            | ServeError::TooShort
            | ServeError::FrameLength => ErrorNumber::BadLength,
            ServeError::Stopped => ErrorNumber::NotRunning,
            ServeError::NotServed => ErrorNumber::AccessDenied,
            ServeError::Sequence => ErrorNumber::Sequence,
            ServeError::Locked => ErrorNumber::Locked,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_refusal_is_class_06_and_reads_back_as_a_known_09xx() {
        for e in ServeError::ALL {
            assert_eq!(e.status().class(), 0x06, "{e:?}");
            let back = status::for_error_byte(e.error_number().code()).unwrap();
            assert_ne!(back, status::PARTNER_ERROR_UNKNOWN, "{e:?}");
        }
        assert_eq!(
            ServeError::Locked.error_number().status(),
            status::PARTNER_LOCKED
        );
        assert_eq!(
            ServeError::Sequence.error_number().status(),
            status::PARTNER_SEQUENCE
        );
        // 06xx codes are in the catalog, in 06xx order.
        let codes: Vec<u16> = ServeError::ALL.iter().map(|e| e.status().code()).collect();
        assert!(codes.is_sorted(), "{codes:04X?}");
    }
}
