//! The exception tree (minimalmodbus-like, carrying the STATUS of the manuals) and the mapping
//! from each crate's async error onto it.
//!
//! ```text
//! OSError
//! └── SiError                 .status (int or None), .status_text
//!     ├── NoResponseError      the partner did not answer in time
//!     ├── InvalidResponseError an answer that fails the checks (CRC, BCC, length, echo)
//!     ├── ProtocolError        the protocol gave up (NAK, retries exhausted, line stopped)
//!     └── DeviceException      the partner answered with an error (.exception_code, .error_number)
//! ValueError
//! └── ConfigError             a parameter out of range (.status, .parameter, .range, .value)
//! ```
//!
//! The class follows from the error's variant and its STATUS's event class and number, never
//! from its text.

use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use si_core::{RangeError, Status};
use si_modbus::tokio::Error as ModbusError;

create_exception!(
    si_serial,
    SiError,
    PyOSError,
    "A job failed; `.status` is the manual's STATUS word (int, None where the failure has none) and `.status_text` its meaning."
);
create_exception!(
    si_serial,
    NoResponseError,
    SiError,
    "The partner did not answer within the configured time."
);
create_exception!(
    si_serial,
    InvalidResponseError,
    SiError,
    "An answer failed the checks: CRC, BCC, length, byte count or echo."
);
create_exception!(
    si_serial,
    ProtocolError,
    SiError,
    "The protocol gave up: NAK, retries exhausted, the line stopped."
);
create_exception!(
    si_serial,
    DeviceException,
    SiError,
    "The partner answered with an error: `.exception_code` (Modbus) or `.error_number` (USS)."
);
create_exception!(
    si_serial,
    ConfigError,
    PyValueError,
    "A parameter is out of range: `.parameter`, `.range` and `.value` name it; `.status` is the module's parameter-assignment STATUS where it has one."
);

/// Adds the exception classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SiError", py.get_type::<SiError>())?;
    m.add("NoResponseError", py.get_type::<NoResponseError>())?;
    m.add(
        "InvalidResponseError",
        py.get_type::<InvalidResponseError>(),
    )?;
    m.add("ProtocolError", py.get_type::<ProtocolError>())?;
    m.add("DeviceException", py.get_type::<DeviceException>())?;
    m.add("ConfigError", py.get_type::<ConfigError>())?;
    Ok(())
}

/// Sets `name` on the exception instance of `err`.
fn with_attr(err: PyErr, name: &str, value: impl for<'py> IntoPyObject<'py>) -> PyErr {
    Python::attach(|py| {
        // Setting an attribute on a fresh exception instance cannot fail.
        let _ = err.value(py).setattr(name, value);
    });
    err
}

/// The STATUS attributes every si exception carries.
fn with_status(err: PyErr, status: Option<Status>) -> PyErr {
    let text = status.map(|s| {
        s.info()
            .map_or_else(|| s.to_string(), |i| i.meaning.to_owned())
    });
    let err = with_attr(err, "status", status.map(Status::code));
    with_attr(err, "status_text", text)
}

/// A parameter out of range, named with its range and value; `.parameter` is the manual's
/// name, `.keyword` the Python keyword argument that set it (the message starts with it).
pub fn range_error(range: &RangeError, status: Option<Status>) -> PyErr {
    let keyword = keyword_of(range.parameter);
    let err = ConfigError::new_err(format!("{keyword}: {range}"));
    let err = with_attr(err, "keyword", keyword);
    let err = with_attr(err, "parameter", range.parameter);
    let err = with_attr(err, "range", range.range.to_string());
    let err = with_attr(err, "value", range.value.clone());
    with_status(err, status)
}

/// The keyword argument that sets the config field the manual calls `parameter`.
fn keyword_of(parameter: &str) -> &str {
    match parameter {
        "response time" => "response_timeout",
        "character delay multiple" => "char_delay_multiplier",
        "slave address" => "address",
        "operating mode" => "mode",
        "data bits" => "data_bits",
        "character delay time (ZVZ)" => "char_delay",
        "acknowledgement delay time (QVZ)" => "ack_delay",
        "connection attempts" => "connection_attempts",
        "transmission attempts" => "transmission_attempts",
        "maximum block length" => "max_block_len",
        "receive buffer" => "receive_buffer_blocks",
        "response monitoring time (TRES)" => "response_timeout",
        "maximum job length" => "max_job_len",
        "response timeout" => "response_timeout",
        "WDH (PKW repetitions)" => "retries",
        "cycle pause" => "cycle_pause",
        "SANZ (polling list entries)" | "TNU (node number)" | "PZD words" | "net data bytes" => {
            "nodes"
        }
        "character delay time" => "char_delay",
        "end-of-text character 1" | "end-of-text character 2" => "end_chars",
        "length of received frame" => "fixed_length",
        "maximum frame length" => "max_frame_len",
        other => other,
    }
}

/// A keyword argument refused before any config is built (outside its Rust type, not a
/// finite time).
pub fn argument_error(parameter: &str, range: &str, value: impl std::fmt::Display) -> PyErr {
    let err = ConfigError::new_err(format!("{parameter} = {value} is out of range: {range}"));
    let err = with_attr(err, "keyword", parameter.to_owned());
    let err = with_attr(err, "parameter", parameter.to_owned());
    let err = with_attr(err, "range", range.to_owned());
    let err = with_attr(err, "value", value.to_string());
    with_status(err, None)
}

/// The exception for a failed Modbus job (RTU master, TCP client, slave, server).
pub fn modbus(e: ModbusError) -> PyErr {
    let status = e.status();
    let text = e.to_string();
    let err = match &e {
        ModbusError::Config(c) => return range_error(&c.range, Some(c.status)),
        // A job the engine refuses (a quantity out of range, a broadcast of a read) is a bad
        // argument.
        ModbusError::Refused { .. } => ConfigError::new_err(text),
        ModbusError::Failed {
            exception: Some(code),
            ..
        } => with_attr(DeviceException::new_err(text), "exception_code", *code),
        ModbusError::Failed { status, .. } => modbus_failure(*status, text),
        ModbusError::Decode { .. } | ModbusError::Header(_) | ModbusError::Broken => {
            InvalidResponseError::new_err(text)
        }
        ModbusError::Stopped => ProtocolError::new_err(text),
        ModbusError::Io(_) => SiError::new_err(text),
    };
    with_status(err, status)
}

/// Nothing arrived within the `timeout` the caller gave a receive.
pub fn nothing_received(timeout: f64) -> PyErr {
    with_status(
        NoResponseError::new_err(format!("nothing received within {timeout} s")),
        None,
    )
}

/// The exception for a failed 3964(R) job ([ET200S SI] §2.13, Table 2-28): the acknowledgement
/// delay time exceeded (0703H, 0707H) is no response; the other send errors (event class 07H:
/// NAK, conflicts) the protocol giving up; receive errors (class 08H: BCC, character delay,
/// transmission errors) an invalid block.
pub fn p3964r(e: si_3964r::tokio::Error) -> PyErr {
    use si_3964r::status::{END_TIMEOUT, SETUP_TIMEOUT};
    use si_3964r::tokio::Error as E;
    let status = e.status();
    let text = e.to_string();
    let err = match &e {
        E::Config(range) => return range_error(range, None),
        E::Refused(_) => ConfigError::new_err(text),
        E::Failed { status } if *status == SETUP_TIMEOUT || *status == END_TIMEOUT => {
            NoResponseError::new_err(text)
        }
        E::Failed { status } if status.class() == 0x08 => InvalidResponseError::new_err(text),
        E::Failed { .. } | E::Stopped => ProtocolError::new_err(text),
        E::Io(_) => SiError::new_err(text),
    };
    with_status(err, status)
}

/// The exception for a failed ASCII job ([ET200S SI] §2.13, Table 2-28): receive errors (event
/// class 08H: character delay, frame too long, transmission errors) an invalid frame; send
/// errors (class 07H: XON or CTS = ON timed out) the protocol giving up.
pub fn ascii(e: si_ascii::tokio::Error) -> PyErr {
    use si_ascii::config::ConfigError as C;
    use si_ascii::tokio::Error as E;
    let status = e.status();
    let text = e.to_string();
    let err = match &e {
        E::Config(C::OutOfRange(range)) => return range_error(range, status),
        E::Config(C::NotAllowed {
            parameter, value, ..
        }) => {
            let err = with_attr(ConfigError::new_err(text), "keyword", keyword_of(parameter));
            let err = with_attr(err, "parameter", *parameter);
            with_attr(err, "value", value.clone())
        }
        E::Config(C::Settings(_)) | E::Refused(_) => ConfigError::new_err(text),
        E::Failed { status } if status.class() == 0x08 => InvalidResponseError::new_err(text),
        E::Failed { .. } | E::Stopped => ProtocolError::new_err(text),
        E::Io(_) => SiError::new_err(text),
    };
    with_status(err, status)
}

/// The exception for a failed RK 512 job ([CP 341] §2.2.3; [CP 341 Diag] §8.1): no reaction
/// telegram (0A05H) or no acknowledgement of the 3964(R) procedure (0703H, 0707H) is no
/// response; the partner's error numbers (event class 09H) a device exception with
/// `.error_number`; a wrong reaction telegram (class 0AH) or receive error (class 08H) an
/// invalid response; the rest (NAK, refused by the procedure) the protocol giving up.
///
/// `cause` is the 3964(R) STATUS behind 051AH "command telegram not sent" (the station's last
/// cause): it decides the class and is the exception's `.cause`.
pub fn rk512(e: si_rk512::tokio::Error, cause: Option<Status>) -> PyErr {
    use si_3964r::status::{END_TIMEOUT, SETUP_TIMEOUT};
    use si_rk512::status::NO_REACTION;
    use si_rk512::tokio::Error as E;
    let status = e.status();
    if let (Some(cause), E::Failed { .. }) = (cause, &e) {
        let err = p3964r(si_3964r::tokio::Error::Failed { status: cause });
        let err = with_attr(err, "cause", cause.code());
        let err = with_attr(err, "args", (e.to_string(),));
        return with_status(err, status);
    }
    let text = e.to_string();
    let err = match &e {
        E::Config(range) => return range_error(range, None),
        E::Refused(_) => ConfigError::new_err(text),
        E::Failed { status, .. }
            if *status == NO_REACTION || *status == SETUP_TIMEOUT || *status == END_TIMEOUT =>
        {
            NoResponseError::new_err(text)
        }
        E::Failed { status, .. } if status.class() == 0x09 => with_attr(
            DeviceException::new_err(text),
            "error_number",
            status.number(),
        ),
        E::Failed { status, .. } if matches!(status.class(), 0x08 | 0x0A) => {
            InvalidResponseError::new_err(text)
        }
        E::Failed { .. } | E::Stopped => ProtocolError::new_err(text),
        E::Io(_) => SiError::new_err(text),
    };
    with_status(err, status)
}

/// The exception for a failed USS parameter job ([Modbus/USS] §3.8): the drive's PKW error
/// (response ID 7, with `.error_number`) a device exception; no answer (1404H, 1408H) no
/// response; the other telegram checks (event class 14H: BCC, LGE, address, character error)
/// an invalid response; the rest (PKW task errors, class 15H) the protocol giving up.
pub fn uss(e: si_uss::tokio::Error) -> PyErr {
    use si_uss::config::ConfigError as C;
    use si_uss::status::{NO_ANSWER, NO_STX};
    use si_uss::tokio::Error as E;
    let status = e.status();
    let text = e.to_string();
    let err = match &e {
        E::Config(C::OutOfRange(range)) => return range_error(range, None),
        E::Config(C::ConflictingStructure { .. }) | E::Refused(_) => {
            with_attr(ConfigError::new_err(text), "keyword", "nodes")
        }
        E::Failed {
            error_number: Some(n),
            ..
        } => with_attr(DeviceException::new_err(text), "error_number", *n),
        E::Failed { status, .. } if *status == NO_ANSWER || *status == NO_STX => {
            NoResponseError::new_err(text)
        }
        E::Failed { status, .. } if status.class() == 0x14 => InvalidResponseError::new_err(text),
        E::Failed { .. } | E::Stopped => ProtocolError::new_err(text),
        E::Io(_) => SiError::new_err(text),
    };
    with_status(err, status)
}

/// A Modbus master job that ended with `status` and no exception ([Modbus/USS] §3.6): 0830H
/// no response; event class 08H (receive errors: parity, framing, overflow) and the response
/// checks 0E50H–0E57H an invalid response; anything else the protocol giving up.
fn modbus_failure(status: Status, text: String) -> PyErr {
    use si_modbus::status::{RESPONSE_CRC, RESPONSE_TIMEOUT, UNSOLICITED_RESPONSE};
    const RECEIVE_ERROR: u8 = 0x08;
    if status == RESPONSE_TIMEOUT {
        NoResponseError::new_err(text)
    } else if status.class() == RECEIVE_ERROR
        || (UNSOLICITED_RESPONSE.code()..=RESPONSE_CRC.code()).contains(&status.code())
    {
        InvalidResponseError::new_err(text)
    } else {
        ProtocolError::new_err(text)
    }
}
