//! The gateway as a program holds it: started from a checked [`Config`], it serves until
//! shut down, and tells its counters ([`Gateway::stats`]) and its lines' events
//! ([`Gateway::events`]) meanwhile.
//!
//! ```no_run
//! # async fn f(config: si_gateway::config::Config) -> Result<(), si_gateway::Error> {
//! let gateway = si_gateway::Gateway::start(config).await?;
//! let stop = gateway.shutdown_handle();
//! tokio::spawn(async move {
//!     // An hour of serving, then stop.
//!     tokio::time::sleep(std::time::Duration::from_secs(3600)).await;
//!     stop.shutdown();
//! });
//! gateway.run().await
//! # }
//! ```

use crate::backend::Backend;
use crate::config::{Config, Line};
use crate::counters::Stats;
use crate::demotion::LineHealth;
use crate::event::{Event, Events};
use crate::faces::{self, Bound, FaceHandler};
use crate::line::lock;
use crate::listeners::{self, Extra};
use crate::open::Opening;
use crate::{start, Error};
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::Peer;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::sync::{broadcast, watch};
use tokio::task::AbortHandle;

/// Events kept for a slow [`Gateway::events`] receiver before it misses the oldest.
const EVENT_BACKLOG: usize = 256;

/// What a program may add to a start: how ports are opened, and a sink seeing every event
/// from the first (a receiver from [`Gateway::events`] sees those after it subscribed).
#[derive(Clone, Default)]
pub struct Options {
    /// The program's part in opening ports (line-error mode, a tap).
    pub opening: Opening,
    /// Called with each event, on the line's task.
    pub on_event: Option<Events>,
}

/// One listening address and the lines (indices in the configuration) reached there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Listener {
    /// The address bound (the port the system chose for `:0`).
    pub addr: SocketAddr,
    /// The lines reached there (indices in the configuration it started with).
    pub lines: Vec<usize>,
}

/// A running gateway: its lines are open (or being reopened) and its addresses bound from
/// [`start`](Self::start) on; [`run`](Self::run) serves the clients. Dropping it ends the
/// lines and releases their ports.
pub struct Gateway {
    lines: tokio::sync::Mutex<Lines>,
    stats: Arc<Mutex<Stats>>,
    handlers: Vec<FaceHandler>,
    listeners: Vec<Listener>,
    extra: Vec<Extra>,
    faces: Mutex<Option<Vec<Bound>>>,
    events: broadcast::Sender<Event>,
    sink: Events,
    opening: Opening,
    shutdown: Arc<watch::Sender<bool>>,
}

/// The lines as configured now: each counts in its slot (module [`crate::counters`]'s
/// `Stats::order`), which it keeps across reloads.
struct Lines {
    config: Config,
    /// Configuration order → slot.
    slots: Vec<usize>,
    /// By slot: how the router reaches the line (a removed line's stays, unrouted).
    backends: Vec<Arc<dyn Backend>>,
    /// By slot: the line's task, while it runs.
    tasks: Vec<Option<AbortHandle>>,
}

impl Lines {
    /// End the task of slot `slot`.
    fn end(&mut self, slot: usize) {
        if let Some(t) = self.tasks[slot].take() {
            t.abort();
        }
    }
}

/// What a reload did, by line name.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Reloaded {
    /// Lines whose configuration did not change: they kept their port, clients, queue and
    /// counters.
    pub kept: Vec<String>,
    /// Lines whose configuration changed: restarted (their counters go on).
    pub restarted: Vec<String>,
    /// Lines new in the configuration: started.
    pub added: Vec<String>,
    /// Lines no longer configured: ended; their unit ids are answered with 0AH.
    pub removed: Vec<String>,
}

impl Gateway {
    /// Open every line of `config` and bind every listening address.
    pub async fn start(config: Config) -> Result<Gateway, Error> {
        Self::start_with(config, Options::default()).await
    }

    /// [`start`](Self::start) with the program's [`Options`].
    pub async fn start_with(config: Config, options: Options) -> Result<Gateway, Error> {
        config
            .check_lines()
            .map_err(|e| Error::Config(e.to_string()))?;
        let (events, _) = broadcast::channel(EVENT_BACKLOG);
        let sink: Events = {
            let (events, on_event) = (events.clone(), options.on_event.clone());
            Arc::new(move |e: &Event| {
                if let Some(f) = &on_event {
                    f(e);
                }
                // No receiver: nobody listens, which is fine.
                let _ = events.send(e.clone());
            })
        };
        let started = start::lines(&config, &options.opening, &sink).await?;
        let backends = started.lines.clone();
        let lines: Arc<[Arc<dyn Backend>]> = started.lines.into();
        let bound = match faces::bind(&config, lines, &started.stats).await {
            Ok(b) => b,
            Err(e) => {
                started.tasks.iter().flatten().for_each(AbortHandle::abort);
                return Err(e);
            }
        };
        let listeners = bound
            .iter()
            .map(|b| Listener {
                addr: b.addr,
                lines: b.lines.clone(),
            })
            .collect();
        let handlers: Vec<FaceHandler> = bound.iter().map(|b| b.handler.clone()).collect();
        let extra = match listeners::start(&config, bound.len(), &handlers[0], &started.stats).await
        {
            Ok(e) => e,
            Err(e) => {
                started.tasks.iter().flatten().for_each(AbortHandle::abort);
                return Err(e);
            }
        };
        Ok(Gateway {
            lines: tokio::sync::Mutex::new(Lines {
                slots: (0..config.lines.len()).collect(),
                config,
                backends,
                tasks: started.tasks,
            }),
            stats: started.stats,
            handlers,
            listeners,
            extra,
            faces: Mutex::new(Some(bound)),
            events,
            sink,
            opening: options.opening,
            shutdown: Arc::new(watch::Sender::new(false)),
        })
    }

    /// The configuration it runs now.
    pub async fn config(&self) -> Config {
        self.lines.lock().await.config.clone()
    }

    /// Where it listens: the top-level address first, then each line address.
    pub fn listeners(&self) -> &[Listener] {
        &self.listeners
    }

    /// The extra listeners it started: `rtu_over_tcp_listen` and `metrics_listen`, if
    /// configured.
    pub fn extra_listeners(&self) -> &[Extra] {
        &self.extra
    }

    /// Every counter now: per configured line, in configuration order (and whether it is
    /// down, and why), per client.
    pub fn stats(&self) -> Stats {
        lock(&self.stats).in_order()
    }

    /// The lines' events from now on (down and up, with why).
    pub fn events(&self) -> broadcast::Receiver<Event> {
        self.events.subscribe()
    }

    /// A handle that ends [`run`](Self::run) from anywhere.
    pub fn shutdown_handle(&self) -> Shutdown {
        Shutdown(Arc::clone(&self.shutdown))
    }

    /// The top-level address's request handler, to mount in a program's own Modbus TCP
    /// server (`si_modbus::tokio::tcp::Server::with_handler`) or to call directly
    /// ([`Handler::call`]): the same routes, lines and counters as the gateway's own.
    pub fn handler(&self) -> Handler {
        Handler(self.handlers[0].clone())
    }

    /// Change to `config` while serving: lines (by name) whose configuration did not change
    /// keep their port, clients, queue and counters; changed lines restart; removed lines
    /// end and their unit ids are answered with 0AH; added lines start. The connections stay.
    /// A line restarted or added whose port cannot be opened starts down and is reopened (as
    /// with `allow_down_at_start`).
    ///
    /// Refused, with the old configuration still running, if `config` does not check
    /// ([`Config::check_lines`]), a changed or added line's settings or engine configuration
    /// are refused ([`start::check`], before any line ends), or it would
    /// change what is bound: the listening addresses (the top-level `listen`, the lines',
    /// `metrics_listen` and `rtu_over_tcp_listen`), `max_connections` or `idle_timeout_ms`,
    /// which need a restart.
    ///
    /// Every line keeps its counter slot: a kept or changed line's counters and metrics go on
    /// (they never go down), a changed line's units start healthy (not demoted), and an added
    /// line gets a new slot, reported in the metrics under its name. A removed line's metric
    /// series disappear from the scrape (a gone target's do in Prometheus).
    pub async fn reload(&self, config: Config) -> Result<Reloaded, Error> {
        config
            .check_lines()
            .map_err(|e| Error::Config(e.to_string()))?;
        let mut lines = self.lines.lock().await;
        let old = lines.config.clone();
        let old = &old;
        let bound = |c: &Config| {
            let faces: Vec<String> = faces::faces(c).into_iter().map(|f| f.listen).collect();
            let extra = (c.metrics_listen.clone(), c.rtu_over_tcp_listen.clone());
            (faces, extra, c.max_connections, c.idle_timeout)
        };
        if bound(old) != bound(&config) {
            return Err(Error::Config(
                "reload: the listening addresses (listen, a line's listen, metrics_listen, \
                 rtu_over_tcp_listen), max_connections and idle_timeout_ms change only with a \
                 restart"
                    .into(),
            ));
        }
        let before = |name: &str| old.lines.iter().position(|l| l.name == name);
        // Every line it would start is checked (its settings, its engine's configuration)
        // before any line ends, so a refused one refuses the reload with nothing stopped.
        for l in &config.lines {
            if !before(&l.name).is_some_and(|i| old.lines[i] == *l) {
                start::check(l)?;
            }
        }
        let mut done = Reloaded::default();
        let mut slots = Vec::with_capacity(config.lines.len());
        // The slots swapped so far, with the line each held before (`None`: added), to put
        // back should a line fail to start after all.
        let mut swapped: Vec<(usize, Option<&Line>)> = Vec::new();
        for l in &config.lines {
            let (slot, was) = match before(&l.name) {
                Some(i) if old.lines[i] == *l => {
                    done.kept.push(l.name.clone());
                    slots.push(lines.slots[i]);
                    continue;
                }
                Some(i) => {
                    done.restarted.push(l.name.clone());
                    let slot = lines.slots[i];
                    lines.end(slot);
                    // It restarts: its units start healthy, under its new settings (its
                    // counters and metrics go on).
                    self.restarting(slot, l);
                    (slot, Some(&old.lines[i]))
                }
                None => {
                    done.added.push(l.name.clone());
                    lines.backends.push(Arc::new(Gone));
                    lines.tasks.push(None);
                    // Its own slot in the counters, health and metrics (the order is set
                    // below, once every line has its slot).
                    let units = l.addresses();
                    let slot = lock(&self.stats).add_line(l.name.clone(), l.demotion, &units);
                    (slot, None)
                }
            };
            swapped.push((slot, was));
            match start::line(l, self.slot(slot), true, &self.opening).await {
                Ok((backend, task)) => {
                    lines.backends[slot] = backend;
                    lines.tasks[slot] = task;
                    slots.push(slot);
                }
                Err(e) => {
                    self.put_back(&mut lines, &swapped).await;
                    return Err(e);
                }
            }
        }
        for (i, l) in lines.config.lines.clone().iter().enumerate() {
            if !config.lines.iter().any(|n| n.name == l.name) {
                done.removed.push(l.name.clone());
                let slot = lines.slots[i];
                lines.end(slot);
                lines.backends[slot] = Arc::new(Gone);
                lock(&self.stats).remove_line(slot);
            }
        }
        let backends: Arc<[Arc<dyn Backend>]> = lines.backends.clone().into();
        let routers = faces::routers(&config, &slots, &backends, &self.stats);
        lock(&self.stats).order = slots.clone();
        for (handler, router) in self.handlers.iter().zip(routers) {
            handler.replace(router);
        }
        lines.config = config;
        lines.slots = slots;
        Ok(done)
    }

    /// Where the line in slot `slot` reports.
    fn slot(&self, slot: usize) -> start::Slot<'_> {
        start::Slot {
            index: slot,
            stats: &self.stats,
            events: &self.sink,
        }
    }

    /// The line in slot `slot` is about to restart as `l`: it is up until its port says
    /// otherwise, and its units are healthy under `l`'s demotion settings.
    fn restarting(&self, slot: usize, l: &Line) {
        let mut s = lock(&self.stats);
        s.down[slot] = None;
        s.health[slot] = LineHealth::new(l.demotion);
    }

    /// A reload failed part way: the slots `swapped` get back the lines they held (those
    /// restarted start again as they were; those added end, unrouted), and the counters'
    /// order is the running configuration's again. The routes never changed.
    async fn put_back(&self, lines: &mut Lines, swapped: &[(usize, Option<&Line>)]) {
        for &(slot, was) in swapped {
            lines.end(slot);
            lines.backends[slot] = Arc::new(Gone);
            let Some(l) = was else {
                // An added line's slot: its series go, as a removed line's do.
                lock(&self.stats).remove_line(slot);
                continue;
            };
            self.restarting(slot, l);
            // It started before with these settings; a port that cannot be opened now
            // starts it down, to be reopened.
            if let Ok((backend, task)) = start::line(l, self.slot(slot), true, &self.opening).await
            {
                lines.backends[slot] = backend;
                lines.tasks[slot] = task;
            }
        }
        lock(&self.stats).order = lines.slots.clone();
    }

    /// Serve the clients until [`Shutdown::shutdown`] (`Ok`), or until a listening server
    /// fails (its error). Only the first call serves; a second returns at once.
    pub async fn run(&self) -> Result<(), Error> {
        let Some(bound) = lock(&self.faces).take() else {
            return Ok(());
        };
        let mut stop = self.shutdown.subscribe();
        tokio::select! {
            ended = faces::run(bound) => match ended {
                Ok(()) => Err(Error::new("gateway stopped")),
                Err(e) => Err(Error::new(format!("gateway stopped: {e}"))),
            },
            _ = stop.wait_for(|&s| s) => Ok(()),
        }
    }
}

impl Drop for Gateway {
    fn drop(&mut self) {
        for t in self.lines.get_mut().tasks.iter().flatten() {
            t.abort();
        }
        for e in &self.extra {
            e.task.abort();
        }
    }
}

/// A removed line's slot: never routed to (its unit ids are no longer routed), 0AH if it were.
struct Gone;

impl Backend for Gone {
    fn reach<'a>(&'a self, request: &'a TcpAdu) -> crate::backend::Reach<'a> {
        let answer = crate::line::exception(request, crate::line::GATEWAY_PATH_UNAVAILABLE);
        crate::backend::Reach::Answer(Box::pin(async move {
            (answer, crate::counters::Outcome::Other)
        }))
    }
}

/// Ends a gateway's [`Gateway::run`].
#[derive(Clone)]
pub struct Shutdown(Arc<watch::Sender<bool>>);

impl Shutdown {
    /// End the run (at once; requests in flight are dropped with their connections).
    pub fn shutdown(&self) {
        self.0.send_replace(true);
    }
}

/// The gateway's request handler, for a program's own Modbus TCP server.
#[derive(Clone)]
pub struct Handler(FaceHandler);

impl Handler {
    /// The answer to one request (`None`: a broadcast without an answer): routed by its unit
    /// id like a request from a TCP client, counted for no client.
    pub async fn call(&self, request: TcpAdu) -> Option<TcpAdu> {
        si_modbus::tokio::tcp::Handler::answer(&self.0, request).await
    }
}

impl si_modbus::tokio::tcp::Handler for Handler {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        self.0.answer(request).await
    }

    async fn answer_from(&self, peer: &Peer, request: TcpAdu) -> Option<TcpAdu> {
        self.0.answer_from(peer, request).await
    }

    fn connected(&self, peer: &Peer) {
        self.0.connected(peer);
    }

    fn disconnected(&self, peer: &Peer) {
        self.0.disconnected(peer);
    }
}
