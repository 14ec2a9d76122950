//! The host engine: what a non-S7 DP master (PC card, gateway, test tool) runs to talk to an
//! ET 200S serial module through its coordination-byte window.
//!
//! [ET200S SI 2005] §2.12.1 (rules for writing a job code), §2.12.7 (error handling)
//! and [ET200S SI 2005] §2.12.1–§2.12.7 `[derived]` (host-side state machines). Call
//! [`Host::cycle`] once per DP cycle (or host cycle) with the input window just read; write the
//! returned output window back as one consistent block. Jobs are submitted with [`Host::submit`]
//! and end in exactly one [`HostEvent::Completed`], taken with [`Host::poll_event`] (or, for one
//! job, with [`Host::take_completion`]).
//!
//! The engine reads no clock: `now` is only used by the job watchdog.
//!
//! # The arbiter
//!
//! Only one job owns byte 0 ([ET200S SI 2005] §2.12.1, derived in §2.12.1–§2.12.7 `[derived]`). A
//! job code is written only in a cycle where the module shows idle (00H, no error bit) *and* the
//! host's previous output byte 0 was 00H, so every job starts from a clean idle on both sides. A
//! job that reads the acknowledgement of a foreign job code backs off (rule 3): it writes 00H,
//! waits for idle, and starts again, reported as [`HostEvent::BackedOff`].
//!
//! # Readings chosen where the manual is unclear
//!
//! * A send or parameter job completes when the end-of-job acknowledgement 7xH arrives, with the
//!   STATUS of bytes 1–2 (0000H = done); write V.24 completes on the 40H acknowledgement. The host
//!   then writes 00H and waits for the module's idle before the next job ([ET200S SI 2005]
//!   §2.12.1–§2.12.7 `[derived]` `DONE`).
//! * A receive or read V.24 job completes when the module shows idle after the host's last echo.
//!   The host holds the echo until then and writes 00H afterwards (`[derived]`; writing 00H earlier
//!   would abort the transfer, [ET200S SI 2005] §2.12.7).
//! * A receive job answered with 20H and 0101H (or 0000H) completes with
//!   [`Outcome::NoMessage`]; 20H with any other word is a failure with that STATUS
//!   ([ET200S SI 2005] §2.12.7).
//! * An out-of-order receive segment sets the error bit with the last valid number. The host then
//!   accepts either answer: the segment after the last valid one (the general go-back rule) or
//!   20H with a STATUS (Table 2-21: 0551H abort; the frame is offered again by a later job,
//!   `[derived]`).
//! * The end-of-job acknowledgement is accepted with any exec number: the manual does not say
//!   which number a 7xH carries when the module ends a job early (`[derived]`).
//! * A received frame longer than [`HostConfig::max_frame_len`] is still read to its end (and
//!   dropped, failing with 0850H): aborting instead would leave it first in the module's buffer
//!   and every later receive job would meet it again.
//! * Each job has a watchdog ([`HostConfig::job_timeout`], `[derived]`); on expiry the job fails
//!   with [`HostConfig::watchdog_status`] and the host writes 00H, which aborts the module's side.

use crate::config::{ConfigError, HostConfig};
use crate::coord::{CoordByte, JobCode};
use crate::frame::{send_stream, ParamBlock, RxStatus, V24Signals, Window};
use crate::status::{
    lookup, ABORTED_BY_RESET, INVALID_LEN, NOT_POSSIBLE_IN_MODE, RECEIVED_FRAME_TOO_LONG,
    TRANSFER_ERROR_TO_CPU,
};
use bytes::{Bytes, BytesMut};
use serde::{Deserialize, Serialize};
use si_core::{Instant, Status};
use std::collections::VecDeque;

/// The one job id of si-core; it identifies a submitted job in its completion event.
pub use si_core::JobId;

/// A job for the module (Table 2-22).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Job {
    /// Job 1: send a frame of 1 … `max_frame_len` bytes to the serial partner.
    Send(Bytes),
    /// Job 2: fetch the oldest received frame.
    Receive,
    /// Job 3: read the V.24 signal states.
    ReadV24,
    /// Job 4: set RTS and DTR (the other bits are inputs and are sent as 0).
    WriteV24 {
        /// Request to send.
        rts: bool,
        /// Data terminal ready.
        dtr: bool,
    },
    /// Job 5: transfer a flow-control parameter block.
    Parameters(ParamBlock),
}

impl From<Bytes> for Job {
    /// S_SEND's frame: a send job.
    fn from(frame: Bytes) -> Self {
        Job::Send(frame)
    }
}

impl Job {
    /// The job code this job writes into byte 0.
    pub const fn code(&self) -> JobCode {
        match self {
            Job::Send(_) => JobCode::Send,
            Job::Receive => JobCode::Receive,
            Job::ReadV24 => JobCode::ReadV24,
            Job::WriteV24 { .. } => JobCode::WriteV24,
            Job::Parameters(_) => JobCode::Parameters,
        }
    }
}

/// What a job produced when it succeeded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Send: the module acknowledged the end of the job with 0000H, i.e. the frame went to the
    /// partner ([ET200S SI 2005] §2.12.1–§2.12.7 `[derived]`).
    Sent,
    /// Receive: the complete frame.
    Received(Bytes),
    /// Receive: the module had no frame (20H + 0101H, "not an error", [ET200S SI 2005] §2.12.7).
    NoMessage,
    /// Read V.24: the signal states.
    Signals(V24Signals),
    /// Write V.24: acknowledged with 0000H.
    SignalsWritten,
    /// Parameters: acknowledged with 0000H.
    ParametersSet,
}

/// Something the host engine reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HostEvent {
    /// A job ended: exactly one per submitted (or automatic) job.
    Completed {
        /// The job.
        id: JobId,
        /// Its job code.
        code: JobCode,
        /// Done, or failed with the STATUS.
        result: Result<Outcome, Status>,
    },
    /// The job read a foreign job acknowledgement, wrote idle and will start again once the module
    /// is idle ([ET200S SI 2005] §2.12.1 rule 3, §2.12.7 "sender gets another job code").
    BackedOff {
        /// The job.
        id: JobId,
        /// The coordination byte that caused it.
        seen: CoordByte,
    },
}

/// Why [`Host::submit`] refused a job.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SubmitError {
    /// The frame is empty or longer than the configured maximum (the FB's LEN check, 1E41H).
    #[error("frame length {len} outside 1 … {max} (STATUS 16#1E41)")]
    InvalidLength {
        /// Length given.
        len: usize,
        /// Configured maximum.
        max: usize,
    },
    /// The job queue is full.
    #[error("job queue full ({capacity} jobs)")]
    QueueFull {
        /// Configured capacity.
        capacity: usize,
    },
}

impl SubmitError {
    /// The STATUS an S7 FB would show for the same refusal (1E41H for a bad LEN, 0502H when no
    /// job can be taken).
    pub fn status(&self) -> Status {
        match self {
            SubmitError::InvalidLength { .. } => INVALID_LEN,
            SubmitError::QueueFull { .. } => NOT_POSSIBLE_IN_MODE,
        }
    }
}

/// Counters for diagnostics and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct HostStats {
    /// Jobs that wrote their request byte (a backed-off job counts again).
    pub requests: u64,
    /// Segments the module echoed (send direction).
    pub segments_sent: u64,
    /// Segments accepted (receive direction).
    pub segments_received: u64,
    /// Go-backs after the module's error bit (send direction).
    pub resends: u64,
    /// Times the host set the error bit (receive direction).
    pub errors_signalled: u64,
    /// Back-offs after a foreign job code.
    pub backoffs: u64,
    /// Jobs ended by the watchdog.
    pub timeouts: u64,
    /// Input windows of the wrong length, ignored.
    pub invalid_windows: u64,
}

/// At most this many events wait for [`Host::poll_event`] beyond the job queue; back-off notices
/// beyond it are dropped (never completions) and automatic receives pause.
const EVENT_SLACK: usize = 64;

#[derive(Debug, Clone, Copy)]
enum Phase {
    /// Writing 00H until the module is idle and the job may write its request.
    WaitIdle,
    /// Send/parameters: the request 10H/50H is out, waiting for the acceptance.
    Request,
    /// Send/parameters: segments going out.
    Sending(SendState),
    /// Receive: segments coming in.
    Receiving(RecvState),
    /// Read V.24 request out.
    ReadV24,
    /// Read V.24 echo out, waiting for idle.
    ReadV24Ack(V24Signals),
    /// Write V.24 request out.
    WriteV24,
}

/// Send/parameters progress: segment `k` of `last` is shown, `acked` is the highest echoed
/// segment, `in_error` the last valid number of the error the module shows.
#[derive(Debug, Clone, Copy)]
struct SendState {
    k: usize,
    last: usize,
    acked: usize,
    in_error: Option<u8>,
}

/// Receive progress: `k` segments accepted (0 = request out), `len` from the first segment,
/// `got` data bytes so far (stored only when `len` fits the configured maximum), `error` while
/// our error bit is out.
#[derive(Debug, Clone, Copy, Default)]
struct RecvState {
    k: usize,
    len: usize,
    got: usize,
    error: bool,
}

#[derive(Debug)]
struct Active {
    id: JobId,
    job: Job,
    started: Instant,
    phase: Phase,
}

/// The host side of the window protocol. See the [module docs](self).
#[derive(Debug)]
pub struct Host {
    cfg: HostConfig,
    out: Window,
    queue: VecDeque<(JobId, Job)>,
    active: Option<Active>,
    events: VecDeque<HostEvent>,
    next_id: u64,
    rx_status: Option<RxStatus>,
    /// Payload stream of the running send/parameter job (reused, no allocation per job once
    /// grown).
    stream: Vec<u8>,
    /// Frame being received. Received frames are cut from it (`split().freeze()`); once the
    /// application drops the previous frame, `reserve` reclaims the same allocation, so a steady
    /// state allocates nothing (the si-core contract, as in the 3964(R) link).
    rx: BytesMut,
    stats: HostStats,
    /// The receive job S_RCV (si-core's, through the [`JobPort`](si_core::JobPort) impl in
    /// [`crate::fb`]) has running: a frame's transfer to the caller spans DP cycles.
    pub(crate) fb_receive: Option<JobId>,
}

impl Host {
    /// A host engine; its first output is idle (00H), and it waits for the module's idle before
    /// the first job, as after any host restart ([ET200S SI 2005] §2.12.2, §2.12.3, §2.11).
    pub fn new(cfg: HostConfig) -> Result<Host, ConfigError> {
        cfg.validate()?;
        Ok(Host {
            out: Window::new(cfg.window),
            queue: VecDeque::with_capacity(cfg.queue_capacity),
            active: None,
            events: VecDeque::with_capacity(cfg.queue_capacity + EVENT_SLACK),
            next_id: 1,
            rx_status: None,
            stream: Vec::with_capacity(cfg.max_frame_len + 2),
            rx: BytesMut::with_capacity(cfg.max_frame_len),
            stats: HostStats::default(),
            fb_receive: None,
            cfg,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &HostConfig {
        &self.cfg
    }

    /// Queues a job. It runs when the arbiter grants it byte 0 and ends in one
    /// [`HostEvent::Completed`].
    pub fn submit(&mut self, job: Job) -> Result<JobId, SubmitError> {
        if let Job::Send(data) = &job {
            if data.is_empty() || data.len() > self.cfg.max_frame_len {
                return Err(SubmitError::InvalidLength {
                    len: data.len(),
                    max: self.cfg.max_frame_len,
                });
            }
        }
        if self.queue.len() >= self.cfg.queue_capacity {
            return Err(SubmitError::QueueFull {
                capacity: self.cfg.queue_capacity,
            });
        }
        let id = self.fresh_id();
        self.queue.push_back((id, job));
        Ok(id)
    }

    /// Ends every queued and running job with 1E0DH ("aborted by reset") and writes idle: the
    /// FB's R input, or a host restart.
    pub fn reset(&mut self) {
        if let Some(a) = self.active.take() {
            self.push_completion(a.id, a.job.code(), Err(ABORTED_BY_RESET));
        }
        while let Some((id, job)) = self.queue.pop_front() {
            self.push_completion(id, job.code(), Err(ABORTED_BY_RESET));
        }
        self.out.clear();
    }

    /// Ends one job with 1E0DH ("aborted by reset"), queued or running: the R input of one FB.
    /// A running job writes idle, which aborts the module's side ([ET200S SI 2005] §2.12.7). False
    /// if `id` is neither queued nor running (already completed, or unknown).
    pub fn abort(&mut self, id: JobId) -> bool {
        if let Some(a) = self.active.take() {
            if a.id == id {
                self.finish(a, Err(ABORTED_BY_RESET));
                return true;
            }
            self.active = Some(a);
        }
        let Some(pos) = self.queue.iter().position(|(i, _)| *i == id) else {
            return false;
        };
        if let Some((id, job)) = self.queue.remove(pos) {
            self.push_completion(id, job.code(), Err(ABORTED_BY_RESET));
        }
        true
    }

    /// The next event, oldest first.
    pub fn poll_event(&mut self) -> Option<HostEvent> {
        self.events.pop_front()
    }

    /// Takes the completion of `id` out of the event queue, if it has arrived: how a caller
    /// that tracks its own jobs (an FB equivalent) collects its result without consuming the
    /// other events.
    pub fn take_completion(&mut self, id: JobId) -> Option<Result<Outcome, Status>> {
        let pos = self
            .events
            .iter()
            .position(|e| matches!(e, HostEvent::Completed { id: i, .. } if *i == id))?;
        match self.events.remove(pos)? {
            HostEvent::Completed { result, .. } => Some(result),
            HostEvent::BackedOff { .. } => None,
        }
    }

    /// The receive status of the last idle window read (0000H, 0001H, 0B01H; [ET200S SI 2005]
    /// §2.12.1).
    pub fn receive_status(&self) -> Option<RxStatus> {
        self.rx_status
    }

    /// True while a job runs or waits.
    pub fn is_busy(&self) -> bool {
        self.active.is_some() || !self.queue.is_empty()
    }

    /// Counters.
    pub fn stats(&self) -> HostStats {
        self.stats
    }

    /// The output window as last computed.
    pub fn output(&self) -> &[u8] {
        self.out.as_bytes()
    }

    /// One DP cycle: reads the module's input window, returns the output window to write.
    ///
    /// An input of the wrong length (a failed consistent read) is ignored: the outputs are held
    /// and only the watchdog runs.
    pub fn cycle(&mut self, now: Instant, input: &[u8]) -> &[u8] {
        let out_was_idle = self.out.as_bytes()[0] == 0;
        self.check_watchdog(now);
        let Some(inw) = Window::from_bytes(input).filter(|w| w.size() == self.cfg.window) else {
            self.stats.invalid_windows += 1;
            return self.out.as_bytes();
        };
        let c = inw.coord();
        if c.is_idle() {
            self.rx_status = Some(RxStatus::from_word(inw.word()));
        }
        if let Some(active) = self.active.take() {
            self.active = self.step(active, c, &inw);
        }
        // Between jobs: idle written, the next job (or an automatic receive) waits for idle.
        if self.active.is_none() {
            self.out.clear();
            self.active = self.next_job(now);
        }
        // [ET200S SI 2005] §2.12.1 rule 1, and our clean-start reading: a job code is written only
        // after the module's idle was read while our own byte 0 was already idle.
        if out_was_idle && c.is_idle() {
            if let Some(mut a) = self.active.take() {
                if matches!(a.phase, Phase::WaitIdle) {
                    self.write_request(&mut a);
                }
                self.active = Some(a);
            }
        }
        self.out.as_bytes()
    }

    /// Writes the job's request byte (J << 4, exec 0) and prepares its payload.
    fn write_request(&mut self, a: &mut Active) {
        self.stats.requests += 1;
        self.out.clear();
        self.out.set_coord(CoordByte::new(a.job.code(), 0));
        a.phase = match &a.job {
            Job::Send(data) => {
                send_stream(data, &mut self.stream);
                Phase::Request
            }
            Job::Parameters(block) => {
                let (bytes, n) = block.encode();
                self.stream.clear();
                self.stream.extend_from_slice(&bytes[..n]);
                Phase::Request
            }
            Job::Receive => {
                self.rx.clear();
                Phase::Receiving(RecvState::default())
            }
            Job::ReadV24 => Phase::ReadV24,
            Job::WriteV24 { rts, dtr } => {
                // The only job whose request carries data (Table 2-26, [derived]).
                let signals = V24Signals {
                    rts: *rts,
                    dtr: *dtr,
                    ..V24Signals::default()
                };
                let word = self.cfg.v24_layout.encode(signals);
                self.out.data_mut()[..2].copy_from_slice(&word);
                Phase::WriteV24
            }
        };
    }

    fn fresh_id(&mut self) -> JobId {
        let id = JobId(self.next_id);
        self.next_id = self.next_id.wrapping_add(1).max(1);
        id
    }

    fn next_job(&mut self, now: Instant) -> Option<Active> {
        let status = self.rx_status.unwrap_or(RxStatus::Empty);
        let auto = self.cfg.auto_receive
            && status.frame_waiting()
            && (self.queue.is_empty() || status == RxStatus::TwoThirdsFull)
            && self.events.len() < self.cfg.queue_capacity + EVENT_SLACK;
        let (id, job) = if auto {
            (self.fresh_id(), Job::Receive)
        } else {
            self.queue.pop_front()?
        };
        Some(Active {
            id,
            job,
            started: now,
            phase: Phase::WaitIdle,
        })
    }

    fn check_watchdog(&mut self, now: Instant) {
        let (Some(limit), Some(a)) = (self.cfg.job_timeout, &self.active) else {
            return;
        };
        if now.saturating_since(a.started) >= limit {
            if let Some(a) = self.active.take() {
                self.stats.timeouts += 1;
                let status = self.cfg.watchdog_status;
                self.finish(a, Err(status));
            }
        }
    }

    fn push_completion(&mut self, id: JobId, code: JobCode, result: Result<Outcome, Status>) {
        self.events
            .push_back(HostEvent::Completed { id, code, result });
    }

    /// Ends the job: one completion, idle written.
    fn finish(&mut self, a: Active, result: Result<Outcome, Status>) {
        self.push_completion(a.id, a.job.code(), result);
        self.out.clear();
    }

    /// Rule 3 / [ET200S SI 2005] §2.12.7: cancel, write idle, wait for idle, repeat the whole job.
    fn back_off(&mut self, mut a: Active, seen: CoordByte) -> Option<Active> {
        self.stats.backoffs += 1;
        if self.events.len() < self.cfg.queue_capacity + EVENT_SLACK {
            self.events
                .push_back(HostEvent::BackedOff { id: a.id, seen });
        }
        a.phase = Phase::WaitIdle;
        self.out.clear();
        Some(a)
    }

    /// The execution number of segment `k` under the configured wrap (`[derived]`).
    fn exec(&self, k: usize) -> u8 {
        self.cfg.exec_wrap.of_segment(k)
    }

    fn show_segment(&mut self, code: JobCode, k: usize) {
        self.out
            .set_segment(CoordByte::new(code, self.exec(k)), &self.stream, k);
    }

    /// One cycle of the running job: the phase handler decides, this applies the decision.
    fn step(&mut self, mut a: Active, c: CoordByte, inw: &Window) -> Option<Active> {
        let next = match a.phase {
            Phase::WaitIdle => Next::Stay(Phase::WaitIdle),
            Phase::Request => self.on_request(&a.job, c, inw.word()),
            Phase::Sending(st) => self.on_sending(&a.job, c, inw.word(), st),
            Phase::Receiving(st) => self.on_receiving(c, inw, st),
            Phase::ReadV24 => self.on_read_v24(c, inw),
            Phase::ReadV24Ack(signals) if c.job == JobCode::Idle => {
                Next::Done(Ok(Outcome::Signals(signals)))
            }
            Phase::ReadV24Ack(signals) => Next::Stay(Phase::ReadV24Ack(signals)),
            Phase::WriteV24 => Self::on_write_v24(c, inw.word()),
        };
        match next {
            Next::Stay(phase) => {
                a.phase = phase;
                Some(a)
            }
            Next::Done(result) => {
                self.finish(a, result);
                None
            }
            Next::BackOff => self.back_off(a, c),
        }
    }

    /// Send/parameters, request 10H/50H out: wait for the acceptance ([ET200S SI 2005] §2.12.1 rule
    /// 2).
    fn on_request(&mut self, job: &Job, c: CoordByte, word: u16) -> Next {
        let code = job.code();
        if c.job == JobCode::Idle || (c.job == code && c != CoordByte::new(code, 0)) {
            Next::Stay(Phase::Request)
        } else if c.job == code {
            self.show_segment(code, 1);
            Next::Stay(Phase::Sending(SendState {
                k: 1,
                last: self.cfg.window.segments(self.stream.len()),
                acked: 0,
                in_error: None,
            }))
        } else if c.job == JobCode::EndOfJob {
            // Refused before any segment ([ET200S SI 2005] §2.12.1–§2.12.7 [derived]: "7xH →
            // rejected").
            Next::Done(Err(status_or(word, NOT_POSSIBLE_IN_MODE)))
        } else {
            Next::BackOff
        }
    }

    /// Send/parameters, segment `k` of `last` shown: advance on the echo, go back on the error
    /// bit, finish on 7xH ([ET200S SI 2005] §2.12.7, §2.12.1–§2.12.7 `[derived]`).
    fn on_sending(&mut self, job: &Job, c: CoordByte, word: u16, st: SendState) -> Next {
        let SendState {
            mut k,
            last,
            mut acked,
            mut in_error,
        } = st;
        let code = job.code();
        if c.job == code && !c.error {
            in_error = None;
            if c.exec == self.exec(k) && acked < k {
                acked = k;
                self.stats.segments_sent += 1;
                if k < last {
                    k += 1;
                    self.show_segment(code, k);
                }
            }
        } else if c.job == code {
            // Error bit: resend from the segment after the last valid one.
            if let Some(j) = self.cfg.exec_wrap.segment_with(k, c.exec) {
                if in_error != Some(c.exec) {
                    self.stats.resends += 1;
                }
                in_error = Some(c.exec);
                k = (j + 1).min(last);
                acked = j.min(acked);
                self.show_segment(code, k);
            }
        } else if c.job == JobCode::EndOfJob {
            return Next::Done(if word != 0 {
                Err(lookup(word))
            } else if k == last {
                Ok(match job {
                    Job::Parameters(_) => Outcome::ParametersSet,
                    _ => Outcome::Sent,
                })
            } else {
                Err(NOT_POSSIBLE_IN_MODE)
            });
        } else {
            // Another job code: cancel, wait for idle, repeat the whole job ([ET200S SI 2005]
            // §2.12.7).
            return Next::BackOff;
        }
        Next::Stay(Phase::Sending(SendState {
            k,
            last,
            acked,
            in_error,
        }))
    }

    /// Receive: `k` segments accepted (0 = request 20H out). Echo each segment in order, set the
    /// error bit on one out of order, finish when the module is idle after the last echo.
    fn on_receiving(&mut self, c: CoordByte, inw: &Window, st: RecvState) -> Next {
        let RecvState {
            mut k,
            mut len,
            mut got,
            mut error,
        } = st;
        let word = inw.word();
        let complete = k > 0 && got >= len;
        // With 7 → 0 ([derived]) number 0 is also a segment's: the next one or the last valid one
        // again. While our error bit is out, 20H is the module's abort answer (Table 2-21).
        let zero_is_segment = k > 0 && !error && (self.exec(k) == 0 || self.exec(k + 1) == 0);
        if c.job == JobCode::Receive && !c.error {
            if c.exec == 0 && !zero_is_segment {
                // 20H + STATUS: nothing there, an erroneous frame, or the abort after our error
                // bit ([ET200S SI 2005] §2.12.7, Table 2-21).
                return Next::Done(if word == 0x0101 || word == 0 {
                    if k == 0 && !error {
                        Ok(Outcome::NoMessage)
                    } else {
                        Err(TRANSFER_ERROR_TO_CPU)
                    }
                } else {
                    Err(lookup(word))
                });
            }
            if c.exec == self.exec(k + 1) && !complete {
                let mut data = inw.data();
                if k == 0 {
                    len = usize::from(word);
                    got = 0;
                    data = &data[2..];
                    self.rx.clear();
                    if len <= self.cfg.max_frame_len {
                        self.rx.reserve(len);
                    }
                }
                let take = data.len().min(len - got);
                got += take;
                // A frame longer than we may hold is read to its end and dropped, so the module
                // removes it instead of offering it forever.
                if len <= self.cfg.max_frame_len {
                    self.rx.extend_from_slice(&data[..take]);
                }
                k += 1;
                error = false;
                self.stats.segments_received += 1;
                self.echo_receive(CoordByte::new(JobCode::Receive, self.exec(k)));
            } else if c.exec == self.exec(k) && k > 0 {
                // The last valid segment again (our echo not seen yet, or resent after our
                // error bit): echo it plainly.
                if error {
                    error = false;
                    self.echo_receive(CoordByte::new(JobCode::Receive, self.exec(k)));
                }
            } else {
                // Out of order: error bit + last valid number ([ET200S SI 2005] §2.12.7).
                if !error {
                    self.stats.errors_signalled += 1;
                }
                error = true;
                self.echo_receive(CoordByte::error(JobCode::Receive, self.exec(k)));
            }
        } else if c.job == JobCode::Idle && k > 0 {
            return Next::Done(if !complete {
                // Idle before the end: the transfer was aborted.
                Err(TRANSFER_ERROR_TO_CPU)
            } else if len <= self.cfg.max_frame_len {
                self.rx.truncate(len);
                Ok(Outcome::Received(self.rx.split().freeze()))
            } else {
                Err(RECEIVED_FRAME_TOO_LONG)
            });
        } else if c.job == JobCode::EndOfJob {
            // 111 during the transfer: aborted ([ET200S SI 2005] §2.12.7).
            return Next::Done(Err(TRANSFER_ERROR_TO_CPU));
        } else if k == 0 && !matches!(c.job, JobCode::Idle | JobCode::Receive) {
            // The module acknowledged someone else's job.
            return Next::BackOff;
        }
        // Otherwise (idle before the module saw the request, a foreign code mid-transfer, which
        // the receiver ignores with its data, [ET200S SI 2005] §2.12.7): hold.
        Next::Stay(Phase::Receiving(RecvState { k, len, got, error }))
    }

    fn echo_receive(&mut self, coord: CoordByte) {
        self.out.clear();
        self.out.set_coord(coord);
    }

    /// Read V.24, request 30H out: 31H + signal word → echo 31H (Table 2-25).
    fn on_read_v24(&mut self, c: CoordByte, inw: &Window) -> Next {
        let code = JobCode::ReadV24;
        if c.job == JobCode::Idle || (c.job == code && c.error) {
            Next::Stay(Phase::ReadV24)
        } else if c.job == code && c.exec == self.exec(1) {
            let d = inw.data();
            let signals = self.cfg.v24_layout.decode([d[0], d[1]]);
            self.out.clear();
            self.out.set_coord(CoordByte::new(code, self.exec(1)));
            Next::Stay(Phase::ReadV24Ack(signals))
        } else if c.job == code && c.exec == 0 {
            Next::Done(Err(status_or(inw.word(), NOT_POSSIBLE_IN_MODE)))
        } else if c.job == code {
            Next::Stay(Phase::ReadV24)
        } else {
            Next::BackOff
        }
    }

    /// Write V.24, request 40H + signals out: 40H + STATUS ends it (Table 2-26).
    fn on_write_v24(c: CoordByte, word: u16) -> Next {
        let code = JobCode::WriteV24;
        if c.job == JobCode::Idle || (c.job == code && (c.error || c.exec != 0)) {
            Next::Stay(Phase::WriteV24)
        } else if c.job == code {
            Next::Done(if word == 0 {
                Ok(Outcome::SignalsWritten)
            } else {
                Err(lookup(word))
            })
        } else {
            Next::BackOff
        }
    }
}

/// What a phase handler decided.
enum Next {
    /// Keep the job, in this phase.
    Stay(Phase),
    /// The job ends with this result.
    Done(Result<Outcome, Status>),
    /// Rule 3: back off and repeat.
    BackOff,
}

/// The STATUS of a word, or `fallback` for 0000H (a refusal must carry an error).
fn status_or(word: u16, fallback: Status) -> Status {
    if word == 0 {
        fallback
    } else {
        lookup(word)
    }
}
