//! The 3964 / 3964(R) procedure as one Sans-IO engine that is both sender and receiver, as the
//! module's driver is ([ET200S SI] §2.7 `[derived]`, [CP 341] §2.2.2, Fig. 2-10
//! and the reconstruction of [CP 341] §2.2.2 `[derived]`, [ET200S SI 2005] §2.7.2–§2.7.4, Fig.
//! 2-12, Fig. 2-15).
//!
//! ```
//! use si_3964r::{Config, Event, Link};
//! use si_sim::Simulator;
//! use si_core::{Instant, SerialSettings};
//! use si_3964r::config::Priority;
//!
//! let settings = SerialSettings::default();
//! let high = Config { priority: Priority::High, ..Config::default() };
//! let mut sim = Simulator::new(1);
//! let a = sim.add_station("A", settings, Link::new(high.with_settings(settings)).unwrap());
//! let b = sim.add_station("B", settings, Link::new(Config::default().with_settings(settings)).unwrap());
//! sim.connect(a, b);
//! let job = sim.with(a, |link, now| link.send(now, &b"hello"[..])).unwrap();
//! sim.run_until_quiet(Instant::from_micros(10_000_000));
//! assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
//! assert_eq!(sim.take_events(b), vec![Event::Received { len: 5 }]);
//! assert_eq!(sim.with(b, |link, now| link.take_block(now)).unwrap(), &b"hello"[..]);
//! ```
//!
//! # Readings where the texts are silent or disagree
//!
//! - **Counting attempts (`[derived]`).** A failed `STX` (NAK, other character, QVZ expiry)
//!   costs a *connection* attempt; the counter starts again at 1 for every transmission attempt
//!   (Siemens practice, [ET200S SI] §2.7 `[derived]`). A block that went out and was not
//!   acknowledged with `DLE` (NAK or other characters during or after it, QVZ expiry at the end)
//!   costs a *transmission* attempt. Yielding in an initialization conflict costs nothing: the job
//!   stays pending and starts again with fresh connection attempts once the partner's block is
//!   received ([ET200S SI] §2.7, Fig. 2-16).
//! - **Initialization conflict, high priority (`[derived]`).** The high-priority side ignores the
//!   partner's `STX` and keeps waiting for `DLE` ([CP 341] §2.2.2, [CP 440], [Public 3964R]). When
//!   its connection attempts run out after such an `STX` was seen, the job fails with 070B (both
//!   high). A low-priority side that yielded and then receives a lone `DLE` followed by silence
//!   (the partner yielded too) counts a failed connection attempt with 070C (both low).
//! - **NAK before the repetition.** Only where the manual says so: after other characters
//!   interrupted our block (wait for quiet, NAK, repeat, [ET200S SI] §2.7, sending: partner
//!   interrupts the send) and when giving up ([ET200S SI] §2.7, sending: connection setup and retry
//!   limit). After a NAK or a QVZ expiry the sender repeats `STX` directly.
//! - **ZVZ expiry while receiving.** NAK and report 0806 at once; the receiver starts no retry of
//!   its own and goes to idle ([ET200S SI] §2.7, receiving: character delay monitoring, [CP 341]
//!   §2.2.2, Fig. 2-11/2-12). Errors that let the block run to its end (BCC, parity, framing, odd
//!   DLE, overlong) are answered with NAK and a 4 s wait for the repetition, and reported only when
//!   the repetitions are used up or do not come ([ET200S SI] §2.7, receiving: cleardown and errors
//!   during reception), with the *first* error (`[derived]`).
//! - **No repetition within the 4 s block wait (`[derived]`, 0809H).** The first error is reported
//!   as the state table says, and then 0809H "the number of repetitions must be set to the same
//!   value on both partners": a partner with as many attempts as we have repeats until *our*
//!   count runs out, so one that stops earlier has fewer (the CP 440 names 0809 "block-repeat
//!   wait time expired", [CP 341 Diag]). S_RCV shows the two in two calls: receive errors wait
//!   in a queue, oldest first, one per call, at most [`RECEIVE_ERRORS`] of them (the oldest is
//!   dropped beyond, as si-rk512 keeps its passive side's codes). `[derived]` Table 2-28
//!   ([ET200S SI] §2.13) gives the block's error and 0809H a row each, and S_RCV shows one
//!   STATUS per call; the manual does not say how many codes wait, and a single slot would hide
//!   every first error behind its 0809H.
//! - **Character delay time ZVZ** is the longest *gap* between two characters ([ET200S SI] §2.7,
//!   Table 2-11). A host sees a character only when it is complete, so after a character completing
//!   at `t` the next must complete by `t` + ZVZ + one character time; one microsecond later the gap
//!   was longer than ZVZ and the reception ends with NAK and 0806 ([`SerialSettings::gap_limit`],
//!   the rule of the ASCII driver's character delay time). At 300 bit/s a character takes
//!   37 ms against a ZVZ minimum of 60 ms, so leaving the character time out gave false 0806
//!   errors. After our DLE the first character gets one more character time, the
//!   DLE's own. The quiet waits before a NAK ([ET200S SI] §2.7, sending: partner interrupts the
//!   send, §2.7, receiving: idle) follow the same rule.
//! - **Receiver repetition limit (`[derived]`).** The configured transmission attempts.
//! - **Zero-length block.** Acknowledged with `DLE`, not queued, reported as 0807 "not an error".
//! - **Overlong block (`[derived]`).** Ended with NAK at the first byte too many (not received to
//!   its end, so a partner that never sends `DLE ETX` cannot hold the line), then treated like a
//!   BCC error (repetition awaited), reported as 0850 ([ET200S SI 2005] Table 2-29) unless
//!   an earlier error of the block came first. See [`crate::bound`].
//! - **A bound on every send job `[derived]`.** A job that has not ended by
//!   [`Config::send_job_bound`] after [`Link::send`] ends then with its first error (or 0703H /
//!   070BH), whatever the line is doing; [`crate::bound`] gives the formula and the reasons.
//! - **A corrupted character in idle** is reported at once as 080C ([ET200S SI] §2.7); other
//!   characters in idle are answered, once the line is quiet for ZVZ, with NAK and 0802
//!   ([ET200S SI] §2.7, receiving: idle). An `STX` arriving during that wait is taken as a
//!   connection request (after reporting the 0802).
//! - **BREAK** ends whatever runs at once, without retries: a send job fails with 080D, and 080D
//!   is reported as a receive error ([ET200S SI] §2.7, [CP 341] §2.2.2, Fig. 2-10).
//! - **"DLE too early" (0706)** is not reported. A host sees its own transmission end only
//!   through the driver's tx-done ([`Engine::handle_tx_done`]), which lags the wire by the OS
//!   buffers and the timer granularity (a pseudo-terminal partner answers within microseconds,
//!   tokio timers tick per millisecond). Treating a `DLE` that arrives before tx-done as "too
//!   early" made a prompt partner's acknowledgement look like an error, and the block was sent,
//!   and delivered, twice; so a `DLE` after our block has started is taken as the
//!   acknowledgement. For the same reason a NAK that ends our block before tx-done is reported
//!   as 0705 (NAK while sending) rather than 0706; both repeat the block.
//! - **"More characters after STX without waiting for DLE" (0802)** cannot be told apart from
//!   prompt data on a host with OS buffering, so such characters are received as the block.

use crate::config::{Config, ConfigError, Priority, BLOCK_WAIT, BUFFER_WAIT};
use crate::frame::{self, Decoder, FrameError, DLE, NAK, STX};
use crate::status;
use bytes::Bytes;
use core::fmt;
use serde::{Deserialize, Serialize};
use si_core::delivery::Delivery;
/// The one job id of si-core, here because the async handle and users name it from this module.
pub use si_core::JobId;
use si_core::{Duration, Engine, FramePool, Instant, LineError, Output, SerialSettings, Status};
use std::collections::VecDeque;

/// How many receive errors wait for S_RCV ([`Link::take_receive_error`]); the oldest is
/// dropped beyond. Two are needed for a failed repetition (its first error, then 0809H).
pub const RECEIVE_ERRORS: usize = 4;

/// What the engine tells the application.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// The partner acknowledged the block of this job with `DLE`: S_SEND's DONE.
    Sent {
        /// The job.
        job: JobId,
    },
    /// The job gave up with the manual's STATUS (class 07H, or 080C / 080D): S_SEND's ERROR.
    SendFailed {
        /// The job.
        job: JobId,
        /// The first error of the job ([ET200S SI] §2.7, `[derived]`).
        status: Status,
    },
    /// A block arrived intact and waits in the receive buffer; take it with
    /// [`Link::take_block`]. Reported once per block.
    Received {
        /// Its length in bytes.
        len: usize,
    },
    /// A reception failed, or the idle line saw something wrong: S_RCV's ERROR (class 08H).
    ReceiveError(Status),
}

/// Why a send job was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SendError {
    /// A job is still running; like S_SEND, one job at a time.
    #[error("a send job is still running")]
    Busy,
    /// No data (S_SEND LEN must be at least 1).
    #[error("nothing to send: a block needs at least 1 byte")]
    Empty,
    /// More data than the configured maximum block length.
    #[error("block of {len} bytes is longer than the maximum of {max}")]
    TooLong {
        /// Bytes given.
        len: usize,
        /// The configured maximum.
        max: usize,
    },
}

impl SendError {
    /// The STATUS an FB would show for this refusal (1E41 "invalid LEN", or 0502 when busy).
    pub fn status(self) -> Status {
        match self {
            SendError::Busy => si_core::status::common::NOT_POSSIBLE_IN_MODE,
            SendError::Empty | SendError::TooLong { .. } => si_core::status::common::INVALID_LEN,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Waiting for a job or the partner's STX.
    Idle,
    /// A character other than STX/NAK arrived in idle: wait until the line is quiet, then NAK.
    IdleQuiet { until: Instant },
    /// We sent STX and wait for the partner's DLE.
    WaitConnAck { deadline: Instant },
    /// Our block is on its way out; `deadline` is the latest the QVZ can end if the driver never
    /// reports tx-done.
    Sending { deadline: Instant },
    /// Block sent (DLE ETX [BCC]); waiting for the partner's DLE.
    WaitEndAck { deadline: Instant },
    /// The partner interrupted our block with characters: wait for quiet, NAK, repeat.
    SendQuiet { until: Instant },
    /// STX arrived with the receive buffer full: wait up to 400 ms for a free slot.
    WaitBuffer { deadline: Instant, conflict: bool },
    /// Receiving a block; `deadline` is ZVZ after the last character.
    Receiving { deadline: Instant, conflict: bool },
    /// We answered a bad block with NAK and wait up to 4 s for the repetition.
    WaitRepeat { deadline: Instant },
}

/// Running totals since the link was created, for diagnostics and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// Blocks put on the line (every transmission attempt that got the partner's DLE).
    pub blocks_sent: u64,
    /// Of those, repetitions (transmission attempts after the first of a job).
    pub repetitions: u64,
    /// Blocks received intact and queued.
    pub blocks_received: u64,
    /// Blocks answered with NAK.
    pub blocks_rejected: u64,
}

#[derive(Debug)]
struct Job {
    id: JobId,
    data: Bytes,
    conn_try: u8,
    tx_try: u8,
    first_err: Option<Status>,
    conflict_seen: bool,
    /// When [`Link::send`] took it.
    started: Instant,
    /// The port's delivery allowance [`deadline`](Self::deadline) was computed with.
    allowance: Duration,
    /// The job's bound ([`Config::send_job_bound`], with the port's allowance) from its start;
    /// widened if the allowance grows while the job runs ([`Link::widen_job_bound`]).
    deadline: Instant,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Attempt {
    Connection,
    Transmission,
}

/// The 3964 / 3964(R) engine: sender and receiver on one line.
///
/// Drive it as every [`Engine`]: feed it bytes, line errors, tx-done and timeouts, drain
/// [`poll_output`](Engine::poll_output) until `Wait`. Start a job with [`send`](Link::send); take
/// received blocks with [`take_block`](Link::take_block).
pub struct Link {
    config: Config,
    settings: SerialSettings,
    state: State,
    job: Option<Job>,
    next_job: u64,
    decoder: Decoder,
    rx_line_error: bool,
    rx_try: u8,
    rx_first_err: Option<Status>,
    received: VecDeque<Bytes>,
    out: VecDeque<Output<Event>>,
    tx_buf: Vec<u8>,
    /// Transmit frames are cut from this pool: a steady state allocates nothing per frame (the
    /// si-core contract).
    tx_pool: FramePool,
    /// Received blocks are cut from a pool the same way: once the application drops the
    /// blocks it took, the allocation is reused.
    rx_pool: FramePool,
    last_outcome: Option<(JobId, Result<(), Status>)>,
    /// Receive errors not yet taken by S_RCV, oldest first (at most [`RECEIVE_ERRORS`]).
    receive_errors: VecDeque<Status>,
    counters: Counters,
    /// How late the port hands bytes over: ZVZ and QVZ get its allowance.
    delivery: Delivery,
}

impl fmt::Debug for Link {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Link")
            .field("state", &self.state)
            .field("job", &self.job.as_ref().map(|j| j.id))
            .field("received", &self.received.len())
            .finish()
    }
}

impl Link {
    /// A link with `config`, on a line with the config's own [`settings`](Config::settings)
    /// (used to know how long our own bytes take on the wire). Queues the startup NAK that puts the partner into idle ([ET200S SI] §2.7,
    /// receiving: startup NAK). Refuses parameters out of range, ZVZ and QVZ also below their
    /// minimum for the line's baud rate ([`Config::validate_for`]).
    pub fn new(config: Config) -> Result<Link, ConfigError> {
        let settings = config.settings;
        config.validate_for(&settings)?;
        let max = usize::from(config.max_block_len);
        let mut link = Link {
            config,
            settings,
            state: State::Idle,
            job: None,
            next_job: 1,
            decoder: Decoder::new(config.mode(), max),
            rx_line_error: false,
            rx_try: 0,
            rx_first_err: None,
            received: VecDeque::with_capacity(config.receive_buffer_blocks.into()),
            out: VecDeque::with_capacity(8),
            tx_buf: Vec::with_capacity(2 * max + 3),
            tx_pool: FramePool::preallocated(2 * (2 * max + 3)),
            rx_pool: FramePool::preallocated(2 * max),
            last_outcome: None,
            receive_errors: VecDeque::with_capacity(RECEIVE_ERRORS),
            counters: Counters::default(),
            delivery: Delivery::new(&settings),
        };
        link.transmit_static(&[NAK]);
        Ok(link)
    }

    /// Running totals (blocks sent, repetitions, received, rejected).
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The line's character format.
    pub fn settings(&self) -> SerialSettings {
        self.settings
    }

    /// The parameters.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Start sending `data` as one block (S_SEND with REQ). The job ends with exactly one
    /// [`Event::Sent`] or [`Event::SendFailed`] carrying the returned id.
    pub fn send(&mut self, now: Instant, data: impl Into<Bytes>) -> Result<JobId, SendError> {
        let data = data.into();
        if self.job.is_some() {
            return Err(SendError::Busy);
        }
        if data.is_empty() {
            return Err(SendError::Empty);
        }
        let max = usize::from(self.config.max_block_len);
        if data.len() > max {
            return Err(SendError::TooLong {
                len: data.len(),
                max,
            });
        }
        let id = JobId(self.next_job);
        self.next_job += 1;
        let allowance = self.delivery.allowance();
        let bound = self
            .config
            .send_job_bound_with(&self.settings, data.len(), allowance);
        self.job = Some(Job {
            id,
            data,
            conn_try: 1,
            tx_try: 1,
            first_err: None,
            conflict_seen: false,
            started: now,
            allowance,
            deadline: now + bound,
        });
        if self.state == State::Idle {
            self.connect(now);
        }
        Ok(id)
    }

    /// A port found to packetise while a job runs (a USB adapter learnt from a multi-byte read)
    /// lengthens every QVZ and ZVZ wait from then on: the job's deadline grows with it, so
    /// the bound never cuts off attempts the manual still allows.
    fn widen_job_bound(&mut self) {
        let allowance = self.delivery.allowance();
        if let Some(job) = self.job.as_mut().filter(|j| allowance > j.allowance) {
            let bound = self
                .config
                .send_job_bound_with(&self.settings, job.data.len(), allowance);
            job.allowance = allowance;
            job.deadline = job.deadline.max(job.started + bound);
        }
    }

    /// True while a send job runs (or waits for the line).
    pub fn is_sending(&self) -> bool {
        self.job.is_some()
    }

    /// The outcome of job `id` if it was the last job to finish.
    pub fn job_outcome(&self, id: JobId) -> Option<Result<(), Status>> {
        self.last_outcome.filter(|(j, _)| *j == id).map(|(_, r)| r)
    }

    /// Take the oldest received block from the receive buffer. Freeing a slot while a partner
    /// waits for one (the 400 ms buffer wait) answers its STX with DLE at `now`.
    pub fn take_block(&mut self, now: Instant) -> Option<Bytes> {
        let block = self.received.pop_front()?;
        if let State::WaitBuffer { conflict, .. } = self.state {
            self.start_receiving(now, conflict);
        }
        Some(block)
    }

    /// CPU STOP → RUN ([ET200S SI] §2.11, [ET200S SI 2005] §2.11, §3.9):
    /// with [`Config::clear_at_startup`] the blocks waiting in the receive buffer are dropped, so
    /// only blocks received after the startup are delivered; without it they stay and are
    /// delivered again. The line procedure is the module's, not the CPU's: a job or a reception
    /// in progress runs on. A partner waiting for a free buffer (the 400 ms wait) is answered
    /// with DLE once the clearing freed a slot.
    pub fn restart(&mut self, now: Instant) {
        if !self.config.clear_at_startup {
            return;
        }
        self.received.clear();
        if let State::WaitBuffer { conflict, .. } = self.state {
            self.start_receiving(now, conflict);
        }
    }

    /// Blocks waiting in the receive buffer.
    pub fn received_blocks(&self) -> usize {
        self.received.len()
    }

    /// True when more than 2/3 of the receive buffer is in use (S_RCV's warning 0B01, [ET200S SI]
    /// §2.10, Table 2-14).
    pub fn buffer_two_thirds_full(&self) -> bool {
        self.received.len() * 3 > usize::from(self.config.receive_buffer_blocks) * 2
    }

    /// The oldest receive error not yet taken (for the S_RCV equivalent): one per call, so a
    /// failed repetition shows its first error and then 0809H (module docs, "No repetition
    /// within the 4 s block wait"). At most [`RECEIVE_ERRORS`] wait; the oldest is dropped
    /// beyond.
    pub fn take_receive_error(&mut self) -> Option<Status> {
        self.receive_errors.pop_front()
    }

    // --- sending -------------------------------------------------------------------------

    /// Send STX for the pending job and wait for DLE.
    fn connect(&mut self, now: Instant) {
        self.transmit_static(&[STX]);
        self.state = State::WaitConnAck {
            deadline: now + self.settings.char_time() + self.ack_delay(),
        };
    }

    fn send_block(&mut self, now: Instant) {
        let Some(job) = &self.job else {
            self.state = State::Idle;
            return;
        };
        self.counters.blocks_sent += 1;
        if job.tx_try > 1 {
            self.counters.repetitions += 1;
        }
        self.tx_buf.clear();
        frame::encode_into(&job.data, self.config.mode(), &mut self.tx_buf);
        let on_wire = self.settings.chars_time(self.tx_buf.len() as u64);
        let block = self.tx_pool.cut(&self.tx_buf);
        self.out.push_back(Output::Transmit(block));
        self.state = State::Sending {
            deadline: now + on_wire + self.ack_delay(),
        };
    }

    /// One attempt failed with `error`; repeat or give up ([ET200S SI] §2.7 `[derived]`).
    fn attempt_failed(&mut self, now: Instant, kind: Attempt, error: Status, nak_first: bool) {
        let (conn_max, tx_max) = (
            self.config.connection_attempts,
            self.config.transmission_attempts,
        );
        let Some(job) = &mut self.job else {
            self.enter_idle(now);
            return;
        };
        job.first_err.get_or_insert(error);
        let exhausted = match kind {
            Attempt::Connection => {
                job.conn_try = job.conn_try.saturating_add(1);
                job.conn_try > conn_max
            }
            Attempt::Transmission => {
                job.tx_try = job.tx_try.saturating_add(1);
                job.conn_try = 1;
                job.tx_try > tx_max
            }
        };
        if exhausted {
            let first = job.first_err.unwrap_or(error);
            let status = match kind {
                Attempt::Connection => self.final_status(first),
                Attempt::Transmission => first,
            };
            // Giving up: NAK to the partner ([ET200S SI] §2.7, sending: connection setup and retry
            // limit).
            self.transmit_static(&[NAK]);
            self.finish_job(Err(status));
            self.enter_idle(now);
        } else {
            if nak_first {
                self.transmit_static(&[NAK]);
            }
            self.connect(now);
        }
    }

    /// What a job that gives up while connecting reports: its first error, or 070B when a
    /// high-priority side met the partner's `STX` (both high, [ET200S SI] §2.7, Fig. 2-16).
    fn final_status(&self, error: Status) -> Status {
        let Some(job) = &self.job else { return error };
        if job.conflict_seen && self.config.priority == Priority::High {
            status::CONFLICT_BOTH_HIGH
        } else {
            job.first_err.unwrap_or(error)
        }
    }

    /// The job's bound has passed ([`crate::bound`]): end it whatever the line is doing. A job
    /// that is on the line is given up with NAK ([ET200S SI] §2.7, sending: retry limit); a
    /// reception in progress, for which the job was waiting, runs on.
    fn end_overdue_job(&mut self, now: Instant) {
        if self.job.as_ref().is_none_or(|j| now < j.deadline) {
            return;
        }
        let status = self.final_status(status::SETUP_TIMEOUT);
        let on_the_line = matches!(
            self.state,
            State::WaitConnAck { .. }
                | State::Sending { .. }
                | State::WaitEndAck { .. }
                | State::SendQuiet { .. }
        );
        self.finish_job(Err(status));
        if on_the_line {
            self.transmit_static(&[NAK]);
            self.state = State::Idle;
        }
    }

    fn finish_job(&mut self, result: Result<(), Status>) {
        if let Some(job) = self.job.take() {
            self.last_outcome = Some((job.id, result));
            self.out.push_back(Output::Event(match result {
                Ok(()) => Event::Sent { job: job.id },
                Err(status) => Event::SendFailed {
                    job: job.id,
                    status,
                },
            }));
        }
    }

    // --- receiving -----------------------------------------------------------------------

    /// STX from the partner: answer DLE if a buffer slot is free, else start the buffer wait.
    fn accept_stx(&mut self, now: Instant, conflict: bool) {
        if self.received.len() < usize::from(self.config.receive_buffer_blocks) {
            self.start_receiving(now, conflict);
        } else {
            self.state = State::WaitBuffer {
                deadline: now + BUFFER_WAIT,
                conflict,
            };
        }
    }

    fn start_receiving(&mut self, now: Instant, conflict: bool) {
        self.transmit_static(&[DLE]);
        self.decoder.reset();
        self.rx_line_error = false;
        // Our DLE takes one character time to leave; the partner's first character may start
        // up to ZVZ after that.
        self.state = State::Receiving {
            deadline: self.zvz_deadline(now + self.settings.char_time()),
            conflict,
        };
    }

    /// The block is complete: acknowledge or reject it ([ET200S SI] §2.7, receiving: cleardown and
    /// errors during reception, §2.7, Fig. 2-15).
    fn end_of_block(&mut self, now: Instant, result: Result<(), FrameError>) {
        let error = match result {
            _ if self.rx_line_error => Some(status::TRANSMISSION_ERROR),
            Ok(()) => None,
            Err(e) => Some(match e {
                FrameError::OddDle { .. } => status::ODD_DLE,
                FrameError::Bcc { .. } => status::BCC_ERROR,
                FrameError::TooLong { .. } => status::BLOCK_TOO_LONG,
                _ => status::TRANSMISSION_ERROR,
            }),
        };
        match error {
            None => {
                self.transmit_static(&[DLE]);
                self.rx_try = 0;
                self.rx_first_err = None;
                let payload = self.decoder.payload();
                if payload.is_empty() {
                    self.receive_error(status::ZERO_LENGTH);
                } else {
                    let len = payload.len();
                    self.counters.blocks_received += 1;
                    self.received.push_back(self.rx_pool.cut(payload));
                    self.out.push_back(Output::Event(Event::Received { len }));
                }
                self.enter_idle(now);
            }
            Some(error) => {
                self.counters.blocks_rejected += 1;
                self.transmit_static(&[NAK]);
                self.rx_first_err.get_or_insert(error);
                self.rx_try = self.rx_try.saturating_add(1);
                if self.rx_try >= self.config.transmission_attempts {
                    self.give_up_receiving(now);
                } else {
                    self.state = State::WaitRepeat {
                        deadline: now + BLOCK_WAIT,
                    };
                }
            }
        }
    }

    fn give_up_receiving(&mut self, now: Instant) {
        let error = self.rx_first_err.take().unwrap_or(status::CHARACTER_DELAY);
        self.rx_try = 0;
        self.receive_error(error);
        self.enter_idle(now);
    }

    fn receive_error(&mut self, status: Status) {
        if self.receive_errors.len() == RECEIVE_ERRORS {
            self.receive_errors.pop_front();
        }
        self.receive_errors.push_back(status);
        self.out
            .push_back(Output::Event(Event::ReceiveError(status)));
    }

    /// Back to idle; a pending job (postponed by a conflict or a reception) starts now.
    fn enter_idle(&mut self, now: Instant) {
        self.state = State::Idle;
        if let Some(job) = &mut self.job {
            job.conn_try = 1;
            self.connect(now);
        }
    }

    fn transmit_static(&mut self, bytes: &'static [u8]) {
        self.out
            .push_back(Output::Transmit(Bytes::from_static(bytes)));
    }

    /// The character delay time ZVZ, plus the port's allowance (zero on a port that delivers
    /// byte by byte; see [`si_core::delivery`]): a partner's next character may reach us up to
    /// the port's latency late.
    fn char_delay(&self) -> Duration {
        self.config.char_delay + self.delivery.allowance()
    }

    /// When the gap after a character that completed at `now` is longer than ZVZ: the next
    /// character may start up to ZVZ later and is seen one character time after that
    /// ([`SerialSettings::gap_limit`], the rule the ASCII driver's character delay time follows).
    fn zvz_deadline(&self, now: Instant) -> Instant {
        now + self.settings.gap_limit(self.char_delay())
    }

    /// The acknowledgement delay time QVZ, plus the port's allowance (as [`Self::char_delay`]).
    fn ack_delay(&self) -> Duration {
        self.config.ack_delay + self.delivery.allowance()
    }

    // --- input dispatch ------------------------------------------------------------------

    fn on_byte(&mut self, now: Instant, byte: u8) {
        match self.state {
            State::Idle => match byte {
                STX => {
                    self.rx_try = 0;
                    self.rx_first_err = None;
                    self.accept_stx(now, false);
                }
                NAK => {}
                _ => {
                    self.state = State::IdleQuiet {
                        until: self.zvz_deadline(now),
                    }
                }
            },
            State::IdleQuiet { .. } => {
                if byte == STX {
                    self.receive_error(status::IDLE_GARBAGE);
                    self.rx_try = 0;
                    self.rx_first_err = None;
                    self.accept_stx(now, false);
                } else {
                    self.state = State::IdleQuiet {
                        until: self.zvz_deadline(now),
                    };
                }
            }
            State::WaitConnAck { .. } => match byte {
                DLE => self.send_block(now),
                STX => {
                    if let Some(job) = &mut self.job {
                        job.conflict_seen = true;
                    }
                    if self.config.priority == Priority::Low {
                        // Yield: answer DLE and receive first; the job stays pending ([ET200S SI]
                        // §2.7, Fig. 2-16).
                        self.rx_try = 0;
                        self.rx_first_err = None;
                        self.accept_stx(now, true);
                    }
                }
                _ => self.attempt_failed(now, Attempt::Connection, status::SETUP_REJECTED, false),
            },
            State::Sending { .. } => match byte {
                NAK => self.attempt_failed(
                    now,
                    Attempt::Transmission,
                    status::NAK_WHILE_SENDING,
                    false,
                ),
                // The acknowledgement, reported by the driver before its tx-done (see the
                // module docs on "DLE too early").
                DLE => {
                    self.finish_job(Ok(()));
                    self.enter_idle(now);
                }
                _ => self.interrupted(now, status::ABORTED_BY_PARTNER),
            },
            State::SendQuiet { .. } => {
                self.state = State::SendQuiet {
                    until: self.zvz_deadline(now),
                };
            }
            State::WaitEndAck { .. } => {
                if byte == DLE {
                    self.finish_job(Ok(()));
                    self.enter_idle(now);
                } else {
                    self.attempt_failed(now, Attempt::Transmission, status::END_REJECTED, false);
                }
            }
            State::WaitBuffer { .. } => {}
            State::Receiving { conflict, .. } => {
                self.state = State::Receiving {
                    deadline: self.zvz_deadline(now),
                    conflict,
                };
                if let Some(result) = self.decoder.push(byte) {
                    self.end_of_block(now, result);
                } else if self.decoder.is_overlong() {
                    // The receive buffer cannot take more: end the block here (see the
                    // module docs), with its first error.
                    let error = self.decoder.error().map_or(Ok(()), Err);
                    self.end_of_block(now, error);
                }
            }
            State::WaitRepeat { .. } => {
                if byte == STX {
                    self.accept_stx(now, false);
                }
            }
        }
    }

    /// Characters from the partner while our block goes out: wait for quiet, then NAK and
    /// repeat ([ET200S SI] §2.7, sending: partner interrupts the send).
    fn interrupted(&mut self, now: Instant, error: Status) {
        if let Some(job) = &mut self.job {
            job.first_err.get_or_insert(error);
        }
        self.state = State::SendQuiet {
            until: self.zvz_deadline(now),
        };
    }

    fn on_line_error(&mut self, now: Instant, error: LineError) {
        if error == LineError::Break {
            return self.on_break(now);
        }
        let bad = status::TRANSMISSION_ERROR;
        match self.state {
            State::Idle => self.receive_error(bad),
            State::IdleQuiet { .. } | State::SendQuiet { .. } => self.on_byte(now, 0xFF),
            State::WaitConnAck { .. } => self.attempt_failed(now, Attempt::Connection, bad, false),
            State::Sending { .. } => self.interrupted(now, bad),
            State::WaitEndAck { .. } => self.attempt_failed(now, Attempt::Transmission, bad, false),
            State::WaitBuffer { .. } | State::WaitRepeat { .. } => {}
            State::Receiving { conflict, .. } => {
                self.rx_line_error = true;
                if self.decoder.awaiting_bcc() {
                    // The BCC itself arrived corrupted: the block is complete and bad.
                    self.end_of_block(now, Ok(()));
                } else {
                    self.state = State::Receiving {
                        deadline: self.zvz_deadline(now),
                        conflict,
                    };
                }
            }
        }
    }

    /// BREAK: back to idle at once, no retries ([ET200S SI] §2.7).
    fn on_break(&mut self, now: Instant) {
        self.finish_job(Err(status::BREAK));
        self.rx_try = 0;
        self.rx_first_err = None;
        self.receive_error(status::BREAK);
        self.state = State::Idle;
        let _ = now;
    }

    /// The next instant the engine must be woken: the state's timer or the job's bound.
    fn deadline(&self) -> Option<Instant> {
        Instant::earliest(self.state_deadline(), self.job.as_ref().map(|j| j.deadline))
    }

    fn state_deadline(&self) -> Option<Instant> {
        match self.state {
            State::Idle => None,
            State::IdleQuiet { until } | State::SendQuiet { until } => Some(until),
            State::WaitConnAck { deadline }
            | State::Sending { deadline }
            | State::WaitEndAck { deadline }
            | State::WaitBuffer { deadline, .. }
            | State::Receiving { deadline, .. }
            | State::WaitRepeat { deadline } => Some(deadline),
        }
    }

    fn on_deadline(&mut self, now: Instant) {
        match self.state {
            State::Idle => {}
            State::IdleQuiet { .. } => {
                self.transmit_static(&[NAK]);
                self.receive_error(status::IDLE_GARBAGE);
                self.enter_idle(now);
            }
            State::WaitConnAck { .. } => {
                self.attempt_failed(now, Attempt::Connection, status::SETUP_TIMEOUT, false)
            }
            State::Sending { .. } | State::WaitEndAck { .. } => {
                self.attempt_failed(now, Attempt::Transmission, status::END_TIMEOUT, false)
            }
            State::SendQuiet { .. } => {
                let error = self
                    .job
                    .as_ref()
                    .and_then(|j| j.first_err)
                    .unwrap_or(status::ABORTED_BY_PARTNER);
                self.attempt_failed(now, Attempt::Transmission, error, true)
            }
            State::WaitBuffer { .. } => {
                self.transmit_static(&[NAK]);
                self.receive_error(status::NO_FREE_BUFFER);
                self.enter_idle(now);
            }
            State::Receiving { conflict, .. } => {
                if conflict && self.decoder.received() == 1 && self.decoder.after_dle() {
                    // We yielded and the partner's answer was a lone DLE: it yielded too.
                    self.state = State::Idle;
                    self.attempt_failed(now, Attempt::Connection, status::CONFLICT_BOTH_LOW, false);
                    return;
                }
                self.transmit_static(&[NAK]);
                let error = self.rx_first_err.take().unwrap_or(status::CHARACTER_DELAY);
                self.rx_try = 0;
                self.receive_error(error);
                self.enter_idle(now);
            }
            State::WaitRepeat { .. } => {
                self.give_up_receiving(now);
                self.receive_error(status::REPETITIONS_DIFFER);
            }
        }
    }
}

impl Engine for Link {
    type Event = Event;

    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        // Checked here too: on a line that never goes quiet the bound holds even if the
        // driver's timers are late.
        self.end_overdue_job(now);
        self.delivery.observe(now, bytes.len());
        self.widen_job_bound();
        for &b in bytes {
            self.on_byte(now, b);
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.end_overdue_job(now);
        if self.state_deadline().is_some_and(|d| now >= d) {
            self.on_deadline(now);
        }
    }

    fn handle_tx_done(&mut self, now: Instant) {
        if let State::Sending { .. } = self.state {
            self.state = State::WaitEndAck {
                deadline: now + self.ack_delay(),
            };
        }
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.end_overdue_job(now);
        self.on_line_error(now, error);
    }

    fn set_rx_latency(&mut self, latency: Duration) {
        self.delivery.declare(latency);
        self.widen_job_bound();
    }

    fn poll_output(&mut self) -> Output<Event> {
        self.out
            .pop_front()
            .unwrap_or_else(|| Output::Wait(self.deadline()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_port_learnt_to_packetise_mid_job_widens_the_jobs_deadline() {
        let settings = SerialSettings::default();
        let mut link = Link::new(Config::default().with_settings(settings)).unwrap();
        link.set_rx_latency(Duration::ZERO); // declared byte by byte until a read shows more
        let start = Instant::ZERO;
        link.send(start, &b"hello"[..]).unwrap();
        let before = link.job.as_ref().unwrap().deadline;
        assert_eq!(
            before,
            start + Config::default().send_job_bound(&settings, 5),
            "no allowance on a port not yet seen to packetise"
        );
        // Two bytes in one read: the port hands bytes over in packets (a USB adapter).
        link.handle_rx(start + Duration::from_millis(1), &[0x55, 0x55]);
        let job = link.job.as_ref().expect("the job runs on");
        assert!(job.allowance > Duration::ZERO);
        assert_eq!(
            job.deadline,
            start + Config::default().send_job_bound_with(&settings, 5, link.delivery.allowance())
        );
        assert!(job.deadline > before);
    }
}
