//! The USS telegram: `STX LGE ADR net-data BCC`, pure encode and decode, no state, no allocation.
//!
//! Sources: [Modbus/USS] §3.7.1 (telegram parts, word order), [ET200S SI 2005]
//! [ET200S SI 2005] §3.8.1, §3.8.3, and [USS spec] and [SINAMICS V20] p. 107 for what the manuals
//! leave out (LGE rule, ADR bits, BCC, PKE layout, task and response IDs, error numbers).
//!
//! - **STX** = 02H.
//! - **LGE** = n + 2: the net-data bytes plus ADR plus BCC; STX and LGE are not counted
//!   ([USS spec] §4.2. 2 ≤ LGE ≤ 254, so n ≤ 252 and a telegram is at most 256 bytes.
//!   The manuals say only "telegram length" ([Modbus/USS] §3.7 `[derived]`); we follow the USS
//!   spec.
//! - **ADR**: bits 0–4 slave address 0–31, bit 5 broadcast, bit 6 mirror, bit 7 special telegram
//!   ([`Adr`]).
//! - **BCC** = XOR of every byte from STX up to the last net byte, STX **included**; a receiver can
//!   check that the XOR of the whole telegram is 0 ([USS spec] §4.4. A BCC computed
//!   without STX differs by exactly 02H and is rejected.
//! - Net data: the PKW area (0, 3, 4 words or variable) followed by the PZD area (0–16 words), words
//!   high byte first, double words high word first ([Modbus/USS] §3.7.1).
//!
//! ```
//! use si_uss::frame::{self, Adr};
//! // The "common fixed length" of [SINAMICS CU240S] p. 178: PKW 4 words + PZD 2 words gives LGE 0EH, 16 bytes.
//! let mut buf = [0u8; frame::MAX_TELEGRAM];
//! let len = frame::encode(Adr::slave(1).unwrap(), &[0; 12], &mut buf).unwrap();
//! assert_eq!(len, 16);
//! assert_eq!(&buf[..3], &[0x02, 0x0E, 0x01]);
//! let t = frame::decode(&buf[..len]).unwrap();
//! assert_eq!(t.adr.address(), 1);
//! ```
//!
//! # Hand-written, not nom
//!
//! Hand-written because a nom version (commit ff29b82 in the history) was longer and
//! slower: [`decode`] checks the whole telegram's length against LGE and XORs it for the BCC,
//! which nom can only express through an error type carrying [`DecodeError`] and `consumed`
//! (36 → 59 lines), and [`NetData::parse`] reads words whose count it has already checked
//! (31 → 34 lines with `fill`); the `uss_decode` bench went from 57.5 to 70.8 ns.

use core::fmt;
use serde::{Deserialize, Serialize};

/// Parameter numbers with their page index live in [`crate::param`]; re-exported here because
/// PKE and IND are frame fields.
pub use crate::param::ParamAddress;

/// Start of text, the first byte of every telegram.
pub const STX: u8 = 0x02;
/// Most net-data bytes a telegram can carry (LGE ≤ 254).
pub const MAX_NET: usize = 252;
/// Longest telegram: STX + LGE + ADR + 252 net bytes + BCC.
pub const MAX_TELEGRAM: usize = MAX_NET + 4;
/// Most PZD words ([Modbus/USS] §3.7.6, Table 3-31: PZD 0…16).
pub const MAX_PZD_WORDS: usize = 16;
/// Most PWE words in a variable-length PKW area: 126 net words minus PKE and IND.
pub const MAX_PWE_WORDS: usize = MAX_NET / 2 - 2;
/// Highest slave address (ADR bits 0–4).
pub const MAX_ADDRESS: u8 = 31;

/// The block check character: XOR of `bytes`, which must start with STX and stop before the BCC.
///
/// ```
/// // STX LGE ADR with no net data: 02 ^ 02 ^ 05 = 05.
/// assert_eq!(si_uss::frame::bcc(&[0x02, 0x02, 0x05]), 0x05);
/// ```
pub fn bcc(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |acc, b| acc ^ b)
}

/// The ADR byte: slave address and telegram type ([USS spec] §4.3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Adr(pub u8);

impl Adr {
    /// Bit 5: broadcast, every slave takes it and none answers.
    pub const BROADCAST_BIT: u8 = 0x20;
    /// Bit 6: mirror telegram, the addressed slave sends it back unchanged.
    pub const MIRROR_BIT: u8 = 0x40;
    /// Bit 7: special telegram (drive-specific, not answered by this crate's drive simulator).
    pub const SPECIAL_BIT: u8 = 0x80;

    /// A normal data-exchange telegram to `address` (0–31); `None` above 31.
    pub const fn slave(address: u8) -> Option<Adr> {
        if address <= MAX_ADDRESS {
            Some(Adr(address))
        } else {
            None
        }
    }

    /// A broadcast telegram (bit 5; the address bits are sent as 0).
    pub const fn broadcast() -> Adr {
        Adr(Self::BROADCAST_BIT)
    }

    /// A mirror telegram to `address`; `None` above 31.
    pub const fn mirror(address: u8) -> Option<Adr> {
        if address <= MAX_ADDRESS {
            Some(Adr(address | Self::MIRROR_BIT))
        } else {
            None
        }
    }

    /// Bits 0–4.
    pub const fn address(self) -> u8 {
        self.0 & 0x1F
    }
    /// Bit 5.
    pub const fn is_broadcast(self) -> bool {
        self.0 & Self::BROADCAST_BIT != 0
    }
    /// Bit 6.
    pub const fn is_mirror(self) -> bool {
        self.0 & Self::MIRROR_BIT != 0
    }
    /// Bit 7.
    pub const fn is_special(self) -> bool {
        self.0 & Self::SPECIAL_BIT != 0
    }
    /// Bits 5–7 all clear: normal data exchange.
    pub const fn is_normal(self) -> bool {
        self.0 & 0xE0 == 0
    }
}

impl fmt::Display for Adr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.address())?;
        if self.is_broadcast() {
            f.write_str(" broadcast")?;
        }
        if self.is_mirror() {
            f.write_str(" mirror")?;
        }
        if self.is_special() {
            f.write_str(" special")?;
        }
        Ok(())
    }
}

/// Why a telegram could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// More than 252 net-data bytes.
    #[error("net data of {0} bytes is over the maximum of 252 (LGE ≤ 254)")]
    NetTooLong(usize),
    /// The output buffer cannot hold the telegram.
    #[error("output buffer of {have} bytes cannot hold the telegram of {need} bytes")]
    BufferTooSmall {
        /// Bytes needed.
        need: usize,
        /// Bytes available.
        have: usize,
    },
}

/// Build a telegram from ADR and net data into `out`; returns its length (net + 4).
pub fn encode(adr: Adr, net: &[u8], out: &mut [u8]) -> Result<usize, EncodeError> {
    if net.len() > MAX_NET {
        return Err(EncodeError::NetTooLong(net.len()));
    }
    let need = net.len() + 4;
    if out.len() < need {
        return Err(EncodeError::BufferTooSmall {
            need,
            have: out.len(),
        });
    }
    out[0] = STX;
    out[1] = (net.len() + 2) as u8;
    out[2] = adr.0;
    out[3..3 + net.len()].copy_from_slice(net);
    out[need - 1] = bcc(&out[..need - 1]);
    Ok(need)
}

/// Why received bytes are not a valid telegram. Offsets count from STX = 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error, Serialize, Deserialize)]
pub enum DecodeError {
    /// Fewer than the 4 bytes of the shortest telegram (STX LGE ADR BCC).
    #[error("telegram of {len} bytes is shorter than the minimum of 4 (STX LGE ADR BCC)")]
    TooShort {
        /// Bytes given.
        len: usize,
    },
    /// The first byte is not STX (comm error word bit 3, "start of frame not recognised").
    #[error("byte 0 is {found:02X}H, not STX 02H")]
    NoStx {
        /// The byte found.
        found: u8,
    },
    /// LGE outside 2…254 (comm error word bit 6).
    #[error("LGE at byte 1 is {lge}, outside 2…254")]
    LgeOutOfRange {
        /// The LGE byte.
        lge: u8,
    },
    /// LGE does not match the number of bytes (comm error word bit 6).
    #[error(
        "LGE at byte 1 is {lge}, so the telegram has {expected} bytes, but {found} were given"
    )]
    WrongLength {
        /// The LGE byte.
        lge: u8,
        /// Telegram length LGE promises.
        expected: usize,
        /// Bytes given.
        found: usize,
    },
    /// More than 256 bytes.
    #[error("{len} bytes are over the maximum telegram of 256 bytes")]
    Oversize {
        /// Bytes given.
        len: usize,
    },
    /// The BCC does not match (comm error word bit 4).
    #[error("BCC at byte {offset} is {found:02X}H, expected {expected:02X}H")]
    Bcc {
        /// Where the BCC is.
        offset: usize,
        /// XOR of STX … last net byte.
        expected: u8,
        /// The BCC received.
        found: u8,
    },
    /// A response from the wrong slave or of the wrong type (comm error word bit 0).
    #[error("ADR at byte 2 is {found:02X}H, expected {expected:02X}H")]
    UnexpectedAddress {
        /// The ADR byte we sent.
        expected: u8,
        /// The ADR byte received.
        found: u8,
    },
    /// The net data do not have the PKW/PZD structure configured for the slave.
    #[error("net data of {found} bytes at byte 3, the configured structure needs {expected}")]
    WrongStructure {
        /// Net bytes the structure needs.
        expected: usize,
        /// Net bytes received.
        found: usize,
    },
}

/// A checked telegram, borrowing its net data from the received bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Telegram<'a> {
    /// The ADR byte.
    pub adr: Adr,
    /// Net data (PKW then PZD), between ADR and BCC.
    pub net: &'a [u8],
}

/// Check STX, LGE and BCC of one whole telegram and take it apart.
pub fn decode(bytes: &[u8]) -> Result<Telegram<'_>, DecodeError> {
    if bytes.len() > MAX_TELEGRAM {
        return Err(DecodeError::Oversize { len: bytes.len() });
    }
    if bytes.len() < 4 {
        return Err(DecodeError::TooShort { len: bytes.len() });
    }
    if bytes[0] != STX {
        return Err(DecodeError::NoStx { found: bytes[0] });
    }
    let lge = bytes[1];
    if !(2..=254).contains(&lge) {
        return Err(DecodeError::LgeOutOfRange { lge });
    }
    let expected = usize::from(lge) + 2;
    if expected != bytes.len() {
        return Err(DecodeError::WrongLength {
            lge,
            expected,
            found: bytes.len(),
        });
    }
    let offset = bytes.len() - 1;
    let want = bcc(&bytes[..offset]);
    if want != bytes[offset] {
        return Err(DecodeError::Bcc {
            offset,
            expected: want,
            found: bytes[offset],
        });
    }
    Ok(Telegram {
        adr: Adr(bytes[2]),
        net: &bytes[3..offset],
    })
}

/// [`decode`], then check that ADR is `expected` (a master checks the answering slave).
pub fn decode_from(bytes: &[u8], expected: Adr) -> Result<Telegram<'_>, DecodeError> {
    let t = decode(bytes)?;
    if t.adr != expected {
        return Err(DecodeError::UnexpectedAddress {
            expected: expected.0,
            found: t.adr.0,
        });
    }
    Ok(t)
}

/// How many words the PKW area has ([Modbus/USS] §3.7.6, Table 3-31: 0, 3 or 4; [MM 440]:
/// P2013 also allows "variable", 127).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PkwWords {
    /// No parameter channel.
    None,
    /// PKE, IND, one PWE word.
    Three,
    /// PKE, IND, PWE1 (high word), PWE2 (low word).
    Four,
    /// PKE, IND and as many PWE words as the telegram carries (arrays, texts).
    Variable,
}

impl PkwWords {
    /// The fixed word count, `None` for [`PkwWords::Variable`].
    pub const fn fixed(self) -> Option<usize> {
        match self {
            PkwWords::None => Some(0),
            PkwWords::Three => Some(3),
            PkwWords::Four => Some(4),
            PkwWords::Variable => None,
        }
    }

    /// From the manual's count 0, 3 or 4 (and 127 for variable, as P2013 writes it).
    pub const fn from_count(n: u8) -> Option<PkwWords> {
        match n {
            0 => Some(PkwWords::None),
            3 => Some(PkwWords::Three),
            4 => Some(PkwWords::Four),
            127 => Some(PkwWords::Variable),
            _ => None,
        }
    }

    /// The manual's count (127 for variable).
    pub const fn count(self) -> u8 {
        match self {
            PkwWords::None => 0,
            PkwWords::Three => 3,
            PkwWords::Four => 4,
            PkwWords::Variable => 127,
        }
    }
}

/// The parameter identifier PKE: AK in bits 12–15, SPM (toggle bit of change reports) in bit 11,
/// PNU in bits 0–10 ([SINAMICS V20] p. 107; [Modbus/USS] §3.7.7 "PKE in the transmit buffer").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Pke(pub u16);

impl Pke {
    /// PKE from AK (0–15), SPM and PNU (0–2047); extra bits are masked off.
    pub const fn new(ak: u8, spm: bool, pnu: u16) -> Pke {
        Pke(((ak as u16 & 0xF) << 12) | ((spm as u16) << 11) | (pnu & 0x7FF))
    }
    /// Task ID (master → slave) or response ID (slave → master).
    pub const fn ak(self) -> u8 {
        (self.0 >> 12) as u8
    }
    /// Bit 11, the toggle bit of parameter change reports.
    pub const fn spm(self) -> bool {
        self.0 & 0x0800 != 0
    }
    /// Bits 0–10.
    pub const fn pnu(self) -> u16 {
        self.0 & 0x7FF
    }
}

/// A parameter channel area: PKE, IND and 0…124 PWE words.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Pkw {
    /// Parameter identifier.
    pub pke: Pke,
    /// Index word: sub-index in the low byte, PNU page bits in the high byte.
    pub ind: u16,
    pwe: [u16; MAX_PWE_WORDS],
    pwe_len: u8,
}

impl Pkw {
    /// A PKW area; `pwe` is cut to 124 words.
    pub fn new(pke: Pke, ind: u16, pwe: &[u16]) -> Pkw {
        let n = pwe.len().min(MAX_PWE_WORDS);
        let mut words = [0; MAX_PWE_WORDS];
        words[..n].copy_from_slice(&pwe[..n]);
        Pkw {
            pke,
            ind,
            pwe: words,
            pwe_len: n as u8,
        }
    }

    /// The PWE words (high word first).
    pub fn pwe(&self) -> &[u16] {
        &self.pwe[..usize::from(self.pwe_len)]
    }

    /// The value: one PWE word, or PWE1:PWE2 as a double word (high word first,
    /// [Modbus/USS] §3.7.1). In a 4-word area a word value sits in PWE2.
    pub fn value(&self) -> u32 {
        match self.pwe() {
            [] => 0,
            [w] => u32::from(*w),
            [h, l, ..] => (u32::from(*h) << 16) | u32::from(*l),
        }
    }

    /// The value read as signed, by the size the response ID gives: a word ID (1, 4, 9, 11)
    /// as a 16-bit two's complement number, any other as 32-bit (the PWE of a response carries
    /// no type of its own; a drive's parameter list says which parameters are signed).
    pub fn signed_value(&self) -> i32 {
        let v = self.value();
        if response::is_word(self.pke.ak()) {
            i32::from(v as u16 as i16)
        } else {
            v as i32
        }
    }

    /// Words of the area (2 + PWE words).
    pub fn words(&self) -> usize {
        2 + usize::from(self.pwe_len)
    }
}

impl fmt::Debug for Pkw {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Pkw {{ ak: {}, pnu: {}, ind: {:04X}, pwe: {:04X?} }}",
            self.pke.ak(),
            self.pke.pnu(),
            self.ind,
            self.pwe()
        )
    }
}

/// The process data area: 0…16 words (PZD1 = control/status word, PZD2 = setpoint/actual value).
#[derive(Clone, Copy, Default, PartialEq, Eq)]
pub struct Pzd {
    words: [u16; MAX_PZD_WORDS],
    len: u8,
}

impl Pzd {
    /// PZD words; cut to 16.
    pub fn new(words: &[u16]) -> Pzd {
        let n = words.len().min(MAX_PZD_WORDS);
        let mut w = [0; MAX_PZD_WORDS];
        w[..n].copy_from_slice(&words[..n]);
        Pzd {
            words: w,
            len: n as u8,
        }
    }
    /// The words.
    pub fn words(&self) -> &[u16] {
        &self.words[..usize::from(self.len)]
    }
    /// Mutable words.
    pub fn words_mut(&mut self) -> &mut [u16] {
        &mut self.words[..usize::from(self.len)]
    }
    /// PZD1: the control word (STW) to a slave, the status word (ZSW) from it.
    pub fn first(&self) -> Option<u16> {
        self.words().first().copied()
    }
    /// PZD2: the main setpoint (HSW) to a slave, the main actual value (HIW) from it.
    pub fn second(&self) -> Option<u16> {
        self.words().get(1).copied()
    }
}

impl fmt::Debug for Pzd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Pzd({:04X?})", self.words())
    }
}

/// Net data taken apart: optional PKW area, then PZD.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NetData {
    /// The parameter channel, if the structure has one.
    pub pkw: Option<Pkw>,
    /// The process data.
    pub pzd: Pzd,
}

impl NetData {
    /// Net bytes this structure occupies.
    pub fn len(&self) -> usize {
        2 * (self.pkw.map_or(0, |p| p.words()) + self.pzd.words().len())
    }

    /// True when there are no net data.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Write the net bytes into `out` (high byte first); returns the length.
    pub fn write(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let need = self.len();
        if need > MAX_NET {
            return Err(EncodeError::NetTooLong(need));
        }
        if out.len() < need {
            return Err(EncodeError::BufferTooSmall {
                need,
                have: out.len(),
            });
        }
        let mut i = 0;
        let mut put = |w: u16| {
            out[i..i + 2].copy_from_slice(&w.to_be_bytes());
            i += 2;
        };
        if let Some(p) = &self.pkw {
            put(p.pke.0);
            put(p.ind);
            p.pwe().iter().for_each(|&w| put(w));
        }
        self.pzd.words().iter().for_each(|&w| put(w));
        Ok(need)
    }

    /// Take net bytes apart for a slave with `pkw` PKW words and `pzd_words` PZD words. With
    /// [`PkwWords::Variable`] the PKW area is whatever precedes the PZD words.
    pub fn parse(net: &[u8], pkw: PkwWords, pzd_words: usize) -> Result<NetData, DecodeError> {
        let pzd_words = pzd_words.min(MAX_PZD_WORDS);
        let pkw_words = match pkw.fixed() {
            Some(n) => n,
            None => (net.len() / 2).saturating_sub(pzd_words).max(2),
        };
        let expected = 2 * (pkw_words + pzd_words);
        if net.len() != expected || net.len() > MAX_NET {
            return Err(DecodeError::WrongStructure {
                expected,
                found: net.len(),
            });
        }
        let word = |i: usize| u16::from_be_bytes([net[2 * i], net[2 * i + 1]]);
        let pkw = (pkw_words > 0).then(|| {
            let mut pwe = [0u16; MAX_PWE_WORDS];
            for (k, w) in pwe.iter_mut().enumerate().take(pkw_words - 2) {
                *w = word(2 + k);
            }
            Pkw::new(Pke(word(0)), word(1), &pwe[..pkw_words - 2])
        });
        let mut pzd = [0u16; MAX_PZD_WORDS];
        for (k, w) in pzd.iter_mut().enumerate().take(pzd_words) {
            *w = word(pkw_words + k);
        }
        Ok(NetData {
            pkw,
            pzd: Pzd::new(&pzd[..pzd_words]),
        })
    }
}

/// Task IDs AK, master → slave ([SINAMICS V20] p. 107; [Modbus/USS] §3.7.7).
pub mod task {
    /// No task (only PZD matter).
    pub const NONE: u8 = 0;
    /// Request parameter value.
    pub const READ: u8 = 1;
    /// Change parameter value, word.
    pub const WRITE_WORD: u8 = 2;
    /// Change parameter value, double word.
    pub const WRITE_DWORD: u8 = 3;
    /// Request descriptive element (with IND = 255 invalid for the ET 200S FCs, status bit 3).
    pub const READ_DESCRIPTION: u8 = 4;
    /// Change descriptive element (not in the [SINAMICS V20] list; MICROMASTER table).
    pub const WRITE_DESCRIPTION: u8 = 5;
    /// Request parameter value, array.
    pub const READ_ARRAY: u8 = 6;
    /// Change array value, word.
    pub const WRITE_ARRAY_WORD: u8 = 7;
    /// Change array value, double word.
    pub const WRITE_ARRAY_DWORD: u8 = 8;
    /// Request number of array elements.
    pub const READ_ARRAY_LEN: u8 = 9;
    /// Change array double word and store in EEPROM.
    pub const WRITE_ARRAY_DWORD_EEPROM: u8 = 11;
    /// Change array word and store in EEPROM.
    pub const WRITE_ARRAY_WORD_EEPROM: u8 = 12;
    /// Change double word and store in EEPROM.
    pub const WRITE_DWORD_EEPROM: u8 = 13;
    /// Change word and store in EEPROM.
    pub const WRITE_WORD_EEPROM: u8 = 14;
    /// Read/change text: invalid for the ET 200S FCs (status bit 3).
    pub const TEXT: u8 = 15;
}

/// Response IDs AK, slave → master ([SINAMICS V20] p. 107; [Modbus/USS] §3.7.7).
pub mod response {
    /// No response.
    pub const NONE: u8 = 0;
    /// Transfer parameter value, word.
    pub const VALUE_WORD: u8 = 1;
    /// Transfer parameter value, double word.
    pub const VALUE_DWORD: u8 = 2;
    /// Transfer descriptive element.
    pub const DESCRIPTION: u8 = 3;
    /// Transfer array value, word.
    pub const ARRAY_WORD: u8 = 4;
    /// Transfer array value, double word.
    pub const ARRAY_DWORD: u8 = 5;
    /// Transfer number of array elements.
    pub const ARRAY_LEN: u8 = 6;
    /// Task cannot be executed; the error number is in PWE.
    pub const CANNOT_EXECUTE: u8 = 7;
    /// No master control / no PKW rights.
    pub const NO_PERMISSION: u8 = 8;
    /// Parameter change report, word (9–12 are change reports).
    pub const CHANGE_REPORT_WORD: u8 = 9;
    /// Parameter change report, array double word (the last change report ID).
    pub const CHANGE_REPORT_ARRAY_DWORD: u8 = 12;
    /// Transfer text.
    pub const TEXT: u8 = 15;

    /// A response ID that carries a word value: 1, 4, 9 (change report, word) and 11 (change
    /// report, array word).
    pub const fn is_word(ak: u8) -> bool {
        matches!(ak, VALUE_WORD | ARRAY_WORD | CHANGE_REPORT_WORD | 11)
    }

    /// The response IDs that may answer task `ak` successfully ([SINAMICS V20] p. 107 pairs; the
    /// MICROMASTER table in [Modbus/USS] §3.7.7).
    pub const fn answers(ak: u8) -> &'static [u8] {
        match ak {
            super::task::NONE => &[NONE],
            super::task::READ => &[VALUE_WORD, VALUE_DWORD],
            super::task::WRITE_WORD | super::task::WRITE_WORD_EEPROM => &[VALUE_WORD],
            super::task::WRITE_DWORD | super::task::WRITE_DWORD_EEPROM => &[VALUE_DWORD],
            super::task::READ_DESCRIPTION | super::task::WRITE_DESCRIPTION => &[DESCRIPTION],
            super::task::READ_ARRAY => &[ARRAY_WORD, ARRAY_DWORD],
            super::task::WRITE_ARRAY_WORD | super::task::WRITE_ARRAY_WORD_EEPROM => &[ARRAY_WORD],
            super::task::WRITE_ARRAY_DWORD | super::task::WRITE_ARRAY_DWORD_EEPROM => {
                &[ARRAY_DWORD]
            }
            super::task::READ_ARRAY_LEN => &[ARRAY_LEN],
            super::task::TEXT => &[TEXT],
            _ => &[],
        }
    }
}

/// AK 7 error numbers ([SINAMICS V20] p. 107, for messages.
pub fn pkw_error_text(number: u16) -> &'static str {
    match number {
        0 => "illegal parameter number",
        1 => "parameter value cannot be changed (read-only)",
        2 => "lower or upper value limit exceeded",
        3 => "wrong sub-index",
        4 => "no array",
        5 => "wrong data type",
        6 => "setting not allowed (can only be reset)",
        7 => "descriptive element cannot be changed",
        9 => "description data not available",
        10 => "access group wrong",
        11 => "no parameter change rights",
        12 => "wrong password",
        17 => "task cannot be executed in this operating state",
        18 => "other error",
        20 => "illegal value",
        101 => "parameter number deactivated",
        _ => "drive-specific error",
    }
}

/// The name of byte `index` of a telegram as a trace labels it: `STX`, `LGE`, `ADR` and the
/// closing `BCC` ([Modbus/USS] §3.7.1, the telegram); `None` for net data, and for every
/// byte of something that does not start with [`STX`] or is shorter than a telegram's 4 bytes.
///
/// ```
/// use si_uss::frame::byte_name;
/// let telegram = [0x02, 0x03, 0x01, 0x00, 0x00];
/// let names: Vec<_> = (0..telegram.len()).map(|i| byte_name(&telegram, i)).collect();
/// assert_eq!(names, [Some("STX"), Some("LGE"), Some("ADR"), None, Some("BCC")]);
/// ```
pub fn byte_name(telegram: &[u8], index: usize) -> Option<&'static str> {
    if telegram.len() < 4 || telegram[0] != STX {
        return None;
    }
    match index {
        0 => Some("STX"),
        1 => Some("LGE"),
        2 => Some("ADR"),
        i if i + 1 == telegram.len() => Some("BCC"),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adr_bits_follow_the_uss_spec() {
        let a = Adr(0x65);
        assert_eq!(a.address(), 5);
        assert!(a.is_broadcast() && a.is_mirror() && !a.is_special());
        assert_eq!(Adr::slave(32), None);
        assert_eq!(Adr::mirror(3), Some(Adr(0x43)));
        assert_eq!(Adr::broadcast(), Adr(0x20));
        assert!(Adr(0x1F).is_normal());
    }

    #[test]
    fn pke_fields() {
        let p = Pke::new(2, false, 1082);
        assert_eq!(p.0, 0x2000 | 1082);
        assert_eq!((p.ak(), p.spm(), p.pnu()), (2, false, 1082));
        assert!(Pke(0x1800).spm());
    }

    #[test]
    fn byte_names_mark_the_telegram_frame_only() {
        let t = [0x02, 0x03, 0x01, 0x00, 0x00];
        let names: Vec<_> = (0..t.len()).map(|i| byte_name(&t, i)).collect();
        assert_eq!(
            names,
            [Some("STX"), Some("LGE"), Some("ADR"), None, Some("BCC")]
        );
        assert_eq!(byte_name(&[0x02, 0x02, 0x01], 0), None);
        assert_eq!(byte_name(&[0x03, 0x02, 0x01, 0x00], 0), None);
    }
}
