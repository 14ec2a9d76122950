//! The control characters of a simulated line trace by name (`si sim`): `tx 02  STX`,
//! `rx 10  DLE`, a 3964(R) block's `DLE ETX BCC`, a USS telegram's `STX LGE ADR … BCC`, an ASCII
//! frame's `CR LF`, `XON`/`XOFF`.
//!
//! A leaf below the commands (used by `crate::scenario::print_trace`). A byte is named by its
//! place in the protocol, not by its value alone: in a 3964(R) block a data byte 02H is data,
//! not STX, and a Modbus frame is binary throughout, so it gets no names. The names come from the
//! transmitting side, where each engine's transmission is whole (one `tx` entry per control
//! character or block); each received character takes the name of the character its partner
//! sent in that place (the line delivers in order, [`arrived`] skips the characters lost), and
//! keeps none if a fault changed it.

use si_sim::{Trace, TraceEntry, TraceKind};
use std::collections::{HashMap, VecDeque};

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
    fn transmission(self, bytes: &[u8]) -> Vec<Option<&'static str>> {
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

/// The trace as `si sim` prints it, each line followed by the names of its control characters.
pub fn named_trace(trace: &Trace, naming: Naming) -> String {
    // Per station: the names of the characters on their way to it, in line order.
    let mut in_flight: HashMap<&str, VecDeque<(u8, Option<&'static str>)>> = HashMap::new();
    for e in &trace.entries {
        in_flight.entry(e.station.as_str()).or_default();
    }
    let mut out = String::new();
    for e in &trace.entries {
        let names: Vec<&'static str> = match &e.kind {
            TraceKind::Tx { bytes } => {
                let names = naming.transmission(bytes);
                for (station, queue) in in_flight.iter_mut() {
                    if *station != e.station {
                        queue.extend(bytes.iter().copied().zip(names.iter().copied()));
                    }
                }
                names.into_iter().flatten().collect()
            }
            TraceKind::Rx { byte } => arrived(&mut in_flight, &e.station, Some(*byte))
                .into_iter()
                .collect(),
            // A garbled character still took its place on the line.
            TraceKind::RxError { .. } => {
                arrived(&mut in_flight, &e.station, None);
                Vec::new()
            }
            _ => Vec::new(),
        };
        out.push_str(&with_names(e, &names));
    }
    out
}

/// The name of the character that arrived at `station` (`None`: a line error in its place).
///
/// Normally the next one on its way. A character sent before the stations were connected (the
/// 3964(R) startup NAK) never arrives: the first character on the way that is `byte` is the
/// one, and those before it were lost. A byte nobody sent (a fault changed it) takes the place
/// of the next character and gets no name.
fn arrived(
    in_flight: &mut HashMap<&str, VecDeque<(u8, Option<&'static str>)>>,
    station: &str,
    byte: Option<u8>,
) -> Option<&'static str> {
    let queue = in_flight.get_mut(station)?;
    match queue.iter().position(|(sent, _)| Some(*sent) == byte) {
        Some(i) => queue.drain(..=i).next_back().and_then(|(_, name)| name),
        None => queue.pop_front().and(None),
    }
}

/// One entry as the trace prints it, with `names` after it.
fn with_names(entry: &TraceEntry, names: &[&str]) -> String {
    let line = Trace {
        entries: vec![entry.clone()],
    }
    .to_string();
    if names.is_empty() {
        return line;
    }
    format!("{}  {}\n", line.trim_end_matches('\n'), names.join(" "))
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
