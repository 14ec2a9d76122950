//! Frame detection by silence ([Modbus/USS] §3.3.5, §3.4.3, §3.5.4, Table 3-11), and by
//! predicted length as a host extension ([`FrameEnd::Length`]).
//!
//! A Modbus RTU receiver of the module does not predict frame lengths: a frame ends when the
//! line has been silent for the gap tZVZ = tZVZ_TAB × fMUL ([`LineConfig::gap`]). The engines
//! then check the frame (CRC, address, lengths). Garbage and short frames are discarded and
//! counted, and the receiver is in step again at the next gap. A gap inside a frame ends it
//! early: both pieces fail their checks and are counted.
//!
//! The gap is measured the way a UART lets a receiver measure it: from the moment one
//! character has been received to the moment the next one has (its end), as the module's
//! character delay time tZVZ is defined "between two characters" ([Modbus/USS] §3.6, 0806H). The
//! silence on the wire is therefore one character time shorter than the time measured.
//!
//! Operating mode ([Modbus/USS] §3.4.3, §3.5.4): in **Normal** mode a frame carrying a UART error
//! or BREAK is handed up as faulty so the engine reports it. In **interference suppression** mode
//! such frames are dropped silently, leading bytes before a correctly received slave address are
//! skipped, and errors after a complete frame (valid CRC) are ignored.
//!
//! Interface ([Modbus/USS] §3.4.1, §3.4.3): on **RS-485** the start of a message is recognised by a
//! correctly received slave address in either mode, so leading bytes before it (a turnaround glitch
//! as the bus changes direction) are skipped, and a UART error or BREAK before the message starts
//! is ignored, as interference suppression does. On RS-232C and RS-422 Normal mode hands them up,
//! and the master reports 0831H. (Reading chosen: [Modbus/USS] §3.4.1, §3.4.3 also says RS-485
//! ignores "all detected transmission errors"; we apply that to errors before a message only, so a
//! character error inside a response is still reported in Normal mode as [Modbus/USS] §3.4.3,
//! §3.5.4 describes.)
//!
//! # Behind a port that delivers in packets (a USB adapter)
//!
//! A USB-serial adapter hands bytes over in packets up to its latency timer late (16 ms by
//! default), so the holes between packets of one frame are far longer than the gap. The
//! receiver keeps a [`Delivery`]: the engines tell it each read's size and the latency the
//! driver declared ([`Engine::set_rx_latency`](si_core::Engine::set_rx_latency)). Once the port
//! is known to packetise, the gap gets the port's allowance added (the gap measured on the
//! host is the wire's gap plus the adapter's hold), and frames also end by their predicted
//! length as with [`FrameEnd::Length`], as pymodbus and libmodbus do on such ports: without it
//! every response would wait gap + latency before the master saw it. On a port that delivers
//! byte by byte the allowance is zero and the configured [`FrameEnd`] holds: the manual's timing
//! exactly.
//!
//! # Ending a frame at its predicted length (host extension)
//!
//! With [`FrameEnd::Length`] (not in the manual; see there for why a host wants it) a frame
//! also ends the moment it holds as many bytes as its header predicts **and** the CRC over
//! them checks ([`Expect`], [`request_len`], [`response_len`]). Bytes after that start a new
//! frame. Everything else (a function code without a prediction, a wrong CRC at the predicted
//! length, a UART error in the frame, garbage) ends at the gap exactly as with
//! [`FrameEnd::Gap`], so the engines see the same frames and report the same STATUS. Echo
//! bytes are dropped first and, in interference suppression mode, leading bytes before the
//! address are skipped first; the prediction starts at the address byte.

use crate::config::{FrameEnd, LineConfig, Mode};
use crate::frame::{crc_ok, fc, Adu, MAX_ADU};
use si_core::delivery::Delivery;
use si_core::echo::EchoFilter;
use si_core::{Duration, Instant, Interface, LineError};

/// What kind of frame the engine expects next, for [`FrameEnd::Length`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expect {
    /// No prediction: the frame ends at the gap (an idle master).
    Nothing,
    /// A request (the slave): its length follows from its function code ([`request_len`]).
    Request,
    /// The response to a request with this function code (a master with a job):
    /// [`response_len`].
    ResponseTo(u8),
}

/// The length (CRC included) of the request that starts with `head`, as far as `head` tells.
///
/// The request layouts of [Modbus/USS] §3.4.5–§3.4.16, §3.5.6–§3.5.14 (Modbus application protocol
/// for FC07, FC11, FC12): FC01–06 and FC08 are 8 bytes (address, function, two 16-bit
/// fields, CRC); FC07, 11, 12 are 4 (address, function, CRC); FC15 and FC16 are 9 + the byte
/// count at offset 6. Any other function code has no prediction.
pub fn request_len(head: &[u8]) -> Prediction {
    let Some(&f) = head.get(1) else {
        return Prediction::NeedMore(2);
    };
    match f {
        fc::READ_COILS..=fc::WRITE_SINGLE_REGISTER | fc::DIAGNOSTICS => Prediction::Len(8),
        fc::READ_EXCEPTION_STATUS | fc::GET_COMM_EVENT_COUNTER | fc::GET_COMM_EVENT_LOG => {
            Prediction::Len(4)
        }
        fc::WRITE_MULTIPLE_COILS | fc::WRITE_MULTIPLE_REGISTERS => match head.get(6) {
            Some(&count) => Prediction::Len(9 + count as usize),
            None => Prediction::NeedMore(7),
        },
        _ => Prediction::Unknown,
    }
}

/// The length (CRC included) of the response to a request with function code `request_fc`
/// that starts with `head`, as far as `head` tells.
///
/// The response layouts of [Modbus/USS] §3.4.5–§3.4.16 (and the Modbus application protocol for
/// FC07, 11, 12): FC01–04 are 5 + the byte count at offset 2; FC05, 06, 08, 15, 16 echo 4 bytes (8
/// in all); FC07 is 5; FC11 is 8; FC12 is 5 + its byte count; an exception (function | 80H,
/// [Modbus/USS] §3.3.6, Table 3-12) is 5. A function code that is neither the request's nor its
/// exception has no prediction: the frame ends at the gap and the master reports it (0E51H) as the
/// module would.
pub fn response_len(request_fc: u8, head: &[u8]) -> Prediction {
    let Some(&f) = head.get(1) else {
        return Prediction::NeedMore(2);
    };
    if f == request_fc | 0x80 {
        return Prediction::Len(5);
    }
    if f != request_fc {
        return Prediction::Unknown;
    }
    let counted = || match head.get(2) {
        Some(&count) => Prediction::Len(5 + count as usize),
        None => Prediction::NeedMore(3),
    };
    match f {
        fc::READ_COILS..=fc::READ_INPUT_REGISTERS | fc::GET_COMM_EVENT_LOG => counted(),
        fc::WRITE_SINGLE_COIL
        | fc::WRITE_SINGLE_REGISTER
        | fc::DIAGNOSTICS
        | fc::WRITE_MULTIPLE_COILS
        | fc::WRITE_MULTIPLE_REGISTERS
        | fc::GET_COMM_EVENT_COUNTER => Prediction::Len(8),
        fc::READ_EXCEPTION_STATUS => Prediction::Len(5),
        _ => Prediction::Unknown,
    }
}

/// What the header received so far says about a frame's length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prediction {
    /// Look again when the frame holds this many bytes.
    NeedMore(usize),
    /// The whole frame, CRC included, is this many bytes.
    Len(usize),
    /// No prediction: the gap ends the frame.
    Unknown,
}

/// Receive statistics, for diagnostics and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames of at least 4 bytes handed to the engine.
    pub frames: u64,
    /// Frames discarded: too short here, or refused by the engine (CRC, garbage, unsolicited).
    pub discarded: u64,
    /// Bytes skipped before a slave address (interference suppression).
    pub skipped_bytes: u64,
    /// Parity, framing, overrun errors and BREAKs seen.
    pub line_errors: u64,
    /// Frames longer than [`MAX_ADU`].
    pub overflows: u64,
    /// Frames dropped silently in interference suppression mode.
    pub suppressed: u64,
}

/// Why a frame cannot be used as it stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// A UART error or BREAK during the frame (or between frames, with no bytes).
    Line(LineError),
    /// More than [`MAX_ADU`] bytes before the gap.
    Overflow,
}

/// A frame ended by silence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Received {
    /// The bytes (the first [`MAX_ADU`] on overflow).
    pub adu: Adu,
    /// Set if the frame is faulty (Normal mode only; suppression mode drops such frames).
    pub fault: Option<Fault>,
    /// The receiver has already found the CRC over `adu` good (a frame ended by its length,
    /// or one whose start was searched for by its CRC), so the engine need not compute it
    /// again; `false` says only that it was not checked here.
    pub crc_good: bool,
}

/// A frame that ended, left in the receiver's buffer ([`Receiver::poll_in_place`]): what
/// [`Received`] says, with the bytes read by [`Receiver::frame`] instead of carried.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct FrameAt {
    start: usize,
    len: usize,
    /// As [`Received::fault`].
    pub(crate) fault: Option<Fault>,
    /// As [`Received::crc_good`].
    pub(crate) crc_good: bool,
}

impl FrameAt {
    /// No bytes (a line error between frames).
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// The frame assembler the master and slave share: silence ends a frame, and with
/// [`FrameEnd::Length`] also a complete frame with a good CRC.
#[derive(Debug, Clone)]
pub struct Receiver {
    buf: [u8; MAX_ADU],
    len: usize,
    /// Time of the last character or error of the frame being received.
    last: Option<Instant>,
    /// Time of the last character or error received at all (frames ended early included).
    last_activity: Option<Instant>,
    fault: Option<Fault>,
    gap: Duration,
    mode: Mode,
    frame_end: FrameEnd,
    /// The frame being received is complete by length: [`poll`](Self::poll) hands it up now.
    complete: bool,
    /// The frame reached its predicted length with a wrong CRC: only the gap ends it now.
    unpredictable: bool,
    /// A line that echoes our transmission: as many received bytes as we sent are dropped
    /// (si-core's one echo filter, count mode).
    echo: EchoFilter,
    counters: Counters,
    /// How late the port hands bytes over; its allowance lengthens the gap.
    delivery: Delivery,
    /// RS-485 recognises a message by its address ([Modbus/USS] §3.4.1, §3.4.3).
    interface: Interface,
    /// The frame's header predicts more bytes than it holds: on a packetising port (or with
    /// `patient`) a hole is then waited out ([`effective_gap`](Self::effective_gap)).
    more_predicted: bool,
    /// Wait for predicted bytes on every port ([`set_patient`](Self::set_patient)).
    patient: bool,
}

impl Receiver {
    /// A receiver for this line, ending frames at the gap ([`FrameEnd::Gap`]).
    pub fn new(line: &LineConfig) -> Self {
        Receiver {
            buf: [0; MAX_ADU],
            len: 0,
            last: None,
            last_activity: None,
            fault: None,
            gap: line.gap(),
            mode: line.mode,
            frame_end: FrameEnd::Gap,
            complete: false,
            unpredictable: false,
            echo: EchoFilter::counting(),
            counters: Counters::default(),
            delivery: Delivery::new(&line.settings),
            interface: Interface::Rs232,
            more_predicted: false,
            patient: false,
        }
    }

    /// Wait out a hole in a frame whose header predicts more bytes on any port, not only on
    /// one that packetises: a master with [`FrameEnd::Length`] (host extension). `[derived]`:
    /// what pauses inside a response on a port that delivers byte by byte is the slave itself
    /// (a slow slave that pauses between characters) or something between it and us (a
    /// device server, a relay, a converter that stalls), and the response's own length says
    /// it is not over. Libmodbus and mbusd likewise end a known response by its length and
    /// wait for late bytes with a timeout of their own. The wait is at most
    /// [`Delivery::assumed_patience`] per hole (64 ms and a character), and a response as a
    /// whole still ends by [`MasterConfig::max_response_duration`](crate::MasterConfig::max_response_duration),
    /// which allows one port margin (255 ms and a character) beyond its wire time and gap.
    /// A slave keeps the gap: on a bus a fragment waited for could swallow the next request.
    pub fn set_patient(&mut self, patient: bool) {
        self.patient = patient;
    }

    /// The driver declared the port's delivery latency ([`si_core::Engine::set_rx_latency`]).
    pub fn set_rx_latency(&mut self, latency: Duration) {
        self.delivery.declare(latency);
    }

    /// The engine got `n` bytes in one read at `now` ([`Delivery::observe`]).
    pub fn observe_read(&mut self, now: Instant, n: usize) {
        self.delivery.observe(now, n);
    }

    /// What the receiver knows about the port's delivery.
    pub fn delivery(&self) -> &Delivery {
        &self.delivery
    }

    /// The silence that ends a frame as measured on this port: the gap plus the port's
    /// allowance (zero on a byte-by-byte port). While the frame's header predicts more bytes
    /// on a packetising port, the allowance is the longest a port can hold bytes
    /// ([`Delivery::patience`]): the learnt latency is only a lower bound, and the host's own
    /// scheduling adds to it, so only a frame that cannot end by its length is judged by the
    /// tighter allowance.
    pub fn effective_gap(&self) -> Duration {
        let allowance = if self.more_predicted && self.patient {
            self.delivery
                .patience()
                .max(self.delivery.assumed_patience())
        } else if self.more_predicted {
            self.delivery.patience()
        } else {
            self.delivery.allowance()
        };
        self.gap + allowance
    }

    /// Frames end by length too: [`FrameEnd::Length`] was chosen, or the port packetises.
    fn ends_by_length(&self) -> bool {
        self.frame_end == FrameEnd::Length || self.delivery.packetises()
    }

    /// The physical interface ([Modbus/USS] §3.4.1, §3.4.3): on RS-485 leading garbage is skipped
    /// in every mode.
    pub fn set_interface(&mut self, interface: Interface) {
        self.interface = interface;
    }

    /// The physical interface.
    pub fn interface(&self) -> Interface {
        self.interface
    }

    /// A message starts at a correctly received address: interference suppression ([Modbus/USS]
    /// §3.4.3, §3.5.4), or any mode on RS-485 ([Modbus/USS] §3.4.1, §3.4.3).
    fn starts_at_address(&self) -> bool {
        self.mode == Mode::InterferenceSuppression || self.interface == Interface::Rs485
    }

    /// End frames this way from now on.
    pub fn set_frame_end(&mut self, frame_end: FrameEnd) {
        self.frame_end = frame_end;
    }

    /// How frames end.
    pub fn frame_end(&self) -> FrameEnd {
        self.frame_end
    }

    /// The end-of-frame gap in use.
    pub fn gap(&self) -> Duration {
        self.gap
    }

    /// Statistics so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// Count a frame the engine threw away after looking at it.
    pub fn count_discarded(&mut self) {
        self.counters.discarded += 1;
    }

    /// We transmitted `n` bytes on a line that echoes them: drop the next `n` received bytes.
    pub fn expect_echo(&mut self, n: usize) {
        // A lost echo must not eat the start of every later frame: each transmission's echo
        // replaces what was still expected of the one before (as the USS engines do).
        self.echo.stop();
        self.echo.sent_len(n);
    }

    /// True while a frame is being received (bytes or an error since the last gap).
    pub fn is_receiving(&self) -> bool {
        self.last.is_some()
    }

    /// When the current frame ends if nothing more arrives (at once if it is complete by
    /// length and not yet taken).
    pub fn deadline(&self) -> Option<Instant> {
        let last = self.last?;
        Some(if self.complete {
            last
        } else {
            last + self.effective_gap()
        })
    }

    /// End frames at `gap` instead of the line's Table 3-11 gap ([`crate::Master::with_gap`]).
    pub fn set_gap(&mut self, gap: Duration) {
        self.gap = gap;
    }

    /// When the last character (or line error) was received, in any frame-end mode.
    pub fn last_activity(&self) -> Option<Instant> {
        self.last_activity
    }

    /// With [`FrameEnd::Length`]: when the line will have been silent for the gap since the
    /// last character received, the earliest a master may start its next request ([Modbus/USS]
    /// §3.3.5, Table 3-11: frames are separated by silence). `None` with [`FrameEnd::Gap`], where
    /// every frame already ends at that moment.
    pub fn quiet_at(&self) -> Option<Instant> {
        if !self.ends_by_length() {
            return None;
        }
        self.last_activity.map(|t| t + self.gap)
    }

    /// The frame that ended by `now`: complete by length, or the gap has passed since its
    /// last character.
    pub fn poll(&mut self, now: Instant) -> Option<Received> {
        let at = self.poll_in_place(now)?;
        Some(Received {
            adu: Adu::from_slice(self.frame(&at)).unwrap_or_default(),
            fault: at.fault,
            crc_good: at.crc_good,
        })
    }

    /// [`poll`](Self::poll), the frame left where the receiver assembled it: the master reads
    /// it there ([`frame`](Self::frame)) before it pushes more bytes, so a response is not
    /// copied into an [`Adu`] (264 bytes zeroed and moved) only to be read once.
    pub(crate) fn poll_in_place(&mut self, now: Instant) -> Option<FrameAt> {
        let last = self.last?;
        if core::mem::take(&mut self.complete) {
            // Complete by length: no fault, at least 4 bytes, CRC checked in `push`.
            self.last = None;
            self.unpredictable = false;
            let len = core::mem::take(&mut self.len);
            self.counters.frames += 1;
            return Some(FrameAt {
                start: 0,
                len,
                fault: None,
                crc_good: true,
            });
        }
        if now < last + self.effective_gap() {
            return None;
        }
        self.last = None;
        self.more_predicted = false;
        self.unpredictable = false;
        let fault = self.fault.take();
        let len = core::mem::take(&mut self.len);
        let mut at = FrameAt {
            start: 0,
            len,
            fault,
            crc_good: false,
        };
        match (self.mode, fault) {
            (Mode::InterferenceSuppression, Some(_)) => {
                self.counters.suppressed += 1;
                return None;
            }
            (_, Some(_)) => return Some(at),
            _ => {}
        }
        if len < 4 {
            self.counters.discarded += 1;
            return None;
        }
        if self.starts_at_address() && !crc_ok(&self.buf[..len]) {
            // The start is a correctly received address: try the later ones. On RS-485 in
            // Normal mode too (`[derived]` from [Modbus/USS] §3.4.1, §3.4.3: a message starts at
            // a correctly received address): behind a port that hands bytes over late, a
            // fragment (noise, a frame for another unit cut at an address byte) can only be
            // judged over after the next frame has begun, and that frame is found here, whatever
            // address started the fragment (the engine checks the frame's address itself).
            let first = self.buf[0];
            let rs485 = self.interface == Interface::Rs485;
            let restart = (1..len.saturating_sub(3))
                .find(|&k| (self.buf[k] == first || rs485) && crc_ok(&self.buf[k..len]));
            if let Some(k) = restart {
                self.counters.skipped_bytes += k as u64;
                at.start = k;
                at.len = len - k;
                at.crc_good = true;
            }
        } else if self.starts_at_address() {
            at.crc_good = true;
        }
        self.counters.frames += 1;
        Some(at)
    }

    /// The bytes of a frame [`poll_in_place`](Self::poll_in_place) reported, valid until the
    /// next [`push`](Self::push).
    pub(crate) fn frame(&self, at: &FrameAt) -> &[u8] {
        self.buf
            .get(at.start..at.start + at.len)
            .unwrap_or_default()
    }

    /// Bytes from the line at `now`; returns how many of them it took. Call
    /// [`poll`](Self::poll) first: a gap before these bytes ends the previous frame. In
    /// interference suppression mode, bytes before the first one `is_start` accepts (the
    /// expected slave address) are skipped.
    ///
    /// With [`FrameEnd::Length`] and a prediction from `expect`, the bytes are taken only up
    /// to the end of a frame that is complete by length; [`poll`](Self::poll) then hands it
    /// up at once, and the engine pushes the rest (which starts a new frame). Otherwise every
    /// byte is taken.
    pub fn push(
        &mut self,
        now: Instant,
        bytes: &[u8],
        is_start: impl Fn(u8) -> bool,
        expect: Expect,
    ) -> usize {
        if self.complete {
            // The engine has not taken the finished frame yet: take nothing.
            return 0;
        }
        let total = bytes.len();
        let mut bytes = self.echo.filter(now, bytes);
        if bytes.is_empty() {
            return total;
        }
        self.last_activity = Some(now);
        if self.len == 0 && self.fault.is_none() && self.starts_at_address() {
            let start = bytes
                .iter()
                .position(|&b| is_start(b))
                .unwrap_or(bytes.len());
            self.counters.skipped_bytes += start as u64;
            bytes = &bytes[start..];
            if bytes.is_empty() {
                return total;
            }
        }
        self.last = Some(now);
        let mut taken = total - bytes.len();
        while !bytes.is_empty() {
            // At a frame's start the bytes at hand are its head: predicted from them at once, a
            // frame that came whole is taken in one step instead of one per header field (a
            // prediction reads fixed header positions, so more of the head gives the answer
            // the steps would reach).
            let head = if self.len == 0 {
                bytes
            } else {
                &self.buf[..self.len]
            };
            let prediction = self.prediction(expect, head);
            let n = match prediction {
                Prediction::NeedMore(k) | Prediction::Len(k) if k > self.len => {
                    (k - self.len).min(bytes.len())
                }
                _ => bytes.len(),
            };
            self.append(&bytes[..n]);
            bytes = &bytes[n..];
            taken += n;
            if let Prediction::Len(k) = prediction {
                if self.len == k {
                    if crc_ok(&self.buf[..k]) {
                        self.complete = true;
                        self.more_predicted = false;
                        return taken;
                    }
                    self.unpredictable = true;
                }
            }
        }
        self.more_predicted = (self.patient || self.delivery.packetises())
            && matches!(self.prediction(expect, &self.buf[..self.len]),
                Prediction::NeedMore(k) | Prediction::Len(k) if k > self.len);
        taken
    }

    /// What `head`, the frame's bytes so far (or, at its start, the bytes about to be taken),
    /// predicts with [`FrameEnd::Length`].
    fn prediction(&self, expect: Expect, head: &[u8]) -> Prediction {
        if !self.ends_by_length() || self.fault.is_some() || self.unpredictable {
            return Prediction::Unknown;
        }
        let p = match expect {
            Expect::Nothing => Prediction::Unknown,
            Expect::Request => request_len(head),
            Expect::ResponseTo(f) => response_len(f, head),
        };
        match p {
            // Past it already (a prediction that changed with the expectation), or beyond
            // what the buffer holds: the gap decides.
            Prediction::Len(k) if k < self.len || k > MAX_ADU => Prediction::Unknown,
            p => p,
        }
    }

    fn append(&mut self, bytes: &[u8]) {
        let room = MAX_ADU - self.len;
        let n = bytes.len().min(room);
        self.buf[self.len..self.len + n].copy_from_slice(&bytes[..n]);
        self.len += n;
        if n < bytes.len() && self.fault.is_none() {
            self.counters.overflows += 1;
            self.fault = Some(Fault::Overflow);
        }
    }

    /// Throw away the frame being received (DSR dropped under automatic V.24, [Modbus/USS] §3.2.2
    /// item 7): it never becomes a frame, and counts as discarded.
    pub fn discard(&mut self) {
        if self.last.take().is_some() {
            self.len = 0;
            self.fault = None;
            self.complete = false;
            self.unpredictable = false;
            self.more_predicted = false;
            self.counters.discarded += 1;
        }
    }

    /// A UART error or BREAK at `now`.
    pub fn line_error(&mut self, now: Instant, error: LineError) {
        self.counters.line_errors += 1;
        self.last_activity = Some(now);
        if self.mode == Mode::InterferenceSuppression
            && self.len >= 4
            && crc_ok(&self.buf[..self.len])
        {
            // [Modbus/USS] §3.4.3, §3.5.4: errors after the end of a message (after the CRC) are
            // ignored.
            return;
        }
        if self.complete {
            // After a frame complete by length: the error belongs to what follows it.
            return;
        }
        if self.interface == Interface::Rs485 && self.last.is_none() {
            // [Modbus/USS] §3.4.1, §3.4.3: before a message starts (a turnaround glitch, BREAK
            // between messages).
            return;
        }
        self.last = Some(now);
        self.more_predicted = false;
        if self.fault.is_none() {
            self.fault = Some(Fault::Line(error));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(us: u64) -> Instant {
        Instant::from_micros(us)
    }

    /// A receiver on a port declared byte by byte (as a driver that knows it does): the
    /// manual's timing exactly.
    fn exact(line: &LineConfig) -> Receiver {
        let mut rx = Receiver::new(line);
        rx.set_rx_latency(Duration::ZERO);
        rx
    }

    #[test]
    fn frame_ends_after_the_gap_not_before() {
        let mut rx = exact(&LineConfig::default());
        rx.push(
            at(0),
            &[1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD],
            |_| true,
            Expect::Nothing,
        );
        assert_eq!(rx.poll(at(3_999)), None);
        assert_eq!(rx.deadline(), Some(at(4_000)));
        let f = rx.poll(at(4_000)).unwrap();
        assert_eq!(f.adu.as_bytes(), &[1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD]);
        assert_eq!(rx.counters().frames, 1);
    }

    #[test]
    fn short_frames_are_counted_and_dropped() {
        let mut rx = exact(&LineConfig::default());
        rx.push(at(0), &[1, 2], |_| true, Expect::Nothing);
        assert_eq!(rx.poll(at(10_000)), None);
        assert_eq!(rx.counters().discarded, 1);
    }

    #[test]
    fn suppression_skips_leading_garbage_and_faulty_frames() {
        let line = LineConfig {
            mode: Mode::InterferenceSuppression,
            ..LineConfig::default()
        };
        let mut rx = exact(&line);
        rx.push(
            at(0),
            &[0x55, 0xAA, 1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD],
            |b| b == 1,
            Expect::Nothing,
        );
        let f = rx.poll(at(10_000)).unwrap();
        assert_eq!(f.adu.as_bytes()[0], 1);
        assert_eq!(rx.counters().skipped_bytes, 2);
        rx.line_error(at(20_000), LineError::Break);
        rx.push(
            at(20_100),
            &[1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD],
            |b| b == 1,
            Expect::Nothing,
        );
        assert_eq!(rx.poll(at(30_000)), None);
        assert_eq!(rx.counters().suppressed, 1);
    }

    #[test]
    fn overflow_is_a_fault() {
        let mut rx = exact(&LineConfig::default());
        rx.push(at(0), &[0u8; 300], |_| true, Expect::Nothing);
        assert_eq!(rx.poll(at(10_000)).unwrap().fault, Some(Fault::Overflow));
    }

    fn length_rx() -> Receiver {
        let mut rx = exact(&LineConfig::default());
        rx.set_frame_end(FrameEnd::Length);
        rx
    }

    /// Push `bytes` in chunks of `chunk` at `now`, polling after each push as the engines do;
    /// the frames handed up at once.
    fn feed(rx: &mut Receiver, now: Instant, bytes: &[u8], chunk: usize) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        for piece in bytes.chunks(chunk) {
            let mut rest = piece;
            while !rest.is_empty() {
                let n = rx.push(now, rest, |_| true, Expect::Request);
                rest = &rest[n..];
                if let Some(f) = rx.poll(now) {
                    out.push(f.adu.as_bytes().to_vec());
                }
            }
        }
        out
    }

    #[test]
    fn length_ends_a_request_at_its_predicted_length_however_it_is_chunked() {
        // FC16 (9 + byte count) then FC03 (8), back to back, then two stray bytes.
        let fc16 = [1, 0x10, 0, 1, 0, 2, 4, 0, 10, 1, 2, 0x92, 0x30];
        assert!(crc_ok(&fc16));
        let fc03 = [1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD];
        let mut all = fc16.to_vec();
        all.extend_from_slice(&fc03);
        all.extend_from_slice(&[0x55, 0xAA]);
        for chunk in 1..=all.len() {
            let mut rx = length_rx();
            let frames = feed(&mut rx, at(0), &all, chunk);
            assert_eq!(frames, vec![fc16.to_vec(), fc03.to_vec()], "chunk {chunk}");
            // The strays are a frame of their own, dropped at its gap.
            assert!(rx.is_receiving());
            assert_eq!(rx.poll(at(4_000)), None);
            assert_eq!(rx.counters().discarded, 1);
            assert_eq!(rx.quiet_at(), Some(at(4_000)));
        }
    }

    #[test]
    fn length_with_a_wrong_crc_waits_for_the_gap() {
        let mut rx = length_rx();
        let bad = [1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCE];
        assert!(feed(&mut rx, at(0), &bad, 3).is_empty());
        // More bytes do not make it end by length later.
        rx.push(at(100), &[0xC5, 0xCD], |_| true, Expect::Request);
        assert_eq!(rx.poll(at(100)), None);
        assert_eq!(rx.poll(at(4_100)).unwrap().adu.as_bytes().len(), 10);
    }

    #[test]
    fn gap_mode_ignores_predictions() {
        let mut rx = exact(&LineConfig::default());
        let n = rx.push(
            at(0),
            &[1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD, 1],
            |_| true,
            Expect::Request,
        );
        assert_eq!(n, 9);
        assert_eq!(rx.poll(at(0)), None);
        assert_eq!(rx.quiet_at(), None);
        assert_eq!(rx.poll(at(4_000)).unwrap().adu.as_bytes().len(), 9);
    }

    #[test]
    fn predictions_follow_the_request_and_response_layouts() {
        use Prediction::*;
        assert_eq!(request_len(&[1]), NeedMore(2));
        for f in [1, 2, 3, 4, 5, 6, 8] {
            assert_eq!(request_len(&[1, f]), Len(8), "FC{f}");
        }
        for f in [7, 11, 12] {
            assert_eq!(request_len(&[1, f]), Len(4), "FC{f}");
        }
        assert_eq!(request_len(&[1, 16, 0, 0, 0, 1]), NeedMore(7));
        assert_eq!(request_len(&[1, 15, 0, 0, 0, 9, 2]), Len(11));
        assert_eq!(request_len(&[1, 0x2B]), Unknown);
        assert_eq!(response_len(3, &[1, 3]), NeedMore(3));
        assert_eq!(response_len(3, &[1, 3, 20]), Len(25));
        assert_eq!(response_len(1, &[1, 1, 2]), Len(7));
        assert_eq!(response_len(12, &[1, 12, 8]), Len(13));
        assert_eq!(response_len(3, &[1, 0x83]), Len(5));
        assert_eq!(response_len(3, &[1, 4]), Unknown);
        for f in [5, 6, 8, 11, 15, 16] {
            assert_eq!(response_len(f, &[1, f]), Len(8), "FC{f}");
        }
        assert_eq!(response_len(7, &[1, 7]), Len(5));
        assert_eq!(response_len(0x2B, &[1, 0x2B]), Unknown);
    }
}
