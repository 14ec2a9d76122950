//! One Modbus RTU line behind the gateway: its queue, and the task that takes requests from it
//! one at a time (the master has one job at a time, [Modbus/USS] §3.4.2), sends each
//! through si-modbus's RTU master with the line's retries, and hands the answer back; while
//! the line's port is closed, the task answers 0AH and reopens it ([`super::reopen`]). A unit
//! that stops answering is demoted ([`super::demotion`]): its requests are answered 0BH at
//! once, without a byte on the line, until one probe finds it again.

use super::counters::{Outcome, Stats};
use super::demotion::{Admit, Change};
use super::quantities;
use super::queue::FairQueue;
use super::reopen::{self, Closed, LineLog, Opened};
use si_core::driver::Clock;
use si_modbus::frame::{DecodeErrorKind, ExceptionCode};
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::{Error, Master};
use si_modbus::{serve, status};
use std::convert::Infallible;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::{oneshot, Notify};

/// Exception 01H: a function the line or its image does not serve.
pub const ILLEGAL_FUNCTION: u8 = ExceptionCode::IllegalFunction.code();
/// Exception 02H: registers outside the line's map.
pub const ILLEGAL_DATA_ADDRESS: u8 = ExceptionCode::IllegalDataAddress.code();
/// Exception 03H: a value (quantity, command, length) out of range.
pub const ILLEGAL_DATA_VALUE: u8 = ExceptionCode::IllegalDataValue.code();
/// Exception 04H: what mbusd answers for a corrupt answer after its retries (`MB_EX_CRC` in
/// mbusd's `src/modbus.h`); we also use it for any other malformed answer.
pub const SLAVE_DEVICE_FAILURE: u8 = ExceptionCode::SlaveDeviceFailure.code();
/// Exception 06H: the line's queue is full.
pub const SLAVE_DEVICE_BUSY: u8 = ExceptionCode::SlaveDeviceBusy.code();
/// Exception 0AH: no line serves the unit, or its line is down (Modbus application protocol
/// V1.1b3 §7, "gateway path unavailable").
pub const GATEWAY_PATH_UNAVAILABLE: u8 = ExceptionCode::GatewayPathUnavailable.code();
/// Exception 0BH: the slave did not answer ([Modbus AP] §7, "gateway target device failed to respond").
pub const GATEWAY_TARGET_FAILED: u8 = ExceptionCode::GatewayTargetFailed.code();

/// A request waiting for a line, with where its answer goes (`None`: a broadcast).
pub struct Job {
    /// The request as the client sent it.
    pub request: TcpAdu,
    /// The waiting client.
    pub reply: Option<oneshot::Sender<TcpAdu>>,
}

/// A line's queue, shared by the router (pushes) and the line task (pops).
pub struct LineQueue {
    queue: Mutex<FairQueue<Job>>,
    ready: Notify,
}

impl LineQueue {
    /// An empty queue of `capacity` requests.
    pub fn new(capacity: usize) -> Self {
        LineQueue {
            queue: Mutex::new(FairQueue::new(capacity)),
            ready: Notify::new(),
        }
    }

    /// Queue a job for `client`: the queue depth after it, or `None` when the queue is full
    /// (the job is dropped; the caller answers 06H).
    pub fn push(&self, client: u64, job: Job) -> Option<usize> {
        let mut q = lock(&self.queue);
        q.push(client, job).ok()?;
        let depth = q.len();
        drop(q);
        self.ready.notify_one();
        Some(depth)
    }

    /// The next job in fair order, waiting for one; the client and the depth left.
    pub async fn pop(&self) -> (u64, Job, usize) {
        loop {
            {
                let mut q = lock(&self.queue);
                if let Some((client, job)) = q.pop() {
                    return (client, job, q.len());
                }
            }
            // A push between the check and here leaves a permit, so nothing is missed.
            self.ready.notified().await;
        }
    }
}

pub use crate::sync::lock;

/// Serve line `log.index` until the process ends: one request at a time, then the pause.
/// While its port is closed every request is answered with 0AH and the port is reopened with
/// `open` ([`super::reopen`]).
pub async fn run(
    log: LineLog,
    queue: Arc<LineQueue>,
    first: reopen::First<Master>,
    open: impl AsyncFnMut() -> Result<Opened<Master>, crate::Error>,
    pause: Duration,
) {
    // The closures own what their futures use: a future borrowing from the task would not
    // be `Send` for every lifetime, which `tokio::spawn` asks.
    let (index, stats) = (log.index, Arc::clone(&log.stats));
    let (q, events) = (Arc::clone(&queue), log.clone());
    // The demotion times of the line's units, on si-core's clock: one for the task, so they
    // stay comparable across reopenings (a restarted line's units start healthy).
    let clock = Clock::start();
    reopen::supervise(
        log,
        first,
        open,
        move |master, closed| serve(events.clone(), Arc::clone(&q), master, closed, pause, clock),
        move || refuse(index, Arc::clone(&queue), Arc::clone(&stats)),
    )
    .await;
}

/// Serve the queue through `master` until its port closes: why it closed.
async fn serve(
    log: LineLog,
    queue: Arc<LineQueue>,
    mut master: Master,
    mut closed: Closed,
    pause: Duration,
    clock: Clock,
) -> String {
    let (index, stats) = (log.index, Arc::clone(&log.stats));
    let now = || clock.now();
    // The master keeps its gap of silence after the last character received before the next
    // request, on the driver's precise timer; a pause no longer than the gap is kept by that
    // and needs no sleep of its own (tokio's 1 ms wheel would make a 1 ms sleep 1–2 ms). The
    // pause after a broadcast, which has no answer to count the gap from, is always slept.
    let gap: Duration = master
        .call(|m, _| m.gap())
        .await
        .map_or(Duration::ZERO, Duration::from);
    loop {
        let (client, job, depth) = tokio::select! {
            why = &mut closed => return why,
            next = queue.pop() => next,
        };
        taken(index, &stats, client, depth);
        let unit = job.request.unit();
        // Broadcasts (unit 0) have no answer to judge a unit by.
        if unit != 0 && lock(&stats).health[index].admit(unit, now()) == Admit::Refuse {
            let answer = exception(&job.request, GATEWAY_TARGET_FAILED);
            answered(
                index,
                &stats,
                client,
                job,
                Some(answer),
                Outcome::Demoted,
                0,
            );
            continue;
        }
        let started = tokio::time::Instant::now();
        let (answer, outcome, crc_errors, sent) = forward(&mut master, &job.request).await;
        let event = {
            let mut s = lock(&stats);
            if sent > 0 {
                let seconds = started.elapsed().as_secs_f64();
                s.metrics.response_time(index, seconds);
                s.metrics.retried(index, unit, (sent - 1).into());
            }
            let event = match (unit, verdict(outcome, answer.as_ref())) {
                (0, _) => None,
                (_, None) => {
                    s.health[index].inconclusive(unit, now());
                    None
                }
                (_, Some(true)) => s.health[index].succeeded(unit),
                (_, Some(false)) => s.health[index].failed(unit, now()),
            };
            if let Some(e) = event {
                s.metrics.demotion_event(index, change_name(e));
            }
            event
        };
        if let Some(e) = event {
            report(&log, e);
        }
        answered(index, &stats, client, job, answer, outcome, crc_errors);
        if !pause.is_zero() && (pause > gap || unit == 0) {
            tokio::time::sleep(pause).await;
        }
    }
}

/// Whether an outcome shows the unit alive (`true`: an answer, the slave's exception too),
/// dead (`false`: no answer, or still corrupt after the retries, 04H), or says nothing of it
/// (the gateway refused the request itself, or the port closed).
fn verdict(outcome: Outcome, answer: Option<&TcpAdu>) -> Option<bool> {
    match outcome {
        Outcome::Answer | Outcome::Exception => Some(true),
        Outcome::Timeout => Some(false),
        Outcome::Other => {
            let code = answer.and_then(|a| a.unit_pdu().get(2).copied());
            (code == Some(SLAVE_DEVICE_FAILURE)).then_some(false)
        }
        Outcome::Busy | Outcome::Sent | Outcome::Demoted => None,
    }
}

/// The metrics label of a demotion change.
fn change_name(c: Change) -> &'static str {
    match c {
        Change::Demoted { .. } => "demoted",
        Change::ProbeFailed { .. } => "probe_failed",
        Change::Restored { .. } => "restored",
    }
}

/// Hand a demotion change to the program's event sink.
fn report(log: &LineLog, c: Change) {
    let (line, name) = (log.index, log.name.clone());
    let event = match c {
        Change::Demoted {
            unit,
            failures,
            for_ms,
        } => crate::Event::UnitDemoted {
            line,
            name,
            unit,
            failures,
            for_ms,
        },
        Change::ProbeFailed { unit, for_ms } => crate::Event::UnitProbeFailed {
            line,
            name,
            unit,
            for_ms,
        },
        Change::Restored { unit } => crate::Event::UnitRestored { line, name, unit },
    };
    (log.events)(&event);
}

/// While the line is down: every request it takes is answered with 0AH, "gateway path
/// unavailable" ([Modbus/USS] §3.6), at once. Every queued line kind (RTU, RK 512) refuses so.
pub async fn refuse(index: usize, queue: Arc<LineQueue>, stats: Arc<Mutex<Stats>>) -> Infallible {
    loop {
        let (client, job, depth) = queue.pop().await;
        taken(index, &stats, client, depth);
        let answer = exception(&job.request, GATEWAY_PATH_UNAVAILABLE);
        answered(index, &stats, client, job, Some(answer), Outcome::Other, 0);
    }
}

/// A job left the queue: the depths of the line and of its client. Every queued line kind
/// counts through this and [`answered`].
pub fn taken(index: usize, stats: &Mutex<Stats>, client: u64, depth: usize) {
    let mut s = lock(stats);
    s.lines[index].queue_depth = depth as u64;
    if let Some(c) = s.client(client) {
        c.queue_depth = c.queue_depth.saturating_sub(1);
    }
}

/// Count what became of `job` for the line and its client (`crc_errors`: the corrupt answers
/// its attempts met, 0 where there is no CRC to check), and hand the answer back.
pub fn answered(
    index: usize,
    stats: &Mutex<Stats>,
    client: u64,
    job: Job,
    answer: Option<TcpAdu>,
    outcome: Outcome,
    crc_errors: u8,
) {
    {
        let mut s = lock(stats);
        let line = &mut s.lines[index];
        line.count(outcome);
        line.crc_errors += u64::from(crc_errors);
        if let Some(c) = s.client(client) {
            c.count(outcome);
            c.crc_errors += u64::from(crc_errors);
        }
        let unit = job.request.unit();
        s.count_request(index, unit, outcome, answer.as_ref(), crc_errors.into());
    }
    if let (Some(reply), Some(answer)) = (job.reply, answer) {
        // The client may have gone; its answer is then dropped.
        let _ = reply.send(answer);
    }
}

/// Send one request through the RTU master: the slave's answer with the client's transaction
/// id (exceptions as they are), or the gateway's own exception; and the corrupt answers its
/// attempts met ([`si_modbus::master::Attempts`]), counted even when a retry cured them; and
/// the requests put on the line (0 if the gateway answered itself, 1 + the retries).
async fn forward(master: &mut Master, request: &TcpAdu) -> (Option<TcpAdu>, Outcome, u8, u8) {
    let broadcast = request.unit() == 0;
    if quantities::out_of_range(request.unit_pdu()) {
        let answer = (!broadcast).then(|| exception(request, ILLEGAL_DATA_VALUE));
        return (answer, Outcome::Other, 0, 0);
    }
    let (result, attempts) = match request.decode_request() {
        Ok((unit, r)) => master.request_with_attempts(unit, &r).await,
        // A function code the RTU master does not know passes through to the slave as it is,
        // as mbusd does since 0.5.3: its answer ends by the gap, an exception by its length.
        Err(e) if e.kind == DecodeErrorKind::Function && !broadcast => {
            master.request_pass_through(request.unit_pdu()).await
        }
        Err(e) => {
            let code = serve::refusal(e.kind).0.code();
            return (Some(exception(request, code)), Outcome::Other, 0, 0);
        }
    };
    let (crc_errors, sent) = (attempts.crc_errors, attempts.sent);
    let (code, outcome) = match result {
        Ok(done) => {
            let answer = done.response_bytes().and_then(|rtu| {
                // The RTU frame without its CRC is unit + PDU, what MBAP carries.
                let unit_pdu = rtu.get(..rtu.len().saturating_sub(2))?;
                TcpAdu::from_unit_pdu(request.transaction(), unit_pdu).ok()
            });
            return match answer {
                Some(a) => (Some(a), Outcome::Answer, crc_errors, sent),
                None if broadcast => (None, Outcome::Sent, crc_errors, sent),
                None => (
                    Some(exception(request, SLAVE_DEVICE_FAILURE)),
                    Outcome::Other,
                    crc_errors,
                    sent,
                ),
            };
        }
        Err(Error::Failed {
            exception: Some(code),
            ..
        }) => {
            // The slave's exception ([Modbus/USS] §3.3.6, Table 3-12), passed through unchanged.
            (code, Outcome::Exception)
        }
        Err(Error::Failed { status: s, .. }) => match s {
            _ if s == status::RESPONSE_TIMEOUT => (GATEWAY_TARGET_FAILED, Outcome::Timeout),
            // Still corrupt after the retries (0E57H) or otherwise bad: 04H; the corrupt
            // answers are in `crc_errors`.
            _ => (SLAVE_DEVICE_FAILURE, Outcome::Other),
        },
        // The master's own checks ([Modbus/USS] §3.4.5–§3.4.16): a function it does not know or that may not be
        // broadcast is 01H, a quantity out of range 03H, as a slave would answer.
        Err(Error::Refused { reason, .. }) => {
            let s = reason.status();
            let function =
                s == status::INVALID_FUNCTION || s == status::BROADCAST_NOT_ALLOWED_FOR_FC;
            (if function { 0x01 } else { 0x03 }, Outcome::Other)
        }
        // The port closed under the job: the line is going down ([`super::reopen`]).
        Err(_) => (GATEWAY_PATH_UNAVAILABLE, Outcome::Other),
    };
    if broadcast {
        return (None, outcome, crc_errors, sent);
    }
    (Some(exception(request, code)), outcome, crc_errors, sent)
}

/// Exception `code` in answer to `request`, with its transaction and unit id.
pub fn exception(request: &TcpAdu, code: u8) -> TcpAdu {
    let pdu = [request.unit(), request.function() | 0x80, code];
    TcpAdu::from_unit_pdu(request.transaction(), &pdu).unwrap_or_default()
}

/// The answer or exception to `adu`, and how it is counted, for every line kind that answers
/// itself (USS, RK 512, 3964(R)): refusals of the image, the store or the partner are the
/// unit's exceptions, as an RTU slave's would be; 0BH a timeout, 06H busy, 0AH other.
pub fn counted(adu: &TcpAdu, result: Result<TcpAdu, u8>) -> (TcpAdu, Outcome) {
    match result {
        Ok(answer) => (answer, Outcome::Answer),
        Err(code) => {
            let outcome = match code {
                GATEWAY_TARGET_FAILED => Outcome::Timeout,
                SLAVE_DEVICE_BUSY => Outcome::Busy,
                GATEWAY_PATH_UNAVAILABLE => Outcome::Other,
                _ => Outcome::Exception,
            };
            (exception(adu, code), outcome)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_line_kind_counts_its_own_answers_one_way() {
        let adu = TcpAdu::from_unit_pdu(7, &[5, 0x03, 0, 0, 0, 1]).unwrap();
        let outcome = |code| counted(&adu, Err(code)).1;
        assert_eq!(outcome(0x02), Outcome::Exception, "the unit's own refusal");
        assert_eq!(outcome(0x01), Outcome::Exception);
        assert_eq!(outcome(GATEWAY_TARGET_FAILED), Outcome::Timeout);
        assert_eq!(outcome(SLAVE_DEVICE_BUSY), Outcome::Busy);
        assert_eq!(outcome(GATEWAY_PATH_UNAVAILABLE), Outcome::Other);
        let (answer, o) = counted(&adu, Err(0x02));
        assert_eq!(
            (answer.transaction(), answer.unit_pdu()),
            (7, &[5, 0x83, 0x02][..])
        );
        assert_eq!(o, Outcome::Exception);
    }
}
