//! The gateway's face to Modbus TCP: routes each request by its unit id to a line's queue (or
//! to a USS line's drive images or a 3964(R) line's blocks),
//! answers the diagnostic unit itself, and keeps the counters per client.

use super::backend::{Backend, Reach};
use super::counters::{Client, Counters, Outcome, Stats};
use super::line::{self, exception, Job, LineQueue};
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::{Handler, Peer};
use std::sync::{Arc, Mutex};
use tokio::sync::oneshot;

/// Routes requests to lines.
#[derive(Clone)]
pub struct Router {
    /// The line serving each unit id, and the unit's address on that line (the unit id
    /// itself unless the line's `unit_map` remaps it).
    pub routes: [Option<(usize, u8)>; 256],
    /// Every line, in configuration order (shared by the listening addresses, [`super::faces`]).
    pub lines: Arc<[Arc<dyn Backend>]>,
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
        let Some((index, address)) = self.routes[unit as usize] else {
            self.count_client(id, |c| c.count(Outcome::Other));
            return Some(exception(&request, line::GATEWAY_PATH_UNAVAILABLE));
        };
        if address == unit {
            return self.to_line(id, index, request).await;
        }
        // The slave answers its own address; the client gets the unit id it asked.
        let answer = self.to_line(id, index, with_unit(&request, address)).await;
        answer.map(|a| with_unit(&a, unit))
    }

    /// The answer of line `index` to `request` (its unit id the line's own address).
    async fn to_line(&self, id: u64, index: usize, request: TcpAdu) -> Option<TcpAdu> {
        let queue = match self.lines[index].reach(&request) {
            Reach::Queue(queue) => queue,
            Reach::Answer(answer) => {
                let (answer, outcome) = answer.await;
                let mut s = line::lock(&self.stats);
                s.lines[index].requests += 1;
                s.lines[index].count(outcome);
                if let Some(c) = s.client(id) {
                    c.count(outcome);
                }
                s.count_request(index, request.unit(), outcome, Some(&answer), 0);
                return Some(answer);
            }
        };
        let (tx, rx) = oneshot::channel();
        let job = Job {
            request,
            reply: Some(tx),
        };
        if self.enqueue(id, index, queue, job).is_err() {
            return Some(exception(&request, line::SLAVE_DEVICE_BUSY));
        }
        // The line task dropped the job without an answer only if it ended: the path is gone.
        Some(
            rx.await
                .unwrap_or_else(|_| exception(&request, line::GATEWAY_PATH_UNAVAILABLE)),
        )
    }

    /// Queue `job` on line `index` for client `id`, counting it; busy (06H, counted) if full.
    fn enqueue(&self, id: u64, index: usize, queue: &LineQueue, job: Job) -> Result<(), ()> {
        // The counters are locked before the push: a line task taking the job at once then
        // writes its depth after ours, never a stale one over it. (No one holds the queue's
        // lock while taking the counters', so the order cannot deadlock.)
        let mut s = line::lock(&self.stats);
        let request = job.request;
        let pushed = queue.push(id, job);
        // Every request routed to the line counts, a refused one too: its outcomes add up.
        s.lines[index].requests += 1;
        let depth = match pushed {
            Some(depth) => depth,
            None => {
                let busy = exception(&request, line::SLAVE_DEVICE_BUSY);
                s.count_request(index, request.unit(), Outcome::Busy, Some(&busy), 0);
                s.lines[index].count(Outcome::Busy);
                if let Some(c) = s.client(id) {
                    c.count(Outcome::Busy);
                }
                return Err(());
            }
        };
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
            // carry an exception. Only queued lines take broadcasts (checked at load).
            if let Reach::Queue(queue) = self.lines[index].reach(&request) {
                let _ = self.enqueue(id, index, queue, job);
            }
        }
        self.reply_on_broadcast.then_some(request)
    }

    /// The diagnostic unit's answer: FC 04 over the counter registers ([`super::counters`]).
    fn diagnostics(&self, id: u64, request: &TcpAdu) -> TcpAdu {
        let pdu = request.unit_pdu();
        if request.function() != 0x04 || pdu.len() != 6 {
            return exception(request, line::ILLEGAL_FUNCTION);
        }
        let start = u16::from_be_bytes([pdu[2], pdu[3]]) as usize;
        let quantity = u16::from_be_bytes([pdu[4], pdu[5]]) as usize;
        if !(1..=125).contains(&quantity) {
            return exception(request, line::ILLEGAL_DATA_VALUE);
        }
        let registers = line::lock(&self.stats).registers(id);
        let Some(values) = registers.get(start..start + quantity) else {
            return exception(request, line::ILLEGAL_DATA_ADDRESS);
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

/// `adu` with unit id `unit`.
fn with_unit(adu: &TcpAdu, unit: u8) -> TcpAdu {
    let pdu = adu.unit_pdu();
    let mut bytes = [0u8; 256];
    let n = pdu.len().min(bytes.len());
    bytes[..n].copy_from_slice(&pdu[..n]);
    bytes[0] = unit;
    TcpAdu::from_unit_pdu(adu.transaction(), &bytes[..n]).unwrap_or(*adu)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reopen::{self, LineLog, Opened};
    use si_modbus::frame::Request;
    use si_modbus::slave::Tables;
    use si_modbus::tokio::{Master, Slave};
    use si_modbus::{MasterConfig, SlaveConfig};

    /// A router with one line (units 7 and 8) to a slave at address 7 over an in-memory pipe;
    /// unit 8 never answers. Diagnostic unit 247.
    fn router() -> (Router, Slave<Tables>) {
        let (a, b) = tokio::io::duplex(1024);
        let mut tables = Tables::new(0, 0, 4, 0);
        tables.holding_registers[2] = 0x1234;
        let slave_config = SlaveConfig {
            address: 7,
            ..SlaveConfig::default()
        };
        let slave = Slave::spawn(slave_config, tables, b).unwrap();
        let master_config = MasterConfig {
            response_timeout: si_core::Duration::from_millis(50),
            retries: 1,
            ..MasterConfig::default()
        };
        let (port, closed) = reopen::watch(Box::new(a));
        let link = Master::spawn(master_config, port).unwrap();
        let stats = Arc::new(Mutex::new(Stats::new(1)));
        let queue = Arc::new(LineQueue::new(4));
        let log = LineLog {
            index: 0,
            name: "pipe".into(),
            stats: Arc::clone(&stats),
            events: crate::event::ignore(),
        };
        let never = async || Err(crate::Error::new("an in-memory pipe"));
        let first = Ok(Opened { link, closed });
        let pause = std::time::Duration::ZERO;
        tokio::spawn(line::run(log, Arc::clone(&queue), first, never, pause));
        let mut routes = [None; 256];
        routes[7] = Some((0, 7));
        routes[8] = Some((0, 8));
        let router = Router {
            routes,
            lines: Arc::new([Arc::new(crate::backend::QueuedLine(queue)) as Arc<dyn Backend>]),
            broadcast_lines: vec![],
            diagnostic_unit: Some(247),
            reply_on_broadcast: false,
            stats,
        };
        (router, slave)
    }

    fn read(transaction: u16, unit: u8, address: u16) -> TcpAdu {
        let r = Request::ReadHoldingRegisters {
            address,
            quantity: 1,
        };
        TcpAdu::request(transaction, unit, &r).unwrap()
    }

    async fn ask(router: &Router, request: TcpAdu) -> Vec<u8> {
        let answer = router.route(1, request).await.expect("an answer");
        assert_eq!(answer.transaction(), request.transaction());
        answer.unit_pdu().to_vec()
    }

    #[tokio::test]
    async fn answers_exceptions_and_gateway_exceptions() {
        let (router, _slave) = router();
        let peer = Peer {
            id: 1,
            addr: "127.0.0.1:9".parse().unwrap(),
        };
        router.connected(&peer);
        assert_eq!(ask(&router, read(1, 7, 2)).await, [7, 0x03, 2, 0x12, 0x34]);
        // Past the slave's table: its exception 02, unchanged.
        assert_eq!(ask(&router, read(2, 7, 9)).await, [7, 0x83, 0x02]);
        assert_eq!(ask(&router, read(3, 8, 0)).await, [8, 0x83, 0x0B]);
        assert_eq!(ask(&router, read(4, 9, 0)).await, [9, 0x83, 0x0A]);
        assert_eq!(ask(&router, read(5, 0, 0)).await, [0, 0x83, 0x0A]);
        assert_eq!(ask(&router, read(6, 247, 0)).await, [247, 0x83, 0x01]);
        let diag = TcpAdu::from_unit_pdu(7, &[247, 0x04, 0, 16, 0, 8]).unwrap();
        let line = ask(&router, diag).await;
        // Line block: 3 requests, 1 answer, 1 exception, 1 timeout.
        assert_eq!(line[..3], [247, 0x04, 16]);
        let words: Vec<u16> = line[3..]
            .chunks(2)
            .map(|w| u16::from_be_bytes([w[0], w[1]]))
            .collect();
        assert_eq!(words, [0, 3, 0, 1, 0, 1, 0, 1]);
        let own = line::lock(&router.stats).clients[&1].counters;
        assert_eq!((own.requests, own.other), (7, 3));
        router.disconnected(&peer);
        assert!(line::lock(&router.stats).clients.is_empty());
    }
}
