//! RK 512 STATUS codes as the CP 341 reports them ([CP 341 Diag]), and the
//! error numbers of byte 4 of a reaction telegram ([CP 341] §2.2.3, Table 2-2).
//!
//! # Which side raises which class
//!
//! | Class | Raised by | When |
//! |---|---|---|
//! | 05H | the requester (our job), before or after the line | 0515/0516: our own coordination-flag bit or CPU number is out of range, the job is refused at once; 051A: our command telegram could not be sent, after the 3964(R) error (07xxH) that caused it |
//! | 06H | the responder (the partner's job, our passive side) | the partner's command telegram is faulty or cannot be served; our reaction carries an error number ([`crate::refusal`]); 0612 after a 3964(R) error sending our reaction |
//! | 07H/08H | the 3964(R) link underneath | procedure errors ([`si_3964r::status`]) |
//! | 09H | the requester | the partner's reaction carries an error number ≠ 00H ([`for_error_byte`]) |
//! | 0AH | the requester | the partner's reaction is itself faulty, or none came within TRES |
//!
//! Every code below cites its row: `[M]` = the CP 341 manual 09/2008, `[T]` = the TIA Portal
//! help, as [CP 341 Diag] names them. A code marked `[derived]` is one where the
//! table is silent and the number was chosen here.
//!
//! # Chained codes ([CP 341 Diag] "Chained reports")
//!
//! 051A and 0612 follow the procedure error that caused them, which "was placed in STATUS just
//! before". The station emits the 3964(R) code as [`Event::ProcedureError`](crate::Event)
//! and then ends the job with 051A ([`Event::Failed`](crate::Event)) or the partner's job with
//! 0612 ([`Event::ServeAborted`](crate::Event)); the request FBs show the two codes in two
//! successive calls ([`crate::fb`]), and S_RCV hands over both, in that order.
//!
//! # Link codes under RK 512
//!
//! The 3964(R) link underneath is si-3964r's, the ET 200S SI's procedure, and its codes pass
//! through unchanged (as [`Event::ProcedureError`](crate::Event), [`Event::ReceiveError`](crate::Event)
//! and S_RCV). Two of them have a different number in the CP 341's table:
//!
//! | Case | si-rk512 reports (ET 200S link) | CP 341 row |
//! |---|---|---|
//! | the partner repeats fewer times than we wait for | 0809H ([ET200S SI] §2.13, Table 2-28) | 0815H "different numbers of transmission attempts" ([CP 341 Diag] §8.1, `[T]`) |
//! | a received block longer than the maximum | 0850H ([ET200S SI 2005] Table 2-29) | 0816H "received frame longer than the allowed maximum" ([CP 341 Diag] §8.1, `[T]`) |
//!
//! `[derived]` Passed on, not mapped: one link gives one event one number, whether RK 512 runs
//! on it or not, so a program or a log that reads si-3964r's codes reads the same codes here,
//! and [`CATALOGS`] carries their texts. The two rows describe the same cases, so no
//! information is lost.
//!
//! # Codes of the tables this crate never raises
//!
//! 0904 ("request type not allowed": no reaction byte of §2.1 leads to it), 0514 and 0517
//! (the request's own address and length are refused with the FB codes 1E20/1E41 before a
//! telegram exists) are left out of the catalog rather than listed unused. So are:
//!
//! - **0501H** "job aborted because the CP restarted" ([CP 341 Diag] §8.1, class 05H, `[T]`).
//!   A station has no restart of its own under a running job: the engine starts once, and a
//!   job ends only with its outcome, with R on its FB (1E0DH, as every si-core FB reports a
//!   reset) or when the station is dropped (the async handle's `Stopped`).
//! - **0815H** and **0816H** ([CP 341 Diag] §8.1, class 08H, `[T]`): the link reports these
//!   cases as 0809H and 0850H ("Link codes under RK 512" above).

use si_core::status::common;
use si_core::Status;

si_core::status_codes! {
    /// Every RK 512 code of this crate, in table order.
    pub static CATALOG;
    pub const FLAG_BIT_OUT_OF_RANGE = 0x0515 {
        meaning: "coordination-flag bit number of the job out of 0 … 7",
        remedy: "give a flag bit 0 … 7, or no flag (byte FFH, bit FH)",
        source: "[CP 341 Diag] class 05H, row 0515 [T]",
    }
    pub const CPU_NUMBER_OUT_OF_RANGE = 0x0516 {
        meaning: "partner CPU number of the job too high (allowed: none, 0 … 4)",
        remedy: "give CPU 1 … 4, 0 (flag without CPU) or none (FH)",
        source: "[CP 341 Diag] class 05H, row 0516 [T]",
    }
    pub const COMMAND_NOT_SENT = 0x051A {
        meaning: "sending the command telegram failed; the 3964(R) error was reported just before",
        remedy: "look at the 07xxH code reported before this one; check line and partner",
        source: "[CP 341 Diag] class 05H, row 051A [T]; [CP 341 Diag] chained reports",
    }
    pub const HEADER_ID = 0x0601 {
        meaning: "partner's telegram: header byte 1 is neither 00H nor FFH",
        remedy: "check the partner's telegram framing",
        source: "[CP 341 Diag] class 06H, row 0601 [M,T]",
    }
    pub const BAD_COMMAND = 0x0602 {
        meaning: "partner's telegram: header byte 3 (command) is not 'A', 'O' or 'E'",
        remedy: "the partner may only SEND ('A', 'O') or FETCH ('E')",
        source: "[CP 341 Diag] class 06H, row 0602 [M,T] (the [M] reading)",
    }
    pub const CONTINUATION_COMMAND = 0x0603 {
        meaning: "partner's continuation telegram: byte 3 differs from its first telegram",
        remedy: "check the partner's continuation telegrams",
        source: "[CP 341 Diag] class 06H, row 0603 [M,T]",
    }
    pub const BAD_DATA_TYPE = 0x0604 {
        meaning: "partner's telegram: byte 4 (data type) wrong, or a command/type combination that is not supported",
        remedy: "SEND 'A' only to 'D', SEND 'O' only to 'X'; FETCH from D, X, E, A, M, T, Z",
        source: "[CP 341 Diag] class 06H, row 0604 [M,T]",
    }
    pub const CONTINUATION_DATA_TYPE = 0x0605 {
        meaning: "partner's continuation telegram: byte 4 differs from its first telegram",
        remedy: "check the partner's continuation telegrams",
        source: "[CP 341 Diag] class 06H, row 0605 [M,T]",
    }
    pub const BAD_DB_NUMBER = 0x0606 {
        meaning: "partner's telegram: byte 5, the DB/DX number, names a block that does not exist here",
        remedy: "create the block, or correct the partner's DB number",
        source: "[CP 341 Diag] class 06H, row 0606 [M,T]",
    }
    pub const START_TOO_HIGH = 0x0607 {
        meaning: "partner's telegram: bytes 5/6, the start address, lie beyond the area",
        remedy: "correct the partner's start address or enlarge the area",
        source: "[CP 341 Diag] class 06H, row 0607 [M,T]",
    }
    pub const BAD_LENGTH = 0x0608 {
        meaning: "partner's telegram: bytes 7/8, the length, are 0, over the job limit, or run past the end of the area",
        remedy: "correct the partner's length or enlarge the area",
        source: "[CP 341 Diag] class 06H, row 0608 [M,T]",
    }
    pub const BAD_FLAG = 0x0609 {
        meaning: "partner's telegram: bytes 9/10, the coordination flag, name a bit above 7 or a flag byte that does not exist",
        remedy: "give a flag M byte.bit with bit 0 … 7 inside the flag area, or FF FF for none",
        source: "[CP 341 Diag] class 06H, row 0609 [T]",
    }
    pub const BAD_CPU_NUMBER = 0x060A {
        meaning: "partner's telegram: byte 10 high nibble, the CPU number, is not 0 … 4 or FH",
        remedy: "the partner must give CPU 1 … 4, 0 (flag without CPU) or FH (none)",
        source: "[CP 341 Diag] class 06H, row 060A [T]; [CP 341] §2.2.3, Table 2-1",
    }
    pub const DATA_AMOUNT = 0x060B {
        meaning: "partner's SEND telegram carried more or less data than its header announced",
        remedy: "check the partner's length field and data",
        source: "[CP 341 Diag] class 06H, row 060B [T]",
    }
    pub const FETCH_WITH_DATA = 0x060C {
        meaning: "partner's FETCH command telegram carried user data",
        remedy: "a FETCH command is the header only ([CP 341] [derived])",
        source: "[CP 341 Diag] class 06H, row 060C [T]",
    }
    pub const NOT_READY = 0x060D {
        meaning: "partner's telegram arrived while this side could not take it: CPU in STOP, or the command is not served here",
        remedy: "put the CPU into RUN, or open SEND/FETCH on this side",
        source: "[CP 341 Diag] class 06H, row 060D [T]",
    }
    pub const SEQUENCE = 0x060E {
        meaning: "partner's telegram out of sequence: a continuation without a running job, a first telegram while a continuation was due, or the continuation did not come within TRES",
        remedy: "none needed after a restart; else repeat the job",
        source: "[CP 341 Diag] class 06H, row 060E [M,T]; the TRES case [derived]",
    }
    pub const DB_LOCKED = 0x060F {
        meaning: "the partner's job names a coordination flag that is still set: the area is locked",
        remedy: "the CPU program resets the flag once it has processed the data; the partner repeats",
        source: "[CP 341 Diag] class 06H, row 060F [M,T]",
    }
    pub const TOO_SHORT = 0x0610 {
        meaning: "partner's telegram too short (< 4 bytes, or < 10 bytes for a command telegram)",
        remedy: "check the partner's telegram framing",
        source: "[CP 341 Diag] class 06H, row 0610 [M,T]",
    }
    pub const FRAME_LENGTH = 0x0611 {
        meaning: "partner's telegram longer than any RK 512 telegram may be (more than 128 data bytes)",
        remedy: "the partner must split jobs into telegrams of 128 data bytes",
        source: "[CP 341 Diag] §8.1 class 06H, row 0611 [M,T] \"actual frame length and header length disagree\"; raised only for more than 128 data bytes [derived]: the other disagreements have rows of their own, 060B (SEND data) and 060C (FETCH with data)",
    }
    pub const REACTION_NOT_SENT = 0x0612 {
        meaning: "sending our reaction telegram failed; the 3964(R) error was reported just before",
        remedy: "look at the 07xxH code reported before this one; the partner repeats its job",
        source: "[CP 341 Diag] class 06H, row 0612 [M,T]; [CP 341 Diag] chained reports",
    }
    pub const PARTNER_NO_AREA = 0x0902 {
        meaning: "the partner reports that the memory area does not exist or may not be accessed",
        remedy: "check the area and the partner's access rights",
        source: "[CP 341 Diag] class 09H, row 0902 [T]",
    }
    pub const PARTNER_NO_SUCH_DB = 0x0903 {
        meaning: "the partner reports the DB/DX missing or too short, or a number not allowed",
        remedy: "check DB number, start address and length against the partner's memory",
        source: "[CP 341 Diag] class 09H, row 0903 [T]",
    }
    pub const PARTNER_CANNOT_SERVE = 0x0905 {
        meaning: "the partner cannot serve the job: data type not allowed, memory fault or internal fault",
        remedy: "check the data type the partner accepts",
        source: "[CP 341 Diag] class 09H, row 0905 [T]",
    }
    pub const PARTNER_SEQUENCE = 0x0908 {
        meaning: "the partner found a sequence (synchronisation) error; normal after a restart",
        remedy: "repeat the job",
        source: "[CP 341 Diag] class 09H, row 0908 [M,T]",
    }
    pub const PARTNER_LOCKED = 0x0909 {
        meaning: "target DB/DX locked at the partner by a coordination flag",
        remedy: "the partner program must reset the flag after processing the data; then repeat the job",
        source: "[CP 341 Diag] class 09H, row 0909 [M,T]",
    }
    pub const PARTNER_BAD_COMMAND = 0x090A {
        meaning: "the partner found header byte 3 (command) wrong",
        remedy: "use SEND 'A', SEND DX 'O' or FETCH 'E'",
        source: "[CP 341 Diag] class 09H, row 090A [M,T]",
    }
    pub const PARTNER_BAD_HEADER = 0x090B {
        meaning: "the partner found header byte 1 or 4 (telegram id or data type) wrong",
        remedy: "check the data type: SEND only to D (or X with 'O')",
        source: "[CP 341 Diag] class 09H, row 090B [M,T]",
    }
    pub const PARTNER_BAD_LENGTH = 0x090C {
        meaning: "the partner found the total telegram length wrong",
        remedy: "check the job length and the partner's telegram limits",
        source: "[CP 341 Diag] class 09H, row 090C [M,T]",
    }
    pub const PARTNER_NOT_RUNNING = 0x090D {
        meaning: "the partner has not restarted yet (its CPU or CP is not in RUN)",
        remedy: "start the partner, then repeat the job",
        source: "[CP 341 Diag] class 09H, row 090D [M,T]",
    }
    pub const PARTNER_ERROR_UNKNOWN = 0x090E {
        meaning: "the reaction carried an error number this side does not know",
        remedy: "look the error number up in the partner's documentation",
        source: "[CP 341 Diag] class 09H, row 090E [M,T]",
    }
    pub const REACTION_SEQUENCE = 0x0A01 {
        meaning: "reaction out of sequence: a reaction without a request, a first reaction where a continuation reaction was due, or the reverse",
        remedy: "none needed after a restart or a reset job; else repeat the job",
        source: "[CP 341 Diag] class 0AH, row 0A01 [M,T]",
    }
    pub const REACTION_HEADER = 0x0A02 {
        meaning: "reaction header faulty: byte 1 neither 00H nor FFH (also byte 2 not 00H, or under 4 bytes)",
        remedy: "check the partner; compare its telegrams with `si frame decode rk512`",
        source: "[CP 341 Diag] class 0AH, row 0A02 [M,T]; byte 2 and short reactions [derived]",
    }
    pub const REACTION_DATA_AMOUNT = 0x0A03 {
        meaning: "FETCH reaction with too much or too little data",
        remedy: "check the partner's length handling",
        source: "[CP 341 Diag] class 0AH, row 0A03 [M,T]",
    }
    pub const SEND_REACTION_WITH_DATA = 0x0A04 {
        meaning: "the reaction to a SEND carried data",
        remedy: "check the partner",
        source: "[CP 341 Diag] class 0AH, row 0A04 [M,T]",
    }
    pub const NO_REACTION = 0x0A05 {
        meaning: "no reaction (or continuation reaction) within the response monitoring time TRES",
        remedy: "look for receive errors (08xxH) before it; check that the partner runs RK 512 and is in RUN; raise TRES for slow partners",
        source: "[CP 341 Diag] class 0AH, row 0A05 [M,T]",
    }
}

/// Every catalog an RK 512 STATUS can come from (RK 512, 3964(R), common).
pub static CATALOGS: &[&[Status]] = &[CATALOG, si_3964r::status::CATALOG, common::CATALOG];

/// A status from its bare code with the manual's text when it is known.
pub fn lookup(code: u16) -> Status {
    Status::lookup(code, CATALOGS)
}

/// Reaction byte 4 → class 09H, **`[inferred]`**: no source gives this table
/// ([CP 341 Diag] `[derived]` "mapping NOT FOUND"); these are the candidates of its §2.1
/// table, from the WinCC OA RK 512 driver and the Elster gas-lab Q1 manual. Where §2.1 offers
/// two: 0CH → 0905 (WinCC OA's "invalid data type", the driver whose numbering every other row
/// follows; Elster reads it as 0903), 2AH → 090D ("PLC stopped" = "not restarted yet", an `[M]`
/// row; 0905 also names STOP). Any other non-zero byte → 090E, which `[M]` p.197 states.
pub const REACTION_ERRORS: [(u8, Status); 10] = [
    (0x0A, PARTNER_NO_AREA),
    (0x0C, PARTNER_CANNOT_SERVE),
    (0x10, PARTNER_BAD_HEADER),
    (0x11, PARTNER_NO_AREA),
    (0x14, PARTNER_NO_SUCH_DB),
    (0x16, PARTNER_BAD_COMMAND),
    (0x2A, PARTNER_NOT_RUNNING),
    (0x32, PARTNER_LOCKED),
    (0x34, PARTNER_BAD_LENGTH),
    (0x36, PARTNER_SEQUENCE),
];

/// The STATUS for the error byte of a reaction (`None` for 00H, no error; 090E for a byte
/// [`REACTION_ERRORS`] does not list).
pub fn for_error_byte(code: u8) -> Option<Status> {
    match code {
        0 => None,
        c => Some(
            REACTION_ERRORS
                .iter()
                .find(|(byte, _)| *byte == c)
                .map_or(PARTNER_ERROR_UNKNOWN, |(_, status)| *status),
        ),
    }
}

/// The error numbers of byte 4 this crate's passive side sends ([CP 341] §2.2.3, Table 2-2; which
/// 06xx sends which is [`crate::refusal::ServeError::error_number`]). Each is a row of
/// [`REACTION_ERRORS`], so a partner built like this crate reads them back as the 09xx code of that
/// row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorNumber {
    /// 0AH: access refused (the command is not served here).
    AccessDenied,
    /// 10H: header byte 1 or 4 wrong (telegram id, or a data type not allowed here).
    BadHeader,
    /// 14H: DB/DX missing or too short, address or flag outside the area.
    NoSuchArea,
    /// 16H: byte 3 (command) wrong.
    BadCommand,
    /// 2AH: CPU not in RUN.
    NotRunning,
    /// 32H: locked by a coordination flag.
    Locked,
    /// 34H: telegram length or data amount wrong.
    BadLength,
    /// 36H: synchronisation (sequence) error.
    Sequence,
}

impl ErrorNumber {
    /// Every number, in byte order.
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
            ErrorNumber::BadHeader => 0x10,
            ErrorNumber::NoSuchArea => 0x14,
            ErrorNumber::BadCommand => 0x16,
            ErrorNumber::NotRunning => 0x2A,
            ErrorNumber::Locked => 0x32,
            ErrorNumber::BadLength => 0x34,
            ErrorNumber::Sequence => 0x36,
        }
    }

    /// The STATUS a requester reports when it reads this number ([`for_error_byte`]).
    pub fn status(self) -> Status {
        for_error_byte(self.code()).unwrap_or(PARTNER_ERROR_UNKNOWN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reaction_bytes_map_to_class_09_with_090e_for_the_rest() {
        for (byte, status) in REACTION_ERRORS {
            assert_eq!(for_error_byte(byte), Some(status));
            assert_eq!(status.class(), 0x09);
        }
        assert_eq!(for_error_byte(0), None);
        for unknown in [0x01, 0x0B, 0x12, 0x77, 0xFF] {
            assert_eq!(for_error_byte(unknown), Some(PARTNER_ERROR_UNKNOWN));
        }
        for e in ErrorNumber::ALL {
            assert_ne!(e.status(), PARTNER_ERROR_UNKNOWN, "{e:?} is a table row");
        }
        assert_eq!(
            lookup(0x0909).to_string(),
            "16#0909 target DB/DX locked at the partner by a coordination flag"
        );
        assert_eq!(lookup(0x0703), si_3964r::status::SETUP_TIMEOUT);
    }

    #[test]
    fn link_codes_pass_through_and_the_never_raised_codes_have_no_text() {
        assert_eq!(lookup(0x0809), si_3964r::status::REPETITIONS_DIFFER);
        assert_eq!(lookup(0x0850), si_3964r::status::BLOCK_TOO_LONG);
        for code in [0x0501, 0x0815, 0x0816] {
            assert!(
                CATALOGS.iter().all(|c| c.iter().all(|s| s.code() != code)),
                "{code:04X} is listed as never raised"
            );
        }
    }

    #[test]
    fn no_invented_codes_remain() {
        for code in [0x0810, 0x0813, 0x0814, 0x0901] {
            assert!(
                CATALOG.iter().all(|s| s.code() != code),
                "{code:04X} is not a CP 341 RK 512 code"
            );
        }
        for s in CATALOG {
            assert!(
                matches!(s.class(), 0x05 | 0x06 | 0x09 | 0x0A),
                "{s}: RK 512 raises classes 05H, 06H, 09H and 0AH"
            );
        }
    }
}
