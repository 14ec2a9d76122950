//! Wireshark's exported-PDU link type, `LINKTYPE_WIRESHARK_UPPER_PDU` (252).
//!
//! A packet of this link type starts with a list of tag/length/value entries, then the PDU
//! itself. Per Wireshark's `wsutil/exported_pdu_tlvs.h`: a 2-byte big-endian tag, a 2-byte
//! big-endian length, the value padded to a multiple of 4 bytes (the length counts the
//! padding; a string's trailing NUL bytes are not part of it), and tag 0 with length 0 ends
//! the list. We write two entries:
//!
//! - tag 12 (`EXP_PDU_TAG_DISSECTOR_NAME`): the registered dissector that decodes the PDU
//!   (`mbrtu` for Modbus RTU, `si_3964r`, `si_rk512`, `si_uss`, `si_dpcoord` from
//!   `contrib/wireshark/si.lua`); Wireshark calls `find_dissector(name)`, so a Lua dissector
//!   registered with `register_dissector` is found by the same name;
//! - tag 35 (`EXP_PDU_TAG_P2P_DIRECTION`): a 4-byte direction, 0 sent, 1 received
//!   (Wireshark's `P2P_DIR_SENT` / `P2P_DIR_RECV`).

/// The pcap/pcapng link type number.
pub const LINKTYPE: u16 = 252;

/// End of the tag list.
pub const TAG_END: u16 = 0;
/// The dissector's registered name (ASCII).
pub const TAG_DISSECTOR_NAME: u16 = 12;
/// The packet's direction, a 4-byte big-endian integer.
pub const TAG_P2P_DIRECTION: u16 = 35;

/// Which way a PDU went, as Wireshark's point-to-point direction says it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Sent (`P2P_DIR_SENT`, 0): in our captures, by the first station.
    Sent,
    /// Received (`P2P_DIR_RECV`, 1): in our captures, sent by the second station.
    Received,
}

impl Direction {
    /// The value of tag 35.
    pub fn value(self) -> u32 {
        match self {
            Direction::Sent => 0,
            Direction::Received => 1,
        }
    }
}

/// One decoded exported PDU: the tags we know, and where the PDU starts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pdu<'a> {
    /// Tag 12, without trailing NULs.
    pub dissector: Option<&'a str>,
    /// Tag 35.
    pub direction: Option<Direction>,
    /// The PDU after the tag list.
    pub payload: &'a [u8],
}

/// A packet whose tag list cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PduError {
    /// The list runs past the packet.
    #[error("exported PDU tag {tag} at offset {offset}: length {len} runs past the packet's {size} bytes")]
    Truncated {
        /// The tag.
        tag: u16,
        /// Offset of the tag in the packet.
        offset: usize,
        /// Its length field.
        len: usize,
        /// The packet's size.
        size: usize,
    },
    /// No end tag.
    #[error("exported PDU: no end-of-options tag (0) in the packet's {0} bytes")]
    NoEnd(usize),
}

fn push_tag(out: &mut Vec<u8>, tag: u16, value: &[u8]) {
    let padded = value.len().div_ceil(4) * 4;
    out.extend_from_slice(&tag.to_be_bytes());
    out.extend_from_slice(&(padded as u16).to_be_bytes());
    out.extend_from_slice(value);
    out.resize(out.len() + padded - value.len(), 0);
}

/// Append the packet for `payload` to `out`: dissector name, direction, end tag, payload.
/// A dissector name longer than 65,532 bytes is cut (no registered name is near that).
pub fn encode_into(out: &mut Vec<u8>, dissector: &str, direction: Direction, payload: &[u8]) {
    let name = &dissector.as_bytes()[..dissector.len().min(65_532)];
    push_tag(out, TAG_DISSECTOR_NAME, name);
    push_tag(out, TAG_P2P_DIRECTION, &direction.value().to_be_bytes());
    push_tag(out, TAG_END, &[]);
    out.extend_from_slice(payload);
}

/// The packet for `payload` (see [`encode_into`]).
pub fn encode(dissector: &str, direction: Direction, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 24 + dissector.len());
    encode_into(&mut out, dissector, direction, payload);
    out
}

/// Read the tag list of `packet`. Unknown tags are skipped; a direction other than 0 or 1 is
/// left out.
pub fn decode(packet: &[u8]) -> Result<Pdu<'_>, PduError> {
    let mut at = 0;
    let mut pdu = Pdu {
        dissector: None,
        direction: None,
        payload: &[],
    };
    loop {
        if at + 4 > packet.len() {
            return Err(PduError::NoEnd(packet.len()));
        }
        let tag = u16::from_be_bytes([packet[at], packet[at + 1]]);
        let len = usize::from(u16::from_be_bytes([packet[at + 2], packet[at + 3]]));
        let value = packet
            .get(at + 4..at + 4 + len)
            .ok_or(PduError::Truncated {
                tag,
                offset: at,
                len,
                size: packet.len(),
            })?;
        match tag {
            TAG_END => {
                pdu.payload = &packet[at + 4 + len..];
                return Ok(pdu);
            }
            TAG_DISSECTOR_NAME => {
                let end = value.iter().position(|&b| b == 0).unwrap_or(value.len());
                pdu.dissector = core::str::from_utf8(&value[..end]).ok();
            }
            TAG_P2P_DIRECTION if len >= 4 => {
                pdu.direction = match u32::from_be_bytes([value[0], value[1], value[2], value[3]]) {
                    0 => Some(Direction::Sent),
                    1 => Some(Direction::Received),
                    _ => None,
                };
            }
            _ => {}
        }
        at += 4 + len;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_is_wiresharks() {
        let p = encode("mbrtu", Direction::Received, &[1, 3]);
        assert_eq!(
            p,
            [
                0, 12, 0, 8, b'm', b'b', b'r', b't', b'u', 0, 0, 0, // name, padded to 8
                0, 35, 0, 4, 0, 0, 0, 1, // direction: received
                0, 0, 0, 0, // end
                1, 3
            ]
        );
        let d = decode(&p).unwrap();
        assert_eq!(d.dissector, Some("mbrtu"));
        assert_eq!(d.direction, Some(Direction::Received));
        assert_eq!(d.payload, &[1, 3]);
    }

    #[test]
    fn a_name_of_four_bytes_has_no_padding() {
        let p = encode("abcd", Direction::Sent, &[]);
        assert_eq!(&p[..8], &[0, 12, 0, 4, b'a', b'b', b'c', b'd']);
        assert_eq!(decode(&p).unwrap().dissector, Some("abcd"));
    }

    #[test]
    fn broken_lists_are_errors_not_panics() {
        assert_eq!(decode(&[]), Err(PduError::NoEnd(0)));
        assert_eq!(
            decode(&[0, 12, 0, 9, b'x']),
            Err(PduError::Truncated {
                tag: 12,
                offset: 0,
                len: 9,
                size: 5
            })
        );
        for n in 0..64u8 {
            let junk: Vec<u8> = (0..n).map(|k| k.wrapping_mul(37)).collect();
            let _ = decode(&junk);
        }
    }
}
