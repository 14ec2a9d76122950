//! One decoded request executed against a [`Store`]: the part of the slave that does not
//! depend on the line, shared by the RTU slave engine ([`crate::slave`]) and the Modbus TCP
//! server ([`crate::tokio::tcp`]), so that both answer a request identically
//! ([Modbus/USS] §3.5.6–§3.5.14, Table 3-12).

use crate::frame::{fc, Bits, DecodeErrorKind, ExceptionCode, Registers, Request, Response};
use crate::status::slave as codes;
use crate::store::{Store, StoreError};
use si_core::Status;

/// Room for the data of any read response: 255 bytes of bits or 254 of registers.
pub type ResponseData = [u8; 256];

/// What a request came to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome<'d> {
    /// Executed: the response to send, the start address and the number of bits or registers
    /// (1 for FC05/06/08; address 0 for FC08).
    Answer {
        /// The response PDU (its data borrows the caller's [`ResponseData`]).
        response: Response<'d>,
        /// Start address.
        address: u16,
        /// Number of bits or registers.
        quantity: u16,
    },
    /// Refused with an exception.
    Refused {
        /// The exception to send.
        code: ExceptionCode,
        /// The driver event (0831H–0835H), if the driver's checks refused it.
        status: Option<Status>,
        /// The store's refusal, if the store refused it.
        error: Option<StoreError>,
    },
}

/// The exception and driver event for a request that failed to decode for any reason but its
/// CRC ([Modbus/USS] §3.5.6–§3.5.14: 0831H → exception 01; 0832H–0835H → exception 03).
pub fn refusal(kind: DecodeErrorKind) -> (ExceptionCode, Option<Status>) {
    match kind {
        DecodeErrorKind::Function => (
            ExceptionCode::IllegalFunction,
            Some(codes::INVALID_FUNCTION),
        ),
        DecodeErrorKind::Quantity => (ExceptionCode::IllegalDataValue, Some(codes::QUANTITY)),
        DecodeErrorKind::ByteCount => (ExceptionCode::IllegalDataValue, Some(codes::BYTE_COUNT)),
        DecodeErrorKind::CoilValue => (ExceptionCode::IllegalDataValue, Some(codes::COIL_VALUE)),
        DecodeErrorKind::SubFunction => {
            (ExceptionCode::IllegalDataValue, Some(codes::SUB_FUNCTION))
        }
        _ => (ExceptionCode::IllegalDataValue, None),
    }
}

/// Execute `request` on `store`. FC08 is answered without the store ([Modbus/USS] §3.5.6–§3.5.14);
/// FC07, 11 and 12 are refused with exception 01, as the module's slave has none of them
/// ([Modbus/USS] §3.5.6–§3.5.14).
pub fn execute<'d, S: Store + ?Sized>(
    store: &mut S,
    request: &Request<'_>,
    data: &'d mut ResponseData,
) -> Outcome<'d> {
    let function = request.function();
    let result: Result<(Response<'d>, u16, u16), StoreError> = match *request {
        Request::ReadCoils { address, quantity }
        | Request::ReadDiscreteInputs { address, quantity } => {
            let n = (quantity as usize).div_ceil(8).min(data.len());
            let out = &mut data[..n];
            out.fill(0);
            let r = if function == fc::READ_COILS {
                store.read_coils(address, quantity, out)
            } else {
                store.read_discrete_inputs(address, quantity, out)
            };
            r.map(|()| {
                let bits = Bits::packed(&data[..n], quantity);
                let resp = if function == fc::READ_COILS {
                    Response::ReadCoils(bits)
                } else {
                    Response::ReadDiscreteInputs(bits)
                };
                (resp, address, quantity)
            })
        }
        Request::ReadHoldingRegisters { address, quantity }
        | Request::ReadInputRegisters { address, quantity } => {
            let n = (quantity as usize * 2).min(data.len());
            let out = &mut data[..n];
            let r = if function == fc::READ_HOLDING_REGISTERS {
                store.read_holding_registers(address, quantity, out)
            } else {
                store.read_input_registers(address, quantity, out)
            };
            r.map(|()| {
                let regs = Registers::Wire(&data[..n]);
                let resp = if function == fc::READ_HOLDING_REGISTERS {
                    Response::ReadHoldingRegisters(regs)
                } else {
                    Response::ReadInputRegisters(regs)
                };
                (resp, address, quantity)
            })
        }
        Request::WriteSingleCoil { address, value } => store
            .write_coils(address, Bits::Bools(&[value]))
            .map(|()| (Response::WriteSingleCoil { address, value }, address, 1)),
        Request::WriteSingleRegister { address, value } => store
            .write_registers(address, Registers::Words(&[value]))
            .map(|()| (Response::WriteSingleRegister { address, value }, address, 1)),
        Request::Diagnostics { data } => Ok((Response::Diagnostics { data }, 0, 1)),
        Request::WriteMultipleCoils { address, values } => {
            let quantity = values.len() as u16;
            store.write_coils(address, values).map(|()| {
                (
                    Response::WriteMultipleCoils { address, quantity },
                    address,
                    quantity,
                )
            })
        }
        Request::WriteMultipleRegisters { address, values } => {
            let quantity = values.len() as u16;
            store.write_registers(address, values).map(|()| {
                (
                    Response::WriteMultipleRegisters { address, quantity },
                    address,
                    quantity,
                )
            })
        }
        Request::ReadExceptionStatus | Request::GetCommEventCounter | Request::GetCommEventLog => {
            return Outcome::Refused {
                code: ExceptionCode::IllegalFunction,
                status: Some(codes::INVALID_FUNCTION),
                error: None,
            };
        }
    };
    match result {
        Ok((response, address, quantity)) => Outcome::Answer {
            response,
            address,
            quantity,
        },
        Err(e) => Outcome::Refused {
            code: e.exception,
            status: e.status,
            error: Some(e),
        },
    }
}
