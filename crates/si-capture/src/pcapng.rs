//! pcapng files (the IETF draft "PCAP Next Generation Dump File Format"), written and read by
//! hand; classic pcap files are read too.
//!
//! The writer puts out one section: a Section Header Block (SHB, with an optional comment), one
//! Interface Description Block (IDB) per link type the caller adds, and an Enhanced Packet
//! Block (EPB) per packet, with microsecond timestamps (the IDB's default resolution) and an
//! optional comment. It writes little-endian, as the format allows either.
//!
//! The reader yields the blocks it understands ([`Block`]) one at a time into a buffer it
//! reuses, so a file of any size reads in memory bounded by its largest block, which is
//! refused above [`MAX_BLOCK`]. It follows the byte order of each section, converts any
//! `if_tsresol` to microseconds, and skips blocks it does not need (name resolution,
//! statistics, custom blocks).

use std::io::{self, Read, Write};

/// The largest block the reader accepts (16 MiB): far above any serial frame, small enough
/// that a corrupt length field cannot make it allocate the machine's memory.
pub const MAX_BLOCK: usize = 16 << 20;

const SHB: u32 = 0x0A0D_0D0A;
const IDB: u32 = 0x0000_0001;
const SPB: u32 = 0x0000_0003;
const EPB: u32 = 0x0000_0006;
const BYTE_ORDER_MAGIC: u32 = 0x1A2B_3C4D;
const OPT_END: u16 = 0;
const OPT_COMMENT: u16 = 1;
const SHB_USERAPPL: u16 = 4;
const IF_NAME: u16 = 2;
const IF_TSRESOL: u16 = 9;

/// Writes one pcapng section.
#[derive(Debug)]
pub struct Writer<W: Write> {
    out: W,
    interfaces: u32,
    block: Vec<u8>,
}

fn option(block: &mut Vec<u8>, code: u16, value: &[u8]) {
    let len = value.len().min(0xFFFC);
    block.extend_from_slice(&code.to_le_bytes());
    block.extend_from_slice(&(len as u16).to_le_bytes());
    block.extend_from_slice(&value[..len]);
    block.resize(block.len() + len.next_multiple_of(4) - len, 0);
}

impl<W: Write> Writer<W> {
    /// Start the file: the section header, naming `application` (`shb_userappl`) and carrying
    /// `comment` (`opt_comment`) when given.
    pub fn new(out: W, application: &str, comment: Option<&str>) -> io::Result<Self> {
        let mut w = Writer {
            out,
            interfaces: 0,
            block: Vec::new(),
        };
        let mut body = Vec::new();
        body.extend_from_slice(&BYTE_ORDER_MAGIC.to_le_bytes());
        body.extend_from_slice(&1u16.to_le_bytes());
        body.extend_from_slice(&0u16.to_le_bytes());
        body.extend_from_slice(&(-1i64).to_le_bytes()); // section length unknown
        if let Some(c) = comment {
            option(&mut body, OPT_COMMENT, c.as_bytes());
        }
        option(&mut body, SHB_USERAPPL, application.as_bytes());
        option(&mut body, OPT_END, &[]);
        w.write_block(SHB, &body)?;
        Ok(w)
    }

    /// Describe an interface of `linktype` named `name`; its id for [`packet`](Self::packet).
    /// Timestamps are in microseconds (the default `if_tsresol`, written out for readers that
    /// want it said).
    pub fn interface(&mut self, linktype: u16, name: &str) -> io::Result<u32> {
        let mut body = Vec::new();
        body.extend_from_slice(&linktype.to_le_bytes());
        body.extend_from_slice(&0u16.to_le_bytes());
        body.extend_from_slice(&0u32.to_le_bytes()); // no snap length limit
        option(&mut body, IF_NAME, name.as_bytes());
        option(&mut body, IF_TSRESOL, &[6]);
        option(&mut body, OPT_END, &[]);
        self.write_block(IDB, &body)?;
        self.interfaces += 1;
        Ok(self.interfaces - 1)
    }

    /// One packet on `interface` at `at_us` microseconds (since the Unix epoch, or since the
    /// recording's start when its wall-clock time is unknown), with an optional comment.
    pub fn packet(
        &mut self,
        interface: u32,
        at_us: u64,
        data: &[u8],
        comment: Option<&str>,
    ) -> io::Result<()> {
        if interface >= self.interfaces {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "pcapng packet: interface {interface} is not described (0..{})",
                    self.interfaces
                ),
            ));
        }
        let mut body = std::mem::take(&mut self.block);
        body.clear();
        body.extend_from_slice(&interface.to_le_bytes());
        body.extend_from_slice(&((at_us >> 32) as u32).to_le_bytes());
        body.extend_from_slice(&(at_us as u32).to_le_bytes());
        body.extend_from_slice(&(data.len() as u32).to_le_bytes());
        body.extend_from_slice(&(data.len() as u32).to_le_bytes());
        body.extend_from_slice(data);
        body.resize(body.len() + data.len().next_multiple_of(4) - data.len(), 0);
        if let Some(c) = comment {
            option(&mut body, OPT_COMMENT, c.as_bytes());
            option(&mut body, OPT_END, &[]);
        }
        let r = self.write_block(EPB, &body);
        self.block = body;
        r
    }

    fn write_block(&mut self, kind: u32, body: &[u8]) -> io::Result<()> {
        let total = (body.len() + 12) as u32;
        self.out.write_all(&kind.to_le_bytes())?;
        self.out.write_all(&total.to_le_bytes())?;
        self.out.write_all(body)?;
        self.out.write_all(&total.to_le_bytes())
    }

    /// Flush and hand back the output.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// A block the reader understood.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Block<'a> {
    /// A new section (a classic pcap file is one section): its comment, if any. Interface
    /// ids start again at 0.
    Section {
        /// `opt_comment`.
        comment: Option<String>,
    },
    /// An interface, numbered in order of appearance within the section.
    Interface {
        /// The link type.
        linktype: u16,
        /// `if_name`.
        name: Option<String>,
    },
    /// A packet.
    Packet {
        /// Its interface.
        interface: u32,
        /// Its time in microseconds (0 for a simple packet block, which has none).
        at_us: u64,
        /// The captured bytes.
        data: &'a [u8],
        /// `opt_comment`.
        comment: Option<String>,
    },
}

/// A file that is not a readable capture.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// Reading failed.
    #[error("cannot read the capture: {0}")]
    Io(#[from] io::Error),
    /// The first four bytes are neither pcapng nor pcap.
    #[error("not a pcapng or pcap file: it starts with {0:02X?}, expected 0A0D0D0A (pcapng) or A1B2C3D4/A1B23C4D (pcap) in either byte order")]
    Magic([u8; 4]),
    /// A block whose length is impossible or too large.
    #[error("capture block at offset {offset}: length {len} is out of range: 12..={max}, a multiple of 4")]
    Length {
        /// The block's offset in the file.
        offset: u64,
        /// Its length field.
        len: u64,
        /// [`MAX_BLOCK`].
        max: usize,
    },
    /// A block too short for its own fields.
    #[error("capture block at offset {offset}: {what}")]
    Malformed {
        /// The block's offset in the file.
        offset: u64,
        /// What is wrong.
        what: String,
    },
}

#[derive(Debug, Clone, Copy)]
enum Format {
    Pcapng { big: bool },
    Pcap { big: bool, nanos: bool },
}

/// Reads pcapng or classic pcap, block by block.
#[derive(Debug)]
pub struct Reader<R: Read> {
    input: R,
    format: Format,
    offset: u64,
    buf: Vec<u8>,
    /// Per interface of this section: ticks per second.
    resolution: Vec<u64>,
    /// A classic pcap's header not yet reported (section, then interface).
    pending: Vec<Block<'static>>,
    first: Option<[u8; 4]>,
}

fn u16_at(b: &[u8], k: usize, big: bool) -> u16 {
    let v = [b[k], b[k + 1]];
    if big {
        u16::from_be_bytes(v)
    } else {
        u16::from_le_bytes(v)
    }
}

fn u32_at(b: &[u8], k: usize, big: bool) -> u32 {
    let v = [b[k], b[k + 1], b[k + 2], b[k + 3]];
    if big {
        u32::from_be_bytes(v)
    } else {
        u32::from_le_bytes(v)
    }
}

/// Options from `b` (a block's option area): (code, value) pairs until the end or `opt_endofopt`.
fn options(b: &[u8], big: bool) -> impl Iterator<Item = (u16, &[u8])> {
    let mut at = 0;
    std::iter::from_fn(move || {
        if at + 4 > b.len() {
            return None;
        }
        let code = u16_at(b, at, big);
        let len = usize::from(u16_at(b, at + 2, big));
        let value = b.get(at + 4..at + 4 + len)?;
        if code == OPT_END {
            return None;
        }
        at += 4 + len.next_multiple_of(4);
        Some((code, value))
    })
}

fn text(v: &[u8]) -> String {
    String::from_utf8_lossy(v).trim_end_matches('\0').to_owned()
}

/// Ticks per second of an `if_tsresol` value.
fn ticks_per_second(v: u8) -> u64 {
    let n = u32::from(v & 0x7F);
    if v & 0x80 == 0 {
        10u64.checked_pow(n).unwrap_or(u64::MAX)
    } else {
        1u64.checked_shl(n).unwrap_or(u64::MAX)
    }
}

fn to_micros(ticks: u64, per_second: u64) -> u64 {
    (u128::from(ticks) * 1_000_000 / u128::from(per_second.max(1))) as u64
}

impl<R: Read> Reader<R> {
    /// Open a capture: the first bytes say pcapng or pcap.
    pub fn new(mut input: R) -> Result<Self, ReadError> {
        let mut magic = [0u8; 4];
        input.read_exact(&mut magic)?;
        let mut r = Reader {
            input,
            format: Format::Pcapng { big: false },
            offset: 0,
            buf: Vec::new(),
            resolution: Vec::new(),
            pending: Vec::new(),
            first: None,
        };
        match magic {
            [0x0A, 0x0D, 0x0D, 0x0A] => r.first = Some(magic),
            _ => {
                let (big, nanos) = match magic {
                    [0xA1, 0xB2, 0xC3, 0xD4] => (true, false),
                    [0xD4, 0xC3, 0xB2, 0xA1] => (false, false),
                    [0xA1, 0xB2, 0x3C, 0x4D] => (true, true),
                    [0x4D, 0x3C, 0xB2, 0xA1] => (false, true),
                    _ => return Err(ReadError::Magic(magic)),
                };
                let mut h = [0u8; 20];
                r.input.read_exact(&mut h)?;
                r.offset = 24;
                r.format = Format::Pcap { big, nanos };
                let linktype = (u32_at(&h, 16, big) & 0xFFFF) as u16;
                r.pending = vec![
                    Block::Interface {
                        linktype,
                        name: None,
                    },
                    Block::Section { comment: None },
                ];
            }
        }
        Ok(r)
    }

    /// The next block, `None` at the end of the file.
    pub fn next_block(&mut self) -> Result<Option<Block<'_>>, ReadError> {
        if let Some(b) = self.pending.pop() {
            return Ok(Some(b));
        }
        match self.format {
            Format::Pcap { big, nanos } => self.next_pcap(big, nanos),
            Format::Pcapng { .. } => loop {
                let at = self.offset;
                let mut head = [0u8; 8];
                match self.first.take() {
                    Some(m) => {
                        head[..4].copy_from_slice(&m);
                        self.input.read_exact(&mut head[4..])?;
                    }
                    None => {
                        if !self.read_or_eof(&mut head)? {
                            return Ok(None);
                        }
                    }
                }
                let kind = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
                if kind == SHB {
                    // The byte order comes with the section: read the magic first.
                    let mut magic = [0u8; 4];
                    self.input.read_exact(&mut magic)?;
                    let big = match u32::from_le_bytes(magic) {
                        BYTE_ORDER_MAGIC => false,
                        0x4D3C_2B1A => true,
                        _ => {
                            return Err(ReadError::Malformed {
                                offset: at,
                                what: format!("section header byte-order magic {magic:02X?}"),
                            })
                        }
                    };
                    self.format = Format::Pcapng { big };
                    let len = u64::from(u32_at(&head, 4, big));
                    self.read_body(at, len, 4)?;
                    self.resolution.clear();
                    // body: [major, minor (4), section length (8), options…, total length]
                    let b = &self.buf;
                    let opts = b.get(12..b.len().saturating_sub(4)).unwrap_or(&[]);
                    let comment = options(opts, big)
                        .find(|(c, _)| *c == OPT_COMMENT)
                        .map(|(_, v)| text(v));
                    return Ok(Some(Block::Section { comment }));
                }
                let Format::Pcapng { big } = self.format else {
                    unreachable!("pcapng branch")
                };
                let kind = u32_at(&head, 0, big);
                let len = u64::from(u32_at(&head, 4, big));
                self.read_body(at, len, 0)?;
                let body_len = self.buf.len().saturating_sub(4);
                match kind {
                    IDB => {
                        let b = &self.buf[..body_len];
                        if b.len() < 8 {
                            return Err(self.malformed(at, "interface block shorter than 20 bytes"));
                        }
                        let linktype = u16_at(b, 0, big);
                        let mut per_second = 1_000_000;
                        let mut name = None;
                        for (code, v) in options(&b[8..], big) {
                            match code {
                                IF_TSRESOL if !v.is_empty() => per_second = ticks_per_second(v[0]),
                                IF_NAME => name = Some(text(v)),
                                _ => {}
                            }
                        }
                        self.resolution.push(per_second);
                        return Ok(Some(Block::Interface { linktype, name }));
                    }
                    EPB => {
                        let b = &self.buf[..body_len];
                        if b.len() < 20 {
                            return Err(
                                self.malformed(at, "enhanced packet block shorter than 32 bytes")
                            );
                        }
                        let interface = u32_at(b, 0, big);
                        let ticks =
                            (u64::from(u32_at(b, 4, big)) << 32) | u64::from(u32_at(b, 8, big));
                        let captured = u32_at(b, 12, big) as usize;
                        if b.get(20..20 + captured).is_none() {
                            return Err(self.malformed(
                                at,
                                &format!("packet length {captured} runs past the block"),
                            ));
                        }
                        let per_second = self
                            .resolution
                            .get(interface as usize)
                            .copied()
                            .unwrap_or(1_000_000);
                        let opts = &b[(20 + captured.next_multiple_of(4)).min(b.len())..];
                        let comment = options(opts, big)
                            .find(|(c, _)| *c == OPT_COMMENT)
                            .map(|(_, v)| text(v));
                        let b = &self.buf[..body_len];
                        return Ok(Some(Block::Packet {
                            interface,
                            at_us: to_micros(ticks, per_second),
                            data: &b[20..20 + captured],
                            comment,
                        }));
                    }
                    SPB => {
                        let b = &self.buf[..body_len];
                        if b.len() < 4 {
                            return Err(
                                self.malformed(at, "simple packet block shorter than 16 bytes")
                            );
                        }
                        let original = u32_at(b, 0, big) as usize;
                        let n = original.min(b.len() - 4);
                        return Ok(Some(Block::Packet {
                            interface: 0,
                            at_us: 0,
                            data: &self.buf[4..4 + n],
                            comment: None,
                        }));
                    }
                    _ => continue,
                }
            },
        }
    }

    fn malformed(&self, offset: u64, what: &str) -> ReadError {
        ReadError::Malformed {
            offset,
            what: what.to_owned(),
        }
    }

    /// Fill `buf` from the input; false on a clean end of file before its first byte.
    fn read_or_eof(&mut self, buf: &mut [u8]) -> Result<bool, ReadError> {
        let mut got = 0;
        while got < buf.len() {
            match self.input.read(&mut buf[got..]) {
                Ok(0) if got == 0 => return Ok(false),
                Ok(0) => return Err(io::Error::from(io::ErrorKind::UnexpectedEof).into()),
                Ok(n) => got += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e.into()),
            }
        }
        Ok(true)
    }

    /// Read the rest of a block of total length `len` (8 header bytes and `already` more
    /// were read) into `buf`.
    fn read_body(&mut self, at: u64, len: u64, already: usize) -> Result<(), ReadError> {
        if len < 12 + already as u64 || !len.is_multiple_of(4) || len > MAX_BLOCK as u64 {
            return Err(ReadError::Length {
                offset: at,
                len,
                max: MAX_BLOCK,
            });
        }
        let rest = len as usize - 8 - already;
        self.buf.clear();
        self.buf.resize(rest, 0);
        self.input.read_exact(&mut self.buf)?;
        self.offset = at + len;
        Ok(())
    }

    fn next_pcap(&mut self, big: bool, nanos: bool) -> Result<Option<Block<'_>>, ReadError> {
        let at = self.offset;
        let mut h = [0u8; 16];
        if !self.read_or_eof(&mut h)? {
            return Ok(None);
        }
        let secs = u64::from(u32_at(&h, 0, big));
        let frac = u64::from(u32_at(&h, 4, big));
        let captured = u64::from(u32_at(&h, 8, big));
        if captured > MAX_BLOCK as u64 {
            return Err(ReadError::Length {
                offset: at,
                len: captured,
                max: MAX_BLOCK,
            });
        }
        self.buf.clear();
        self.buf.resize(captured as usize, 0);
        self.input.read_exact(&mut self.buf)?;
        self.offset = at + 16 + captured;
        let at_us = secs * 1_000_000 + if nanos { frac / 1000 } else { frac };
        Ok(Some(Block::Packet {
            interface: 0,
            at_us,
            data: &self.buf,
            comment: None,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn collect(bytes: &[u8]) -> Vec<String> {
        let mut r = Reader::new(bytes).unwrap();
        let mut out = Vec::new();
        while let Some(b) = r.next_block().unwrap() {
            out.push(format!("{b:?}"));
        }
        out
    }

    #[test]
    fn what_is_written_reads_back() {
        let mut w = Writer::new(Vec::new(), "si test", Some("{\"x\":1}")).unwrap();
        let pdu = w.interface(252, "line").unwrap();
        let ser = w.interface(250, "line events").unwrap();
        w.packet(pdu, 1_700_000_000_123_456, &[1, 2, 3], None)
            .unwrap();
        w.packet(ser, 7, &[], Some("parity")).unwrap();
        assert!(
            w.packet(2, 0, &[], None).is_err(),
            "an undescribed interface"
        );
        let bytes = w.finish().unwrap();
        assert_eq!(bytes.len() % 4, 0);
        let mut r = Reader::new(&bytes[..]).unwrap();
        assert_eq!(
            r.next_block().unwrap(),
            Some(Block::Section {
                comment: Some("{\"x\":1}".into())
            })
        );
        assert_eq!(
            r.next_block().unwrap(),
            Some(Block::Interface {
                linktype: 252,
                name: Some("line".into())
            })
        );
        assert!(matches!(
            r.next_block().unwrap(),
            Some(Block::Interface { linktype: 250, .. })
        ));
        assert_eq!(
            r.next_block().unwrap(),
            Some(Block::Packet {
                interface: 0,
                at_us: 1_700_000_000_123_456,
                data: &[1, 2, 3],
                comment: None
            })
        );
        assert_eq!(
            r.next_block().unwrap(),
            Some(Block::Packet {
                interface: 1,
                at_us: 7,
                data: &[],
                comment: Some("parity".into())
            })
        );
        assert_eq!(r.next_block().unwrap(), None);
    }

    #[test]
    fn a_classic_pcap_reads_as_one_section() {
        let mut f = Vec::new();
        f.extend_from_slice(&0xA1B2_3C4Du32.to_be_bytes()); // nanoseconds, big-endian
        f.extend_from_slice(&[0, 2, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF]);
        f.extend_from_slice(&147u32.to_be_bytes());
        f.extend_from_slice(&5u32.to_be_bytes());
        f.extend_from_slice(&1_500u32.to_be_bytes());
        f.extend_from_slice(&2u32.to_be_bytes());
        f.extend_from_slice(&2u32.to_be_bytes());
        f.extend_from_slice(&[0x11, 0x22]);
        assert_eq!(
            collect(&f),
            [
                "Section { comment: None }",
                "Interface { linktype: 147, name: None }",
                "Packet { interface: 0, at_us: 5000001, data: [17, 34], comment: None }"
            ]
        );
    }

    #[test]
    fn a_nanosecond_interface_is_converted_to_microseconds() {
        assert_eq!(to_micros(1_500_000, ticks_per_second(9)), 1_500);
        assert_eq!(to_micros(3, ticks_per_second(0x80 | 1)), 1_500_000);
    }

    #[test]
    fn bad_files_are_errors_naming_the_offset() {
        assert!(matches!(
            Reader::new(&b"nope"[..]),
            Err(ReadError::Magic(m)) if &m == b"nope"
        ));
        let mut w = Writer::new(Vec::new(), "si", None).unwrap();
        w.interface(252, "x").unwrap();
        let mut bytes = w.finish().unwrap();
        let shb_len = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]) as usize;
        bytes[shb_len + 4..shb_len + 8].copy_from_slice(&u32::MAX.to_le_bytes());
        let mut r = Reader::new(&bytes[..]).unwrap();
        r.next_block().unwrap();
        let e = r.next_block().unwrap_err();
        assert!(
            e.to_string().starts_with(&format!(
                "capture block at offset {shb_len}: length 4294967295"
            )),
            "{e}"
        );
        // Cut anywhere, never a panic.
        let full = {
            let mut w = Writer::new(Vec::new(), "si", Some("c")).unwrap();
            let i = w.interface(252, "x").unwrap();
            w.packet(i, 1, &[9; 7], Some("k")).unwrap();
            w.finish().unwrap()
        };
        for n in 0..full.len() {
            if let Ok(mut r) = Reader::new(&full[..n]) {
                while let Ok(Some(_)) = r.next_block() {}
            }
        }
    }
}
