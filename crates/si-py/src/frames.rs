//! Frame encode/decode for every framed protocol, offline (module functions of `si_serial`):
//! the protocol crates' codecs, their errors as `InvalidResponseError` naming what is wrong
//! and where. (ASCII frames carry no framing of their own: the bytes are the frame.)

use crate::errors::{argument_error, InvalidResponseError};
use crate::options::narrow;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use si_modbus::tokio::Job;

fn invalid(e: impl std::fmt::Display) -> PyErr {
    InvalidResponseError::new_err(e.to_string())
}

fn mode_3964r(block_check: bool) -> si_3964r::Mode {
    if block_check {
        si_3964r::Mode::BlockCheck
    } else {
        si_3964r::Mode::NoBlockCheck
    }
}

/// 3964(R): the block that follows the partner's DLE: `payload` with DLE doubled, DLE ETX and
/// (with `block_check`) the BCC ([ET200S SI] §2.9).
#[pyfunction]
#[pyo3(signature = (payload, block_check=true))]
pub fn encode_3964r<'py>(
    py: Python<'py>,
    payload: &[u8],
    block_check: bool,
) -> Bound<'py, PyBytes> {
    PyBytes::new(
        py,
        &si_3964r::frame::encode(payload, mode_3964r(block_check)),
    )
}

/// 3964(R): the payload of a block (after DLE, up to DLE ETX and BCC); InvalidResponseError
/// for a wrong BCC, an odd DLE or a block longer than `max_len`.
#[pyfunction]
#[pyo3(signature = (block, block_check=true, max_len=1024))]
pub fn decode_3964r<'py>(
    py: Python<'py>,
    block: &[u8],
    block_check: bool,
    max_len: usize,
) -> PyResult<Bound<'py, PyBytes>> {
    let payload =
        si_3964r::frame::decode(block, mode_3964r(block_check), max_len).map_err(invalid)?;
    Ok(PyBytes::new(py, &payload))
}

/// Modbus RTU: the ADU of `unit` and `pdu` (function code and data), CRC appended low byte
/// first ([Modbus/USS] §3.3.1, Table 3-9).
#[pyfunction]
pub fn encode_modbus<'py>(py: Python<'py>, unit: i64, pdu: &[u8]) -> PyResult<Bound<'py, PyBytes>> {
    if pdu.is_empty() || pdu.len() > si_modbus::frame::MAX_ADU - 3 {
        return Err(argument_error(
            "pdu",
            &format!("1 … {} bytes", si_modbus::frame::MAX_ADU - 3),
            pdu.len(),
        ));
    }
    let mut adu = vec![narrow::<u8>("unit", unit)?];
    adu.extend_from_slice(pdu);
    let crc = si_modbus::frame::crc16(&adu);
    adu.extend(crc.to_le_bytes());
    Ok(PyBytes::new(py, &adu))
}

/// Modbus RTU: a request ADU checked as the slave driver checks it ([Modbus/USS]
/// §3.5.6–§3.5.14): a dict of `unit`, `function`, `address` (None for FC07/08/11/12) and
/// `pdu`; InvalidResponseError naming the offset and what was expected.
#[pyfunction]
pub fn decode_modbus_request<'py>(py: Python<'py>, adu: &[u8]) -> PyResult<Bound<'py, PyDict>> {
    let (unit, request) = si_modbus::frame::decode_request(adu).map_err(invalid)?;
    let job = Job::of(unit, &request);
    let d = PyDict::new(py);
    d.set_item("unit", unit)?;
    d.set_item("function", job.function)?;
    d.set_item("address", job.address)?;
    d.set_item("pdu", PyBytes::new(py, &adu[1..adu.len() - 2]))?;
    d.set_item("text", format!("{request:?}"))?;
    Ok(d)
}

/// Modbus RTU: a response ADU checked (length, CRC, byte counts): a dict of `unit`,
/// `function` (with 80H set for an exception), `pdu` and `text`.
#[pyfunction]
pub fn decode_modbus_response<'py>(py: Python<'py>, adu: &[u8]) -> PyResult<Bound<'py, PyDict>> {
    let (unit, response) = si_modbus::frame::decode_response(adu).map_err(invalid)?;
    let d = PyDict::new(py);
    d.set_item("unit", unit)?;
    d.set_item("function", adu[1])?;
    d.set_item("pdu", PyBytes::new(py, &adu[1..adu.len() - 2]))?;
    d.set_item("text", format!("{response:?}"))?;
    Ok(d)
}

/// USS: the telegram STX LGE ADR net BCC for node address byte `adr` and `net` (PKW then
/// PZD, at most 252 bytes) ([Modbus/USS] §3.8).
#[pyfunction]
pub fn encode_uss<'py>(py: Python<'py>, adr: i64, net: &[u8]) -> PyResult<Bound<'py, PyBytes>> {
    let mut out = [0u8; si_uss::frame::MAX_TELEGRAM];
    let n = si_uss::frame::encode(si_uss::frame::Adr(narrow("adr", adr)?), net, &mut out)
        .map_err(|e| argument_error("net", &e.to_string(), net.len()))?;
    Ok(PyBytes::new(py, &out[..n]))
}

/// USS: a telegram checked (STX, LGE, BCC) and taken apart: `(adr, net)`.
#[pyfunction]
pub fn decode_uss<'py>(py: Python<'py>, telegram: &[u8]) -> PyResult<(u8, Bound<'py, PyBytes>)> {
    let t = si_uss::frame::decode(telegram).map_err(invalid)?;
    Ok((t.adr.0, PyBytes::new(py, t.net)))
}

/// RK 512: a command, continuation or reaction telegram (the 3964(R) payload) taken apart
/// ([CP 341] §2.2.3): a dict of `kind` ("command", "continuation", "reaction"), `header`
/// (its fields as text) and `data`.
#[pyfunction]
pub fn decode_rk512<'py>(py: Python<'py>, telegram: &[u8]) -> PyResult<Bound<'py, PyDict>> {
    use si_rk512::frame::Telegram;
    let t = Telegram::decode(telegram).map_err(invalid)?;
    let d = PyDict::new(py);
    let (kind, header, data) = match t {
        Telegram::Command(h, data) => ("command", format!("{h:?}"), data),
        Telegram::Continuation(h, data) => ("continuation", format!("{h:?}"), data),
        Telegram::Reaction(h, data) => {
            d.set_item("error_number", h.error)?;
            ("reaction", format!("{h:?}"), data)
        }
    };
    d.set_item("kind", kind)?;
    d.set_item("header", header)?;
    d.set_item("data", PyBytes::new(py, data))?;
    Ok(d)
}

/// Adds the functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(encode_3964r, m)?)?;
    m.add_function(wrap_pyfunction!(decode_3964r, m)?)?;
    m.add_function(wrap_pyfunction!(encode_modbus, m)?)?;
    m.add_function(wrap_pyfunction!(decode_modbus_request, m)?)?;
    m.add_function(wrap_pyfunction!(decode_modbus_response, m)?)?;
    m.add_function(wrap_pyfunction!(encode_uss, m)?)?;
    m.add_function(wrap_pyfunction!(decode_uss, m)?)?;
    m.add_function(wrap_pyfunction!(decode_rk512, m)?)?;
    Ok(())
}
