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
use crate::config::Config;
use crate::counters::Stats;
use crate::event::{Event, Events};
use crate::faces::{self, Bound, FaceHandler};
use crate::line::lock;
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
    /// The lines reached there.
    pub lines: Vec<usize>,
}

/// A running gateway: its lines are open (or being reopened) and its addresses bound from
/// [`start`](Self::start) on; [`run`](Self::run) serves the clients. Dropping it ends the
/// lines and releases their ports.
pub struct Gateway {
    config: Config,
    stats: Arc<Mutex<Stats>>,
    handler: FaceHandler,
    listeners: Vec<Listener>,
    faces: Mutex<Option<Vec<Bound>>>,
    events: broadcast::Sender<Event>,
    shutdown: Arc<watch::Sender<bool>>,
    tasks: Vec<AbortHandle>,
}

impl Gateway {
    /// Open every line of `config` and bind every listening address.
    pub async fn start(config: Config) -> Result<Gateway, Error> {
        Self::start_with(config, Options::default()).await
    }

    /// [`start`](Self::start) with the program's [`Options`].
    pub async fn start_with(config: Config, options: Options) -> Result<Gateway, Error> {
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
        let end_lines = |tasks: &[AbortHandle]| tasks.iter().for_each(AbortHandle::abort);
        let lines: Arc<[Arc<dyn Backend>]> = started.lines.into();
        let bound = match faces::bind(&config, lines, &started.stats).await {
            Ok(b) => b,
            Err(e) => {
                end_lines(&started.tasks);
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
        let handler = bound[0].handler.clone();
        Ok(Gateway {
            config,
            stats: started.stats,
            handler,
            listeners,
            faces: Mutex::new(Some(bound)),
            events,
            shutdown: Arc::new(watch::Sender::new(false)),
            tasks: started.tasks,
        })
    }

    /// The configuration it runs.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Where it listens: the top-level address first, then each line address.
    pub fn listeners(&self) -> &[Listener] {
        &self.listeners
    }

    /// Every counter now: per line (and whether it is down, and why), per client.
    pub fn stats(&self) -> Stats {
        lock(&self.stats).clone()
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
        Handler(self.handler.clone())
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
        for t in &self.tasks {
            t.abort();
        }
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
