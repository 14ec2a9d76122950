//! The module's serial side over a Sans-IO line engine ([`si_core::Engine`]): the adapter
//! through which a 3964(R), ASCII or any other engine becomes the module's line, and through
//! which the whole module becomes a station of the line simulator.
//!
//! The protocol crates do not depend on each other (ARCHITECTURE.md), so the adapter knows an
//! engine only through three plain functions ([`LineHooks`]): how to start sending a frame, which
//! of its events mean "frame received", "receive error" and "send finished", and how to apply a
//! flow-control block. [`EngineSerial`] implements [`SerialSide`] with them, and
//! `Module<EngineSerial<E>>` implements [`Engine`] by passing the line through to `E`, so a
//! simulator or the tokio driver runs it like any engine while the DP side is driven with
//! [`Module::cycle`] (from `Simulator::with` or `Handle::call`).

use crate::frame::{ParamBlock, V24Signals};
use crate::module::{Module, SerialEvent, SerialSide};
use crate::status::FLOW_CONTROL_MISMATCH;
use si_core::{Engine, Instant, LineError, ModemSignals, Output, SignalUpdate, Status};
use std::collections::VecDeque;

/// Applies a flow-control block to an engine.
pub type FlowControlHook<E> = fn(&mut E, Instant, ParamBlock) -> Result<(), Status>;

/// How [`EngineSerial`] talks to one kind of engine.
pub struct LineHooks<E: Engine> {
    /// Starts sending a frame (the engine's own send command).
    pub send: fn(&mut E, Instant, &[u8]) -> Result<(), Status>,
    /// What an engine event means for the module, if anything.
    pub classify: fn(&E::Event) -> Option<SerialEvent>,
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
    events: VecDeque<SerialEvent>,
    dropped: u64,
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
        }
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
            Output::Event(e) => {
                if let Some(se) = (self.hooks.classify)(e) {
                    if self.events.len() < MAX_PENDING {
                        self.events.push_back(se);
                    } else {
                        self.dropped += 1;
                    }
                }
            }
            Output::SetSignals(u) => {
                self.signals.rts = u.rts.unwrap_or(self.signals.rts);
                self.signals.dtr = u.dtr.unwrap_or(self.signals.dtr);
            }
            Output::Transmit(_) | Output::Wait(_) => {}
        }
        out
    }
}

impl<E: Engine> SerialSide for EngineSerial<E> {
    fn send(&mut self, now: Instant, frame: &[u8]) -> Result<(), Status> {
        (self.hooks.send)(&mut self.engine, now, frame)
    }

    fn poll(&mut self, _now: Instant) -> Option<SerialEvent> {
        self.events.pop_front()
    }

    fn signals(&self) -> V24Signals {
        self.signals.into()
    }

    fn set_signals(&mut self, _now: Instant, rts: bool, dtr: bool) -> Result<(), Status> {
        self.signals.rts = rts;
        self.signals.dtr = dtr;
        self.pending_signals = Some(SignalUpdate {
            rts: Some(rts),
            dtr: Some(dtr),
        });
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

    fn poll_output(&mut self) -> Output<Self::Event> {
        self.serial_mut().poll_engine()
    }
}
