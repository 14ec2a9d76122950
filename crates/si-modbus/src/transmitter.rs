//! The transmit side the Modbus master and slave share: frames cut from one kept buffer (no
//! allocation per frame in steady state), and automatic use of the V.24 signals around each
//! transmission ([Modbus/USS] §3.2.2). The sequence is si-core's ([`si_core::v24`],
//! shared with the ASCII driver); this holds the one frame that waits for CTS.
//!
//! Without the option every call passes straight through: a frame goes out at once, every byte
//! is received.

use crate::config::LineConfig;
use crate::rx::Receiver;
use bytes::Bytes;
use si_core::v24::{AutoV24, AutoV24Times, Step};
use si_core::{FramePool, Instant, ModemSignals, Output};
use std::collections::VecDeque;

/// What became of a frame handed to [`V24Gate::transmit`] or of the held one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Gate {
    /// Nothing changed.
    Nothing,
    /// The frame is on its way (queued as `Transmit` now), this many bytes long.
    Sent(usize),
    /// The frame waits for CTS = ON.
    Held,
    /// The transmission is aborted (DSR = OFF, no CTS in time, CTS or DSR dropped): 0818H.
    Aborted,
}

/// A Modbus engine's transmit side: the kept buffer, the V.24 sequence if configured, and the
/// frame waiting for CTS.
#[derive(Debug)]
pub(crate) struct Transmitter {
    /// Frames are cut from this pool: no allocation per frame in steady state (the si-core
    /// contract).
    pool: FramePool,
    sequence: Option<AutoV24>,
    held: Option<Bytes>,
    /// The caller writes a frame that goes out at once from where the engine keeps it
    /// ([`set_in_place`](Self::set_in_place)): it is queued as an empty `Transmit`, not cut.
    in_place: bool,
}

impl Transmitter {
    /// Enters the V.24 mode at once (DTR = ON, RTS = OFF, [Modbus/USS] §3.2.2 item 1) when
    /// configured.
    pub(crate) fn new<E>(times: Option<AutoV24Times>, out: &mut VecDeque<Output<E>>) -> Self {
        let sequence = times.map(|t| {
            let mut s = AutoV24::new(t);
            s.enter(out);
            s
        });
        Transmitter {
            pool: FramePool::preallocated(4 * crate::frame::MAX_ADU),
            sequence,
            held: None,
            in_place: false,
        }
    }

    /// Queue a frame that goes out at once (no V.24 sequence holds it) as an empty
    /// `Transmit`: the caller ([`crate::tokio::InlineMaster`]) writes the engine's request from
    /// where the engine keeps it, so no frame is cut from the pool and dropped per request. A
    /// frame a V.24 sequence holds is still cut (the engine's request may be gone by the time
    /// CTS comes).
    #[cfg(feature = "tokio")]
    pub(crate) fn set_in_place(&mut self) {
        self.in_place = true;
    }

    /// Transmit `bytes` now, or once CTS = ON ([Modbus/USS] §3.2.2 item 3).
    pub(crate) fn transmit<E>(
        &mut self,
        now: Instant,
        bytes: &[u8],
        out: &mut VecDeque<Output<E>>,
    ) -> Gate {
        if self.in_place && self.sequence.is_none() {
            out.push_back(Output::Transmit(Bytes::new()));
            return Gate::Sent(bytes.len());
        }
        let frame = self.pool.cut(bytes);
        let step = match self.sequence.as_mut() {
            None => Step::Send,
            Some(s) => s.begin(now, out),
        };
        match step {
            Step::Send => Self::send(frame, out),
            Step::Abort => Gate::Aborted,
            Step::Nothing | Step::Done => {
                self.held = Some(frame);
                Gate::Held
            }
        }
    }

    /// The transmission has left the line: RTS goes OFF after the RTS-off time (item 5).
    pub(crate) fn sent<E>(&mut self, now: Instant, out: &mut VecDeque<Output<E>>) {
        if let Some(s) = self.sequence.as_mut() {
            s.sent(now, out);
        }
    }

    /// The clock reached [`deadline`](Self::deadline): RTS = OFF, or no CTS in time (item 4).
    pub(crate) fn on_timeout<E>(&mut self, now: Instant, out: &mut VecDeque<Output<E>>) -> Gate {
        let Some(s) = self.sequence.as_mut() else {
            return Gate::Nothing;
        };
        match s.on_timeout(now, out) {
            Step::Abort => {
                self.held = None;
                Gate::Aborted
            }
            _ => Gate::Nothing,
        }
    }

    /// The modem inputs changed: the held frame goes out at CTS = ON; CTS or DSR dropping
    /// aborts (items 4 and 7). The flag says DSR went OFF, which also aborts a reception.
    pub(crate) fn on_signals<E>(
        &mut self,
        signals: ModemSignals,
        out: &mut VecDeque<Output<E>>,
    ) -> (Gate, bool) {
        let Some(s) = self.sequence.as_mut() else {
            return (Gate::Nothing, false);
        };
        let (step, dsr_dropped) = s.on_signals(signals, out);
        let gate = match step {
            Step::Send => match self.held.take() {
                Some(frame) => Self::send(frame, out),
                None => Gate::Nothing,
            },
            Step::Abort => {
                self.held = None;
                Gate::Aborted
            }
            Step::Nothing | Step::Done => Gate::Nothing,
        };
        (gate, dsr_dropped)
    }

    /// Received characters count only while DSR = ON (item 6).
    pub(crate) fn may_receive(&self) -> bool {
        self.sequence.as_ref().is_none_or(AutoV24::may_receive)
    }

    /// No automatic V.24 sequence: [`on_timeout`](Self::on_timeout) and
    /// [`sent`](Self::sent) do nothing, and the line may always receive.
    #[cfg(feature = "tokio")]
    pub(crate) fn is_plain(&self) -> bool {
        self.sequence.is_none()
    }

    /// When [`on_timeout`](Self::on_timeout) has something to do.
    pub(crate) fn deadline(&self) -> Option<Instant> {
        self.sequence.as_ref().and_then(AutoV24::deadline)
    }

    /// A frame of `len` bytes went out at `now`: a line that echoes it drops as many received
    /// bytes; returns when the last one has left at the line's character time.
    pub(crate) fn on_air(
        line: &LineConfig,
        rx: &mut Receiver,
        now: Instant,
        len: usize,
    ) -> Instant {
        if line.local_echo {
            rx.expect_echo(len);
        }
        now + line.settings.chars_time(len as u64)
    }

    fn send<E>(frame: Bytes, out: &mut VecDeque<Output<E>>) -> Gate {
        let len = frame.len();
        out.push_back(Output::Transmit(frame));
        Gate::Sent(len)
    }
}
