//! Noise peers for the "bound on every job" tests: a line that never carries a valid
//! answer, in the patterns the issue probed (silent, random bytes, one byte repeated, an
//! endless frame, a flood, noise that stops), and a direct driver that feeds an engine an
//! arbitrary noise stream in virtual time and says when its job ended.
//!
//! Both are Sans-IO: time is passed in, nothing sleeps, so a bound is asserted exactly.
//! [`facing`] is the set-up every engine crate's noise test starts from: its engine and a
//! noise peer wired point to point on the line simulator.

use bytes::Bytes;
use si_core::{Duration, Engine, Instant, Output, SerialSettings};
use si_sim::{Simulator, StationId};

/// Where a noise peer's bytes come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Pseudo-random bytes from a seed (reproducible).
    Random(u64),
    /// The same byte every time (the issue's "01H every 2 ms").
    Fixed(u8),
}

/// What a [`NoisePeer`] puts on the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Noise {
    /// Nothing at all (a partner that is not there).
    Silent,
    /// `burst` bytes every `every`. With `every` below the receiver's end-of-frame silence
    /// this is an endless frame: bytes that never form a frame end.
    Every {
        /// The period.
        every: Duration,
        /// Bytes per period.
        burst: usize,
        /// Which bytes.
        bytes: Source,
    },
    /// Back to back at line rate, forever: the next chunk as soon as the last has left.
    Flood(Source),
}

/// A station that transmits [`Noise`] from the start until `until` (forever if `None`), then
/// stays silent; it hears nothing.
#[derive(Debug)]
pub struct NoisePeer {
    noise: Noise,
    until: Option<Instant>,
    next: Option<Instant>,
    rng: u64,
    out: Option<Bytes>,
    /// Bytes sent so far.
    pub sent: u64,
}

/// Bytes per flood chunk: one USB packet's worth.
const FLOOD_CHUNK: usize = 64;

impl NoisePeer {
    /// A peer making `noise` until `until` (`None`: forever).
    pub fn new(noise: Noise, until: Option<Instant>) -> Self {
        let rng = match noise {
            Noise::Every {
                bytes: Source::Random(seed),
                ..
            }
            | Noise::Flood(Source::Random(seed)) => seed | 1,
            _ => 1,
        };
        NoisePeer {
            noise,
            until,
            next: (noise != Noise::Silent).then_some(Instant::ZERO),
            rng,
            out: None,
            sent: 0,
        }
    }

    fn byte(&mut self, source: Source) -> u8 {
        match source {
            Source::Fixed(b) => b,
            Source::Random(_) => {
                // xorshift64: reproducible, no dependency.
                self.rng ^= self.rng << 13;
                self.rng ^= self.rng >> 7;
                self.rng ^= self.rng << 17;
                (self.rng >> 24) as u8
            }
        }
    }

    fn emit(&mut self, now: Instant) {
        if self.until.is_some_and(|u| now >= u) {
            self.next = None;
            return;
        }
        let (n, source) = match self.noise {
            Noise::Silent => return,
            Noise::Every {
                every,
                burst,
                bytes,
            } => {
                self.next = Some(now + every);
                (burst, bytes)
            }
            // The next chunk when this one has left (tx-done).
            Noise::Flood(bytes) => {
                self.next = None;
                (FLOOD_CHUNK, bytes)
            }
        };
        let chunk: Vec<u8> = (0..n).map(|_| self.byte(source)).collect();
        self.sent += n as u64;
        self.out = Some(Bytes::from(chunk));
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

    fn handle_tx_done(&mut self, now: Instant) {
        if matches!(self.noise, Noise::Flood(_)) {
            self.emit(now);
        }
    }

    fn poll_output(&mut self) -> Output<()> {
        match self.out.take() {
            Some(b) => Output::Transmit(b),
            None => Output::Wait(self.next),
        }
    }
}

/// A named noise pattern for a test loop: [`NoisePeer::new`]`(noise, until)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pattern {
    /// What the assertion messages call it.
    pub name: &'static str,
    /// The noise.
    pub noise: Noise,
    /// When it stops (`None`: never).
    pub until: Option<Instant>,
}

/// The noise patterns, for a line with this character time: silent, random bytes
/// every 2 ms, 01H every 2 ms, an endless frame (a byte every two character times, never a
/// gap), a random, a 01H and a 02H (STX) flood, a flood that stops after 300 ms, and 01H every 2 ms for 5 s.
pub fn issue_patterns(char_time: Duration) -> Vec<Pattern> {
    let every = |every, bytes| Noise::Every {
        every,
        burst: 1,
        bytes,
    };
    let ms = Duration::from_millis;
    let p = |name, noise, until: Option<u64>| Pattern {
        name,
        noise,
        until: until.map(|ms| Instant::from_micros(ms * 1_000)),
    };
    vec![
        p("silent", Noise::Silent, None),
        p("random every 2 ms", every(ms(2), Source::Random(21)), None),
        p("01H every 2 ms", every(ms(2), Source::Fixed(0x01)), None),
        p(
            "endless frame",
            every(char_time.saturating_mul(2), Source::Random(5)),
            None,
        ),
        p("random flood", Noise::Flood(Source::Random(9)), None),
        p("01H flood", Noise::Flood(Source::Fixed(0x01)), None),
        p("02H (STX) flood", Noise::Flood(Source::Fixed(0x02)), None),
        p(
            "random flood then silence",
            Noise::Flood(Source::Random(3)),
            Some(300),
        ),
        p(
            "01H every 2 ms for 5 s",
            every(ms(2), Source::Fixed(0x01)),
            Some(5_000),
        ),
    ]
}

/// An engine facing a [`NoisePeer`] on the line simulator (see [`facing`]).
pub struct Facing<E> {
    /// The simulator, without a trace (hours of noise would fill memory), at instant zero.
    pub sim: Simulator,
    /// The engine under test, station "engine".
    pub engine: StationId<E>,
    /// The noise peer, station "noise"; [`Simulator::transmit`] on it puts chosen bytes on the
    /// line besides the pattern's.
    pub peer: StationId<NoisePeer>,
}

/// `engine` and a noise peer making `pattern`, both with `settings`, wired point to point on a
/// simulator seeded with `seed`, no time run yet. The noise tests of every engine crate start
/// here, so they face the same line: the peer starts at instant zero and hears nothing.
pub fn facing<E>(seed: u64, settings: SerialSettings, engine: E, pattern: Pattern) -> Facing<E>
where
    E: Engine + 'static,
    E::Event: 'static,
{
    let mut sim = Simulator::new(seed).without_trace();
    let engine = sim.add_station("engine", settings, engine);
    let peer = sim.add_station(
        "noise",
        settings,
        NoisePeer::new(pattern.noise, pattern.until),
    );
    sim.connect(engine, peer);
    Facing { sim, engine, peer }
}

/// A [`Pattern`] that puts nothing on the line, for tests that transmit chosen bytes through
/// [`Facing::peer`].
pub const SILENT: Pattern = Pattern {
    name: "silent",
    noise: Noise::Silent,
    until: None,
};

/// Wake-ups at one instant after which [`drive`] calls the engine a busy loop.
pub const MAX_STEPS_AT_ONE_INSTANT: u32 = 10_000;

/// Drive `engine` directly (no line model) with `chunks` of noise, each `(delay after the
/// previous one in µs, bytes)`, then silence; transmissions end `char_time` per byte later
/// (tx-done). Returns the instant and event at which `ended` first holds, or `None` if the
/// engine went idle with no deadline, `horizon` passed first, or the engine kept asking for
/// the same instant ([`MAX_STEPS_AT_ONE_INSTANT`] wake-ups without time moving: a busy loop).
pub fn drive<E: Engine>(
    engine: &mut E,
    start: Instant,
    chunks: &[(u64, Vec<u8>)],
    char_time: Duration,
    horizon: Instant,
    mut ended: impl FnMut(&E::Event) -> bool,
) -> Option<(Instant, E::Event)> {
    let mut now = start;
    let mut next_chunk = 0;
    let mut chunk_at = chunks
        .first()
        .map(|(d, _)| start + Duration::from_micros(*d));
    let mut tx_done: Option<Instant> = None;
    let mut same_instant = 0;
    loop {
        // Outputs first: an event may already end the job.
        let deadline = loop {
            match engine.poll_output() {
                Output::Event(e) if ended(&e) => return Some((now, e)),
                Output::Transmit(b) => {
                    let from = tx_done.unwrap_or(now).max(now);
                    tx_done = Some(from + char_time.saturating_mul(b.len() as u64));
                }
                Output::Wait(d) => break d,
                _ => {}
            }
        };
        let next = Instant::earliest(Instant::earliest(deadline, chunk_at), tx_done)?;
        if next <= now {
            same_instant += 1;
            if same_instant > MAX_STEPS_AT_ONE_INSTANT {
                return None;
            }
        } else {
            same_instant = 0;
        }
        now = now.max(next);
        if now > horizon {
            return None;
        }
        if tx_done.is_some_and(|t| now >= t) {
            tx_done = None;
            engine.handle_tx_done(now);
        }
        if chunk_at.is_some_and(|t| now >= t) {
            engine.handle_rx(now, &chunks[next_chunk].1);
            next_chunk += 1;
            chunk_at = chunks
                .get(next_chunk)
                .map(|(d, _)| now + Duration::from_micros(*d));
        }
        if deadline.is_some_and(|d| now >= d) {
            engine.handle_timeout(now);
        }
    }
}
