//! A noise peer for the line simulator: a station that sends what a broken or hostile partner
//! sends, so a test can show that every job of an engine ends within its bound whatever the line
//! does (issue 21, "A bound on every job"): silence, random characters, an endless frame, a flood,
//! and noise that stops.
//!
//! ```
//! use si_core::sim::Simulator;
//! use si_core::{Duration, Instant, SerialSettings};
//! use si_testkit::noise::{Noise, NoisePeer};
//!
//! let line = SerialSettings::default();
//! let mut sim = Simulator::new(1);
//! let peer = sim.add_station("noise", line, NoisePeer::new(Noise::Flood, line, 7));
//! let listener = sim.add_station("host", line, NoisePeer::new(Noise::Silent, line, 0));
//! sim.connect(peer, listener);
//! sim.run_until(Instant::from_micros(100_000));
//! // 100 ms of 9600 8E1 back to back: about 87 characters.
//! assert!(sim.trace().received("host").len() >= 80);
//! ```

use bytes::Bytes;
use si_core::sim::Simulator;
use si_core::{Duration, Engine, Instant, Output, SerialSettings};

/// Steps `sim` one happening at a time while `busy` holds (a job is running) and returns the
/// instant it stopped holding. Panics when it still holds after `limit` (the job outlived its
/// bound) or when nothing is scheduled any more although it holds (the job hangs).
pub fn run_while(
    sim: &mut Simulator,
    limit: Instant,
    mut busy: impl FnMut(&Simulator) -> bool,
) -> Instant {
    while busy(sim) {
        assert!(
            sim.now() <= limit,
            "the job still runs at {} (bound {limit})",
            sim.now()
        );
        assert!(
            sim.step(),
            "the job runs with nothing scheduled at {}",
            sim.now()
        );
    }
    assert!(
        sim.now() <= limit,
        "the job ended at {}, after its bound {limit}",
        sim.now()
    );
    sim.now()
}

/// What the peer sends.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Noise {
    /// Nothing at all: a partner that is off or not connected.
    Silent,
    /// One random character every `every` (e.g. 2 ms), the rest of the time quiet.
    Random {
        /// The spacing between the starts of two characters.
        every: Duration,
    },
    /// `first` once, then `then` over and over, back to back: a frame that never ends (e.g.
    /// 3964(R)'s `STX` and then data for ever, or `DLE`-doubled data with no `DLE ETX`).
    Endless {
        /// Sent once at the start.
        first: Vec<u8>,
        /// Repeated for ever after it (must not be empty).
        then: Vec<u8>,
    },
    /// Random characters back to back, as fast as the line carries them.
    Flood,
    /// `noise` until `for_` has passed, then silence.
    ThenSilence {
        /// The noise before the silence.
        noise: Box<Noise>,
        /// How long the noise lasts from the peer's start.
        for_: Duration,
    },
}

impl Noise {
    /// The five patterns of issue 21, with `STX`-like framing bytes for the endless frame
    /// given by the caller: silent, random every 2 ms, endless, flood, and random for
    /// `noise_for` then silence.
    pub fn issue_21_patterns(first: &[u8], then: &[u8], noise_for: Duration) -> Vec<Noise> {
        let random = Noise::Random {
            every: Duration::from_millis(2),
        };
        vec![
            Noise::Silent,
            random.clone(),
            Noise::Endless {
                first: first.to_vec(),
                then: then.to_vec(),
            },
            Noise::Flood,
            Noise::ThenSilence {
                noise: Box::new(random),
                for_: noise_for,
            },
        ]
    }
}

/// Characters the flood and the endless frame hand to the line at a time.
const CHUNK: usize = 16;

/// A station that sends [`Noise`] and ignores what it receives. Its events are never emitted.
#[derive(Debug)]
pub struct NoisePeer {
    pattern: Noise,
    settings: SerialSettings,
    rng: u64,
    /// When the next characters go out; `None` once the peer is silent for good.
    next: Option<Instant>,
    /// The end of the noise ([`Noise::ThenSilence`]), fixed at the first wake-up.
    stop: Option<Instant>,
    started: bool,
    pending: Option<Bytes>,
    /// Where the endless frame's repeated part continues.
    offset: usize,
}

impl NoisePeer {
    /// A peer sending `pattern` on a line with `settings` from the simulation's start; `seed`
    /// makes the random characters reproducible.
    pub fn new(pattern: Noise, settings: SerialSettings, seed: u64) -> NoisePeer {
        let next = (pattern != Noise::Silent).then_some(Instant::ZERO);
        NoisePeer {
            pattern,
            settings,
            rng: seed ^ 0x9E37_79B9_7F4A_7C15,
            next,
            stop: None,
            started: false,
            pending: None,
            offset: 0,
        }
    }

    /// SplitMix64: small, reproducible, good enough for noise.
    fn random_byte(&mut self) -> u8 {
        self.rng = self.rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        (z ^ (z >> 31)) as u8
    }

    fn emit(&mut self, now: Instant) {
        let mut pattern = &self.pattern;
        if let Noise::ThenSilence { noise, for_ } = pattern {
            let stop = *self.stop.get_or_insert(now + *for_);
            if now >= stop {
                self.next = None;
                return;
            }
            pattern = noise;
        }
        let (bytes, wait) = match pattern.clone() {
            Noise::Silent | Noise::ThenSilence { .. } => {
                self.next = None;
                return;
            }
            Noise::Random { every } => (vec![self.random_byte()], every),
            Noise::Flood => {
                let chunk: Vec<u8> = (0..CHUNK).map(|_| self.random_byte()).collect();
                let wait = self.settings.chars_time(CHUNK as u64);
                (chunk, wait)
            }
            Noise::Endless { first, then } => {
                let mut chunk = Vec::with_capacity(CHUNK + first.len());
                if !self.started {
                    chunk.extend_from_slice(&first);
                }
                for _ in 0..CHUNK {
                    if let Some(&b) = then.get(self.offset % then.len().max(1)) {
                        chunk.push(b);
                    }
                    self.offset = self.offset.wrapping_add(1);
                }
                let wait = self.settings.chars_time(chunk.len() as u64);
                (chunk, wait)
            }
        };
        self.started = true;
        self.pending = Some(Bytes::from(bytes));
        self.next = Some(now + wait);
    }
}

impl Engine for NoisePeer {
    type Event = ();

    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}

    fn handle_timeout(&mut self, now: Instant) {
        if self.next.is_some_and(|t| now >= t) {
            self.emit(now);
        }
    }

    fn poll_output(&mut self) -> Output<()> {
        match self.pending.take() {
            Some(bytes) => Output::Transmit(bytes),
            None => Output::Wait(self.next),
        }
    }
}
