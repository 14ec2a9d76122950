//! The STATUS words that travel through the window (input bytes 1–2) or end a host job.
//!
//! The module puts STATUS codes of Table 2-29 into input bytes 1–2, MSB first
//! ([ET200S SI 2005] §2.12.1, Table 2-29). The codes shared by every driver (0502H,
//! 0B01H, 1E0DH, 1E20H, 1E41H) live in [`si_core::status::common`]; this module declares the ones
//! the window protocol itself produces, plus the receive-status words of the idle window.

pub use si_core::status::common::{
    ABORTED_BY_RESET, BUFFER_TWO_THIRDS_FULL, INVALID_LEN, NOT_POSSIBLE_IN_MODE,
    PARAMETER_OUT_OF_RANGE,
};

si_core::status_codes! {
    /// Every code this crate declares, for [`si_core::Status::lookup`].
    pub static CATALOG;
    pub const FRAME_PRESENT = 0x0001 {
        meaning: "a received frame is waiting in the module",
        remedy: "issue a receive job",
        source: "[ET200S SI 2005] §2.12.1",
    }
    pub const NO_MESSAGE = 0x0101 {
        meaning: "receive job issued but no received frame is available (not an error)",
        remedy: "none; poll the idle receive status for 0001H before the next receive job",
        source: "[ET200S SI 2005] §2.12.7",
    }
    pub const INVALID_FRAME_LENGTH = 0x050E {
        meaning: "invalid frame length: send frame empty or longer than the module's maximum (224 bytes for the 2005 module's 3964(R)/ASCII, 200 for the ET 200S 1SI and in Modbus mode)",
        remedy: "use a shorter frame",
        source: "[ET200S SI 2005] §2.12.7, Table 2-29 (224 bytes); [ET200S SI] §2.12 and [Modbus/USS] §3.4.2 (LEN 1 … 200); the limit per module is HostConfig::max_frame_len",
    }
    pub const FLOW_CONTROL_MISMATCH = 0x0550 {
        meaning: "parameter job does not match the configured flow-control type",
        remedy: "send the parameter block of the configured flow control (XON/XOFF 20H, RTS/CTS 21H, automatic V.24 22H)",
        source: "[ET200S SI 2005] §2.12.2–§2.12.6, Table 2-29 [derived]",
    }
    pub const TRANSFER_ERROR_TO_CPU = 0x0551 {
        meaning: "frame execution error between module and CPU while passing a received frame to the CPU",
        remedy: "both sides aborted; repeat the receive job, the module offers the frame again",
        source: "[ET200S SI 2005] §2.12.7, Table 2-29",
    }
    pub const NO_FREE_RECEIVE_BUFFER = 0x080A {
        meaning: "no free receive buffer",
        remedy: "fetch received frames more often",
        source: "[ET200S SI 2005] Table 2-29",
    }
    pub const RECEIVED_FRAME_TOO_LONG = 0x0850 {
        meaning: "received frame longer than 224 bytes or than the configured length",
        remedy: "adjust the partner or raise the configured maximum",
        source: "[ET200S SI 2005] Table 2-29",
    }
}

/// Every catalog a window STATUS may come from: this crate's and the common one.
pub const CATALOGS: &[&[si_core::Status]] = &[CATALOG, si_core::status::common::CATALOG];

/// The code with the manual's text when one of [`CATALOGS`] knows it (0000H is "no error").
pub fn lookup(code: u16) -> si_core::Status {
    if code == 0 {
        return si_core::Status::OK;
    }
    si_core::Status::lookup(code, CATALOGS)
}

/// The code with the manual's text from the window's catalogs ([`lookup`]) or, failing them,
/// those of the drivers behind the module (3964(R), ASCII): a window passes their STATUS on.
/// `None` for a code none of them has.
#[cfg(feature = "module-sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "module-sim")))]
pub fn lookup_with_drivers(status: si_core::Status) -> Option<si_core::Status> {
    let lookups: [fn(u16) -> si_core::Status; 3] =
        [lookup, si_3964r::status::lookup, si_ascii::status::lookup];
    lookups
        .iter()
        .map(|l| status.described_by(l))
        .find(|s| s.info().is_some())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_codes_have_text() {
        assert_eq!(
            lookup(0x0551).to_string(),
            "16#0551 frame execution error between module and CPU while passing a received frame to the CPU"
        );
        assert_eq!(lookup(0x0B01), BUFFER_TWO_THIRDS_FULL);
        assert!(lookup(0x050E).info().is_some());
        let text = lookup(0x050E).to_string();
        assert!(
            text.contains("224") && text.contains("200") && text.contains("Modbus"),
            "{text}"
        );
        assert!(lookup(0x4242).info().is_none());
    }
}
