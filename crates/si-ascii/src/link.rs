//! The ASCII driver as a Sans-IO engine ([ET200S SI] §2.8): receive end criteria,
//! the receive frame buffer, transmit with inter-frame pause, XON/XOFF and RTS/CTS flow control,
//! automatic V.24 operation and RS-485 half duplex.
//!
//! ```
//! use si_ascii::{Config, EndCriterion, Event, Link};
//! use si_core::{Duration, Engine, Instant, Output};
//!
//! let config = Config { end: EndCriterion::DEFAULT_END_CHARS, ..Config::default() };
//! let mut link = Link::new(config).unwrap();
//! link.handle_rx(Instant::ZERO, b"ab\x03c");
//! assert!(matches!(link.poll_output(), Output::Event(Event::Received { len: 3, .. })));
//! assert_eq!(link.read_frame_vec(Instant::ZERO).unwrap(), b"ab\x03");
//! // "c" waits for its end character, monitored by the character delay time.
//! assert!(matches!(link.poll_output(), Output::Wait(Some(_))));
//! ```
//!
//! # Readings of the manual
//!
//! - **Character delay time** ([ET200S SI] §2.6, Fig. 2-10): "the longest gap allowed between two
//!   characters". The host sees a character when it is complete, so the next character must
//!   *complete* within CDT + one character time of the previous one; a gap of exactly the CDT keeps
//!   the frame whole, one microsecond more ends it, and the frame end is reported at that
//!   microsecond.
//! - **Inter-frame pause** ([ET200S SI] §2.8, Fig. 2-17): in CDT mode a frame starts only after
//!   *more than* one CDT since the end of our previous frame (the 2005 manual's "a gap longer than
//!   the CDT"), so a partner with the same CDT always sees two frames. Only in CDT mode, as the ET
//!   200S manual says; the CP 341 ([CP 341] §2.2.4) also pauses in fixed-length mode, switchably.
//! - **Surplus characters** after an end-of-text sequence or a fixed-length frame start the next
//!   frame ([CP 341] §2.2.4, [CP 440], [CP 340]); if the CDT then runs out they are a fragment:
//!   0806H.
//! - **Errors inside a frame** (parity, framing, overrun, BREAK, too long, no buffer): the frame is
//!   discarded, the error reported once, and the rest of that frame skipped until the line is quiet
//!   for the CDT (or, with end characters, until the end characters), so its tail never becomes a
//!   frame of its own.
//! - **Frame longer than the maximum** ([`Config::max_frame_len`], 200 bytes by default) in CDT
//!   or end-character mode (`[derived]`): reported with 0850H ([ET200S SI 2005] Table 2-29,
//!   "received frame longer than 224 bytes or than the configured length") and discarded; 050EH is
//!   class 05 "error executing a CPU job" and stays with the send side: a send job longer than the
//!   maximum is refused with 050EH (Table 2-28 "invalid frame length", [ET200S SI] §2.12: the
//!   module rejects a send longer than its maximum, `[derived]`), an empty one with 1E41H (the FB's
//!   LEN check). The FB itself ([`crate::fb`]) checks LEN against 1 … maximum first and answers
//!   1E41H, as S_SEND does (Table 2-13).
//! - **Buffer full** ([ET200S SI] §2.8): with dynamic frames and overwrite allowed the oldest
//!   frames make room (reported with 080AH, the manual's "diagnostic interrupt"); with overwrite
//!   prevented the newest frame is lost with 080AH, or with 0812H when we had already sent XOFF /
//!   RTS = OFF ([ET200S SI] §2.8). Without dynamic frames one frame is stored (`[derived]`):
//!   prevent overwrite keeps it and loses the new one (080AH); otherwise the new frame replaces it,
//!   the manual's "only the newest frame".
//! - **XOFF threshold** (`[derived]`): XOFF / RTS = OFF when 50 bytes or fewer are free, or,
//!   without dynamic frames, when the one frame the buffer holds is stored (the "configured number
//!   of frames" is reached); XON / RTS = ON once a read makes room again.
//! - **Automatic V.24** (`[derived]`): RTS = ON, then the data go out as soon as CTS = ON, and the
//!   send fails with 0818H if CTS is still off when the data output wait time ends; RTS = OFF after
//!   the RTS-off time from the last byte, and only then is the job done.
//! - **Character delay while holding the partner**: after XOFF / RTS = OFF the partner is
//!   supposed to pause, possibly inside a frame, so the character delay time is not monitored
//!   until XON / RTS = ON; then it starts again.
//! - **Flow-control wait** ([ET200S SI] §2.8): the XON / CTS wait time runs from the moment sending
//!   is held (XOFF or CTS = OFF while sending, or at the start of a send that finds it held).
//! - **Behind a USB adapter** (not in the manual): a port that hands received bytes
//!   over in packets (declared with [`Engine::set_rx_latency`], or shown by a read of two or
//!   more bytes, [`si_core::delivery`]) gets the port's allowance added to the character delay
//!   time, so a hole between two packets of one frame does not end it (with end characters or
//!   a fixed length, which end a frame by its content, the longest latency an adapter can
//!   have, [`Delivery::longest_patience`](si_core::delivery::Delivery::longest_patience)). Frames the partner
//!   separates by less than the adapter's latency cannot be told apart on such a port (the
//!   adapter packs them together); end characters and fixed length still cut them. On a port
//!   that delivers byte by byte the allowance is zero and the timing above holds exactly.
//! - Transmission goes out in chunks of [`Config::tx_chunk`] characters whenever a flow control
//!   is configured, so XOFF or CTS = OFF stops the sender after the chunk on the line; with a
//!   chunk of 1 (for simulation) that is the character on the line, as the module does. Without
//!   flow control the whole frame is handed out at once.

use crate::buffer::FrameBuffer;
use crate::config::{
    AutoV24, Config, ConfigError, EndCriterion, FlowControl, Interface, RtsCts, XonXoff,
    XOFF_MARGIN,
};
use crate::frame::{Cut, Cutter};
use crate::status;
use bytes::Bytes;
use si_core::delivery::Delivery;
use si_core::echo::EchoFilter;
use si_core::param_block::{ten_ms_time, ParamBlock};
use si_core::v24::{AutoV24 as AutoV24Sequence, Step};
use si_core::{
    Duration, Engine, FramePool, Instant, LineError, ModemSignals, Output, SignalUpdate, Status,
};
use std::collections::VecDeque;

/// The one job id of si-core, here because users name it from this module.
pub use si_core::JobId;

/// What the link reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// A frame of `len` bytes was cut and stored; read it with [`Link::read_frame`].
    Received {
        /// Frame length in bytes.
        len: usize,
        /// When the end criterion was met.
        at: Instant,
    },
    /// Receiving failed (0806H, 080AH, 080CH, 080DH, 0810H, 0811H, 0812H, 0818H, 0850H).
    ReceiveError {
        /// What went wrong.
        status: Status,
        /// When.
        at: Instant,
    },
    /// A send job is complete: the last byte has left (and, with automatic V.24, RTS is off).
    Sent {
        /// The job.
        job: JobId,
        /// When.
        at: Instant,
    },
    /// A send job failed (0708H, 0818H).
    SendFailed {
        /// The job.
        job: JobId,
        /// Why.
        status: Status,
        /// When.
        at: Instant,
    },
}

/// Why [`Link::send`] refused a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SendError {
    /// A send job is still running (S_SEND's BUSY).
    #[error("a send job is still running")]
    Busy,
    /// An empty frame (S_SEND LEN must be at least 1).
    #[error("frame length {0} out of range: a frame needs at least 1 byte")]
    Length(usize),
    /// More bytes than the configured maximum frame length ([`Config::max_frame_len`]).
    #[error("frame of {len} bytes is longer than the maximum of {max} bytes")]
    TooLong {
        /// Bytes given.
        len: usize,
        /// The configured maximum.
        max: usize,
    },
    /// With XON/XOFF, user data must not contain the XON or XOFF character ([ET200S SI] §2.8, Fig.
    /// 2-17).
    #[error("frame contains the flow-control character {0:02X}H, not allowed with XON/XOFF")]
    FlowCharacter(u8),
}

impl SendError {
    /// The STATUS: 1E41H for an empty frame, 050EH for one longer than the maximum, 0502H
    /// otherwise.
    pub fn status(&self) -> Status {
        match self {
            SendError::Length(_) => status::INVALID_LEN,
            SendError::TooLong { .. } => status::INVALID_FRAME_LENGTH,
            _ => status::NOT_POSSIBLE_IN_MODE,
        }
    }
}

/// A signal or parameter job the configuration does not allow.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("job refused: {status}{}", detail.as_ref().map(|d| format!(" ({d})")).unwrap_or_default())]
pub struct Refused {
    /// The STATUS an FB reports.
    pub status: Status,
    /// The parameter error behind it, if any.
    pub detail: Option<ConfigError>,
}

impl Refused {
    fn new(status: Status) -> Self {
        Refused {
            status,
            detail: None,
        }
    }
}

impl From<ConfigError> for Refused {
    fn from(e: ConfigError) -> Self {
        Refused {
            status: e.status(),
            detail: Some(e),
        }
    }
}

/// Receiver state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rx {
    /// Between frames.
    Idle,
    /// A frame is being received into the buffer.
    Receiving,
    /// The rest of a broken frame is being skipped.
    Skipping,
}

/// Transmitter state.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Tx {
    Idle,
    /// Accepted; waiting for the inter-frame pause or (RS-485) a quiet receiver.
    Waiting {
        job: JobId,
        frame: Bytes,
        not_before: Instant,
    },
    /// Automatic V.24: RTS is on, waiting for CTS (until [`AutoV24::deadline`]).
    WaitCts {
        job: JobId,
        frame: Bytes,
    },
    /// Handing out bytes; `hold_until` while XOFF / CTS = OFF holds us.
    Sending {
        job: JobId,
        frame: Bytes,
        pos: usize,
        hold_until: Option<Instant>,
    },
    /// Automatic V.24: all sent, RTS goes off at [`AutoV24::deadline`].
    RtsOff {
        job: JobId,
    },
}

const fn all_bytes() -> [u8; 256] {
    let mut a = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        a[i] = i as u8;
        i += 1;
    }
    a
}

/// One static byte per value, so a flow-control character is sent without allocating.
static ALL_BYTES: [u8; 256] = all_bytes();

fn single(byte: u8) -> Bytes {
    let i = usize::from(byte);
    Bytes::from_static(&ALL_BYTES[i..i + 1])
}

/// The ASCII driver engine.
#[derive(Debug)]
pub struct Link {
    cfg: Config,
    cdt: Duration,
    /// CDT + one character time + 1 µs + the port's allowance: a received character's
    /// monitoring deadline is this after it completes ([`Link::gap_deadline`]).
    gap: Duration,
    /// How late the port hands bytes over ([`si_core::delivery`]).
    delivery: Delivery,
    mask: u8,
    /// Every received character is part of a frame: no XON/XOFF characters to pick out, no
    /// RS-485 echo to ignore, no DSR to watch (the flow control and interface never change
    /// after [`Link::new`]).
    plain_rx: bool,
    /// XON/XOFF or RTS/CTS: the buffer's fill level can hold the partner ([`Link::check_stop`]).
    holds_partner: bool,
    /// No XOFF / RTS = OFF sent and no send job: the next deadline is the receive one alone, so
    /// [`Engine::poll_output`] answers from `rx_deadline` directly (it is polled after
    /// every byte). Recomputed by [`Link::settle_wait`] at the end of every input except the
    /// inline receive path, which changes neither (it only calls out to paths that settle).
    /// Only a send ([`Link::send`]) and XOFF / RTS = OFF ([`Link::stop_partner`]) can make it
    /// false; debug builds check every answer against the full computation.
    rx_deadline_only: bool,
    buffer: FrameBuffer,
    cutter: Cutter,
    rx: Rx,
    rx_deadline: Option<Instant>,
    rx_error: Option<Status>,
    /// We told the partner to stop (XOFF sent / RTS = OFF).
    stop_sent: bool,
    tx: Tx,
    /// Bytes handed out whose tx-done has not come yet.
    in_flight: bool,
    /// RS-485 is half duplex ([CP 341] §2.2.4): what is received while our
    /// bytes are in flight is our own (si-core's one echo filter, while-sending mode). `None`
    /// on RS-232 and RS-422.
    echo: Option<EchoFilter>,
    last_tx_end: Option<Instant>,
    /// The partner sent XOFF.
    partner_stopped: bool,
    next_job: u64,
    send_result: Option<(JobId, Result<(), Status>)>,
    inputs: ModemSignals,
    rts: bool,
    dtr: bool,
    /// The automatic V.24 sequence (si-core, shared with Modbus), with that flow control only.
    v24: Option<AutoV24Sequence>,
    out: VecDeque<Output<Event>>,
    /// [`Link::read_frame_bytes`] cuts frames from this pool: once the caller has dropped the
    /// frames it took, a steady state allocates nothing per frame. Allocated at creation, room
    /// for [`RX_POOL_FRAMES`] of the longest frames.
    rx_pool: FramePool,
}

/// Frames [`Link::read_frame_bytes`] allocates room for at a time, of the longest size.
const RX_POOL_FRAMES: usize = 4;

impl Link {
    /// A link with validated parameters, entering its flow-control mode as the module does at
    /// startup ([ET200S SI] §2.8): XON is sent, or RTS = ON, or (automatic V.24) DTR = ON, RTS =
    /// OFF.
    pub fn new(config: Config) -> Result<Link, ConfigError> {
        config.validate()?;
        let mut link = Link {
            cfg: config,
            cdt: config.char_delay,
            gap: config.settings.gap_limit(config.char_delay),
            delivery: Delivery::new(&config.settings),
            mask: config.settings.data_mask(),
            plain_rx: matches!(config.flow_control, FlowControl::None | FlowControl::RtsCts)
                && config.interface != Interface::Rs485,
            holds_partner: matches!(
                config.flow_control,
                FlowControl::XonXoff | FlowControl::RtsCts
            ),
            buffer: FrameBuffer::new(),
            cutter: Cutter::new(config.end, config.max_frame()),
            rx: Rx::Idle,
            rx_deadline: None,
            rx_error: None,
            stop_sent: false,
            tx: Tx::Idle,
            in_flight: false,
            echo: (config.interface == Interface::Rs485).then(EchoFilter::while_sending),
            last_tx_end: None,
            partner_stopped: false,
            next_job: 0,
            send_result: None,
            inputs: ModemSignals::default(),
            rts: false,
            dtr: false,
            v24: (config.flow_control == FlowControl::AutoV24)
                .then(|| AutoV24Sequence::new(config.auto_v24)),
            out: VecDeque::with_capacity(16),
            rx_pool: FramePool::preallocated(RX_POOL_FRAMES * config.max_frame()),
            rx_deadline_only: true,
        };
        link.delivery_changed();
        link.enter_mode();
        link.settle_wait();
        Ok(link)
    }

    /// The parameters in force.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// CPU STOP → RUN ([ET200S SI] §2.11): clear the receive buffer if so configured, and announce
    /// the flow-control mode again. A send job in progress is completed ([ET200S SI] §2.11, "CPU
    /// STOP").
    pub fn restart(&mut self, now: Instant) {
        if self.cfg.clear_at_startup {
            self.buffer.clear();
            self.cutter.reset();
            self.rx = Rx::Idle;
            self.rx_deadline = None;
        }
        self.stop_sent = false;
        self.enter_mode();
        // Frames kept over the restart may still call for XOFF / RTS = OFF.
        self.check_stop();
        self.pump(now);
        self.settle_wait();
    }

    fn enter_mode(&mut self) {
        match self.cfg.flow_control {
            FlowControl::None => {}
            FlowControl::XonXoff => self.transmit_flow_char(self.cfg.xon_xoff.xon),
            FlowControl::RtsCts => self.set_rts(true),
            // RTS = OFF, unless a send job (which is completed, [ET200S SI] §2.11) holds it on.
            FlowControl::AutoV24 => {
                self.v24_step(|v, out| {
                    v.enter(out);
                    Step::Nothing
                });
            }
        }
    }

    // ---------------------------------------------------------------- send side

    /// Start a send job (S_SEND). The frame is the user data, 1 … [`Config::max_frame_len`]
    /// bytes (200 by default), including any start
    /// and end characters the partner needs ([ET200S SI] §2.8, Fig. 2-17). Completion comes as
    /// [`Event::Sent`] or [`Event::SendFailed`].
    pub fn send(&mut self, now: Instant, frame: Bytes) -> Result<JobId, SendError> {
        if self.tx != Tx::Idle {
            return Err(SendError::Busy);
        }
        if frame.is_empty() {
            return Err(SendError::Length(0));
        }
        if frame.len() > self.cfg.max_frame() {
            return Err(SendError::TooLong {
                len: frame.len(),
                max: self.cfg.max_frame(),
            });
        }
        if self.cfg.flow_control == FlowControl::XonXoff {
            let XonXoff { xon, xoff, .. } = self.cfg.xon_xoff;
            // On the wire a 7-bit character loses its top bit.
            let mask = self.mask;
            if let Some(&b) = frame.iter().find(|&&b| b & mask == xon || b & mask == xoff) {
                return Err(SendError::FlowCharacter(b));
            }
        }
        let job = JobId(self.next_job);
        self.next_job = self.next_job.wrapping_add(1);
        let not_before = match (self.cfg.end, self.last_tx_end) {
            (EndCriterion::CharDelay, Some(end)) => end + self.cdt + Duration::from_micros(1),
            _ => now,
        };
        self.tx = Tx::Waiting {
            job,
            frame,
            not_before,
        };
        self.pump(now);
        self.settle_wait();
        Ok(job)
    }

    /// True while a send job runs.
    pub fn is_sending(&self) -> bool {
        self.tx != Tx::Idle
    }

    /// The outcome of `job` once it has finished (kept until the next job finishes).
    pub fn send_result(&self, job: JobId) -> Option<Result<(), Status>> {
        self.send_result.filter(|(j, _)| *j == job).map(|(_, r)| r)
    }

    fn held(&self) -> bool {
        match self.cfg.flow_control {
            FlowControl::XonXoff => self.partner_stopped,
            FlowControl::RtsCts => !self.inputs.cts,
            _ => false,
        }
    }

    fn hold_time(&self) -> Duration {
        match self.cfg.flow_control {
            FlowControl::XonXoff => self.cfg.xon_xoff.wait_for_xon,
            _ => self.cfg.rts_cts.wait_for_cts,
        }
    }

    fn rx_busy(&self) -> bool {
        self.rx != Rx::Idle
    }

    /// Move the transmitter on as far as the state allows.
    fn pump(&mut self, now: Instant) {
        if let Tx::Waiting { not_before, .. } = self.tx {
            let half_duplex_busy = self.cfg.interface == Interface::Rs485 && self.rx_busy();
            if now >= not_before && !half_duplex_busy {
                let Tx::Waiting { job, frame, .. } = std::mem::replace(&mut self.tx, Tx::Idle)
                else {
                    return;
                };
                self.start(now, job, frame);
            }
        }
        if let Tx::Sending {
            frame,
            pos,
            hold_until: None,
            ..
        } = &mut self.tx
        {
            if !self.in_flight && *pos < frame.len() {
                let rest = frame.len() - *pos;
                let n = match self.cfg.flow_control {
                    FlowControl::None => rest,
                    _ => rest.min(usize::from(self.cfg.tx_chunk)),
                };
                let chunk = frame.slice(*pos..*pos + n);
                *pos += n;
                self.put_on_air(chunk);
            }
        }
    }

    fn start(&mut self, now: Instant, job: JobId, frame: Bytes) {
        if self.v24.is_some() {
            // [ET200S SI] §2.8: RTS = ON, then the data go out at CTS = ON; while the partner is
            // not ready (DSR = OFF) a send job is aborted.
            match self.v24_step(|v, out| v.begin(now, out)) {
                Step::Abort => return self.fail_send(now, job, status::DSR_CTS_OFF),
                Step::Send => {}
                Step::Nothing | Step::Done => {
                    self.tx = Tx::WaitCts { job, frame };
                    return;
                }
            }
        }
        let hold_until = self.held().then(|| now + self.hold_time());
        self.tx = Tx::Sending {
            job,
            frame,
            pos: 0,
            hold_until,
        };
        self.pump(now);
    }

    fn fail_send(&mut self, now: Instant, job: JobId, status: Status) {
        self.tx = Tx::Idle;
        self.last_tx_end = Some(now);
        self.v24_step(|v, out| {
            v.cancel(out);
            Step::Nothing
        });
        self.send_result = Some((job, Err(status)));
        self.out.push_back(Output::Event(Event::SendFailed {
            job,
            status,
            at: now,
        }));
    }

    fn finish_send(&mut self, now: Instant, job: JobId) {
        self.tx = Tx::Idle;
        self.send_result = Some((job, Ok(())));
        self.out
            .push_back(Output::Event(Event::Sent { job, at: now }));
    }

    /// Run one input of the automatic V.24 sequence and take over the outputs it set;
    /// [`Step::Nothing`] without that flow control.
    fn v24_step(
        &mut self,
        f: impl FnOnce(&mut AutoV24Sequence, &mut VecDeque<Output<Event>>) -> Step,
    ) -> Step {
        let Some(v24) = self.v24.as_mut() else {
            return Step::Nothing;
        };
        let step = f(v24, &mut self.out);
        (self.rts, self.dtr) = (v24.rts(), v24.dtr());
        step
    }

    fn set_rts(&mut self, on: bool) {
        self.rts = on;
        self.out.push_back(Output::SetSignals(SignalUpdate {
            dtr: None,
            rts: Some(on),
        }));
    }

    fn transmit_flow_char(&mut self, c: u8) {
        self.put_on_air(single(c));
    }

    /// Hands `bytes` to the driver: in flight until tx-done, and heard back as echo on RS-485.
    fn put_on_air(&mut self, bytes: Bytes) {
        self.in_flight = true;
        if let Some(echo) = self.echo.as_mut() {
            echo.sent_len(bytes.len());
        }
        self.out.push_back(Output::Transmit(bytes));
    }

    /// XOFF received or CTS = OFF: hold sending and start the wait time.
    fn hold(&mut self, now: Instant) {
        let until = now + self.hold_time();
        if let Tx::Sending { hold_until, .. } = &mut self.tx {
            hold_until.get_or_insert(until);
        }
    }

    /// XON received or CTS = ON: go on sending.
    fn resume(&mut self, now: Instant) {
        if let Tx::Sending { hold_until, .. } = &mut self.tx {
            *hold_until = None;
        }
        self.pump(now);
    }

    // ------------------------------------------------------------- receive side

    /// Copy the oldest received frame into `out` and remove it from the buffer (S_RCV); its
    /// length. `None` if no frame is stored or `out` is shorter than the frame (then it stays;
    /// [`Config::max_frame_len`] bytes always suffice).
    /// `now` matters with flow control: a read that makes room sends XON / sets RTS = ON.
    pub fn read_frame(&mut self, now: Instant, out: &mut [u8]) -> Option<usize> {
        let n = self.buffer.pop_into(out)?;
        self.frame_taken(now);
        Some(n)
    }

    /// [`read_frame`](Self::read_frame) as [`Bytes`] cut from a buffer the link keeps: no
    /// allocation per frame in steady state, once the frames taken before have been dropped
    /// (the si-core contract; a module forwarding frames through the DP window reads them so).
    pub fn read_frame_bytes(&mut self, now: Instant) -> Option<Bytes> {
        let len = self.buffer.oldest_len()?;
        let buffer = &mut self.buffer;
        let frame = self
            .rx_pool
            .cut_filled(len, |dst| buffer.pop_into(dst).is_some())?;
        self.frame_taken(now);
        Some(frame)
    }

    /// A frame has left the buffer: the partner may go on (XON / RTS = ON), and a half-duplex
    /// send may start.
    fn frame_taken(&mut self, now: Instant) {
        self.check_resume(now);
        self.pump(now);
        self.settle_wait();
    }

    /// [`read_frame`](Self::read_frame) into a new vector.
    pub fn read_frame_vec(&mut self, now: Instant) -> Option<Vec<u8>> {
        let mut v = vec![0; self.buffer.oldest_len()?];
        self.read_frame(now, &mut v)?;
        Some(v)
    }

    /// Frames stored and waiting to be read.
    pub fn frames_waiting(&self) -> usize {
        self.buffer.frames()
    }

    /// The receive buffer (read-only), for diagnostics.
    pub fn buffer(&self) -> &FrameBuffer {
        &self.buffer
    }

    /// S_RCV's STATUS when there is no error: 0B01H while the buffer is more than 2/3 full,
    /// else 0000H ([ET200S SI] §2.8, `[derived]`).
    pub fn receive_status(&self) -> Status {
        if self.buffer.above_two_thirds() {
            status::BUFFER_TWO_THIRDS_FULL
        } else {
            Status::OK
        }
    }

    /// The latest receive error not yet taken (S_RCV reports it once).
    pub fn take_receive_error(&mut self) -> Option<Status> {
        self.rx_error.take()
    }

    fn rx_fail(&mut self, now: Instant, status: Status) {
        self.rx_error = Some(status);
        self.out
            .push_back(Output::Event(Event::ReceiveError { status, at: now }));
        self.check_resume(now);
    }

    /// The rest of the current frame is to be skipped; `byte` (the one that broke it) may
    /// already end it.
    fn skip_rest(&mut self, byte: Option<u8>) {
        self.buffer.discard_pending();
        self.cutter.reset();
        if byte.is_some_and(|b| self.cutter.ends_text(b)) {
            self.rx = Rx::Idle;
            self.rx_deadline = None;
        } else {
            self.rx = Rx::Skipping;
        }
    }

    /// XOFF / RTS = OFF once the buffer reaches the threshold (`[derived]`). Runs after every
    /// stored character, so the common "nothing to do" answer is a few comparisons inline.
    #[inline]
    fn check_stop(&mut self) {
        if !self.holds_partner || self.stop_sent {
            return;
        }
        let full = self.buffer.free() <= XOFF_MARGIN
            || (!self.cfg.dynamic_frames && self.buffer.frames() >= 1);
        if full {
            self.stop_partner();
        }
    }

    fn stop_partner(&mut self) {
        match self.cfg.flow_control {
            FlowControl::XonXoff => self.transmit_flow_char(self.cfg.xon_xoff.xoff),
            FlowControl::RtsCts => self.set_rts(false),
            _ => return,
        }
        self.stop_sent = true;
        self.settle_wait();
    }

    fn check_resume(&mut self, now: Instant) {
        let room = self.buffer.free() > XOFF_MARGIN
            && (self.cfg.dynamic_frames || self.buffer.frames() == 0);
        if !self.stop_sent || !room {
            return;
        }
        self.stop_sent = false;
        // The partner may go on now: the character delay monitoring of a frame it paused in
        // starts again.
        if self.rx_deadline.is_some() {
            self.rx_deadline = Some(self.gap_deadline(now));
        }
        match self.cfg.flow_control {
            FlowControl::XonXoff => self.transmit_flow_char(self.cfg.xon_xoff.xon),
            FlowControl::RtsCts => self.set_rts(true),
            _ => {}
        }
    }

    /// One received character. The common case, a character inside a frame that neither ends
    /// it, nor is a flow-control character, nor fills the buffer, is kept short and inline, so
    /// a host fed one byte per [`Engine::handle_rx`] pays little more than one fed whole
    /// frames; everything else goes through [`Link::on_byte_general`], which handles
    /// every case. `gap` is [`Link::gap_deadline`] of `now`, computed once per call.
    #[inline(always)]
    fn on_byte(&mut self, now: Instant, gap: Instant, byte: u8) {
        let byte = byte & self.mask;
        if self.rx != Rx::Receiving || (!self.plain_rx && self.rx_intercepts(byte)) {
            self.on_byte_general(now, gap, byte);
            return;
        }
        self.rx_deadline = Some(gap);
        match self.cutter.push(byte) {
            Cut::Continue => {
                if self.buffer.push(byte) || self.store_when_full(now, byte) {
                    self.check_stop();
                }
            }
            cut => self.frame_byte(now, byte, cut),
        }
    }

    /// True when `byte` is not a character of the frame in progress: an XON / XOFF character,
    /// our own RS-485 echo, or anything while DSR = OFF under automatic V.24 operation.
    #[inline]
    fn rx_intercepts(&self, byte: u8) -> bool {
        match self.cfg.flow_control {
            FlowControl::None | FlowControl::RtsCts => {}
            FlowControl::XonXoff => {
                if byte == self.cfg.xon_xoff.xoff || byte == self.cfg.xon_xoff.xon {
                    return true;
                }
            }
            FlowControl::AutoV24 => {
                if !self.inputs.dsr {
                    return true;
                }
            }
        }
        self.cfg.interface == Interface::Rs485 && self.in_flight
    }

    /// Every received character, whatever the state; `byte` is already masked.
    #[inline(never)]
    fn on_byte_general(&mut self, now: Instant, gap: Instant, byte: u8) {
        self.byte_general(now, gap, byte);
        self.settle_wait();
    }

    fn byte_general(&mut self, now: Instant, gap: Instant, byte: u8) {
        if self.cfg.flow_control == FlowControl::XonXoff {
            if byte == self.cfg.xon_xoff.xoff {
                self.partner_stopped = true;
                self.hold(now);
                return;
            }
            if byte == self.cfg.xon_xoff.xon {
                self.partner_stopped = false;
                self.resume(now);
                return;
            }
        }
        if self.echo.as_mut().is_some_and(|e| e.drops(now, byte)) {
            return; // half duplex: our own echo
        }
        if self.cfg.flow_control == FlowControl::AutoV24 && !self.inputs.dsr {
            return; // [ET200S SI] §2.8: nothing is received while DSR = OFF
        }
        self.rx_deadline = Some(gap);
        match self.rx {
            Rx::Skipping => {
                if self.cutter.ends_text(byte) {
                    self.rx = Rx::Idle;
                    self.rx_deadline = None;
                    self.pump(now);
                }
                return;
            }
            Rx::Idle => {
                self.cutter.reset();
                self.rx = Rx::Receiving;
            }
            Rx::Receiving => {}
        }
        let cut = self.cutter.push(byte);
        self.frame_byte_inner(now, byte, cut);
    }

    /// A character of the frame in progress, already counted by the cutter as `cut`.
    fn frame_byte(&mut self, now: Instant, byte: u8, cut: Cut) {
        self.frame_byte_inner(now, byte, cut);
        self.settle_wait();
    }

    fn frame_byte_inner(&mut self, now: Instant, byte: u8, cut: Cut) {
        if cut == Cut::TooLong {
            self.skip_rest(Some(byte));
            self.rx_fail(now, status::FRAME_TOO_LONG);
            return;
        }
        if !self.store(now, byte) {
            return;
        }
        if cut == Cut::Complete {
            self.rx_deadline = None;
            self.complete_frame(now);
        }
    }

    /// Put a received byte into the buffer, making room or losing the frame when full.
    fn store(&mut self, now: Instant, byte: u8) -> bool {
        if self.buffer.push(byte) || self.store_when_full(now, byte) {
            self.check_stop();
            return true;
        }
        false
    }

    /// [`Link::store`] when the buffer has no room for `byte`: drop the oldest frames if
    /// overwriting is allowed, else lose the frame in progress. True when `byte` was stored
    /// after all.
    #[cold]
    fn store_when_full(&mut self, now: Instant, byte: u8) -> bool {
        let stored = self.make_room(now, byte);
        self.settle_wait();
        stored
    }

    fn make_room(&mut self, now: Instant, byte: u8) -> bool {
        if self.cfg.dynamic_frames && !self.cfg.prevent_overwrite {
            while self.buffer.free() == 0 && self.buffer.drop_oldest().is_some() {
                self.rx_fail(now, status::NO_FREE_RECEIVE_BUFFER);
            }
        }
        if !self.buffer.push(byte) {
            let code = if self.stop_sent {
                status::RECEIVED_AFTER_XOFF
            } else {
                status::NO_FREE_RECEIVE_BUFFER
            };
            self.skip_rest(Some(byte));
            self.rx_fail(now, code);
            return false;
        }
        true
    }

    fn complete_frame(&mut self, now: Instant) {
        self.rx = Rx::Idle;
        if !self.cfg.dynamic_frames && self.buffer.frames() >= 1 {
            if self.cfg.prevent_overwrite {
                self.buffer.discard_pending();
                self.rx_fail(now, status::NO_FREE_RECEIVE_BUFFER);
                self.pump(now);
                return;
            }
            self.buffer.drop_oldest();
        }
        let len = self.buffer.pending_len();
        self.buffer.commit();
        self.out
            .push_back(Output::Event(Event::Received { len, at: now }));
        self.check_stop();
        self.pump(now);
    }

    // ------------------------------------------------------------------ signals

    /// The V.24 signals: our outputs DTR and RTS, the partner's DSR, CTS and DCD as last
    /// reported (S_VSTAT, [ET200S SI] §2.10, Table 2-18; always possible).
    pub fn signals(&self) -> ModemSignals {
        ModemSignals {
            dtr: self.dtr,
            rts: self.rts,
            ..self.inputs
        }
    }

    /// Set DTR and/or RTS by job (S_VSET, [ET200S SI] §2.10, Table 2-19). Refused with 0502H on
    /// RS-422/485, under automatic V.24 operation, and for RTS under RTS/CTS flow control
    /// ([ET200S SI] §2.8).
    pub fn set_signals(&mut self, update: SignalUpdate) -> Result<(), Refused> {
        let refused = self.cfg.interface != Interface::Rs232
            || self.cfg.flow_control == FlowControl::AutoV24
            || (self.cfg.flow_control == FlowControl::RtsCts && update.rts.is_some());
        if refused {
            return Err(Refused::new(status::NOT_POSSIBLE_IN_MODE));
        }
        if let Some(dtr) = update.dtr {
            self.dtr = dtr;
        }
        if let Some(rts) = update.rts {
            self.rts = rts;
        }
        if update.dtr.is_some() || update.rts.is_some() {
            self.out.push_back(Output::SetSignals(update));
        }
        Ok(())
    }

    /// New XON/XOFF parameters (S_XON, Table 2-26 block 20H); 0550H unless XON/XOFF is the
    /// configured flow control, 1E20H when out of range.
    pub fn set_xon_xoff(&mut self, params: XonXoff) -> Result<(), Refused> {
        self.update(FlowControl::XonXoff, |c| c.xon_xoff = params)
    }

    /// New RTS/CTS parameters (S_RTS, block 21H).
    pub fn set_rts_cts(&mut self, params: RtsCts) -> Result<(), Refused> {
        self.update(FlowControl::RtsCts, |c| c.rts_cts = params)
    }

    /// New automatic V.24 parameters (S_V24, block 22H).
    pub fn set_auto_v24(&mut self, params: AutoV24) -> Result<(), Refused> {
        self.update(FlowControl::AutoV24, |c| c.auto_v24 = params)?;
        if let Some(v24) = self.v24.as_mut() {
            v24.set_times(params);
        }
        Ok(())
    }

    /// Apply a Table 2-26 parameter block as job code 5 carries it ([ET200S SI] §2.12,
    /// Table 2-26), its counts of 10 ms
    /// converted by si-core's one conversion: 0550H when it does not match the configured flow
    /// control, 1E20H when a value is out of range.
    pub fn apply_param_block(&mut self, block: ParamBlock) -> Result<(), Refused> {
        match block {
            ParamBlock::XonXoff {
                xon,
                xoff,
                xon_wait,
            } => self.set_xon_xoff(XonXoff {
                xon,
                xoff,
                wait_for_xon: ten_ms_time(xon_wait),
            }),
            ParamBlock::RtsCts { cts_wait } => self.set_rts_cts(RtsCts {
                wait_for_cts: ten_ms_time(cts_wait),
            }),
            ParamBlock::AutoV24 {
                rts_off_delay,
                cts_wait,
            } => self.set_auto_v24(AutoV24 {
                time_rts_off: ten_ms_time(rts_off_delay),
                data_wait_time: ten_ms_time(cts_wait),
            }),
        }
    }

    fn update(&mut self, needs: FlowControl, f: impl FnOnce(&mut Config)) -> Result<(), Refused> {
        if self.cfg.flow_control != needs {
            return Err(Refused::new(status::FLOW_PARAMETERS_MISMATCH));
        }
        let mut cfg = self.cfg;
        f(&mut cfg);
        cfg.validate()?;
        self.cfg = cfg;
        Ok(())
    }

    /// When the gap after a character completing at `now` exceeds the CDT: the next character
    /// must complete within CDT + one character time; one microsecond (the clock's resolution)
    /// later the gap is longer than the CDT.
    #[inline]
    fn gap_deadline(&self, now: Instant) -> Instant {
        now + self.gap
    }

    /// A read of `n` bytes at `now`: what it proves about the port's hold ([`Delivery::observe`]).
    #[inline]
    fn observe_read(&mut self, now: Instant, n: usize) {
        if self.delivery.observe(now, n) {
            self.delivery_changed();
        }
    }

    /// The port's delivery changed: the character delay monitoring gets its allowance. With
    /// end characters or a fixed length the frame's own content ends it, and the character
    /// delay time only catches a partner that stopped: there it waits out the longest latency
    /// an adapter can have ([`Delivery::longest_patience`]), so host scheduling on top of the adapter's
    /// holes never cuts a frame. In character-delay mode the silence *is* the frame end, so it
    /// gets only the port's [`Delivery::allowance`], to stay responsive.
    #[cold]
    fn delivery_changed(&mut self) {
        let allowance = match self.cfg.end {
            EndCriterion::CharDelay => self.delivery.allowance(),
            EndCriterion::EndChars { .. } | EndCriterion::FixedLength { .. } => {
                self.delivery.longest_patience()
            }
        };
        self.gap = self.cfg.settings.gap_limit(self.cdt) + allowance;
    }

    /// The receive deadline in force: none while we hold the partner in the middle of a frame
    /// (XOFF sent / RTS = OFF), since it is then *supposed* to pause.
    #[inline]
    fn rx_monitoring(&self) -> Option<Instant> {
        if self.stop_sent && self.rx == Rx::Receiving {
            None
        } else {
            self.rx_deadline
        }
    }

    fn pop_output(&mut self) -> Output<Event> {
        match self.out.pop_front() {
            Some(output) => output,
            None => Output::Wait(self.next_deadline()),
        }
    }

    /// See `rx_deadline_only`.
    #[inline]
    fn settle_wait(&mut self) {
        self.rx_deadline_only = !self.stop_sent && matches!(self.tx, Tx::Idle);
    }

    /// The earliest deadline in force, receive or transmit.
    #[inline]
    fn next_deadline(&self) -> Option<Instant> {
        if self.rx_deadline_only {
            debug_assert_eq!(self.rx_deadline, self.any_deadline());
            return self.rx_deadline;
        }
        self.any_deadline()
    }

    fn any_deadline(&self) -> Option<Instant> {
        let rx = self.rx_monitoring();
        if matches!(self.tx, Tx::Idle) {
            return rx;
        }
        // `Instant::earliest`, spelled out so it inlines into the caller's crate.
        match (rx, self.tx_deadline()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, None) => a,
            (None, b) => b,
        }
    }

    fn tx_deadline(&self) -> Option<Instant> {
        match &self.tx {
            Tx::Idle => None,
            Tx::Waiting { not_before, .. } => {
                (!self.rx_busy() || self.cfg.interface != Interface::Rs485).then_some(*not_before)
            }
            Tx::WaitCts { .. } | Tx::RtsOff { .. } => self.v24.as_ref().and_then(|v| v.deadline()),
            Tx::Sending { hold_until, .. } => *hold_until,
        }
    }
}

impl Engine for Link {
    type Event = Event;

    /// Inline, so a driver feeding single bytes pays no call for the common case.
    #[inline(always)]
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.observe_read(now, bytes.len());
        let gap = self.gap_deadline(now);
        for &b in bytes {
            self.on_byte(now, gap, b);
        }
    }

    fn set_rx_latency(&mut self, latency: Duration) {
        self.delivery.declare(latency);
        self.delivery_changed();
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.on_timeout(now);
        self.settle_wait();
    }

    fn handle_tx_done(&mut self, now: Instant) {
        self.on_tx_done(now);
        self.settle_wait();
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.on_line_error(now, error);
        self.settle_wait();
    }

    fn handle_signals(&mut self, now: Instant, signals: ModemSignals) {
        self.on_signals(now, signals);
        self.settle_wait();
    }

    /// Inline: polled after every input, mostly to hear `Wait` again.
    #[inline]
    fn poll_output(&mut self) -> Output<Event> {
        if self.out.is_empty() {
            return Output::Wait(self.next_deadline());
        }
        self.pop_output()
    }
}

/// The inputs other than received characters; each [`Engine`] method runs one, then
/// [`Link::settle_wait`].
impl Link {
    fn on_timeout(&mut self, now: Instant) {
        if self.rx_monitoring().is_some_and(|d| now >= d) {
            self.rx_deadline = None;
            match self.rx {
                Rx::Receiving if self.cfg.end == EndCriterion::CharDelay => {
                    self.complete_frame(now)
                }
                Rx::Receiving => {
                    // [ET200S SI] §2.8: the CDT ran out before the end criterion; fragment
                    // discarded.
                    self.buffer.discard_pending();
                    self.rx = Rx::Idle;
                    self.rx_fail(now, status::CHAR_DELAY_EXCEEDED);
                }
                Rx::Skipping | Rx::Idle => self.rx = Rx::Idle,
            }
        }
        match self.tx {
            Tx::WaitCts { job, .. } | Tx::RtsOff { job } => {
                match self.v24_step(|v, out| v.on_timeout(now, out)) {
                    Step::Abort => self.fail_send(now, job, status::DSR_CTS_OFF),
                    Step::Done => self.finish_send(now, job),
                    Step::Send | Step::Nothing => {}
                }
            }
            Tx::Sending {
                job,
                hold_until: Some(until),
                ..
            } if now >= until => self.fail_send(now, job, status::XON_CTS_TIMEOUT),
            _ => {}
        }
        self.pump(now);
    }

    fn on_tx_done(&mut self, now: Instant) {
        if !self.in_flight {
            return;
        }
        self.in_flight = false;
        if let Some(echo) = self.echo.as_mut() {
            echo.transmitted();
        }
        if let Tx::Sending {
            job, frame, pos, ..
        } = &self.tx
        {
            if *pos >= frame.len() {
                let job = *job;
                self.last_tx_end = Some(now);
                if self.v24.is_some() {
                    // [ET200S SI] §2.8: RTS = OFF after the RTS-off time, and only then is the job
                    // done.
                    self.tx = Tx::RtsOff { job };
                    if self.v24_step(|v, out| v.sent(now, out)) == Step::Done {
                        self.finish_send(now, job);
                    }
                } else {
                    self.finish_send(now, job);
                }
            }
        }
        self.pump(now);
    }

    fn on_line_error(&mut self, now: Instant, error: LineError) {
        if self.echo.as_mut().is_some_and(EchoFilter::drops_line_error) {
            return; // our own transmission
        }
        let code = match error {
            LineError::Parity => status::PARITY_ERROR,
            LineError::Framing => status::FRAMING_ERROR,
            LineError::Overrun => status::TRANSMISSION_ERROR,
            LineError::Break => status::BREAK,
        };
        self.skip_rest(None);
        self.rx_deadline = Some(self.gap_deadline(now));
        self.rx_fail(now, code);
    }

    fn on_signals(&mut self, now: Instant, signals: ModemSignals) {
        self.inputs = ModemSignals {
            dtr: self.dtr,
            rts: self.rts,
            ..signals
        };
        match self.cfg.flow_control {
            FlowControl::RtsCts => {
                if signals.cts {
                    self.resume(now);
                } else {
                    self.hold(now);
                }
            }
            FlowControl::AutoV24 => {
                let mut dsr_dropped = false;
                let step = self.v24_step(|v, out| {
                    let (step, dropped) = v.on_signals(signals, out);
                    dsr_dropped = dropped;
                    step
                });
                match (step, &self.tx) {
                    (
                        Step::Abort,
                        Tx::WaitCts { job, .. } | Tx::Sending { job, .. } | Tx::RtsOff { job },
                    ) => self.fail_send(now, *job, status::DSR_CTS_OFF),
                    (Step::Send, Tx::WaitCts { .. }) => {
                        let Tx::WaitCts { job, frame } = std::mem::replace(&mut self.tx, Tx::Idle)
                        else {
                            return;
                        };
                        self.tx = Tx::Sending {
                            job,
                            frame,
                            pos: 0,
                            hold_until: None,
                        };
                        self.pump(now);
                    }
                    _ => {}
                }
                if dsr_dropped && self.rx == Rx::Receiving {
                    // [ET200S SI] §2.8: DSR ON → OFF aborts a reception too.
                    self.skip_rest(None);
                    self.rx = Rx::Idle;
                    self.rx_deadline = None;
                    self.rx_fail(now, status::DSR_CTS_OFF);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    //! The inline receive path ([`Link::on_byte`]) is a shortcut of the general one
    //! ([`Link::on_byte_general`]) and must never behave differently: two links, one fed
    //! through each, see the same inputs and must give the same outputs and state. The first
    //! also reads with [`Link::read_frame_bytes`], the second with [`Link::read_frame_vec`].

    use super::*;
    use proptest::prelude::*;
    use si_core::{Parity, SerialSettings};

    /// Received characters go through the general path only.
    fn rx_general(link: &mut Link, now: Instant, bytes: &[u8]) {
        link.observe_read(now, bytes.len());
        let gap = link.gap_deadline(now);
        for &b in bytes {
            let b = b & link.mask;
            link.on_byte_general(now, gap, b);
        }
    }

    #[derive(Debug, Clone)]
    enum Op {
        Rx(Vec<u8>),
        Timeout,
        TxDone,
        LineError(u8),
        Signals(u8),
        Send(Vec<u8>),
        Read,
        Restart,
    }

    /// Characters that mean something to some configuration (XON, XOFF, end characters),
    /// often, and any other.
    fn byte() -> impl Strategy<Value = u8> {
        prop_oneof![
            3 => prop::sample::select(vec![0x11u8, 0x13, b'\r', b'\n', 0x03, 0x93]),
            5 => any::<u8>(),
        ]
    }

    fn op() -> impl Strategy<Value = (u64, Op)> {
        let op = prop_oneof![
            8 => prop::collection::vec(byte(), 1..64).prop_map(Op::Rx),
            4 => prop::collection::vec(byte(), 1..3).prop_map(Op::Rx),
            2 => Just(Op::Timeout),
            2 => Just(Op::TxDone),
            1 => any::<u8>().prop_map(Op::LineError),
            1 => any::<u8>().prop_map(Op::Signals),
            1 => prop::collection::vec(b'a'..=b'z', 1..40).prop_map(Op::Send),
            2 => Just(Op::Read),
            1 => Just(Op::Restart),
        ];
        // Same instant, within the character delay time, or well past it.
        (prop_oneof![Just(0u64), 0u64..5_000, 0u64..100_000], op)
    }

    fn config() -> impl Strategy<Value = Config> {
        (
            0usize..4,
            0usize..3,
            0usize..4,
            any::<(bool, bool, bool)>(),
            1u16..=200,
            prop::bool::ANY,
            // Every module preset's maximum frame length (200, 224, 1024 bytes).
            prop::sample::select(si_core::ModulePreset::ALL.to_vec()),
        )
            .prop_map(
                |(flow, iface, end, (dynamic, prevent, clear), n, seven, module)| {
                    let settings = if seven {
                        SerialSettings::new(9600, 7, Parity::Even, 1).unwrap()
                    } else {
                        SerialSettings::default()
                    };
                    Config {
                        settings,
                        flow_control: [
                            FlowControl::None,
                            FlowControl::XonXoff,
                            FlowControl::RtsCts,
                            FlowControl::AutoV24,
                        ][flow],
                        interface: [Interface::Rs232, Interface::Rs422, Interface::Rs485][iface],
                        end: [
                            EndCriterion::CharDelay,
                            EndCriterion::EndChars {
                                first: b'\r',
                                second: b'\n',
                            },
                            EndCriterion::DEFAULT_END_CHARS,
                            EndCriterion::FixedLength { len: n },
                        ][end],
                        dynamic_frames: dynamic,
                        prevent_overwrite: prevent,
                        clear_at_startup: clear,
                        tx_chunk: 1,
                        ..Config::for_module(module)
                    }
                },
            )
    }

    fn drain(link: &mut Link) -> Vec<Output<Event>> {
        let mut outputs = Vec::new();
        loop {
            let output = link.poll_output();
            let done = matches!(output, Output::Wait(_));
            outputs.push(output);
            if done {
                return outputs;
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        #[test]
        fn the_inline_receive_path_behaves_as_the_general_one(
            config in config(),
            ops in prop::collection::vec(op(), 1..150),
        ) {
            let Ok(mut fast) = Link::new(config) else { return Ok(()) };
            let mut general = Link::new(config).unwrap();
            let mut now = Instant::ZERO;
            prop_assert_eq!(drain(&mut fast), drain(&mut general));
            for (dt, op) in ops {
                now += Duration::from_micros(dt);
                let mut read = [None, None];
                for (link, inline) in [(&mut fast, true), (&mut general, false)] {
                    match &op {
                        Op::Rx(bytes) if inline => link.handle_rx(now, bytes),
                        Op::Rx(bytes) => rx_general(link, now, bytes),
                        Op::Timeout => link.handle_timeout(now),
                        Op::TxDone => link.handle_tx_done(now),
                        Op::LineError(k) => link.handle_line_error(now, [
                            LineError::Parity, LineError::Framing, LineError::Overrun,
                            LineError::Break,
                        ][usize::from(k % 4)]),
                        Op::Signals(s) => link.handle_signals(now, ModemSignals {
                            dsr: s & 1 != 0,
                            cts: s & 2 != 0,
                            ..ModemSignals::default()
                        }),
                        Op::Send(frame) => {
                            let _ = link.send(now, Bytes::copy_from_slice(frame));
                        }
                        // The pooled read gives the same frames as the plain one.
                        Op::Read if inline => {
                            read[0] = link.read_frame_bytes(now).map(|f| f.to_vec());
                        }
                        Op::Read => read[1] = link.read_frame_vec(now),
                        Op::Restart => link.restart(now),
                    }
                }
                prop_assert_eq!(&read[0], &read[1]);
                prop_assert_eq!(drain(&mut fast), drain(&mut general), "after {:?}", op);
                prop_assert_eq!(fast.buffer().fill(), general.buffer().fill());
                prop_assert_eq!(fast.frames_waiting(), general.frames_waiting());
                prop_assert_eq!(fast.signals(), general.signals());
                prop_assert_eq!(fast.take_receive_error(), general.take_receive_error());
            }
        }
    }
}
