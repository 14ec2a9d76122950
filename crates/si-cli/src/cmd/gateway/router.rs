//! The gateway's face to Modbus TCP: routes each request by its unit id to a line's queue,
//! answers the diagnostic unit itself, and keeps the counters per client.

use super::counters::{Client, Counters, Outcome, Stats};
use super::line::{self, exception, Job, LineQueue};
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::{Handler, Peer};
use std::sync::{Arc, Mutex};
use tokio::sync::oneshot;

/// Routes requests to lines.
pub struct Router {
    /// The line serving each unit id.
    pub routes: [Option<usize>; 256],
    /// Every line's queue, in configuration order.
    pub lines: Vec<Arc<LineQueue>>,
    /// The lines broadcasts (unit 0) go to; empty: broadcasts are refused with 0AH.
    pub broadcast_lines: Vec<usize>,
    /// The unit that answers the counters.
    pub diagnostic_unit: Option<u8>,
    /// Echo a broadcast once queued (mbusd's `-b`); otherwise no answer.
    pub reply_on_broadcast: bool,
    /// The counters.
    pub stats: Arc<Mutex<Stats>>,
}

impl Router {
    /// The answer to `request` from client `id`.
    async fn route(&self, id: u64, request: TcpAdu) -> Option<TcpAdu> {
        self.count_client(id, |c| c.requests += 1);
        let unit = request.unit();
        if Some(unit) == self.diagnostic_unit {
            let answer = self.diagnostics(id, &request);
            let outcome = if answer.function() & 0x80 == 0 {
                Outcome::Answer
            } else {
                Outcome::Other
            };
            self.count_client(id, |c| c.count(outcome));
            return Some(answer);
        }
        if unit == 0 {
            return self.broadcast(id, request);
        }
        let Some(index) = self.routes[unit as usize] else {
            self.count_client(id, |c| c.count(Outcome::Other));
            return Some(exception(&request, line::GATEWAY_PATH_UNAVAILABLE));
        };
        let (tx, rx) = oneshot::channel();
        let job = Job {
            request,
            reply: Some(tx),
        };
        if self.enqueue(id, index, job).is_err() {
            return Some(exception(&request, line::SLAVE_DEVICE_BUSY));
        }
        // The line task dropped the job without an answer only if it ended: the path is gone.
        Some(
            rx.await
                .unwrap_or_else(|_| exception(&request, line::GATEWAY_PATH_UNAVAILABLE)),
        )
    }

    /// Queue `job` on line `index` for client `id`, counting it; busy (06H, counted) if full.
    fn enqueue(&self, id: u64, index: usize, job: Job) -> Result<(), ()> {
        let pushed = self.lines[index].push(id, job);
        let mut s = line::lock(&self.stats);
        let depth = match pushed {
            Some(depth) => depth,
            None => {
                s.lines[index].count(Outcome::Busy);
                if let Some(c) = s.client(id) {
                    c.count(Outcome::Busy);
                }
                return Err(());
            }
        };
        s.lines[index].requests += 1;
        s.lines[index].queue_depth = depth as u64;
        if let Some(c) = s.client(id) {
            c.queue_depth += 1;
        }
        Ok(())
    }

    /// A broadcast: queued on every line that allows them, with no answer (or its echo).
    fn broadcast(&self, id: u64, request: TcpAdu) -> Option<TcpAdu> {
        if self.broadcast_lines.is_empty() {
            self.count_client(id, |c| c.count(Outcome::Other));
            return Some(exception(&request, line::GATEWAY_PATH_UNAVAILABLE));
        }
        for &index in &self.broadcast_lines {
            let job = Job {
                request,
                reply: None,
            };
            // A full queue drops the broadcast (counted as busy): there is no answer to
            // carry an exception.
            let _ = self.enqueue(id, index, job);
        }
        self.reply_on_broadcast.then_some(request)
    }

    /// The diagnostic unit's answer: FC 04 over the counter registers ([`super::counters`]).
    fn diagnostics(&self, id: u64, request: &TcpAdu) -> TcpAdu {
        let pdu = request.unit_pdu();
        if request.function() != 0x04 || pdu.len() != 6 {
            return exception(request, 0x01);
        }
        let start = u16::from_be_bytes([pdu[2], pdu[3]]) as usize;
        let quantity = u16::from_be_bytes([pdu[4], pdu[5]]) as usize;
        if !(1..=125).contains(&quantity) {
            return exception(request, 0x03);
        }
        let registers = line::lock(&self.stats).registers(id);
        let Some(values) = registers.get(start..start + quantity) else {
            return exception(request, 0x02);
        };
        let mut answer = Vec::with_capacity(3 + 2 * quantity);
        answer.extend_from_slice(&[request.unit(), 0x04, (2 * quantity) as u8]);
        answer.extend(values.iter().flat_map(|v| v.to_be_bytes()));
        TcpAdu::from_unit_pdu(request.transaction(), &answer).unwrap_or_default()
    }

    fn count_client(&self, id: u64, f: impl FnOnce(&mut Counters)) {
        if let Some(c) = line::lock(&self.stats).client(id) {
            f(c);
        }
    }
}

impl Handler for Router {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        self.route(0, request).await
    }

    async fn answer_from(&self, peer: &Peer, request: TcpAdu) -> Option<TcpAdu> {
        self.route(peer.id, request).await
    }

    fn connected(&self, peer: &Peer) {
        line::lock(&self.stats).clients.insert(
            peer.id,
            Client {
                peer: peer.addr,
                counters: Counters::default(),
            },
        );
    }

    fn disconnected(&self, peer: &Peer) {
        line::lock(&self.stats).clients.remove(&peer.id);
    }
}
