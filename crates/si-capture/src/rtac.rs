//! The RTAC serial link type, `LINKTYPE_RTAC_SERIAL` (250): what SEL's RTAC serial sniffers
//! write, and what Wireshark's `rtacser` dissector reads.
//!
//! Every packet starts with a 12-byte header, big-endian as Wireshark reads it: u32 seconds,
//! u32 microseconds, u8 event type, u8 control lines, u16 footer; the payload (the serial
//! characters) follows and is handed to whatever the user chose with "Decode As"
//! `rtacser.data`.
//!
//! We use it for what the exported-PDU packets cannot say: line errors, BREAK and changes of
//! the modem lines, each as a header with no payload in a second pcapng interface. The import
//! also reads whole captures of this type from other sniffers (the payload of each RX/TX
//! event is characters on the line).

/// The pcap/pcapng link type number.
pub const LINKTYPE: u16 = 250;

/// The header's size.
pub const HEADER_LEN: usize = 12;

/// The header's event type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// 01: transmission started (payload: characters sent).
    TxStart,
    /// 02: reception started (payload: characters received).
    RxStart,
    /// 03: transmission ended.
    TxEnd,
    /// 04: reception ended.
    RxEnd,
    /// 07: framing error.
    Framing,
    /// 08: parity error.
    Parity,
    /// 09: BREAK on the line.
    Break,
    /// 0A: receive overflow (overrun).
    Overflow,
    /// Any other value, kept as it was.
    Other(u8),
}

impl Event {
    /// The byte in the header.
    pub fn code(self) -> u8 {
        match self {
            Event::TxStart => 0x01,
            Event::RxStart => 0x02,
            Event::TxEnd => 0x03,
            Event::RxEnd => 0x04,
            Event::Framing => 0x07,
            Event::Parity => 0x08,
            Event::Break => 0x09,
            Event::Overflow => 0x0A,
            Event::Other(b) => b,
        }
    }

    /// The event for a header byte.
    pub fn from_code(b: u8) -> Event {
        match b {
            0x01 => Event::TxStart,
            0x02 => Event::RxStart,
            0x03 => Event::TxEnd,
            0x04 => Event::RxEnd,
            0x07 => Event::Framing,
            0x08 => Event::Parity,
            0x09 => Event::Break,
            0x0A => Event::Overflow,
            other => Event::Other(other),
        }
    }
}

/// The control-line bits of the header.
pub mod lines {
    /// Clear to send.
    pub const CTS: u8 = 0x01;
    /// Data carrier detect.
    pub const DCD: u8 = 0x02;
    /// Data set ready.
    pub const DSR: u8 = 0x04;
    /// Request to send.
    pub const RTS: u8 = 0x08;
    /// Data terminal ready.
    pub const DTR: u8 = 0x10;
}

/// One header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// Microseconds since the Unix epoch (or since the recording's start, when unknown).
    pub at_us: u64,
    /// What happened.
    pub event: Event,
    /// The control lines ([`lines`]).
    pub lines: u8,
    /// The footer (0 when we write it).
    pub footer: u16,
}

impl Header {
    /// The 12 bytes. Seconds beyond u32 (the year 2106) wrap.
    pub fn bytes(&self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        b[0..4].copy_from_slice(&((self.at_us / 1_000_000) as u32).to_be_bytes());
        b[4..8].copy_from_slice(&((self.at_us % 1_000_000) as u32).to_be_bytes());
        b[8] = self.event.code();
        b[9] = self.lines;
        b[10..12].copy_from_slice(&self.footer.to_be_bytes());
        b
    }

    /// The header of `packet` and its payload; `None` when it is shorter than a header.
    pub fn parse(packet: &[u8]) -> Option<(Header, &[u8])> {
        let h = packet.get(..HEADER_LEN)?;
        let u32_at = |k: usize| u32::from_be_bytes([h[k], h[k + 1], h[k + 2], h[k + 3]]);
        let header = Header {
            at_us: u64::from(u32_at(0)) * 1_000_000 + u64::from(u32_at(4)),
            event: Event::from_code(h[8]),
            lines: h[9],
            footer: u16::from_be_bytes([h[10], h[11]]),
        };
        Some((header, &packet[HEADER_LEN..]))
    }
}

/// The packet: header then payload.
pub fn encode(header: &Header, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(&header.bytes());
    out.extend_from_slice(payload);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_is_big_endian_and_reads_back() {
        let h = Header {
            at_us: 3_000_000_250,
            event: Event::Break,
            lines: lines::RTS | lines::CTS,
            footer: 0,
        };
        let p = encode(&h, &[0x55]);
        assert_eq!(
            p,
            [0, 0, 0x0B, 0xB8, 0, 0, 0, 250, 0x09, 0x09, 0, 0, 0x55],
            "3000 s, 250 µs, BREAK, RTS|CTS"
        );
        assert_eq!(Header::parse(&p), Some((h, &[0x55][..])));
        assert_eq!(Header::parse(&p[..11]), None);
    }

    #[test]
    fn every_event_code_round_trips() {
        for b in 0..=255u8 {
            assert_eq!(Event::from_code(b).code(), b);
        }
        assert_eq!(Event::from_code(0x0A), Event::Overflow);
    }
}
