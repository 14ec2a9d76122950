//! STATUS codes of the USS master.
//!
//! The ET 200S USS FCs do not report STATUS words of their own: S_USSR flags the **comm status
//! word** and writes the cause into the **comm error word** of each slave's net-data block
//! ([Modbus/USS] §3.7.7). Every job of this crate still ends in exactly one event with a
//! [`Status`](si_core::Status), so we give each of those bits a code:
//!
//! - class **14H** mirrors the comm error word: the event number is the bit number + 1
//!   (bit 0 ADR error → 1401H, bit 3 no STX → 1404H, bit 4 BCC → 1405H, bit 6 LGE → 1407H,
//!   bit 7 telegram monitoring time → 1408H), plus 1409H for a residual run time exceeded (also
//!   bit 7: the response did not arrive in time) and 140AH for character errors, which the manual
//!   counts among the "S_SEND/S_RCV feedback" of the group error bit 9;
//! - class **15H** mirrors the PKW bits of the comm status word, number = bit + 1
//!   (bit 2 AK 7 → 1503H, bit 3 invalid task → 1504H, bit 4 PKW interface error → 1505H).
//!
//! A PKW job whose node never answered ends with 1408H, "node does not answer", as a poll
//! does, although [Modbus/USS] §3.7.7 sets status bit 4 for it as well: 1505H stays for response ID
//! 8 and for answers that never matched, so a refusal and an absent drive read differently
//! (`crate::master`, "The PKW handshake").
//!
//! Classes 14H and 15H are not used by any table of the manuals (they use 01H–0EH and 1EH), so a
//! program can tell these apart from module codes; the meaning and the bit they mirror are in each
//! code's text.

si_core::status_codes! {
    /// Every USS code, for [`Status::lookup`](si_core::Status::lookup).
    pub static CATALOG;
    pub const ADDRESS_ERROR = 0x1401 {
        meaning: "response from a wrong address or of a wrong telegram type (comm error word bit 0)",
        remedy: "check that only one slave has this address and that the polling list matches the drives",
        source: "[Modbus/USS] §3.7.7, comm error word",
    }
    pub const NO_STX = 0x1404 {
        meaning: "start of frame not recognised: no STX after the start interval (comm error word bit 3)",
        remedy: "check the line for noise and the slave's timing",
        source: "[Modbus/USS] §3.7.7, comm error word; [USS spec]",
    }
    pub const BCC_ERROR = 0x1405 {
        meaning: "BCC of the response is wrong (comm error word bit 4)",
        remedy: "check cabling, termination and the character format (8E1)",
        source: "[Modbus/USS] §3.7.7, comm error word; [USS spec]",
    }
    pub const LGE_ERROR = 0x1407 {
        meaning: "wrong telegram length LGE or net-data structure (comm error word bit 6)",
        remedy: "make the PKW/PZD word counts match the drive's settings",
        source: "[Modbus/USS] §3.7.7, comm error word",
    }
    pub const NO_ANSWER = 0x1408 {
        meaning: "node does not answer: telegram monitoring time exceeded (comm error word bit 7)",
        remedy: "check that the slave is on, addressed and set to the same baud rate",
        source: "[Modbus/USS] §3.7.7, comm error word; [USS spec] §5.2.2 (20 ms)",
    }
    pub const RESIDUAL_TIME = 0x1409 {
        meaning: "residual run time 1.5 × (n + 3) character times exceeded while receiving (comm error word bit 7)",
        remedy: "check for a slave that pauses inside its telegram, or a slow converter",
        source: "[USS spec] §5.2.1.2",
    }
    pub const CHARACTER_ERROR = 0x140A {
        meaning: "parity, framing or overrun error or BREAK while receiving (group error, comm status bit 9)",
        remedy: "check the cable and that baud rate and parity match",
        source: "[USS spec] §5.2.2; [Modbus/USS] §3.7.7 bit 9",
    }
    pub const PKW_ERROR = 0x1503 {
        meaning: "PKW job finished with error: response ID 7, error number in PWE (comm status bit 2)",
        remedy: "see the error number: parameter number, limits, access rights",
        source: "[Modbus/USS] §3.7.7, comm status word bit 2; [USS spec]",
    }
    pub const PKW_INVALID_TASK = 0x1504 {
        meaning: "invalid PKW task ID: 15, or 4 with index 255; also (a reading of this crate) the reserved ID 10, or a task the PKW area cannot carry (comm status bit 3)",
        remedy: "use a valid task ID",
        source: "[Modbus/USS] §3.7.7, comm status word bit 3 (15; 4 with index 255); ID 10 and the PKW-area case [derived]: 10 is reserved in the USS task-ID table ([USS spec], [MM 420])",
    }
    pub const PKW_INTERFACE_ERROR = 0x1505 {
        meaning: "PKW interface error: response ID 8 (no master control / no PKW rights), or answers that never matched the job within the permitted repetitions (comm status bit 4)",
        remedy: "give the master PKW control rights on the drive, or check that it answers this task and parameter",
        source: "[Modbus/USS] §3.7.7, comm status word bit 4",
    }
}
