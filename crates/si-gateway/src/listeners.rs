//! The gateway's extra listeners beside its Modbus TCP faces: Prometheus metrics on
//! `metrics_listen` ([`crate::metrics_http`]) and raw RTU frames over TCP on
//! `rtu_over_tcp_listen` ([`crate::rtu_listener`], routed like the top-level `listen`).

use crate::config::Gateway;
use crate::counters::Stats;
use crate::router::LineHandle;
use crate::{faces, metrics_http, rtu_listener, Error};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::net::TcpListener;

/// Bind and spawn the extra listeners `gw` configures, on the current tokio runtime: each one's
/// event name (`rtu_over_tcp_listening`, `metrics_listening`) and the address it listens on.
/// `faces` is the number of Modbus TCP faces already bound (the RTU listener's clients are
/// numbered after theirs); `lines` and `stats` are the gateway's.
pub async fn start(
    gw: &Gateway,
    faces: usize,
    lines: Arc<[LineHandle]>,
    stats: &Arc<Mutex<Stats>>,
) -> Result<Vec<(&'static str, SocketAddr)>, Error> {
    let mut bound = Vec::new();
    let rtu = match &gw.rtu_over_tcp_listen {
        Some(addr) => {
            let top = &faces::faces(gw)[0];
            let handler = faces::handler(gw, faces as u64, top, lines, stats);
            let listener = bind(addr).await?;
            bound.push(("rtu_over_tcp_listening", listener.local_addr()?));
            let counters = Arc::new(rtu_listener::RtuCounters::default());
            let run = rtu_listener::run(listener, Arc::new(handler), Arc::clone(&counters), 0);
            tokio::spawn(async move {
                if let Err(e) = run.await {
                    tracing::error!("RTU-over-TCP listener stopped: {e}");
                }
            });
            Some(counters)
        }
        None => None,
    };
    if let Some(addr) = &gw.metrics_listen {
        let listener = bind(addr).await?;
        bound.push(("metrics_listening", listener.local_addr()?));
        let source = metrics_http::Source {
            stats: Arc::clone(stats),
            rtu,
        };
        tokio::spawn(async move {
            if let Err(e) = metrics_http::run(listener, source).await {
                tracing::error!("metrics listener stopped: {e}");
            }
        });
    }
    Ok(bound)
}

async fn bind(addr: &str) -> Result<TcpListener, Error> {
    TcpListener::bind(addr)
        .await
        .map_err(|e| Error::new(format!("cannot listen on {addr}: {e}")))
}
