//! Frames as a person reads them: `FC03 read 10 holding registers from 0`, `FC03 2 registers:
//! 0001 0002`, `FC03 exception 02 illegal data address`. Used by `si frame decode modbus`, the
//! line monitor and the frame log (`-v`); `Debug` stays the Rust form.
//!
//! Addresses are the PDU's (0-based, as on the wire), quantities and addresses decimal, data
//! hexadecimal as the manual prints register contents ([Modbus/USS] §3.5.6–§3.5.14). The alternate
//! form (`{:#}`) leaves out the leading `FCnn `, for a place that shows the function code already
//! (the monitor's label).

use super::{Bits, Registers, Request, Response};
use core::fmt;

/// `n thing` or `n things`, written without building a string.
struct Count<'a>(usize, &'a str);

impl fmt::Display for Count<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let plural = if self.0 == 1 { "" } else { "s" };
        write!(f, "{} {}{plural}", self.0, self.1)
    }
}

fn on_off(value: bool) -> &'static str {
    if value {
        "ON"
    } else {
        "OFF"
    }
}

/// Bits as 0/1 in address order.
fn bits(f: &mut fmt::Formatter<'_>, values: &Bits<'_>) -> fmt::Result {
    values
        .iter()
        .try_for_each(|b| f.write_str(if b { "1" } else { "0" }))
}

/// Registers as 4-digit hex words separated by spaces.
fn registers(f: &mut fmt::Formatter<'_>, values: &Registers<'_>) -> fmt::Result {
    for (i, r) in values.iter().enumerate() {
        let sep = if i == 0 { "" } else { " " };
        write!(f, "{sep}{r:04X}")?;
    }
    Ok(())
}

impl fmt::Display for Request<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !f.alternate() {
            write!(f, "FC{:02} ", self.function())?;
        }
        let read = |f: &mut fmt::Formatter<'_>, quantity: u16, thing: &str, address: u16| {
            write!(f, "read {} from {address}", Count(quantity.into(), thing))
        };
        match self {
            Request::ReadCoils { address, quantity } => read(f, *quantity, "coil", *address),
            Request::ReadDiscreteInputs { address, quantity } => {
                read(f, *quantity, "discrete input", *address)
            }
            Request::ReadHoldingRegisters { address, quantity } => {
                read(f, *quantity, "holding register", *address)
            }
            Request::ReadInputRegisters { address, quantity } => {
                read(f, *quantity, "input register", *address)
            }
            Request::WriteSingleCoil { address, value } => {
                write!(f, "write coil {address} {}", on_off(*value))
            }
            Request::WriteSingleRegister { address, value } => {
                write!(f, "write holding register {address} = {value:04X}")
            }
            Request::ReadExceptionStatus => f.write_str("read exception status"),
            Request::Diagnostics { data } => write!(f, "diagnostics echo {data:04X}"),
            Request::GetCommEventCounter => f.write_str("get comm event counter"),
            Request::GetCommEventLog => f.write_str("get comm event log"),
            Request::WriteMultipleCoils { address, values } => {
                write!(f, "write {} from {address}: ", Count(values.len(), "coil"))?;
                bits(f, values)
            }
            Request::WriteMultipleRegisters { address, values } => {
                let n = Count(values.len(), "holding register");
                write!(f, "write {n} from {address}: ")?;
                registers(f, values)
            }
        }
    }
}

impl fmt::Display for Response<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !f.alternate() {
            write!(f, "FC{:02} ", self.function() & 0x7F)?;
        }
        match self {
            Response::ReadCoils(values) | Response::ReadDiscreteInputs(values) => {
                // The count is the byte count × 8: the request's quantity is not in the answer.
                write!(f, "{}: ", Count(values.len(), "bit"))?;
                bits(f, values)
            }
            Response::ReadHoldingRegisters(values) | Response::ReadInputRegisters(values) => {
                write!(f, "{}: ", Count(values.len(), "register"))?;
                registers(f, values)
            }
            Response::WriteSingleCoil { address, value } => {
                write!(f, "coil {address} written {}", on_off(*value))
            }
            Response::WriteSingleRegister { address, value } => {
                write!(f, "holding register {address} written {value:04X}")
            }
            Response::ReadExceptionStatus(status) => write!(f, "exception status {status:02X}"),
            Response::Diagnostics { data } => write!(f, "diagnostics echo {data:04X}"),
            Response::GetCommEventCounter {
                status,
                event_count,
            } => write!(f, "status {status:04X}, event count {event_count}"),
            Response::GetCommEventLog {
                status,
                event_count,
                message_count,
                events,
            } => write!(
                f,
                "status {status:04X}, event count {event_count}, message count \
                 {message_count}, {}",
                Count(events.len(), "event byte")
            ),
            Response::WriteMultipleCoils { address, quantity } => {
                write!(
                    f,
                    "{} written from {address}",
                    Count((*quantity).into(), "coil")
                )
            }
            Response::WriteMultipleRegisters { address, quantity } => write!(
                f,
                "{} written from {address}",
                Count((*quantity).into(), "holding register")
            ),
            Response::Exception { code, .. } => write!(f, "{code}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::frame::{crc16, decode_request, decode_response};

    /// `adu` with its CRC (low byte first).
    fn with_crc(adu: &[u8]) -> Vec<u8> {
        let mut v = adu.to_vec();
        v.extend_from_slice(&crc16(adu).to_le_bytes());
        v
    }

    fn request(adu: &[u8]) -> String {
        decode_request(&with_crc(adu)).unwrap().1.to_string()
    }

    fn response(adu: &[u8]) -> String {
        decode_response(&with_crc(adu)).unwrap().1.to_string()
    }

    #[test]
    fn requests_read_as_the_function_and_its_fields() {
        assert_eq!(
            request(&[1, 3, 0, 0, 0, 10]),
            "FC03 read 10 holding registers from 0"
        );
        assert_eq!(request(&[1, 1, 0, 5, 0, 1]), "FC01 read 1 coil from 5");
        assert_eq!(request(&[1, 5, 0, 5, 0xFF, 0]), "FC05 write coil 5 ON");
        assert_eq!(
            request(&[1, 6, 0, 1, 0, 10]),
            "FC06 write holding register 1 = 000A"
        );
        assert_eq!(
            request(&[1, 16, 0, 1, 0, 2, 4, 0, 10, 1, 2]),
            "FC16 write 2 holding registers from 1: 000A 0102"
        );
        assert_eq!(
            request(&[1, 15, 0, 0, 0, 3, 1, 0b101]),
            "FC15 write 3 coils from 0: 101"
        );
        assert_eq!(
            request(&[1, 8, 0, 0, 0xA5, 0x37]),
            "FC08 diagnostics echo A537"
        );
    }

    #[test]
    fn responses_read_as_their_data_and_exceptions_by_name() {
        assert_eq!(
            response(&[1, 3, 4, 0, 1, 0, 2]),
            "FC03 2 registers: 0001 0002"
        );
        assert_eq!(response(&[1, 1, 1, 0b101]), "FC01 8 bits: 10100000");
        assert_eq!(
            response(&[1, 16, 0, 1, 0, 2]),
            "FC16 2 holding registers written from 1"
        );
        assert_eq!(
            response(&[1, 0x83, 2]),
            "FC03 exception 02 illegal data address"
        );
        let adu = with_crc(&[1, 3, 2, 0, 7]);
        let plain = decode_response(&adu).unwrap().1;
        assert_eq!(format!("{plain:#}"), "1 register: 0007");
    }
}
