//! The module engine: the ET 200S SI module's side of the window protocol, for simulation, test
//! doubles and gateways that play the module.
//!
//! [ET200S SI 2005] §2.12.1–§2.12.7 `[derived]` ("Module-side state machine", the mirror image of
//! the host's) and [ET200S SI 2005] §2.12.7. Call [`Module::cycle`] once per DP cycle with the
//! output window the master wrote; it returns the input window the master will read. The serial
//! line sits behind the [`SerialSide`] trait, so any line engine (3964(R), ASCII, a loopback) can
//! be plugged in through a small adapter; [`LoopbackSerial`] is the one the tests and simulations
//! use.
//!
//! # Behaviour, job by job
//!
//! * **Idle:** publishes 00H and the receive status in bytes 1–2: 0000H none, 0001H a frame (or a
//!   receive error) waiting, 0B01H buffer more than 2/3 full ([ET200S SI 2005] §2.12.1). A job
//!   starts only from a request byte (job code, no error bit, exec 0); anything else is ignored.
//! * **Send (1) / parameters (5):** accepts with the job code and exec 0 (status word = the
//!   receive status), then checks each segment's exec number against last + 1 (after 7: 1, or 0
//!   with [`ModuleConfig::exec_wrap`], `[derived]`): in order → echo; the same number again →
//!   ignore (the host holds a segment until echoed); anything else → error bit with the last valid
//!   number ([ET200S SI 2005] §2.12.7). After the last segment a send frame goes to
//!   the serial side and the module answers 7xH + STATUS only when it has been transmitted
//!   ([ET200S SI 2005] §2.12.1–§2.12.7 `[derived]`); a parameter block is applied one cycle after
//!   its last echo (Table 2-28 shows 53H before 73H). 7xH carries the exec number of the last
//!   segment. A length word of 0 or above `max_frame_len` is answered at once after the segment
//!   carrying it with 7xH + 050EH ([ET200S SI 2005] §2.12.7 case 1, `[derived]`).
//! * **Receive (2):** no frame → 20H + 0101H; a buffered receive error → 20H + its STATUS
//!   ([ET200S SI 2005] §2.12.7 cases 2–3); else segment 1 at once as 21H with the length word
//!   (`[derived]`), each further segment after the host's echo, idle after the echo of the last one
//!   (the frame is then removed). The host's error bit → [`ReceiveErrorPolicy`] (`[derived]`).
//! * **Read V.24 (3):** 31H + signal word, idle after the host's echo 31H (Table 2-25).
//! * **Write V.24 (4):** the signal word rides in the request; answers 40H + STATUS and waits for
//!   the host's 00H (Table 2-26, `[derived]`).
//! * **Aborts:** idle (000) or 111 from the host during any job → idle, no error bit; a foreign job
//!   code → ignored with its data ([ET200S SI 2005] §2.12.7). A frame already handed to the serial
//!   side is still sent (`[derived]`); a frame being delivered stays in the buffer and is offered
//!   again.
//! * The 7xH / 20H / 40H answers are held until the host writes 00H (or 111).
//! * No module-side timeout (the manual has none, `[derived]`): a DP master that stops makes the
//!   module's outputs fail safe to 0, which is the idle code, so a half-done job is aborted by
//!   the rule above; a host restart writes 00H first for the same effect ([ET200S SI 2005] §2.12.2,
//!   §2.12.3, §2.11).

use crate::config::{ConfigError, FlowControl, ModuleConfig, ReceiveErrorPolicy};
use crate::coord::{CoordByte, ExecWrap, JobCode};
use crate::frame::{send_stream, ParamBlock, RxStatus, V24Signals, Window};
use crate::status::{
    FLOW_CONTROL_MISMATCH, INVALID_FRAME_LENGTH, NO_FREE_RECEIVE_BUFFER, NO_MESSAGE,
    PARAMETER_OUT_OF_RANGE, RECEIVED_FRAME_TOO_LONG, TRANSFER_ERROR_TO_CPU,
};
use bytes::Bytes;
use serde::{Deserialize, Serialize};
use si_core::{Duration, Instant, Status};
use std::collections::VecDeque;

/// What the serial side reports to the module engine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SerialEvent {
    /// A complete frame arrived from the partner.
    Received(Bytes),
    /// A frame was received with an error; the STATUS is delivered to the next receive job
    /// (20H + STATUS, [ET200S SI 2005] §2.12.7 case 2).
    ReceiveFailed(Status),
    /// The frame handed over with [`SerialSide::send`] has been transmitted (or failed).
    SendDone(Result<(), Status>),
}

/// The serial side of a module: a line engine (3964(R), ASCII, …) seen through a narrow face.
///
/// The module engine hands it one frame at a time and polls it once per DP cycle. Adapters for
/// the protocol crates implement it over their engines; [`LoopbackSerial`] implements it for tests.
pub trait SerialSide {
    /// Starts transmitting a complete frame; its end is reported as [`SerialEvent::SendDone`].
    /// An immediate refusal returns the STATUS (the module answers 7xH with it).
    fn send(&mut self, now: Instant, frame: &[u8]) -> Result<(), Status>;
    /// The next event since the last call, if any.
    fn poll(&mut self, now: Instant) -> Option<SerialEvent>;
    /// The current V.24 signal states (read V.24 job).
    fn signals(&self) -> V24Signals;
    /// Sets RTS and DTR (write V.24 job); a refusal returns the STATUS for the 40H answer.
    fn set_signals(&mut self, now: Instant, rts: bool, dtr: bool) -> Result<(), Status>;
    /// Applies a flow-control block the module has validated (parameter job).
    fn set_flow_control(&mut self, now: Instant, block: ParamBlock) -> Result<(), Status>;
}

/// Counters for diagnostics and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModuleStats {
    /// Jobs accepted from a request byte.
    pub jobs: u64,
    /// Segments that arrived out of order (error bit set).
    pub out_of_order: u64,
    /// Jobs aborted by the host's idle or 111 code.
    pub aborts: u64,
    /// Error bits received from the host in a receive job.
    pub host_errors: u64,
    /// Frames delivered completely to the host.
    pub frames_delivered: u64,
    /// Received frames dropped because the buffer was full.
    pub frames_dropped: u64,
    /// Output windows of the wrong length, ignored.
    pub invalid_windows: u64,
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum RxEntry {
    Frame(Bytes),
    Error(Status),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Idle,
    /// Send/parameters: `last` = exec number of the last accepted segment.
    Collect {
        job: JobCode,
        last: u8,
    },
    /// The send frame is complete; `exec` of the last segment. `handed` once the serial side has
    /// it (it may still be busy with a frame of an aborted job).
    Transmitting {
        exec: u8,
        handed: bool,
    },
    /// The parameter block is complete and echoed; it is applied in the next cycle (the
    /// module's processing time: Table 2-28 shows the echo 53H before 73H).
    Applying {
        exec: u8,
    },
    /// Holding an answer (7xH, 20H, 40H) until the host writes idle.
    Ended,
    /// Delivering the oldest frame: segment `k` of `segs` is published.
    Deliver {
        k: usize,
        segs: usize,
    },
    /// Read V.24 answer published, waiting for the echo.
    ReadV24,
}

/// Most serial events handled per cycle (keeps a cycle bounded whatever the serial side does).
const MAX_EVENTS_PER_CYCLE: usize = 64;

/// The module side of the window protocol. See the [module docs](self).
#[derive(Debug)]
pub struct Module<S> {
    cfg: ModuleConfig,
    serial: S,
    inw: Window,
    phase: Phase,
    rx: VecDeque<RxEntry>,
    rx_bytes: usize,
    /// Collected send/parameter stream (bounded by `max_frame_len + 2 + n`).
    stream: Vec<u8>,
    /// Stream of the frame being delivered.
    tx_stream: Vec<u8>,
    stats: ModuleStats,
    /// The serial side has a frame that has not been reported done.
    serial_busy: bool,
}

impl<S: SerialSide> Module<S> {
    /// A module in idle with an empty receive buffer.
    pub fn new(cfg: ModuleConfig, serial: S) -> Result<Module<S>, ConfigError> {
        cfg.validate()?;
        let n = cfg.window.payload();
        let mut m = Module {
            inw: Window::new(cfg.window),
            phase: Phase::Idle,
            // Frames plus the one error slot beyond them (`buffer_error`).
            rx: VecDeque::with_capacity(cfg.rx_buffer_frames + 1),
            rx_bytes: 0,
            stream: Vec::with_capacity(cfg.max_frame_len + 2 + n),
            tx_stream: Vec::with_capacity(cfg.max_frame_len + 2),
            stats: ModuleStats::default(),
            serial_busy: false,
            serial,
            cfg,
        };
        m.publish_idle();
        Ok(m)
    }

    /// A module restart or re-parameterization ([Modbus/USS] §3.8.2, §3.8.4): the running
    /// job is dropped and the module shows idle; with `clear_receive_buffer` (the parameter
    /// "clear receive buffer on startup", default yes, [ET200S SI 2005] §2.8.3, Table 2-8)
    /// the buffered frames are lost too. A frame already with the serial side still goes out.
    pub fn restart(&mut self, clear_receive_buffer: bool) {
        self.phase = Phase::Idle;
        self.stream.clear();
        if clear_receive_buffer {
            self.rx.clear();
            self.rx_bytes = 0;
        }
        self.publish_idle();
    }

    /// Counts execution numbers past 7 this way (`[derived]`; [`ModuleConfig::exec_wrap`]), for a
    /// module built by a constructor that takes no configuration (`engines::r3964r_module`, …).
    pub fn with_exec_wrap(mut self, wrap: ExecWrap) -> Self {
        self.cfg.exec_wrap = wrap;
        self
    }

    /// The configuration.
    pub fn config(&self) -> &ModuleConfig {
        &self.cfg
    }

    /// The serial side.
    pub fn serial(&self) -> &S {
        &self.serial
    }

    /// The serial side, mutably (to inject frames, change inputs …).
    pub fn serial_mut(&mut self) -> &mut S {
        &mut self.serial
    }

    /// Counters.
    pub fn stats(&self) -> ModuleStats {
        self.stats
    }

    /// The receive status as the idle window shows it.
    pub fn receive_status(&self) -> RxStatus {
        if self.rx.is_empty() {
            RxStatus::Empty
        } else if self.rx_bytes.saturating_mul(3) > self.cfg.rx_buffer_bytes.saturating_mul(2) {
            RxStatus::TwoThirdsFull
        } else {
            RxStatus::FramePresent
        }
    }

    /// Frames and receive errors waiting in the buffer.
    pub fn buffered(&self) -> usize {
        self.rx.len()
    }

    /// True when no job is in progress.
    pub fn is_idle(&self) -> bool {
        self.phase == Phase::Idle
    }

    /// The input window as last computed.
    pub fn input(&self) -> &[u8] {
        self.inw.as_bytes()
    }

    /// One DP cycle: takes the master's output window, returns the input window.
    ///
    /// An output window of the wrong length is ignored (the job state is kept).
    pub fn cycle(&mut self, now: Instant, output: &[u8]) -> &[u8] {
        self.drain_serial(now);
        self.advance_pending(now);
        match Window::from_bytes(output).filter(|w| w.size() == self.cfg.window) {
            Some(o) => self.step(now, &o),
            None => self.stats.invalid_windows += 1,
        }
        if matches!(self.phase, Phase::Transmitting { .. }) {
            self.advance_pending(now);
        }
        if self.phase == Phase::Idle {
            self.publish_idle();
        }
        self.inw.as_bytes()
    }

    fn drain_serial(&mut self, now: Instant) {
        for _ in 0..MAX_EVENTS_PER_CYCLE {
            let Some(event) = self.serial.poll(now) else {
                return;
            };
            match event {
                SerialEvent::Received(frame) => {
                    if frame.is_empty() {
                        continue;
                    }
                    if frame.len() > self.cfg.max_frame_len {
                        self.buffer_error(RECEIVED_FRAME_TOO_LONG);
                    } else if self.rx.len() >= self.cfg.rx_buffer_frames
                        || self.rx_bytes + frame.len() > self.cfg.rx_buffer_bytes
                    {
                        // "Prevent overwriting" (default yes): the newest frame is discarded
                        // and the loss reported ([ET200S SI 2005] §2.8.3, Table 2-8).
                        self.stats.frames_dropped += 1;
                        self.buffer_error(NO_FREE_RECEIVE_BUFFER);
                    } else {
                        self.rx_bytes += frame.len();
                        self.rx.push_back(RxEntry::Frame(frame));
                    }
                }
                SerialEvent::ReceiveFailed(status) => self.buffer_error(status),
                SerialEvent::SendDone(result) => {
                    self.serial_busy = false;
                    if let Phase::Transmitting { exec, handed: true } = self.phase {
                        let word = result.err().map_or(0, Status::code);
                        self.end_job(exec, word);
                    }
                }
            }
        }
    }

    /// Moves a complete job on: applies a collected parameter block (one cycle after its echo),
    /// hands a collected send frame to the serial side once that is free (it may still be busy
    /// with the frame of an aborted job).
    fn advance_pending(&mut self, now: Instant) {
        if let Phase::Applying { exec } = self.phase {
            let word = self.apply_parameters(now);
            self.end_job(exec, word);
            return;
        }
        let Phase::Transmitting {
            exec,
            handed: false,
        } = self.phase
        else {
            return;
        };
        if self.serial_busy {
            return;
        }
        match self.serial.send(now, &self.stream[2..]) {
            Ok(()) => {
                self.serial_busy = true;
                self.phase = Phase::Transmitting { exec, handed: true };
            }
            Err(status) => self.end_job(exec, status.code()),
        }
    }

    /// Queues a receive error for the next receive job; one slot beyond the frame limit is kept
    /// for it, and repeated losses collapse into one entry.
    fn buffer_error(&mut self, status: Status) {
        if self.rx.back() == Some(&RxEntry::Error(status)) {
            return;
        }
        if self.rx.len() <= self.cfg.rx_buffer_frames {
            self.rx.push_back(RxEntry::Error(status));
        }
    }

    fn publish_idle(&mut self) {
        let word = self.receive_status().word();
        self.inw.set_coord_word(CoordByte::IDLE, word);
    }

    /// 7xH + STATUS, held until the host's idle.
    fn end_job(&mut self, exec: u8, word: u16) {
        self.inw
            .set_coord_word(CoordByte::new(JobCode::EndOfJob, exec), word);
        self.phase = Phase::Ended;
    }

    fn answer(&mut self, job: JobCode, word: u16) {
        self.inw.set_coord_word(CoordByte::new(job, 0), word);
        self.phase = Phase::Ended;
    }

    fn step(&mut self, now: Instant, o: &Window) {
        let c = o.coord();
        let abort = matches!(c.job, JobCode::Idle | JobCode::EndOfJob);
        match self.phase {
            Phase::Idle => {
                if !c.error && c.exec == 0 {
                    self.start(now, c.job, o);
                }
            }
            Phase::Collect { job, last } => {
                if abort {
                    self.stats.aborts += 1;
                    self.phase = Phase::Idle;
                } else if c.job != job || c.error || c.exec == last {
                    // Foreign code: ignored with its data; same number: the host holds it.
                } else if c.exec == self.cfg.exec_wrap.next(last) {
                    self.collect(job, c.exec, o.data());
                } else {
                    self.stats.out_of_order += 1;
                    self.inw.set_coord_word(CoordByte::error(job, last), 0);
                }
            }
            Phase::Transmitting { .. } | Phase::Applying { .. } | Phase::Ended | Phase::ReadV24 => {
                let echo = self.phase == Phase::ReadV24
                    && c == CoordByte::new(JobCode::ReadV24, self.cfg.exec_wrap.of_segment(1));
                if abort || echo {
                    if abort && self.phase != Phase::Ended {
                        self.stats.aborts += 1;
                    }
                    self.phase = Phase::Idle;
                }
            }
            Phase::Deliver { k, segs } => {
                if abort {
                    self.stats.aborts += 1;
                    self.phase = Phase::Idle;
                } else if c.job != JobCode::Receive {
                    // Foreign code: ignored.
                } else if c.error {
                    self.stats.host_errors += 1;
                    match self.cfg.receive_error_policy {
                        ReceiveErrorPolicy::AbortAndReoffer => {
                            self.answer(JobCode::Receive, TRANSFER_ERROR_TO_CPU.code());
                        }
                        ReceiveErrorPolicy::GoBack => {
                            match self.cfg.exec_wrap.segment_with(k, c.exec) {
                                // The host reports everything valid: as good as the last echo.
                                Some(j) if j >= segs => self.delivered(),
                                Some(j) => {
                                    self.phase = Phase::Deliver { k: j + 1, segs };
                                    self.publish_segment(j + 1);
                                }
                                None => {}
                            }
                        }
                    }
                } else if c.exec == self.cfg.exec_wrap.of_segment(k) {
                    if k >= segs {
                        self.delivered();
                    } else {
                        self.phase = Phase::Deliver { k: k + 1, segs };
                        self.publish_segment(k + 1);
                    }
                }
            }
        }
    }

    /// The host has the whole frame: remove it and go idle.
    fn delivered(&mut self) {
        if let Some(RxEntry::Frame(f)) = self.rx.pop_front() {
            self.rx_bytes = self.rx_bytes.saturating_sub(f.len());
        }
        self.stats.frames_delivered += 1;
        self.phase = Phase::Idle;
    }

    fn start(&mut self, now: Instant, job: JobCode, o: &Window) {
        match job {
            JobCode::Send | JobCode::Parameters => {
                self.stats.jobs += 1;
                self.stream.clear();
                let word = self.receive_status().word();
                self.inw.set_coord_word(CoordByte::new(job, 0), word);
                self.phase = Phase::Collect { job, last: 0 };
            }
            JobCode::Receive => {
                self.stats.jobs += 1;
                match self.rx.front() {
                    None => self.answer(JobCode::Receive, NO_MESSAGE.code()),
                    Some(RxEntry::Error(s)) => {
                        let word = s.code();
                        self.rx.pop_front();
                        self.answer(JobCode::Receive, word);
                    }
                    Some(RxEntry::Frame(f)) => {
                        send_stream(f, &mut self.tx_stream);
                        let segs = self.cfg.window.segments(self.tx_stream.len());
                        self.phase = Phase::Deliver { k: 1, segs };
                        self.publish_segment(1);
                    }
                }
            }
            JobCode::ReadV24 => {
                self.stats.jobs += 1;
                let signals = self.serial.signals();
                let [b1, b2] = self.cfg.v24_layout.encode(signals);
                self.inw.clear();
                self.inw.set_coord(CoordByte::new(
                    JobCode::ReadV24,
                    self.cfg.exec_wrap.of_segment(1),
                ));
                self.inw.data_mut()[..2].copy_from_slice(&[b1, b2]);
                self.phase = Phase::ReadV24;
            }
            JobCode::WriteV24 => {
                self.stats.jobs += 1;
                let d = o.data();
                let s = self.cfg.v24_layout.decode([d[0], d[1]]);
                let word = match self.serial.set_signals(now, s.rts, s.dtr) {
                    Ok(()) => 0,
                    Err(status) => status.code(),
                };
                self.answer(JobCode::WriteV24, word);
            }
            JobCode::Idle | JobCode::Reserved | JobCode::EndOfJob => {}
        }
    }

    fn publish_segment(&mut self, k: usize) {
        self.inw.set_segment(
            CoordByte::new(JobCode::Receive, self.cfg.exec_wrap.of_segment(k)),
            &self.tx_stream,
            k,
        );
    }

    /// Accepts an in-order segment of a send or parameter job.
    fn collect(&mut self, job: JobCode, exec: u8, data: &[u8]) {
        self.stream.extend_from_slice(data);
        let (header, max_body) = match job {
            JobCode::Send => (2, self.cfg.max_frame_len),
            _ => (3, 16),
        };
        if self.stream.len() < header {
            self.echo(job, exec);
            return;
        }
        let body = usize::from(u16::from_be_bytes([
            self.stream[header - 2],
            self.stream[header - 1],
        ]));
        if (job == JobCode::Send && body == 0) || body > max_body {
            let status = if job == JobCode::Send {
                INVALID_FRAME_LENGTH
            } else {
                PARAMETER_OUT_OF_RANGE
            };
            self.end_job(exec, status.code());
            return;
        }
        let total = header + body;
        if self.stream.len() < total {
            self.echo(job, exec);
            return;
        }
        self.stream.truncate(total);
        if job == JobCode::Send {
            self.echo(job, exec);
            self.phase = Phase::Transmitting {
                exec,
                handed: false,
            };
        } else {
            self.echo(job, exec);
            self.phase = Phase::Applying { exec };
        }
    }

    fn echo(&mut self, job: JobCode, exec: u8) {
        self.inw.set_coord_word(CoordByte::new(job, exec), 0);
        self.phase = Phase::Collect { job, last: exec };
    }

    /// Table 2-27: the block must be the configured flow control's (else 0550H) and well formed
    /// (else 1E20H, parameter out of range).
    fn apply_parameters(&mut self, now: Instant) -> u16 {
        let block_no = self.stream[0];
        if self.cfg.flow_control.block() != Some(block_no) {
            return FLOW_CONTROL_MISMATCH.code();
        }
        let block = ParamBlock::decode(&self.stream).and_then(|b| b.check().map(|()| b));
        match block {
            Ok(block) => match self.serial.set_flow_control(now, block) {
                Ok(()) => 0,
                Err(status) => status.code(),
            },
            Err(_) => PARAMETER_OUT_OF_RANGE.code(),
        }
    }
}

/// A serial side for tests and simulations: frames "sent" are logged, optionally looped back as
/// received frames, and reported done after a fixed transmission time.
#[derive(Debug, Clone)]
pub struct LoopbackSerial {
    /// Frames sent come back as received frames.
    pub loopback: bool,
    /// Time from [`SerialSide::send`] to [`SerialEvent::SendDone`].
    pub send_time: Duration,
    /// Fail the next send with this STATUS instead of transmitting.
    pub fail_next_send: Option<Status>,
    /// The input signals (DCD, CTS, DSR) the module reads.
    pub inputs: V24Signals,
    /// The flow-control block last applied.
    pub flow_control: Option<ParamBlock>,
    /// Flow control the fake accepts; a block of another type is refused with 0550H, as a line
    /// engine configured for it would.
    pub configured_flow: FlowControl,
    rts: bool,
    dtr: bool,
    sending: Option<(Bytes, Instant)>,
    events: VecDeque<SerialEvent>,
    sent: VecDeque<Bytes>,
}

/// Frames kept in [`LoopbackSerial::sent`]'s log.
const SENT_LOG: usize = 1024;

impl Default for LoopbackSerial {
    fn default() -> Self {
        LoopbackSerial {
            loopback: true,
            send_time: Duration::ZERO,
            fail_next_send: None,
            inputs: V24Signals::default(),
            flow_control: None,
            configured_flow: FlowControl::XonXoff,
            rts: false,
            dtr: false,
            sending: None,
            events: VecDeque::new(),
            sent: VecDeque::new(),
        }
    }
}

impl LoopbackSerial {
    /// Loopback on, zero transmission time.
    pub fn new() -> Self {
        LoopbackSerial::default()
    }

    /// A frame arrives from the partner.
    pub fn inject_frame(&mut self, frame: impl Into<Bytes>) {
        self.events.push_back(SerialEvent::Received(frame.into()));
    }

    /// A frame arrives with an error.
    pub fn inject_error(&mut self, status: Status) {
        self.events.push_back(SerialEvent::ReceiveFailed(status));
    }

    /// The frames transmitted so far (the last 1024).
    pub fn sent(&self) -> impl Iterator<Item = &Bytes> {
        self.sent.iter()
    }

    /// Takes the log of transmitted frames.
    pub fn take_sent(&mut self) -> Vec<Bytes> {
        self.sent.drain(..).collect()
    }
}

impl SerialSide for LoopbackSerial {
    fn send(&mut self, now: Instant, frame: &[u8]) -> Result<(), Status> {
        if let Some(status) = self.fail_next_send.take() {
            return Err(status);
        }
        self.sending = Some((Bytes::copy_from_slice(frame), now + self.send_time));
        Ok(())
    }

    fn poll(&mut self, now: Instant) -> Option<SerialEvent> {
        if let Some((frame, done)) = &self.sending {
            if now >= *done {
                let frame = frame.clone();
                self.sending = None;
                if self.sent.len() >= SENT_LOG {
                    self.sent.pop_front();
                }
                self.sent.push_back(frame.clone());
                if self.loopback {
                    self.events.push_back(SerialEvent::Received(frame));
                }
                return Some(SerialEvent::SendDone(Ok(())));
            }
        }
        self.events.pop_front()
    }

    fn signals(&self) -> V24Signals {
        V24Signals {
            rts: self.rts,
            dtr: self.dtr,
            ..self.inputs
        }
    }

    fn set_signals(&mut self, _now: Instant, rts: bool, dtr: bool) -> Result<(), Status> {
        self.rts = rts;
        self.dtr = dtr;
        Ok(())
    }

    fn set_flow_control(&mut self, _now: Instant, block: ParamBlock) -> Result<(), Status> {
        if self.configured_flow.block() != Some(block.number()) {
            return Err(FLOW_CONTROL_MISMATCH);
        }
        self.flow_control = Some(block);
        Ok(())
    }
}
