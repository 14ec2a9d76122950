//! `si_serial.Monitor` and `monitor_trace`: the protocol crates' passive monitors over the
//! bytes of a line (live, as a port reads them) or over a trace file. Records come back as
//! dicts: `start`, `end` (seconds), `from` (station name), `kind`, `label`, `text`, `bytes`,
//! `flags` ("!! fault" or "-- remark").

use crate::errors::{argument_error, SiError};
use crate::options::{seconds, settings};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use si_core::monitor::{decode_all, Decoder, LineChar, Record};
use si_core::{Instant, SerialSettings};

/// The monitor of `protocol` ("3964r", "3964", "rk512", "modbus", "uss", "ascii") for a line
/// of `line` settings, with each crate's default timers; ASCII frames end at `end_char`
/// (None: by the character delay time).
fn decoder(
    protocol: &str,
    line: SerialSettings,
    end_char: Option<u8>,
) -> PyResult<Box<dyn Decoder>> {
    Ok(match protocol {
        "3964r" | "3964" | "rk512" => {
            let link = if protocol == "3964" {
                si_3964r::Config::without_block_check()
            } else {
                si_3964r::Config::default()
            };
            let p = if protocol == "rk512" {
                si_rk512::monitor::params(&link, line)
            } else {
                si_3964r::monitor::Params::from_config(&link, line)
            };
            Box::new(si_3964r::monitor::Monitor::new(p))
        }
        "modbus" => {
            let mut master = si_modbus::MasterConfig::default();
            master.line.settings = line;
            Box::new(si_modbus::monitor::Monitor::new(
                si_modbus::monitor::Params::from_config(&master),
                false,
            ))
        }
        "uss" => Box::new(si_uss::monitor::Monitor::new(line, false)),
        "ascii" => {
            let config = si_ascii::Config {
                settings: line,
                end: match end_char {
                    Some(first) => si_ascii::config::EndCriterion::EndChars { first, second: 0 },
                    None => si_ascii::config::EndCriterion::CharDelay,
                },
                char_delay: si_ascii::config::min_char_delay(line.baud()),
                ..si_ascii::Config::default()
            };
            Box::new(si_ascii::monitor::Monitor::new(
                si_ascii::monitor::Params::from_config(&config),
            ))
        }
        other => {
            return Err(argument_error(
                "protocol",
                "3964r, 3964, rk512, modbus, uss, ascii",
                other,
            ))
        }
    })
}

fn secs(at: Instant) -> f64 {
    at.as_micros() as f64 / 1e6
}

fn record_dict<'py>(
    py: Python<'py>,
    r: &Record,
    stations: &[String],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("start", secs(r.start))?;
    d.set_item("end", secs(r.end))?;
    d.set_item("from", r.from.and_then(|i| stations.get(i)))?;
    d.set_item("kind", format!("{:?}", r.kind).to_lowercase())?;
    d.set_item("label", &r.label)?;
    d.set_item("text", &r.text)?;
    d.set_item("bytes", PyBytes::new(py, &r.bytes))?;
    d.set_item(
        "flags",
        r.flags.iter().map(|f| f.to_string()).collect::<Vec<_>>(),
    )?;
    Ok(d)
}

fn record_list<'py>(
    py: Python<'py>,
    records: &[Record],
    stations: &[String],
) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for r in records {
        list.append(record_dict(py, r, stations)?)?;
    }
    Ok(list)
}

/// The records of a trace file (`si --record`, the tokio driver's recorder, the simulator's
/// `write_trace`) decoded as `protocol`.
#[pyfunction]
#[pyo3(signature = (path, protocol, *, baud=9600, data_bits=8, parity="even", stop_bits=1, end_char=None))]
#[allow(clippy::too_many_arguments)]
pub fn monitor_trace<'py>(
    py: Python<'py>,
    path: &str,
    protocol: &str,
    baud: i64,
    data_bits: i64,
    parity: &str,
    stop_bits: i64,
    end_char: Option<u8>,
) -> PyResult<Bound<'py, PyList>> {
    let line = settings(baud, data_bits, parity, stop_bits)?;
    let mut decoder = decoder(protocol, line, end_char)?;
    let file = std::fs::File::open(path).map_err(|e| SiError::new_err(format!("{path}: {e}")))?;
    let trace = si_core::tracefile::read(std::io::BufReader::new(file))
        .map_err(|e| SiError::new_err(format!("{path}: {e}")))?;
    let view = si_core::monitor::line::from_trace(&trace, line);
    let end = view.chars.last().map_or(Instant::ZERO, |c| c.at) + line.chars_time(64);
    let records = decode_all(decoder.as_mut(), &view.chars, end);
    record_list(py, &records, &view.stations)
}

/// A live monitor: `push` the bytes a port read (with the time they arrived and, where
/// known, which of `stations` sent them) and take the records each completes.
#[pyclass(unsendable, module = "si_serial")]
pub struct Monitor {
    decoder: Box<dyn Decoder>,
    line: SerialSettings,
    stations: Vec<String>,
}

#[pymethods]
impl Monitor {
    #[new]
    #[pyo3(signature = (protocol, *, stations=vec![], baud=9600, data_bits=8, parity="even", stop_bits=1, end_char=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        protocol: &str,
        stations: Vec<String>,
        baud: i64,
        data_bits: i64,
        parity: &str,
        stop_bits: i64,
        end_char: Option<u8>,
    ) -> PyResult<Self> {
        let line = settings(baud, data_bits, parity, stop_bits)?;
        Ok(Monitor {
            decoder: decoder(protocol, line, end_char)?,
            line,
            stations,
        })
    }

    /// `data` arrived at `at` seconds (the last byte's end; the others are placed a character
    /// time apart before it, their gaps not judged), sent by station number `station`.
    #[pyo3(signature = (data, at, station=None))]
    fn push<'py>(
        &mut self,
        py: Python<'py>,
        data: &[u8],
        at: f64,
        station: Option<usize>,
    ) -> PyResult<Bound<'py, PyList>> {
        let end = Instant::ZERO + seconds("at", at)?;
        let n = data.len() as u64;
        let mut out = Vec::new();
        for (k, &byte) in data.iter().enumerate() {
            let before = self.line.chars_time(n - 1 - k as u64);
            let c = LineChar {
                at: Instant::from_micros(end.as_micros().saturating_sub(before.as_micros())),
                from: station,
                to: None,
                item: Ok(byte),
                exact: k == 0,
            };
            self.decoder.push(&c, &mut out);
        }
        record_list(py, &out, &self.stations)
    }

    /// The line was quiet until `now` seconds: the records of what is overdue.
    fn idle<'py>(&mut self, py: Python<'py>, now: f64) -> PyResult<Bound<'py, PyList>> {
        let mut out = Vec::new();
        self.decoder
            .idle(Instant::ZERO + seconds("now", now)?, &mut out);
        record_list(py, &out, &self.stations)
    }

    /// The monitor's counters (frames, errors, … by name).
    fn counters(&self) -> std::collections::BTreeMap<String, u64> {
        self.decoder
            .counters()
            .0
            .iter()
            .map(|(k, v)| ((*k).to_owned(), *v))
            .collect()
    }
}
