//! A simulator trace as Python records: one dict per entry with `at` (float seconds of
//! virtual time), `station`, `kind` and the entry's fields.

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use si_core::trace::{Trace, TraceKind};

/// The trace as a list of dicts: `kind` "tx" (`bytes`), "rx" (`byte`), "rx_chunk" (`bytes`),
/// "rx_error" (`error`), or another kind with its `text`.
pub fn records<'py>(py: Python<'py>, trace: &Trace) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for entry in &trace.entries {
        let d = PyDict::new(py);
        d.set_item("at", entry.at.as_micros() as f64 / 1e6)?;
        d.set_item("station", &entry.station)?;
        match &entry.kind {
            TraceKind::Tx { bytes } => {
                d.set_item("kind", "tx")?;
                d.set_item("bytes", PyBytes::new(py, bytes))?;
            }
            TraceKind::Rx { byte } => {
                d.set_item("kind", "rx")?;
                d.set_item("byte", byte)?;
            }
            TraceKind::RxChunk { bytes } => {
                d.set_item("kind", "rx_chunk")?;
                d.set_item("bytes", PyBytes::new(py, bytes))?;
            }
            TraceKind::RxError { error } => {
                d.set_item("kind", "rx_error")?;
                d.set_item("error", format!("{error:?}"))?;
            }
            other => {
                d.set_item("kind", "other")?;
                d.set_item("text", format!("{other:?}"))?;
            }
        }
        list.append(d)?;
    }
    Ok(list)
}
