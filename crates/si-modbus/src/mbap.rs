//! Modbus TCP framing: the MBAP header and a streaming decoder, Sans-IO.
//!
//! **External source** (not in the project's spec files, whose manuals cover the serial module
//! only): *Modbus Messaging on TCP/IP Implementation Guide V1.0b*, §3.1.3 "MBAP header
//! description", and *Modbus Application Protocol Specification V1.1b3*, §4.1 (a PDU is at
//! most 253 bytes). A Modbus TCP ADU is
//!
//! ```text
//! offset 0  transaction id  u16 big-endian  chosen by the client, copied by the server
//!        2  protocol id     u16             0 = Modbus
//!        4  length          u16             bytes that follow: unit id + PDU, 2…254
//!        6  unit id         u8              the serial slave behind a gateway
//!        7  PDU             function code + data, 1…253 bytes, no CRC (TCP has its own)
//! ```
//!
//! The PDU codec is the RTU one ([`crate::frame`]): an RTU ADU is `unit | PDU | CRC` and the
//! part after the MBAP length field is `unit | PDU`, so encoding writes
//! [`Request::encode_unit_pdu`] straight after a 6-byte header, and decoding reads the same
//! bytes with [`frame::decode_unit_pdu_request`].
//!
//! # Readings chosen
//!
//! - The manual's quantity limits (2040 bits, 127 registers, see [`crate::frame`]) are above
//!   what fits in 253 PDU bytes; over TCP the MBAP length is the bound: an ADU that would be
//!   longer than 254 bytes after the length field is refused by the encoder, and the
//!   [`Server`](crate::tokio::tcp::Server) answers a request whose response would not fit with
//!   exception 03 (illegal data value), the exception the Modbus specification gives for a
//!   quantity over 125 registers or 2000 bits.
//! - After a bad header (protocol id ≠ 0, length outside 2…254) there is no way to find the
//!   next frame: the length field is the only delimiter. The guide names no resynchronisation;
//!   the [`Decoder`] stays failed until [`Decoder::reset`], and the connection should be closed,
//!   as mbusd does ("header is damaged, drop connection", `conn_loop` in the copy at
//!   mbusd's `src/conn.c`). Our server closes it.
//!
//! No allocation: an ADU is held inline ([`TcpAdu`]), the decoder owns one.
//!
//! ```
//! use si_modbus::frame::Request;
//! use si_modbus::mbap::{Decoder, TcpAdu};
//! let adu = TcpAdu::request(0x0102, 1, &Request::ReadHoldingRegisters { address: 0, quantity: 10 }).unwrap();
//! assert_eq!(adu.as_bytes(), [0x01, 0x02, 0, 0, 0, 6, 0x01, 0x03, 0x00, 0x00, 0x00, 0x0A]);
//! // Any chunking: here one byte at a time.
//! let mut decoder = Decoder::new();
//! let mut frames = 0;
//! for b in adu.as_bytes() {
//!     let mut input: &[u8] = std::slice::from_ref(b);
//!     if let Some(got) = decoder.decode(&mut input).unwrap() {
//!         assert_eq!(got.transaction(), 0x0102);
//!         assert_eq!(got.decode_request().unwrap(), (1, Request::ReadHoldingRegisters { address: 0, quantity: 10 }));
//!         frames += 1;
//!     }
//! }
//! assert_eq!(frames, 1);
//! ```

use core::fmt;

use crate::frame::{self, DecodeError, EncodeError, Expected, Request, Response, MAX_ADU};

/// Bytes before the unit id: transaction id, protocol id, length.
pub const PREFIX_LEN: usize = 6;

/// The MBAP header with the unit id (Implementation Guide §3.1.3: 7 bytes).
pub const HEADER_LEN: usize = 7;

/// The protocol id of Modbus.
pub const PROTOCOL_MODBUS: u16 = 0;

/// Smallest length field: unit id + function code.
pub const MIN_LENGTH: u16 = 2;

/// Largest length field: unit id + a PDU of 253 bytes (Application Protocol §4.1).
pub const MAX_LENGTH: u16 = 254;

/// The largest Modbus TCP ADU: 6 + 254 = 260 bytes.
pub const MAX_TCP_ADU: usize = PREFIX_LEN + MAX_LENGTH as usize;

/// Room to encode into: the RTU encoder may write up to [`MAX_ADU`] bytes (manual limits)
/// before the length check refuses them.
const ENCODE_ROOM: usize = PREFIX_LEN + MAX_ADU;

/// One Modbus TCP ADU held inline (no heap).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct TcpAdu {
    buf: [u8; ENCODE_ROOM],
    len: u16,
}

impl TcpAdu {
    const EMPTY: TcpAdu = TcpAdu {
        buf: [0; ENCODE_ROOM],
        len: 0,
    };

    /// Encode a request with this transaction id for `unit`.
    pub fn request(transaction: u16, unit: u8, request: &Request<'_>) -> Result<Self, EncodeError> {
        let mut a = Self::EMPTY;
        let n = request.encode_unit_pdu(unit, &mut a.buf[PREFIX_LEN..])?;
        a.finish(transaction, n)
    }

    /// Encode a response (an exception too) with the request's transaction id and unit.
    pub fn response(
        transaction: u16,
        unit: u8,
        response: &Response<'_>,
    ) -> Result<Self, EncodeError> {
        let mut a = Self::EMPTY;
        let n = response.encode_unit_pdu(unit, &mut a.buf[PREFIX_LEN..])?;
        a.finish(transaction, n)
    }

    /// Put an MBAP header before raw `unit | PDU` bytes, unchecked beyond their length (2…254):
    /// what a transparent gateway does with an RTU ADU without its CRC, or with an exception
    /// the module never sends (0AH, 0BH).
    pub fn from_unit_pdu(transaction: u16, unit_pdu: &[u8]) -> Result<Self, EncodeError> {
        let mut a = Self::EMPTY;
        let n = unit_pdu.len();
        // One error for every length out of range, too short or too long.
        if !(MIN_LENGTH as usize..=MAX_LENGTH as usize).contains(&n) {
            return Err(EncodeError::Quantity {
                what: "Modbus TCP unit id + PDU bytes",
                value: n,
                max: MAX_LENGTH as usize,
            });
        }
        a.buf
            .get_mut(PREFIX_LEN..PREFIX_LEN + n)
            .ok_or(EncodeError::BufferTooSmall(ENCODE_ROOM))?
            .copy_from_slice(unit_pdu);
        a.finish(transaction, n)
    }

    /// Write the header for `unit_pdu` bytes of unit + PDU, refusing more than [`MAX_LENGTH`].
    fn finish(mut self, transaction: u16, unit_pdu: usize) -> Result<Self, EncodeError> {
        if unit_pdu > MAX_LENGTH as usize {
            return Err(EncodeError::Quantity {
                what: "Modbus TCP unit id + PDU bytes",
                value: unit_pdu,
                max: MAX_LENGTH as usize,
            });
        }
        self.buf[0..2].copy_from_slice(&transaction.to_be_bytes());
        self.buf[2..4].copy_from_slice(&PROTOCOL_MODBUS.to_be_bytes());
        self.buf[4..6].copy_from_slice(&(unit_pdu as u16).to_be_bytes());
        self.len = (PREFIX_LEN + unit_pdu) as u16;
        Ok(self)
    }

    /// The bytes on the wire.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len as usize]
    }

    /// The transaction id.
    pub fn transaction(&self) -> u16 {
        u16::from_be_bytes([self.buf[0], self.buf[1]])
    }

    /// The unit id.
    pub fn unit(&self) -> u8 {
        self.buf[PREFIX_LEN]
    }

    /// The function code (MSB set for an exception).
    pub fn function(&self) -> u8 {
        self.buf[HEADER_LEN]
    }

    /// `unit | PDU`, the bytes after the length field.
    pub fn unit_pdu(&self) -> &[u8] {
        &self.buf[PREFIX_LEN..self.len as usize]
    }

    /// Read it as a request: `(unit, request)`. Error offsets count from the transaction id.
    pub fn decode_request(&self) -> Result<(u8, Request<'_>), DecodeError> {
        frame::decode_unit_pdu_request(self.unit_pdu()).map_err(shift)
    }

    /// Read it as a response: `(unit, response)`. Error offsets count from the transaction id.
    pub fn decode_response(&self) -> Result<(u8, Response<'_>), DecodeError> {
        frame::decode_unit_pdu_response(self.unit_pdu()).map_err(shift)
    }
}

/// An error found in `unit | PDU`, with its offset in the whole TCP ADU.
fn shift(mut e: DecodeError) -> DecodeError {
    e.offset += PREFIX_LEN;
    e
}

impl Default for TcpAdu {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl fmt::Debug for TcpAdu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "TcpAdu({})", si_core::hex::format(self.as_bytes()))
    }
}

/// A header the decoder refuses: which field, at which byte offset of the ADU, what the guide
/// allows and what the bytes hold. The stream cannot be resynchronised after it (see the
/// module documentation): close the connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
#[error("MBAP header byte {offset}: {field} expected {expected}, found {found} (0x{found:X})")]
pub struct HeaderError {
    /// Byte offset of the field in the ADU (2 = protocol id, 4 = length).
    pub offset: usize,
    /// "protocol id" or "length".
    pub field: &'static str,
    /// What the Implementation Guide allows.
    pub expected: Expected,
    /// What the bytes hold.
    pub found: u32,
}

/// A streaming MBAP decoder: takes bytes in any chunking and hands out complete ADUs.
#[derive(Clone)]
pub struct Decoder {
    adu: TcpAdu,
    /// Bytes of the current ADU collected so far.
    have: usize,
    /// The ADU in `adu` was handed out; the next call starts a new one.
    complete: bool,
    failed: Option<HeaderError>,
}

impl Decoder {
    /// A decoder waiting for the first byte of an ADU.
    pub const fn new() -> Self {
        Decoder {
            adu: TcpAdu::EMPTY,
            have: 0,
            complete: false,
            failed: None,
        }
    }

    /// Forget everything, including a failure (for a new connection).
    pub fn reset(&mut self) {
        *self = Decoder::new();
    }

    /// Bytes of an unfinished ADU held (0 between ADUs): a connection that closes with some
    /// held ended in the middle of a frame.
    pub fn pending(&self) -> usize {
        if self.complete {
            0
        } else {
            self.have
        }
    }

    /// Take bytes from the front of `input` until one ADU is complete or `input` is empty.
    ///
    /// Returns the ADU once it is complete (call again with the rest of `input` for the next),
    /// `Ok(None)` when all of `input` was taken and more is needed, or the header error; after
    /// an error every call returns it again until [`Decoder::reset`].
    pub fn decode(&mut self, input: &mut &[u8]) -> Result<Option<&TcpAdu>, HeaderError> {
        if let Some(e) = self.failed {
            return Err(e);
        }
        if self.complete {
            self.complete = false;
            self.have = 0;
        }
        loop {
            let want = self.expected_len();
            if self.have == want {
                self.adu.len = want as u16;
                self.complete = true;
                return Ok(Some(&self.adu));
            }
            let Some((&byte, rest)) = input.split_first() else {
                return Ok(None);
            };
            *input = rest;
            self.adu.buf[self.have] = byte;
            self.have += 1;
            if let Err(e) = self.check_header() {
                self.failed = Some(e);
                return Err(e);
            }
        }
    }

    /// The length of the current ADU as far as it is known: the header until the length field
    /// has arrived, then the whole ADU.
    fn expected_len(&self) -> usize {
        if self.have < PREFIX_LEN {
            PREFIX_LEN
        } else {
            PREFIX_LEN + self.length_field() as usize
        }
    }

    fn length_field(&self) -> u16 {
        u16::from_be_bytes([self.adu.buf[4], self.adu.buf[5]])
    }

    /// Check a header field as soon as its last byte has arrived.
    fn check_header(&self) -> Result<(), HeaderError> {
        match self.have {
            4 => {
                let protocol = u16::from_be_bytes([self.adu.buf[2], self.adu.buf[3]]);
                if protocol != PROTOCOL_MODBUS {
                    return Err(HeaderError {
                        offset: 2,
                        field: "protocol id",
                        expected: Expected::Exactly(PROTOCOL_MODBUS as u32),
                        found: protocol as u32,
                    });
                }
            }
            PREFIX_LEN => {
                let length = self.length_field();
                if !(MIN_LENGTH..=MAX_LENGTH).contains(&length) {
                    return Err(HeaderError {
                        offset: 4,
                        field: "length",
                        expected: Expected::Range(MIN_LENGTH as u32, MAX_LENGTH as u32),
                        found: length as u32,
                    });
                }
            }
            _ => {}
        }
        Ok(())
    }
}

impl Default for Decoder {
    fn default() -> Self {
        Decoder::new()
    }
}

impl fmt::Debug for Decoder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Decoder")
            .field("have", &self.have)
            .field("complete", &self.complete)
            .field("failed", &self.failed)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{ExceptionCode, Registers};

    fn decode_all(bytes: &[u8]) -> Vec<Result<TcpAdu, HeaderError>> {
        let mut d = Decoder::new();
        let mut input = bytes;
        let mut out = Vec::new();
        loop {
            match d.decode(&mut input) {
                Ok(Some(adu)) => out.push(Ok(*adu)),
                Ok(None) => return out,
                Err(e) => {
                    out.push(Err(e));
                    return out;
                }
            }
        }
    }

    /// The Implementation Guide's layout: FC16 request, header then `unit | PDU`.
    #[test]
    fn golden_fc16_request_and_response() {
        let req = TcpAdu::request(
            7,
            0x11,
            &Request::WriteMultipleRegisters {
                address: 1,
                values: Registers::Words(&[0x000A, 0x0102]),
            },
        )
        .unwrap();
        assert_eq!(
            si_core::hex::format(req.as_bytes()),
            "00 07 00 00 00 0B 11 10 00 01 00 02 04 00 0A 01 02"
        );
        let resp = TcpAdu::response(
            7,
            0x11,
            &Response::Exception {
                function: 0x10,
                code: ExceptionCode::IllegalDataAddress,
            },
        )
        .unwrap();
        assert_eq!(
            si_core::hex::format(resp.as_bytes()),
            "00 07 00 00 00 03 11 90 02"
        );
    }

    #[test]
    fn raw_unit_pdu_gets_a_header_within_the_length_limits() {
        let adu = TcpAdu::from_unit_pdu(0x1234, &[5, 0x83, 0x0B]).unwrap();
        assert_eq!(adu.as_bytes(), [0x12, 0x34, 0, 0, 0, 3, 5, 0x83, 0x0B]);
        assert!(TcpAdu::from_unit_pdu(1, &[5]).is_err());
        assert!(TcpAdu::from_unit_pdu(1, &[0; 254]).is_ok());
        for n in [1, 255, 256, 1000] {
            assert!(
                matches!(
                    TcpAdu::from_unit_pdu(1, &vec![0; n]),
                    Err(EncodeError::Quantity { value, max: 254, .. }) if value == n
                ),
                "{n} bytes"
            );
        }
    }

    #[test]
    fn two_adus_in_one_chunk_come_out_one_by_one() {
        let a = TcpAdu::request(
            1,
            1,
            &Request::ReadCoils {
                address: 0,
                quantity: 8,
            },
        )
        .unwrap();
        let b = TcpAdu::request(2, 9, &Request::Diagnostics { data: 0xA537 }).unwrap();
        let mut wire = a.as_bytes().to_vec();
        wire.extend_from_slice(b.as_bytes());
        let got = decode_all(&wire);
        assert_eq!(got, vec![Ok(a), Ok(b)]);
    }

    #[test]
    fn protocol_id_other_than_zero_is_refused_at_offset_2() {
        let got = decode_all(&[0, 1, 0, 1, 0, 6, 1, 3, 0, 0, 0, 1]);
        let e = got[0].unwrap_err();
        assert_eq!((e.offset, e.field, e.found), (2, "protocol id", 1));
        assert_eq!(
            e.to_string(),
            "MBAP header byte 2: protocol id expected 0 (0x0), found 1 (0x1)"
        );
    }

    #[test]
    fn length_outside_2_to_254_is_refused_and_stays_refused_until_reset() {
        for length in [0u16, 1, 255, 0xFFFF] {
            let [h, l] = length.to_be_bytes();
            let mut d = Decoder::new();
            let mut input: &[u8] = &[0, 1, 0, 0, h, l, 1, 3];
            let e = d.decode(&mut input).unwrap_err();
            assert_eq!((e.offset, e.field, e.found), (4, "length", length as u32));
            assert_eq!(e.expected, Expected::Range(2, 254));
            assert_eq!(input, &[1, 3], "bytes after the bad header are not taken");
            let mut more: &[u8] = &[0, 1, 0, 0, 0, 2, 1, 7];
            assert_eq!(d.decode(&mut more), Err(e));
            d.reset();
            assert!(d.decode(&mut more).unwrap().is_some());
        }
    }

    #[test]
    fn a_response_too_long_for_tcp_is_refused_by_the_encoder() {
        let words = [0u16; 127];
        let e = TcpAdu::response(
            1,
            1,
            &Response::ReadHoldingRegisters(Registers::Words(&words)),
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                EncodeError::Quantity {
                    value: 257,
                    max: 254,
                    ..
                }
            ),
            "{e:?}"
        );
        // 125 registers, the Modbus specification's limit, fit: unit, FC, byte count, 250 bytes.
        let ok = TcpAdu::response(
            1,
            1,
            &Response::ReadHoldingRegisters(Registers::Words(&words[..125])),
        )
        .unwrap();
        assert_eq!(ok.as_bytes().len(), 6 + 253);
    }

    #[test]
    fn pdu_errors_name_their_offset_in_the_tcp_adu() {
        // FC03 with quantity 0: the quantity is at TCP offset 10.
        let got = decode_all(&[0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 0]);
        let e = got[0].unwrap().decode_request().unwrap_err();
        assert_eq!((e.offset, e.field), (10, "quantity"));
        // A request one byte short: length says 5, FC03 needs 6.
        let got = decode_all(&[0, 1, 0, 0, 0, 5, 1, 3, 0, 0, 0]);
        let e = got[0].unwrap().decode_request().unwrap_err();
        assert_eq!((e.offset, e.field), (11, "length"));
    }
}
