//! The 3964(R) STATUS codes: class 07H "send error" and class 08H "receive error" of
//! [ET200S SI] §2.13 (Table 2-28) and [ET200S SI 2005] Table 2-29
//! (Table 2-29), with the manual's meaning and remedy.
//!
//! The codes every driver shares (0502, 0B01, 1E0D, 1E41, …) are in
//! [`si_core::status::common`]; look a bare code up in both catalogs with
//! `Status::lookup(code, &[CATALOG, si_core::status::common::CATALOG])`.

use si_core::status::common;
use si_core::Status;

si_core::status_codes! {
    /// Every 3964(R) code of this module, in table order.
    pub static CATALOG;
    pub const SETUP_REJECTED = 0x0702 {
        meaning: "connection setup error: after STX, NAK or another code (not DLE or STX) was received",
        remedy: "check the partner, e.g. with an interface tester",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const SETUP_TIMEOUT = 0x0703 {
        meaning: "acknowledgement delay time (QVZ) exceeded after STX: no answer",
        remedy: "partner too slow or not ready, or the line is broken; check with a tester",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const ABORTED_BY_PARTNER = 0x0704 {
        meaning: "abort by the partner: characters received from the partner while sending",
        remedy: "check whether the partner also reports errors (incomplete data, line break, partner failure)",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const NAK_WHILE_SENDING = 0x0705 {
        meaning: "negative acknowledgement (NAK) while sending",
        remedy: "check whether the partner also reports errors",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const END_REJECTED = 0x0706 {
        meaning: "end-of-connection error: the partner rejected the block with NAK or another string (not DLE), or its DLE came too early",
        remedy: "check whether the partner also reports errors",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const END_TIMEOUT = 0x0707 {
        meaning: "acknowledgement delay time (QVZ) exceeded after DLE ETX: no answer",
        remedy: "partner too slow or faulty",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const CONFLICT_BOTH_HIGH = 0x070B {
        meaning: "unresolvable initialization conflict: both partners set to high priority",
        remedy: "set one partner to high and the other to low priority",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const CONFLICT_BOTH_LOW = 0x070C {
        meaning: "unresolvable initialization conflict: both partners set to low priority",
        remedy: "set one partner to high and the other to low priority",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const IDLE_GARBAGE = 0x0802 {
        meaning: "connection setup error: in idle, codes other than NAK or STX were received, or the partner sent more after STX without waiting for DLE",
        remedy: "check the partner, e.g. with an interface tester",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const ODD_DLE = 0x0805 {
        meaning: "logical receive error: after a DLE, a code other than DLE or ETX arrived",
        remedy: "check that the partner always doubles DLE and ends the block with DLE ETX",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const CHARACTER_DELAY = 0x0806 {
        meaning: "character delay time (ZVZ) exceeded: the next character, or the first after our DLE, did not arrive in time",
        remedy: "partner too slow or faulty",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const ZERO_LENGTH = 0x0807 {
        meaning: "zero-length block received (not an error)",
        remedy: "find out why the partner sends empty blocks",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const BCC_ERROR = 0x0808 {
        meaning: "BCC error: the computed block check character differs from the received one",
        remedy: "check the line for disturbances and check the partner",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const REPETITIONS_DIFFER = 0x0809 {
        meaning: "the number of repetitions must be set to the same value on both partners",
        remedy: "set the partner's attempts and block wait time equal to ours",
        source: "[ET200S SI] §2.13, Table 2-28 ([derived])",
    }
    pub const NO_FREE_BUFFER = 0x080A {
        meaning: "no free receive buffer",
        remedy: "take received blocks more often (call S_RCV more often)",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const TRANSMISSION_ERROR = 0x080C {
        meaning: "transmission error (parity, stop bit or overrun)",
        remedy: "check the cable and that baud rate, parity and stop bits match the partner",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const BREAK = 0x080D {
        meaning: "BREAK: the receive line to the partner is interrupted",
        remedy: "reconnect or switch on the partner",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const BLOCK_TOO_LONG = 0x0850 {
        meaning: "received block longer than the configured maximum length",
        remedy: "shorten the partner's blocks or raise the maximum block length",
        source: "[ET200S SI 2005] Table 2-29",
    }
}

/// Both catalogs a 3964(R) STATUS can come from, for [`Status::lookup`].
pub static CATALOGS: &[&[Status]] = &[CATALOG, common::CATALOG];

/// A status from its bare code with the manual's text when it is a 3964(R) or common code.
pub fn lookup(code: u16) -> Status {
    Status::lookup(code, CATALOGS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn send_errors_are_class_07_and_receive_errors_class_08() {
        for s in CATALOG {
            assert!(s.class() == 0x07 || s.class() == 0x08, "{s}");
            assert!(s.info().is_some());
        }
        assert_eq!(
            lookup(0x0808).to_string(),
            "16#0808 BCC error: the computed block check character differs from the received one"
        );
        assert_eq!(lookup(0x1E0D), common::ABORTED_BY_RESET);
    }
}
