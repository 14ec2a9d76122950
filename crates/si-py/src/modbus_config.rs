//! Modbus configs from keyword arguments, checked with si-modbus's own ranges
//! ([Modbus/USS] §3.4.3, Table 3-17; §3.5.4, Table 3-20).

use crate::errors::range_error;
use crate::options::{narrow, seconds, settings};
use pyo3::prelude::*;
use si_modbus::config::LineConfig;
use si_modbus::{MasterConfig, Mode, SlaveConfig};

/// The line keyword arguments master and slave share.
pub struct LineArgs<'a> {
    /// Bit/s.
    pub baud: i64,
    /// Data bits (Modbus: 8).
    pub data_bits: i64,
    /// Parity name.
    pub parity: &'a str,
    /// Stop bits.
    pub stop_bits: i64,
    /// "normal" or "interference-suppression".
    pub mode: &'a str,
    /// fMUL, 1–10.
    pub char_delay_multiplier: i64,
}

impl LineArgs<'_> {
    fn line(&self) -> PyResult<LineConfig> {
        Ok(LineConfig {
            settings: settings(self.baud, self.data_bits, self.parity, self.stop_bits)?,
            mode: Mode::from_name(self.mode).map_err(|e| range_error(&e.range, Some(e.status)))?,
            char_delay_multiplier: narrow("char_delay_multiplier", self.char_delay_multiplier)?,
            ..LineConfig::default()
        })
    }
}

/// A checked master config.
pub fn master(
    line: &LineArgs<'_>,
    response_timeout: f64,
    retries: i64,
    broadcast_turnaround: f64,
) -> PyResult<MasterConfig> {
    let config = MasterConfig {
        line: line.line()?,
        response_timeout: seconds("response_timeout", response_timeout)?,
        retries: narrow("retries", retries)?,
        broadcast_turnaround: seconds("broadcast_turnaround", broadcast_turnaround)?,
    };
    config
        .validate()
        .map_err(|e| range_error(&e.range, Some(e.status)))?;
    Ok(config)
}

/// A checked slave config.
pub fn slave(line: &LineArgs<'_>, address: i64) -> PyResult<SlaveConfig> {
    let config = SlaveConfig {
        line: line.line()?,
        address: narrow("address", address)?,
    };
    config
        .validate()
        .map_err(|e| range_error(&e.range, Some(e.status)))?;
    Ok(config)
}

/// How received frames end: "gap" (the module's silence, [Modbus/USS] §3.3.5, Table 3-11) or
/// "length" (si-modbus's host extension: at the length the header predicts once the CRC checks).
pub fn frame_end(name: &str) -> PyResult<si_modbus::FrameEnd> {
    match name {
        "gap" => Ok(si_modbus::FrameEnd::Gap),
        "length" => Ok(si_modbus::FrameEnd::Length),
        other => Err(crate::errors::argument_error(
            "frame_end",
            "gap, length",
            other,
        )),
    }
}
