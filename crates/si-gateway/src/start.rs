//! Starting the lines: each line's engine built from its configuration, its port opened
//! ([`crate::open`]) and its task spawned, watched for its port closing ([`crate::reopen`]).

use crate::backend::{Backend, QueuedLine};
use crate::config::{Config, Kind, Line};
use crate::counters::Stats;
use crate::event::Events;
use crate::open::{self, Opening};
use crate::reopen;
use crate::rk512_config::{Rk512Line, Role};
use crate::uss_config::UssLine;
use crate::{line, r3964, rk512, rk512_own, tcp_line, uss, Error};
use si_modbus::config::LineConfig;
use si_modbus::{MasterConfig, Mode};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::task::AbortHandle;

/// The started lines.
pub struct Started {
    /// The counters the lines share with the router.
    pub stats: Arc<Mutex<Stats>>,
    /// How the router reaches each line, in file order.
    pub lines: Vec<Arc<dyn Backend>>,
    /// The lines' tasks (none for a line of the program's own kind), to end them (and
    /// release their ports) with the gateway.
    pub tasks: Vec<Option<AbortHandle>>,
}

/// Open every line of `gw` and spawn its task (on the current tokio runtime); line `i`
/// counts in slot `i` of the counters. A line whose configuration its engine refuses stops
/// the start; so does a port that cannot be opened, unless `allow_down_at_start` lets the
/// line start down. On an error the lines started so far are ended.
pub async fn lines(gw: &Config, opening: &Opening, events: &Events) -> Result<Started, Error> {
    let mut counters = Stats::new(0);
    for l in &gw.lines {
        counters.add_line(l.name.clone(), l.demotion, &l.addresses());
    }
    let stats = Arc::new(Mutex::new(counters));
    let mut handles = Vec::with_capacity(gw.lines.len());
    let mut tasks = Tasks(Vec::with_capacity(gw.lines.len()));
    for (i, l) in gw.lines.iter().enumerate() {
        let at = Slot {
            index: i,
            stats: &stats,
            events,
        };
        let (backend, task) = line(l, at, gw.allow_down_at_start, opening).await?;
        handles.push(backend);
        tasks.0.push(task);
    }
    Ok(Started {
        stats,
        lines: handles,
        tasks: std::mem::take(&mut tasks.0),
    })
}

/// Where a line reports: its slot in the counters, and the event sink.
#[derive(Clone, Copy)]
pub struct Slot<'a> {
    /// The line's slot in [`Stats::lines`].
    pub index: usize,
    /// The counters.
    pub stats: &'a Arc<Mutex<Stats>>,
    /// The events.
    pub events: &'a Events,
}

/// Open line `l` and spawn its task, counting in slot `at`: how the router reaches it, and
/// its task. A port that cannot be opened stops it unless `allow_down` lets it start down.
pub async fn line(
    l: &Line,
    at: Slot<'_>,
    allow_down: bool,
    opening: &Opening,
) -> Result<(Arc<dyn Backend>, Option<AbortHandle>), Error> {
    let log = reopen::LineLog {
        index: at.index,
        name: l.name.clone(),
        stats: Arc::clone(at.stats),
        events: Arc::clone(at.events),
    };
    let (o, l) = (opening.clone(), l.clone());
    let started = |task| Some(tokio::spawn(task).abort_handle());
    Ok(match &l.kind {
        Kind::ModbusRtu => {
            let first = start(open_modbus(&o, &l).await, allow_down, &l)?;
            let queue = Arc::new(line::LineQueue::new(l.queue));
            let (q, pause) = (Arc::clone(&queue), l.pause);
            let open = async move || open_modbus(&o, &l).await;
            let task = started(Box::pin(line::run(log, q, first, open, pause)) as Task);
            (Arc::new(QueuedLine(queue)), task)
        }
        Kind::ModbusTcp(tcp) => {
            let (tcp, prefix) = (tcp.clone(), format!("line {}: ", l.name));
            let opened = tcp_line::open(&tcp).await.map_err(|e| e.prefixed(&prefix));
            let first = start(opened, allow_down, &l)?;
            let queue = Arc::new(line::LineQueue::new(l.queue));
            let (q, pause) = (Arc::clone(&queue), l.pause);
            let open = async move || tcp_line::open(&tcp).await.map_err(|e| e.prefixed(&prefix));
            let task = started(Box::pin(tcp_line::run(log, q, first, open, pause)));
            (Arc::new(QueuedLine(queue)), task)
        }
        Kind::Uss(u) => {
            let u = u.clone();
            let first = start(open_uss(&o, &l, &u).await, allow_down, &l)?;
            let drives = uss::UssDrives::new(&u);
            let open = async move || open_uss(&o, &l, &u).await;
            let task = started(Box::pin(drives.supervise(log, first, open)));
            (Arc::new(drives), task)
        }
        Kind::Rk512(r) => {
            let (r, pause) = (r.clone(), l.pause);
            let queue = Arc::new(line::LineQueue::new(l.queue));
            let q = Arc::clone(&queue);
            let task = match r.role {
                Role::Active => {
                    let first = start(open_rk512(&o, &l, &r, None).await, allow_down, &l)?;
                    let partner = rk512::Partner::new(&r);
                    let open = async move || open_rk512(&o, &l, &r, None).await;
                    started(Box::pin(rk512::run(log, q, partner, first, open, pause)))
                }
                Role::Passive => {
                    let own = rk512_own::OwnMemory::new(&r);
                    let kept = own.kept();
                    let first = start(open_rk512(&o, &l, &r, None).await, allow_down, &l)?;
                    let open = async move || open_rk512(&o, &l, &r, Some(&kept)).await;
                    started(Box::pin(own.run(log, q, first, open)))
                }
            };
            (Arc::new(QueuedLine(queue)), task)
        }
        Kind::R3964(link) => {
            let link = *link;
            let first = start(open_3964r(&o, &l, &link).await, allow_down, &l)?;
            let blocks = r3964::BlockLine::new(link.max_block_len.into());
            let open = async move || open_3964r(&o, &l, &link).await;
            let task = started(Box::pin(blocks.supervise(log, first, open)));
            (Arc::new(blocks), task)
        }
        Kind::Custom(custom) => (Arc::clone(&custom.0), None),
    })
}

/// A line's task.
type Task = std::pin::Pin<Box<dyn std::future::Future<Output = ()> + Send + 'static>>;

/// The tasks started so far, ended if the start fails part way (dropped without being taken).
struct Tasks(Vec<Option<AbortHandle>>);

impl Drop for Tasks {
    fn drop(&mut self) {
        for t in self.0.iter().flatten() {
            t.abort();
        }
    }
}

/// How line `l` starts from its first opening: open, or (with `allow_down_at_start` and a port
/// that cannot be opened) down with the reason; otherwise the error stops the gateway.
fn start<L>(
    opened: Result<reopen::Opened<L>, Error>,
    allow_down: bool,
    l: &Line,
) -> Result<reopen::First<L>, Error> {
    match opened {
        Ok(o) => Ok(Ok(o)),
        Err(Error::Port(e)) if allow_down => {
            let prefix = format!("line {}: ", l.name);
            Ok(Err(e.trim_start_matches(&prefix).to_owned()))
        }
        Err(e) => Err(e),
    }
}

/// Open a USS line and start its master polling the drives.
async fn open_uss(
    o: &Opening,
    l: &Line,
    u: &UssLine,
) -> Result<reopen::Opened<si_uss::tokio::Handle>, Error> {
    let rates = &si_uss::config::USS_BAUD_RATES[..];
    open_engine(o, l, "uss", rates, |settings| uss_master(u, settings))
        .await
        .map(|o| o.spawn(si_uss::tokio::Handle::spawn_engine))
}

/// A USS line's master for its serial settings.
fn uss_master(
    u: &UssLine,
    settings: si_core::SerialSettings,
) -> Result<si_uss::Master, si_uss::config::ConfigError> {
    let mut config = u.master.clone();
    config.settings = settings;
    si_uss::Master::new(config)
}

/// Open an RK 512 line and start its station: active only, or serving the line's memory in
/// the passive role, from the memory `kept` before its port last closed, if any.
async fn open_rk512(
    o: &Opening,
    l: &Line,
    r: &Rk512Line,
    kept: Option<&rk512_own::Kept>,
) -> Result<reopen::Opened<si_rk512::tokio::Handle>, Error> {
    open_engine(o, l, "rk512", &si_core::BAUD_RATES, |settings| {
        rk512_station(r, settings, kept)
    })
    .await
    .map(|o| o.spawn(si_rk512::tokio::Handle::spawn_engine))
}

/// An RK 512 line's station for its serial settings: active only, or serving the line's
/// memory in the passive role, from the memory `kept` if any.
fn rk512_station(
    r: &Rk512Line,
    settings: si_core::SerialSettings,
    kept: Option<&rk512_own::Kept>,
) -> Result<si_rk512::Station, si_3964r::ConfigError> {
    match r.role {
        Role::Active => si_rk512::Station::new(r.config.with_settings(settings)),
        Role::Passive => {
            let server = si_rk512::passive::ServerConfig {
                memory: r.memory.clone(),
                ..si_rk512::passive::ServerConfig::default()
            };
            let mut station =
                si_rk512::Station::serving(r.config.with_settings(settings), &server)?;
            if let Some(kept) = kept {
                kept.restore(&mut station);
            }
            Ok(station)
        }
    }
}

/// Open a plain 3964(R) line and start its link.
async fn open_3964r(
    o: &Opening,
    l: &Line,
    link: &si_3964r::Config,
) -> Result<reopen::Opened<si_3964r::tokio::Handle>, Error> {
    open_engine(o, l, "3964r", &si_core::BAUD_RATES, |settings| {
        si_3964r::Link::new((*link).with_settings(settings))
    })
    .await
    .map(|o| o.spawn(si_3964r::tokio::Handle::spawn_engine))
}

/// Open a Modbus RTU line and start its master.
async fn open_modbus(
    o: &Opening,
    l: &Line,
) -> Result<reopen::Opened<si_modbus::tokio::Master>, Error> {
    open_engine(o, l, "modbus", &si_core::BAUD_RATES, |settings| {
        modbus_master(l, settings)
    })
    .await
    .map(|o| o.spawn(si_modbus::tokio::Master::spawn_engine))
}

/// A Modbus RTU line's master for its serial settings.
fn modbus_master(
    l: &Line,
    settings: si_core::SerialSettings,
) -> Result<si_modbus::Master, si_modbus::config::ConfigError> {
    // On RS-485 a response is recognised by its address, skipping a turnaround glitch ([Modbus/USS]
    // §3.4.1, §3.4.3).
    let interface = if l.port.as_ref().is_some_and(|p| p.rs485.is_some()) {
        si_core::Interface::Rs485
    } else {
        si_core::Interface::Rs232
    };
    {
        let gap = spec_gap(&settings);
        let config = MasterConfig {
            line: LineConfig {
                settings,
                mode: Mode::Normal,
                char_delay_multiplier: l.rtu.char_delay_multiplier,
                local_echo: false,
                auto_v24: None,
            },
            response_timeout: l.response_timeout.into(),
            retries: l.retries,
            ..MasterConfig::default()
        };
        // A late answer never reaches the next request (si-modbus's quiet guard).
        let quiet = l
            .rtu
            .quiet_after_timeout_ms
            .map_or(l.response_timeout, |ms| Duration::from_millis(ms.into()));
        si_modbus::Master::new(config).map(|m| {
            let m = m
                .with_interface(interface)
                .with_frame_end(l.rtu.frame_end)
                .with_quiet_after_timeout(quiet);
            if l.rtu.spec_gap {
                m.with_gap(gap)
            } else {
                m
            }
        })
    }
}

/// The Modbus specification's inter-frame silence t3.5 ([Modbus serial] §2.5.1.1): 3.5
/// character times below 19200 bit/s, a fixed 1.75 ms at and above, where the character time
/// would make it too short for a host to time.
fn spec_gap(settings: &si_core::SerialSettings) -> si_core::Duration {
    if settings.baud() >= 19_200 {
        si_core::Duration::from_micros(1_750)
    } else {
        let seven_halves = settings.chars_time(7).as_micros();
        si_core::Duration::from_micros(seven_halves.div_ceil(2))
    }
}

/// Build line `l`'s engine for its serial settings (a baud rate from `rates`, the protocol's
/// list), checking its configuration before the port opens, then open the port, watched for
/// its closing ([`reopen::watch`]). Errors name the line: [`Error::Config`] for settings or
/// an engine configuration refused, [`Error::Port`] for a port that cannot be opened.
async fn open_engine<E, F: std::error::Error>(
    o: &Opening,
    l: &Line,
    protocol: &'static str,
    rates: &'static [u32],
    engine: impl FnOnce(si_core::SerialSettings) -> Result<E, F>,
) -> Result<reopen::Opened<(E, Box<dyn si_core::driver::Transport>)>, Error> {
    let prefix = format!("line {}: ", l.name);
    let (settings, engine) = build(l, rates, engine)?;
    let port = open::open(l, &settings, protocol, o)
        .await
        .map_err(|e| match e {
            Error::Config(t) | Error::Port(t) | Error::Io(t) => Error::Port(format!("{prefix}{t}")),
        })?;
    let (port, closed) = reopen::watch(port);
    Ok(reopen::Opened {
        link: (engine, port),
        closed,
    })
}

/// Line `l`'s serial settings (a baud rate from `rates`) and its engine built for them, or
/// the [`Error::Config`] naming the line.
fn build<E, F: std::error::Error>(
    l: &Line,
    rates: &'static [u32],
    engine: impl FnOnce(si_core::SerialSettings) -> Result<E, F>,
) -> Result<(si_core::SerialSettings, E), Error> {
    let prefix = format!("line {}: ", l.name);
    let settings = open::settings(l, rates).map_err(|e| e.prefixed(&prefix))?;
    let engine = engine(settings).map_err(|e| Error::Config(format!("{prefix}{e}")))?;
    Ok((settings, engine))
}

/// Whether line `l` would start, short of its port: its settings and its engine's
/// configuration are accepted, with the error [`line()`] would give if not. Nothing is opened
/// (an engine is state only), so a reload checks every line it would start before it ends
/// any ([`crate::Gateway::reload`]).
pub fn check(l: &Line) -> Result<(), Error> {
    let serial = &si_core::BAUD_RATES;
    match &l.kind {
        Kind::ModbusRtu => build(l, serial, |s| modbus_master(l, s)).map(drop),
        Kind::Uss(u) => build(l, &si_uss::config::USS_BAUD_RATES, |s| uss_master(u, s)).map(drop),
        Kind::Rk512(r) => build(l, serial, |s| rk512_station(r, s, None)).map(drop),
        Kind::R3964(link) => {
            build(l, serial, |s| si_3964r::Link::new(link.with_settings(s))).map(drop)
        }
        // A Modbus TCP line has nothing to check before it connects; a program's own kind
        // was built by the program.
        Kind::ModbusTcp(_) | Kind::Custom(_) => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::spec_gap;
    use si_core::{Parity, SerialSettings};

    #[test]
    fn the_spec_gap_is_t35_below_19200_and_1_75_ms_from_there() {
        let at = |baud| SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
        // 9600 8E1: 11 bits a character, 3.5 × 1145.8 µs.
        assert_eq!(spec_gap(&at(9600)).as_micros(), 4011);
        assert_eq!(spec_gap(&at(19_200)).as_micros(), 1750);
        assert_eq!(spec_gap(&at(115_200)).as_micros(), 1750);
    }
}
