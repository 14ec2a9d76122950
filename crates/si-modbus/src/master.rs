//! The Modbus master engine ([Modbus/USS] §3.3.2, §3.3.5–§3.4.3, Table 3-11, Table 3-17, §3.4).
//!
//! One request at a time. After the request has left the line the master waits "Response
//! Time" (50–655 000 ms) for the **start** of a response ([Modbus/USS] §3.4.3, Table 3-17, 0830H);
//! the response ends at the end-of-frame gap ([Modbus/USS] §3.3.5, Table 3-11) and is then checked
//! in the order of §3.4.5–§3.4.16: address (0831H, Normal mode), CRC (0E57H), function code (0E51H,
//! or an exception 0E61H–0E67H), lengths and byte counts (0E52H–0E55H), echoed fields (0E56H). A
//! broadcast (address 0, FC05/06/15/16 only, else 0E43H) completes after the turnaround delay
//! without waiting for a reply.
//!
//! Every job ends in exactly one [`MasterEvent::Completed`] or [`MasterEvent::Failed`], and
//! within [`MasterConfig::job_bound`] whatever the line does (host bound; the
//! crate docs, "Bounds"): a response that has started must be whole within
//! [`MasterConfig::max_response_duration`], else the attempt ends with 0830H as if nothing had
//! come (a retry follows if configured); a request held for silence (`FrameEnd::Length`) goes
//! out after that long even if the line never goes quiet; and whatever is left when the job's
//! bound passes (a flood, a state that never moves) fails the job with 0830H; a job started
//! while the quiet guard after a timeout holds the line ([`crate::quiet_guard`], off unless
//! set) has that guard's bound added. **Reading
//! chosen** for the STATUS: 0830H "no response start within Response Time" ([Modbus/USS] §3.6)
//! rather than a frame error, because noise that never forms a frame is no response at all, and a
//! frame that does end is still judged by [Modbus/USS] §3.4.5–§3.4.16 (0831H, 0E57H, …) as before.
//!
//! With [`FrameEnd::Length`] (a host extension, see there) a response also ends as soon as it
//! has the length its function code and byte count predict and its CRC checks
//! ([`crate::rx::response_len`]). The job then completes at once, but the line has not yet
//! been silent for the gap: the module's master never starts a request before it has ([Modbus/USS]
//! §3.3.5, Table 3-11, frames are separated by silence), so the next request waits until the gap
//! has passed since the last character received, and other stations on an RS-485 line still see two
//! frames.

use crate::config::{FrameEnd, MasterConfig, Mode};
use crate::frame::{self, fc, Adu, Request, Response, BROADCAST};
use crate::quiet_guard::QuietGuard;
use crate::rx::{Counters, Expect, Fault, FrameAt, Receiver};
use crate::status;
use crate::transmitter::{Gate, Transmitter};
use si_core::job::{JobId, JobSlot};
use si_core::{Duration, Engine, Instant, Interface, LineError, ModemSignals, Output, Status};
use std::collections::VecDeque;

/// A finished job: the request and, unless it was a broadcast, the checked response.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Completion {
    job: JobId,
    request: Adu,
    response: Option<Adu>,
}

impl Completion {
    /// The job this completes (the id [`Master::request`] returned).
    pub fn job(&self) -> JobId {
        self.job
    }

    /// The slave address the request went to (0 for a broadcast).
    pub fn unit(&self) -> u8 {
        self.request.unit()
    }

    /// The request as sent.
    pub fn request(&self) -> Request<'_> {
        frame::decode_unit_pdu_request(unit_pdu(&self.request))
            .map(|(_, r)| r)
            .unwrap_or(Request::ReadExceptionStatus)
    }

    /// The response, `None` for a broadcast. Coil and input reads are cut to the quantity
    /// requested.
    pub fn response(&self) -> Option<Response<'_>> {
        let pdu = unit_pdu(self.response.as_ref()?);
        if let Some(r) = frame::register_response(pdu) {
            return Some(r);
        }
        let (_, r) = frame::decode_unit_pdu_response(pdu).ok()?;
        // Only bit reads need the request (for its quantity): decoding it for every response
        // would cost a round trip more than the rest of the decode.
        Some(match r {
            Response::ReadCoils(b) => match self.request() {
                Request::ReadCoils { quantity, .. } => Response::ReadCoils(b.truncate(quantity)),
                _ => Response::ReadCoils(b),
            },
            Response::ReadDiscreteInputs(b) => match self.request() {
                Request::ReadDiscreteInputs { quantity, .. } => {
                    Response::ReadDiscreteInputs(b.truncate(quantity))
                }
                _ => Response::ReadDiscreteInputs(b),
            },
            r => r,
        })
    }

    /// The response ADU as received (CRC included).
    pub fn response_bytes(&self) -> Option<&[u8]> {
        self.response.as_ref().map(Adu::as_bytes)
    }

    /// Make this the completion of `job` with these ADUs, copying only their bytes into the
    /// buffers it has (the engine's kept last completion).
    fn refill(&mut self, job: JobId, request: &[u8], response: Option<&[u8]>) {
        self.job = job;
        self.request.fill(request);
        match (self.response.as_mut(), response) {
            (Some(adu), Some(bytes)) => {
                adu.fill(bytes);
            }
            (None, Some(bytes)) => self.response = Adu::from_slice(bytes),
            (_, None) => self.response = None,
        }
    }
}

/// `unit | PDU` of an ADU whose CRC is known good (computed when the request was encoded,
/// checked when the response was received), so reading it again skips the CRC.
fn unit_pdu(adu: &Adu) -> &[u8] {
    let bytes = adu.as_bytes();
    &bytes[..bytes.len().saturating_sub(2)]
}

/// What the attempts of one job met (a host extension): a job whose first response
/// was corrupt and whose retry was answered completes like any other, and a gateway that counts
/// CRC errors per line must still see the corrupt answer. Counts saturate at 255; a job has at
/// most 16 attempts (retries 0–15, [Modbus/USS] §3.4.3, Table 3-17).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Attempts {
    /// Requests put on the line (1 + the retries used).
    pub sent: u8,
    /// Attempts ended by a response whose CRC was wrong (0E57H, [Modbus/USS] §3.4.5–§3.4.16).
    pub crc_errors: u8,
    /// Attempts ended without a response (0830H, [Modbus/USS] §3.4.3, Table 3-17).
    pub timeouts: u8,
}

/// What the master reports.
///
/// A completion carries its request and response inline (no heap per frame), which makes
/// this enum large; that is deliberate.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MasterEvent {
    /// The job succeeded.
    Completed(Completion),
    /// The job failed with the manual's STATUS (an exception response is 0E61H–0E67H).
    Failed {
        /// The job (the id [`Master::request`] returned).
        job: JobId,
        /// The slave address of the job.
        unit: u8,
        /// Its function code.
        function: u8,
        /// Why.
        status: Status,
    },
    /// Something on the line outside a job (0E50H unsolicited response, a line error between
    /// jobs in Normal mode).
    Diagnostic(Status),
}

/// Why [`Master::request`] refused a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// A job is running; one at a time ([Modbus/USS] §3.4.2).
    #[error("a job is already running")]
    Busy,
    /// The job breaks a rule of [Modbus/USS] §3.4.5–§3.4.16 (0E42H–0E4AH).
    #[error("job refused: {0}")]
    Invalid(Status),
}

impl RequestError {
    /// The STATUS the module would report for this job.
    pub fn status(&self) -> Status {
        match self {
            RequestError::Busy => si_core::status::common::NOT_POSSIBLE_IN_MODE,
            RequestError::Invalid(s) => *s,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Idle,
    /// A job waits for the line to be silent for the gap since the last character received
    /// ([`FrameEnd::Length`] only: a response ended by its length, [Modbus/USS] §3.3.5, Table
    /// 3-11).
    Holding {
        until: Instant,
    },
    /// The request is on the line until `until` (or tx-done).
    Sending {
        until: Instant,
    },
    /// Waiting for the start of the response until `deadline`, and for its end until `limit`
    /// (`deadline` + [`MasterConfig::max_response_duration`]).
    Waiting {
        deadline: Instant,
        limit: Instant,
    },
    /// Automatic V.24 ([Modbus/USS] §3.2.2): RTS is on, the request waits for CTS = ON.
    WaitCts,
    /// After a broadcast, until the turnaround delay is over.
    Turnaround {
        until: Instant,
    },
}

/// An event as the engine queues it: a completion is queued as a mark standing for the kept
/// last completion (`Master::last_completion`), so its ADUs are filled once per job, there, and
/// copied whole only when [`Engine::poll_output`] hands the event out by value. As large as
/// the events it carries, as [`MasterEvent`] is.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub(crate) enum Queued {
    /// This event.
    Event(MasterEvent),
    /// [`MasterEvent::Completed`] with the kept last completion. At most one is queued: a job
    /// that completes while an earlier one's mark is still queued gives that mark its own copy
    /// first.
    Completed,
}

/// The Sans-IO Modbus master.
#[derive(Debug)]
pub struct Master {
    config: MasterConfig,
    rx: Receiver,
    state: State,
    /// The running job's attempts left; `None` while no job runs.
    job: Option<u8>,
    /// The running job's request as sent (read only while `job` is `Some`). Kept between jobs
    /// so a request is encoded into it in place, with no new 264-byte ADU zeroed per job.
    request: Adu,
    /// What the running job's attempts met so far, or the last job's once it ended.
    attempts: Attempts,
    /// The running job fails with 0830H at this instant ([`MasterConfig::job_bound`]).
    job_deadline: Option<Instant>,
    /// The current attempt's request goes out by then even if the line is never quiet.
    hold_limit: Instant,
    out: VecDeque<Output<Queued>>,
    /// Silence kept after a timeout before the next request ([`crate::quiet_guard`]).
    guard: QuietGuard,
    /// Frames out, with automatic V.24 operation ([Modbus/USS] §3.2.2) around each if configured.
    tx: Transmitter,
    /// The running job's id and the last job's outcome: every job, whoever started it, gets a
    /// [`JobId`] from [`Master::request`], and its outcome stays readable by that id
    /// ([`Master::outcome`]) until the next job ends; a completion's own data is in
    /// `last_completion`.
    jobs: JobSlot<()>,
    /// The last completed job's completion, for [`Master::outcome`]: refilled in place with the
    /// bytes of its ADUs (a whole completion copied into the slot is 540 bytes per job).
    last_completion: Completion,
    /// The job S_SEND started and S_RCV's reception not yet taken: kept here for the FB
    /// equivalents, whose `JobPort` impl (the `fb` module) alone reads and writes them; the
    /// engine never looks at them.
    pub(crate) fb_job: Option<JobId>,
    /// See `fb_job`.
    pub(crate) fb_reception: Option<Result<Completion, Status>>,
    /// The id of the running job (or of the last one), named by its end event even when an FB
    /// reset made `jobs` forget it.
    job_id: JobId,
    /// [`MasterConfig::max_response_duration`], computed once (the config does not change),
    /// not at each step of every job.
    max_response: Duration,
    /// [`MasterConfig::job_bound`], computed once.
    job_bound: Duration,
}

impl Master {
    /// A master with checked parameters.
    pub fn new(config: MasterConfig) -> Result<Self, crate::config::ConfigError> {
        config.validate()?;
        let mut out = VecDeque::new();
        Ok(Master {
            rx: Receiver::new(&config.line),
            tx: Transmitter::new(config.line.auto_v24, &mut out),
            config,
            state: State::Idle,
            job: None,
            request: Adu::new(),
            attempts: Attempts::default(),
            job_deadline: None,
            hold_limit: Instant::ZERO,
            guard: QuietGuard::default(),
            out,
            jobs: JobSlot::default(),
            last_completion: Completion {
                job: JobId(0),
                request: Adu::new(),
                response: None,
            },
            job_id: JobId(0),
            fb_job: None,
            fb_reception: None,
            max_response: config.max_response_duration(),
            job_bound: config.job_bound(),
        })
    }

    /// The longest a job started on this engine at any instant takes, from its start to its
    /// end, whatever the line does: [`MasterConfig::job_bound`] plus the longest hold of the
    /// quiet guard after a timeout ([`crate::quiet_guard`]; zero when it is off), which a job
    /// started while the guard holds the line waits out first. The engine's own deadline for a
    /// job never lies beyond it, so a caller announcing how long jobs take (a bus scan,
    /// [`crate::scan::probe_bound`]) counts from this, not from a formula of its own.
    pub fn longest_job(&self) -> Duration {
        self.guard.longest_hold(self.max_response) + self.job_bound
    }

    /// End received frames this way (host extension [`FrameEnd::Length`]; the default is
    /// the module's [`FrameEnd::Gap`]).
    ///
    /// An engine option rather than a [`LineConfig`](crate::config::LineConfig) field:
    /// `LineConfig` is the module's own parameter set ([Modbus/USS] §3.3.5–§3.9, Table 3-11, what
    /// si-dp-coord reads from a parameter record), and this is not one of the module's parameters.
    ///
    /// With [`FrameEnd::Length`] the master also waits out a hole inside a response whose
    /// header predicts more bytes, on any port ([`Receiver::set_patient`]).
    pub fn with_frame_end(mut self, frame_end: FrameEnd) -> Self {
        self.rx.set_frame_end(frame_end);
        self.rx.set_patient(frame_end == FrameEnd::Length);
        self
    }

    /// The physical interface ([Modbus/USS] §3.4.1, §3.4.3; RS-232C by default). On RS-485 the
    /// start of a response is recognised by a correctly received slave address in Normal mode too:
    /// a turnaround glitch before it is skipped instead of failing the job with 0831H. An engine
    /// option like [`with_frame_end`](Self::with_frame_end), because [`LineConfig`] carries the
    /// protocol's parameters and the interface is the module's (si-dp-coord holds it).
    ///
    /// [`LineConfig`]: crate::config::LineConfig
    pub fn with_interface(mut self, interface: Interface) -> Self {
        self.rx.set_interface(interface);
        self
    }

    /// After a job that ended without an answer (0830H), hold the next request until the line
    /// has been silent for `quiet`, discarding what arrives meanwhile (a host extension, off by
    /// default and with zero; the rule, its bound and why in [`crate::quiet_guard`]).
    pub fn with_quiet_after_timeout(mut self, quiet: impl Into<Duration>) -> Self {
        self.guard = QuietGuard::new(quiet.into());
        self
    }

    /// End received frames, and keep the silence before each request, at `gap` instead of the
    /// module's end-of-frame gap ([Modbus/USS] §3.3.5, Table 3-11 × fMUL): a host extension for
    /// a master among other makers' slaves, which keep the Modbus specification's t3.5
    /// ([Modbus serial] §2.5.1.1). The bounds that contain a gap
    /// ([`MasterConfig::max_response_duration`]) keep the table's.
    pub fn with_gap(mut self, gap: impl Into<Duration>) -> Self {
        self.rx.set_gap(gap.into());
        self
    }

    /// The silence that ends a received frame and that the master keeps after the last
    /// character received before its next request ([Modbus/USS] §3.3.5, Table 3-11 × fMUL, or
    /// [`with_gap`](Self::with_gap)'s): a caller's own pause between requests that is no
    /// longer than this is already kept, on the driver's precise timer.
    pub fn gap(&self) -> Duration {
        self.rx.gap()
    }

    /// How received frames end.
    pub fn frame_end(&self) -> FrameEnd {
        self.rx.frame_end()
    }

    /// The parameters.
    pub fn config(&self) -> &MasterConfig {
        &self.config
    }

    /// Receive statistics.
    pub fn counters(&self) -> Counters {
        self.rx.counters()
    }

    /// True while a job runs.
    pub fn is_busy(&self) -> bool {
        self.job.is_some()
    }

    /// What the running job's attempts met so far, or the last job's once it has ended
    /// ([`Attempts`]); a refused job leaves the previous job's.
    pub fn attempts(&self) -> Attempts {
        self.attempts
    }

    /// Start a job: send `request` to `unit` (0 = broadcast). Refused with the manual's STATUS
    /// when it breaks [Modbus/USS]
    /// §3.4.5–§3.4.16, or when a job is running.
    ///
    /// The job's [`JobId`] names its outcome: the job ends in exactly one
    /// [`MasterEvent::Completed`] or [`MasterEvent::Failed`], and [`outcome`](Self::outcome)
    /// gives it by id until the next job ends.
    pub fn request(
        &mut self,
        now: Instant,
        unit: u8,
        request: &Request<'_>,
    ) -> Result<JobId, RequestError> {
        if self.job.is_some() {
            return Err(RequestError::Busy);
        }
        // Encoded straight into the request's place: no ADU returned and moved in.
        Self::check_job_into(unit, request, &mut self.request)?;
        Ok(self.start_placed(now))
    }

    /// Start a job for a function code this crate does not know, passed through as it is (a
    /// host extension, for a gateway that forwards every function as mbusd does): `unit_pdu`
    /// is the request's unit id and PDU, without CRC, 2–254 bytes, unit 1–255. The answer ends
    /// by the gap (a function's length cannot be predicted without knowing it; an exception
    /// answer ends by its length, [Modbus serial] §2.5.1 `[derived]`) and is checked for its
    /// address, CRC, and function code: the request's (any length), or the request's + 80H
    /// with an exception code 01–07 (0E61H–0E67H). [`Completion::response_bytes`] holds it.
    /// A function this crate knows is checked as [`request`](Self::request) checks it.
    pub fn request_pass_through(
        &mut self,
        now: Instant,
        unit_pdu: &[u8],
    ) -> Result<JobId, RequestError> {
        if self.job.is_some() {
            return Err(RequestError::Busy);
        }
        let adu = pass_through_adu(unit_pdu)?;
        Ok(self.start(now, adu))
    }

    /// Start a job checked beforehand ([`CheckedRequest`]); refused only while a job runs.
    pub(crate) fn request_checked(
        &mut self,
        now: Instant,
        request: CheckedRequest,
    ) -> Result<JobId, RequestError> {
        if self.job.is_some() {
            return Err(RequestError::Busy);
        }
        Ok(self.start(now, request.0))
    }

    /// The outcome of job `id` once it has ended: the completion, or the failure's STATUS.
    /// `None` while it runs, and once a later job has ended (the engine keeps one outcome).
    pub fn outcome(&self, id: JobId) -> Option<Result<Completion, Status>> {
        self.jobs
            .outcome(id)
            .map(|r| r.map(|()| self.last_completion))
    }

    /// The job that is running, if any.
    pub fn running_job(&self) -> Option<JobId> {
        self.jobs.running()
    }

    /// Start the job of request `adu` at `now`: its id.
    fn start(&mut self, now: Instant, adu: Adu) -> JobId {
        self.request = adu;
        self.start_placed(now)
    }

    /// Start the job whose request is already in its place (`request`), at `now`: its id.
    fn start_placed(&mut self, now: Instant) -> JobId {
        let id = self.jobs.start();
        self.job_id = id;
        self.job = Some(1 + self.config.retries);
        self.attempts = Attempts::default();
        // A request the quiet guard holds has its bound counted from the guard's end.
        let held = self
            .guard
            .bound(self.max_response)
            .map_or(Duration::ZERO, |b| b.saturating_since(now));
        self.job_deadline = Some(now + held + self.job_bound);
        self.attempt(now);
        id
    }

    /// The checks of [Modbus/USS] §3.4.5–§3.4.16 a job must pass before it is started (0E43H
    /// broadcast not allowed for this function, 0E44H–0E46H counts), with the request as it would
    /// be sent. Pure, so a caller can check a job without the engine at hand.
    pub fn check_job(unit: u8, request: &Request<'_>) -> Result<Adu, RequestError> {
        let mut adu = Adu::new();
        Self::check_job_into(unit, request, &mut adu)?;
        Ok(adu)
    }

    /// [`check_job`](Self::check_job), the request encoded into `adu`.
    fn check_job_into(unit: u8, request: &Request<'_>, adu: &mut Adu) -> Result<(), RequestError> {
        let f = request.function();
        if unit == BROADCAST && !fc::broadcast_allowed(f) {
            return Err(RequestError::Invalid(status::BROADCAST_NOT_ALLOWED_FOR_FC));
        }
        adu.encode_request(unit, request).map_err(|_| {
            RequestError::Invalid(match f {
                fc::READ_COILS | fc::READ_DISCRETE_INPUTS => status::BIT_COUNT,
                fc::READ_HOLDING_REGISTERS | fc::READ_INPUT_REGISTERS => status::REGISTER_COUNT,
                _ => status::WRITE_COUNT,
            })
        })
    }

    /// Start an attempt: its request may be held for silence at most
    /// [`MasterConfig::max_response_duration`] (a frame in progress is over by then; a line
    /// that is still busy carries noise, which the request would not wait out).
    fn attempt(&mut self, now: Instant) {
        self.hold_limit = now + self.max_response;
        self.send(now);
    }

    /// Send the job's request, or hold it while the line has not been silent for the gap.
    fn send(&mut self, now: Instant) {
        let gap = self
            .rx
            .quiet_at()
            .filter(|&q| now < q && now < self.hold_limit)
            .map(|q| q.min(self.hold_limit));
        let guard = self
            .guard
            .until(self.rx.last_activity(), self.max_response)
            .filter(|&g| now < g);
        if let Some(until) = gap.max(guard) {
            self.state = State::Holding { until };
            return;
        }
        self.guard.clear();
        let Some(attempts) = self.job.as_mut() else {
            return;
        };
        *attempts = attempts.saturating_sub(1);
        self.attempts.sent = self.attempts.sent.saturating_add(1);
        let gate = self
            .tx
            .transmit(now, self.request.as_bytes(), &mut self.out);
        self.on_gate(now, gate);
    }

    /// What became of the request at the automatic V.24 gate ([Modbus/USS] §3.2.2; without it,
    /// always sent).
    fn on_gate(&mut self, now: Instant, gate: Gate) {
        match gate {
            Gate::Sent(len) => {
                let until = Transmitter::on_air(&self.config.line, &mut self.rx, now, len);
                self.state = State::Sending { until };
            }
            Gate::Held => self.state = State::WaitCts,
            Gate::Aborted if self.job.is_some() => self.fail(status::DSR_CTS_OFF),
            Gate::Aborted | Gate::Nothing => {}
        }
    }

    fn sent(&mut self, now: Instant) {
        if let State::Sending { .. } = self.state {
            let broadcast = self.job.is_some() && self.request.unit() == BROADCAST;
            self.state = if broadcast {
                State::Turnaround {
                    until: now + self.config.broadcast_turnaround,
                }
            } else {
                // The response's first byte may reach us up to the port's latency late.
                let deadline = now + self.config.response_timeout + self.rx.delivery().allowance();
                State::Waiting {
                    deadline,
                    limit: deadline + self.max_response,
                }
            };
        }
    }

    fn finish(&mut self, event: MasterEvent) {
        self.job = None;
        self.job_deadline = None;
        self.state = State::Idle;
        match &event {
            MasterEvent::Completed(c) => {
                self.last_completion
                    .refill(c.job, c.request.as_bytes(), c.response_bytes());
                self.jobs.finish(Ok(()))
            }
            MasterEvent::Failed { status, .. } => self.jobs.finish(Err(*status)),
            MasterEvent::Diagnostic(_) => None,
        };
        self.out.push_back(Output::Event(Queued::Event(event)));
    }

    /// End the running job with its completion: the request is moved out of the job, not
    /// copied (an ADU is 264 bytes inline); the response is read where the receiver assembled
    /// it.
    fn complete(&mut self, response: Option<FrameAt>) {
        if self.job.is_none() {
            return;
        }
        // An earlier completion nobody has taken yet stands for the kept one: it gets its own
        // copy before the kept one is refilled.
        for queued in self.out.iter_mut() {
            if let Output::Event(mark @ Queued::Completed) = queued {
                *mark = Queued::Event(MasterEvent::Completed(self.last_completion));
            }
        }
        // The ADUs' bytes are copied once, into the kept completion; the queue holds a mark.
        let response = response.as_ref().map(|at| self.rx.frame(at));
        self.last_completion
            .refill(self.job_id, self.request.as_bytes(), response);
        self.jobs.finish(Ok(()));
        self.out.push_back(Output::Event(Queued::Completed));
        self.job = None;
        self.job_deadline = None;
        self.state = State::Idle;
    }

    /// The next output where the queue keeps it, for [`Engine::poll_output`]'s caller in this
    /// crate that reads it in place ([`crate::tokio::InlineMaster`]): an output is as large as a
    /// completion (two ADUs inline), and handing it out by value copies all of it, also for a
    /// transmission. `Err(deadline)` when the queue is empty (what `poll_output` reports as
    /// [`Output::Wait`]); the caller drops an output it read with [`Master::consume_output`].
    /// A [`Queued::Completed`] mark is read with the kept completion, given beside it.
    #[cfg(feature = "tokio")]
    pub(crate) fn next_output_mut(
        &mut self,
    ) -> Result<(&mut Output<Queued>, &Completion), Option<Instant>> {
        if self.out.is_empty() {
            return Err(self.deadline());
        }
        let completion = &self.last_completion;
        self.out
            .front_mut()
            .map(|out| (out, completion))
            .ok_or(None)
    }

    /// Drop the output [`Master::next_output_mut`] showed.
    #[cfg(feature = "tokio")]
    pub(crate) fn consume_output(&mut self) {
        self.out.pop_front();
    }

    /// From now on, a request that goes out at once is queued as an empty
    /// [`Output::Transmit`], which stands for [`Master::request_bytes`]: for
    /// [`crate::tokio::InlineMaster`], which writes the request from here instead of a frame
    /// cut for it (a cut and a drop per request). Only for a caller that writes every
    /// `Transmit` before the engine starts another job.
    #[cfg(feature = "tokio")]
    pub(crate) fn transmit_in_place(&mut self) {
        self.tx.set_in_place();
    }

    /// The running (or last) job's request as sent: what an empty [`Output::Transmit`] stands
    /// for after [`Master::transmit_in_place`].
    #[cfg(feature = "tokio")]
    pub(crate) fn request_bytes(&self) -> &[u8] {
        self.request.as_bytes()
    }

    fn fail(&mut self, status: Status) {
        let (unit, function) = self.job.map_or((0, 0), |_| {
            (self.request.unit(), self.request.as_bytes()[1])
        });
        self.finish(MasterEvent::Failed {
            job: self.job_id,
            unit,
            function,
            status,
        });
    }

    /// Fail, or send again if retries are left and the failure is one a retry can cure.
    fn fail_or_retry(&mut self, now: Instant, status: Status) {
        self.count_attempt(status);
        let retry = self.job.is_some_and(|left| left > 0)
            && (status == status::RESPONSE_TIMEOUT || status == status::RESPONSE_CRC);
        if retry {
            self.attempt(now);
        } else {
            if status == status::RESPONSE_TIMEOUT {
                self.guard.arm(now);
            }
            self.fail(status);
        }
    }

    /// Count an attempt that ended without a good response ([`Attempts`]).
    fn count_attempt(&mut self, status: Status) {
        let a = &mut self.attempts;
        if status == status::RESPONSE_CRC {
            a.crc_errors = a.crc_errors.saturating_add(1);
        } else if status == status::RESPONSE_TIMEOUT {
            a.timeouts = a.timeouts.saturating_add(1);
        }
    }

    fn on_frame(&mut self, now: Instant, frame: FrameAt) {
        let waiting = matches!(self.state, State::Waiting { .. });
        if let Some(fault) = frame.fault {
            let status = fault_status(fault);
            if waiting {
                self.fail(status);
            } else {
                self.out
                    .push_back(Output::Event(Queued::Event(MasterEvent::Diagnostic(
                        status,
                    ))));
            }
            return;
        }
        let Some(request) = self.job.filter(|_| waiting).map(|_| &self.request) else {
            if !frame.is_empty() {
                self.rx.count_discarded();
                self.out
                    .push_back(Output::Event(Queued::Event(MasterEvent::Diagnostic(
                        status::UNSOLICITED_RESPONSE,
                    ))));
            }
            return;
        };
        let response = self.rx.frame(&frame);
        // Checked where they lie (neither the job's request nor the response is copied out).
        let checked = (response.first() == Some(&request.unit()))
            .then(|| check_response_with(request.as_bytes(), response, frame.crc_good));
        match checked {
            None => {
                if self.config.line.mode == Mode::InterferenceSuppression {
                    // Not a correctly received address: not a response start; keep waiting.
                    self.rx.count_discarded();
                    return;
                }
                // A response cut by a late packet starts mid-frame: name the adapter if it may
                // be one.
                self.fail(self.rx.delivery().annotate(status::WRONG_SLAVE_ADDRESS));
            }
            Some(Ok(())) => self.complete(Some(frame)),
            Some(Err(s)) => {
                self.rx.count_discarded();
                // CRC, length and structure errors may be a frame cut by a late packet; a
                // slave's exception answer arrived whole and keeps the manual's remedy.
                let s = if status::is_exception(s) {
                    s
                } else {
                    self.rx.delivery().annotate(s)
                };
                self.fail_or_retry(now, s);
            }
        }
    }

    fn tick(&mut self, now: Instant) {
        if let Some(frame) = self.rx.poll_in_place(now) {
            self.on_frame(now, frame);
        }
        let gate = self.tx.on_timeout(now, &mut self.out);
        self.on_gate(now, gate);
        if self.job.is_some() && self.job_deadline.is_some_and(|d| now >= d) {
            // The job's bound: whatever the line still does, the job is over (module docs).
            self.rx.discard();
            self.count_attempt(status::RESPONSE_TIMEOUT);
            self.guard.arm(now);
            self.fail(status::RESPONSE_TIMEOUT);
            return;
        }
        match self.state {
            State::Holding { until } if now >= until => self.send(now),
            State::Sending { until } if now >= until => self.sent(now),
            State::Waiting { limit, .. } if now >= limit => {
                // A "response" still running past its longest duration is noise: no valid
                // response came in this attempt (module docs, reading chosen).
                self.rx.discard();
                self.fail_or_retry(now, status::RESPONSE_TIMEOUT)
            }
            State::Waiting { deadline, .. } if now >= deadline && !self.rx.is_receiving() => {
                self.fail_or_retry(now, status::RESPONSE_TIMEOUT)
            }
            State::Turnaround { until } if now >= until => {
                self.complete(None);
            }
            _ => {}
        }
    }

    fn deadline(&self) -> Option<Instant> {
        let state = match self.state {
            State::Idle | State::WaitCts => None,
            State::Holding { until } | State::Sending { until } | State::Turnaround { until } => {
                Some(until)
            }
            State::Waiting { deadline, limit } => Some(if self.rx.is_receiving() {
                limit
            } else {
                deadline
            }),
        };
        let engine = Instant::earliest(state, self.job_deadline);
        Instant::earliest(
            Instant::earliest(engine, self.rx.deadline()),
            self.tx.deadline(),
        )
    }
}

impl Master {
    /// What the receiver may predict the length of: the response to the running job's
    /// request once it is being sent (a broadcast has none).
    fn expect(&self) -> Expect {
        match (self.job.map(|_| &self.request), self.state) {
            (Some(request), State::Sending { .. } | State::Waiting { .. })
                if request.unit() != BROADCAST =>
            {
                Expect::ResponseTo(request.as_bytes()[1])
            }
            _ => Expect::Nothing,
        }
    }
}

/// The longest RTU frame, CRC included ([Modbus serial] §2.5.1): a passed-through request
/// keeps to it (the codec's own limit is the module's, longer).
const PASS_THROUGH_MAX: usize = 256;

/// A request that passed the checks a job must pass before it starts
/// ([`Master::check_job`], or those of [`Master::request_pass_through`]): the job the async
/// handle hands the driver ([`si_core::job::JobEnd`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CheckedRequest(Adu);

impl CheckedRequest {
    /// `request` to `unit`, checked as [`Master::request`] checks it.
    pub fn new(unit: u8, request: &Request<'_>) -> Result<Self, RequestError> {
        Master::check_job(unit, request).map(CheckedRequest)
    }

    /// A request passed through as it is (`unit | PDU` without CRC), checked as
    /// [`Master::request_pass_through`] checks it.
    pub fn pass_through(unit_pdu: &[u8]) -> Result<Self, RequestError> {
        pass_through_adu(unit_pdu).map(CheckedRequest)
    }
}

/// The ADU of a passed-through request ([`Master::request_pass_through`]): `unit_pdu` and its
/// CRC; refused with 0E42H (invalid function) when it is shorter than unit + function code,
/// with 0E43H for a broadcast (whether the function may be broadcast is unknown), and with
/// 0E46H when it would not fit an RTU frame of [`PASS_THROUGH_MAX`] bytes.
fn pass_through_adu(unit_pdu: &[u8]) -> Result<Adu, RequestError> {
    match unit_pdu {
        [] | [_] => Err(RequestError::Invalid(status::INVALID_FUNCTION)),
        [BROADCAST, ..] => Err(RequestError::Invalid(status::BROADCAST_NOT_ALLOWED_FOR_FC)),
        _ if unit_pdu.len() > PASS_THROUGH_MAX - 2 => {
            Err(RequestError::Invalid(status::WRITE_COUNT))
        }
        _ => {
            let mut bytes = [0u8; frame::MAX_ADU];
            bytes[..unit_pdu.len()].copy_from_slice(unit_pdu);
            let crc = frame::crc16(unit_pdu).to_le_bytes();
            bytes[unit_pdu.len()..unit_pdu.len() + 2].copy_from_slice(&crc);
            Adu::from_slice(&bytes[..unit_pdu.len() + 2])
                .ok_or(RequestError::Invalid(status::WRITE_COUNT))
        }
    }
}

fn fault_status(fault: Fault) -> Status {
    match fault {
        Fault::Overflow => status::RECEIVE_BUFFER_OVERFLOW,
        Fault::Line(LineError::Parity) => status::PARITY_ERROR,
        Fault::Line(LineError::Framing) => status::FRAMING_ERROR,
        Fault::Line(LineError::Overrun) => status::TRANSMISSION_ERROR,
        Fault::Line(LineError::Break) => status::BREAK,
    }
}

/// Check a response against its request ([Modbus/USS] §3.4.5–§3.4.16; the address is already
/// checked).
///
/// The manual lists the checks but not their order. We check the structure (function code,
/// lengths, byte count, echo) and the CRC, and when both fail we report the length error
/// (0E52H/0E53H) rather than 0E57H: a response cut short by a gap or run into by another
/// frame fails its CRC as a consequence, and "too few bytes" says what happened.
pub fn check_response(request: &[u8], response: &[u8]) -> Result<(), Status> {
    check_response_with(request, response, false)
}

/// [`check_response`], where `crc_good` says the receiver has already found the response's
/// CRC good (a frame ended by its length is checked there before it is handed up), so it is
/// not computed a second time.
fn check_response_with(request: &[u8], response: &[u8], crc_good: bool) -> Result<(), Status> {
    if response.len() < 4 {
        return Err(status::TOO_FEW_BYTES);
    }
    let without_crc = |adu: &[u8]| adu.len().saturating_sub(2);
    let structure = check_structure(
        &request[..without_crc(request)],
        &response[..without_crc(response)],
    );
    if !crc_good && !frame::crc_ok(response) {
        return match structure {
            Err(s) if s == status::TOO_FEW_BYTES || s == status::TOO_MANY_BYTES => Err(s),
            _ => Err(status::RESPONSE_CRC),
        };
    }
    structure?;
    if !fc::is_supported(request[1]) {
        // A function passed through: its answer's structure is the slave's business.
        return Ok(());
    }
    if read_fully_checked(request) {
        // The structure check above has pinned the byte count to one the decoder accepts:
        // decoding the response here too would only repeat it (the caller decodes it once).
        return Ok(());
    }
    // The CRC is good (above): read `unit | PDU` without computing it again.
    frame::decode_unit_pdu_response(&response[..without_crc(response)])
        .map(|_| ())
        .map_err(|_| status::BYTE_COUNT_WRONG)
}

/// True for a read (FC01–04) whose quantity the decoder's byte-count limits accept
/// (1–[`frame::MAX_BITS`] bits, 1–[`frame::MAX_REGISTERS`] registers, as
/// [`Master::check_job`] allows): once [`check_structure`]
/// has found the response's byte count equal to the one the quantity needs, decoding it cannot
/// fail. A passed-through read of another quantity is still decoded by [`check_response`].
fn read_fully_checked(request: &[u8]) -> bool {
    let Some(&[f, _, _, hi, lo]) = request.get(1..6).and_then(|b| <&[u8; 5]>::try_from(b).ok())
    else {
        return false;
    };
    let quantity = u16::from_be_bytes([hi, lo]);
    match f {
        fc::READ_COILS | fc::READ_DISCRETE_INPUTS => (1..=frame::MAX_BITS).contains(&quantity),
        fc::READ_HOLDING_REGISTERS | fc::READ_INPUT_REGISTERS => {
            (1..=frame::MAX_REGISTERS).contains(&quantity)
        }
        _ => false,
    }
}

/// The structure of a response (`unit | PDU`, no CRC: RTU and Modbus TCP alike) against its
/// request's: function code, lengths, byte count, echo ([Modbus/USS] §3.4.5–§3.4.16).
pub(crate) fn check_structure(request: &[u8], response: &[u8]) -> Result<(), Status> {
    let f = request[1];
    let body = response.len();
    let exact = |len: usize| -> Result<(), Status> {
        match body.cmp(&len) {
            core::cmp::Ordering::Less => Err(status::TOO_FEW_BYTES),
            core::cmp::Ordering::Greater => Err(status::TOO_MANY_BYTES),
            core::cmp::Ordering::Equal => Ok(()),
        }
    };
    if response[1] == f | 0x80 {
        exact(3)?;
        return match frame::ExceptionCode::from_u8(response[2]) {
            Some(code) => Err(status::for_exception(code)),
            None => Err(status::WRONG_FUNCTION),
        };
    }
    if response[1] != f {
        return Err(status::WRONG_FUNCTION);
    }
    let qty = || u16::from_be_bytes([request[4], request[5]]) as usize;
    let byte_counted = |expected_min: usize, expected_max: usize| -> Result<(), Status> {
        if body < 3 {
            return Err(status::TOO_FEW_BYTES);
        }
        let bc = response[2] as usize;
        if bc < expected_min {
            return Err(status::BYTE_COUNT_TOO_SMALL);
        }
        if bc > expected_max {
            return Err(status::BYTE_COUNT_WRONG);
        }
        exact(3 + bc)
    };
    match f {
        fc::READ_COILS | fc::READ_DISCRETE_INPUTS => {
            let need = qty().div_ceil(8);
            byte_counted(need, need)?
        }
        fc::READ_HOLDING_REGISTERS | fc::READ_INPUT_REGISTERS => {
            let need = qty() * 2;
            byte_counted(need, need)?
        }
        fc::WRITE_SINGLE_COIL | fc::WRITE_SINGLE_REGISTER | fc::DIAGNOSTICS => {
            exact(6)?;
            if response[2..6] != request[2..6] {
                return Err(status::ECHO_WRONG);
            }
        }
        fc::WRITE_MULTIPLE_COILS | fc::WRITE_MULTIPLE_REGISTERS => {
            exact(6)?;
            if response[2..6] != request[2..6] {
                return Err(status::ECHO_WRONG);
            }
        }
        fc::READ_EXCEPTION_STATUS => exact(3)?,
        fc::GET_COMM_EVENT_COUNTER => exact(6)?,
        fc::GET_COMM_EVENT_LOG => byte_counted(6, 6 + frame::MAX_EVENTS)?,
        // Passed through ([`Master::request_pass_through`]): the function code matches.
        _ if !fc::is_supported(f) => {}
        _ => return Err(status::WRONG_FUNCTION),
    }
    Ok(())
}

impl Master {
    /// The bytes of a read, after the read's clock check ([`Engine::handle_rx`] minus its
    /// `tick`).
    fn receive(&mut self, now: Instant, mut bytes: &[u8]) {
        if !self.tx.may_receive() {
            return; // [Modbus/USS] §3.2.2 item 6: nothing is received while DSR = OFF
        }
        while !bytes.is_empty() {
            let unit = self.job.map(|_| self.request.unit());
            let taken = self.rx.push(now, bytes, |b| Some(b) == unit, self.expect());
            bytes = &bytes[taken..];
            if matches!(self.state, State::Sending { .. }) && self.rx.is_receiving() {
                // A reply while we think we are still sending: the transport has no wire time
                // (a pseudo-terminal, a pipe) or our estimate was long. On a half-duplex line
                // the request has left, so the response has started.
                self.sent(now);
            }
            // A frame complete by its length (FrameEnd::Length) is handed up at once; the
            // rest of the bytes start the next frame.
            if let Some(frame) = self.rx.poll_in_place(now) {
                self.on_frame(now, frame);
            }
        }
    }

    /// [`Engine::handle_tx_done`] and then [`Engine::handle_rx`] at the same instant, for
    /// [`crate::tokio::InlineMaster`], whose read usually finds both the request's end due and
    /// the whole response. The read's `tick` is left out where it provably does nothing: the
    /// receiver has no frame open (nothing to end), no automatic V.24 sequence runs (no RTS or
    /// CTS step), and the response is awaited until an instant still ahead (no timeout; the
    /// job's bound was checked by the first `tick` at this same instant). Anything else (a
    /// broadcast's turnaround, a zero response timeout, stray bytes before the request's end)
    /// goes the two calls' way.
    #[cfg(feature = "tokio")]
    pub(crate) fn handle_tx_done_and_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.handle_tx_done(now);
        let nothing_due = !self.rx.is_receiving()
            && self.tx.is_plain()
            && matches!(self.state, State::Waiting { deadline, .. } if now < deadline);
        if nothing_due {
            self.rx.observe_read(now, bytes.len());
            self.receive(now, bytes);
        } else {
            self.handle_rx(now, bytes);
        }
    }
}

impl Engine for Master {
    type Event = MasterEvent;

    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.rx.observe_read(now, bytes.len());
        self.tick(now);
        self.receive(now, bytes);
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.tick(now);
    }

    fn handle_tx_done(&mut self, now: Instant) {
        self.tick(now);
        self.sent(now);
        // The RTS-off time of automatic V.24 ([Modbus/USS] §3.2.2 item 5) runs from the last byte
        // actually leaving, which only the driver knows: not from the engine's estimate.
        self.tx.sent(now, &mut self.out);
    }

    fn set_rx_latency(&mut self, latency: Duration) {
        self.rx.set_rx_latency(latency);
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.tick(now);
        self.rx.line_error(now, error);
    }

    fn handle_signals(&mut self, now: Instant, signals: ModemSignals) {
        self.tick(now);
        let (gate, dsr_dropped) = self.tx.on_signals(signals, &mut self.out);
        self.on_gate(now, gate);
        if !dsr_dropped {
            return;
        }
        // [Modbus/USS] §3.2.2 item 7: DSR ON → OFF aborts "an active send job and any active
        // reception". A running job is aborted at once in every phase, not only while the
        // request waits for CTS or is sent (the gate above) or a response is arriving: also
        // during the RTS-off time, between the request's last byte and the response's first,
        // and in a broadcast's turnaround delay. `[derived]` The master's job is one send job
        // from S_SEND's start to its end (response or timeout), and nothing can be received
        // while DSR = OFF (item 6), so waiting out the response time would only turn the
        // abort into a later 0830H.
        if self.rx.is_receiving() {
            self.rx.discard();
        }
        if self.job.is_some() {
            self.fail(status::DSR_CTS_OFF);
        }
    }

    fn poll_output(&mut self) -> Output<MasterEvent> {
        match self.out.pop_front() {
            None => Output::Wait(self.deadline()),
            Some(Output::Event(Queued::Event(event))) => Output::Event(event),
            Some(Output::Event(Queued::Completed)) => {
                Output::Event(MasterEvent::Completed(self.last_completion))
            }
            Some(Output::Transmit(frame)) => Output::Transmit(frame),
            Some(Output::SetSignals(update)) => Output::SetSignals(update),
            Some(Output::Wait(deadline)) => Output::Wait(deadline),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adu(hex: &str) -> Vec<u8> {
        si_core::hex::parse(hex).unwrap()
    }

    fn with_crc(mut v: Vec<u8>) -> Vec<u8> {
        let c = frame::crc16(&v).to_le_bytes();
        v.extend_from_slice(&c);
        v
    }

    #[test]
    fn response_checks_follow_section_4_4() {
        let req = adu("01 03 00 00 00 02 C4 0B");
        assert_eq!(
            check_response(&req, &with_crc(adu("01 03 04 00 01 00 02"))),
            Ok(())
        );
        assert_eq!(
            check_response(&req, &adu("01 03 04 00 01 00 02 00 00")),
            Err(status::RESPONSE_CRC)
        );
        assert_eq!(
            check_response(&req, &with_crc(adu("01 04 04 00 01 00 02"))),
            Err(status::WRONG_FUNCTION)
        );
        assert_eq!(
            check_response(&req, &with_crc(adu("01 03 02 00 01"))),
            Err(status::BYTE_COUNT_TOO_SMALL)
        );
        assert_eq!(
            check_response(&req, &with_crc(adu("01 03 06 00 01 00 02 00 03"))),
            Err(status::BYTE_COUNT_WRONG)
        );
        assert_eq!(
            check_response(&req, &with_crc(adu("01 03 04 00 01 00"))),
            Err(status::TOO_FEW_BYTES)
        );
        assert_eq!(
            check_response(&req, &with_crc(adu("01 03 04 00 01 00 02 FF"))),
            Err(status::TOO_MANY_BYTES)
        );
        assert_eq!(
            check_response(&req, &with_crc(adu("01 83 02"))),
            Err(status::EXCEPTION_ILLEGAL_DATA_ADDRESS)
        );
        let req = with_crc(adu("01 06 00 01 00 03"));
        assert_eq!(
            check_response(&req, &with_crc(adu("01 06 00 01 00 04"))),
            Err(status::ECHO_WRONG)
        );
    }

    /// The request's end and the response in one call (what `InlineMaster` uses) give the
    /// engine's outputs of the two calls, also where the second call's clock check matters: a
    /// broadcast whose turnaround of zero is over at the very instant the request ended.
    #[cfg(feature = "tokio")]
    #[test]
    fn tx_done_and_rx_in_one_call_give_the_two_calls_outputs() {
        use crate::frame::Registers;
        fn outputs(m: &mut Master) -> Vec<String> {
            let mut all = Vec::new();
            loop {
                let out = m.poll_output();
                let wait = matches!(out, Output::Wait(_));
                all.push(format!("{out:?}"));
                if wait {
                    return all;
                }
            }
        }
        let config = MasterConfig {
            broadcast_turnaround: Duration::ZERO,
            ..MasterConfig::default()
        };
        let answer = Adu::response(
            1,
            &Response::ReadHoldingRegisters(Registers::Words(&[7, 8])),
        )
        .unwrap();
        let jobs = [
            (
                1,
                Request::ReadHoldingRegisters {
                    address: 0,
                    quantity: 2,
                },
                answer.as_bytes(),
            ),
            (
                BROADCAST,
                Request::WriteSingleRegister {
                    address: 0,
                    value: 1,
                },
                &[0x01][..],
            ),
        ];
        for (unit, request, bytes) in jobs {
            let [mut two, mut one] = [(); 2].map(|()| {
                Master::new(config)
                    .unwrap()
                    .with_frame_end(FrameEnd::Length)
            });
            let t = Instant::from_micros(1_000);
            two.request(t, unit, &request).unwrap();
            one.request(t, unit, &request).unwrap();
            assert_eq!(outputs(&mut two), outputs(&mut one));
            let t = t + Duration::from_millis(1);
            two.handle_tx_done(t);
            two.handle_rx(t, bytes);
            one.handle_tx_done_and_rx(t, bytes);
            let expected = outputs(&mut two);
            assert!(
                expected.iter().any(|o| o.contains("Completed")),
                "{expected:?}"
            );
            assert_eq!(outputs(&mut one), expected, "unit {unit}");
        }
    }

    /// Two jobs complete before anyone polls the engine: each completion event carries its
    /// own job's ADUs (the queue marks a completion standing for the kept last one, and an
    /// earlier mark gets its own copy when the next job completes), and `outcome` has the last.
    #[test]
    fn completions_left_in_the_queue_keep_their_own_adus() {
        use crate::frame::Registers;
        let mut m = Master::new(MasterConfig::default())
            .unwrap()
            .with_frame_end(FrameEnd::Length);
        let mut t = Instant::from_micros(1_000);
        let mut expected = Vec::new();
        for (quantity, values) in [(3u16, &[7u16, 8, 9][..]), (1, &[5][..])] {
            let request = Request::ReadHoldingRegisters {
                address: 0,
                quantity,
            };
            let id = m.request(t, 1, &request).unwrap();
            t += Duration::from_millis(1);
            m.handle_tx_done(t);
            let answer =
                Adu::response(1, &Response::ReadHoldingRegisters(Registers::Words(values)))
                    .unwrap();
            m.handle_rx(t, answer.as_bytes());
            assert!(!m.is_busy(), "job {id:?} completed");
            expected.push((id, Adu::request(1, &request).unwrap(), answer));
            // Past the gap, so the next request is not held.
            t += Duration::from_millis(10);
            m.handle_timeout(t);
        }
        let mut completions = Vec::new();
        loop {
            match m.poll_output() {
                Output::Wait(_) => break,
                Output::Event(MasterEvent::Completed(c)) => completions.push(c),
                _ => {}
            }
        }
        assert_eq!(completions.len(), 2);
        for (c, (id, request, answer)) in completions.iter().zip(&expected) {
            assert_eq!(c.job(), *id);
            assert_eq!(c.request, *request);
            assert_eq!(c.response_bytes(), Some(answer.as_bytes()));
        }
        assert_eq!(m.outcome(expected[1].0), Some(Ok(completions[1])));
    }

    #[test]
    fn a_passed_through_read_of_a_quantity_the_decoder_refuses_is_still_decoded() {
        // Quantity 0 (a pass-through request is not range-checked): the byte count 0 matches
        // the structure, but no register read has it.
        let req = with_crc(adu("01 03 00 00 00 00"));
        assert_eq!(
            check_response(&req, &with_crc(adu("01 03 00"))),
            Err(status::BYTE_COUNT_WRONG)
        );
        let req = with_crc(adu("01 01 00 00 00 00"));
        assert_eq!(
            check_response(&req, &with_crc(adu("01 01 00"))),
            Err(status::BYTE_COUNT_WRONG)
        );
        // In range: the structure check alone accepts it.
        let req = with_crc(adu("01 03 00 00 00 01"));
        assert_eq!(
            check_response(&req, &with_crc(adu("01 03 02 00 07"))),
            Ok(())
        );
    }
}
