//! Modbus RTU frames: ADU encode/decode with CRC-16, request and response PDUs.
//!
//! An RTU frame (ADU) is `address | function | data | CRC lo | CRC hi`
//! ([Modbus/USS] §3.3.1, Table 3-9). The CRC is CRC-16 with polynomial
//! x¹⁶ + x¹⁵ + x² + 1, sent **low byte first** ([Modbus/USS] §3.3.5); we use the `crc` crate's
//! catalogued `CRC_16_MODBUS` (init 0xFFFF, reflected), table-driven.
//!
//! Pure functions, no state, no allocation: requests and responses are views ([`Bits`],
//! [`Registers`]) over the received bytes, and encoding writes into a caller's buffer
//! (an [`Adu`] holds one frame inline).
//!
//! # Quantity limits
//!
//! The module allows 1–2040 bits and 1–127 registers per job ([Modbus/USS] §3.3.6, Table 3-12,
//! §3.4.5–§3.4.16, §3.5.6–§3.5.14), more than the Modbus specification's 2000/125 (read) and
//! 1968/123 (write). We follow the manual so that frames the module sends and accepts round-trip
//! here; the price is that an FC15 with 2040 bits is a 264-byte ADU, above the Modbus
//! specification's 256. [`MAX_ADU`] is sized for the manual's limits.

use core::fmt;

mod text;

/// The largest ADU the manual's limits produce: FC15 with 2040 bits =
/// address + FC + start + quantity + byte count + 255 data bytes + CRC = 264 bytes.
pub const MAX_ADU: usize = 264;

/// Most bits one job may read or write ([Modbus/USS] §3.4.5–§3.4.16: 0E44H; §3.5.6–§3.5.14: 0832H).
pub const MAX_BITS: u16 = 2040;

/// Most registers one job may read or write ([Modbus/USS] §3.4.5–§3.4.16: 0E45H; §3.5.6–§3.5.14:
/// 0832H).
pub const MAX_REGISTERS: u16 = 127;

/// Most event bytes in an FC12 response (Modbus: 0–64 events; [Modbus/USS] §3.4.5–§3.4.16 and
/// [Modbus/USS] §3.3.3, Table 3-10 `[derived]`).
pub const MAX_EVENTS: usize = 64;

/// The broadcast address ([Modbus/USS] §3.3.2): only FC05, 06, 15 and 16, never answered.
pub const BROADCAST: u8 = 0;

/// Slice-by-16 tables (8 KiB, built at compile time) for short frames.
const CRC: crc::Crc<u16, crc::Table<16>> =
    crc::Crc::<u16, crc::Table<16>>::new(&crc::CRC_16_MODBUS);

/// From this length on, carry-less multiplication beats the tables: measured on the project's
/// machine, the two are equal at 64 bytes, the tables are faster below (crc-fast's set-up costs
/// about 30 ns) and half as fast at 256 bytes (2.2 against 4.8 GiB/s; BENCHMARKS.md).
const FOLDING_FROM: usize = 64;

/// CRC-16/MODBUS of `bytes` ([Modbus/USS] §3.3.5); on the wire the low byte goes first.
///
/// Short frames (every request but FC15/16) use the `crc` crate's slice-by-16 tables; long ones
/// (register and coil data) the `crc-fast` crate's carry-less-multiply folding, which falls back
/// to tables on CPUs without it. Both compute the catalog's CRC-16/MODBUS; a test compares them
/// at every length up to a full frame.
///
/// ```
/// // [Modbus/USS] §3.3.5, the frame the brief names: 01 03 00 00 00 0A C5 CD
/// assert_eq!(si_modbus::frame::crc16(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A]), 0xCDC5);
/// ```
pub fn crc16(bytes: &[u8]) -> u16 {
    if bytes.len() < FOLDING_FROM {
        CRC.checksum(bytes)
    } else {
        crc_fast::checksum(crc_fast::CrcAlgorithm::Crc16Modbus, bytes) as u16
    }
}

/// Function codes the module speaks ([Modbus/USS] §3.3.3, Table 3-10).
pub mod fc {
    /// 01 read coils.
    pub const READ_COILS: u8 = 0x01;
    /// 02 read discrete inputs.
    pub const READ_DISCRETE_INPUTS: u8 = 0x02;
    /// 03 read holding registers.
    pub const READ_HOLDING_REGISTERS: u8 = 0x03;
    /// 04 read input registers.
    pub const READ_INPUT_REGISTERS: u8 = 0x04;
    /// 05 write single coil.
    pub const WRITE_SINGLE_COIL: u8 = 0x05;
    /// 06 write single register.
    pub const WRITE_SINGLE_REGISTER: u8 = 0x06;
    /// 07 read exception status.
    pub const READ_EXCEPTION_STATUS: u8 = 0x07;
    /// 08 diagnostics, sub-function 0000 (return query data) only.
    pub const DIAGNOSTICS: u8 = 0x08;
    /// 11 get comm event counter.
    pub const GET_COMM_EVENT_COUNTER: u8 = 0x0B;
    /// 12 get comm event log.
    pub const GET_COMM_EVENT_LOG: u8 = 0x0C;
    /// 15 write multiple coils.
    pub const WRITE_MULTIPLE_COILS: u8 = 0x0F;
    /// 16 write multiple registers.
    pub const WRITE_MULTIPLE_REGISTERS: u8 = 0x10;

    /// True for the function codes of Table 3-10.
    pub const fn is_supported(code: u8) -> bool {
        matches!(code, 0x01..=0x08 | 0x0B | 0x0C | 0x0F | 0x10)
    }

    /// True for the functions a broadcast may carry ([Modbus/USS] §3.3.2).
    pub const fn broadcast_allowed(code: u8) -> bool {
        matches!(code, 0x05 | 0x06 | 0x0F | 0x10)
    }
}

/// FC05 value for ON ([Modbus/USS] §3.4.5–§3.4.16).
pub const COIL_ON: u16 = 0xFF00;
/// FC05 value for OFF ([Modbus/USS] §3.4.5–§3.4.16).
pub const COIL_OFF: u16 = 0x0000;

/// A packed bit string, lowest address in bit 0 of the first byte (Modbus order; [Modbus/USS]
/// §3.5.5–§3.5.19).
///
/// Either a view over bytes from the line or over the caller's `bool`s, so neither side copies.
#[derive(Clone, Copy)]
pub enum Bits<'a> {
    /// `len` bits packed in `bytes` (LSB first), as on the wire.
    Packed {
        /// The packed bytes, at least `ceil(len / 8)` of them.
        bytes: &'a [u8],
        /// Number of bits.
        len: u16,
    },
    /// One `bool` per bit.
    Bools(&'a [bool]),
}

impl<'a> Bits<'a> {
    /// `len` bits packed in `bytes`.
    pub const fn packed(bytes: &'a [u8], len: u16) -> Self {
        Bits::Packed { bytes, len }
    }

    /// Number of bits.
    pub fn len(&self) -> usize {
        match self {
            Bits::Packed { bytes, len } => (*len as usize).min(bytes.len() * 8),
            Bits::Bools(b) => b.len(),
        }
    }

    /// True when there are no bits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bit `i`, `None` past the end.
    pub fn get(&self, i: usize) -> Option<bool> {
        if i >= self.len() {
            return None;
        }
        Some(match self {
            Bits::Packed { bytes, .. } => bytes[i / 8] & (1 << (i % 8)) != 0,
            Bits::Bools(b) => b[i],
        })
    }

    /// The bits in order.
    pub fn iter(&self) -> impl Iterator<Item = bool> + '_ {
        (0..self.len()).filter_map(|i| self.get(i))
    }

    /// Bytes on the wire: `ceil(len / 8)`.
    pub fn byte_len(&self) -> usize {
        self.len().div_ceil(8)
    }

    /// Packed byte `k` (unused high bits zero, as the Modbus specification asks).
    pub fn byte(&self, k: usize) -> u8 {
        let mut b = 0u8;
        for bit in 0..8 {
            if self.get(k * 8 + bit) == Some(true) {
                b |= 1 << bit;
            }
        }
        b
    }

    /// The first `len` bits (a read response carries whole bytes; the request knew how many).
    pub fn truncate(self, len: u16) -> Self {
        match self {
            Bits::Packed { bytes, len: l } => Bits::Packed {
                bytes,
                len: l.min(len),
            },
            Bits::Bools(b) => Bits::Bools(&b[..b.len().min(len as usize)]),
        }
    }
}

impl PartialEq for Bits<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}
impl Eq for Bits<'_> {}

/// The bits in order, as booleans.
impl serde::Serialize for Bits<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.iter())
    }
}

impl fmt::Debug for Bits<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Bits[")?;
        for b in self.iter() {
            f.write_str(if b { "1" } else { "0" })?;
        }
        write!(f, "]")
    }
}

/// 16-bit registers, high byte first on the wire ([Modbus/USS] §3.5.5–§3.5.19: "Modbus register =
/// S7 WORD, no swap").
#[derive(Clone, Copy)]
pub enum Registers<'a> {
    /// Big-endian pairs as on the wire.
    Wire(&'a [u8]),
    /// The caller's words.
    Words(&'a [u16]),
}

impl Registers<'_> {
    /// Number of registers.
    pub fn len(&self) -> usize {
        match self {
            Registers::Wire(b) => b.len() / 2,
            Registers::Words(w) => w.len(),
        }
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Register `i`, `None` past the end.
    pub fn get(&self, i: usize) -> Option<u16> {
        match self {
            Registers::Wire(b) => b
                .get(2 * i..2 * i + 2)
                .map(|p| u16::from_be_bytes([p[0], p[1]])),
            Registers::Words(w) => w.get(i).copied(),
        }
    }

    /// The registers in order.
    pub fn iter(&self) -> impl Iterator<Item = u16> + '_ {
        (0..self.len()).filter_map(|i| self.get(i))
    }
}

impl PartialEq for Registers<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}
impl Eq for Registers<'_> {}

/// The registers in order, as numbers.
impl serde::Serialize for Registers<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.iter())
    }
}

impl fmt::Debug for Registers<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[")?;
        for (i, r) in self.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{r:04X}")?;
        }
        write!(f, "]")
    }
}

/// A request PDU ([Modbus/USS] §3.3.3, Table 3-10, §3.4.5–§3.4.16, §3.5.6–§3.5.14).
///
/// Serializes (for JSON output) as `{"pdu": "read_holding_registers", "fields": {"address": 0,
/// "quantity": 10}}`: the variant's name in snake case, its fields by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "pdu", content = "fields", rename_all = "snake_case")]
pub enum Request<'a> {
    /// 01: `start`, `quantity` 1–2040.
    ReadCoils {
        /// First coil (0-based wire address, [Modbus/USS] §3.3.3, Table 3-10).
        address: u16,
        /// Number of coils.
        quantity: u16,
    },
    /// 02: `start`, `quantity` 1–2040.
    ReadDiscreteInputs {
        /// First input.
        address: u16,
        /// Number of inputs.
        quantity: u16,
    },
    /// 03: `start`, `quantity` 1–127.
    ReadHoldingRegisters {
        /// First register.
        address: u16,
        /// Number of registers.
        quantity: u16,
    },
    /// 04: `start`, `quantity` 1–127.
    ReadInputRegisters {
        /// First register.
        address: u16,
        /// Number of registers.
        quantity: u16,
    },
    /// 05: FF00H = ON, 0000H = OFF.
    WriteSingleCoil {
        /// The coil.
        address: u16,
        /// ON or OFF.
        value: bool,
    },
    /// 06: any value.
    WriteSingleRegister {
        /// The register.
        address: u16,
        /// Its new value.
        value: u16,
    },
    /// 07: no data.
    ReadExceptionStatus,
    /// 08 sub-function 0000 "return query data": the slave echoes `data` ([Modbus/USS]
    /// §3.5.6–§3.5.14, §3.3.3 `[derived]`).
    Diagnostics {
        /// The test value.
        data: u16,
    },
    /// 11: no data.
    GetCommEventCounter,
    /// 12: no data.
    GetCommEventLog,
    /// 15: byte count derived from the bit count ([Modbus/USS] §3.4.5–§3.4.16).
    WriteMultipleCoils {
        /// First coil.
        address: u16,
        /// The values, 1–2040.
        values: Bits<'a>,
    },
    /// 16: byte count = 2 × registers.
    WriteMultipleRegisters {
        /// First register.
        address: u16,
        /// The values, 1–127.
        values: Registers<'a>,
    },
}

/// Exception codes: 01–07 as the module's manual lists them ([Modbus/USS] §3.3.6, Table 3-12;
/// the slave sends 01–04), 08, 0AH and 0BH from the Modbus application protocol ([Modbus AP] §7),
/// which gateways and other slaves send, and [`ExceptionCode::Custom`] for any other byte, so a
/// response never fails to decode for its exception code alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExceptionCode {
    /// 01: function not supported.
    IllegalFunction,
    /// 02: SIMATIC area not enabled, outside the conversion areas or limits.
    IllegalDataAddress,
    /// 03: length over 2040 bits / 127 registers, FC05 value, FC08 sub-code.
    IllegalDataValue,
    /// 04: FB not initialised or reporting an error, CPU transfer error.
    SlaveDeviceFailure,
    /// 05: acknowledge.
    Acknowledge,
    /// 06: busy, request rejected.
    SlaveDeviceBusy,
    /// 07: negative acknowledge.
    NegativeAcknowledge,
    /// 08: memory parity error (Modbus application protocol V1.1b3 §7; FC20/21 only).
    MemoryParityError,
    /// 0AH: gateway path unavailable: the gateway has no path to the addressed unit
    /// (Modbus application protocol V1.1b3 §7).
    GatewayPathUnavailable,
    /// 0BH: gateway target device failed to respond (Modbus application protocol V1.1b3 §7).
    GatewayTargetFailed,
    /// Any other code, kept as its byte (a code neither the module's manual nor the Modbus
    /// application protocol names; 00 and 09 included).
    Custom(u8),
}

impl ExceptionCode {
    /// The code from its byte, for the seven codes of [Modbus/USS] §3.6, Table 3-12 (01–07),
    /// the ones the module maps to a STATUS (0E61H–0E67H); `None` for any other byte. Use
    /// [`ExceptionCode::from_byte`] to name every byte.
    pub const fn from_u8(code: u8) -> Option<Self> {
        match Self::from_byte(code) {
            c @ (ExceptionCode::IllegalFunction
            | ExceptionCode::IllegalDataAddress
            | ExceptionCode::IllegalDataValue
            | ExceptionCode::SlaveDeviceFailure
            | ExceptionCode::Acknowledge
            | ExceptionCode::SlaveDeviceBusy
            | ExceptionCode::NegativeAcknowledge) => Some(c),
            _ => None,
        }
    }

    /// The code for any byte: a named code where one exists, [`ExceptionCode::Custom`] otherwise.
    pub const fn from_byte(code: u8) -> Self {
        match code {
            1 => ExceptionCode::IllegalFunction,
            2 => ExceptionCode::IllegalDataAddress,
            3 => ExceptionCode::IllegalDataValue,
            4 => ExceptionCode::SlaveDeviceFailure,
            5 => ExceptionCode::Acknowledge,
            6 => ExceptionCode::SlaveDeviceBusy,
            7 => ExceptionCode::NegativeAcknowledge,
            8 => ExceptionCode::MemoryParityError,
            0x0A => ExceptionCode::GatewayPathUnavailable,
            0x0B => ExceptionCode::GatewayTargetFailed,
            other => ExceptionCode::Custom(other),
        }
    }

    /// The byte on the wire.
    pub const fn code(self) -> u8 {
        match self {
            ExceptionCode::IllegalFunction => 1,
            ExceptionCode::IllegalDataAddress => 2,
            ExceptionCode::IllegalDataValue => 3,
            ExceptionCode::SlaveDeviceFailure => 4,
            ExceptionCode::Acknowledge => 5,
            ExceptionCode::SlaveDeviceBusy => 6,
            ExceptionCode::NegativeAcknowledge => 7,
            ExceptionCode::MemoryParityError => 8,
            ExceptionCode::GatewayPathUnavailable => 0x0A,
            ExceptionCode::GatewayTargetFailed => 0x0B,
            ExceptionCode::Custom(code) => code,
        }
    }

    /// The code's name as the Modbus application protocol gives it; `None` for
    /// [`ExceptionCode::Custom`].
    pub const fn name(self) -> Option<&'static str> {
        Some(match self {
            ExceptionCode::IllegalFunction => "illegal function",
            ExceptionCode::IllegalDataAddress => "illegal data address",
            ExceptionCode::IllegalDataValue => "illegal data value",
            ExceptionCode::SlaveDeviceFailure => "slave device failure",
            ExceptionCode::Acknowledge => "acknowledge",
            ExceptionCode::SlaveDeviceBusy => "slave device busy",
            ExceptionCode::NegativeAcknowledge => "negative acknowledge",
            ExceptionCode::MemoryParityError => "memory parity error",
            ExceptionCode::GatewayPathUnavailable => "gateway path unavailable",
            ExceptionCode::GatewayTargetFailed => "gateway target device failed to respond",
            ExceptionCode::Custom(_) => return None,
        })
    }
}

impl From<u8> for ExceptionCode {
    fn from(code: u8) -> Self {
        ExceptionCode::from_byte(code)
    }
}

impl From<ExceptionCode> for u8 {
    fn from(code: ExceptionCode) -> Self {
        code.code()
    }
}

/// The byte on the wire.
impl serde::Serialize for ExceptionCode {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(self.code())
    }
}

/// "exception 02 illegal data address", "exception 0A gateway path unavailable",
/// "exception 0C (not a named code)": the code in hexadecimal, as the manuals write it.
impl fmt::Display for ExceptionCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.name() {
            Some(text) => write!(f, "exception {:02X} {text}", self.code()),
            None => write!(f, "exception {:02X} (not a named code)", self.code()),
        }
    }
}

/// A response PDU ([Modbus/USS] §3.4.5–§3.4.16, §3.5.6–§3.5.14).
///
/// Serializes like [`Request`]: `{"pdu": "read_holding_registers", "fields": [1, 2]}`, bits as
/// booleans, registers as numbers, an exception code as its byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "pdu", content = "fields", rename_all = "snake_case")]
pub enum Response<'a> {
    /// 01: whole bytes of coils; [`Bits::truncate`] to the requested quantity.
    ReadCoils(Bits<'a>),
    /// 02: whole bytes of inputs.
    ReadDiscreteInputs(Bits<'a>),
    /// 03: the registers.
    ReadHoldingRegisters(Registers<'a>),
    /// 04: the registers.
    ReadInputRegisters(Registers<'a>),
    /// 05: echo of the request.
    WriteSingleCoil {
        /// The coil.
        address: u16,
        /// ON or OFF.
        value: bool,
    },
    /// 06: echo of the request.
    WriteSingleRegister {
        /// The register.
        address: u16,
        /// The value written.
        value: u16,
    },
    /// 07: the eight exception status bits.
    ReadExceptionStatus(u8),
    /// 08: echo of the test value.
    Diagnostics {
        /// The test value.
        data: u16,
    },
    /// 11: status word and event counter.
    GetCommEventCounter {
        /// Status word (FFFFH = busy).
        status: u16,
        /// Event counter.
        event_count: u16,
    },
    /// 12: status, event and message counters, 0–64 event bytes.
    GetCommEventLog {
        /// Status word.
        status: u16,
        /// Event counter.
        event_count: u16,
        /// Message counter.
        message_count: u16,
        /// Event bytes, newest first.
        events: &'a [u8],
    },
    /// 15: start and quantity.
    WriteMultipleCoils {
        /// First coil.
        address: u16,
        /// Number written.
        quantity: u16,
    },
    /// 16: start and quantity.
    WriteMultipleRegisters {
        /// First register.
        address: u16,
        /// Number written.
        quantity: u16,
    },
    /// Function code with MSB set and one exception byte ([Modbus/USS] §3.3.6, Table 3-12).
    Exception {
        /// The function code of the request (MSB clear).
        function: u8,
        /// Why.
        code: ExceptionCode,
    },
}

impl Request<'_> {
    /// The function code.
    pub const fn function(&self) -> u8 {
        match self {
            Request::ReadCoils { .. } => fc::READ_COILS,
            Request::ReadDiscreteInputs { .. } => fc::READ_DISCRETE_INPUTS,
            Request::ReadHoldingRegisters { .. } => fc::READ_HOLDING_REGISTERS,
            Request::ReadInputRegisters { .. } => fc::READ_INPUT_REGISTERS,
            Request::WriteSingleCoil { .. } => fc::WRITE_SINGLE_COIL,
            Request::WriteSingleRegister { .. } => fc::WRITE_SINGLE_REGISTER,
            Request::ReadExceptionStatus => fc::READ_EXCEPTION_STATUS,
            Request::Diagnostics { .. } => fc::DIAGNOSTICS,
            Request::GetCommEventCounter => fc::GET_COMM_EVENT_COUNTER,
            Request::GetCommEventLog => fc::GET_COMM_EVENT_LOG,
            Request::WriteMultipleCoils { .. } => fc::WRITE_MULTIPLE_COILS,
            Request::WriteMultipleRegisters { .. } => fc::WRITE_MULTIPLE_REGISTERS,
        }
    }

    /// Check the manual's limits ([Modbus/USS] §3.4.5–§3.4.16) before encoding.
    pub fn validate(&self) -> Result<(), EncodeError> {
        match *self {
            Request::ReadCoils { quantity, .. } | Request::ReadDiscreteInputs { quantity, .. } => {
                check_quantity(quantity, MAX_BITS, "bit count")
            }
            Request::ReadHoldingRegisters { quantity, .. }
            | Request::ReadInputRegisters { quantity, .. } => {
                check_quantity(quantity, MAX_REGISTERS, "register count")
            }
            Request::WriteMultipleCoils { values, .. } => {
                check_quantity(values.len().min(65_535) as u16, MAX_BITS, "bit count")
            }
            Request::WriteMultipleRegisters { values, .. } => check_quantity(
                values.len().min(65_535) as u16,
                MAX_REGISTERS,
                "register count",
            ),
            _ => Ok(()),
        }
    }

    /// Write the ADU (address, PDU, CRC) into `buf`; returns its length.
    pub fn encode(&self, unit: u8, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let n = self.encode_unit_pdu(unit, buf)?;
        append_crc(buf, n)
    }

    /// Write `unit | PDU` without a CRC into `buf`; returns its length. The RTU ADU adds the
    /// CRC to it ([`Request::encode`]), the Modbus TCP ADU puts an MBAP header before it
    /// ([`crate::mbap`]): one PDU encoder for both.
    pub fn encode_unit_pdu(&self, unit: u8, buf: &mut [u8]) -> Result<usize, EncodeError> {
        self.validate()?;
        let mut w = Writer::new(buf);
        w.u8(unit)?;
        w.u8(self.function())?;
        match *self {
            Request::ReadCoils { address, quantity }
            | Request::ReadDiscreteInputs { address, quantity }
            | Request::ReadHoldingRegisters { address, quantity }
            | Request::ReadInputRegisters { address, quantity } => {
                w.u16(address)?;
                w.u16(quantity)?;
            }
            Request::WriteSingleCoil { address, value } => {
                w.u16(address)?;
                w.u16(if value { COIL_ON } else { COIL_OFF })?;
            }
            Request::WriteSingleRegister { address, value } => {
                w.u16(address)?;
                w.u16(value)?;
            }
            Request::ReadExceptionStatus
            | Request::GetCommEventCounter
            | Request::GetCommEventLog => {}
            Request::Diagnostics { data } => {
                w.u16(0)?;
                w.u16(data)?;
            }
            Request::WriteMultipleCoils { address, values } => {
                w.u16(address)?;
                w.u16(values.len() as u16)?;
                w.u8(values.byte_len() as u8)?;
                for k in 0..values.byte_len() {
                    w.u8(values.byte(k))?;
                }
            }
            Request::WriteMultipleRegisters { address, values } => {
                w.u16(address)?;
                w.u16(values.len() as u16)?;
                w.u8((values.len() * 2) as u8)?;
                for r in values.iter() {
                    w.u16(r)?;
                }
            }
        }
        Ok(w.len)
    }
}

impl Response<'_> {
    /// The function code on the wire (MSB set for an exception).
    pub const fn function(&self) -> u8 {
        match self {
            Response::ReadCoils(_) => fc::READ_COILS,
            Response::ReadDiscreteInputs(_) => fc::READ_DISCRETE_INPUTS,
            Response::ReadHoldingRegisters(_) => fc::READ_HOLDING_REGISTERS,
            Response::ReadInputRegisters(_) => fc::READ_INPUT_REGISTERS,
            Response::WriteSingleCoil { .. } => fc::WRITE_SINGLE_COIL,
            Response::WriteSingleRegister { .. } => fc::WRITE_SINGLE_REGISTER,
            Response::ReadExceptionStatus(_) => fc::READ_EXCEPTION_STATUS,
            Response::Diagnostics { .. } => fc::DIAGNOSTICS,
            Response::GetCommEventCounter { .. } => fc::GET_COMM_EVENT_COUNTER,
            Response::GetCommEventLog { .. } => fc::GET_COMM_EVENT_LOG,
            Response::WriteMultipleCoils { .. } => fc::WRITE_MULTIPLE_COILS,
            Response::WriteMultipleRegisters { .. } => fc::WRITE_MULTIPLE_REGISTERS,
            Response::Exception { function, .. } => *function | 0x80,
        }
    }

    /// Write the ADU into `buf`; returns its length.
    pub fn encode(&self, unit: u8, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let n = self.encode_unit_pdu(unit, buf)?;
        append_crc(buf, n)
    }

    /// Write `unit | PDU` without a CRC into `buf`; returns its length (shared by RTU and
    /// Modbus TCP, see [`Request::encode_unit_pdu`]).
    pub fn encode_unit_pdu(&self, unit: u8, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let mut w = Writer::new(buf);
        w.u8(unit)?;
        w.u8(self.function())?;
        match *self {
            Response::ReadCoils(bits) | Response::ReadDiscreteInputs(bits) => {
                let n = bits.byte_len();
                if n == 0 || n > 255 {
                    return Err(EncodeError::Quantity {
                        what: "byte count",
                        value: n,
                        max: 255,
                    });
                }
                w.u8(n as u8)?;
                for k in 0..n {
                    w.u8(bits.byte(k))?;
                }
            }
            Response::ReadHoldingRegisters(regs) | Response::ReadInputRegisters(regs) => {
                check_quantity(
                    regs.len().min(65_535) as u16,
                    MAX_REGISTERS,
                    "register count",
                )?;
                w.u8((regs.len() * 2) as u8)?;
                for r in regs.iter() {
                    w.u16(r)?;
                }
            }
            Response::WriteSingleCoil { address, value } => {
                w.u16(address)?;
                w.u16(if value { COIL_ON } else { COIL_OFF })?;
            }
            Response::WriteSingleRegister { address, value } => {
                w.u16(address)?;
                w.u16(value)?;
            }
            Response::ReadExceptionStatus(s) => w.u8(s)?,
            Response::Diagnostics { data } => {
                w.u16(0)?;
                w.u16(data)?;
            }
            Response::GetCommEventCounter {
                status,
                event_count,
            } => {
                w.u16(status)?;
                w.u16(event_count)?;
            }
            Response::GetCommEventLog {
                status,
                event_count,
                message_count,
                events,
            } => {
                if events.len() > MAX_EVENTS {
                    return Err(EncodeError::Quantity {
                        what: "event bytes",
                        value: events.len(),
                        max: MAX_EVENTS,
                    });
                }
                w.u8((6 + events.len()) as u8)?;
                w.u16(status)?;
                w.u16(event_count)?;
                w.u16(message_count)?;
                for &e in events {
                    w.u8(e)?;
                }
            }
            Response::WriteMultipleCoils { address, quantity }
            | Response::WriteMultipleRegisters { address, quantity } => {
                w.u16(address)?;
                w.u16(quantity)?;
            }
            Response::Exception { code, .. } => w.u8(code.code())?,
        }
        Ok(w.len)
    }
}

/// Append the CRC of `buf[..len]` ([Modbus/USS] §3.3.5, low byte first); returns the new length.
fn append_crc(buf: &mut [u8], len: usize) -> Result<usize, EncodeError> {
    let mut w = Writer { buf, len };
    let [lo, hi] = crc16(&w.buf[..len]).to_le_bytes();
    w.u8(lo)?;
    w.u8(hi)?;
    Ok(w.len)
}

fn check_quantity(value: u16, max: u16, what: &'static str) -> Result<(), EncodeError> {
    if value == 0 || value > max {
        Err(EncodeError::Quantity {
            what,
            value: value as usize,
            max: max as usize,
        })
    } else {
        Ok(())
    }
}

/// Why a frame could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// A count outside the manual's range.
    #[error("{what} {value} out of range 1…{max}")]
    Quantity {
        /// Which count.
        what: &'static str,
        /// The value given.
        value: usize,
        /// The manual's maximum.
        max: usize,
    },
    /// The output buffer is too small ([`MAX_ADU`] always suffices).
    #[error("output buffer of {0} bytes too small")]
    BufferTooSmall(usize),
}

struct Writer<'b> {
    buf: &'b mut [u8],
    len: usize,
}

impl<'b> Writer<'b> {
    fn new(buf: &'b mut [u8]) -> Self {
        Writer { buf, len: 0 }
    }
    fn u8(&mut self, b: u8) -> Result<(), EncodeError> {
        let slot = self
            .buf
            .get_mut(self.len)
            .ok_or(EncodeError::BufferTooSmall(self.len))?;
        *slot = b;
        self.len += 1;
        Ok(())
    }
    fn u16(&mut self, v: u16) -> Result<(), EncodeError> {
        let [h, l] = v.to_be_bytes();
        self.u8(h)?;
        self.u8(l)
    }
}

/// Which reading of the bytes failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameKind {
    /// Read as a request (master → slave).
    Request,
    /// Read as a response (slave → master).
    Response,
}

impl fmt::Display for FrameKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FrameKind::Request => "request",
            FrameKind::Response => "response",
        })
    }
}

/// What was wrong, so the engines can map it to the manual's STATUS ([Modbus/USS] §3.4.5–§3.4.16,
/// §3.5.6–§3.5.14).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DecodeErrorKind {
    /// Fewer bytes than the function needs (master 0E52H).
    TooShort,
    /// More bytes than the function needs (master 0E53H).
    TooLong,
    /// CRC mismatch (slave 0836H, master 0E57H).
    Crc,
    /// Function code not in Table 3-10 (slave 0831H / exception 01).
    Function,
    /// Quantity outside 1–2040 / 1–127 (slave 0832H / exception 03).
    Quantity,
    /// FC15/16 byte count does not match the quantity (slave 0833H), or a response's byte
    /// count is wrong (master 0E55H).
    ByteCount,
    /// FC05 value not FF00H/0000H (slave 0834H / exception 03).
    CoilValue,
    /// FC08 sub-function not 0000H (slave 0835H / exception 03).
    SubFunction,
}

/// Where the expected value lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Expected {
    /// Exactly this number.
    Exactly(u32),
    /// At least this many.
    AtLeast(u32),
    /// In this inclusive range.
    Range(u32, u32),
    /// One of the listed values (text).
    OneOf(&'static str),
}

impl fmt::Display for Expected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expected::Exactly(v) => write!(f, "{v} (0x{v:X})"),
            Expected::AtLeast(v) => write!(f, "at least {v}"),
            Expected::Range(a, b) => write!(f, "{a}…{b}"),
            Expected::OneOf(s) => f.write_str(s),
        }
    }
}

/// A frame that cannot be read: which reading, at which byte offset, what was expected and
/// what was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error("{frame} byte {offset}: {field} expected {expected}, found {found} (0x{found:X})")]
pub struct DecodeError {
    /// Request or response.
    pub frame: FrameKind,
    /// Byte offset in the ADU (0 = address).
    pub offset: usize,
    /// The field: "length", "CRC", "function code", "quantity", …
    pub field: &'static str,
    /// What was wrong, for STATUS mapping.
    pub kind: DecodeErrorKind,
    /// What the manual allows there.
    pub expected: Expected,
    /// What the bytes hold.
    pub found: u32,
}

struct Reader<'a> {
    adu: &'a [u8],
    frame: FrameKind,
    /// Bytes after the PDU: 2 for the RTU CRC, 0 for `unit | PDU` from Modbus TCP.
    trailer: usize,
}

impl<'a> Reader<'a> {
    fn err(
        &self,
        offset: usize,
        field: &'static str,
        kind: DecodeErrorKind,
        expected: Expected,
        found: u32,
    ) -> DecodeError {
        DecodeError {
            frame: self.frame,
            offset,
            field,
            kind,
            expected,
            found,
        }
    }
    fn u16(&self, at: usize) -> u16 {
        u16::from_be_bytes([self.adu[at], self.adu[at + 1]])
    }
    /// The body (ADU without CRC) must be exactly `n` bytes.
    fn exact(&self, n: usize) -> Result<(), DecodeError> {
        let body = self.adu.len() - self.trailer;
        if body < n {
            Err(self.err(
                body,
                "length",
                DecodeErrorKind::TooShort,
                Expected::Exactly((n + self.trailer) as u32),
                self.adu.len() as u32,
            ))
        } else if body > n {
            Err(self.err(
                n,
                "length",
                DecodeErrorKind::TooLong,
                Expected::Exactly((n + self.trailer) as u32),
                self.adu.len() as u32,
            ))
        } else {
            Ok(())
        }
    }
    fn at_least(&self, n: usize) -> Result<(), DecodeError> {
        let body = self.adu.len() - self.trailer;
        if body < n {
            Err(self.err(
                body,
                "length",
                DecodeErrorKind::TooShort,
                Expected::AtLeast((n + self.trailer) as u32),
                self.adu.len() as u32,
            ))
        } else {
            Ok(())
        }
    }
}

/// A reader over `bytes`, which end in `trailer` bytes after the PDU (2 for the RTU CRC, 0
/// for Modbus TCP), once they hold at least an address, a function code and the trailer.
fn reader(bytes: &[u8], frame: FrameKind, trailer: usize) -> Result<Reader<'_>, DecodeError> {
    let r = Reader {
        adu: bytes,
        frame,
        trailer,
    };
    let min = 2 + trailer;
    if bytes.len() < min {
        return Err(r.err(
            bytes.len(),
            "length",
            DecodeErrorKind::TooShort,
            Expected::AtLeast(min as u32),
            bytes.len() as u32,
        ));
    }
    Ok(r)
}

/// Check length ≥ 4 and the CRC; returns a reader.
fn open(adu: &[u8], frame: FrameKind) -> Result<Reader<'_>, DecodeError> {
    let r = reader(adu, frame, 2)?;
    let n = adu.len() - 2;
    let expected = crc16(&adu[..n]);
    let found = u16::from_le_bytes([adu[n], adu[n + 1]]);
    if expected != found {
        return Err(r.err(
            n,
            "CRC",
            DecodeErrorKind::Crc,
            Expected::Exactly(expected as u32),
            found as u32,
        ));
    }
    Ok(r)
}

/// Check that `unit | PDU` (no CRC, as Modbus TCP carries it) has a unit and a function code.
fn open_unit_pdu(bytes: &[u8], frame: FrameKind) -> Result<Reader<'_>, DecodeError> {
    reader(bytes, frame, 0)
}

/// True if the last two bytes are the CRC of the rest (and there are at least 4 bytes).
pub fn crc_ok(adu: &[u8]) -> bool {
    open(adu, FrameKind::Request).is_ok()
}

fn quantity(r: &Reader<'_>, at: usize, max: u16) -> Result<u16, DecodeError> {
    let q = r.u16(at);
    if q == 0 || q > max {
        return Err(r.err(
            at,
            "quantity",
            DecodeErrorKind::Quantity,
            Expected::Range(1, max as u32),
            q as u32,
        ));
    }
    Ok(q)
}

fn coil_value(r: &Reader<'_>, at: usize) -> Result<bool, DecodeError> {
    match r.u16(at) {
        COIL_ON => Ok(true),
        COIL_OFF => Ok(false),
        v => Err(r.err(
            at,
            "coil value",
            DecodeErrorKind::CoilValue,
            Expected::OneOf("FF00H or 0000H"),
            v as u32,
        )),
    }
}

fn sub_function(r: &Reader<'_>, at: usize) -> Result<(), DecodeError> {
    match r.u16(at) {
        0 => Ok(()),
        v => Err(r.err(
            at,
            "diagnostics sub-function",
            DecodeErrorKind::SubFunction,
            Expected::Exactly(0),
            v as u32,
        )),
    }
}

/// Read an ADU as a request: `(unit, request)`.
///
/// Checks, in order, the length (≥ 4), the CRC, the function code, the field lengths, the
/// quantities and byte counts, the FC05 value and the FC08 sub-function, which is the order
/// in which the slave driver reports 0836H, 0831H, 0832H, 0833H, 0834H, 0835H ([Modbus/USS]
/// §3.5.6–§3.5.14).
pub fn decode_request(adu: &[u8]) -> Result<(u8, Request<'_>), DecodeError> {
    read_request(open(adu, FrameKind::Request)?)
}

/// Read `unit | PDU` without a CRC (the part of a Modbus TCP ADU after the MBAP header) as a
/// request, with the checks of [`decode_request`] but the CRC's. Offsets in errors count from
/// the unit byte.
pub fn decode_unit_pdu_request(bytes: &[u8]) -> Result<(u8, Request<'_>), DecodeError> {
    read_request(open_unit_pdu(bytes, FrameKind::Request)?)
}

fn read_request(r: Reader<'_>) -> Result<(u8, Request<'_>), DecodeError> {
    let adu = r.adu;
    let unit = adu[0];
    let function = adu[1];
    let req = match function {
        fc::READ_COILS
        | fc::READ_DISCRETE_INPUTS
        | fc::READ_HOLDING_REGISTERS
        | fc::READ_INPUT_REGISTERS => {
            r.exact(6)?;
            let address = r.u16(2);
            let max = if function <= fc::READ_DISCRETE_INPUTS {
                MAX_BITS
            } else {
                MAX_REGISTERS
            };
            let quantity = quantity(&r, 4, max)?;
            match function {
                fc::READ_COILS => Request::ReadCoils { address, quantity },
                fc::READ_DISCRETE_INPUTS => Request::ReadDiscreteInputs { address, quantity },
                fc::READ_HOLDING_REGISTERS => Request::ReadHoldingRegisters { address, quantity },
                _ => Request::ReadInputRegisters { address, quantity },
            }
        }
        fc::WRITE_SINGLE_COIL => {
            r.exact(6)?;
            Request::WriteSingleCoil {
                address: r.u16(2),
                value: coil_value(&r, 4)?,
            }
        }
        fc::WRITE_SINGLE_REGISTER => {
            r.exact(6)?;
            Request::WriteSingleRegister {
                address: r.u16(2),
                value: r.u16(4),
            }
        }
        fc::READ_EXCEPTION_STATUS => {
            r.exact(2)?;
            Request::ReadExceptionStatus
        }
        fc::GET_COMM_EVENT_COUNTER => {
            r.exact(2)?;
            Request::GetCommEventCounter
        }
        fc::GET_COMM_EVENT_LOG => {
            r.exact(2)?;
            Request::GetCommEventLog
        }
        fc::DIAGNOSTICS => {
            r.exact(6)?;
            sub_function(&r, 2)?;
            Request::Diagnostics { data: r.u16(4) }
        }
        fc::WRITE_MULTIPLE_COILS | fc::WRITE_MULTIPLE_REGISTERS => {
            r.at_least(7)?;
            let address = r.u16(2);
            let coils = function == fc::WRITE_MULTIPLE_COILS;
            let q = quantity(&r, 4, if coils { MAX_BITS } else { MAX_REGISTERS })?;
            let need = if coils {
                (q as usize).div_ceil(8)
            } else {
                q as usize * 2
            };
            let bc = adu[6] as usize;
            if bc != need {
                return Err(r.err(
                    6,
                    "byte count",
                    DecodeErrorKind::ByteCount,
                    Expected::Exactly(need as u32),
                    bc as u32,
                ));
            }
            r.exact(7 + bc)?;
            let data = &adu[7..7 + bc];
            if coils {
                Request::WriteMultipleCoils {
                    address,
                    values: Bits::packed(data, q),
                }
            } else {
                Request::WriteMultipleRegisters {
                    address,
                    values: Registers::Wire(data),
                }
            }
        }
        other => {
            return Err(r.err(
                1,
                "function code",
                DecodeErrorKind::Function,
                Expected::OneOf("01-08, 0B, 0C, 0F, 10"),
                other as u32,
            ))
        }
    };
    Ok((unit, req))
}

/// Read an ADU as a response: `(unit, response)`.
///
/// Without the request it cannot know how many bits a read asked for: coil and input
/// responses come back in whole bytes (see [`Bits::truncate`]).
pub fn decode_response(adu: &[u8]) -> Result<(u8, Response<'_>), DecodeError> {
    read_response(open(adu, FrameKind::Response)?)
}

/// The RTU ADU of `body` (slave address, function code and the rest of the PDU): `body` with
/// its [`crc16`] appended, low byte first. Refused, naming why, when `body` lacks the address
/// or the function code, or the ADU would be longer than [`MAX_ADU`].
pub fn seal(body: &[u8]) -> Result<Vec<u8>, String> {
    if body.len() < 2 {
        return Err("give at least the slave address and the function code".into());
    }
    if body.len() + 2 > MAX_ADU {
        return Err(format!(
            "{} bytes: an ADU holds at most {MAX_ADU} bytes with the CRC",
            body.len()
        ));
    }
    let mut adu = body.to_vec();
    adu.extend_from_slice(&crc16(body).to_le_bytes());
    Ok(adu)
}

/// How an ADU with a good CRC reads, as `si frame decode modbus` says it: `("request", "unit 1
/// FC03 read …")`, `"response"`, or `"request and response (an echo reads the same both
/// ways)"` for a frame both decode to alike (FC05, FC06 and their echoes); `None` when it is
/// neither.
pub fn reading(adu: &[u8]) -> Option<(&'static str, String)> {
    let req = decode_request(adu).ok();
    let resp = decode_response(adu).ok();
    match (req, resp) {
        (Some((u, r)), Some((_, p))) if format!("{r:?}") == format!("{p:?}") => Some((
            "request and response (an echo reads the same both ways)",
            format!("unit {u} {r}"),
        )),
        (Some((u, r)), _) => Some(("request", format!("unit {u} {r}"))),
        (None, Some((u, p))) => Some(("response", format!("unit {u} {p}"))),
        (None, None) => None,
    }
}

/// Read `unit | PDU` without a CRC (Modbus TCP) as a response; see
/// [`decode_unit_pdu_request`].
pub fn decode_unit_pdu_response(bytes: &[u8]) -> Result<(u8, Response<'_>), DecodeError> {
    read_response(open_unit_pdu(bytes, FrameKind::Response)?)
}

/// A register read's answer (FC03, FC04) in `unit | PDU` as [`decode_unit_pdu_response`]
/// reads it, or `None` for any other answer and for one the decoder refuses: a master's typed
/// read, the commonest job, without the general decoder's bookkeeping (a reader, error
/// contexts) on its path.
pub(crate) fn register_response(unit_pdu: &[u8]) -> Option<Response<'_>> {
    let [_, function, count, data @ ..] = unit_pdu else {
        return None;
    };
    let n = *count as usize;
    if data.len() != n || n < 2 || n > 2 * MAX_REGISTERS as usize || !n.is_multiple_of(2) {
        return None;
    }
    let registers = Registers::Wire(data);
    match *function {
        fc::READ_HOLDING_REGISTERS => Some(Response::ReadHoldingRegisters(registers)),
        fc::READ_INPUT_REGISTERS => Some(Response::ReadInputRegisters(registers)),
        _ => None,
    }
}

fn read_response(r: Reader<'_>) -> Result<(u8, Response<'_>), DecodeError> {
    let adu = r.adu;
    let unit = adu[0];
    let function = adu[1];
    if function & 0x80 != 0 && fc::is_supported(function & 0x7F) {
        r.exact(3)?;
        let code = ExceptionCode::from_byte(adu[2]);
        return Ok((
            unit,
            Response::Exception {
                function: function & 0x7F,
                code,
            },
        ));
    }
    let byte_counted = |r: &Reader<'_>, min: usize, max: usize| -> Result<&[u8], DecodeError> {
        r.at_least(3)?;
        let bc = adu[2] as usize;
        if bc < min || bc > max {
            return Err(r.err(
                2,
                "byte count",
                DecodeErrorKind::ByteCount,
                Expected::Range(min as u32, max as u32),
                bc as u32,
            ));
        }
        r.exact(3 + bc)?;
        Ok(&adu[3..3 + bc])
    };
    let resp = match function {
        fc::READ_COILS | fc::READ_DISCRETE_INPUTS => {
            let data = byte_counted(&r, 1, 255)?;
            let bits = Bits::packed(data, (data.len() * 8) as u16);
            if function == fc::READ_COILS {
                Response::ReadCoils(bits)
            } else {
                Response::ReadDiscreteInputs(bits)
            }
        }
        fc::READ_HOLDING_REGISTERS | fc::READ_INPUT_REGISTERS => {
            let data = byte_counted(&r, 2, 2 * MAX_REGISTERS as usize)?;
            if data.len() % 2 != 0 {
                return Err(r.err(
                    2,
                    "byte count",
                    DecodeErrorKind::ByteCount,
                    Expected::OneOf("an even number"),
                    data.len() as u32,
                ));
            }
            if function == fc::READ_HOLDING_REGISTERS {
                Response::ReadHoldingRegisters(Registers::Wire(data))
            } else {
                Response::ReadInputRegisters(Registers::Wire(data))
            }
        }
        fc::WRITE_SINGLE_COIL => {
            r.exact(6)?;
            Response::WriteSingleCoil {
                address: r.u16(2),
                value: coil_value(&r, 4)?,
            }
        }
        fc::WRITE_SINGLE_REGISTER => {
            r.exact(6)?;
            Response::WriteSingleRegister {
                address: r.u16(2),
                value: r.u16(4),
            }
        }
        fc::READ_EXCEPTION_STATUS => {
            r.exact(3)?;
            Response::ReadExceptionStatus(adu[2])
        }
        fc::DIAGNOSTICS => {
            r.exact(6)?;
            sub_function(&r, 2)?;
            Response::Diagnostics { data: r.u16(4) }
        }
        fc::GET_COMM_EVENT_COUNTER => {
            r.exact(6)?;
            Response::GetCommEventCounter {
                status: r.u16(2),
                event_count: r.u16(4),
            }
        }
        fc::GET_COMM_EVENT_LOG => {
            let data = byte_counted(&r, 6, 6 + MAX_EVENTS)?;
            Response::GetCommEventLog {
                status: u16::from_be_bytes([data[0], data[1]]),
                event_count: u16::from_be_bytes([data[2], data[3]]),
                message_count: u16::from_be_bytes([data[4], data[5]]),
                events: &data[6..],
            }
        }
        fc::WRITE_MULTIPLE_COILS | fc::WRITE_MULTIPLE_REGISTERS => {
            r.exact(6)?;
            let address = r.u16(2);
            let coils = function == fc::WRITE_MULTIPLE_COILS;
            let quantity = quantity(&r, 4, if coils { MAX_BITS } else { MAX_REGISTERS })?;
            if coils {
                Response::WriteMultipleCoils { address, quantity }
            } else {
                Response::WriteMultipleRegisters { address, quantity }
            }
        }
        other => {
            return Err(r.err(
                1,
                "function code",
                DecodeErrorKind::Function,
                Expected::OneOf("01-08, 0B, 0C, 0F, 10, or one of them + 80H"),
                other as u32,
            ))
        }
    };
    Ok((unit, resp))
}

/// One ADU held inline ([`MAX_ADU`] bytes, no heap): what the engines hand to the application.
/// Two ADUs are equal when their bytes ([`Adu::as_bytes`]) are: what lies in the buffer beyond
/// them is not part of the ADU (an engine refills a kept ADU without zeroing it first).
#[derive(Clone, Copy)]
pub struct Adu {
    buf: [u8; MAX_ADU],
    len: u16,
}

impl PartialEq for Adu {
    fn eq(&self, other: &Self) -> bool {
        self.as_bytes() == other.as_bytes()
    }
}

impl Eq for Adu {}

impl Adu {
    /// An empty ADU.
    pub const fn new() -> Self {
        Adu {
            buf: [0; MAX_ADU],
            len: 0,
        }
    }

    /// A copy of `bytes`, `None` if longer than [`MAX_ADU`].
    pub fn from_slice(bytes: &[u8]) -> Option<Self> {
        let mut a = Adu::new();
        a.buf.get_mut(..bytes.len())?.copy_from_slice(bytes);
        a.len = bytes.len() as u16;
        Some(a)
    }

    /// Encode a request into a new ADU.
    pub fn request(unit: u8, request: &Request<'_>) -> Result<Self, EncodeError> {
        let mut a = Adu::new();
        a.len = request.encode(unit, &mut a.buf)? as u16;
        Ok(a)
    }

    /// Overwrite this ADU with `bytes` (an engine's frame built in place); `false`, and left
    /// as it was, if they are longer than [`MAX_ADU`].
    pub(crate) fn fill(&mut self, bytes: &[u8]) -> bool {
        let Some(buf) = self.buf.get_mut(..bytes.len()) else {
            return false;
        };
        buf.copy_from_slice(bytes);
        self.len = bytes.len() as u16;
        true
    }

    /// Encode a request into this ADU, in place (an engine's job slot); on error it is
    /// left as it was.
    pub(crate) fn encode_request(
        &mut self,
        unit: u8,
        request: &Request<'_>,
    ) -> Result<(), EncodeError> {
        self.len = request.encode(unit, &mut self.buf)? as u16;
        Ok(())
    }

    /// Encode a response into a new ADU.
    pub fn response(unit: u8, response: &Response<'_>) -> Result<Self, EncodeError> {
        let mut a = Adu::new();
        a.len = response.encode(unit, &mut a.buf)? as u16;
        Ok(a)
    }

    /// The bytes, CRC included.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len as usize]
    }

    /// The slave address byte.
    pub fn unit(&self) -> u8 {
        self.buf[0]
    }

    /// Read it as a request.
    pub fn decode_request(&self) -> Result<(u8, Request<'_>), DecodeError> {
        decode_request(self.as_bytes())
    }

    /// Read it as a response.
    pub fn decode_response(&self) -> Result<(u8, Response<'_>), DecodeError> {
        decode_response(self.as_bytes())
    }
}

impl Default for Adu {
    fn default() -> Self {
        Adu::new()
    }
}

impl fmt::Debug for Adu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Adu({})", si_core::hex::format(self.as_bytes()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seal_appends_the_crc_low_byte_first_and_refuses_a_body_too_short_or_too_long() {
        let adu = seal(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x01]).unwrap();
        assert_eq!(adu, [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A]);
        assert!(crc_ok(&adu));
        assert!(seal(&[0x01]).unwrap_err().contains("function code"));
        let e = seal(&[0u8; MAX_ADU - 1]).unwrap_err();
        assert!(e.contains(&format!("{} bytes", MAX_ADU - 1)), "{e}");
        assert_eq!(seal(&[0u8; MAX_ADU - 2]).unwrap().len(), MAX_ADU);
    }

    fn hex(s: &str) -> Vec<u8> {
        si_core::hex::parse(s).unwrap()
    }

    #[test]
    fn a_register_read_is_read_by_the_short_path_as_the_decoder_reads_it() {
        let mut accepted = 0;
        for function in [0x03, 0x04, 0x01, 0x83] {
            for count in [0u8, 1, 2, 3, 20, 254, 255] {
                for extra in [0usize, 1] {
                    let mut pdu = vec![0x01, function, count];
                    pdu.extend((0..count as usize + extra).map(|i| i as u8));
                    pdu.truncate(3 + (count as usize + extra).min(252));
                    let short = register_response(&pdu);
                    let decoded = decode_unit_pdu_response(&pdu).ok().map(|(_, r)| r);
                    match short {
                        Some(r) => {
                            accepted += 1;
                            assert_eq!(Some(r), decoded, "{pdu:02X?}");
                        }
                        None => assert!(
                            !matches!(
                                decoded,
                                Some(
                                    Response::ReadHoldingRegisters(_)
                                        | Response::ReadInputRegisters(_)
                                )
                            ),
                            "{pdu:02X?}"
                        ),
                    }
                }
            }
        }
        // FC03 and FC04 with 2 and 20 bytes, each exact.
        assert_eq!(accepted, 4);
    }

    fn req(unit: u8, r: Request<'_>) -> Vec<u8> {
        Adu::request(unit, &r).unwrap().as_bytes().to_vec()
    }

    fn resp(unit: u8, r: Response<'_>) -> Vec<u8> {
        Adu::response(unit, &r).unwrap().as_bytes().to_vec()
    }

    /// The two CRC paths agree with the catalog's definition at every length up to a full ADU
    /// and over the threshold where [`crc16`] switches between them.
    #[test]
    fn crc16_both_paths_match_the_catalog_at_every_length() {
        let reference = crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_MODBUS);
        let mut x = 0x2545_F491_u32;
        let data: Vec<u8> = (0..MAX_ADU + 64)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                x as u8
            })
            .collect();
        for len in 0..data.len() {
            for start in [0, 1, 3] {
                let bytes = &data[start..len.max(start)];
                assert_eq!(
                    crc16(bytes),
                    reference.checksum(bytes),
                    "length {}",
                    bytes.len()
                );
            }
        }
        assert_eq!(crc16(b"123456789"), crc::CRC_16_MODBUS.check);
    }

    /// Golden request bytes for every function code ([Modbus/USS] §3.3.3, Table 3-10,
    /// §3.4.5–§3.4.16), CRC included. The CRCs are those of the Modbus specification's examples and
    /// of common tools (modpoll, pymodbus).
    #[test]
    fn golden_requests_every_function_code() {
        let cases: &[(Request<'_>, &str)] = &[
            (
                Request::ReadHoldingRegisters {
                    address: 0,
                    quantity: 10,
                },
                "01 03 00 00 00 0A C5 CD",
            ),
            (
                Request::ReadCoils {
                    address: 0x13,
                    quantity: 0x25,
                },
                "01 01 00 13 00 25 0C 14",
            ),
            (
                Request::ReadDiscreteInputs {
                    address: 0xC4,
                    quantity: 0x16,
                },
                "01 02 00 C4 00 16 B8 39",
            ),
            (
                Request::ReadInputRegisters {
                    address: 0x08,
                    quantity: 1,
                },
                "01 04 00 08 00 01 B0 08",
            ),
            (
                Request::WriteSingleCoil {
                    address: 0xAC,
                    value: true,
                },
                "01 05 00 AC FF 00 4C 1B",
            ),
            (
                Request::WriteSingleRegister {
                    address: 1,
                    value: 3,
                },
                "01 06 00 01 00 03 98 0B",
            ),
            (Request::ReadExceptionStatus, "01 07 41 E2"),
            (
                Request::Diagnostics { data: 0xA537 },
                "01 08 00 00 A5 37 DA 8D",
            ),
            (Request::GetCommEventCounter, "01 0B 41 E7"),
            (Request::GetCommEventLog, "01 0C 00 25"),
            (
                Request::WriteMultipleCoils {
                    address: 0x13,
                    values: Bits::packed(&[0xCD, 0x01], 10),
                },
                "01 0F 00 13 00 0A 02 CD 01 72 CB",
            ),
            (
                Request::WriteMultipleRegisters {
                    address: 1,
                    values: Registers::Words(&[0x000A, 0x0102]),
                },
                "01 10 00 01 00 02 04 00 0A 01 02 92 30",
            ),
        ];
        for (r, bytes) in cases {
            assert_eq!(req(1, *r), hex(bytes), "{r:?}");
            let wire = hex(bytes);
            assert_eq!(decode_request(&wire).unwrap(), (1, *r), "{bytes}");
        }
    }

    /// Golden response bytes for every function code, CRC included.
    #[test]
    fn golden_responses_every_function_code() {
        let cases: &[(Response<'_>, &str)] = &[
            (
                Response::ReadCoils(Bits::packed(&[0xCD, 0x6B, 0xB2, 0x0E, 0x1B], 40)),
                "01 01 05 CD 6B B2 0E 1B 44 EA",
            ),
            (
                Response::ReadDiscreteInputs(Bits::packed(&[0xAC, 0xDB, 0x35], 24)),
                "01 02 03 AC DB 35 22 88",
            ),
            (
                Response::ReadHoldingRegisters(Registers::Words(&[0x022B, 0x0000, 0x0064])),
                "01 03 06 02 2B 00 00 00 64 05 7A",
            ),
            (
                Response::ReadInputRegisters(Registers::Words(&[0x000A])),
                "01 04 02 00 0A 39 37",
            ),
            (
                Response::WriteSingleCoil {
                    address: 0xAC,
                    value: true,
                },
                "01 05 00 AC FF 00 4C 1B",
            ),
            (
                Response::WriteSingleRegister {
                    address: 1,
                    value: 3,
                },
                "01 06 00 01 00 03 98 0B",
            ),
            (Response::ReadExceptionStatus(0x6D), "01 07 6D E3 DD"),
            (
                Response::Diagnostics { data: 0xA537 },
                "01 08 00 00 A5 37 DA 8D",
            ),
            (
                Response::GetCommEventCounter {
                    status: 0xFFFF,
                    event_count: 0x0108,
                },
                "01 0B FF FF 01 08 A4 79",
            ),
            (
                Response::GetCommEventLog {
                    status: 0,
                    event_count: 0x0108,
                    message_count: 0x0121,
                    events: &[0x20, 0x00],
                },
                "01 0C 08 00 00 01 08 01 21 20 00 0D C1",
            ),
            (
                Response::WriteMultipleCoils {
                    address: 0x13,
                    quantity: 10,
                },
                "01 0F 00 13 00 0A 24 09",
            ),
            (
                Response::WriteMultipleRegisters {
                    address: 1,
                    quantity: 2,
                },
                "01 10 00 01 00 02 10 08",
            ),
        ];
        for (r, bytes) in cases {
            assert_eq!(resp(1, *r), hex(bytes), "{r:?}");
            assert_eq!(decode_response(&hex(bytes)).unwrap(), (1, *r), "{bytes}");
        }
    }

    /// [Modbus/USS] §3.3.6, Table 3-12: "05 85 02 CRClo CRChi", and every code 01–07 decodes.
    #[test]
    fn golden_exceptions_every_code() {
        let e = Response::Exception {
            function: 5,
            code: ExceptionCode::IllegalDataAddress,
        };
        assert_eq!(resp(5, e), hex("05 85 02 82 90"));
        let cases = [
            (ExceptionCode::IllegalFunction, "01 81 01 81 90"),
            (ExceptionCode::IllegalDataAddress, "01 81 02 C1 91"),
            (ExceptionCode::IllegalDataValue, "01 81 03 00 51"),
            (ExceptionCode::SlaveDeviceFailure, "01 81 04 41 93"),
            (ExceptionCode::Acknowledge, "01 81 05 80 53"),
            (ExceptionCode::SlaveDeviceBusy, "01 81 06 C0 52"),
            (ExceptionCode::NegativeAcknowledge, "01 81 07 01 92"),
        ];
        for (code, bytes) in cases {
            let e = Response::Exception { function: 1, code };
            assert_eq!(resp(1, e), hex(bytes), "{code}");
            assert_eq!(decode_response(&hex(bytes)).unwrap(), (1, e));
        }
        let named = [
            (
                8,
                ExceptionCode::MemoryParityError,
                "exception 08 memory parity error",
            ),
            (
                0x0A,
                ExceptionCode::GatewayPathUnavailable,
                "exception 0A gateway path unavailable",
            ),
            (
                0x0B,
                ExceptionCode::GatewayTargetFailed,
                "exception 0B gateway target device failed to respond",
            ),
            (
                0x0C,
                ExceptionCode::Custom(0x0C),
                "exception 0C (not a named code)",
            ),
            (
                0,
                ExceptionCode::Custom(0),
                "exception 00 (not a named code)",
            ),
        ];
        for (byte, code, text) in named {
            let mut v = vec![1, 0x81, byte];
            let c = crc16(&v).to_le_bytes();
            v.extend_from_slice(&c);
            let e = Response::Exception { function: 1, code };
            assert_eq!(decode_response(&v).unwrap(), (1, e), "{byte:02X}");
            assert_eq!(code.to_string(), text);
            assert_eq!(code.code(), byte);
            assert_eq!(resp(1, e), v);
        }
    }

    #[test]
    fn every_exception_byte_round_trips_and_only_01_to_07_have_a_status() {
        for byte in 0..=u8::MAX {
            let code = ExceptionCode::from_byte(byte);
            assert_eq!(code.code(), byte);
            assert_eq!(ExceptionCode::from(byte), code);
            assert_eq!(
                ExceptionCode::from_u8(byte).is_some(),
                (1..=7).contains(&byte)
            );
        }
    }

    #[test]
    fn decode_errors_name_frame_offset_expected_and_found() {
        let e = decode_request(&hex("01 03 00 00 00 0A C5 CE")).unwrap_err();
        assert_eq!(e.kind, DecodeErrorKind::Crc);
        assert_eq!(
            e.to_string(),
            "request byte 6: CRC expected 52677 (0xCDC5), found 52933 (0xCEC5)"
        );
        let mut f = hex("01 03 00 00 08 00");
        let c = crc16(&f).to_le_bytes();
        f.extend_from_slice(&c);
        let e = decode_request(&f).unwrap_err();
        assert_eq!((e.kind, e.offset), (DecodeErrorKind::Quantity, 4));
        assert_eq!(e.expected, Expected::Range(1, 127));
        assert_eq!(e.found, 0x0800);
        let e = decode_request(&[1, 3, 0]).unwrap_err();
        assert_eq!(e.kind, DecodeErrorKind::TooShort);
    }

    #[test]
    fn request_limits_are_the_manuals() {
        let ok = Request::ReadCoils {
            address: 0,
            quantity: 2040,
        };
        assert!(ok.validate().is_ok());
        let bad = Request::ReadCoils {
            address: 0,
            quantity: 2041,
        };
        assert!(bad.validate().is_err());
        let bad = Request::ReadHoldingRegisters {
            address: 0,
            quantity: 128,
        };
        assert!(bad.validate().is_err());
        // FC15 with 2040 bits fits MAX_ADU.
        let bools = [true; 2040];
        let r = Request::WriteMultipleCoils {
            address: 0,
            values: Bits::Bools(&bools),
        };
        assert_eq!(Adu::request(1, &r).unwrap().as_bytes().len(), MAX_ADU);
    }
}
