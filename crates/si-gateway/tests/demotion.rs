//! A dead unit does not slow a live one on the same line (auto-demotion, `si_gateway::demotion`),
//! in-process: two clients poll a live unit (a si-modbus slave at address 1) and a dead one
//! (unit 2, nobody answers) on one RTU line over an in-memory pipe, through the gateway's router
//! and line task. The live unit's p99 stays within 2× its p99 without the dead unit, and while
//! the dead unit is demoted the line carries no byte for it (the bytes the master sends are
//! counted on the line side).
//!
//! The p99 comparison is a generous bound on the same machine in the same run, not a timing
//! claim: without demotion each request to the dead unit holds the line for its 50 ms response
//! timeout, ten times the live unit's exchange.

use si_gateway::backend::{Backend, QueuedLine};
use si_gateway::counters::Stats;
use si_gateway::demotion::{DemotionConfig, LineHealth};
use si_gateway::line::{self, LineQueue};
use si_gateway::reopen::{self, LineLog, Opened};
use si_gateway::router::Router;
use si_modbus::frame::Request;
use si_modbus::mbap::TcpAdu;
use si_modbus::slave::Tables;
use si_modbus::tokio::tcp::{Handler, Peer};
use si_modbus::tokio::{Master, Slave};
use si_modbus::{MasterConfig, SlaveConfig};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};

/// Requests per client and phase.
const REQUESTS: usize = 100;

/// The bytes the master put on the line, in order, shared with the test.
type LineBytes = Arc<Mutex<Vec<u8>>>;

/// Copy `from` to `to`, recording what passes if `record` is given.
async fn pipe(
    mut from: tokio::io::ReadHalf<DuplexStream>,
    mut to: tokio::io::WriteHalf<DuplexStream>,
    record: Option<LineBytes>,
) {
    let mut buf = [0u8; 512];
    while let Ok(n) = from.read(&mut buf).await {
        if n == 0 {
            return;
        }
        if let Some(r) = &record {
            r.lock().unwrap().extend_from_slice(&buf[..n]);
        }
        if to.write_all(&buf[..n]).await.is_err() {
            return;
        }
    }
}

/// A router with one RTU line (units 1 and 2) to a slave at address 1; what the master sends
/// is recorded on the way. `demotion` is the line's setting.
fn gateway(demotion: DemotionConfig) -> (Router, Slave<Tables>, LineBytes) {
    let (master_end, line_a) = tokio::io::duplex(1024);
    let (line_b, slave_end) = tokio::io::duplex(1024);
    let sent = LineBytes::default();
    let (a_read, a_write) = tokio::io::split(line_a);
    let (b_read, b_write) = tokio::io::split(line_b);
    tokio::spawn(pipe(a_read, b_write, Some(Arc::clone(&sent))));
    tokio::spawn(pipe(b_read, a_write, None));
    let mut tables = Tables::new(0, 0, 16, 0);
    tables.holding_registers[3] = 0x0BEE;
    let slave_config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    let slave = Slave::spawn(slave_config, tables, slave_end).unwrap();
    let master_config = MasterConfig {
        response_timeout: si_core::Duration::from_millis(50),
        retries: 0,
        ..MasterConfig::default()
    };
    let (port, closed) = reopen::watch(Box::new(master_end));
    let link = Master::spawn(master_config, port).unwrap();
    let mut stats = Stats::new(1);
    stats.health[0] = LineHealth::new(demotion);
    let stats = Arc::new(Mutex::new(stats));
    let queue = Arc::new(LineQueue::new(8));
    let log = LineLog {
        index: 0,
        name: "pipe".into(),
        stats: Arc::clone(&stats),
        events: si_gateway::event::ignore(),
    };
    let never = async || Err(si_gateway::Error::new("an in-memory pipe"));
    let first = Ok(Opened { link, closed });
    tokio::spawn(line::run(
        log,
        Arc::clone(&queue),
        first,
        never,
        Duration::ZERO,
    ));
    let mut routes = [None; 256];
    routes[1] = Some((0, 1));
    routes[2] = Some((0, 2));
    let router = Router {
        routes,
        lines: Arc::new([Arc::new(QueuedLine(queue)) as Arc<dyn Backend>]),
        broadcast_lines: vec![],
        diagnostic_unit: None,
        reply_on_broadcast: false,
        stats,
    };
    (router, slave, sent)
}

fn read(unit: u8) -> TcpAdu {
    let r = Request::ReadHoldingRegisters {
        address: 3,
        quantity: 1,
    };
    TcpAdu::request(7, unit, &r).unwrap()
}

fn peer(id: u64) -> Peer {
    Peer {
        id,
        addr: "127.0.0.1:9".parse().unwrap(),
    }
}

/// Two clients, each sending `REQUESTS` rounds of one request per unit in `units`; the live
/// unit's (unit 1's) response times of both.
async fn poll(router: &Arc<Router>, units: &'static [u8]) -> Vec<Duration> {
    let mut clients = Vec::new();
    for id in 1..=2 {
        let router = Arc::clone(router);
        clients.push(tokio::spawn(async move {
            let peer = peer(id);
            router.connected(&peer);
            let mut live = Vec::new();
            for _ in 0..REQUESTS {
                for &unit in units {
                    let started = Instant::now();
                    let answer = router.answer_from(&peer, read(unit)).await.unwrap();
                    let took = started.elapsed();
                    if unit == 1 {
                        assert_eq!(answer.unit_pdu(), [1, 0x03, 2, 0x0B, 0xEE]);
                        live.push(took);
                    } else {
                        assert_eq!(answer.unit_pdu(), [unit, 0x83, 0x0B]);
                    }
                }
            }
            live
        }));
    }
    let mut all = Vec::new();
    for c in clients {
        all.extend(c.await.unwrap());
    }
    all
}

fn p99(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[(times.len() * 99).div_ceil(100) - 1]
}

/// Requests to `unit` in the master's bytes: every request here is an 8-byte FC03.
fn requests_to(bytes: &[u8], unit: u8) -> usize {
    assert_eq!(bytes.len() % 8, 0, "whole FC03 requests");
    bytes.chunks(8).filter(|f| f[0] == unit).count()
}

async fn dead_unit_beside_a_live_one(
    demotion: DemotionConfig,
) -> (Duration, Duration, usize, usize) {
    let (router, _slave, sent) = gateway(demotion);
    let router = Arc::new(router);
    let alone = p99(poll(&router, &[1]).await);
    // The dead unit's first failures, in a row: it is demoted after the third.
    let probe = peer(3);
    router.connected(&probe);
    for _ in 0..3 {
        let answer = router.answer_from(&probe, read(2)).await.unwrap();
        assert_eq!(answer.unit_pdu(), [2, 0x83, 0x0B]);
    }
    let before = requests_to(&sent.lock().unwrap(), 2);
    let both = p99(poll(&router, &[1, 2]).await);
    let bytes = sent.lock().unwrap().clone();
    let during = requests_to(&bytes, 2) - before;
    (alone, both, before, during)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_demoted_unit_costs_the_live_one_nothing_and_gets_no_byte() {
    let (alone, both, before, during) =
        dead_unit_beside_a_live_one(DemotionConfig::default()).await;
    assert_eq!(before, 3, "three failed requests went to the line");
    assert_eq!(during, 0, "no byte for the dead unit while it is demoted");
    assert!(
        both <= 2 * alone,
        "the live unit's p99 {both:?} beside a demoted unit, {alone:?} without it"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn without_demotion_the_dead_unit_holds_the_line() {
    // The control: the same run with demotion off fails both claims above.
    let off = DemotionConfig {
        demote_after: 0,
        ..DemotionConfig::default()
    };
    let (_, both, _, during) = dead_unit_beside_a_live_one(off).await;
    assert_eq!(
        during,
        2 * REQUESTS,
        "every request to the dead unit went to the line"
    );
    // A live request queued behind one to the dead unit waits out its response timeout: a
    // lower bound that a loaded machine can only raise (a ratio to `alone` would not be).
    assert!(
        both >= Duration::from_millis(50),
        "the live unit's p99 {both:?}: it never waited behind the dead unit's 50 ms timeout"
    );
}
