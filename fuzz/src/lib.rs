//! What every engine target shares: the fuzzer's bytes read as a script of line events with
//! their timing (received bytes, time passing, spurious timeouts, tx-done, UART errors, modem
//! signals, commands), a driver that drains the engine after every input exactly as the
//! si-core contract says, and the invariants every engine owes (ARCHITECTURE.md): no panic,
//! bounded transmissions and output queues, timers that settle, and every job completing
//! exactly once.

use si_core::{Duration, Engine, Instant, LineError, ModemSignals, Output};
use std::collections::BTreeSet;

/// The fuzzer's bytes, read front to back; reads past the end give zeros.
pub struct Input<'a>(pub &'a [u8]);

impl<'a> Input<'a> {
    /// Nothing left.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// One byte.
    pub fn u8(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }

    /// Two bytes, big-endian.
    pub fn u16(&mut self) -> u16 {
        u16::from_be_bytes([self.u8(), self.u8()])
    }

    /// Up to `n` bytes.
    pub fn take(&mut self, n: usize) -> &'a [u8] {
        let (head, rest) = self.0.split_at(n.min(self.0.len()));
        self.0 = rest;
        head
    }
}

/// A line event drawn from the script.
pub enum Step<'a> {
    /// Bytes arrive.
    Rx(&'a [u8]),
    /// Time passes (timers fire at their deadlines on the way).
    Advance(Duration),
    /// A spurious `handle_timeout` now.
    Timeout,
    /// The transmitter emptied.
    TxDone,
    /// A UART error instead of a character.
    LineError(LineError),
    /// The modem inputs changed.
    Signals(ModemSignals),
    /// An engine command: a selector and argument bytes.
    Command(u8, &'a [u8]),
}

/// The next step of the script, `None` at its end.
pub fn next_step<'a>(input: &mut Input<'a>) -> Option<Step<'a>> {
    if input.is_empty() {
        return None;
    }
    let op = input.u8();
    Some(match op % 8 {
        0 | 1 => {
            let n = usize::from(input.u8() % 64);
            Step::Rx(input.take(n))
        }
        2 => {
            let unit = match input.u8() % 3 {
                0 => 1,
                1 => 100,
                _ => 1_000,
            };
            Step::Advance(Duration::from_micros(u64::from(input.u16()) * unit))
        }
        3 => Step::Timeout,
        4 => Step::TxDone,
        5 => Step::LineError(match input.u8() % 4 {
            0 => LineError::Parity,
            1 => LineError::Framing,
            2 => LineError::Overrun,
            _ => LineError::Break,
        }),
        6 => {
            let b = input.u8();
            Step::Signals(ModemSignals {
                dtr: b & 1 != 0,
                dsr: b & 2 != 0,
                rts: b & 4 != 0,
                cts: b & 8 != 0,
                dcd: b & 16 != 0,
            })
        }
        _ => {
            let selector = input.u8();
            let n = usize::from(input.u8());
            Step::Command(selector, input.take(n))
        }
    })
}

/// Outputs one input may produce before we call the queue unbounded.
const MAX_OUTPUTS: usize = 4_096;

/// An engine under a driver that follows the contract, with its invariants checked.
pub struct Harness<E: Engine> {
    /// The engine.
    pub engine: E,
    /// Virtual time.
    pub now: Instant,
    /// The deadline of the last `Wait`.
    pub deadline: Option<Instant>,
    /// The longest `Transmit` the engine may produce.
    pub max_transmit: usize,
    /// Jobs started and not yet completed.
    pub open: BTreeSet<u64>,
    /// Bytes were transmitted and no tx-done has been reported since.
    pub tx_pending: bool,
}

impl<E: Engine> Harness<E> {
    /// A harness for `engine`, whose frames are never longer than `max_transmit`.
    pub fn new(engine: E, max_transmit: usize) -> Self {
        let mut h = Harness {
            engine,
            now: Instant::ZERO,
            deadline: None,
            max_transmit,
            open: BTreeSet::new(),
            tx_pending: false,
        };
        h.drain(&mut |_, _| {});
        h
    }

    /// A job was started.
    pub fn started(&mut self, job: u64) {
        assert!(self.open.insert(job), "job id {job} handed out twice");
    }

    /// A job completed: it must be open, and it closes.
    pub fn completed(&mut self, job: u64) {
        assert!(
            self.open.remove(&job),
            "job {job} completed twice or never started"
        );
    }

    /// Drain until `Wait`, handing events to `on_event`.
    pub fn drain(&mut self, on_event: &mut impl FnMut(&mut Self, E::Event)) {
        for _ in 0..MAX_OUTPUTS {
            match self.engine.poll_output() {
                Output::Transmit(bytes) => {
                    assert!(
                        bytes.len() <= self.max_transmit,
                        "transmit of {} bytes, more than {}",
                        bytes.len(),
                        self.max_transmit
                    );
                    self.tx_pending = true;
                }
                Output::SetSignals(_) => {}
                Output::Event(e) => on_event(self, e),
                Output::Wait(deadline) => {
                    self.deadline = deadline;
                    return;
                }
            }
        }
        panic!("more than {MAX_OUTPUTS} outputs for one input: unbounded queue");
    }

    /// Fire the timers due by `until`, at their deadlines, then set the clock to `until`.
    pub fn advance(&mut self, until: Instant, on_event: &mut impl FnMut(&mut Self, E::Event)) {
        let mut same_instant = 0;
        while let Some(t) = self.deadline.filter(|&t| t <= until) {
            let t = t.max(self.now);
            same_instant = if t == self.now { same_instant + 1 } else { 0 };
            assert!(
                same_instant < 64,
                "a timer keeps firing at {t:?} without settling"
            );
            self.now = t;
            self.engine.handle_timeout(t);
            self.drain(on_event);
        }
        self.now = self.now.max(until);
    }

    /// Play the script; `command` runs an engine command from a `Step::Command`.
    pub fn run(
        &mut self,
        input: &mut Input<'_>,
        command: &mut impl FnMut(&mut Self, u8, &[u8]),
        on_event: &mut impl FnMut(&mut Self, E::Event),
    ) {
        while let Some(step) = next_step(input) {
            let now = self.now;
            match step {
                Step::Rx(bytes) => self.engine.handle_rx(now, bytes),
                Step::Advance(d) => {
                    self.advance(now + d, on_event);
                    continue;
                }
                Step::Timeout => self.engine.handle_timeout(now),
                Step::TxDone => {
                    self.tx_pending = false;
                    self.engine.handle_tx_done(now);
                }
                Step::LineError(e) => self.engine.handle_line_error(now, e),
                Step::Signals(s) => self.engine.handle_signals(now, s),
                Step::Command(selector, args) => command(self, selector, args),
            }
            self.drain(on_event);
        }
    }

    /// With the partner silent, let every timer run out (bounded), reporting tx-done after
    /// every transmission as a driver does: afterwards every job must have completed.
    pub fn finish(&mut self, on_event: &mut impl FnMut(&mut Self, E::Event)) {
        for _ in 0..10_000 {
            if self.open.is_empty() {
                return;
            }
            if self.tx_pending {
                self.tx_pending = false;
                let now = self.now;
                self.engine.handle_tx_done(now);
                self.drain(on_event);
                continue;
            }
            match self.deadline {
                Some(t) => self.advance(t, on_event),
                None => break,
            }
        }
        assert!(
            self.open.is_empty(),
            "jobs {:?} never completed (deadline {:?})",
            self.open,
            self.deadline
        );
    }
}
