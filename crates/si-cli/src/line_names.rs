//! Which protocol crate names a simulated trace's bytes (`si sim`): `tx 02  STX`, `rx 10  DLE`.
//!
//! A leaf below the commands (used by `crate::scenario::print_trace`); the naming of a whole
//! trace is `si_core::trace_names::named_trace`. A byte is named by its place in the protocol,
//! not by its value alone: in a 3964(R) block a data byte 02H is data, not STX, and a Modbus
//! frame is binary throughout, so it gets no names.

/// How a protocol's bytes are named: by the protocol crate's frame module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Naming {
    /// 3964(R), also under RK 512 ([`si_3964r::frame::byte_names`]).
    R3964,
    /// USS ([`si_uss::frame::byte_name`]).
    Uss,
    /// ASCII ([`si_ascii::frame::control_name`]).
    Ascii,
}

impl Naming {
    /// The naming for a trace of `protocol` (the trace header's name); `None` where the bytes
    /// are binary (Modbus) or unknown.
    pub fn for_protocol(protocol: &str) -> Option<Naming> {
        match protocol {
            "3964r" | "rk512" => Some(Naming::R3964),
            "uss" => Some(Naming::Uss),
            "ascii" => Some(Naming::Ascii),
            _ => None,
        }
    }

    /// The name of each byte of one transmission (`None`: data), from the protocol crate's
    /// frame module.
    pub fn transmission(self, bytes: &[u8]) -> Vec<Option<&'static str>> {
        match self {
            Naming::R3964 => si_3964r::frame::byte_names(bytes).collect(),
            Naming::Uss => (0..bytes.len())
                .map(|i| si_uss::frame::byte_name(bytes, i))
                .collect(),
            Naming::Ascii => bytes
                .iter()
                .map(|&b| si_ascii::frame::control_name(b))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_3964r_block_names_dle_etx_and_bcc_and_leaves_its_data_unnamed() {
        let names = Naming::R3964.transmission(&[0x02, 0x10, 0x10, 0x41, 0x10, 0x03, 0x55]);
        let want = [
            None,
            None,
            None,
            None,
            Some("DLE"),
            Some("ETX"),
            Some("BCC"),
        ];
        assert_eq!(names, want);
        assert_eq!(Naming::R3964.transmission(&[0x15]), [Some("NAK")]);
        assert_eq!(Naming::R3964.transmission(&[0x41]), [None]);
    }

    #[test]
    fn uss_names_the_telegram_frame_and_ascii_the_control_characters() {
        let names = Naming::Uss.transmission(&[0x02, 0x03, 0x01, 0x00, 0x00]);
        assert_eq!(
            names,
            [Some("STX"), Some("LGE"), Some("ADR"), None, Some("BCC")]
        );
        let names = Naming::Ascii.transmission(&[0x48, 0x0D, 0x0A, 0x11, 0x13]);
        assert_eq!(
            names,
            [None, Some("CR"), Some("LF"), Some("XON"), Some("XOFF")]
        );
        assert_eq!(Naming::for_protocol("modbus"), None);
    }
}
