//! The gateway's extra listeners beside its Modbus TCP faces: Prometheus metrics on
//! `metrics_listen` ([`crate::metrics_http`]) and raw RTU frames over TCP on
//! `rtu_over_tcp_listen` ([`crate::rtu_listener`], routed like the top-level `listen`).

use crate::config::Config;
use crate::counters::Stats;
use crate::faces::FaceHandler;
use crate::{metrics_http, rtu_listener, Error};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::net::TcpListener;
use tokio::task::AbortHandle;

/// One extra listener, bound and serving.
#[derive(Debug, Clone)]
pub struct Extra {
    /// Its event name: `rtu_over_tcp_listening` or `metrics_listening`.
    pub event: &'static str,
    /// The address bound (the port the system chose for `:0`).
    pub addr: SocketAddr,
    /// Its task, ended with the gateway.
    pub task: AbortHandle,
}

/// Bind and spawn the extra listeners `gw` configures, on the current tokio runtime. `top` is
/// the top-level face's handler: the RTU listener routes through it, so a reload's new routes
/// (and `unit_map`) apply there too; its clients are numbered as face `faces` (the number of
/// Modbus TCP faces bound), apart from every TCP face's. `stats` are the gateway's.
pub async fn start(
    gw: &Config,
    faces: usize,
    top: &FaceHandler,
    stats: &Arc<Mutex<Stats>>,
) -> Result<Vec<Extra>, Error> {
    let mut bound = Vec::new();
    let ended = |bound: &[Extra]| bound.iter().for_each(|e| e.task.abort());
    let rtu = match &gw.rtu_over_tcp_listen {
        Some(addr) => {
            let listener = bind(addr).await?;
            let addr = listener.local_addr()?;
            let counters = Arc::new(rtu_listener::RtuCounters::default());
            let handler = Arc::new(top.clone());
            let id_base = (faces as u64) << crate::faces::CONNECTION_BITS;
            // The Modbus TCP faces' limits, from the same keys.
            let limits = rtu_listener::Limits {
                max_connections: gw.max_connections,
                idle_timeout: gw.idle_timeout,
            };
            let run = rtu_listener::run(listener, handler, Arc::clone(&counters), id_base, limits);
            let task = tokio::spawn(async move { match run.await {} });
            bound.push(Extra {
                event: "rtu_over_tcp_listening",
                addr,
                task: task.abort_handle(),
            });
            Some(counters)
        }
        None => None,
    };
    if let Some(addr) = &gw.metrics_listen {
        let listener = match bind(addr).await {
            Ok(l) => l,
            Err(e) => {
                ended(&bound);
                return Err(e);
            }
        };
        let addr = listener.local_addr()?;
        let source = metrics_http::Source {
            stats: Arc::clone(stats),
            rtu,
        };
        let task = tokio::spawn(async move { match metrics_http::run(listener, source).await {} });
        bound.push(Extra {
            event: "metrics_listening",
            addr,
            task: task.abort_handle(),
        });
    }
    Ok(bound)
}

async fn bind(addr: &str) -> Result<TcpListener, Error> {
    TcpListener::bind(addr)
        .await
        .map_err(|e| Error::new(format!("cannot listen on {addr}: {e}")))
}
