//! PROFIBUS slave diagnosis of an ET 200S station with an SI module: decode and encode.
//!
//! [ET200S SI 2005] Tables 2-30, 3-73 (Tables 2-30 and 3-73), [ET200S SI] §2.13, Table 2-29
//! (Table 2-29) and [Modbus/USS] §3.6.3 (Table 3-28): "the slave diagnosis follows
//! EN 50170 vol. 2. It contains module diagnosis, module status and channel-specific diagnosis;
//! the channel-specific part comes after the module status." The manuals refer to the ET 200S
//! system manual for the byte layout; this module decodes that layout:
//!
//! | Offset | Part | Bytes |
//! |---|---|---|
//! | 0 … 5 | standard diagnosis: station status 1–3, master address, ident number (MSB first) | 6 |
//! | 6 … | module diagnosis (identifier-related): header `01LLLLLL` (L counts the header), one bit per module | L |
//! | … | module status (device-related): header `00LLLLLL`, status type 82H, 00H, 00H, two bits per module | L |
//! | … | channel-specific diagnosis: 3 bytes per channel, header `10SSSSSS` (slot) | 3 each |
//!
//! Each part after the standard diagnosis is optional (the IM sends it only when it has
//! something to say or the parameters ask for it), and the IM sends them in this order.
//!
//! The channel-specific third byte holds the channel type (bits 7–5) and the **5-bit error
//! type** (bits 4–0) of Tables 2-30 / 3-73, decoded as [`ErrorType`] with the manual's meaning
//! and action per module variant ([`Variant`]).
//!
//! # A full station: what the SI module's tables do not describe
//!
//! The diagnosis is the whole station's, so it also carries what the other modules of the
//! station report, and blocks the SI manuals do not describe. Decoding does not fail on them:
//! each is kept as an [`UnknownPart`] with its offset, a typed [`UnknownKind`] and its raw
//! bytes, and everything else is decoded as usual:
//!
//! - a channel entry whose error type is not in Tables 2-30 / 3-73 (another module's, such as
//!   a digital module's short circuit), or whose I/O type (00) or channel type (000, 111) is
//!   reserved: [`UnknownKind::Channel`], with slot, channel and the fields that are known;
//! - a device-related block (header `00`) that is not the module status `82H 00H 00H`: an
//!   interrupt, a DP-V1 status message, a manufacturer-specific block:
//!   [`UnknownKind::StatusBlock`];
//! - a second module diagnosis or module status ([`UnknownKind::Repeated`]);
//! - a header with bits 7–6 = 11, whose length rule none of the manuals give: the rest of the
//!   diagnosis is kept as one [`UnknownKind::Header`] part rather than guessed at.
//!
//! Decoding fails only where a length is wrong: fewer than 6 bytes, more than 244, a block
//! header of length 0, or a block or channel entry running past the end ([`DiagError`], naming
//! the offset). It never panics.
//!
//! # Readings
//!
//! - **Module numbering in the bit fields.** The ET 200S figures label the first bit field byte
//!   "modules 1 to 8"; we read bit 0 of the first byte as module 1 (the module diagnosis) and
//!   bits 1–0 of the first byte as module 1 (the module status).
//! - **Order.** The first module diagnosis and the first module status are decoded wherever
//!   they stand (an IM may append interrupts after the channel entries; a block out of the
//!   usual order is still the block its header says). [`SlaveDiagnosis::encode`] writes the
//!   usual order, then the unknown parts in the order received, so a diagnosis whose unknown
//!   parts came last encodes to the bytes it was decoded from.
//! - **Error types outside the tables.** The SI module reports only the six types of Tables 2-30
//!   / 3-73; other ET 200S modules in the same station use further types, which are theirs to
//!   explain, so they are kept raw rather than given a meaning from another manual.
//! - **Type 8 wording.** Chapter 2 limits "underflow" to 3964(R) ("a message of length 0 was
//!   sent"); chapter 3 gives the same text without the restriction. [`ErrorType::meaning`] gives
//!   each variant its own wording.
//!
//! # Hand-written, not nom
//!
//! Hand-written because a nom version (commit 303f045 in the history) was longer and
//! slower: the parts are ordered and may each be absent, every error names its part and offset,
//! so the loop and its checks stay as they are and nom only replaced the slicing, through a
//! 17-line helper mapping its errors to [`DiagError::Truncated`] (521 → 536 code lines;
//! `module_diag_decode` 64.8 → 87.8 ns).

use serde::{Deserialize, Serialize};

/// The longest slave diagnosis EN 50170 allows (244 bytes).
pub const MAX_DIAG_LEN: usize = 244;

/// Length of the standard diagnosis (station status 1–3, master address, ident number).
pub const STANDARD_LEN: usize = 6;

/// Status type of the ET 200S module status block (82H, "module status").
pub const MODULE_STATUS_TYPE: u8 = 0x82;

/// The two SI module families, whose manuals word the channel errors slightly differently.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Variant {
    /// ET 200S 1SI 3964(R)/ASCII, 6ES7 138-4DF01-0AB0 (chapter 2, Table 2-30).
    #[default]
    #[serde(rename = "3964r-ascii")]
    R3964Ascii,
    /// ET 200S 1SI Modbus/USS, 6ES7 138-4DF11-0AB0 (chapter 3, Table 3-73).
    ModbusUss,
}

/// The 5-bit channel error type of Tables 2-30 and 3-73 ([ET200S SI 2005] Tables 2-30, 3-73).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ErrorType {
    /// 00110 (6): wire break or disconnection.
    WireBreak,
    /// 00111 (7): overflow: buffer overflow, message length overflow.
    Overflow,
    /// 01000 (8): underflow: a message of length 0 was sent.
    Underflow,
    /// 01001 (9): internal module error.
    InternalError,
    /// 10000 (16): parameter assignment error: module not parameterized.
    ParameterAssignment,
    /// 10110 (22): message error: frame or parity error.
    MessageError,
}

impl ErrorType {
    /// Every type of the tables, in table order.
    pub const ALL: [ErrorType; 6] = [
        ErrorType::WireBreak,
        ErrorType::Overflow,
        ErrorType::Underflow,
        ErrorType::InternalError,
        ErrorType::ParameterAssignment,
        ErrorType::MessageError,
    ];

    /// The 5-bit code.
    pub const fn code(self) -> u8 {
        match self {
            ErrorType::WireBreak => 6,
            ErrorType::Overflow => 7,
            ErrorType::Underflow => 8,
            ErrorType::InternalError => 9,
            ErrorType::ParameterAssignment => 16,
            ErrorType::MessageError => 22,
        }
    }

    /// The type for a 5-bit code, if the SI module's tables list it.
    pub const fn from_code(code: u8) -> Option<ErrorType> {
        Some(match code {
            6 => ErrorType::WireBreak,
            7 => ErrorType::Overflow,
            8 => ErrorType::Underflow,
            9 => ErrorType::InternalError,
            16 => ErrorType::ParameterAssignment,
            22 => ErrorType::MessageError,
            _ => return None,
        })
    }

    /// The table's short name.
    pub const fn name(self) -> &'static str {
        match self {
            ErrorType::WireBreak => "wire break",
            ErrorType::Overflow => "overflow",
            ErrorType::Underflow => "underflow",
            ErrorType::InternalError => "error",
            ErrorType::ParameterAssignment => "parameter assignment error",
            ErrorType::MessageError => "message error",
        }
    }

    /// The manual's meaning for this module variant.
    pub const fn meaning(self, variant: Variant) -> &'static str {
        match (self, variant) {
            (ErrorType::WireBreak, _) => "a wire is broken or disconnected",
            (ErrorType::Overflow, _) => "buffer overflow, or message length exceeded",
            (ErrorType::Underflow, Variant::R3964Ascii) => {
                "a message of length 0 was sent (3964(R) only)"
            }
            (ErrorType::Underflow, Variant::ModbusUss) => "a message of length 0 was sent",
            (ErrorType::InternalError, _) => "internal module error",
            (ErrorType::ParameterAssignment, _) => "the module is not parameterized",
            (ErrorType::MessageError, _) => "frame error or parity error",
        }
    }

    /// The manual's action for this module variant.
    pub const fn action(self, variant: Variant) -> &'static str {
        match (self, variant) {
            (ErrorType::WireBreak, _) => "check the terminal wiring and the partner cable",
            (ErrorType::Overflow, _) => "call S_RCV more often",
            (ErrorType::Underflow, Variant::R3964Ascii) => {
                "find out why the partner sends empty frames"
            }
            (ErrorType::Underflow, Variant::ModbusUss) => {
                "check why the partner sends frames without user data"
            }
            (ErrorType::InternalError, _) => "replace the module",
            (ErrorType::ParameterAssignment, _) => "correct the parameter assignment",
            (ErrorType::MessageError, _) => "check the communication settings",
        }
    }
}

/// Whether the reporting channel is an input, an output or both (byte 2, bits 7–6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IoType {
    /// 01: input channel.
    Input,
    /// 10: output channel.
    Output,
    /// 11: input/output channel.
    InputOutput,
}

/// The data width of the reporting channel (byte 3, bits 7–5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ChannelType {
    /// 001: bit.
    Bit,
    /// 010: 2 bits.
    TwoBits,
    /// 011: 4 bits.
    FourBits,
    /// 100: byte.
    Byte,
    /// 101: word.
    Word,
    /// 110: 2 words.
    TwoWords,
}

impl IoType {
    /// A short description.
    pub const fn text(self) -> &'static str {
        match self {
            IoType::Input => "input",
            IoType::Output => "output",
            IoType::InputOutput => "input/output",
        }
    }

    const fn bits(self) -> u8 {
        match self {
            IoType::Input => 1,
            IoType::Output => 2,
            IoType::InputOutput => 3,
        }
    }

    /// The type for bits 7–6 of byte 2; 00 is reserved.
    const fn from_bits(bits: u8) -> Option<IoType> {
        Some(match bits {
            1 => IoType::Input,
            2 => IoType::Output,
            3 => IoType::InputOutput,
            _ => return None,
        })
    }
}

impl ChannelType {
    /// A short description.
    pub const fn text(self) -> &'static str {
        match self {
            ChannelType::Bit => "bit",
            ChannelType::TwoBits => "2 bits",
            ChannelType::FourBits => "4 bits",
            ChannelType::Byte => "byte",
            ChannelType::Word => "word",
            ChannelType::TwoWords => "2 words",
        }
    }

    const fn code(self) -> u8 {
        match self {
            ChannelType::Bit => 1,
            ChannelType::TwoBits => 2,
            ChannelType::FourBits => 3,
            ChannelType::Byte => 4,
            ChannelType::Word => 5,
            ChannelType::TwoWords => 6,
        }
    }

    const fn from_code(code: u8) -> Option<ChannelType> {
        Some(match code {
            1 => ChannelType::Bit,
            2 => ChannelType::TwoBits,
            3 => ChannelType::FourBits,
            4 => ChannelType::Byte,
            5 => ChannelType::Word,
            6 => ChannelType::TwoWords,
            _ => return None,
        })
    }
}

/// One channel-specific diagnosis entry (3 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ChannelDiagnosis {
    /// The slot (identifier number) of the module reporting, 0 … 63.
    pub slot: u8,
    /// The channel number, 0 … 63 (the SI module has one channel, 0).
    pub channel: u8,
    /// Input, output or both.
    pub io: IoType,
    /// The channel's data width.
    pub channel_type: ChannelType,
    /// What is wrong.
    pub error: ErrorType,
}

impl ChannelDiagnosis {
    /// The entry the simulated SI module reports: its one channel 0, input/output, byte wide.
    ///
    /// The manuals print the error types but not the other two fields for the SI module; the
    /// serial channel both sends and receives bytes, hence input/output and byte.
    pub const fn si(slot: u8, error: ErrorType) -> ChannelDiagnosis {
        ChannelDiagnosis {
            slot,
            channel: 0,
            io: IoType::InputOutput,
            channel_type: ChannelType::Byte,
            error,
        }
    }
}

/// The state of one module in the module status (2 bits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModuleState {
    /// 00: module OK, valid user data.
    Ok,
    /// 01: module error, invalid user data.
    Error,
    /// 10: wrong module, invalid user data.
    WrongModule,
    /// 11: no module (or module failure), invalid user data.
    NoModule,
}

impl ModuleState {
    const fn from_bits(bits: u8) -> ModuleState {
        match bits & 3 {
            0 => ModuleState::Ok,
            1 => ModuleState::Error,
            2 => ModuleState::WrongModule,
            _ => ModuleState::NoModule,
        }
    }

    const fn bits(self) -> u8 {
        match self {
            ModuleState::Ok => 0,
            ModuleState::Error => 1,
            ModuleState::WrongModule => 2,
            ModuleState::NoModule => 3,
        }
    }

    /// A short description.
    pub const fn text(self) -> &'static str {
        match self {
            ModuleState::Ok => "module OK, valid user data",
            ModuleState::Error => "module error, invalid user data",
            ModuleState::WrongModule => "wrong module, invalid user data",
            ModuleState::NoModule => "no module (or module failure), invalid user data",
        }
    }
}

/// The standard diagnosis: the first 6 bytes of every slave diagnosis (EN 50170 vol. 2).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct StationStatus {
    /// Station status 1 (byte 0).
    pub status1: u8,
    /// Station status 2 (byte 1).
    pub status2: u8,
    /// Station status 3 (byte 2).
    pub status3: u8,
    /// PROFIBUS address of the master that parameterized the slave (byte 3; FFH = none).
    pub master_address: u8,
    /// The slave's ident number (bytes 4–5, MSB first).
    pub ident_number: u16,
}

/// The station status bits that are set, as (byte, bit, meaning) in byte order.
const STATION_BITS: [(usize, u8, &str); 15] = [
    (0, 0, "station does not exist"),
    (0, 1, "station not ready for data exchange"),
    (0, 2, "configuration fault"),
    (0, 3, "extended diagnosis present"),
    (0, 4, "requested function not supported"),
    (0, 5, "invalid slave response"),
    (0, 6, "parameter assignment fault"),
    (0, 7, "parameterized by another master"),
    (1, 0, "slave must be parameterized again"),
    (1, 1, "static diagnosis"),
    (1, 3, "response monitoring (watchdog) on"),
    (1, 4, "FREEZE mode"),
    (1, 5, "SYNC mode"),
    (1, 7, "slave deactivated"),
    (2, 7, "diagnosis overflow"),
];

impl StationStatus {
    /// The meanings of the set station status bits (station status 2 bit 2, always 1, is left
    /// out).
    pub fn flags(&self) -> impl Iterator<Item = &'static str> + '_ {
        let bytes = [self.status1, self.status2, self.status3];
        STATION_BITS
            .iter()
            .filter(move |(byte, bit, _)| bytes[*byte] & (1 << bit) != 0)
            .map(|(_, _, text)| *text)
    }
}

/// Identifier-related diagnosis ("module diagnosis"): one bit per module with an event.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ModuleDiagnosis {
    /// The bit field as sent, 0 … 62 bytes; bit 0 of byte 0 is module 1.
    pub bits: Vec<u8>,
}

impl ModuleDiagnosis {
    /// The numbers (from 1) of the modules whose bit is set.
    pub fn modules(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.bits.len() * 8)
            .filter(|i| self.bits[i / 8] & (1 << (i % 8)) != 0)
            .map(|i| i + 1)
    }
}

/// The module status: two bits per module.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ModuleStatus {
    /// The bit field as sent, 0 … 59 bytes; bits 1–0 of byte 0 are module 1.
    pub bits: Vec<u8>,
}

impl ModuleStatus {
    /// The state of module `n` (from 1), if the bit field covers it.
    pub fn state(&self, n: usize) -> Option<ModuleState> {
        let i = n.checked_sub(1)?;
        let byte = *self.bits.get(i / 4)?;
        Some(ModuleState::from_bits(byte >> (2 * (i % 4))))
    }

    /// Every module the bit field covers, with its state.
    pub fn states(&self) -> impl Iterator<Item = (usize, ModuleState)> + '_ {
        (1..=self.bits.len() * 4).filter_map(|n| self.state(n).map(|s| (n, s)))
    }

    /// Sets module `n`'s state, growing the bit field as needed (up to 59 bytes = 236 modules).
    pub fn set(&mut self, n: usize, state: ModuleState) {
        let Some(i) = n.checked_sub(1) else { return };
        if i / 4 >= MAX_STATUS_BYTES {
            return;
        }
        if self.bits.len() <= i / 4 {
            self.bits.resize(i / 4 + 1, 0);
        }
        let shift = 2 * (i % 4);
        self.bits[i / 4] = self.bits[i / 4] & !(3 << shift) | state.bits() << shift;
    }
}

/// What an [`UnknownPart`] is, as far as its header and the known fields tell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum UnknownKind {
    /// A channel-specific entry (3 bytes) with a code outside the SI module's tables: an error
    /// type not in Tables 2-30 / 3-73, or a reserved I/O type or channel type. The fields that
    /// are known are decoded.
    Channel {
        /// The slot (identifier number) of the reporting module, 0 … 63.
        slot: u8,
        /// The channel number, 0 … 63.
        channel: u8,
        /// Input, output or both; `None` for the reserved 00.
        io: Option<IoType>,
        /// The data width; `None` for the reserved 000 and 111.
        channel_type: Option<ChannelType>,
        /// The 5-bit error type as sent.
        error_type: u8,
    },
    /// A device-related block (header `00`) that is not the module status `82H 00H 00H`: an
    /// interrupt, a DP-V1 status message or a manufacturer-specific block.
    StatusBlock {
        /// Its second byte (the DP-V1 status or alarm type), if the block has one.
        status_type: Option<u8>,
    },
    /// A second module diagnosis or module status (the header says which); the first is the
    /// one decoded.
    Repeated,
    /// A block header with bits 7–6 = 11. No manual gives its length, so this part holds the
    /// rest of the diagnosis.
    Header {
        /// The header byte.
        header: u8,
    },
}

impl core::fmt::Display for UnknownKind {
    /// One line for a user: what the part is and why it is kept raw.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            UnknownKind::Channel {
                slot,
                channel,
                io,
                channel_type,
                error_type,
            } => {
                write!(f, "channel entry: slot {slot} channel {channel} (")?;
                match io {
                    Some(io) => f.write_str(io.text())?,
                    None => f.write_str("I/O type 00 reserved")?,
                }
                match channel_type {
                    Some(t) => write!(f, ", {}", t.text())?,
                    None => f.write_str(", channel type reserved")?,
                }
                write!(f, "): error type {error_type:05b} ({error_type})")?;
                if ErrorType::from_code(error_type).is_none() {
                    f.write_str(", not in the SI module's tables (see the reporting module's manual)")?;
                }
                Ok(())
            }
            UnknownKind::StatusBlock {
                status_type: Some(t),
            } => write!(
                f,
                "device-related block of status type {t:02X}H, not the module status 82H 00H 00H: \
                 an interrupt, a status message or manufacturer-specific data"
            ),
            UnknownKind::StatusBlock { status_type: None } => {
                f.write_str("device-related block without a status type")
            }
            UnknownKind::Repeated => {
                f.write_str("a second block of a kind already decoded; the first one counts")
            }
            UnknownKind::Header { header } => write!(
                f,
                "block header {header:02X}H (bits 7-6 = 11) of unknown length: the rest of the diagnosis"
            ),
        }
    }
}

/// A part of the diagnosis the SI module's tables do not describe, kept as it was sent.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct UnknownPart {
    /// Offset of its first byte in the diagnosis.
    pub offset: usize,
    /// What it is.
    pub kind: UnknownKind,
    /// Its bytes as sent, header included.
    pub bytes: Vec<u8>,
}

/// A decoded slave diagnosis.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SlaveDiagnosis {
    /// Bytes 0–5.
    pub station: StationStatus,
    /// The identifier-related block, if present.
    pub module_diagnosis: Option<ModuleDiagnosis>,
    /// The module status block, if present.
    pub module_status: Option<ModuleStatus>,
    /// The channel-specific entries the SI module's tables describe, in the order sent.
    pub channels: Vec<ChannelDiagnosis>,
    /// Everything else, in the order sent: other modules' channel entries, interrupts, status
    /// messages, blocks of unknown layout.
    pub unknown: Vec<UnknownPart>,
}

/// Why a slave diagnosis could not be decoded or encoded. Decoding fails only on a wrong length
/// (what it does not know it keeps as an [`UnknownPart`]); every decode error names the offset
/// of the byte where the problem starts.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DiagError {
    /// The data ends inside a part.
    #[error("truncated at offset {offset}: the {part} needs {needed} bytes, {available} remain")]
    Truncated {
        /// Where the incomplete part starts.
        offset: usize,
        /// Which part.
        part: &'static str,
        /// Bytes the part needs.
        needed: usize,
        /// Bytes that remain from `offset`.
        available: usize,
    },
    /// More than [`MAX_DIAG_LEN`] bytes.
    #[error("slave diagnosis of {len} bytes is longer than the 244 bytes EN 50170 allows")]
    TooLong {
        /// The length given.
        len: usize,
    },
    /// A block header whose length cannot be right.
    #[error("invalid length {length} in the {part} header at offset {offset} (at least {min})")]
    BadLength {
        /// Offset of the header byte.
        offset: usize,
        /// Which part.
        part: &'static str,
        /// The length the header gives.
        length: usize,
        /// The smallest valid length.
        min: usize,
    },
    /// Encoding: a field that does not fit its bits.
    #[error("{field} = {value} does not fit: at most {max}")]
    TooLarge {
        /// Which field.
        field: &'static str,
        /// The value given.
        value: usize,
        /// The largest value that fits.
        max: usize,
    },
}

/// Largest module diagnosis bit field: the 6-bit length counts the header.
const MAX_MODULE_BITS_BYTES: usize = 62;
/// Largest module status bit field: 63 minus header, status type and two reserved bytes.
const MAX_STATUS_BYTES: usize = 59;

const PART_STANDARD: &str = "standard diagnosis";
const PART_MODULE_DIAG: &str = "module diagnosis";
const PART_MODULE_STATUS: &str = "module status";
const PART_DEVICE_BLOCK: &str = "device-related block";
const PART_CHANNEL: &str = "channel-specific diagnosis";

fn truncated(bytes: &[u8], offset: usize, part: &'static str, needed: usize) -> DiagError {
    DiagError::Truncated {
        offset,
        part,
        needed,
        available: bytes.len().saturating_sub(offset),
    }
}

impl SlaveDiagnosis {
    /// Decodes a complete slave diagnosis, from station status 1 on.
    ///
    /// ```
    /// use si_module::diag::{ErrorType, SlaveDiagnosis};
    /// // Standard part, module diagnosis (module 2), module status (module 2: error),
    /// // one channel entry: slot 2, channel 0, input/output, byte, wire break.
    /// let bytes = [0x08, 0x0C, 0x00, 0x02, 0x80, 0xE0,
    ///              0x42, 0x02,
    ///              0x05, 0x82, 0x00, 0x00, 0x04,
    ///              0x82, 0xC0, 0x86];
    /// let d = SlaveDiagnosis::decode(&bytes).unwrap();
    /// assert_eq!(d.module_diagnosis.unwrap().modules().collect::<Vec<_>>(), [2]);
    /// assert_eq!(d.channels[0].error, ErrorType::WireBreak);
    /// assert_eq!(
    ///     SlaveDiagnosis::decode(&bytes[..15]).unwrap_err().to_string(),
    ///     "truncated at offset 13: the channel-specific diagnosis needs 3 bytes, 2 remain"
    /// );
    /// ```
    pub fn decode(bytes: &[u8]) -> Result<SlaveDiagnosis, DiagError> {
        if bytes.len() > MAX_DIAG_LEN {
            return Err(DiagError::TooLong { len: bytes.len() });
        }
        let Some(std) = bytes.get(..STANDARD_LEN) else {
            return Err(truncated(bytes, 0, PART_STANDARD, STANDARD_LEN));
        };
        let mut out = SlaveDiagnosis {
            station: StationStatus {
                status1: std[0],
                status2: std[1],
                status3: std[2],
                master_address: std[3],
                ident_number: u16::from_be_bytes([std[4], std[5]]),
            },
            ..SlaveDiagnosis::default()
        };
        let mut at = STANDARD_LEN;
        while let Some(&header) = bytes.get(at) {
            at += match header >> 6 {
                0b10 => {
                    let entry = bytes
                        .get(at..at + 3)
                        .ok_or_else(|| truncated(bytes, at, PART_CHANNEL, 3))?;
                    out.channel_entry(at, entry);
                    3
                }
                0b11 => {
                    out.unknown.push(UnknownPart {
                        offset: at,
                        kind: UnknownKind::Header { header },
                        bytes: bytes[at..].to_vec(),
                    });
                    bytes.len() - at
                }
                kind => {
                    let len = usize::from(header & 0x3F);
                    let part = match (kind, bytes.get(at + 1)) {
                        (0b01, _) => PART_MODULE_DIAG,
                        (_, Some(&MODULE_STATUS_TYPE)) => PART_MODULE_STATUS,
                        _ => PART_DEVICE_BLOCK,
                    };
                    if len == 0 {
                        return Err(DiagError::BadLength {
                            offset: at,
                            part,
                            length: len,
                            min: 1,
                        });
                    }
                    let block = bytes
                        .get(at..at + len)
                        .ok_or_else(|| truncated(bytes, at, part, len))?;
                    if kind == 0b01 {
                        out.module_diagnosis_block(at, block);
                    } else {
                        out.device_block(at, block);
                    }
                    len
                }
            };
        }
        Ok(out)
    }

    /// A channel entry: decoded when every code is in the SI module's tables, else kept raw.
    fn channel_entry(&mut self, offset: usize, entry: &[u8]) {
        let (slot, channel) = (entry[0] & 0x3F, entry[1] & 0x3F);
        let io = IoType::from_bits(entry[1] >> 6);
        let channel_type = ChannelType::from_code(entry[2] >> 5);
        let error_type = entry[2] & 0x1F;
        match (io, channel_type, ErrorType::from_code(error_type)) {
            (Some(io), Some(channel_type), Some(error)) => self.channels.push(ChannelDiagnosis {
                slot,
                channel,
                io,
                channel_type,
                error,
            }),
            _ => self.unknown.push(UnknownPart {
                offset,
                kind: UnknownKind::Channel {
                    slot,
                    channel,
                    io,
                    channel_type,
                    error_type,
                },
                bytes: entry.to_vec(),
            }),
        }
    }

    /// An identifier-related block (header `01`): the module diagnosis, unless one was given.
    fn module_diagnosis_block(&mut self, offset: usize, block: &[u8]) {
        if self.module_diagnosis.is_some() {
            return self.keep(offset, UnknownKind::Repeated, block);
        }
        self.module_diagnosis = Some(ModuleDiagnosis {
            bits: block[1..].to_vec(),
        });
    }

    /// A device-related block (header `00`): the module status when it is `82H 00H 00H` and
    /// none was given, else kept raw.
    fn device_block(&mut self, offset: usize, block: &[u8]) {
        let is_module_status = matches!(block, [_, MODULE_STATUS_TYPE, 0, 0, ..]);
        if !is_module_status {
            let kind = UnknownKind::StatusBlock {
                status_type: block.get(1).copied(),
            };
            return self.keep(offset, kind, block);
        }
        if self.module_status.is_some() {
            return self.keep(offset, UnknownKind::Repeated, block);
        }
        self.module_status = Some(ModuleStatus {
            bits: block[4..].to_vec(),
        });
    }

    fn keep(&mut self, offset: usize, kind: UnknownKind, bytes: &[u8]) {
        self.unknown.push(UnknownPart {
            offset,
            kind,
            bytes: bytes.to_vec(),
        });
    }

    /// Encodes the diagnosis; the inverse of [`decode`](Self::decode): the known parts in the
    /// usual order, then the unknown parts as they were received.
    pub fn encode(&self) -> Result<Vec<u8>, DiagError> {
        let s = &self.station;
        let mut out = vec![s.status1, s.status2, s.status3, s.master_address];
        out.extend_from_slice(&s.ident_number.to_be_bytes());
        if let Some(m) = &self.module_diagnosis {
            fits(
                "module diagnosis bytes",
                m.bits.len(),
                MAX_MODULE_BITS_BYTES,
            )?;
            out.push(0x40 | (m.bits.len() as u8 + 1));
            out.extend_from_slice(&m.bits);
        }
        if let Some(m) = &self.module_status {
            fits("module status bytes", m.bits.len(), MAX_STATUS_BYTES)?;
            out.extend_from_slice(&[m.bits.len() as u8 + 4, MODULE_STATUS_TYPE, 0, 0]);
            out.extend_from_slice(&m.bits);
        }
        for c in &self.channels {
            fits("slot", c.slot.into(), 63)?;
            fits("channel", c.channel.into(), 63)?;
            out.extend_from_slice(&[
                0x80 | c.slot,
                c.io.bits() << 6 | c.channel,
                c.channel_type.code() << 5 | c.error.code(),
            ]);
        }
        for u in &self.unknown {
            out.extend_from_slice(&u.bytes);
        }
        fits("slave diagnosis bytes", out.len(), MAX_DIAG_LEN)?;
        Ok(out)
    }
}

fn fits(field: &'static str, value: usize, max: usize) -> Result<(), DiagError> {
    if value > max {
        return Err(DiagError::TooLarge { field, value, max });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip() {
        for t in ErrorType::ALL {
            assert_eq!(ErrorType::from_code(t.code()), Some(t));
        }
        for c in 0..8 {
            if let Some(t) = ChannelType::from_code(c) {
                assert_eq!(t.code(), c);
            }
        }
        for b in 0..4 {
            assert_eq!(ModuleState::from_bits(b).bits(), b);
            if let Some(io) = IoType::from_bits(b) {
                assert_eq!(io.bits(), b);
            }
        }
        assert_eq!(IoType::from_bits(0), None);
    }

    #[test]
    fn module_status_set_and_get() {
        let mut m = ModuleStatus::default();
        m.set(5, ModuleState::WrongModule);
        assert_eq!(m.bits, [0, 0b10]);
        assert_eq!(m.state(5), Some(ModuleState::WrongModule));
        assert_eq!(m.state(0), None);
        m.set(0, ModuleState::Error);
        m.set(1000, ModuleState::Error);
        assert_eq!(m.bits.len(), 2);
    }
}
