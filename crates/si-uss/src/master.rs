//! The USS master: a Sans-IO engine that polls the slaves of its polling list cyclically.
//!
//! Sources: [Modbus/USS] §3.7.1 (cycle: "each slave must answer before the master
//! addresses the next"), [Modbus/USS] §3.7.3 (one job per slave), §3.7.7 (comm status word, comm
//! error word, KSTW), [Modbus/USS] §3.7.8 (polling list, WDH) and [USS spec] (timing, error
//! handling), [SINAMICS CU240S] p. 229 (PKW rules).
//!
//! # One poll
//!
//! 1. Wait for the **start interval**: 2 character times of silence since the line was last busy
//!    (our own request, a response, any stray character).
//! 2. Send `STX LGE ADR PKW PZD BCC` to the entry's node: the PKW area carries the slave's current
//!    parameter job (AK 0 "no task" when there is none) and the PZD area its control words
//!    ([`Master::set_control`]).
//! 3. Wait up to the **response timeout** (20 ms, [USS spec] §5.2.2) from the end of the request
//!    for the response's STX, then up to the **residual run time** 1.5 × (n + 3) character times
//!    for the rest of it.
//! 4. Check STX, LGE, ADR, BCC and the net-data structure, update the slave's status word, error
//!    word and received PZD, and report [`Event::Response`]; or report "node x does not answer"
//!    ([`Event::NoAnswer`]) or the rejection ([`Event::Rejected`]) and **go on with the cycle**
//!    ([USS spec] §5.2.2.
//!
//! # The PKW handshake
//!
//! A parameter job ([`Master::request_parameter`]) is sent with every poll of its slave until a
//! response with a matching response ID, PNU and IND (and, for writes, value) arrives
//! ([SINAMICS CU240S] p. 229: "master repeats request until matching response"). It ends with:
//!
//! - response ID 7: [`status::PKW_ERROR`] (16#1503) and the drive's error number from PWE
//!   ([Modbus/USS] §3.7.7 status bit 2);
//! - response ID 8, "no master control / no PKW rights": [`status::PKW_INTERFACE_ERROR`]
//!   (16#1505, status bit 4);
//! - WDH repetitions after the first telegram used up ([`MasterConfig::retries`]):
//!   [`status::NO_ANSWER`] (16#1408, comm error word bit 7, the code a poll reports) when the
//!   node did not answer a single telegram of the job, or the rejection code of its last
//!   telegram (BCC, LGE, …) when it answered only with faulty ones; [`status::PKW_INTERFACE_ERROR`]
//!   when it answered but never matched the job. Status bit 4 is set in each case, as [Modbus/USS]
//!   §3.7.7 says ("did not acknowledge within WDH retries").
//!
//! **Reading chosen** for the absent node: [Modbus/USS] §3.7.7 folds it into status bit 4 with
//! response ID 8; a user must tell a drive that is not there from a drive that refuses, so the
//! job's STATUS names the telegram-level cause, as a poll does.
//!
//! After the job the PKW area carries AK 0 "no task" ([SINAMICS CU240S] p. 229, or, with
//! [`PkwAfterJob::RepeatLast`], the last job again, as the module's FCs do ("sent to the slave
//! again and again until the user enters a new job", [Modbus/USS] §3.7.7). See [`PkwAfterJob`] for
//! why AK 0 is the default.
//!
//! # Ending a run
//!
//! [`Master::stop_after_cycles`] and [`Master::stop_when_idle`] end the polling inside the
//! engine, in the same step as the cycle or the job that completes the run: the telegram that
//! would follow never leaves. A program that stops the master on the event instead races the
//! next poll, which may already be on its way.
//!
//! # Special telegrams
//!
//! [`Master::broadcast`] (ADR bit 5, no response) and [`Master::mirror`] (ADR bit 6, the slave
//! sends the telegram back unchanged) are slipped in between two polls.

use crate::config::{ConfigError, MasterConfig, PkwAfterJob, PollEntry};
use crate::frame::{
    self, response, task, Adr, DecodeError, NetData, ParamAddress, Pke, Pkw, PkwWords, Pzd,
    MAX_NET, MAX_TELEGRAM,
};
use crate::rx::{Receiver, RxOutcome};
use crate::status;
use serde::{Deserialize, Serialize};
use si_core::echo::EchoFilter;
use si_core::{Duration, Engine, FramePool, Instant, LineError, Output, Status};
use std::collections::VecDeque;

/// The one job id of si-core; it identifies a job (parameter, broadcast, mirror) in its
/// completion event.
pub use si_core::JobId;

/// Comm status word bits ([Modbus/USS] §3.7.7).
pub mod comm_status {
    /// Bit 0: PKW job in progress.
    pub const PKW_BUSY: u16 = 1 << 0;
    /// Bit 1: PKW job finished without error.
    pub const PKW_DONE: u16 = 1 << 1;
    /// Bit 2: PKW job finished with error (response ID 7).
    pub const PKW_ERROR: u16 = 1 << 2;
    /// Bit 3: invalid PKW task ID.
    pub const PKW_INVALID: u16 = 1 << 3;
    /// Bit 4: PKW interface error (WDH exceeded, response ID 8).
    pub const PKW_INTERFACE: u16 = 1 << 4;
    /// Bit 5: parameter change report received.
    pub const CHANGE_REPORT: u16 = 1 << 5;
    /// Bit 6: slave fault (ZSW bit 3).
    pub const SLAVE_FAULT: u16 = 1 << 6;
    /// Bit 7: slave warning (ZSW bit 7).
    pub const SLAVE_WARNING: u16 = 1 << 7;
    /// Bit 8: PLC control requested (ZSW bit 9 and STW bit 10).
    pub const PLC_CONTROL: u16 = 1 << 8;
    /// Bit 9: group error; received data are valid only when it is 0.
    pub const GROUP_ERROR: u16 = 1 << 9;
}

/// Comm error word bits ([Modbus/USS] §3.7.7).
pub mod comm_error {
    /// Bit 0: address (ADR) error.
    pub const ADDRESS: u16 = 1 << 0;
    /// Bit 3: start of frame not recognised.
    pub const NO_STX: u16 = 1 << 3;
    /// Bit 4: BCC error.
    pub const BCC: u16 = 1 << 4;
    /// Bit 6: wrong telegram length.
    pub const LGE: u16 = 1 << 6;
    /// Bit 7: telegram monitoring time exceeded.
    pub const MONITORING_TIME: u16 = 1 << 7;
}

/// The diagnostic counters.
///
/// [USS spec] §5.2.3 recommends these counters: ok and rejected
/// telegrams, framing, overflow, parity, start not identified, residual time, BCC, length and
/// monitoring time. It does not list sixteen, so we chose these sixteen: those ten, split and
/// completed by what a master also needs to see (requests sent, address errors, BREAKs, PKW
/// repetitions, PKW failures, cycles).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// 1. Telegrams sent (polls, broadcasts, mirrors).
    pub sent: u32,
    /// 2. Telegrams received without error.
    pub ok: u32,
    /// 3. Telegrams rejected for any reason (sum of 4–11, telegram-level).
    pub rejected: u32,
    /// 4. Character frame errors.
    pub framing: u32,
    /// 5. Overrun (overflow) errors.
    pub overrun: u32,
    /// 6. Parity errors.
    pub parity: u32,
    /// 7. Characters that could not start a telegram (start not identified).
    pub start_not_identified: u32,
    /// 8. Residual run time exceeded.
    pub residual_time: u32,
    /// 9. BCC errors.
    pub bcc: u32,
    /// 10. Length errors (LGE, net-data structure).
    pub length: u32,
    /// 11. Responses from a wrong address or of a wrong type.
    pub address: u32,
    /// 12. Telegram monitoring time exceeded: node did not answer.
    pub no_answer: u32,
    /// 13. BREAKs on the receive line.
    pub breaks: u32,
    /// 14. PKW requests repeated (sent again without a matching response).
    pub pkw_repeats: u32,
    /// 15. PKW jobs that ended with an error.
    pub pkw_failed: u32,
    /// 16. Complete polling cycles.
    pub cycles: u32,
}

impl Counters {
    /// The sixteen counters in the order of their numbers.
    pub fn as_array(&self) -> [u32; 16] {
        [
            self.sent,
            self.ok,
            self.rejected,
            self.framing,
            self.overrun,
            self.parity,
            self.start_not_identified,
            self.residual_time,
            self.bcc,
            self.length,
            self.address,
            self.no_answer,
            self.breaks,
            self.pkw_repeats,
            self.pkw_failed,
            self.cycles,
        ]
    }
}

/// How wide a parameter value written is: it picks the task ID (AK 2 or 3, for an array
/// element AK 7 or 8) ([Modbus/USS] §3.7.7; the task IDs are the USS protocol's, \[USS\]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Width {
    /// A 16-bit value (AK 2, AK 7).
    #[default]
    Word,
    /// A 32-bit value (AK 3, AK 8).
    DoubleWord,
}

/// A parameter job for [`Master::request_parameter`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ParamRequest {
    /// Task ID AK (see [`frame::task`]).
    pub task: u8,
    /// Parameter number and sub-index.
    pub param: ParamAddress,
    /// Value to write (ignored by read tasks).
    pub value: u32,
}

impl ParamRequest {
    /// Read a parameter value (AK 1); for an array element use [`ParamRequest::read_array`].
    pub fn read(number: u16, index: u8) -> Self {
        ParamRequest {
            task: task::READ,
            param: ParamAddress { number, index },
            value: 0,
        }
    }
    /// Read an array element (AK 6).
    pub fn read_array(number: u16, index: u8) -> Self {
        ParamRequest {
            task: task::READ_ARRAY,
            ..Self::read(number, index)
        }
    }
    /// Write an array element: a word (AK 7) or a double word (AK 8).
    pub fn write_array(number: u16, index: u8, value: u32, width: Width) -> Self {
        ParamRequest {
            task: match width {
                Width::Word => task::WRITE_ARRAY_WORD,
                Width::DoubleWord => task::WRITE_ARRAY_DWORD,
            },
            ..Self::write(number, index, value, width)
        }
    }
    /// Write a word (AK 2) or a double word (AK 3).
    pub fn write(number: u16, index: u8, value: u32, width: Width) -> Self {
        ParamRequest {
            task: match width {
                Width::Word => task::WRITE_WORD,
                Width::DoubleWord => task::WRITE_DWORD,
            },
            param: ParamAddress { number, index },
            value,
        }
    }
}

/// A command the master refused; no job was started and no event will follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// The node is not in the polling list.
    #[error("node {0} is not in the polling list")]
    UnknownSlave(u8),
    /// The node's structure has no PKW area.
    #[error("node {0} has no PKW area (PKW = 0)")]
    NoPkwArea(u8),
    /// A PKW job for this node is still running (one job per slave, [Modbus/USS] §3.7.3).
    #[error("a PKW job for node {0} is still in progress")]
    Busy(u8),
    /// The task is invalid (status bit 3): 15, 4 with index 255 (the manual's two), and, as
    /// this crate reads it (`[derived]`), the reserved ID 10, an ID above 15, or a double word
    /// in a 3-word PKW area.
    #[error("invalid PKW task {task} for node {address}")]
    InvalidTask {
        /// The node.
        address: u8,
        /// The task ID.
        task: u8,
    },
    /// The parameter number is above [`crate::param::MAX_NUMBER`] (61 999): the page index
    /// cannot address it ([MM 420] p. 115, [G120 Fieldbus] §5.3).
    #[error("parameter number {number} for node {address} is out of range: 0 … 61999")]
    ParameterNumber {
        /// The node.
        address: u8,
        /// The number asked for.
        number: u16,
    },
    /// A special telegram of this kind is already waiting.
    #[error("a {0} telegram is already waiting to be sent")]
    SpecialPending(&'static str),
    /// Net data longer than 252 bytes, or a PZD list longer than the slave's.
    #[error("net data too long: {0} bytes")]
    TooLong(usize),
    /// The master has not been started.
    #[error("the master is stopped")]
    Stopped,
}

impl RequestError {
    /// The STATUS a refused command reports, so a caller that shows STATUS words (a CPU-style
    /// status register, a gateway's parameter window) never has to invent one.
    ///
    /// **Reading chosen:** the manual's USS FCs refuse nothing with a STATUS of their own
    /// ([Modbus/USS] §3.7.7 flags bits instead), so each refusal takes the code whose
    /// meaning fits it:
    ///
    /// - an invalid task ([`RequestError::InvalidTask`]) sets comm status bit 3, and a job for
    ///   a node without a PKW area is a task its PKW area cannot carry: 16#1504
    ///   ([`status::PKW_INVALID_TASK`], [Modbus/USS] §3.7.7 comm status word bit 3);
    /// - a node outside the polling list, or a parameter number the page index cannot address
    ///   ([MM 420] p. 115, [G120 Fieldbus] §5.3): an input out of range, 16#1E20
    ///   ([`si_core::status::common::PARAMETER_OUT_OF_RANGE`], [Modbus/USS] §3.6);
    /// - net data or a PZD list too long: a byte count the job cannot carry, 16#1E41
    ///   ([`si_core::status::common::INVALID_LEN`], [Modbus/USS] §3.6, "invalid byte count");
    /// - a job still running for the node (one job per slave, [Modbus/USS] §3.7.3), a special
    ///   telegram still waiting, or a stopped master: "job not possible in the current mode",
    ///   16#0502 ([`si_core::status::common::NOT_POSSIBLE_IN_MODE`], [Modbus/USS] §3.6), as
    ///   si-modbus reports a busy master.
    pub fn status(&self) -> Status {
        use si_core::status::common;
        match self {
            RequestError::InvalidTask { .. } | RequestError::NoPkwArea(_) => {
                status::PKW_INVALID_TASK
            }
            RequestError::UnknownSlave(_) | RequestError::ParameterNumber { .. } => {
                common::PARAMETER_OUT_OF_RANGE
            }
            RequestError::TooLong(_) => common::INVALID_LEN,
            RequestError::Busy(_) | RequestError::SpecialPending(_) | RequestError::Stopped => {
                common::NOT_POSSIBLE_IN_MODE
            }
        }
    }
}

/// What the master reports.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Event {
    /// A slave answered its poll; its PZD (status word, actual values) are fresh.
    Response {
        /// Cycle number (from 0).
        cycle: u64,
        /// The node.
        address: u8,
        /// The response's PKW and PZD areas.
        net: NetData,
    },
    /// "Node x does not answer": no STX within the response timeout. The cycle goes on.
    NoAnswer {
        /// Cycle number.
        cycle: u64,
        /// The node.
        address: u8,
    },
    /// A response was discarded (BCC, LGE, ADR, structure, residual time, character error).
    Rejected {
        /// Cycle number.
        cycle: u64,
        /// The node polled.
        address: u8,
        /// Why, as a STATUS of [`crate::status`].
        status: Status,
        /// The decoder's finding with offsets, when a whole telegram was there to decode.
        error: Option<DecodeError>,
    },
    /// Every entry of the polling list has had its turn.
    CycleDone {
        /// The cycle that ended.
        cycle: u64,
    },
    /// A parameter job ended with a matching response.
    ParameterDone {
        /// The job.
        job: JobId,
        /// The node.
        address: u8,
        /// The response's PKW area.
        response: Pkw,
    },
    /// A parameter job failed.
    ParameterFailed {
        /// The job.
        job: JobId,
        /// The node.
        address: u8,
        /// [`status::PKW_ERROR`] (response ID 7), [`status::PKW_INTERFACE_ERROR`] (response ID
        /// 8, or answers that never matched), [`status::NO_ANSWER`] (the node never answered)
        /// or the rejection code of the job's last telegram (module docs, "The PKW handshake").
        status: Status,
        /// The AK 7 error number from PWE.
        error_number: Option<u16>,
    },
    /// A slave sent a parameter change report (response IDs 9–12).
    ChangeReport {
        /// The node.
        address: u8,
        /// The report.
        report: Pkw,
    },
    /// A broadcast telegram has been sent (nobody answers it).
    BroadcastDone {
        /// The job.
        job: JobId,
    },
    /// A queued broadcast was not sent (the master was stopped).
    BroadcastFailed {
        /// The job.
        job: JobId,
        /// Why.
        status: Status,
    },
    /// The slave mirrored the telegram unchanged.
    MirrorDone {
        /// The job.
        job: JobId,
        /// The node.
        address: u8,
    },
    /// The mirror telegram did not come back unchanged.
    MirrorFailed {
        /// The job.
        job: JobId,
        /// The node.
        address: u8,
        /// Why.
        status: Status,
    },
}

/// What the master knows about one slave: the net-data DB's communication words and buffers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SlaveState {
    /// Node number.
    pub address: u8,
    /// PKW words.
    pub pkw: PkwWords,
    /// Control words sent with each poll (PZD1 = STW, PZD2 = HSW, …).
    pub control: Pzd,
    /// Last PZD received (PZD1 = ZSW, PZD2 = HIW, …); valid when the group error bit is 0.
    pub status: Pzd,
    /// Last PKW area received.
    pub pkw_response: Option<Pkw>,
    /// Comm status word (bits in [`comm_status`]).
    pub comm_status: u16,
    /// Comm error word (bits in [`comm_error`]) of the last poll.
    pub comm_error: u16,
    /// Outcome of the last poll.
    pub last_status: Status,
    /// Polls answered correctly.
    pub answered: u32,
    /// Polls not answered or rejected.
    pub failed: u32,
    job: Option<PkwJob>,
    /// The last job's PKW area, sent again after it with [`PkwAfterJob::RepeatLast`].
    last_task: Option<Pkw>,
    /// The SPM toggle bit we send: the toggle of the last change report the user acknowledged.
    spm_ack: bool,
    /// The toggle bit of the last change report seen, so a repeated report is reported once.
    report_spm: Option<bool>,
}

impl SlaveState {
    /// The status word ZSW (PZD1), if the structure has one.
    pub fn status_word(&self) -> Option<u16> {
        self.status.first()
    }
    /// The main actual value HIW (PZD2), if the structure has one.
    pub fn actual_value(&self) -> Option<u16> {
        self.status.second()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct PkwJob {
    id: JobId,
    request: Pkw,
    sent: u16,
    /// The node answered (a valid telegram) at least once during the job.
    answered: bool,
}

#[derive(Clone, Copy)]
struct PendingSpecial {
    job: JobId,
    net: [u8; MAX_NET],
    len: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Current {
    Poll { entry: usize },
    Mirror { job: JobId, address: u8 },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Stopped,
    /// Send the next telegram at `at`, and at `latest` even if the line has not been quiet
    /// for the start interval ([`MasterConfig::max_wait_for_silence`] after it was due).
    Idle {
        at: Instant,
        latest: Instant,
    },
    /// Waiting for the response to `current` until `deadline` (STX) or the residual run time.
    Awaiting {
        current: Current,
        deadline: Instant,
    },
}

/// The USS master engine. See the [module docs](self).
pub struct Master {
    config: MasterConfig,
    start_interval: Duration,
    rx: Receiver,
    slaves: Vec<SlaveState>,
    entry: usize,
    cycle: u64,
    phase: Phase,
    /// A line that echoes our telegrams: as many received characters (or line errors) as we
    /// sent are dropped (si-core's one echo filter, count mode).
    echo: EchoFilter,
    line_free: Instant,
    tx: [u8; MAX_TELEGRAM],
    tx_len: usize,
    out: VecDeque<Output<Event>>,
    broadcast: Option<PendingSpecial>,
    mirror: Option<(u8, PendingSpecial)>,
    next_job: u64,
    counters: Counters,
    /// Transmit frames are cut from this pool: a steady state allocates nothing per frame (the
    /// si-core contract).
    tx_pool: FramePool,
    /// [`Master::stop_after_cycles`].
    stop_after_cycles: Option<u64>,
    /// [`Master::stop_when_idle`].
    stop_when_idle: bool,
}

impl Master {
    /// A stopped master; [`start`](Self::start) begins the polling cycle.
    pub fn new(config: MasterConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let mut slaves: Vec<SlaveState> = Vec::with_capacity(config.polling_list.len());
        for e in &config.polling_list {
            if slaves.iter().all(|s| s.address != e.address) {
                slaves.push(SlaveState {
                    address: e.address,
                    pkw: e.pkw,
                    control: Pzd::new(&[0; 16][..usize::from(e.pzd_words)]),
                    status: Pzd::default(),
                    pkw_response: None,
                    comm_status: 0,
                    comm_error: 0,
                    last_status: Status::OK,
                    answered: 0,
                    failed: 0,
                    job: None,
                    last_task: None,
                    spm_ack: false,
                    report_spm: None,
                });
            }
        }
        Ok(Master {
            start_interval: config.start_interval(),
            rx: Receiver::new(config.settings),
            slaves,
            entry: 0,
            cycle: 0,
            phase: Phase::Stopped,
            echo: EchoFilter::counting(),
            line_free: Instant::ZERO,
            tx: [0; MAX_TELEGRAM],
            tx_len: 0,
            out: VecDeque::with_capacity(32),
            broadcast: None,
            mirror: None,
            next_job: 0,
            counters: Counters::default(),
            tx_pool: FramePool::preallocated(4 * MAX_TELEGRAM),
            stop_after_cycles: None,
            stop_when_idle: false,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &MasterConfig {
        &self.config
    }

    /// Begin (or resume) cyclic polling: the first request goes out after the start interval.
    pub fn start(&mut self, now: Instant) {
        if self.phase == Phase::Stopped {
            self.idle(self.next_send_time(now));
            self.tick(now);
        }
    }

    /// Stop after nothing: a poll in progress is abandoned, running parameter jobs fail with
    /// [`si_core::status::common::ABORTED_BY_RESET`], pending special telegrams likewise.
    pub fn stop(&mut self, _now: Instant) {
        self.phase = Phase::Stopped;
        self.rx.resync();
        let aborted = si_core::status::common::ABORTED_BY_RESET;
        for i in 0..self.slaves.len() {
            if let Some(job) = self.slaves[i].job.take() {
                self.slaves[i].comm_status &= !comm_status::PKW_BUSY;
                let address = self.slaves[i].address;
                self.emit(Event::ParameterFailed {
                    job: job.id,
                    address,
                    status: aborted,
                    error_number: None,
                });
            }
        }
        if let Some(b) = self.broadcast.take() {
            self.emit(Event::BroadcastFailed {
                job: b.job,
                status: aborted,
            });
        }
        if let Some((address, m)) = self.mirror.take() {
            self.emit(Event::MirrorFailed {
                job: m.job,
                address,
                status: aborted,
            });
        }
    }

    /// End the run after `cycles` complete cycles (counted from 0 since the master was built,
    /// as [`cycle`](Self::cycle) counts): the master stops in the step that reports the last
    /// [`Event::CycleDone`], so no telegram of the next cycle leaves. A parameter job still
    /// running then fails as with [`stop`](Self::stop).
    pub fn stop_after_cycles(&mut self, cycles: u64) {
        self.stop_after_cycles = Some(cycles);
    }

    /// End the run as soon as no parameter job runs and no broadcast or mirror telegram waits:
    /// the master stops in the step that reports the last job's end, before the next poll. For a
    /// program that runs one job and exits (`si uss read-param`): enter the job and call this
    /// before [`start`](Self::start), so every telegram of the run carries the job (a master
    /// started first may poll with AK 0 before a job entered later, and one told to stop while
    /// idle stops at once).
    pub fn stop_when_idle(&mut self) {
        self.stop_when_idle = true;
    }

    /// Is the run over ([`stop_after_cycles`](Self::stop_after_cycles),
    /// [`stop_when_idle`](Self::stop_when_idle))?
    fn run_is_over(&self) -> bool {
        let cycles_done = self.stop_after_cycles.is_some_and(|n| self.cycle >= n);
        let idle = self.stop_when_idle
            && self.slaves.iter().all(|s| s.job.is_none())
            && self.broadcast.is_none()
            && self.mirror.is_none();
        cycles_done || idle
    }

    /// Stop now if the run is over (and forget the end condition, so a later
    /// [`start`](Self::start) runs on); true if stopped.
    fn finish_if_over(&mut self, now: Instant) -> bool {
        if self.phase != Phase::Stopped && self.run_is_over() {
            self.stop_after_cycles = None;
            self.stop_when_idle = false;
            self.stop(now);
        }
        self.phase == Phase::Stopped
    }

    /// The diagnostic counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Current cycle number (from 0).
    pub fn cycle(&self) -> u64 {
        self.cycle
    }

    /// What the master knows about node `address`.
    pub fn slave(&self, address: u8) -> Option<&SlaveState> {
        self.slaves.iter().find(|s| s.address == address)
    }

    /// Every slave, in polling-list order of first appearance.
    pub fn slaves(&self) -> &[SlaveState] {
        &self.slaves
    }

    fn slave_index(&self, address: u8) -> Result<usize, RequestError> {
        self.slaves
            .iter()
            .position(|s| s.address == address)
            .ok_or(RequestError::UnknownSlave(address))
    }

    /// Set the PZD words sent to `address` from the next poll on (PZD1 = STW, PZD2 = HSW, …).
    /// Words beyond the slave's PZD count are refused; fewer leave the rest unchanged.
    pub fn set_control(&mut self, address: u8, words: &[u16]) -> Result<(), RequestError> {
        let i = self.slave_index(address)?;
        let control = self.slaves[i].control.words_mut();
        if words.len() > control.len() {
            return Err(RequestError::TooLong(2 * words.len()));
        }
        control[..words.len()].copy_from_slice(words);
        Ok(())
    }

    /// The user has seen the parameter change report of `address`: comm status bit 5 is reset
    /// and the next requests carry the report's toggle bit (PKE bit 11, SPM) back to the slave,
    /// which acknowledges it; the slave then sends its next report or resumes normal answers
    /// (KSTW bit 1, [Modbus/USS] §3.7.7).
    ///
    /// **Reading chosen:** the manual says only that the FC "acknowledges the report to the
    /// slave" and masks bit 11 from the user; we acknowledge by mirroring the report's toggle bit
    /// in SPM, as the PROFIdrive parameter channel does.
    pub fn acknowledge_change_report(&mut self, address: u8) -> Result<(), RequestError> {
        let i = self.slave_index(address)?;
        let s = &mut self.slaves[i];
        s.comm_status &= !comm_status::CHANGE_REPORT;
        if let Some(t) = s.report_spm {
            s.spm_ack = t;
        }
        Ok(())
    }

    /// Start a parameter job at `address`. It ends with exactly one [`Event::ParameterDone`] or
    /// [`Event::ParameterFailed`]. An invalid task sets comm status bit 3 and is refused.
    pub fn request_parameter(
        &mut self,
        _now: Instant,
        address: u8,
        request: ParamRequest,
    ) -> Result<JobId, RequestError> {
        let i = self.slave_index(address)?;
        let words = self.slaves[i].pkw;
        if words == PkwWords::None {
            return Err(RequestError::NoPkwArea(address));
        }
        if self.slaves[i].job.is_some() {
            return Err(RequestError::Busy(address));
        }
        if request.param.number > crate::param::MAX_NUMBER {
            return Err(RequestError::ParameterNumber {
                address,
                number: request.param.number,
            });
        }
        let pkw = build_request(words, &request);
        let Some(pkw) = pkw else {
            self.slaves[i].comm_status |= comm_status::PKW_INVALID;
            return Err(RequestError::InvalidTask {
                address,
                task: request.task,
            });
        };
        let id = self.new_job();
        let s = &mut self.slaves[i];
        s.comm_status &=
            !(comm_status::PKW_INVALID | comm_status::PKW_DONE | comm_status::PKW_ERROR);
        s.comm_status |= comm_status::PKW_BUSY;
        s.job = Some(PkwJob {
            id,
            request: pkw,
            sent: 0,
            answered: false,
        });
        s.last_task = Some(pkw);
        Ok(id)
    }

    /// Queue a broadcast telegram (ADR bit 5) with these net data; it goes out between two polls
    /// and ends with [`Event::BroadcastDone`].
    pub fn broadcast(&mut self, _now: Instant, net: &[u8]) -> Result<JobId, RequestError> {
        if self.broadcast.is_some() {
            return Err(RequestError::SpecialPending("broadcast"));
        }
        let p = self.special(net)?;
        self.broadcast = Some(p);
        Ok(p.job)
    }

    /// Queue a mirror telegram (ADR bit 6) to `address`; it ends with [`Event::MirrorDone`] when
    /// the slave sends it back unchanged, else [`Event::MirrorFailed`].
    pub fn mirror(
        &mut self,
        _now: Instant,
        address: u8,
        net: &[u8],
    ) -> Result<JobId, RequestError> {
        if self.mirror.is_some() {
            return Err(RequestError::SpecialPending("mirror"));
        }
        if address > frame::MAX_ADDRESS {
            return Err(RequestError::UnknownSlave(address));
        }
        let p = self.special(net)?;
        self.mirror = Some((address, p));
        Ok(p.job)
    }

    fn special(&mut self, net: &[u8]) -> Result<PendingSpecial, RequestError> {
        if self.phase == Phase::Stopped {
            return Err(RequestError::Stopped);
        }
        if net.len() > MAX_NET {
            return Err(RequestError::TooLong(net.len()));
        }
        let mut buf = [0; MAX_NET];
        buf[..net.len()].copy_from_slice(net);
        Ok(PendingSpecial {
            job: self.new_job(),
            net: buf,
            len: net.len(),
        })
    }

    fn new_job(&mut self) -> JobId {
        self.next_job = self.next_job.wrapping_add(1);
        JobId(self.next_job)
    }

    fn emit(&mut self, e: Event) {
        self.out.push_back(Output::Event(e));
    }

    fn next_send_time(&self, now: Instant) -> Instant {
        let busy = self
            .line_free
            .max(self.rx.last_char().unwrap_or(Instant::ZERO));
        now.max(busy + self.start_interval)
    }

    /// The next telegram is due at `at`: it waits for the start interval of silence at most
    /// [`MasterConfig::max_wait_for_silence`] (host bound; module docs, "Bounds").
    fn idle(&mut self, at: Instant) {
        self.phase = Phase::Idle {
            at,
            latest: at + self.config.max_wait_for_silence(),
        };
    }

    /// Send whatever is due.
    fn tick(&mut self, now: Instant) {
        let Phase::Idle { at, latest } = self.phase else {
            return;
        };
        if self.finish_if_over(now) {
            return;
        }
        let overdue = now >= latest;
        if now < at || (self.rx.is_receiving() && !overdue) {
            return;
        }
        let at = self.next_send_time(now);
        if now < at && !overdue {
            self.phase = Phase::Idle {
                at: at.min(latest),
                latest,
            };
            return;
        }
        if let Some(b) = self.broadcast.take() {
            self.transmit(now, Adr::broadcast(), &b.net[..b.len]);
            self.emit(Event::BroadcastDone { job: b.job });
            self.idle(self.line_free + self.start_interval);
            return;
        }
        if let Some((address, m)) = self.mirror.take() {
            let adr = Adr::mirror(address).unwrap_or(Adr(address));
            self.transmit(now, adr, &m.net[..m.len]);
            self.rx.expect_net(m.len);
            self.await_response(Current::Mirror {
                job: m.job,
                address,
            });
            return;
        }
        let entry = self.entry;
        let e = self.config.polling_list[entry];
        let Ok(i) = self.slave_index(e.address) else {
            return;
        };
        let mut net = [0u8; MAX_NET];
        let after_job = self.config.pkw_after_job;
        let len = {
            let s = &mut self.slaves[i];
            let pkw = match (&mut s.job, s.pkw) {
                (_, PkwWords::None) => None,
                (Some(job), _) => {
                    job.sent = job.sent.saturating_add(1);
                    if job.sent > 1 {
                        bump(&mut self.counters.pkw_repeats);
                    }
                    Some(job.request)
                }
                (None, _) if after_job == PkwAfterJob::RepeatLast && s.last_task.is_some() => {
                    s.last_task
                }
                (None, words) => build_request(words, &ParamRequest::read(0, 0)).map(|mut p| {
                    p.pke = Pke(0);
                    p
                }),
            };
            let spm = s.spm_ack;
            NetData {
                pkw: pkw.map(|mut p| {
                    p.pke = Pke::new(p.pke.ak(), spm, p.pke.pnu());
                    p
                }),
                pzd: s.control,
            }
            .write(&mut net)
            .unwrap_or(0)
        };
        let adr = Adr::slave(e.address).unwrap_or(Adr(e.address));
        self.transmit(now, adr, &net[..len]);
        self.rx.expect_net(expected_response_len(&e));
        self.await_response(Current::Poll { entry });
    }

    fn transmit(&mut self, now: Instant, adr: Adr, net: &[u8]) {
        self.tx_len = frame::encode(adr, net, &mut self.tx).unwrap_or(0);
        let len = self.tx_len;
        let telegram = self.tx_pool.cut(&self.tx[..len]);
        self.out.push_back(Output::Transmit(telegram));
        bump(&mut self.counters.sent);
        self.line_free = now + self.config.settings.chars_time(len as u64);
        if self.config.local_echo {
            // A new telegram: an echo of the previous one not heard back is forgotten.
            self.echo.stop();
            self.echo.sent_len(len);
        }
    }

    fn await_response(&mut self, current: Current) {
        self.rx.accept_next_stx();
        self.phase = Phase::Awaiting {
            current,
            // The response's STX may reach us up to the port's latency late.
            deadline: self.line_free + self.config.response_timeout + self.rx.allowance(),
        };
    }

    /// The poll (or mirror) in progress is over; go on with the cycle.
    fn advance(&mut self, now: Instant, current: Current) {
        let mut pause = Duration::ZERO;
        if let Current::Poll { .. } = current {
            self.entry += 1;
            if self.entry >= self.config.polling_list.len() {
                self.entry = 0;
                let cycle = self.cycle;
                self.cycle = self.cycle.wrapping_add(1);
                bump(&mut self.counters.cycles);
                self.emit(Event::CycleDone { cycle });
                pause = self.config.cycle_pause;
            }
        }
        self.idle(self.next_send_time(now) + pause);
        self.finish_if_over(now);
    }

    fn complete(&mut self, now: Instant, current: Current) {
        let mut bytes = [0u8; MAX_TELEGRAM];
        let t = self.rx.telegram();
        let len = t.len();
        bytes[..len].copy_from_slice(t);
        match current {
            Current::Mirror { job, address } => {
                if bytes[..len] == self.tx[..self.tx_len] {
                    bump(&mut self.counters.ok);
                    self.emit(Event::MirrorDone { job, address });
                } else {
                    let status = match frame::decode(&bytes[..len]) {
                        Err(e) => self.count_decode_error(&e),
                        Ok(_) => {
                            bump(&mut self.counters.rejected);
                            bump(&mut self.counters.address);
                            status::ADDRESS_ERROR
                        }
                    };
                    self.emit(Event::MirrorFailed {
                        job,
                        address,
                        status,
                    });
                }
            }
            Current::Poll { entry } => {
                let e = self.config.polling_list[entry];
                let adr = Adr::slave(e.address).unwrap_or(Adr(e.address));
                let parsed = frame::decode_from(&bytes[..len], adr)
                    .and_then(|t| NetData::parse(t.net, e.pkw, usize::from(e.pzd_words)));
                match parsed {
                    Ok(net) => self.response(e.address, net),
                    Err(err) => {
                        let status = self.count_decode_error(&err);
                        self.poll_failed(e.address, status, Some(err));
                    }
                }
            }
        }
        self.advance(now, current);
    }

    fn count_decode_error(&mut self, e: &DecodeError) -> Status {
        bump(&mut self.counters.rejected);
        match e {
            DecodeError::Bcc { .. } => {
                bump(&mut self.counters.bcc);
                status::BCC_ERROR
            }
            DecodeError::UnexpectedAddress { .. } => {
                bump(&mut self.counters.address);
                status::ADDRESS_ERROR
            }
            DecodeError::NoStx { .. } => {
                bump(&mut self.counters.start_not_identified);
                status::NO_STX
            }
            _ => {
                bump(&mut self.counters.length);
                status::LGE_ERROR
            }
        }
    }

    fn response(&mut self, address: u8, net: NetData) {
        bump(&mut self.counters.ok);
        let Ok(i) = self.slave_index(address) else {
            return;
        };
        let cycle = self.cycle;
        let mut events: [Option<Event>; 2] = [None, None];
        {
            let s = &mut self.slaves[i];
            s.answered = s.answered.wrapping_add(1);
            s.comm_error = 0;
            s.last_status = Status::OK;
            s.status = net.pzd;
            s.pkw_response = net.pkw;
            let zsw = net.pzd.first().unwrap_or(0);
            let stw = s.control.first().unwrap_or(0);
            let mut cs = s.comm_status
                & !(comm_status::GROUP_ERROR
                    | comm_status::SLAVE_FAULT
                    | comm_status::SLAVE_WARNING
                    | comm_status::PLC_CONTROL);
            if zsw & (1 << 3) != 0 {
                cs |= comm_status::SLAVE_FAULT;
            }
            if zsw & (1 << 7) != 0 {
                cs |= comm_status::SLAVE_WARNING;
            }
            if zsw & (1 << 9) != 0 && stw & (1 << 10) != 0 {
                cs |= comm_status::PLC_CONTROL;
            }
            s.comm_status = cs;
            if let Some(reply) = net.pkw {
                let ak = reply.pke.ak();
                if (response::CHANGE_REPORT_WORD..=response::CHANGE_REPORT_ARRAY_DWORD)
                    .contains(&ak)
                    && s.report_spm != Some(reply.pke.spm())
                {
                    s.report_spm = Some(reply.pke.spm());
                    s.comm_status |= comm_status::CHANGE_REPORT;
                    events[1] = Some(Event::ChangeReport {
                        address,
                        report: reply,
                    });
                }
                if let Some(job) = &mut s.job {
                    job.answered = true;
                }
                if let Some(job) = s.job {
                    match judge(&job.request, &reply) {
                        Verdict::Done => {
                            s.job = None;
                            s.comm_status =
                                (s.comm_status & !comm_status::PKW_BUSY) | comm_status::PKW_DONE;
                            s.comm_status &= !comm_status::PKW_INTERFACE;
                            events[0] = Some(Event::ParameterDone {
                                job: job.id,
                                address,
                                response: reply,
                            });
                        }
                        Verdict::Error(number) => {
                            s.job = None;
                            s.comm_status =
                                (s.comm_status & !comm_status::PKW_BUSY) | comm_status::PKW_ERROR;
                            events[0] = Some(Event::ParameterFailed {
                                job: job.id,
                                address,
                                status: status::PKW_ERROR,
                                error_number: Some(number),
                            });
                        }
                        Verdict::NoPermission => {
                            s.job = None;
                            s.comm_status = (s.comm_status & !comm_status::PKW_BUSY)
                                | comm_status::PKW_INTERFACE;
                            events[0] = Some(Event::ParameterFailed {
                                job: job.id,
                                address,
                                status: status::PKW_INTERFACE_ERROR,
                                error_number: None,
                            });
                        }
                        Verdict::NotYet => {}
                    }
                }
            }
        }
        self.emit(Event::Response {
            cycle,
            address,
            net,
        });
        let mut failed = false;
        for e in events.into_iter().flatten() {
            failed |= matches!(e, Event::ParameterFailed { .. });
            self.emit(e);
        }
        if failed {
            bump(&mut self.counters.pkw_failed);
        }
        self.check_retries(i);
    }

    /// A PKW job that has used up its WDH repetitions fails with a PKW interface error.
    fn check_retries(&mut self, i: usize) {
        let s = &mut self.slaves[i];
        let Some(job) = s.job else {
            return;
        };
        if job.sent > self.config.retries {
            s.job = None;
            s.comm_status = (s.comm_status & !comm_status::PKW_BUSY) | comm_status::PKW_INTERFACE;
            let address = s.address;
            // Never answered: the telegram-level cause, as a poll reports it (module docs).
            let status = if job.answered {
                status::PKW_INTERFACE_ERROR
            } else {
                s.last_status
            };
            bump(&mut self.counters.pkw_failed);
            self.emit(Event::ParameterFailed {
                job: job.id,
                address,
                status,
                error_number: None,
            });
        }
    }

    fn poll_failed(&mut self, address: u8, status: Status, error: Option<DecodeError>) {
        let Ok(i) = self.slave_index(address) else {
            return;
        };
        let bit = match status.code() {
            c if c == status::ADDRESS_ERROR.code() => comm_error::ADDRESS,
            c if c == status::NO_STX.code() => comm_error::NO_STX,
            c if c == status::BCC_ERROR.code() => comm_error::BCC,
            c if c == status::LGE_ERROR.code() => comm_error::LGE,
            c if c == status::NO_ANSWER.code() || c == status::RESIDUAL_TIME.code() => {
                comm_error::MONITORING_TIME
            }
            _ => 0,
        };
        let s = &mut self.slaves[i];
        s.comm_error = bit;
        s.comm_status |= comm_status::GROUP_ERROR;
        s.last_status = status;
        s.failed = s.failed.wrapping_add(1);
        let cycle = self.cycle;
        if status == status::NO_ANSWER {
            self.emit(Event::NoAnswer { cycle, address });
        } else {
            self.emit(Event::Rejected {
                cycle,
                address,
                status,
                error,
            });
        }
        self.check_retries(i);
    }

    fn fail_current(&mut self, now: Instant, current: Current, status: Status) {
        match current {
            Current::Poll { entry } => {
                let address = self.config.polling_list[entry].address;
                self.poll_failed(address, status, None);
            }
            Current::Mirror { job, address } => self.emit(Event::MirrorFailed {
                job,
                address,
                status,
            }),
        }
        self.advance(now, current);
    }
}

/// Count one more; counters wrap after 2³² instead of panicking.
fn bump(counter: &mut u32) {
    *counter = counter.wrapping_add(1);
}

/// How a PKW response relates to the job's request.
enum Verdict {
    Done,
    Error(u16),
    NoPermission,
    NotYet,
}

/// [SINAMICS CU240S] p. 229: the response matches when its ID answers the task and PNU, IND (and
/// for writes the value) are the request's; ID 7 with the request's PNU is the job's error.
fn judge(request: &Pkw, reply: &Pkw) -> Verdict {
    let ak = reply.pke.ak();
    let same_pnu = reply.pke.pnu() == request.pke.pnu();
    match ak {
        response::CANNOT_EXECUTE if same_pnu => {
            Verdict::Error(reply.pwe().last().copied().unwrap_or(0))
        }
        response::NO_PERMISSION => Verdict::NoPermission,
        _ => {
            let task = request.pke.ak();
            let fits =
                response::answers(task).contains(&ak) && same_pnu && reply.ind == request.ind;
            let writes = !matches!(
                task,
                task::READ | task::READ_ARRAY | task::READ_ARRAY_LEN | task::READ_DESCRIPTION
            );
            if fits && (!writes || reply.value() == request.value()) {
                Verdict::Done
            } else {
                Verdict::NotYet
            }
        }
    }
}

/// Lay a request out in a PKW area of `words`; `None` if the task is invalid there
/// ([Modbus/USS] §3.7.7 status bit 3).
fn build_request(words: PkwWords, r: &ParamRequest) -> Option<Pkw> {
    // [Modbus/USS] §3.7.7, comm status word bit 3, names two invalid request IDs: 15, and 4
    // with index 255. `[derived]` 10 is refused too: the USS task-ID table reserves it
    // ([USS spec], [MM 420]), so no drive serves it, and a refusal here says so at once instead
    // of a drive's error response. Above 15 the ID does not fit PKE's four bits.
    if r.task > 15 || r.task == task::TEXT || r.task == 10 {
        return None;
    }
    if r.task == task::READ_DESCRIPTION && r.param.index == 255 {
        return None;
    }
    let (pnu, ind) = r.param.split()?;
    let pke = Pke::new(r.task, false, pnu);
    let dword = matches!(
        r.task,
        task::WRITE_DWORD
            | task::WRITE_DWORD_EEPROM
            | task::WRITE_ARRAY_DWORD
            | task::WRITE_ARRAY_DWORD_EEPROM
    );
    match words {
        PkwWords::None => None,
        PkwWords::Three => {
            if dword {
                None
            } else {
                Some(Pkw::new(pke, ind, &[r.value as u16]))
            }
        }
        PkwWords::Four | PkwWords::Variable => {
            let pwe = if dword {
                [(r.value >> 16) as u16, r.value as u16]
            } else {
                [0, r.value as u16]
            };
            Some(Pkw::new(pke, ind, &pwe))
        }
    }
}

/// Net bytes of the response we expect from `e` (for the residual run time before LGE is in).
fn expected_response_len(e: &PollEntry) -> usize {
    match e.pkw {
        PkwWords::Variable => MAX_NET,
        _ => e.net_len(),
    }
}

impl Engine for Master {
    type Event = Event;

    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.rx.observe_read(now, bytes.len());
        for &b in bytes {
            if self.echo.drops(now, b) {
                continue;
            }
            let outcome = self.rx.push(now, b);
            match (self.phase, outcome) {
                (_, RxOutcome::StartNotIdentified) => bump(&mut self.counters.start_not_identified),
                (Phase::Awaiting { current, .. }, RxOutcome::Complete) => {
                    self.complete(now, current)
                }
                (Phase::Awaiting { current, .. }, RxOutcome::LengthError) => {
                    bump(&mut self.counters.rejected);
                    bump(&mut self.counters.length);
                    self.fail_current(now, current, status::LGE_ERROR);
                }
                (_, RxOutcome::Complete) | (_, RxOutcome::LengthError) => {
                    // A telegram nobody asked for (a late response): discarded.
                    bump(&mut self.counters.rejected);
                }
                _ => {}
            }
            if let Phase::Idle { at, latest } = self.phase {
                // Silence is waited for, but not past `latest` (a line that never goes quiet).
                self.phase = Phase::Idle {
                    at: at.max(now + self.start_interval).min(latest),
                    latest,
                };
            }
        }
    }

    fn handle_timeout(&mut self, now: Instant) {
        if self.rx.timeout(now).is_some() {
            bump(&mut self.counters.residual_time);
            bump(&mut self.counters.rejected);
            if let Phase::Awaiting { current, .. } = self.phase {
                // A telegram cut by a late packet: name the adapter if reads showed one.
                let residual = self.rx.annotate(status::RESIDUAL_TIME);
                self.fail_current(now, current, residual);
            }
        }
        if let Phase::Awaiting { current, deadline } = self.phase {
            if now >= deadline && !self.rx.is_receiving() {
                bump(&mut self.counters.no_answer);
                self.echo.stop();
                self.rx.resync();
                self.fail_current(now, current, status::NO_ANSWER);
            }
        }
        self.tick(now);
    }

    fn set_rx_latency(&mut self, latency: Duration) {
        self.rx.set_rx_latency(latency);
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        if self.echo.drops_line_error() {
            return;
        }
        match error {
            LineError::Framing => bump(&mut self.counters.framing),
            LineError::Parity => bump(&mut self.counters.parity),
            LineError::Overrun => bump(&mut self.counters.overrun),
            LineError::Break => bump(&mut self.counters.breaks),
        }
        let receiving = self.rx.is_receiving();
        self.rx.line_error(now, error);
        if let Phase::Awaiting { current, .. } = self.phase {
            if receiving {
                bump(&mut self.counters.rejected);
                self.fail_current(now, current, status::CHARACTER_ERROR);
            }
        }
    }

    fn poll_output(&mut self) -> Output<Event> {
        if let Some(o) = self.out.pop_front() {
            return o;
        }
        Output::Wait(match self.phase {
            Phase::Stopped => None,
            // While a stray telegram is on the line we send nothing: wake at its residual
            // deadline, not at a send time that may already have passed (no busy loop).
            Phase::Idle { at, latest } => Some(self.rx.deadline().map_or(at, |d| d.min(latest))),
            Phase::Awaiting { deadline, .. } => Some(self.rx.deadline().unwrap_or(deadline)),
        })
    }
}
