//! The FIFO UART model: a station's received characters reach its engine when a 16550-type
//! receive FIFO interrupts, not one by one.
//!
//! A 16550A-compatible UART (the `8250`/`16550` driver's `/dev/ttyS*` on an industrial PC)
//! collects received characters in a receive FIFO of **16** places and raises its interrupt
//! when the FIFO holds its **trigger level** (1, 4, 8 or 14 characters), or, with fewer
//! waiting, after a **character timeout** of 4 character times without a new character. The
//! host then reads everything the FIFO holds, `service` after the interrupt (its interrupt and
//! scheduling latency); characters that arrive meanwhile are read with the others. A character
//! that arrives while all 16 places are taken is lost: an **overrun**, reported to the engine as
//! [`LineError::Overrun`] after the characters read with it (the kernel marks the character
//! read when the UART's overrun bit was set).
//!
//! What the host sees: with trigger 1, single characters at wire pace (plus a constant
//! `service`); with a higher trigger, reads of `trigger` characters and more, and the tail of a
//! frame 4 character times after its last character. The longest a character waits is
//! `(trigger + 2)` character times plus `service` (the first of `trigger − 1` characters
//! followed by the timeout); with trigger 1, `service`. That is what the model declares to the
//! engine when it `announce`s ([`FifoUart::hold`]); the tokio driver on Linux does not read the
//! trigger level, so a real `ttyS` port is an undeclared one.
//!
//! Parity and framing errors and BREAK take a FIFO place like the character they stand for and
//! reach the engine in order with the characters around them.

use si_core::{Duration, Instant, LineError, SerialSettings};

/// A 16550-type UART in front of a station's receiver ([`Simulator::set_uart`]).
///
/// [`Simulator::set_uart`]: crate::Simulator::set_uart
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FifoUart {
    /// The receive FIFO's trigger level: 1, 4, 8 or 14 characters.
    pub trigger: u8,
    /// How long after the interrupt the host reads the FIFO (interrupt and scheduling
    /// latency). Longer than `(16 − trigger)` character times loses characters: an overrun.
    pub service: Duration,
    /// Whether the host tells the engine the longest hold ([`FifoUart::hold`]) through
    /// [`Engine::set_rx_latency`]. `false` is a real `ttyS` port under the tokio driver,
    /// which reads no trigger level: the engine must learn from the reads.
    ///
    /// [`Engine::set_rx_latency`]: si_core::Engine::set_rx_latency
    pub announce: bool,
}

impl FifoUart {
    /// The receive FIFO's depth.
    pub const DEPTH: usize = 16;
    /// The trigger levels a 16550A offers.
    pub const TRIGGERS: [u8; 4] = [1, 4, 8, 14];
    /// The character timeout, in character times.
    pub const TIMEOUT_CHARS: u64 = 4;

    /// A 16550A as Linux sets it up (trigger 8 for the `16550A` port type) with a host that
    /// reads within 100 µs, announcing nothing.
    pub const LINUX_16550A: FifoUart = FifoUart {
        trigger: 8,
        service: Duration::from_micros(100),
        announce: false,
    };

    /// The same UART with another trigger level.
    pub const fn with_trigger(self, trigger: u8) -> Self {
        FifoUart { trigger, ..self }
    }

    /// The same UART with another host service latency.
    pub const fn with_service(self, service: Duration) -> Self {
        FifoUart { service, ..self }
    }

    /// The same UART on a host that declares its hold to the engine.
    pub const fn announced(self) -> Self {
        FifoUart {
            announce: true,
            ..self
        }
    }

    /// The longest a character can wait in the FIFO and for the host on this line:
    /// `(trigger + 2)` character times plus `service` (trigger 1: `service`).
    pub fn hold(&self, settings: &SerialSettings) -> Duration {
        if self.trigger <= 1 {
            self.service
        } else {
            settings
                .char_time()
                .saturating_mul(u64::from(self.trigger) + 2)
                + self.service
        }
    }

    /// Checks the trigger level.
    pub fn validate(&self) -> Result<(), UartError> {
        if !Self::TRIGGERS.contains(&self.trigger) {
            return Err(UartError {
                parameter: "trigger",
                range: "1, 4, 8 or 14",
                value: self.trigger.to_string(),
            });
        }
        Ok(())
    }
}

impl Default for FifoUart {
    fn default() -> Self {
        Self::LINUX_16550A
    }
}

/// A UART parameter out of range: names the parameter, the range and the value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("FIFO UART {parameter} = {value} is out of range {range}")]
pub struct UartError {
    /// The parameter.
    pub parameter: &'static str,
    /// The allowed range.
    pub range: &'static str,
    /// The value given.
    pub value: String,
}

/// What the simulator schedules for a FIFO: when, which kind, and the generation that keeps it
/// live (a later arrival or read makes an earlier entry a no-op).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FifoWake {
    /// The character timeout runs out: the UART interrupts.
    Timeout(u64),
    /// The host reads the FIFO.
    Read(u64),
}

/// A UART's receive state.
#[derive(Debug)]
pub(crate) struct Fifo {
    pub config: FifoUart,
    char_time: Duration,
    /// Characters (or errors standing for them) in the FIFO, plus at most one overrun marker.
    pub pending: Vec<Result<u8, LineError>>,
    /// FIFO places taken (the overrun marker takes none).
    taken: usize,
    overrun: bool,
    /// An interrupt is raised and the host's read is scheduled.
    read_due: bool,
    generation: u64,
    /// Bytes being handed over (reused, no allocation per read).
    pub scratch: Vec<u8>,
}

impl Fifo {
    pub fn new(config: FifoUart, settings: &SerialSettings) -> Self {
        Fifo {
            config,
            char_time: settings.char_time(),
            pending: Vec::with_capacity(FifoUart::DEPTH + 1),
            taken: 0,
            overrun: false,
            read_due: false,
            generation: 0,
            scratch: Vec::with_capacity(FifoUart::DEPTH * 2),
        }
    }

    /// A character (or an error standing for one) reaches the UART at `now`; what to schedule.
    pub fn arrive(
        &mut self,
        now: Instant,
        item: Result<u8, LineError>,
    ) -> Option<(Instant, FifoWake)> {
        if self.taken >= FifoUart::DEPTH {
            if !self.overrun {
                self.overrun = true;
                self.pending.push(Err(LineError::Overrun));
            }
            return None;
        }
        self.pending.push(item);
        self.taken += 1;
        if self.read_due {
            return None;
        }
        self.generation += 1;
        if self.taken >= usize::from(self.config.trigger) {
            self.read_due = true;
            Some((now + self.config.service, FifoWake::Read(self.generation)))
        } else {
            let timeout = self.char_time.saturating_mul(FifoUart::TIMEOUT_CHARS);
            Some((now + timeout, FifoWake::Timeout(self.generation)))
        }
    }

    /// The character timeout ran out: the UART interrupts, if nothing came since.
    pub fn timeout(&mut self, now: Instant, generation: u64) -> Option<(Instant, FifoWake)> {
        if generation != self.generation || self.read_due || self.taken == 0 {
            return None;
        }
        self.read_due = true;
        Some((now + self.config.service, FifoWake::Read(self.generation)))
    }

    /// The host reads the FIFO: true if this read is live (then `pending` holds what it got,
    /// to hand over and clear with [`Fifo::emptied`]).
    pub fn read(&mut self, generation: u64) -> bool {
        generation == self.generation && self.read_due
    }

    /// The host took everything: the FIFO is empty again.
    pub fn emptied(&mut self) {
        self.pending.clear();
        self.taken = 0;
        self.overrun = false;
        self.read_due = false;
        self.generation += 1;
    }
}
