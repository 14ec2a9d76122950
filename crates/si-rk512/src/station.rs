//! The RK 512 station: one Sans-IO engine that runs the active side (our SEND and FETCH jobs)
//! and the passive side (the partner's jobs, served from memory) over one 3964(R)
//! [`Link`] ([CP 341] §2.2.3, Fig. 2-18/2-19).
//!
//! ```
//! use si_rk512::frame::{Address, Coordination};
//! use si_rk512::passive::ServerConfig;
//! use si_rk512::{Config, Event, Station};
//! use si_3964r::Priority;
//! use si_sim::Simulator;
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
//! let host = sim.add_station("host", line, Station::new(active_config.with_settings(line)).unwrap());
//! let plc = sim.add_station("PLC", line, Station::serving(Config::default().with_settings(line), &serve).unwrap());
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
//! - **One job at a time** ([CP 341] §2.2.3, Fig. 2-17 "nesting depth is 1"): [`Station::send`] and
//!   [`Station::fetch`] refuse a second job with [`RequestError::Busy`]. The passive side runs
//!   at most one partner job; both may run at once (quasi-full-duplex).
//! - **Telegram order (Fig. 2-17).** Telegrams wait in a FIFO of two (one command, one
//!   reaction) and go out one 3964(R) block after the other in the order they were made, so a
//!   reaction may wait until our own command has gone out, as the figure shows.
//! - **TRES** starts when the partner acknowledged our command telegram (its `DLE`), for every
//!   first and continuation telegram, and on the passive side when our reaction that asks for a
//!   continuation was acknowledged. Expiry ends our job with 0A05; on the passive side it
//!   aborts the partner's job with 060E (`[derived]`: the tables have no row for it, and 060E is
//!   what the partner's late continuation then meets) (`[derived]`, [CP 341] §2.2.3, Fig.
//!   2-18/2-19).
//! - **The STATUS classes** ([CP 341 Diag]; [`crate::status`] has the table): our
//!   own request is checked first (0515 flag bit, 0516 CPU number); a reaction with an error
//!   number ends our job with its 09xx; a faulty reaction with 0A01 (out of sequence), 0A02
//!   (header), 0A03 (FETCH data amount) or 0A04 (SEND reaction with data). A partner's
//!   telegram the passive side refuses is [`Event::Refused`] with its 06xx.
//! - **Chained codes.** When the 3964(R) link gives up on our command telegram, the station
//!   emits [`Event::ProcedureError`] with the link's 07xx and then [`Event::Failed`] with 051A;
//!   when it gives up on our reaction, [`Event::ProcedureError`] and then
//!   [`Event::ServeAborted`] with 0612 ([CP 341 Diag] "Chained reports").
//! - **S_RCV** ([`JobPort::take_received`](si_core::job::JobPort::take_received)) reports the
//!   passive side's STATUS as the CP's P_RCV_RK does: every 06xx, the 07xx before a 0612, and
//!   the link's receive errors (08xx), one per call, oldest first, at most
//!   [`RECEIVE_REPORTS`] kept (the oldest is dropped). The partner's SEND data land in memory,
//!   so S_RCV has no NDR here; [`Event::Served`] tells of them.
//! - **Bounds** ([`crate::bound`]): every job ends within [`Config::job_bound`] whatever the
//!   line does: each telegram within the 3964(R) link's bound, TRES judged on every input.
//! - **Cancel** ([`Station::cancel`], the FBs' R input): the station forgets the job at once,
//!   and the next job can start in the same call. A command telegram still queued is dropped;
//!   one already on the line cannot be called back (3964(R) sends what it has), so the next
//!   reaction within its TRES is taken as that telegram's ([CP 341] §2.2.3, Fig. 2-17: the partner
//!   answers in order) and reported as [`Event::ReceiveError`] with 0A01 instead of being read as
//!   the new job's.

use crate::config::Config;
use crate::frame::{
    Address, Command, CommandHeader, ContinuationHeader, Coordination, DataType, ReactionHeader,
    COMMAND_HEADER_LEN, MAX_DATA_PER_TELEGRAM, SHORT_HEADER_LEN,
};
use crate::passive::{Served, Server, ServerConfig};
use crate::refusal::ServeError;
use crate::status;
use bytes::{Bytes, BytesMut};
use core::fmt;
use si_3964r::{ConfigError, Link};
use si_core::status::common;
use si_core::{Engine, FramePool, Instant, LineError, ModemSignals, Output, Status};
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
    /// Our job ended with an error: 0515/0516 never get here (the request is refused), 051A
    /// after [`Event::ProcedureError`], 09xx from the partner's error number, 0Axx for a
    /// faulty or missing reaction.
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
    /// The passive side refused a partner's telegram (class 06H); the reaction carried
    /// `error.error_number()`.
    Refused {
        /// The 06xx row and the error number sent.
        error: ServeError,
    },
    /// A partner's job broke off: no continuation within TRES or a first telegram instead
    /// (060E), or our reaction could not be delivered (0612, after [`Event::ProcedureError`]).
    ServeAborted(Status),
    /// The 3964(R) link gave up on one of our telegrams (class 07H, the *first* error seen,
    /// [CP 341 Diag], chained reports). The next event says what it cost: [`Event::Failed`] with
    /// 051A for a command telegram, [`Event::ServeAborted`] with 0612 for a reaction.
    ProcedureError(Status),
    /// The link reported a receive error (class 08H), or a reaction arrived that no job waits
    /// for (0A01).
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
            Event::ProcedureError(s) => f.debug_tuple("ProcedureError").field(s).finish(),
            Event::ReceiveError(s) => f.debug_tuple("ReceiveError").field(s).finish(),
        }
    }
}

/// Why a job was refused before it started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// A job is still running ([CP 341] §2.2.3, Fig. 2-17: one job at a time).
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
    /// A coordination flag byte (≠ FFH) with a bit number above 7.
    #[error("coordination flag bit {0} is out of range 0 … 7")]
    FlagBit(u8),
    /// A CPU number other than 0 … 4 or FH (none).
    #[error("partner CPU number {0} is out of range: 0 … 4, or none")]
    CpuNumber(u8),
}

impl RequestError {
    /// The STATUS an FB would show for this refusal: 0502 when busy, 1E41 for the length,
    /// 1E20 (parameter out of range) for a data type SEND cannot use, 0515 for the flag bit,
    /// 0516 for the CPU number ([CP 341 Diag] class 05H).
    pub fn status(self) -> Status {
        match self {
            RequestError::Busy => common::NOT_POSSIBLE_IN_MODE,
            RequestError::Length { .. } => common::INVALID_LEN,
            RequestError::NotSendable(_) => common::PARAMETER_OUT_OF_RANGE,
            RequestError::FlagBit(_) => status::FLAG_BIT_OUT_OF_RANGE,
            RequestError::CpuNumber(_) => status::CPU_NUMBER_OUT_OF_RANGE,
        }
    }
}

/// How many passive-side STATUS codes wait for S_RCV (the oldest is dropped beyond).
pub const RECEIVE_REPORTS: usize = 4;

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
    /// The 07xx that caused the last outcome's 051A.
    last_cause: Option<Status>,
    /// A cancelled job's command telegram that was already on the line: its reaction is still
    /// due ([`Station::cancel`]).
    orphan: Option<Phase>,
    /// The passive side's STATUS codes for S_RCV, oldest first.
    receptions: VecDeque<Status>,
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
    /// An active-only station: it runs our jobs and refuses every partner command with 060D
    /// (error number 0AH, access refused).
    /// The line settings are the config's own (`config.link.settings`).
    pub fn new(config: Config) -> Result<Station, ConfigError> {
        Station::with_server(config, Server::refusing())
    }

    /// A station that also serves the partner's jobs from memory of these sizes.
    pub fn serving(config: Config, server: &ServerConfig) -> Result<Station, ConfigError> {
        Station::with_server(config, Server::new(server))
    }

    fn with_server(config: Config, server: Server) -> Result<Station, ConfigError> {
        config.validate()?;
        Ok(Station {
            link: Link::new(config.link)?,
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
            last_cause: None,
            orphan: None,
            receptions: VecDeque::with_capacity(RECEIVE_REPORTS),
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

    /// The 3964(R) error (07xx) reported just before the last job's 051A, if it ended so.
    pub fn last_cause(&self) -> Option<Status> {
        self.last_cause
    }

    /// Forget job `id` at once (the FBs' R input): no outcome will come for it, and a new job
    /// may start right away. See the module docs for a telegram already on the line.
    pub fn cancel(&mut self, id: JobId) {
        let Some(job) = self.job.take_if(|j| j.id == id) else {
            return;
        };
        self.queue.retain(|(k, _)| *k != Kind::Command);
        self.orphan = match job.phase {
            Phase::Sending(None) => None,
            on_the_line => Some(on_the_line),
        };
        if !job.header.command.is_send() {
            self.fetch_pools[job.pool].clear();
        }
    }

    /// The next passive-side STATUS for S_RCV (06xx, 07xx before 0612, 08xx).
    pub fn take_reception_error(&mut self) -> Option<Status> {
        self.receptions.pop_front()
    }

    /// Drop every STATUS waiting for S_RCV (its R input).
    pub fn clear_reception_errors(&mut self) {
        self.receptions.clear();
    }

    fn report_reception(&mut self, status: Status) {
        if self.receptions.len() == RECEIVE_REPORTS {
            self.receptions.pop_front();
        }
        self.receptions.push_back(status);
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
        if coordination.flag_byte != 0xFF && coordination.flag_bit > 7 {
            return Err(RequestError::FlagBit(coordination.flag_bit));
        }
        if !matches!(coordination.cpu, 0..=4 | 0xF) {
            return Err(RequestError::CpuNumber(coordination.cpu));
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
            // Byte 4, the data type: the configured counter letter ([derived]).
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
                Err(e) => self.telegram_failed(kind, None, e.status()),
            }
        }
    }

    /// The link gave up on a telegram (`id` on the link, `None` if it never got there): the
    /// 3964(R) error first, then what it cost (051A or 0612).
    fn telegram_failed(&mut self, kind: Kind, id: Option<si_3964r::JobId>, status: Status) {
        match kind {
            Kind::Command => {
                let ours = self
                    .job
                    .as_ref()
                    .is_some_and(|j| id.is_none() || j.phase == Phase::Sending(id));
                if ours {
                    self.event(Event::ProcedureError(status));
                    self.finish(Err(status::COMMAND_NOT_SENT));
                    self.last_cause = Some(status);
                } else if self.orphan == Some(Phase::Sending(id)) {
                    // A cancelled job's telegram: no reaction will come for it.
                    self.orphan = None;
                }
            }
            Kind::Reaction => {
                if self.server.abort() {
                    self.serve_deadline = None;
                }
                self.event(Event::ProcedureError(status));
                self.report_reception(status);
                self.serve_aborted(status::REACTION_NOT_SENT);
            }
        }
    }

    fn serve_aborted(&mut self, status: Status) {
        self.report_reception(status);
        self.event(Event::ServeAborted(status));
    }

    fn finish(&mut self, result: Result<(), Status>) {
        let Some(job) = self.job.take() else { return };
        self.last_cause = None;
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
                        self.telegram_failed(kind, Some(id), status);
                    }
                }
            }
            si_3964r::Event::Received { .. } => {
                while let Some(block) = self.link.take_block(self.now) {
                    self.on_telegram(&block);
                }
            }
            si_3964r::Event::ReceiveError(status) => {
                self.report_reception(status);
                self.event(Event::ReceiveError(status));
            }
        }
        self.pump();
    }

    fn telegram_sent(&mut self, kind: Kind, id: si_3964r::JobId) {
        let tres = self.now + self.config.response_timeout;
        match kind {
            Kind::Command => match &mut self.job {
                Some(job) if job.phase == Phase::Sending(Some(id)) => {
                    job.phase = Phase::Waiting(tres);
                }
                _ if self.orphan == Some(Phase::Sending(Some(id))) => {
                    self.orphan = Some(Phase::Waiting(tres));
                }
                _ => {}
            },
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
        if self.orphan.take().is_some() {
            // The answer to a cancelled job's telegram ([CP 341] §2.2.3, Fig. 2-17: answers come in
            // order).
            self.event(Event::ReceiveError(status::REACTION_SEQUENCE));
            return;
        }
        // Only a telegram on the line (or acknowledged) can be answered; a reaction while ours
        // still waits in the queue is a stray one (a duplicate, or meant for an ended job).
        let Some(job) = self
            .job
            .as_mut()
            .filter(|j| j.phase != Phase::Sending(None))
        else {
            self.event(Event::ReceiveError(status::REACTION_SEQUENCE));
            return;
        };
        // The header alone: the data amount is judged against the job below (0A03, 0A04),
        // not against the 128-byte limit of `Telegram::decode`.
        let header = match ReactionHeader::decode(block) {
            Ok(h) => h,
            Err(_) => return self.finish(Err(status::REACTION_HEADER)),
        };
        let data = &block[SHORT_HEADER_LEN..];
        let expected_continuation = job.done > 0;
        if header.continuation != expected_continuation {
            return self.finish(Err(status::REACTION_SEQUENCE));
        }
        if let Some(status) = status::for_error_byte(header.error) {
            return self.finish(Err(status));
        }
        let chunk = (job.total - job.done).min(MAX_DATA_PER_TELEGRAM);
        if job.header.command.is_send() {
            if !data.is_empty() {
                return self.finish(Err(status::SEND_REACTION_WITH_DATA));
            }
        } else {
            if data.len() != chunk {
                return self.finish(Err(status::REACTION_DATA_AMOUNT));
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
            self.serve_aborted(status::SEQUENCE);
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
        // Nesting depth 1 ([CP 341] §2.2.3, Fig. 2-17): a partner that sends a new command before
        // our reaction to the last one went out has given that one up, so its stale reaction is
        // replaced. The queue therefore never holds more than one command and one reaction.
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
            Served::Refused(error) => {
                self.report_reception(error.status());
                self.event(Event::Refused { error });
            }
        }
    }

    // --- timers --------------------------------------------------------------------------

    fn own_deadline(&self) -> Option<Instant> {
        let waiting = |phase: Option<Phase>| match phase {
            Some(Phase::Waiting(d)) => Some(d),
            _ => None,
        };
        [
            waiting(self.job.as_ref().map(|j| j.phase)),
            waiting(self.orphan),
            self.serve_deadline,
        ]
        .into_iter()
        .flatten()
        .min()
    }

    fn check_timers(&mut self) {
        let now = self.now;
        if let Some(Phase::Waiting(d)) = self.job.as_ref().map(|j| j.phase) {
            if now >= d {
                self.finish(Err(status::NO_REACTION));
            }
        }
        if matches!(self.orphan, Some(Phase::Waiting(d)) if now >= d) {
            self.orphan = None;
        }
        if self.serve_deadline.is_some_and(|d| now >= d) {
            self.serve_deadline = None;
            if self.server.abort() {
                self.serve_aborted(status::SEQUENCE);
            }
        }
    }
}

impl Engine for Station {
    type Event = Event;

    /// TRES is judged before the bytes are read (a reaction that arrives after it is late), so
    /// a line that never goes quiet cannot hold a job beyond its bound even if the driver's
    /// timers are late ([`crate::bound`]).
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.now = now;
        self.check_timers();
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
