//! The Sans-IO contract every protocol engine follows.
//!
//! An engine is a state machine. It never reads a clock, sleeps, spawns a task or touches a port:
//! a *driver* (the `si-sim` simulator, the [tokio driver](crate::driver), a test, a
//! microcontroller main loop) feeds it what happened on the line together with the current
//! [`Instant`], and then **drains** its outputs until it says [`Output::Wait`]:
//!
//! ```
//! use si_core::{Engine, Instant, Output};
//!
//! /// Drain after every input; `Wait` carries the next deadline for `handle_timeout`.
//! fn drain<E: Engine>(engine: &mut E, wire: &mut Vec<u8>, events: &mut Vec<E::Event>) -> Option<Instant> {
//!     loop {
//!         match engine.poll_output() {
//!             Output::Transmit(bytes) => wire.extend_from_slice(&bytes),
//!             Output::SetSignals(_update) => { /* set RTS/DTR on the port */ }
//!             Output::Event(event) => events.push(event),
//!             Output::Wait(deadline) => return deadline,
//!         }
//!     }
//! }
//! # struct Quiet;
//! # impl Engine for Quiet {
//! #     type Event = ();
//! #     fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
//! #     fn handle_timeout(&mut self, _: Instant) {}
//! #     fn poll_output(&mut self) -> Output<()> { Output::Wait(None) }
//! # }
//! # let (mut wire, mut events) = (Vec::new(), Vec::new());
//! # assert_eq!(drain(&mut Quiet, &mut wire, &mut events), None);
//! ```
//!
//! The rule "drain until `Wait`" matters: an engine may queue several outputs for one input (a
//! NAK and then an error event), and its deadline is only valid once everything before it has
//! been taken. A driver calls [`Engine::handle_timeout`] when the clock reaches the deadline
//! (calling it early or spuriously is harmless: engines compare `now` with their own deadlines).
//!
//! Bad input never panics: any byte sequence at any timing is valid input, and errors come out as
//! events carrying a [`Status`](crate::Status).

use crate::time::Instant;
use bytes::Bytes;
use serde::{Deserialize, Serialize};

/// One thing an engine wants its driver to do, or the news that it has nothing more to say.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Output<E> {
    /// Put these bytes on the line, after anything transmitted before.
    Transmit(Bytes),
    /// Change the modem-control outputs (RTS, DTR).
    SetSignals(SignalUpdate),
    /// Something the application must hear about: a received frame, a finished job, an error.
    Event(E),
    /// Nothing more for now. Call [`Engine::handle_timeout`] at this instant if no other input
    /// arrives first; `None` means no timer is running.
    Wait(Option<Instant>),
}

/// A line condition the UART reports instead of a character.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LineError {
    /// Parity bit wrong.
    Parity,
    /// Stop bit missing (also what a collision on an RS-485 bus looks like).
    Framing,
    /// The receiver lost characters.
    Overrun,
    /// The line held at space for longer than a character: a BREAK or a broken wire.
    Break,
}

/// The RS-232 modem signals as the host's port sees them ([ET200S SI] §2.8).
///
/// DTR and RTS are the host's outputs, DSR, CTS and DCD its inputs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ModemSignals {
    /// Data terminal ready (output).
    pub dtr: bool,
    /// Data set ready (input).
    pub dsr: bool,
    /// Request to send (output).
    pub rts: bool,
    /// Clear to send (input).
    pub cts: bool,
    /// Data carrier detect (input).
    pub dcd: bool,
}

/// A change of the host's modem outputs; `None` leaves a signal as it is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SignalUpdate {
    /// New DTR level.
    pub dtr: Option<bool>,
    /// New RTS level.
    pub rts: Option<bool>,
}

/// A Sans-IO protocol engine.
///
/// Inputs are the `handle_*` methods plus the engine's own commands (`send`, `request`, …,
/// which return a typed error when refused). After each input the driver drains
/// [`poll_output`](Engine::poll_output) until it returns [`Output::Wait`].
pub trait Engine {
    /// What the engine reports to the application.
    type Event: core::fmt::Debug;

    /// Bytes received from the line, in order, at `now`.
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]);

    /// The clock reached (or passed) the deadline of the last `Wait`.
    fn handle_timeout(&mut self, now: Instant);

    /// The last byte queued by `Transmit` has left the transmitter. Drivers that cannot know
    /// (a TCP stream) call it when the write completed. Engines use it for RS-485 turnaround and
    /// the RTS-off delay; the default ignores it.
    fn handle_tx_done(&mut self, now: Instant) {
        let _ = now;
    }

    /// The UART reported a parity, framing or overrun error or a BREAK instead of a character.
    /// The default ignores it.
    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        let _ = (now, error);
    }

    /// The modem inputs (CTS, DSR, DCD) changed. The default ignores them.
    fn handle_signals(&mut self, now: Instant, signals: ModemSignals) {
        let _ = (now, signals);
    }

    /// The port hands received bytes over up to `latency` after they left the wire, in packets:
    /// a USB-serial adapter's latency timer (16 ms by default on FTDI chips), a serial device
    /// server's packing delay. A driver that knows it (the tokio driver reads the adapter's
    /// latency timer on Linux; the simulator's adapter model knows its own) says so before the
    /// first byte. Engines whose timers judge silence (an end-of-frame gap, a character delay
    /// time, a response start) allow for it so that a hole between two packets is not taken for
    /// silence; on a port that delivers bytes one by one the manual's timing is kept exactly.
    /// `Duration::ZERO` declares such a port (the simulator's direct stations, a driver that
    /// knows its UART delivers every byte at once). A port nobody declared is taken to packetise
    /// like a default USB adapter until its reads prove otherwise ([`crate::delivery`]).
    /// The default ignores it.
    fn set_rx_latency(&mut self, latency: crate::time::Duration) {
        let _ = latency;
    }

    /// The next output; [`Output::Wait`] when there is nothing more to do.
    fn poll_output(&mut self) -> Output<Self::Event>;
}
