//! RK 512 telegrams: the 10-byte command header, the 4-byte continuation header and the 4-byte
//! reaction (response) header, pure encode and decode without state
//! ([CP 341] §2.2.3, Table 2-1, Fig. 2-13 to 2-16; [Public RK 512]).
//!
//! Every telegram travels as the payload of one 3964(R) block. The first byte tells first
//! (`00H`) from continuation (`FFH`) telegrams; the third byte tells commands (`'A'`, `'O'`,
//! `'E'`) from reactions (`00H`).
//!
//! ```
//! use si_rk512::frame::{Address, Command, CommandHeader, Coordination};
//!
//! // Fig. 2-13: SEND 50 data words to DB10 from DW1, no coordination flag, CPU 1.
//! let header = CommandHeader {
//!     command: Command::Send,
//!     address: Address::Db { db: 10, dw: 1 },
//!     length: 50,
//!     coordination: Coordination::cpu_only(1),
//! };
//! assert_eq!(header.encode(), [0x00, 0x00, 0x41, 0x44, 0x0A, 0x01, 0x00, 0x32, 0xFF, 0x1F]);
//! assert_eq!(CommandHeader::decode(&header.encode()), Ok(header));
//! ```
//!
//! # Readings where the texts disagree
//!
//! - **Counter letter (`[derived]`).** The table writes "'C' (5AH)"; 5AH is `'Z'` (German
//!   *Zähler*), and the German letters `'E'`/`'A'` for inputs/outputs show the table speaks German
//!   letters. Counters are encoded as `'Z'` (5AH); the decoder also accepts `'C'` (43H) from a
//!   partner that followed the translation, and a station sends `'C'` with
//!   [`CounterLetter::C`](crate::config::CounterLetter::C).
//! - **FETCH carries no data (`[derived]`).** The examples (Fig. 2-15, 2-16) show a header only, so
//!   a FETCH command is exactly 10 (or 4) bytes.
//! - **Bytes 5–6.** For `'D'`/`'X'` they are DB number and DW number (Fig. 2-13: `0A 01` =
//!   DB10, DW1); for the other types the manual says only "address part 1 / part 2", read here
//!   as one 16-bit big-endian start address (byte number for E/A/M, element number for T/Z),
//!   as in the public RK 512 headers ([Public RK 512]). How a DW number becomes a byte
//!   offset is a setting of the passive side ([`crate::config::DwUnit`]).
//! - **Length unit.** Words for D, X, T and Z, bytes for E, A and M ([CP 341] §2.2.3, Table 2-1
//!   "bytes or words depending on the data type"; a timer or counter cell is one word).
//! - **Byte 10 (`[derived]`).** Both nibbles are kept as sent: high nibble CPU number (1–4, `0`
//!   with a flag but no CPU, `F` none), low nibble flag bit (`F` none). Fig. 2-13's `1F` shows a
//!   CPU number without a flag.
//!
//! # Hand-written, not nom
//!
//! Hand-written because a nom version (commit 5bedae2 in the history) was longer and
//! slower: the errors name the offset and what the manual allows there, and the 4 identifying
//! bytes are checked before the 10-byte length, so nom needed its own error type, a context per
//! byte and a mapping back to [`DecodeError`] (403 → 450 code lines), and the
//! `rk512_decode_telegram` bench went from 7.4 to 16.2 ns.

use core::fmt;

/// First-telegram marker in byte 1 (command and reaction).
pub const FIRST: u8 = 0x00;
/// Continuation-telegram marker in byte 1 (command and reaction).
pub const CONTINUATION: u8 = 0xFF;
/// Length of the command header of a first telegram.
pub const COMMAND_HEADER_LEN: usize = 10;
/// Length of a continuation command header and of every reaction header.
pub const SHORT_HEADER_LEN: usize = 4;
/// User data per telegram ([CP 341] §2.2.3): more is carried by continuation telegrams.
pub const MAX_DATA_PER_TELEGRAM: usize = 128;
/// The longest telegram: a 10-byte header and 128 data bytes.
pub const MAX_TELEGRAM_LEN: usize = COMMAND_HEADER_LEN + MAX_DATA_PER_TELEGRAM;

/// The command letter in byte 3 (Table 2-1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// `'A'` (41H): SEND to a data block DB.
    Send,
    /// `'O'` (4FH): SEND to an extended data block DX.
    SendDx,
    /// `'E'` (45H): FETCH.
    Fetch,
}

impl Command {
    /// The ASCII letter on the wire.
    pub const fn letter(self) -> u8 {
        match self {
            Command::Send => b'A',
            Command::SendDx => b'O',
            Command::Fetch => b'E',
        }
    }

    /// The command for a letter, if it is one.
    pub const fn from_letter(letter: u8) -> Option<Command> {
        match letter {
            b'A' => Some(Command::Send),
            b'O' => Some(Command::SendDx),
            b'E' => Some(Command::Fetch),
            _ => None,
        }
    }

    /// True for SEND and SEND-to-DX.
    pub const fn is_send(self) -> bool {
        !matches!(self, Command::Fetch)
    }

    /// The job's name as the manual writes it: `SEND`, `SEND DX`, `FETCH`.
    pub const fn name(self) -> &'static str {
        match self {
            Command::Send => "SEND",
            Command::SendDx => "SEND DX",
            Command::Fetch => "FETCH",
        }
    }
}

/// The data type letter in byte 4 (Table 2-1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataType {
    /// `'D'` (44H): data block.
    Db,
    /// `'X'` (58H): extended data block DX.
    Dx,
    /// `'E'` (45H): input bytes.
    Inputs,
    /// `'A'` (41H): output bytes.
    Outputs,
    /// `'M'` (4DH): flag (memory) bytes.
    Flags,
    /// `'T'` (54H): timer cells.
    Timers,
    /// `'Z'` (5AH): counter cells (`[derived]`).
    Counters,
}

impl DataType {
    /// The ASCII letter on the wire (`'Z'` for counters, `[derived]`).
    pub const fn letter(self) -> u8 {
        match self {
            DataType::Db => b'D',
            DataType::Dx => b'X',
            DataType::Inputs => b'E',
            DataType::Outputs => b'A',
            DataType::Flags => b'M',
            DataType::Timers => b'T',
            DataType::Counters => b'Z',
        }
    }

    /// The data type for a letter; `'C'` is accepted for counters (`[derived]`).
    pub const fn from_letter(letter: u8) -> Option<DataType> {
        match letter {
            b'D' => Some(DataType::Db),
            b'X' => Some(DataType::Dx),
            b'E' => Some(DataType::Inputs),
            b'A' => Some(DataType::Outputs),
            b'M' => Some(DataType::Flags),
            b'T' => Some(DataType::Timers),
            b'Z' | b'C' => Some(DataType::Counters),
            _ => None,
        }
    }

    /// What the type addresses, in words: `data block`, `input bytes`, `timer cells`.
    pub const fn name(self) -> &'static str {
        match self {
            DataType::Db => "data block",
            DataType::Dx => "extended data block",
            DataType::Inputs => "input bytes",
            DataType::Outputs => "output bytes",
            DataType::Flags => "flag bytes",
            DataType::Timers => "timer cells",
            DataType::Counters => "counter cells",
        }
    }

    /// True when the header length counts 16-bit words (D, X, T, Z), false for bytes.
    pub const fn counts_words(self) -> bool {
        matches!(
            self,
            DataType::Db | DataType::Dx | DataType::Timers | DataType::Counters
        )
    }

    /// Data bytes for a header length of `length` units.
    pub const fn bytes_for(self, length: u16) -> usize {
        if self.counts_words() {
            length as usize * 2
        } else {
            length as usize
        }
    }
}

/// Where the data of a job lives at the partner: data type plus header bytes 5–6.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Address {
    /// Data block `db` from data word `dw`.
    Db {
        /// DB number (byte 5).
        db: u8,
        /// DW number (byte 6).
        dw: u8,
    },
    /// Extended data block `db` from data word `dw`.
    Dx {
        /// DX number (byte 5).
        db: u8,
        /// DW number (byte 6).
        dw: u8,
    },
    /// Input bytes from this byte number.
    Inputs(u16),
    /// Output bytes from this byte number.
    Outputs(u16),
    /// Flag bytes from this byte number.
    Flags(u16),
    /// Timer cells from this timer number.
    Timers(u16),
    /// Counter cells from this counter number.
    Counters(u16),
}

impl Address {
    /// The data type letter's meaning.
    pub const fn data_type(self) -> DataType {
        match self {
            Address::Db { .. } => DataType::Db,
            Address::Dx { .. } => DataType::Dx,
            Address::Inputs(_) => DataType::Inputs,
            Address::Outputs(_) => DataType::Outputs,
            Address::Flags(_) => DataType::Flags,
            Address::Timers(_) => DataType::Timers,
            Address::Counters(_) => DataType::Counters,
        }
    }

    /// Header bytes 5 and 6.
    pub const fn bytes(self) -> [u8; 2] {
        match self {
            Address::Db { db, dw } | Address::Dx { db, dw } => [db, dw],
            Address::Inputs(a)
            | Address::Outputs(a)
            | Address::Flags(a)
            | Address::Timers(a)
            | Address::Counters(a) => a.to_be_bytes(),
        }
    }

    /// The address for a data type and header bytes 5 and 6.
    pub const fn from_bytes(data_type: DataType, b: [u8; 2]) -> Address {
        let a = u16::from_be_bytes(b);
        match data_type {
            DataType::Db => Address::Db { db: b[0], dw: b[1] },
            DataType::Dx => Address::Dx { db: b[0], dw: b[1] },
            DataType::Inputs => Address::Inputs(a),
            DataType::Outputs => Address::Outputs(a),
            DataType::Flags => Address::Flags(a),
            DataType::Timers => Address::Timers(a),
            DataType::Counters => Address::Counters(a),
        }
    }
}

impl fmt::Display for Address {
    /// `DB10.DW1`, `DX3.DW0`, `MB100`, `IB0`, `QB4`, `T7`, `Z2`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Address::Db { db, dw } => write!(f, "DB{db}.DW{dw}"),
            Address::Dx { db, dw } => write!(f, "DX{db}.DW{dw}"),
            Address::Inputs(a) => write!(f, "IB{a}"),
            Address::Outputs(a) => write!(f, "QB{a}"),
            Address::Flags(a) => write!(f, "MB{a}"),
            Address::Timers(a) => write!(f, "T{a}"),
            Address::Counters(a) => write!(f, "Z{a}"),
        }
    }
}

/// Header bytes 9 and 10: coordination flag (interprocessor-communication flag, "KM") and CPU
/// number ([CP 341] §2.2.3, Table 2-1). Kept as sent, so decoding and encoding are exact inverses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Coordination {
    /// Flag byte number (byte 9); `FFH` when no flag is defined.
    pub flag_byte: u8,
    /// Flag bit number (byte 10 bits 0–3); `FH` when no flag is defined.
    pub flag_bit: u8,
    /// CPU number 1–4 (byte 10 bits 4–7); `0H` flag but no CPU, `FH` neither.
    pub cpu: u8,
}

impl Coordination {
    /// No flag and no CPU number: `FF FF`.
    pub const NONE: Coordination = Coordination {
        flag_byte: 0xFF,
        flag_bit: 0xF,
        cpu: 0xF,
    };

    /// A CPU number without a flag, as in Fig. 2-13 (`FF 1F`).
    pub const fn cpu_only(cpu: u8) -> Coordination {
        Coordination {
            flag_byte: 0xFF,
            flag_bit: 0xF,
            cpu: cpu & 0xF,
        }
    }

    /// Flag `byte.bit` (e.g. M 20.3) without a CPU number (high nibble 0, [CP 341] §2.2.3, Table
    /// 2-1).
    pub const fn flag(byte: u8, bit: u8) -> Coordination {
        Coordination {
            flag_byte: byte,
            flag_bit: bit & 0x7,
            cpu: 0,
        }
    }

    /// A flag written `BYTE.BIT` (`20.3`: M 20.3), byte 0 … 254 (FFH means "no flag") and bit
    /// 0 … 7, and CPU number `cpu` 1 … 4 if given ([CP 341] §2.2.3, Table 2-1); the error
    /// names what is out of range.
    pub fn parse(flag: Option<&str>, cpu: Option<u8>) -> Result<Coordination, String> {
        let mut c = match flag {
            None => Coordination::NONE,
            Some(text) => {
                let parsed = text.split_once('.').and_then(|(b, bit)| {
                    Some((b.trim().parse::<u8>().ok()?, bit.trim().parse::<u8>().ok()?))
                });
                match parsed {
                    Some((byte, bit)) if byte != 0xFF && bit <= 7 => Coordination::flag(byte, bit),
                    _ => {
                        return Err(format!(
                            "flag must be BYTE.BIT with BYTE 0 … 254 and BIT 0 … 7, got {text:?}"
                        ))
                    }
                }
            }
        };
        if let Some(cpu) = cpu {
            if !(1..=4).contains(&cpu) {
                return Err(format!("cpu must be 1 … 4, got {cpu}"));
            }
            c.cpu = cpu;
        }
        Ok(c)
    }

    /// The flag as (byte, bit) when one is defined: byte ≠ FFH and bit 0–7.
    pub const fn flag_address(self) -> Option<(u8, u8)> {
        if self.flag_byte != 0xFF && self.flag_bit <= 7 {
            Some((self.flag_byte, self.flag_bit))
        } else {
            None
        }
    }

    /// Bytes 9 and 10.
    pub const fn bytes(self) -> [u8; 2] {
        [self.flag_byte, (self.cpu << 4) | (self.flag_bit & 0xF)]
    }

    /// From bytes 9 and 10.
    pub const fn from_bytes(b: [u8; 2]) -> Coordination {
        Coordination {
            flag_byte: b[0],
            flag_bit: b[1] & 0xF,
            cpu: b[1] >> 4,
        }
    }
}

impl Default for Coordination {
    /// [`Coordination::NONE`].
    fn default() -> Self {
        Coordination::NONE
    }
}

/// The 10-byte header of a first command telegram (Table 2-1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CommandHeader {
    /// SEND, SEND to DX, or FETCH (byte 3).
    pub command: Command,
    /// Data type and bytes 5–6.
    pub address: Address,
    /// Bytes 7–8: the length of the whole job in words (D, X, T, Z) or bytes (E, A, M).
    pub length: u16,
    /// Bytes 9–10.
    pub coordination: Coordination,
}

impl CommandHeader {
    /// The 10 header bytes.
    pub fn encode(&self) -> [u8; COMMAND_HEADER_LEN] {
        let a = self.address.bytes();
        let l = self.length.to_be_bytes();
        let c = self.coordination.bytes();
        [
            FIRST,
            0x00,
            self.command.letter(),
            self.address.data_type().letter(),
            a[0],
            a[1],
            l[0],
            l[1],
            c[0],
            c[1],
        ]
    }

    /// Decode the first 10 bytes of a first command telegram (any data after them is ignored).
    pub fn decode(bytes: &[u8]) -> Result<CommandHeader, DecodeError> {
        // The identifying bytes first, so a wrong one is named even in a short telegram.
        need(bytes, SHORT_HEADER_LEN)?;
        expect(bytes, 0, FIRST, "00H (first command telegram)")?;
        expect(bytes, 1, 0x00, "00H")?;
        let command = command_at(bytes)?;
        let data_type = data_type_at(bytes)?;
        need(bytes, COMMAND_HEADER_LEN)?;
        Ok(CommandHeader {
            command,
            address: Address::from_bytes(data_type, [bytes[4], bytes[5]]),
            length: u16::from_be_bytes([bytes[6], bytes[7]]),
            coordination: Coordination::from_bytes([bytes[8], bytes[9]]),
        })
    }

    /// Data bytes of the whole job.
    pub fn data_len(&self) -> usize {
        self.address.data_type().bytes_for(self.length)
    }
}

/// The 4-byte header of a continuation command telegram: `FF 00 <command> <data type>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ContinuationHeader {
    /// Byte 3, as in the first telegram.
    pub command: Command,
    /// Byte 4, as in the first telegram.
    pub data_type: DataType,
}

impl ContinuationHeader {
    /// The 4 header bytes.
    pub fn encode(&self) -> [u8; SHORT_HEADER_LEN] {
        [
            CONTINUATION,
            0x00,
            self.command.letter(),
            self.data_type.letter(),
        ]
    }

    /// Decode the first 4 bytes of a continuation command telegram.
    pub fn decode(bytes: &[u8]) -> Result<ContinuationHeader, DecodeError> {
        need(bytes, SHORT_HEADER_LEN)?;
        expect(
            bytes,
            0,
            CONTINUATION,
            "FFH (continuation command telegram)",
        )?;
        expect(bytes, 1, 0x00, "00H")?;
        Ok(ContinuationHeader {
            command: command_at(bytes)?,
            data_type: data_type_at(bytes)?,
        })
    }
}

/// The 4-byte header of a reaction telegram (Table 2-2): `00|FF 00 00 <error number>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ReactionHeader {
    /// Answers a continuation telegram (`FFH`) rather than a first one (`00H`).
    pub continuation: bool,
    /// The partner's error number; 0 = no error (see [`crate::status::ErrorNumber`]).
    pub error: u8,
}

impl ReactionHeader {
    /// The 4 header bytes.
    pub fn encode(&self) -> [u8; SHORT_HEADER_LEN] {
        [
            if self.continuation {
                CONTINUATION
            } else {
                FIRST
            },
            0x00,
            0x00,
            self.error,
        ]
    }

    /// Decode the first 4 bytes of a reaction telegram.
    pub fn decode(bytes: &[u8]) -> Result<ReactionHeader, DecodeError> {
        need(bytes, SHORT_HEADER_LEN)?;
        let continuation = match bytes[0] {
            FIRST => false,
            CONTINUATION => true,
            found => {
                return Err(DecodeError::Unexpected {
                    offset: 0,
                    expected: "00H or FFH (reaction telegram)",
                    found,
                })
            }
        };
        expect(bytes, 1, 0x00, "00H")?;
        expect(bytes, 2, 0x00, "00H (reaction telegram)")?;
        Ok(ReactionHeader {
            continuation,
            error: bytes[3],
        })
    }
}

/// Any RK 512 telegram, with its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Telegram<'a> {
    /// A first command telegram and the data after its header (SEND) or none (FETCH).
    Command(CommandHeader, &'a [u8]),
    /// A continuation command telegram and its data.
    Continuation(ContinuationHeader, &'a [u8]),
    /// A reaction telegram and its data (FETCH reactions).
    Reaction(ReactionHeader, &'a [u8]),
}

impl<'a> Telegram<'a> {
    /// Decode a whole telegram (the payload of one 3964(R) block). Byte 3 tells reactions
    /// (`00H`) from commands; byte 1 tells first from continuation telegrams.
    pub fn decode(bytes: &'a [u8]) -> Result<Telegram<'a>, DecodeError> {
        need(bytes, SHORT_HEADER_LEN)?;
        if bytes[2] == 0x00 {
            // A FETCH reaction carries at most 128 data bytes as well ([CP 341] §2.2.3).
            let h = ReactionHeader::decode(bytes)?;
            let data = &bytes[SHORT_HEADER_LEN..];
            check_data_len(data.len(), SHORT_HEADER_LEN)?;
            return Ok(Telegram::Reaction(h, data));
        }
        let data_len = bytes.len().saturating_sub(SHORT_HEADER_LEN);
        match bytes[0] {
            CONTINUATION => {
                let h = ContinuationHeader::decode(bytes)?;
                check_data_len(data_len, SHORT_HEADER_LEN)?;
                Ok(Telegram::Continuation(h, &bytes[SHORT_HEADER_LEN..]))
            }
            _ => {
                let h = CommandHeader::decode(bytes)?;
                let data = &bytes[COMMAND_HEADER_LEN..];
                check_data_len(data.len(), COMMAND_HEADER_LEN)?;
                Ok(Telegram::Command(h, data))
            }
        }
    }
}

fn check_data_len(len: usize, header: usize) -> Result<(), DecodeError> {
    if len > MAX_DATA_PER_TELEGRAM {
        Err(DecodeError::TooMuchData {
            offset: header + MAX_DATA_PER_TELEGRAM,
            len,
        })
    } else {
        Ok(())
    }
}

fn need(bytes: &[u8], len: usize) -> Result<(), DecodeError> {
    if bytes.len() < len {
        Err(DecodeError::TooShort {
            expected: len,
            found: bytes.len(),
        })
    } else {
        Ok(())
    }
}

fn expect(
    bytes: &[u8],
    offset: usize,
    value: u8,
    expected: &'static str,
) -> Result<(), DecodeError> {
    if bytes[offset] == value {
        Ok(())
    } else {
        Err(DecodeError::Unexpected {
            offset,
            expected,
            found: bytes[offset],
        })
    }
}

fn command_at(bytes: &[u8]) -> Result<Command, DecodeError> {
    Command::from_letter(bytes[2]).ok_or(DecodeError::Unexpected {
        offset: 2,
        expected: "command 'A' (41H), 'O' (4FH) or 'E' (45H)",
        found: bytes[2],
    })
}

fn data_type_at(bytes: &[u8]) -> Result<DataType, DecodeError> {
    DataType::from_letter(bytes[3]).ok_or(DecodeError::Unexpected {
        offset: 3,
        expected: "data type 'D', 'X', 'E', 'A', 'M', 'T' or 'Z'",
        found: bytes[3],
    })
}

/// What is wrong with a telegram: the offset, what was expected and what was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// Fewer bytes than the header needs.
    #[error("telegram too short: expected at least {expected} bytes, found {found}")]
    TooShort {
        /// Bytes the header needs.
        expected: usize,
        /// Bytes given.
        found: usize,
    },
    /// A header byte has a value the telegram cannot have.
    #[error("byte at offset {offset}: expected {expected}, found {found:02X}H")]
    Unexpected {
        /// Offset of the byte from the start of the telegram (0-based).
        offset: usize,
        /// What the manual allows there.
        expected: &'static str,
        /// The byte found.
        found: u8,
    },
    /// More than 128 data bytes in one telegram ([CP 341] §2.2.3).
    #[error("at offset {offset}: expected at most 128 data bytes per telegram, found {len}")]
    TooMuchData {
        /// Offset of the first byte beyond the limit.
        offset: usize,
        /// Data bytes found.
        len: usize,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_coordination_flag_is_byte_dot_bit_and_the_cpu_1_to_4() {
        assert_eq!(Coordination::parse(None, None), Ok(Coordination::NONE));
        let c = Coordination::parse(Some("20.3"), Some(2)).unwrap();
        assert_eq!((c.flag_address(), c.cpu), (Some((20, 3)), 2));
        for bad in ["255.0", "20.8", "20", "x.1"] {
            let e = Coordination::parse(Some(bad), None).unwrap_err();
            assert!(e.contains(bad), "{e}");
        }
        assert!(Coordination::parse(None, Some(5))
            .unwrap_err()
            .contains("got 5"));
    }

    /// Fig. 2-13: `00 00 41 44 0A 01 00 32 FF 1F`.
    #[test]
    fn fig_2_13_send_header() {
        let bytes = [0x00, 0x00, 0x41, 0x44, 0x0A, 0x01, 0x00, 0x32, 0xFF, 0x1F];
        let h = CommandHeader::decode(&bytes).unwrap();
        assert_eq!(h.command, Command::Send);
        assert_eq!(h.address, Address::Db { db: 10, dw: 1 });
        assert_eq!(h.length, 50);
        assert_eq!(h.data_len(), 100);
        assert_eq!(h.coordination.cpu, 1);
        assert_eq!(h.coordination.flag_address(), None);
        assert_eq!(h.encode(), bytes);
    }

    /// Fig. 2-14: continuation SEND `FF 00 41 44`, answered by `FF 00 00 <err>`.
    #[test]
    fn fig_2_14_continuation_send() {
        let c = ContinuationHeader {
            command: Command::Send,
            data_type: DataType::Db,
        };
        assert_eq!(c.encode(), [0xFF, 0x00, 0x41, 0x44]);
        let r = ReactionHeader {
            continuation: true,
            error: 0,
        };
        assert_eq!(r.encode(), [0xFF, 0x00, 0x00, 0x00]);
        assert_eq!(
            Telegram::decode(&[0xFF, 0x00, 0x41, 0x44, 1, 2]),
            Ok(Telegram::Continuation(c, &[1, 2][..]))
        );
    }

    /// Fig. 2-15: FETCH `00 00 45 44 <DB> 64 00 32 FF 1F` (DW100, 50 words); `[derived]`: the DB
    /// byte is taken as 0AH (DB10) like the SEND example.
    #[test]
    fn fig_2_15_fetch_header_and_reaction() {
        let bytes = [0x00, 0x00, 0x45, 0x44, 0x0A, 0x64, 0x00, 0x32, 0xFF, 0x1F];
        let h = CommandHeader::decode(&bytes).unwrap();
        assert_eq!(h.command, Command::Fetch);
        assert_eq!(h.address, Address::Db { db: 10, dw: 100 });
        assert_eq!(h.address.to_string(), "DB10.DW100");
        assert_eq!(
            Telegram::decode(&[0, 0, 0, 0, 0xAB, 0xCD]),
            Ok(Telegram::Reaction(
                ReactionHeader {
                    continuation: false,
                    error: 0
                },
                &[0xAB, 0xCD][..]
            ))
        );
    }

    /// Fig. 2-16: continuation FETCH `FF 00 45 44`, reaction `FF 00 00 <err>` + data.
    #[test]
    fn fig_2_16_continuation_fetch() {
        let c = ContinuationHeader {
            command: Command::Fetch,
            data_type: DataType::Db,
        };
        assert_eq!(c.encode(), [0xFF, 0x00, 0x45, 0x44]);
        assert_eq!(
            Telegram::decode(&[0xFF, 0, 0, 0x34]),
            Ok(Telegram::Reaction(
                ReactionHeader {
                    continuation: true,
                    error: 0x34
                },
                &[][..]
            ))
        );
    }

    #[test]
    fn counters_are_z_and_c_is_accepted() {
        assert_eq!(DataType::Counters.letter(), 0x5A);
        assert_eq!(DataType::from_letter(b'C'), Some(DataType::Counters));
        let h = CommandHeader::decode(&[0, 0, b'E', b'C', 0, 5, 0, 2, 0xFF, 0xFF]).unwrap();
        assert_eq!(h.address, Address::Counters(5));
        assert_eq!(h.data_len(), 4);
    }

    #[test]
    fn errors_name_offset_expected_and_found() {
        let e = Telegram::decode(&[0, 0, b'Q', b'D', 0, 0, 0, 1, 0xFF, 0xFF]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "byte at offset 2: expected command 'A' (41H), 'O' (4FH) or 'E' (45H), found 51H"
        );
        let e = Telegram::decode(&[0, 0, b'A', b'D', 0]).unwrap_err();
        assert_eq!(
            e,
            DecodeError::TooShort {
                expected: 10,
                found: 5
            }
        );
        let e = Telegram::decode(&[0, 1, 0, 0]).unwrap_err();
        assert!(matches!(e, DecodeError::Unexpected { offset: 1, .. }));
        let mut long = vec![0xFF, 0, b'A', b'D'];
        long.extend([0; 129]);
        assert_eq!(
            Telegram::decode(&long),
            Err(DecodeError::TooMuchData {
                offset: 132,
                len: 129
            })
        );
    }

    /// A reaction of 59,996 data bytes is refused like a command of 129 ([CP 341] §2.2.3).
    #[test]
    fn a_reaction_with_more_than_128_data_bytes_is_refused() {
        let mut reaction = vec![0, 0, 0, 0];
        reaction.extend([0; 128]);
        assert!(matches!(
            Telegram::decode(&reaction),
            Ok(Telegram::Reaction(_, d)) if d.len() == 128
        ));
        reaction.push(0);
        assert_eq!(
            Telegram::decode(&reaction),
            Err(DecodeError::TooMuchData {
                offset: 132,
                len: 129
            })
        );
        let mut huge = vec![0xFF, 0, 0, 0];
        huge.extend(std::iter::repeat_n(0x55, 59_996));
        let e = Telegram::decode(&huge).unwrap_err();
        assert_eq!(
            e.to_string(),
            "at offset 132: expected at most 128 data bytes per telegram, found 59996"
        );
    }

    #[test]
    fn coordination_flag_with_and_without_cpu() {
        let c = Coordination::flag(20, 3);
        assert_eq!(c.bytes(), [20, 0x03]);
        assert_eq!(c.flag_address(), Some((20, 3)));
        assert_eq!(Coordination::NONE.bytes(), [0xFF, 0xFF]);
        assert_eq!(
            Coordination::from_bytes([0xFF, 0x1F]),
            Coordination::cpu_only(1)
        );
    }
}
