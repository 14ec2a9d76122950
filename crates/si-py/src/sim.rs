//! `si_serial.Simulator`: si-sim's deterministic line simulator with the protocol engines as
//! stations, in virtual time. A job call steps the simulation until that job's event, so it
//! returns at once in real time; `now` tells the virtual time it took.

use crate::errors::{
    argument_error, ascii, modbus, nothing_received, p3964r, range_error, rk512, uss,
};
use crate::options::{narrow, seconds, settings};
use crate::sim_trace::records;
use crate::store::SharedStore;
use crate::store_class::{area, ModbusStore};
use bytes::Bytes;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyList};
use si_core::{Duration, Instant, SerialSettings, Status};
use si_modbus::frame::{Registers, Request, Response};
use si_modbus::tokio::Job;
use si_modbus::{MasterConfig, MasterEvent, SlaveConfig};
use si_rk512::frame::{Address, Coordination};
use si_sim::{Simulator as Sim, StationId};

/// One station: its engine type, so its events and engine come back typed.
#[derive(Clone, Copy)]
enum Station {
    ModbusMaster(StationId<si_modbus::Master>),
    ModbusSlave(StationId<si_modbus::Slave<SharedStore>>),
    Link3964R(StationId<si_3964r::Link>),
    Ascii(StationId<si_ascii::Link>),
    Rk512(StationId<si_rk512::Station>),
    UssMaster(StationId<si_uss::master::Master>),
    UssDrive(StationId<si_uss::drive::Drive>),
}

/// Runs `$body` with `$id` bound to the typed station id `$station` holds.
macro_rules! on_station {
    ($station:expr, $id:ident => $body:expr) => {
        match $station {
            Station::ModbusMaster($id) => $body,
            Station::ModbusSlave($id) => $body,
            Station::Link3964R($id) => $body,
            Station::Ascii($id) => $body,
            Station::Rk512($id) => $body,
            Station::UssMaster($id) => $body,
            Station::UssDrive($id) => $body,
        }
    };
}

/// The deterministic line simulator ([`si_sim`]): add stations, `connect` two of them (or
/// put several on a `bus`), run jobs, `run_for` a span of virtual time, read the `trace`.
/// Station methods return the station's number.
#[pyclass(unsendable, module = "si_serial")]
pub struct Simulator {
    sim: Sim,
    stations: Vec<Station>,
    /// The longest a job may take in virtual time before it is given up.
    limit: Duration,
}

impl Simulator {
    fn station(&self, n: usize) -> PyResult<Station> {
        self.stations.get(n).copied().ok_or_else(|| {
            argument_error(
                "station",
                &format!("0 … {}", self.stations.len().saturating_sub(1)),
                n,
            )
        })
    }

    fn wrong_kind(n: usize, wanted: &str) -> PyErr {
        argument_error("station", wanted, n)
    }

    fn add(&mut self, station: Station) -> usize {
        self.stations.push(station);
        self.stations.len() - 1
    }

    /// Steps until `done` finds the outcome in the events `take` drains, or the line is
    /// quiet, or `limit` of virtual time has passed (None then).
    fn run_until<T>(&mut self, mut take: impl FnMut(&mut Sim) -> Option<T>) -> Option<T> {
        let end = self.sim.now() + self.limit;
        loop {
            if let Some(found) = take(&mut self.sim) {
                return Some(found);
            }
            if self.sim.now() >= end || !self.sim.step() {
                return take(&mut self.sim);
            }
        }
    }

    fn modbus_job(
        &mut self,
        n: usize,
        unit: u8,
        request: &Request<'_>,
    ) -> PyResult<Option<Vec<u16>>> {
        let Station::ModbusMaster(id) = self.station(n)? else {
            return Err(Self::wrong_kind(n, "a Modbus master station"));
        };
        let job = Job::of(unit, request);
        self.sim
            .with(id, |m, now| m.request(now, unit, request))
            .map_err(|reason| modbus(si_modbus::tokio::Error::Refused { job, reason }))?;
        let outcome = self.run_until(|sim| {
            sim.take_events(id).into_iter().find_map(|e| match e {
                MasterEvent::Completed(c) => Some(Ok(match c.response() {
                    Some(Response::ReadHoldingRegisters(w))
                    | Some(Response::ReadInputRegisters(w)) => Some(w.iter().collect()),
                    _ => None,
                })),
                MasterEvent::Failed { status, .. } => Some(Err(status)),
                MasterEvent::Diagnostic(_) => None,
            })
        });
        match outcome {
            Some(Ok(words)) => Ok(words),
            Some(Err(status)) => Err(modbus(si_modbus::tokio::Error::Failed {
                status,
                job,
                exception: exception_of(status),
            })),
            None => Err(nothing_received(self.limit.as_micros() as f64 / 1e6)),
        }
    }
}

/// The exception code an exception STATUS (0E61H … 0E6FH) carries ([Modbus/USS] §3.6).
fn exception_of(status: Status) -> Option<u8> {
    let code = status.code();
    (0x0E61..=0x0E6F)
        .contains(&code)
        .then(|| (code & 0xFF) as u8 - 0x60)
}

/// The 3964(R) config of a simulated station from its keyword arguments.
fn r3964_config(priority: &str, settings: SerialSettings) -> PyResult<si_3964r::Config> {
    crate::link3964r::link_config(priority, true, 0.22, None, 6, 6, 200, 5, settings)
}

#[pymethods]
impl Simulator {
    /// A simulator whose random faults follow `seed`; `trace` records every character.
    /// `job_limit`: the virtual time a job may take before it is given up.
    #[new]
    #[pyo3(signature = (seed=1, *, trace=true, job_limit=60.0))]
    fn new(seed: u64, trace: bool, job_limit: f64) -> PyResult<Self> {
        let sim = Sim::new(seed);
        Ok(Simulator {
            sim: if trace { sim } else { sim.without_trace() },
            stations: Vec::new(),
            limit: seconds("job_limit", job_limit)?,
        })
    }

    /// Virtual time in seconds.
    #[getter]
    fn now(&self) -> f64 {
        self.sim.now().as_micros() as f64 / 1e6
    }

    /// Wires two stations point to point, full duplex (null modem).
    fn connect(&mut self, a: usize, b: usize) -> PyResult<()> {
        let (sa, sb) = (self.station(a)?, self.station(b)?);
        let sim = &mut self.sim;
        on_station!(sa, ia => on_station!(sb, ib => sim.connect(ia, ib)));
        Ok(())
    }

    /// Puts `stations` on one shared half-duplex RS-485 bus (a USS master and its drives).
    fn bus(&mut self, stations: Vec<usize>) -> PyResult<()> {
        let members = stations
            .into_iter()
            .map(|n| Ok(on_station!(self.station(n)?, id => id.index())))
            .collect::<PyResult<Vec<_>>>()?;
        self.sim.bus(&members);
        Ok(())
    }

    /// Runs `span` seconds of virtual time.
    fn run_for(&mut self, span: f64) -> PyResult<()> {
        self.sim.run_for(seconds("span", span)?);
        Ok(())
    }

    /// The trace so far, one dict per entry (`at`, `station`, `kind`, …).
    fn trace<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        records(py, self.sim.trace())
    }

    /// Writes the trace as a trace file (JSON lines, what `si monitor` and `monitor_trace`
    /// read).
    fn write_trace(&self, path: &str) -> PyResult<()> {
        let file = std::fs::File::create(path)
            .map_err(|e| crate::errors::SiError::new_err(format!("{path}: {e}")))?;
        let header = si_core::tracefile::Header::new("si_serial.Simulator");
        si_core::tracefile::write(std::io::BufWriter::new(file), &header, self.sim.trace())
            .map_err(|e| crate::errors::SiError::new_err(format!("{path}: {e}")))
    }

    /// Adds a Modbus RTU master ([Modbus/USS] §3.4.3, Table 3-17).
    #[pyo3(signature = (name, *, response_timeout=2.0, retries=0, baud=9600))]
    fn add_modbus_master(
        &mut self,
        name: &str,
        response_timeout: f64,
        retries: i64,
        baud: i64,
    ) -> PyResult<usize> {
        let mut config = MasterConfig {
            response_timeout: seconds("response_timeout", response_timeout)?,
            retries: narrow("retries", retries)?,
            ..MasterConfig::default()
        };
        config.line.settings = settings(baud, 8, "even", 1)?;
        let master =
            si_modbus::Master::new(config).map_err(|e| range_error(&e.range, Some(e.status)))?;
        let id = self.sim.add_station(name, config.line.settings, master);
        Ok(self.add(Station::ModbusMaster(id)))
    }

    /// Adds a Modbus RTU slave at `address` serving `store` (default: plain tables).
    #[pyo3(signature = (name, *, address=1, store=None, baud=9600))]
    fn add_modbus_slave(
        &mut self,
        py: Python<'_>,
        name: &str,
        address: i64,
        store: Option<Py<ModbusStore>>,
        baud: i64,
    ) -> PyResult<usize> {
        let mut config = SlaveConfig {
            address: narrow("address", address)?,
            ..SlaveConfig::default()
        };
        config.line.settings = settings(baud, 8, "even", 1)?;
        let store = match store {
            Some(s) => s,
            None => Py::new(py, ModbusStore::new(10000, 10000, 10000, 10000)?)?,
        };
        let slave = si_modbus::Slave::new(config, store.get().shared.clone())
            .map_err(|e| range_error(&e.range, Some(e.status)))?;
        let id = self.sim.add_station(name, config.line.settings, slave);
        Ok(self.add(Station::ModbusSlave(id)))
    }

    /// Adds a 3964(R) link ([ET200S SI] §2.9, Table 2-11) with the manual's defaults.
    #[pyo3(signature = (name, *, priority="low", baud=9600))]
    fn add_3964r(&mut self, name: &str, priority: &str, baud: i64) -> PyResult<usize> {
        let line = settings(baud, 8, "even", 1)?;
        let link = si_3964r::Link::new(r3964_config(priority, line)?.with_settings(line))
            .map_err(|e| range_error(&e, None))?;
        let id = self.sim.add_station(name, line, link);
        Ok(self.add(Station::Link3964R(id)))
    }

    /// Adds an ASCII link ([ET200S SI] §2.8, Table 2-10) whose frames end with `end_char`
    /// (None: by the character delay time).
    #[pyo3(signature = (name, *, end_char=None, baud=9600))]
    fn add_ascii(&mut self, name: &str, end_char: Option<i64>, baud: i64) -> PyResult<usize> {
        let line = settings(baud, 8, "even", 1)?;
        let config = si_ascii::Config {
            settings: line,
            end: match end_char {
                Some(c) => si_ascii::config::EndCriterion::EndChars {
                    first: narrow("end_char", c)?,
                    second: 0,
                },
                None => si_ascii::config::EndCriterion::CharDelay,
            },
            ..si_ascii::Config::default()
        };
        let link = si_ascii::Link::new(config).map_err(|e| ascii(e.into()))?;
        let id = self.sim.add_station(name, line, link);
        Ok(self.add(Station::Ascii(id)))
    }

    /// Adds an RK 512 station; with `dbs` ({number: bytes}) it also serves the partner's jobs
    /// from its own memory.
    #[pyo3(signature = (name, *, priority="low", dbs=None, baud=9600))]
    fn add_rk512(
        &mut self,
        name: &str,
        priority: &str,
        dbs: Option<std::collections::BTreeMap<u16, u32>>,
        baud: i64,
    ) -> PyResult<usize> {
        let line = settings(baud, 8, "even", 1)?;
        let config = si_rk512::Config {
            link: r3964_config(priority, line)?,
            ..si_rk512::Config::default()
        };
        let station = match dbs {
            Some(dbs) => {
                let mut server = si_rk512::passive::ServerConfig::default();
                server.memory.dbs = dbs;
                si_rk512::Station::serving(config.with_settings(line), &server)
            }
            None => si_rk512::Station::new(config.with_settings(line)),
        }
        .map_err(|e| range_error(&e, None))?;
        let id = self.sim.add_station(name, line, station);
        Ok(self.add(Station::Rk512(id)))
    }

    /// Adds a USS master polling `nodes` (`(address, pkw_words, pzd_words)`), started.
    /// `local_echo`: drop what it hears of its own sending (on a `bus`).
    #[pyo3(signature = (name, nodes, *, baud=9600, local_echo=false))]
    fn add_uss_master(
        &mut self,
        name: &str,
        nodes: Vec<(u8, u8, u8)>,
        baud: i64,
        local_echo: bool,
    ) -> PyResult<usize> {
        let line = si_uss::config::uss_settings(narrow("baud", baud)?)
            .map_err(|e| crate::options::settings_error(&e))?;
        let list = nodes
            .into_iter()
            .map(|(a, pkw, pzd)| {
                let pkw = match pkw {
                    0 => si_uss::frame::PkwWords::None,
                    3 => si_uss::frame::PkwWords::Three,
                    127 => si_uss::frame::PkwWords::Variable,
                    _ => si_uss::frame::PkwWords::Four,
                };
                si_uss::config::PollEntry::new(a, pkw, pzd)
            })
            .collect();
        let config = si_uss::config::MasterConfig {
            settings: line,
            local_echo,
            ..si_uss::config::MasterConfig::new(list)
        };
        let master = si_uss::master::Master::new(config).map_err(|e| uss(e.into()))?;
        let id = self.sim.add_station(name, line, master);
        self.sim.with(id, |m, now| m.start(now));
        Ok(self.add(Station::UssMaster(id)))
    }

    /// Adds a simulated USS drive at `address` (PKW 4, PZD 2, the parameters of si-uss's
    /// `DriveConfig::new`: P700, P1082, P2010, P964, P2000, P1120, P20001).
    #[pyo3(signature = (name, *, address=1, baud=9600, local_echo=false))]
    fn add_uss_drive(
        &mut self,
        name: &str,
        address: i64,
        baud: i64,
        local_echo: bool,
    ) -> PyResult<usize> {
        let line = si_uss::config::uss_settings(narrow("baud", baud)?)
            .map_err(|e| crate::options::settings_error(&e))?;
        let config = si_uss::drive::DriveConfig {
            local_echo,
            ..si_uss::drive::DriveConfig::new(line, narrow("address", address)?)
        };
        let drive = si_uss::drive::Drive::new(config).map_err(|e| uss(e.into()))?;
        let id = self.sim.add_station(name, line, drive);
        Ok(self.add(Station::UssDrive(id)))
    }

    /// Modbus master `station`: FC03, `count` registers from `address` of `unit`.
    #[pyo3(signature = (station, address, count, unit=1))]
    fn read_holding_registers(
        &mut self,
        station: usize,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Vec<u16>> {
        let request = Request::ReadHoldingRegisters {
            address: narrow("address", address)?,
            quantity: narrow("count", count)?,
        };
        Ok(self
            .modbus_job(station, narrow("unit", unit)?, &request)?
            .unwrap_or_default())
    }

    /// Modbus master `station`: FC16, `values` from `address` of `unit`.
    #[pyo3(signature = (station, address, values, unit=1))]
    fn write_multiple_registers(
        &mut self,
        station: usize,
        address: i64,
        values: Vec<u16>,
        unit: i64,
    ) -> PyResult<()> {
        let request = Request::WriteMultipleRegisters {
            address: narrow("address", address)?,
            values: Registers::Words(&values),
        };
        self.modbus_job(station, narrow("unit", unit)?, &request)
            .map(|_| ())
    }

    /// 3964(R) or ASCII `station`: sends `data` and runs until it is acknowledged (3964(R)) or
    /// on the line (ASCII).
    fn send(&mut self, station: usize, data: Vec<u8>) -> PyResult<()> {
        let data = Bytes::from(data);
        match self.station(station)? {
            Station::Link3964R(id) => {
                let job = self
                    .sim
                    .with(id, |l, now| l.send(now, data))
                    .map_err(|e| p3964r(si_3964r::tokio::Error::Refused(e)))?;
                let outcome = self.run_until(|sim| {
                    sim.take_events(id).into_iter().find_map(|e| match e {
                        si_3964r::Event::Sent { job: j } if j == job => Some(Ok(())),
                        si_3964r::Event::SendFailed { job: j, status } if j == job => {
                            Some(Err(status))
                        }
                        _ => None,
                    })
                });
                match outcome {
                    Some(r) => {
                        r.map_err(|status| p3964r(si_3964r::tokio::Error::Failed { status }))
                    }
                    None => Err(nothing_received(self.limit.as_micros() as f64 / 1e6)),
                }
            }
            Station::Ascii(id) => {
                let job = self
                    .sim
                    .with(id, |l, now| l.send(now, data))
                    .map_err(|e| ascii(si_ascii::tokio::Error::Refused(e.into())))?;
                let outcome = self.run_until(|sim| {
                    sim.take_events(id).into_iter().find_map(|e| match e {
                        si_ascii::Event::Sent { job: j, .. } if j == job => Some(Ok(())),
                        si_ascii::Event::SendFailed { job: j, status, .. } if j == job => {
                            Some(Err(status))
                        }
                        _ => None,
                    })
                });
                match outcome {
                    Some(r) => r.map_err(|status| ascii(si_ascii::tokio::Error::Failed { status })),
                    None => Err(nothing_received(self.limit.as_micros() as f64 / 1e6)),
                }
            }
            _ => Err(Self::wrong_kind(station, "a 3964(R) or ASCII station")),
        }
    }

    /// 3964(R) or ASCII `station`: the next block or frame received, running up to `timeout`
    /// seconds of virtual time; NoResponseError if none came.
    #[pyo3(signature = (station, timeout=10.0))]
    fn recv<'py>(
        &mut self,
        py: Python<'py>,
        station: usize,
        timeout: f64,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let end = self.sim.now() + seconds("timeout", timeout)?;
        let kind = self.station(station)?;
        loop {
            let got = match kind {
                Station::Link3964R(id) => self.sim.with(id, |l, now| l.take_block(now)),
                Station::Ascii(id) => self.sim.with(id, |l, now| l.read_frame_bytes(now)),
                _ => return Err(Self::wrong_kind(station, "a 3964(R) or ASCII station")),
            };
            if let Some(data) = got {
                return Ok(PyBytes::new(py, &data));
            }
            if self.sim.now() >= end || !self.sim.step() {
                return Err(nothing_received(timeout));
            }
        }
    }

    /// RK 512 `station`: SEND `data` into the partner's `area` from `start`.
    fn rk512_send(
        &mut self,
        station: usize,
        area: &str,
        start: i64,
        data: Vec<u8>,
    ) -> PyResult<()> {
        let at = rk512_address(area, start)?;
        self.rk512_job(station, at, |s, now| {
            s.send(now, at, Coordination::NONE, data)
        })
        .map(|_| ())
    }

    /// RK 512 `station`: FETCH `length` bytes from the partner's `area` from `start`.
    fn rk512_fetch<'py>(
        &mut self,
        py: Python<'py>,
        station: usize,
        area: &str,
        start: i64,
        length: usize,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let at = rk512_address(area, start)?;
        let data = self.rk512_job(station, at, |s, now| {
            s.fetch(now, at, Coordination::NONE, length)
        })?;
        Ok(PyBytes::new(py, &data))
    }

    /// `count` bytes of an RK 512 serving station's own memory.
    fn read_memory<'py>(
        &self,
        py: Python<'py>,
        station: usize,
        area_name: &str,
        start: u32,
        count: usize,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let Station::Rk512(id) = self.station(station)? else {
            return Err(Self::wrong_kind(station, "an RK 512 station"));
        };
        let mut out = vec![0; count];
        self.sim
            .engine(id)
            .server()
            .memory()
            .read(area(area_name)?, start, &mut out)
            .map_err(|e| argument_error("start", &e.to_string(), start))?;
        Ok(PyBytes::new(py, &out))
    }

    /// USS master `station`: reads parameter `number` of `node`.
    #[pyo3(signature = (station, node, number, index=0))]
    fn read_parameter(
        &mut self,
        station: usize,
        node: u8,
        number: u16,
        index: u8,
    ) -> PyResult<u32> {
        let Station::UssMaster(id) = self.station(station)? else {
            return Err(Self::wrong_kind(station, "a USS master station"));
        };
        let request = si_uss::master::ParamRequest::read(number, index);
        let job = self
            .sim
            .with(id, |m, now| m.request_parameter(now, node, request))
            .map_err(|e| uss(si_uss::tokio::Error::Refused(e)))?;
        let outcome = self.run_until(|sim| {
            sim.take_events(id).into_iter().find_map(|e| match e {
                si_uss::master::Event::ParameterDone {
                    job: j, response, ..
                } if j == job => Some(Ok(response.value())),
                si_uss::master::Event::ParameterFailed {
                    job: j,
                    status,
                    error_number,
                    ..
                } if j == job => Some(Err((status, error_number))),
                _ => None,
            })
        });
        match outcome {
            Some(Ok(value)) => Ok(value),
            Some(Err((status, error_number))) => Err(uss(si_uss::tokio::Error::Failed {
                status,
                error_number,
                address: node,
                number,
            })),
            None => Err(nothing_received(self.limit.as_micros() as f64 / 1e6)),
        }
    }
}

impl Simulator {
    fn rk512_job(
        &mut self,
        station: usize,
        at: Address,
        start: impl FnOnce(
            &mut si_rk512::Station,
            Instant,
        ) -> Result<si_rk512::JobId, si_rk512::station::RequestError>,
    ) -> PyResult<Bytes> {
        let Station::Rk512(id) = self.station(station)? else {
            return Err(Self::wrong_kind(station, "an RK 512 station"));
        };
        let job = self
            .sim
            .with(id, start)
            .map_err(|e| rk512(si_rk512::tokio::Error::Refused(e), None))?;
        let outcome = self.run_until(|sim| {
            sim.take_events(id).into_iter().find_map(|e| match e {
                si_rk512::Event::Done { job: j, data } if j == job => Some(Ok(data)),
                si_rk512::Event::Failed { job: j, status } if j == job => Some(Err(status)),
                _ => None,
            })
        });
        match outcome {
            Some(r) => r.map_err(|status| {
                let cause = self.sim.engine(id).last_cause();
                rk512(
                    si_rk512::tokio::Error::Failed {
                        status,
                        address: at,
                    },
                    cause.filter(|_| status == si_rk512::status::COMMAND_NOT_SENT),
                )
            }),
            None => Err(nothing_received(self.limit.as_micros() as f64 / 1e6)),
        }
    }
}

/// The RK 512 address of `area` and `start` (see `Rk512Station`).
fn rk512_address(area: &str, start: i64) -> PyResult<Address> {
    crate::rk512::address(area, start)
}
