//! The module's serial side over a Sans-IO line engine ([`si_core::Engine`]): the adapter
//! through which a 3964(R), ASCII or any other engine becomes the module's line, and through
//! which the whole module becomes a station of the line simulator.
//!
//! The adapter knows an engine only through a few plain functions ([`LineHooks`]): how to start
//! sending a frame, which of its events mean "frame received", "receive error", "send finished"
//! and "send finished with an answer" (a Modbus master's job), how to take a frame (or a failed
//! reception) the engine keeps in its own buffer, how to set RTS/DTR and how to apply a
//! flow-control block. [`EngineSerial`] implements [`SerialSide`] with them, and
//! `Module<EngineSerial<E>>` implements [`Engine`] by passing the line through to `E`, so a
//! simulator or the tokio driver runs it like any engine while the DP side is driven with
//! [`Module::cycle`] (from `Simulator::with` or `Handle::call`).
//!
//! The hooks for the finished line engines are in `engines` (feature `module-sim`):
//! `engines::r3964r` and `engines::ascii` make a simulated module that runs 3964(R) or ASCII on
//! its line, `modbus::master` one in Modbus master mode.

use crate::frame::{ParamBlock, V24Signals};
use crate::module::{Module, SerialEvent, SerialSide};
use crate::status::FLOW_CONTROL_MISMATCH;
use bytes::Bytes;
use si_core::{Engine, FramePool, Instant, LineError, ModemSignals, Output, SignalUpdate, Status};
use std::collections::VecDeque;

/// Applies a flow-control block to an engine.
pub type FlowControlHook<E> = fn(&mut E, Instant, ParamBlock) -> Result<(), Status>;

/// Takes the oldest reception out of an engine's own receive buffer: a frame, or the STATUS of a
/// reception that failed (a Modbus master job's timeout or exception, which S_RCV reports too).
/// An engine that builds the frame on the spot (into a scratch area) cuts it from `pool`, which
/// the adapter keeps, so taking allocates nothing per frame in steady state.
pub type TakeFrameHook<E> = fn(&mut E, Instant, &mut FramePool) -> Option<Result<Bytes, Status>>;

/// Sets RTS and DTR through the engine (which may refuse, e.g. under automatic V.24 control).
pub type SetSignalsHook<E> = fn(&mut E, Instant, SignalUpdate) -> Result<(), Status>;

/// Starts sending a frame the adapter hands over as [`Bytes`] cut from a buffer it keeps (see
/// [`EngineSerial::with_pooled_send`]), for engines whose send command takes `Bytes`.
pub type SendBytesHook<E> = fn(&mut E, Instant, Bytes) -> Result<(), Status>;

/// Bytes a frame pool allocates at a time: four of the longest frames of chapter 2
/// ([`crate::config::MAX_FRAME_LEN`]), so a frame still held elsewhere while the next one is
/// cut (a frame in the module's receive buffer, say) rarely makes the pool move to a new
/// allocation.
const POOL_BYTES: usize = 4 * crate::config::MAX_FRAME_LEN;

/// What one engine event means for the module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LineEvent {
    /// Passed to the module as it is.
    Serial(SerialEvent),
    /// A frame waits in the engine's own buffer (engines that report only a length, like
    /// si-3964r and si-ascii); it is taken with [`LineHooks::take_frame`] at the module's next
    /// cycle, in order with the other events, so the engine's buffer frees at that time.
    FrameWaiting,
    /// A send ended and left an answer in the engine (a master's request and the slave's
    /// response, or the job's failure): the module hears [`SerialEvent::SendDone`] with the
    /// result, and takes the answer as after [`LineEvent::FrameWaiting`] (first, so it is
    /// buffered by the time the end-of-job acknowledgement is shown). Nothing waits after a
    /// broadcast: `take_frame` then returns `None`.
    Answered(Result<(), Status>),
}

impl From<SerialEvent> for LineEvent {
    fn from(e: SerialEvent) -> Self {
        LineEvent::Serial(e)
    }
}

/// How [`EngineSerial`] talks to one kind of engine.
pub struct LineHooks<E: Engine> {
    /// Starts sending a frame (the engine's own send command).
    pub send: fn(&mut E, Instant, &[u8]) -> Result<(), Status>,
    /// What an engine event means for the module, if anything.
    pub classify: fn(&E::Event) -> Option<LineEvent>,
    /// Takes a waiting frame after [`LineEvent::FrameWaiting`] or [`LineEvent::Answered`];
    /// `None` when the engine never reports those.
    pub take_frame: Option<TakeFrameHook<E>>,
    /// Sets RTS/DTR through the engine; `None` sets them directly on the line (the adapter
    /// emits the [`Output::SetSignals`] itself).
    pub set_signals: Option<SetSignalsHook<E>>,
    /// Applies a flow-control block; `None` refuses every block with 0550H.
    pub set_flow_control: Option<FlowControlHook<E>>,
}

impl<E: Engine> Clone for LineHooks<E> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<E: Engine> Copy for LineHooks<E> {}

impl<E: Engine> core::fmt::Debug for LineHooks<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("LineHooks")
    }
}

/// Most serial events held between two module cycles; more are dropped and counted.
const MAX_PENDING: usize = 256;

/// A line engine seen as the module's [`SerialSide`].
#[derive(Debug)]
pub struct EngineSerial<E: Engine> {
    engine: E,
    hooks: LineHooks<E>,
    /// Modem inputs as last reported to the engine, outputs as last set.
    signals: ModemSignals,
    /// A write V.24 job's signal change, handed to the driver before the engine's outputs.
    pending_signals: Option<SignalUpdate>,
    events: VecDeque<LineEvent>,
    dropped: u64,
    /// Frames waiting in the engine whose [`LineEvent::FrameWaiting`] was dropped.
    unannounced: u64,
    /// Set by [`EngineSerial::with_pooled_send`]: frames to send go to the engine as `Bytes`
    /// cut from `tx_pool`, instead of through [`LineHooks::send`].
    send_bytes: Option<SendBytesHook<E>>,
    /// Frames to send are cut from this pool (no allocation per frame in steady state).
    tx_pool: FramePool,
    /// Frames [`LineHooks::take_frame`] builds on the spot are cut from this pool.
    rx_pool: FramePool,
}

impl<E: Engine> EngineSerial<E> {
    /// Wraps `engine`.
    pub fn new(engine: E, hooks: LineHooks<E>) -> Self {
        EngineSerial {
            engine,
            hooks,
            signals: ModemSignals::default(),
            pending_signals: None,
            events: VecDeque::new(),
            dropped: 0,
            unannounced: 0,
            send_bytes: None,
            tx_pool: FramePool::new(POOL_BYTES),
            rx_pool: FramePool::new(POOL_BYTES),
        }
    }

    /// Sends through `send` instead of [`LineHooks::send`]: each frame is copied into a buffer
    /// the adapter keeps and handed over as [`Bytes`] cut from it. Once the engine has dropped
    /// the previous frame (its job ended) the buffer's allocation is reused, so sending
    /// allocates nothing per frame in steady state (the si-core contract), where a `send` hook
    /// taking `&[u8]` would have to copy each frame into a new `Bytes` for an engine that keeps it.
    pub fn with_pooled_send(mut self, send: SendBytesHook<E>) -> Self {
        self.send_bytes = Some(send);
        self
    }

    /// The engine.
    pub fn engine(&self) -> &E {
        &self.engine
    }

    /// The engine, mutably (to configure it or call its commands).
    pub fn engine_mut(&mut self) -> &mut E {
        &mut self.engine
    }

    /// Serial events dropped because the module did not cycle for too long.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// The engine's next output, noting what the module must hear about.
    fn poll_engine(&mut self) -> Output<E::Event> {
        if let Some(update) = self.pending_signals.take() {
            return Output::SetSignals(update);
        }
        let out = self.engine.poll_output();
        match &out {
            Output::Event(e) => match (self.hooks.classify)(e) {
                Some(LineEvent::Answered(result)) => {
                    self.note(LineEvent::FrameWaiting);
                    self.note(SerialEvent::SendDone(result).into());
                }
                Some(se) => self.note(se),
                None => {}
            },
            Output::SetSignals(u) => {
                self.signals.rts = u.rts.unwrap_or(self.signals.rts);
                self.signals.dtr = u.dtr.unwrap_or(self.signals.dtr);
            }
            Output::Transmit(_) | Output::Wait(_) => {}
        }
        out
    }

    /// Queues what the module must hear about, within [`MAX_PENDING`].
    fn note(&mut self, se: LineEvent) {
        let send_done = matches!(se, LineEvent::Serial(SerialEvent::SendDone(_)));
        if self.events.len() < MAX_PENDING || send_done {
            // The end of a send is never dropped (the module would wait for it forever); the
            // engine runs one send at a time, so this stays bounded.
            self.events.push_back(se);
        } else {
            self.dropped += 1;
            if se == LineEvent::FrameWaiting {
                self.unannounced += 1;
            }
        }
    }

    /// Takes the reception waiting in the engine, if any.
    fn take(&mut self, now: Instant) -> Option<SerialEvent> {
        let take = self.hooks.take_frame?;
        Some(match take(&mut self.engine, now, &mut self.rx_pool)? {
            Ok(frame) => SerialEvent::Received(frame),
            Err(status) => SerialEvent::ReceiveFailed(status),
        })
    }
}

impl<E: Engine> SerialSide for EngineSerial<E> {
    fn send(&mut self, now: Instant, frame: &[u8]) -> Result<(), Status> {
        match self.send_bytes {
            Some(send) => {
                let frame = self.tx_pool.cut(frame);
                send(&mut self.engine, now, frame)
            }
            None => (self.hooks.send)(&mut self.engine, now, frame),
        }
    }

    fn poll(&mut self, now: Instant) -> Option<SerialEvent> {
        while let Some(e) = self.events.pop_front() {
            match e {
                LineEvent::Serial(e) => return Some(e),
                // `Answered` is split into these two by `poll_engine`.
                LineEvent::FrameWaiting | LineEvent::Answered(_) => {
                    if let Some(reception) = self.take(now) {
                        return Some(reception);
                    }
                }
            }
        }
        // Frames whose notice was dropped while the module did not cycle still wait in the
        // engine: fetch them once the queue is empty, so none stays behind for good.
        if self.unannounced > 0 {
            self.unannounced -= 1;
            return self.take(now);
        }
        None
    }

    fn signals(&self) -> V24Signals {
        self.signals.into()
    }

    fn set_signals(&mut self, now: Instant, rts: bool, dtr: bool) -> Result<(), Status> {
        let update = SignalUpdate {
            rts: Some(rts),
            dtr: Some(dtr),
        };
        if let Some(set) = self.hooks.set_signals {
            // The engine emits the change itself; `poll_engine` notes it in `signals`.
            return set(&mut self.engine, now, update);
        }
        self.signals.rts = rts;
        self.signals.dtr = dtr;
        self.pending_signals = Some(update);
        Ok(())
    }

    fn set_flow_control(&mut self, now: Instant, block: ParamBlock) -> Result<(), Status> {
        match self.hooks.set_flow_control {
            Some(f) => f(&mut self.engine, now, block),
            None => Err(FLOW_CONTROL_MISMATCH),
        }
    }
}

/// The module as a line station: the line side is the wrapped engine's, unchanged; its events
/// are passed on after the module has taken what it needs.
impl<E: Engine> Engine for Module<EngineSerial<E>> {
    type Event = E::Event;

    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.serial_mut().engine.handle_rx(now, bytes);
    }

    fn handle_timeout(&mut self, now: Instant) {
        self.serial_mut().engine.handle_timeout(now);
    }

    fn handle_tx_done(&mut self, now: Instant) {
        self.serial_mut().engine.handle_tx_done(now);
    }

    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.serial_mut().engine.handle_line_error(now, error);
    }

    fn handle_signals(&mut self, now: Instant, signals: ModemSignals) {
        let s = self.serial_mut();
        s.signals.cts = signals.cts;
        s.signals.dsr = signals.dsr;
        s.signals.dcd = signals.dcd;
        s.engine.handle_signals(now, signals);
    }

    fn set_rx_latency(&mut self, latency: si_core::Duration) {
        self.serial_mut().engine.set_rx_latency(latency);
    }

    fn poll_output(&mut self) -> Output<Self::Event> {
        self.serial_mut().poll_engine()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bytes::Bytes;

    /// Buffers numbered one-byte frames and reports each with a length-only event.
    #[derive(Default)]
    struct Flood {
        frames: VecDeque<Bytes>,
        out: VecDeque<Output<u8>>,
    }

    impl Engine for Flood {
        type Event = u8;
        fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
            for &b in bytes {
                self.frames.push_back(Bytes::copy_from_slice(&[b]));
                self.out.push_back(Output::Event(b));
            }
        }
        fn handle_timeout(&mut self, _: Instant) {}
        fn handle_tx_done(&mut self, _: Instant) {
            self.out.push_back(Output::Event(0xFF));
        }
        fn poll_output(&mut self) -> Output<u8> {
            self.out.pop_front().unwrap_or(Output::Wait(None))
        }
    }

    const FLOOD: LineHooks<Flood> = LineHooks {
        send: |_, _, _| Ok(()),
        classify: |e| match e {
            0xFF => Some(SerialEvent::SendDone(Ok(())).into()),
            _ => Some(LineEvent::FrameWaiting),
        },
        take_frame: Some(|f, _, _| f.frames.pop_front().map(Ok)),
        set_signals: None,
        set_flow_control: None,
    };

    #[test]
    fn overflow_drops_notices_but_no_frame_and_never_the_end_of_a_send() {
        let mut side = EngineSerial::new(Flood::default(), FLOOD);
        let now = Instant::ZERO;
        let bytes: Vec<u8> = (0..300u16).map(|i| (i % 250) as u8).collect();
        side.engine_mut().handle_rx(now, &bytes);
        side.engine_mut().handle_tx_done(now);
        while !matches!(side.poll_engine(), Output::Wait(_)) {}
        assert_eq!(side.dropped(), 300 - MAX_PENDING as u64);
        let events: Vec<SerialEvent> = std::iter::from_fn(|| side.poll(now)).collect();
        let frames: Vec<u8> = events
            .iter()
            .filter_map(|e| match e {
                SerialEvent::Received(f) => Some(f[0]),
                _ => None,
            })
            .collect();
        assert_eq!(frames, bytes, "every frame, in order");
        assert!(events.contains(&SerialEvent::SendDone(Ok(()))));
    }
}
