//! The RK 512 station: one Sans-IO engine that runs the active side (our SEND and FETCH jobs)
//! and the passive side (the partner's jobs, served from memory) over one 3964(R)
//! [`Link`] (cp341-3964r-rk512-ascii.md §4.1, §4.5–§4.7).
//!
//! ```
//! use si_rk512::frame::{Address, Coordination};
//! use si_rk512::passive::ServerConfig;
//! use si_rk512::{Config, Event, Station};
//! use si_3964r::Priority;
//! use si_core::sim::Simulator;
//! use si_core::memory::Area;
//! use si_core::{Instant, SerialSettings};
//!
//! let line = SerialSettings::default();
//! let mut active_config = Config::default();
//! active_config.link.priority = Priority::High;
//! let mut serve = ServerConfig::default();
//! serve.memory.dbs.insert(10, 512);
//!
//! let mut sim = Simulator::new(1);
//! let host = sim.add_station("host", line, Station::new(active_config, line).unwrap());
//! let plc = sim.add_station("PLC", line, Station::serving(Config::default(), line, &serve).unwrap());
//! sim.connect(host, plc);
//!
//! let job = sim
//!     .with(host, |s, now| s.send(now, Address::Db { db: 10, dw: 1 }, Coordination::NONE, &[0x12, 0x34][..]))
//!     .unwrap();
//! sim.run_until_quiet(Instant::from_micros(30_000_000));
//! assert_eq!(sim.take_events(host), vec![Event::Done { job, data: Default::default() }]);
//! assert_eq!(sim.engine(plc).server().memory().word(Area::Db(10), 2).unwrap(), 0x1234);
//! ```
//!
//! # How it works, and the readings chosen
//!
//! - **One job at a time** (§4.6 "nesting depth is 1"): [`Station::send`] and
//!   [`Station::fetch`] refuse a second job with [`RequestError::Busy`]. The passive side runs
//!   at most one partner job; both may run at once (quasi-full-duplex).
//! - **Telegram order (Fig. 2-17).** Telegrams wait in a FIFO of two (one command, one
//!   reaction) and go out one 3964(R) block after the other in the order they were made, so a
//!   reaction may wait until our own command has gone out, as the figure shows.
//! - **TRES** starts when the partner acknowledged our command telegram (its `DLE`), for every
//!   first and continuation telegram, and on the passive side when our reaction that asks for a
//!   continuation was acknowledged. Expiry ends the job with 0814 (A-12, §4.7).
//! - **A first reaction where a continuation reaction was due** (Fig. 2-18) ends the job with
//!   0813; a reaction nobody waits for is reported as a receive error 0813 and dropped.
//! - **A reaction with an error number** ends the job with that number's class 09H STATUS; a
//!   FETCH reaction with the wrong amount of data, or a SEND reaction with data, with 0810.
//! - **3964(R) failures** of our command telegram end the job with the link's STATUS (class
//!   07H); the link's receive errors are passed on as [`Event::ReceiveError`].

use crate::config::Config;
use crate::frame::{
    Address, Command, CommandHeader, ContinuationHeader, Coordination, DataType, Telegram,
    COMMAND_HEADER_LEN, MAX_DATA_PER_TELEGRAM,
};
use crate::passive::{Served, Server, ServerConfig};
use crate::status::{self, ErrorNumber};
use bytes::{Bytes, BytesMut};
use core::fmt;
use si_3964r::{ConfigError, Link};
use si_core::status::common;
use si_core::{
    Engine, FramePool, Instant, LineError, ModemSignals, Output, SerialSettings, Status,
};
use std::collections::VecDeque;

/// The one job id of si-core, here because the async handle and users name it from this module.
pub use si_core::JobId;

/// What the station tells the application.
#[derive(Clone, PartialEq, Eq)]
pub enum Event {
    /// Our job finished without error: the partner accepted all SEND data (`data` empty), or
    /// all FETCH data arrived (`data`).
    Done {
        /// The job.
        job: JobId,
        /// The fetched bytes; empty for SEND.
        data: Bytes,
    },
    /// Our job ended with an error (class 07H/08H from the link or the reaction checks, class
    /// 09H from the partner's error number).
    Failed {
        /// The job.
        job: JobId,
        /// What went wrong.
        status: Status,
    },
    /// The passive side completed a partner's job.
    Served {
        /// SEND, SEND to DX or FETCH.
        command: Command,
        /// Where the data went or came from.
        address: Address,
        /// Bytes of the whole job.
        len: usize,
    },
    /// The passive side answered a partner's telegram with an error number.
    Refused {
        /// The number sent in the reaction.
        error: ErrorNumber,
    },
    /// A partner's job broke off: no continuation within TRES (0814), a new first telegram
    /// instead (0813), or our reaction could not be delivered (the link's STATUS).
    ServeAborted(Status),
    /// The link reported a receive error (class 08H), or a telegram arrived that nobody expects.
    ReceiveError(Status),
}

impl fmt::Debug for Event {
    /// As derived, except that long FETCH data show as their length (traces stay readable).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Event::Done { job, data } if data.len() > 16 => f
                .debug_struct("Done")
                .field("job", job)
                .field("data", &format_args!("{} bytes", data.len()))
                .finish(),
            Event::Done { job, data } => f
                .debug_struct("Done")
                .field("job", job)
                .field("data", data)
                .finish(),
            Event::Failed { job, status } => f
                .debug_struct("Failed")
                .field("job", job)
                .field("status", status)
                .finish(),
            Event::Served {
                command,
                address,
                len,
            } => f
                .debug_struct("Served")
                .field("command", command)
                .field("address", address)
                .field("len", len)
                .finish(),
            Event::Refused { error } => f.debug_struct("Refused").field("error", error).finish(),
            Event::ServeAborted(s) => f.debug_tuple("ServeAborted").field(s).finish(),
            Event::ReceiveError(s) => f.debug_tuple("ReceiveError").field(s).finish(),
        }
    }
}

/// Why a job was refused before it started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// A job is still running (§4.6: one job at a time).
    #[error("an RK 512 job is still running")]
    Busy,
    /// Zero bytes, more than the configured maximum, or an odd count for a word-counted type.
    #[error("invalid length {len}: 1 … {max} bytes, even for D, X, T and Z")]
    Length {
        /// Bytes asked for.
        len: usize,
        /// The configured maximum.
        max: usize,
    },
    /// SEND goes only to D (command 'A') or X (command 'O') (Table 2-1 footnote).
    #[error("SEND goes only to a DB or DX, not to {0}")]
    NotSendable(Address),
}

impl RequestError {
    /// The STATUS an FB would show for this refusal: 0502 when busy, 1E41 for the length,
    /// 1E20 (parameter out of range) for a data type SEND cannot use.
    pub fn status(self) -> Status {
        match self {
            RequestError::Busy => common::NOT_POSSIBLE_IN_MODE,
            RequestError::Length { .. } => common::INVALID_LEN,
            RequestError::NotSendable(_) => common::PARAMETER_OUT_OF_RANGE,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Command,
    Reaction,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Our telegram waits in the queue or on the link (its 3964(R) job).
    Sending(Option<si_3964r::JobId>),
    /// Acknowledged; waiting for the reaction until the deadline (TRES).
    Waiting(Instant),
}

#[derive(Debug)]
struct ActiveJob {
    id: JobId,
    header: CommandHeader,
    total: usize,
    done: usize,
    send_data: Bytes,
    /// The fetch pool (index into `fetch_pools`) the FETCH data collect in.
    pool: usize,
    phase: Phase,
}

/// The RK 512 engine: our jobs and the partner's jobs over one 3964(R) link.
pub struct Station {
    config: Config,
    link: Link,
    server: Server,
    job: Option<ActiveJob>,
    next_job: u64,
    queue: VecDeque<(Kind, Bytes)>,
    in_flight: Option<(si_3964r::JobId, Kind)>,
    /// TRES while the partner's continuation is due, started when our reaction was acknowledged.
    serve_deadline: Option<Instant>,
    reaction_in_flight_partial: bool,
    out: VecDeque<Output<Event>>,
    buf: Vec<u8>,
    /// Command and reaction telegrams are cut from these pools, one per kind since at most one
    /// telegram of each kind is alive: a steady state allocates nothing (the si-core contract,
    /// as in the 3964(R) link).
    command_pool: FramePool,
    reaction_pool: FramePool,
    /// FETCH data collect in these, used by turns: `job_outcome` keeps the last
    /// job's data, so the data of the job before it (dropped by the application by then) is
    /// the allocation the next FETCH reclaims.
    fetch_pools: [BytesMut; 2],
    fetch_turn: usize,
    now: Instant,
    last_outcome: Option<(JobId, Result<Bytes, Status>)>,
}

impl fmt::Debug for Station {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Station")
            .field("link", &self.link)
            .field("job", &self.job.as_ref().map(|j| j.id))
            .field("queue", &self.queue.len())
            .finish()
    }
}

impl Station {
    /// An active-only station: it runs our jobs and answers every partner command with error
    /// 0AH (access refused).
    pub fn new(config: Config, settings: SerialSettings) -> Result<Station, ConfigError> {
        Station::with_server(config, settings, Server::refusing())
    }

    /// A station that also serves the partner's jobs from memory of these sizes.
    pub fn serving(
        config: Config,
        settings: SerialSettings,
        server: &ServerConfig,
    ) -> Result<Station, ConfigError> {
        Station::with_server(config, settings, Server::new(server))
    }

    fn with_server(
        config: Config,
        settings: SerialSettings,
        server: Server,
    ) -> Result<Station, ConfigError> {
        config.validate()?;
        Ok(Station {
            link: Link::new(config.link, settings)?,
            config,
            server,
            job: None,
            next_job: 1,
            queue: VecDeque::with_capacity(2),
            in_flight: None,
            serve_deadline: None,
            reaction_in_flight_partial: false,
            out: VecDeque::with_capacity(8),
            buf: Vec::with_capacity(COMMAND_HEADER_LEN + MAX_DATA_PER_TELEGRAM),
            command_pool: FramePool::preallocated(COMMAND_HEADER_LEN + MAX_DATA_PER_TELEGRAM),
            reaction_pool: FramePool::preallocated(COMMAND_HEADER_LEN + MAX_DATA_PER_TELEGRAM),
            fetch_pools: [
                BytesMut::with_capacity(config.max_job_len as usize),
                BytesMut::with_capacity(config.max_job_len as usize),
            ],
            fetch_turn: 0,
            now: Instant::ZERO,
            last_outcome: None,
        })
    }

    /// The line's character format.
    pub fn settings(&self) -> si_core::SerialSettings {
        self.link.settings()
    }

    /// The parameters.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The 3964(R) link underneath (counters, state).
    pub fn link(&self) -> &Link {
        &self.link
    }

    /// The passive side: memory, DX blocks, RUN/STOP.
    pub fn server(&self) -> &Server {
        &self.server
    }

    /// The passive side, mutable (the CPU program's view of its memory).
    pub fn server_mut(&mut self) -> &mut Server {
        &mut self.server
    }

    /// True while our job runs.
    pub fn is_busy(&self) -> bool {
        self.job.is_some()
    }

    /// Telegrams waiting for the link (at most one command and one reaction).
    pub fn queued_telegrams(&self) -> usize {
        self.queue.len()
    }

    /// The outcome of job `id` if it was the last to finish (for the FB equivalents).
    pub fn job_outcome(&self, id: JobId) -> Option<Result<Bytes, Status>> {
        self.last_outcome
            .as_ref()
            .filter(|(j, _)| *j == id)
            .map(|(_, r)| r.clone())
    }

    /// Start a SEND job: `data` to `address` (a DB with command `'A'`, or a DX with `'O'`),
    /// split into telegrams of 128 bytes. Ends with [`Event::Done`] or [`Event::Failed`].
    pub fn send(
        &mut self,
        now: Instant,
        address: Address,
        coordination: Coordination,
        data: impl Into<Bytes>,
    ) -> Result<JobId, RequestError> {
        let data = data.into();
        let command = match address {
            Address::Db { .. } => Command::Send,
            Address::Dx { .. } => Command::SendDx,
            other => return Err(RequestError::NotSendable(other)),
        };
        self.start(now, command, address, coordination, data.len(), data)
    }

    /// Start a FETCH job of `len` bytes from `address` (words for D, X, T, Z: `len` even).
    /// Ends with [`Event::Done`] carrying the data, or [`Event::Failed`].
    pub fn fetch(
        &mut self,
        now: Instant,
        address: Address,
        coordination: Coordination,
        len: usize,
    ) -> Result<JobId, RequestError> {
        self.start(
            now,
            Command::Fetch,
            address,
            coordination,
            len,
            Bytes::new(),
        )
    }

    fn start(
        &mut self,
        now: Instant,
        command: Command,
        address: Address,
        coordination: Coordination,
        len: usize,
        send_data: Bytes,
    ) -> Result<JobId, RequestError> {
        self.now = now;
        if self.job.is_some() {
            return Err(RequestError::Busy);
        }
        let max = self.config.max_job_len as usize;
        let words = address.data_type().counts_words();
        if len == 0 || len > max || (words && !len.is_multiple_of(2)) {
            return Err(RequestError::Length { len, max });
        }
        let units = if words { len / 2 } else { len };
        let header = CommandHeader {
            command,
            address,
            length: u16::try_from(units).map_err(|_| RequestError::Length { len, max })?,
            coordination,
        };
        let id = JobId(self.next_job);
        self.next_job += 1;
        let pool = self.fetch_turn;
        if !command.is_send() {
            self.fetch_turn ^= 1;
            let fetched = &mut self.fetch_pools[pool];
            fetched.clear();
            fetched.reserve(len);
        }
        self.job = Some(ActiveJob {
            id,
            header,
            total: len,
            done: 0,
            send_data,
            pool,
            phase: Phase::Sending(None),
        });
        self.queue_command();
        self.pump();
        Ok(id)
    }

    /// Build the next command telegram of the running job and queue it.
    fn queue_command(&mut self) {
        let Some(job) = &mut self.job else { return };
        self.buf.clear();
        if job.done == 0 {
            self.buf.extend_from_slice(&job.header.encode());
        } else {
            self.buf.extend_from_slice(
                &ContinuationHeader {
                    command: job.header.command,
                    data_type: job.header.address.data_type(),
                }
                .encode(),
            );
        }
        if job.header.address.data_type() == DataType::Counters {
            // Byte 4, the data type: the configured counter letter (A-10).
            self.buf[3] = self.config.counter_letter.byte();
        }
        if job.header.command.is_send() {
            let end = (job.done + MAX_DATA_PER_TELEGRAM).min(job.total);
            if let Some(chunk) = job.send_data.get(job.done..end) {
                self.buf.extend_from_slice(chunk);
            }
        }
        job.phase = Phase::Sending(None);
        let telegram = self.command_pool.cut(&self.buf);
        self.queue.push_back((Kind::Command, telegram));
    }

    /// Hand the next queued telegram to the link when it is free.
    fn pump(&mut self) {
        while self.in_flight.is_none() {
            let Some((kind, telegram)) = self.queue.pop_front() else {
                return;
            };
            match self.link.send(self.now, telegram) {
                Ok(id) => {
                    self.in_flight = Some((id, kind));
                    if kind == Kind::Command {
                        if let Some(job) = &mut self.job {
                            job.phase = Phase::Sending(Some(id));
                        }
                    }
                }
                // Cannot happen with a validated config (telegrams are 4 … 138 bytes and the
                // link is idle); fail the telegram's owner rather than lose it.
                Err(e) => self.telegram_failed(kind, e.status()),
            }
        }
    }

    fn telegram_failed(&mut self, kind: Kind, status: Status) {
        match kind {
            Kind::Command => self.finish(Err(status)),
            Kind::Reaction => {
                if self.server.abort() {
                    self.serve_deadline = None;
                }
                self.event(Event::ServeAborted(status));
            }
        }
    }

    fn finish(&mut self, result: Result<(), Status>) {
        let Some(job) = self.job.take() else { return };
        // A telegram of this job still queued is dropped with it.
        self.queue.retain(|(k, _)| *k != Kind::Command);
        let fetched = &mut self.fetch_pools[job.pool];
        let outcome = match result {
            Ok(()) if !job.header.command.is_send() => Ok(fetched.split().freeze()),
            Ok(()) => Ok(Bytes::new()),
            Err(status) => {
                if !job.header.command.is_send() {
                    fetched.clear();
                }
                Err(status)
            }
        };
        self.last_outcome = Some((job.id, outcome.clone()));
        self.event(match outcome {
            Ok(data) => Event::Done { job: job.id, data },
            Err(status) => Event::Failed {
                job: job.id,
                status,
            },
        });
    }

    fn event(&mut self, event: Event) {
        self.out.push_back(Output::Event(event));
    }

    // --- link events ---------------------------------------------------------------------

    fn on_link_event(&mut self, event: si_3964r::Event) {
        match event {
            si_3964r::Event::Sent { job } => {
                if let Some((id, kind)) = self.in_flight {
                    if id == job {
                        self.in_flight = None;
                        self.telegram_sent(kind, id);
                    }
                }
            }
            si_3964r::Event::SendFailed { job, status } => {
                if let Some((id, kind)) = self.in_flight {
                    if id == job {
                        self.in_flight = None;
                        self.telegram_failed(kind, status);
                    }
                }
            }
            si_3964r::Event::Received { .. } => {
                while let Some(block) = self.link.take_block(self.now) {
                    self.on_telegram(&block);
                }
            }
            si_3964r::Event::ReceiveError(status) => self.event(Event::ReceiveError(status)),
        }
        self.pump();
    }

    fn telegram_sent(&mut self, kind: Kind, id: si_3964r::JobId) {
        let tres = self.now + self.config.response_timeout();
        match kind {
            Kind::Command => {
                if let Some(job) = &mut self.job {
                    if job.phase == Phase::Sending(Some(id)) {
                        job.phase = Phase::Waiting(tres);
                    }
                }
            }
            Kind::Reaction => {
                if self.reaction_in_flight_partial && self.server.expects_continuation() {
                    self.serve_deadline = Some(tres);
                }
            }
        }
    }

    fn on_telegram(&mut self, block: &[u8]) {
        if block.len() >= 3 && block[2] == 0x00 {
            self.on_reaction(block);
        } else {
            self.on_command(block);
        }
    }

    fn on_reaction(&mut self, block: &[u8]) {
        // Only a telegram on the line (or acknowledged) can be answered; a reaction while ours
        // still waits in the queue is a stray one (a duplicate, or meant for an ended job).
        let Some(job) = self
            .job
            .as_mut()
            .filter(|j| j.phase != Phase::Sending(None))
        else {
            self.event(Event::ReceiveError(status::RESPONSE_SEQUENCE));
            return;
        };
        let (header, data) = match Telegram::decode(block) {
            Ok(Telegram::Reaction(h, d)) => (h, d),
            _ => return self.finish(Err(status::RESPONSE_INVALID)),
        };
        let expected_continuation = job.done > 0;
        if header.continuation != expected_continuation {
            return self.finish(Err(status::RESPONSE_SEQUENCE));
        }
        if let Some(status) = status::for_error_byte(header.error) {
            return self.finish(Err(status));
        }
        let chunk = (job.total - job.done).min(MAX_DATA_PER_TELEGRAM);
        if job.header.command.is_send() {
            if !data.is_empty() {
                return self.finish(Err(status::RESPONSE_INVALID));
            }
        } else {
            if data.len() != chunk {
                return self.finish(Err(status::RESPONSE_INVALID));
            }
            self.fetch_pools[job.pool].extend_from_slice(data);
        }
        job.done += chunk;
        if job.done >= job.total {
            self.finish(Ok(()));
        } else {
            self.queue_command();
        }
    }

    fn on_command(&mut self, block: &[u8]) {
        let first = block.first() != Some(&crate::frame::CONTINUATION);
        if first && self.server.abort() {
            self.serve_deadline = None;
            self.event(Event::ServeAborted(status::RESPONSE_SEQUENCE));
        }
        let mut reaction = std::mem::take(&mut self.buf);
        let served = self.server.serve(
            block,
            self.config.dw_unit,
            self.config.max_job_len as usize,
            &mut reaction,
        );
        self.serve_deadline = None;
        self.reaction_in_flight_partial = served == Served::Partial;
        // Nesting depth 1 (§4.6): a partner that sends a new command before our reaction to the
        // last one went out has given that one up, so its stale reaction is replaced. The
        // queue therefore never holds more than one command and one reaction.
        self.queue.retain(|(k, _)| *k != Kind::Reaction);
        let telegram = self.reaction_pool.cut(&reaction);
        self.queue.push_back((Kind::Reaction, telegram));
        self.buf = reaction;
        match served {
            Served::Partial => {}
            Served::Complete {
                command,
                address,
                len,
            } => self.event(Event::Served {
                command,
                address,
                len,
            }),
            Served::Refused(error) => self.event(Event::Refused { error }),
        }
    }

    // --- timers --------------------------------------------------------------------------

    fn own_deadline(&self) -> Option<Instant> {
        let job = match self.job.as_ref().map(|j| j.phase) {
            Some(Phase::Waiting(d)) => Some(d),
            _ => None,
        };
        match (job, self.serve_deadline) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn check_timers(&mut self) {
        let now = self.now;
        if let Some(Phase::Waiting(d)) = self.job.as_ref().map(|j| j.phase) {
            if now >= d {
                self.finish(Err(status::RESPONSE_TIMEOUT));
            }
        }
        if self.serve_deadline.is_some_and(|d| now >= d) {
            self.serve_deadline = None;
            if self.server.abort() {
                self.event(Event::ServeAborted(status::RESPONSE_TIMEOUT));
            }
        }
    }
}

impl Engine for Station {
    type Event = Event;

    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.now = now;
        self.link.handle_rx(now, bytes);
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.now = now;
        self.link.handle_timeout(now);
        self.check_timers();
    }

    fn handle_tx_done(&mut self, now: Instant) {
        self.now = now;
        self.link.handle_tx_done(now);
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.now = now;
        self.link.handle_line_error(now, error);
    }

    fn handle_signals(&mut self, now: Instant, signals: ModemSignals) {
        self.now = now;
        self.link.handle_signals(now, signals);
    }

    /// The 3964(R) link judges the line's silences (ZVZ, QVZ): it gets the port's latency.
    fn set_rx_latency(&mut self, latency: si_core::Duration) {
        self.link.set_rx_latency(latency);
    }

    fn poll_output(&mut self) -> Output<Event> {
        loop {
            if let Some(output) = self.out.pop_front() {
                return output;
            }
            match self.link.poll_output() {
                Output::Transmit(bytes) => return Output::Transmit(bytes),
                Output::SetSignals(update) => return Output::SetSignals(update),
                Output::Event(e) => self.on_link_event(e),
                Output::Wait(deadline) => {
                    if let Some(output) = self.out.pop_front() {
                        return output;
                    }
                    return Output::Wait(match (deadline, self.own_deadline()) {
                        (Some(a), Some(b)) => Some(a.min(b)),
                        (a, b) => a.or(b),
                    });
                }
            }
        }
    }
}
