//! The manual's STATUS codes for Modbus ([Modbus/USS] §3.3.6, Table 3-12, §3.4.5–§3.4.16,
//! §3.5.6–§3.5.14, §3.6; [ET200S SI 2005] Tables 3-65 to 3-72).
//!
//! Codes 0830H and 0831H mean one thing in the master and another in the slave (Table 3-65ff.):
//! the master's meanings are in [`CATALOG`], the slave's in [`slave::CATALOG`]; the same number
//! appears in both with the text of the side that reports it.
//!
//! # Codes of the manual's tables this driver never reports
//!
//! The catalogs hold the codes this crate raises (and the exception codes it decodes), so a
//! code in them is a code a user can meet. These codes of the tables are left out on purpose:
//!
//! - **0806H** "character delay time exceeded between two characters". In Modbus RTU the
//!   character delay time tZVZ *is* the end-of-frame gap ([Modbus/USS] §3.3.5, Table 3-11:
//!   "character delay time tZVZ_TAB"; tZVZ = tZVZ_TAB × fMUL): its expiry ends every frame, so it
//!   cannot be an error by itself ([Modbus/USS] §3.3.5, Table 3-11 `[derived]`, [ET200S SI 2005]
//!   `[derived]`). A frame that the gap ended too early fails a check the manual does name: in the
//!   master 0E52H "too few bytes", 0E54H/0E55H or 0E57H ([Modbus/USS] §3.4.5–§3.4.16), in the slave
//!   0836H (CRC). Reporting 0806H there instead would replace a code the manual gives for exactly
//!   that case with one it does not tie to Modbus framing; the table row reads as the shared
//!   receive-error table of the 3964(R)/ASCII modules (where 0806H is their ZVZ). So it is not
//!   raised and not listed.
//! - **0812H** "characters received after the module set CTS = 0": the Modbus driver has no
//!   receive flow control ([Modbus/USS] §3.2.2 offers only the automatic V.24 signals, where RTS
//!   belongs to sending), so it never holds a partner off.
//! - **0E2EH** "error reading the interface parameter file; driver not ready" ([Modbus/USS]
//!   §3.6, event class 0EH; [ET200S SI 2005] Tables 3-65 … 3-72). The module's firmware reads
//!   its parameters from a file the configuration tool loads; here the parameters are a typed
//!   [`MasterConfig`](crate::MasterConfig) or [`SlaveConfig`](crate::SlaveConfig) that
//!   `Master::new`/`Slave::new` check field by field. There is no file to fail reading, and a
//!   value out of range is refused with the code the manual gives for it (0E20H–0E23H) or an
//!   error naming the parameter, range and value, so the driver is never "not ready".
//! - **0201H** "no (valid) parameter assignment" ([ET200S SI 2005] Tables 3-65 … 3-72 only;
//!   the Modbus/USS manual has no such row). An engine exists only once its parameters passed
//!   the checks above, so no job can meet an unparameterized driver (a module still waiting
//!   for its parameter record is a state of the module, outside this driver).
//!
//! 0E22H "invalid operating mode" is raised where the manual says: when the mode parameter has
//! a value other than Normal or Interference suppression ([`crate::config::Mode::from_name`],
//! the parameter files of si-module; [Modbus/USS] §3.4.3, §3.5.4).

use crate::frame::ExceptionCode;
use si_core::Status;

si_core::status_codes! {
    /// Every master-side and shared code, in table order.
    pub static CATALOG;
    pub const FRAME_TOO_LONG = 0x050E {
        meaning: "illegal frame length: more than 200 bytes",
        remedy: "use shorter frames: a read job's result must fit S_RCV's 200 bytes (at most 100 registers or 1600 bits)",
        source: "[Modbus/USS] §3.6; the read limits of §3.4.5–§3.4.16 [derived]",
    }
    pub const RECEIVE_BUFFER_OVERFLOW = 0x080A {
        meaning: "receive buffer overflow while receiving a response",
        remedy: "check the slave's protocol settings",
        source: "[Modbus/USS] §3.6",
    }
    pub const TRANSMISSION_ERROR = 0x080C {
        meaning: "transmission error (parity, stop bit, overrun)",
        remedy: "check the cable, and that baud, parity and stop bits match",
        source: "[Modbus/USS] §3.6",
    }
    pub const BREAK = 0x080D {
        meaning: "BREAK: receive line to the partner interrupted",
        remedy: "reconnect, or switch the partner on",
        source: "[Modbus/USS] §3.6",
    }
    pub const PARITY_ERROR = 0x0810 {
        meaning: "parity error",
        remedy: "check cable and settings",
        source: "[Modbus/USS] §3.6",
    }
    pub const FRAMING_ERROR = 0x0811 {
        meaning: "character frame error",
        remedy: "check cable and settings",
        source: "[Modbus/USS] §3.6",
    }
    pub const DSR_CTS_OFF = 0x0818 {
        meaning: "DSR = OFF or CTS = OFF: the partner dropped DSR, or CTS did not come on in time, under automatic V.24 operation",
        remedy: "check the partner's handling of the RS-232C secondary signals and the data output wait time",
        source: "[Modbus/USS] §3.2.2 (\"aborted with an error\", no code given); derived: the ASCII driver's code for the same abort, [ET200S SI] §2.8",
    }
    pub const RESPONSE_TIMEOUT = 0x0830 {
        meaning: "response timeout: no start of a response within the response time",
        remedy: "check the line, the parameters, the response time and that the slave exists",
        source: "[Modbus/USS] §3.4.3, Table 3-17, §3.6",
    }
    pub const WRONG_SLAVE_ADDRESS = 0x0831 {
        meaning: "first response character is not the slave address sent",
        remedy: "a different slave answered; check the line",
        source: "[Modbus/USS] §3.4.3, §3.5.4, §3.6",
    }
    pub const DATA_BITS_NOT_8 = 0x0E20 {
        meaning: "data bits must be 8; driver not ready",
        remedy: "set 8 data bits",
        source: "[Modbus/USS] §3.4.3, §3.5.4, §3.9, §3.6",
    }
    pub const CHAR_DELAY_MULTIPLIER = 0x0E21 {
        meaning: "character delay multiplier outside 1…10",
        remedy: "use 1…10",
        source: "[Modbus/USS] §3.3.5, Table 3-11, §3.6",
    }
    pub const INVALID_MODE = 0x0E22 {
        meaning: "invalid operating mode; driver not ready",
        remedy: "choose Normal or Interference suppression",
        source: "[Modbus/USS] §3.4.3, §3.5.4, §3.6",
    }
    pub const INVALID_TIMEOUT_OR_ADDRESS = 0x0E23 {
        meaning: "master: response time outside 50…655000 ms; slave: invalid slave address",
        remedy: "fix the parameter",
        source: "[Modbus/USS] §3.4.3, Table 3-17, §3.6",
    }
    pub const LEN_TOO_SMALL = 0x0E40 {
        meaning: "S_SEND LEN too small (minimum 2)",
        remedy: "give address and function code at least",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const LEN_TOO_SMALL_FOR_FC = 0x0E41 {
        meaning: "LEN too small for this function code (minimum 6)",
        remedy: "give start address and quantity",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const INVALID_FUNCTION = 0x0E42 {
        meaning: "invalid function code in the job",
        remedy: "use 01-08, 11, 12, 15 or 16",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const BROADCAST_NOT_ALLOWED_FOR_FC = 0x0E43 {
        meaning: "slave address 0 (broadcast) not allowed for this function code",
        remedy: "broadcast only FC05, 06, 15, 16",
        source: "[Modbus/USS] §3.3.2, §3.6",
    }
    pub const BIT_COUNT = 0x0E44 {
        meaning: "bit count outside 1…2040",
        remedy: "read 1…2040 bits",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const REGISTER_COUNT = 0x0E45 {
        meaning: "register count outside 1…127",
        remedy: "read 1…127 registers",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const WRITE_COUNT = 0x0E46 {
        meaning: "FC15/16: bit or register count outside 1…2040 / 1…127",
        remedy: "write 1…2040 bits or 1…127 registers",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const LEN_DOES_NOT_MATCH_COUNT = 0x0E47 {
        meaning: "FC15/16: LEN too small for the bit or register count",
        remedy: "increase LEN or reduce the count",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const COIL_VALUE = 0x0E48 {
        meaning: "FC05: invalid ON/OFF code (only FF00H/0000H)",
        remedy: "use FF00H or 0000H",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const DIAGNOSTIC_CODE = 0x0E49 {
        meaning: "FC08: wrong diagnostic code (only 0000H)",
        remedy: "use sub-function 0000H",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const LEN_TOO_LARGE = 0x0E4A {
        meaning: "length exceeds the maximum for this function code",
        remedy: "shorten the job",
        source: "[Modbus/USS] §3.4.5–§3.4.16, §3.6",
    }
    pub const UNSOLICITED_RESPONSE = 0x0E50 {
        meaning: "response received with no request pending",
        remedy: "another master or slave is active on the bus, or a line fault",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const WRONG_FUNCTION = 0x0E51 {
        meaning: "function code in the response differs from the one sent",
        remedy: "check the slave",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const TOO_FEW_BYTES = 0x0E52 {
        meaning: "too few bytes in the response",
        remedy: "check the slave",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const TOO_MANY_BYTES = 0x0E53 {
        meaning: "too many bytes in the response",
        remedy: "check the slave",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const BYTE_COUNT_TOO_SMALL = 0x0E54 {
        meaning: "byte count in the response too small",
        remedy: "check the slave",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const BYTE_COUNT_WRONG = 0x0E55 {
        meaning: "byte count in the response wrong",
        remedy: "check the slave",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const ECHO_WRONG = 0x0E56 {
        meaning: "echo error: the echoed fields differ from the request",
        remedy: "check the slave",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const RESPONSE_CRC = 0x0E57 {
        meaning: "CRC error in the response",
        remedy: "check the line and the slave",
        source: "[Modbus/USS] §3.4.5–§3.4.16",
    }
    pub const EXCEPTION_ILLEGAL_FUNCTION = 0x0E61 {
        meaning: "exception 01 received: illegal function",
        remedy: "see the slave's manual",
        source: "[Modbus/USS] §3.3.6, Table 3-12",
    }
    pub const EXCEPTION_ILLEGAL_DATA_ADDRESS = 0x0E62 {
        meaning: "exception 02 received: illegal data address",
        remedy: "see the slave's manual",
        source: "[Modbus/USS] §3.3.6, Table 3-12",
    }
    pub const EXCEPTION_ILLEGAL_DATA_VALUE = 0x0E63 {
        meaning: "exception 03 received: illegal data value",
        remedy: "see the slave's manual",
        source: "[Modbus/USS] §3.3.6, Table 3-12",
    }
    pub const EXCEPTION_SLAVE_DEVICE_FAILURE = 0x0E64 {
        meaning: "exception 04 received: slave device failure",
        remedy: "see the slave's manual",
        source: "[Modbus/USS] §3.3.6, Table 3-12",
    }
    pub const EXCEPTION_ACKNOWLEDGE = 0x0E65 {
        meaning: "exception 05 received: acknowledge",
        remedy: "see the slave's manual",
        source: "[Modbus/USS] §3.3.6, Table 3-12",
    }
    pub const EXCEPTION_BUSY = 0x0E66 {
        meaning: "exception 06 received: slave busy, request rejected",
        remedy: "repeat the request later",
        source: "[Modbus/USS] §3.3.6, Table 3-12",
    }
    pub const EXCEPTION_NEGATIVE_ACKNOWLEDGE = 0x0E67 {
        meaning: "exception 07 received: negative acknowledge",
        remedy: "see the slave's manual",
        source: "[Modbus/USS] §3.3.6, Table 3-12",
    }
}

/// The slave driver's receive and syntax events ([Modbus/USS] §3.5.6–§3.5.14, Table 3-65ff.).
pub mod slave {
    si_core::status_codes! {
        /// Every slave-side code, and the slave's wording of the shared 080AH.
        pub static CATALOG;
        // [Modbus/USS] §3.6 words 080AH for the master ("while receiving a response"); a slave that
        // overflows is receiving a request, so its report says so (same code, same remedy).
        pub const RECEIVE_BUFFER_OVERFLOW = 0x080A {
            meaning: "receive buffer overflow while receiving a request",
            remedy: "check the master's protocol settings",
            source: "[Modbus/USS] §3.6 (worded there for the master)",
        }
        pub const BROADCAST_NOT_ALLOWED = 0x0830 {
            meaning: "broadcast not allowed for this function code",
            remedy: "broadcast only FC05, 06, 15, 16",
            source: "[Modbus/USS] §3.3.2, §3.5.6–§3.5.14",
        }
        pub const INVALID_FUNCTION = 0x0831 {
            meaning: "invalid function code received",
            remedy: "the slave serves FC01-06, 08, 15, 16",
            source: "[Modbus/USS] §3.3.3, Table 3-10, §3.5.6–§3.5.14",
        }
        pub const QUANTITY = 0x0832 {
            meaning: "maximum bits (2040) or registers (127) exceeded, or bit count not a multiple of 16 for T/C",
            remedy: "limit the job; T/C only in 16-bit steps",
            source: "[Modbus/USS] §3.5.5–§3.5.19, §3.5.6–§3.5.14",
        }
        pub const BYTE_COUNT = 0x0833 {
            meaning: "FC15/16 quantity does not match the byte count",
            remedy: "correct the master",
            source: "[Modbus/USS] §3.5.6–§3.5.14",
        }
        pub const COIL_VALUE = 0x0834 {
            meaning: "FC05 value not FF00H/0000H",
            remedy: "use FF00H or 0000H",
            source: "[Modbus/USS] §3.5.6–§3.5.14",
        }
        pub const SUB_FUNCTION = 0x0835 {
            meaning: "FC08 sub-code not 0000H",
            remedy: "use sub-function 0000H",
            source: "[Modbus/USS] §3.5.6–§3.5.14",
        }
        pub const CRC = 0x0836 {
            meaning: "computed CRC16 differs from the received CRC",
            remedy: "check the master's CRC generation",
            source: "[Modbus/USS] §3.5.6–§3.5.14",
        }
        pub const SEQUENCE = 0x0837 {
            meaning: "sequence error: new request while the previous response was still pending",
            remedy: "increase the master's response timeout",
            source: "[Modbus/USS] §3.5.6–§3.5.14",
        }
    }
}

/// The master's STATUS for a received exception ([Modbus/USS] §3.3.6, Table 3-12): 0E60H + code.
pub fn for_exception(code: ExceptionCode) -> Status {
    Status::lookup(0x0E60 + code.code() as u16, &[CATALOG])
}

/// Whether `status` reports a slave's exception answer (0E61H–0E6FH, [Modbus/USS] §3.3.6,
/// Table 3-12): a frame that arrived whole, as opposed to a framing, CRC or length error.
pub fn is_exception(status: Status) -> bool {
    status.code() & 0xFFF0 == 0x0E60 && status.code() != 0x0E60
}

/// A code with its text from either catalog (the master's meaning first).
pub fn lookup(code: u16) -> Status {
    Status::lookup(
        code,
        &[CATALOG, slave::CATALOG, si_core::status::common::CATALOG],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exception_statuses_are_0e61_to_0e67() {
        for c in 1..=7 {
            let code = ExceptionCode::from_u8(c).unwrap();
            let s = for_exception(code);
            assert_eq!(s.code(), 0x0E60 + c as u16);
            assert!(s.info().is_some());
        }
        assert_eq!(
            lookup(0x0836).to_string(),
            "16#0836 computed CRC16 differs from the received CRC"
        );
    }
}
