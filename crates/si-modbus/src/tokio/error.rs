//! The one error of the async layer: the RTU master handles ([`Master`](super::Master),
//! [`InlineMaster`](super::InlineMaster)), the slave handle and the Modbus TCP client
//! ([`tcp::Client`](super::tcp::Client)) all fail with [`Error`], so a program generic over
//! [`Client`](super::Client) handles one type.

use crate::config::ConfigError;
use crate::frame::{fc, DecodeError, ExceptionCode, Request};
use crate::master::RequestError;
use crate::mbap::HeaderError;
use si_core::Status;
use std::fmt;

/// Which job failed: the unit, the function code and, where the request has one, its first
/// address. Errors print it first: "unit 17 FC03 address 100: …".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Job {
    /// The slave address (RTU) or unit id (TCP); 0 is a broadcast.
    pub unit: u8,
    /// The function code.
    pub function: u8,
    /// The request's starting address (none for FC07, FC08, FC11, FC12).
    pub address: Option<u16>,
}

impl Job {
    /// The job `request` to `unit`.
    pub fn of(unit: u8, request: &Request<'_>) -> Job {
        let address = match *request {
            Request::ReadCoils { address, .. }
            | Request::ReadDiscreteInputs { address, .. }
            | Request::ReadHoldingRegisters { address, .. }
            | Request::ReadInputRegisters { address, .. }
            | Request::WriteSingleCoil { address, .. }
            | Request::WriteSingleRegister { address, .. }
            | Request::WriteMultipleCoils { address, .. }
            | Request::WriteMultipleRegisters { address, .. } => Some(address),
            Request::ReadExceptionStatus
            | Request::Diagnostics { .. }
            | Request::GetCommEventCounter
            | Request::GetCommEventLog => None,
        };
        Job {
            unit,
            function: request.function(),
            address,
        }
    }
}

impl fmt::Display for Job {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unit {} FC{:02}", self.unit, self.function)?;
        if let Some(a) = self.address {
            write!(f, " address {a}")?;
        }
        Ok(())
    }
}

/// Why an async Modbus job failed. `Refused`, `Failed`, `Config` and `Stopped` mean the same in
/// every protocol crate of si; the rest are Modbus TCP's.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The job was refused before anything was sent: it breaks a rule of [Modbus/USS] §3.4.5–§3.4.16 (0E43H–0E46H:
    /// a quantity out of range, a function not allowed as broadcast), or it cannot be encoded
    /// for TCP.
    #[error("{job}: {reason}")]
    Refused {
        /// The job.
        job: Job,
        /// Why, with the STATUS the module reports ([`RequestError::status`]).
        reason: RequestError,
    },
    /// The job ended with the manual's STATUS: no response (0830H), a response that fails the
    /// checks of [Modbus/USS] §3.4.5–§3.4.16 (0E51H–0E57H, 0831H), or an exception (0E61H–0E67H, with its code in
    /// `exception`).
    #[error("{job}: {}", failure_text(*.status, *.exception))]
    Failed {
        /// The STATUS (for a Modbus TCP exception the module's master has no STATUS for, such
        /// as a gateway's 0AH or 0BH: 0E51H "wrong function code", as an RTU master reports
        /// it; the code is in `exception`).
        status: Status,
        /// The job.
        job: Job,
        /// The exception code the slave or server answered with, if it did.
        exception: Option<u8>,
    },
    /// The configuration is out of range.
    #[error("{0}")]
    Config(#[from] ConfigError),
    /// The line is gone: the driver task ended (the port closed or failed), or the Modbus TCP
    /// server closed the connection.
    #[error("the line has stopped: the port or connection was closed")]
    Stopped,
    /// Opening the serial port or connecting failed, or the connection failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// Modbus TCP: the server sent a header that cannot be framed; the connection is unusable.
    #[error("{0}")]
    Header(#[from] HeaderError),
    /// Modbus TCP: the response PDU is malformed.
    #[error("{job}: {source}")]
    Decode {
        /// The job.
        job: Job,
        /// What is wrong with the PDU.
        source: DecodeError,
    },
    /// Modbus TCP: an earlier failure left the stream without a frame boundary (a header error,
    /// or a timeout in the middle of sending a request): connect again.
    #[error("connection unusable after an earlier failure")]
    Broken,
}

impl From<si_core::driver::DriverStopped> for Error {
    fn from(_: si_core::driver::DriverStopped) -> Self {
        Error::Stopped
    }
}

fn failure_text(status: Status, exception: Option<u8>) -> String {
    match exception {
        Some(code) => match ExceptionCode::from_u8(code) {
            Some(e) => format!("{e} ({status})"),
            None => format!("exception {code:02X}H{}", gateway_text(code)),
        },
        None => status.to_string(),
    }
}

/// The gateway exception codes of the Modbus application protocol, which the module never sends.
fn gateway_text(code: u8) -> &'static str {
    match code {
        0x0A => " (gateway path unavailable)",
        0x0B => " (gateway target device failed to respond)",
        _ => "",
    }
}

impl Error {
    /// A job that ended with `status` (an exception status 0E61H–0E6FH carries its code).
    pub(crate) fn failed(job: Job, status: Status) -> Error {
        Error::Failed {
            status,
            job,
            exception: exception_of(status),
        }
    }

    /// A job answered with exception `code`: its STATUS as the RTU master reports it.
    pub(crate) fn exception(job: Job, code: u8) -> Error {
        let status = ExceptionCode::from_u8(code)
            .map_or(crate::status::WRONG_FUNCTION, crate::status::for_exception);
        Error::Failed {
            status,
            job,
            exception: Some(code),
        }
    }

    /// The job's response is not the one its request calls for: the manual's "wrong function
    /// code in the response" (0E51H).
    pub(crate) fn unexpected(job: Job) -> Error {
        Error::failed(job, crate::status::WRONG_FUNCTION)
    }

    /// The STATUS for this error, if it has one.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Refused { reason, .. } => Some(reason.status()),
            Error::Failed { status, .. } => Some(*status),
            Error::Config(e) => Some(e.status),
            _ => None,
        }
    }

    /// The exception code the slave (RTU) or server (TCP) answered with, if the job ended with
    /// an exception.
    pub fn exception_code(&self) -> Option<u8> {
        match self {
            Error::Failed { exception, .. } => *exception,
            _ => None,
        }
    }

    /// The job that failed, where the error belongs to one.
    pub fn job(&self) -> Option<Job> {
        match self {
            Error::Refused { job, .. } | Error::Failed { job, .. } | Error::Decode { job, .. } => {
                Some(*job)
            }
            _ => None,
        }
    }
}

/// The exception code of an exception STATUS (0E60H + code, [Modbus/USS] §3.6).
fn exception_of(status: Status) -> Option<u8> {
    let code = status.code();
    (0x0E61..=0x0E6F)
        .contains(&code)
        .then(|| (code - 0x0E60) as u8)
}

/// A refused request as the module reports it (0E44H–0E46H by function).
pub(crate) fn refused_count(job: Job) -> Error {
    let status = match job.function {
        fc::READ_COILS | fc::READ_DISCRETE_INPUTS => crate::status::BIT_COUNT,
        fc::READ_HOLDING_REGISTERS | fc::READ_INPUT_REGISTERS => crate::status::REGISTER_COUNT,
        _ => crate::status::WRITE_COUNT,
    };
    Error::Refused {
        job,
        reason: RequestError::Invalid(status),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failure_names_unit_function_address_and_exception() {
        let job = Job::of(
            17,
            &Request::ReadHoldingRegisters {
                address: 100,
                quantity: 2,
            },
        );
        let e = Error::failed(job, crate::status::EXCEPTION_ILLEGAL_DATA_ADDRESS);
        assert_eq!(e.exception_code(), Some(2));
        let text = e.to_string();
        assert!(
            text.starts_with("unit 17 FC03 address 100: exception 02 illegal data address"),
            "{text}"
        );
        let gateway = Error::exception(job, 0x0B);
        assert_eq!(gateway.exception_code(), Some(0x0B));
        assert!(
            gateway
                .to_string()
                .ends_with("exception 0BH (gateway target device failed to respond)"),
            "{gateway}"
        );
        let timeout = Error::failed(job, crate::status::RESPONSE_TIMEOUT);
        assert_eq!(timeout.exception_code(), None);
    }
}
