//! The STATUS codes the ASCII driver reports ([ET200S SI] §2.13, Table 2-28, and
//! [ET200S SI 2005], Table 2-29).
//!
//! The codes every driver shares (0502H, 0B01H, 1E0DH, 1E20H, 1E41H) live in
//! [`si_core::status::common`]; they are re-exported here so an ASCII user finds every code in
//! one place. [`CATALOG`] lists the ASCII driver's own codes; [`lookup`] searches both.

use si_core::Status;

pub use si_core::status::common::{
    ABORTED_BY_RESET, BUFFER_TWO_THIRDS_FULL, INVALID_LEN, NOT_POSSIBLE_IN_MODE,
    PARAMETER_OUT_OF_RANGE,
};

si_core::status_codes! {
    /// The ASCII driver's codes of Table 2-28 (plus 0850H of the 2005 manual), in table order.
    pub static CATALOG;
    pub const INVALID_FRAME_LENGTH = 0x050E {
        meaning: "invalid frame length: longer than the maximum (200 bytes on the ET 200S 1SI)",
        remedy: "use a shorter frame",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const FLOW_PARAMETERS_MISMATCH = 0x0550 {
        meaning: "parameter-update request not valid for the configured flow control",
        remedy: "make the S_XON/S_RTS/S_V24 parameters and the configured flow control match",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const XON_CTS_TIMEOUT = 0x0708 {
        meaning: "wait for XON or CTS = ON timed out",
        remedy: "partner faulty, too slow or offline; check the partner and its parameters",
        source: "[ET200S SI] §2.8, §2.13, Table 2-28",
    }
    pub const CHAR_DELAY_EXCEEDED = 0x0806 {
        meaning: "character delay time exceeded: the frame was not complete; fragment discarded",
        remedy: "partner too slow or faulty; check the end criterion and the character delay time",
        source: "[ET200S SI] §2.8, §2.13, Table 2-28",
    }
    pub const NO_FREE_RECEIVE_BUFFER = 0x080A {
        meaning: "no free receive buffer: a received frame was lost",
        remedy: "call S_RCV more often",
        source: "[ET200S SI] §2.8, §2.13, Table 2-28",
    }
    pub const TRANSMISSION_ERROR = 0x080C {
        meaning: "transmission error (overrun)",
        remedy: "check the cable and that baud rate, parity and stop bits match",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const BREAK = 0x080D {
        meaning: "BREAK: the receive line to the partner is interrupted",
        remedy: "reconnect or switch on the partner",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const PARITY_ERROR = 0x0810 {
        meaning: "parity error",
        remedy: "check the cable and the settings",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const FRAMING_ERROR = 0x0811 {
        meaning: "character frame error",
        remedy: "check the cable and the settings",
        source: "[ET200S SI] §2.13, Table 2-28",
    }
    pub const RECEIVED_AFTER_XOFF = 0x0812 {
        meaning: "characters received after the module sent XOFF or set RTS = OFF; buffer overflow",
        remedy: "reconfigure the partner or read data faster",
        source: "[ET200S SI] §2.8, §2.13, Table 2-28",
    }
    pub const DSR_CTS_OFF = 0x0818 {
        meaning: "DSR = OFF or CTS = OFF before or during a send",
        remedy: "check the partner's handling of the RS-232C secondary signals",
        source: "[ET200S SI] §2.8, §2.13, Table 2-28",
    }
    pub const FRAME_TOO_LONG = 0x0850 {
        meaning: "received frame longer than the maximum frame length",
        remedy: "adjust the partner or the end criterion",
        source: "[ET200S SI 2005] Table 2-29",
    }
}

/// `code` with its text from the ASCII catalog or the shared one.
pub fn lookup(code: u16) -> Status {
    Status::lookup(code, &[CATALOG, si_core::status::common::CATALOG])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_the_table_2_28_numbers() {
        assert_eq!(XON_CTS_TIMEOUT.code(), 0x0708);
        assert_eq!(XON_CTS_TIMEOUT.class(), 0x07);
        assert_eq!(PARITY_ERROR.code(), 0x0810);
        assert_eq!(FRAMING_ERROR.code(), 0x0811);
        assert_eq!(lookup(0x0B01), BUFFER_TWO_THIRDS_FULL);
        assert_eq!(
            lookup(0x0812).to_string(),
            "16#0812 characters received after the module sent XOFF or set RTS = OFF; buffer overflow"
        );
    }
}
