//! Telegram reception shared by master and drive: start interval, LGE, residual run time.
//!
//! [USS spec] §5.1.2, §5.2.1.2, §5.2.2, §6.3:
//! - only an STX after a start interval (≥ 2 character times of silence) starts a telegram; any
//!   other character there is "start not identified" and the receiver waits for silence again;
//! - after STX comes LGE, which fixes the length (n + 4 bytes in all); LGE outside 2…254 is a
//!   length error;
//! - the whole rest of the telegram must arrive within the residual run time 1.5 × (n + 3)
//!   character times from the end of STX; for variable length n = 252 is assumed until LGE is in;
//! - the character delay need not be monitored (it is, implicitly, by the residual run time);
//! - parity, framing and overrun errors and BREAK discard the telegram.
//!
//! Behind a port that hands bytes over in packets (a USB adapter, [`si_core::delivery`]) the
//! residual run time gets the port's patience: the telegram's last packet may reach the host
//! up to the port's latency after its last character left the wire, while its STX may have
//! come at once, and since the telegram's length is known (LGE, or the expected structure
//! before it) a telegram that is whole ends at once anyway, so waiting out the longest latency
//! an adapter can have ([`Delivery::patience`]) costs only a broken telegram's detection
//! time. On a port that delivers byte by byte it is zero.
//!
//! The receiver keeps at most one telegram (256 bytes) in a fixed buffer: no allocation.

use crate::config::{residual_run_time, start_interval};
use crate::frame::{MAX_NET, MAX_TELEGRAM, STX};
use si_core::delivery::Delivery;
use si_core::{Duration, Instant, LineError, SerialSettings};

/// What a received character did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RxOutcome {
    /// Nothing to report yet.
    Pending,
    /// A whole telegram is in [`Receiver::telegram`].
    Complete,
    /// A character was not the start of a telegram.
    StartNotIdentified,
    /// LGE outside 2…254.
    LengthError,
}

/// Why a telegram in progress was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Dropped {
    /// The residual run time passed.
    ResidualTime,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Waiting for STX. `need_gap`: a start interval of silence must come first.
    Hunting { need_gap: bool },
    /// Receiving; the rest must be in by `deadline`.
    Receiving { deadline: Instant },
}

/// Character-by-character telegram assembly.
pub(crate) struct Receiver {
    settings: SerialSettings,
    start_interval: Duration,
    buf: [u8; MAX_TELEGRAM],
    len: usize,
    state: State,
    last_char: Option<Instant>,
    /// Net bytes expected before LGE arrives (the master knows its slave's structure).
    expected_net: usize,
    /// How late the port hands bytes over.
    delivery: Delivery,
}

impl Receiver {
    pub(crate) fn new(settings: SerialSettings) -> Self {
        Receiver {
            settings,
            start_interval: start_interval(&settings),
            buf: [0; MAX_TELEGRAM],
            len: 0,
            state: State::Hunting { need_gap: false },
            last_char: None,
            expected_net: MAX_NET,
            delivery: Delivery::new(&settings),
        }
    }

    /// The engine got `n` bytes in one read ([`Delivery::observe`]).
    pub(crate) fn observe_read(&mut self, now: Instant, n: usize) {
        self.delivery.observe(now, n);
    }

    /// The driver declared the port's latency ([`si_core::Engine::set_rx_latency`]).
    pub(crate) fn set_rx_latency(&mut self, latency: Duration) {
        self.delivery.declare(latency);
    }

    /// What the silence-judging timers add on this port (zero byte by byte).
    pub(crate) fn allowance(&self) -> Duration {
        self.delivery.allowance()
    }

    /// `status` with the adapter remedy once reads showed a packetising port
    /// ([`Delivery::annotate`]).
    pub(crate) fn annotate(&self, status: si_core::Status) -> si_core::Status {
        self.delivery.annotate(status)
    }

    /// The residual run time for `n` net bytes on this port: the manual's, plus the port's
    /// patience (zero byte by byte).
    fn residual(&self, n: usize) -> Duration {
        residual_run_time(&self.settings, n) + self.delivery.patience()
    }

    /// Net bytes to assume for the residual run time until LGE is in.
    pub(crate) fn expect_net(&mut self, n: usize) {
        self.expected_net = n.min(MAX_NET);
    }

    /// The next STX counts even without a preceding start interval (the master's own request
    /// ended the previous silence; over a pseudo-terminal the response may come at any time).
    pub(crate) fn accept_next_stx(&mut self) {
        self.state = State::Hunting { need_gap: false };
        self.len = 0;
    }

    /// Abandon any telegram in progress and require a start interval again.
    pub(crate) fn resync(&mut self) {
        self.state = State::Hunting { need_gap: true };
        self.len = 0;
    }

    /// When the line was last busy (end of the last character received).
    pub(crate) fn last_char(&self) -> Option<Instant> {
        self.last_char
    }

    /// The completed telegram (valid right after [`RxOutcome::Complete`]).
    pub(crate) fn telegram(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// True while a telegram is being received.
    pub(crate) fn is_receiving(&self) -> bool {
        matches!(self.state, State::Receiving { .. })
    }

    /// The residual-run-time deadline of a telegram in progress.
    pub(crate) fn deadline(&self) -> Option<Instant> {
        match self.state {
            State::Receiving { deadline } => Some(deadline),
            State::Hunting { .. } => None,
        }
    }

    /// A character arrived completely at `now`.
    pub(crate) fn push(&mut self, now: Instant, byte: u8) -> RxOutcome {
        let previous = self.last_char.replace(now);
        match self.state {
            State::Hunting { need_gap } => {
                // Silence before this character's start bit: arrival − one character − last end.
                let gap_ok = !need_gap
                    || match previous {
                        None => true,
                        Some(p) => {
                            now.saturating_since(p)
                                >= self.start_interval + self.settings.char_time()
                        }
                    };
                if byte == STX && gap_ok {
                    self.buf[0] = STX;
                    self.len = 1;
                    self.state = State::Receiving {
                        deadline: now + self.residual(self.expected_net),
                    };
                    RxOutcome::Pending
                } else {
                    self.state = State::Hunting { need_gap: true };
                    RxOutcome::StartNotIdentified
                }
            }
            State::Receiving { deadline } => {
                if self.len < MAX_TELEGRAM {
                    self.buf[self.len] = byte;
                    self.len += 1;
                }
                if self.len == 2 {
                    if !(2..=254).contains(&byte) {
                        self.resync();
                        return RxOutcome::LengthError;
                    }
                    let n = usize::from(byte) - 2;
                    // From STX's end: deadline − residual(assumed) + residual(n).
                    let stx_end = deadline
                        .as_micros()
                        .saturating_sub(self.residual(self.expected_net).as_micros());
                    self.state = State::Receiving {
                        deadline: Instant::from_micros(stx_end) + self.residual(n),
                    };
                }
                if self.len >= 2 && self.len == usize::from(self.buf[1]) + 2 {
                    self.state = State::Hunting { need_gap: true };
                    return RxOutcome::Complete;
                }
                RxOutcome::Pending
            }
        }
    }

    /// The UART reported an error instead of a character: the telegram is discarded.
    pub(crate) fn line_error(&mut self, now: Instant, _error: LineError) {
        self.last_char = Some(now);
        self.resync();
    }

    /// Check the residual run time; `Some` if a telegram in progress was dropped.
    pub(crate) fn timeout(&mut self, now: Instant) -> Option<Dropped> {
        match self.state {
            State::Receiving { deadline } if now >= deadline => {
                self.resync();
                Some(Dropped::ResidualTime)
            }
            _ => None,
        }
    }
}
