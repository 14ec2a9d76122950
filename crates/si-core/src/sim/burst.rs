//! Transmissions in flight: one record per burst instead of one queue entry per character.
//!
//! A burst is what a station's engine handed over in one `Output::Transmit` (or a scripted
//! [`Simulator::transmit`](super::Simulator::transmit)): its bytes, when its characters start
//! and end, and one [`Cursor`] per receiver saying which character that receiver gets next.
//! The event queue holds one entry per cursor, keyed by the (time, seq) of that cursor's next
//! delivery; popping it delivers the character and moves the key on. So a 200-byte block costs
//! one queue entry per receiver instead of 200, and the queue stays small enough that an hour
//! of saturated traffic runs in a fraction of a second.
//!
//! Ordering is exactly that of one entry per character: at transmit time the burst reserves
//! two sequence numbers per character and receiver (the character, then an inserted noise
//! character), in the order the characters used to be scheduled (character by character,
//! receiver by receiver), so ties with every other happening resolve as before. Seeded faults
//! are drawn at transmit time in that same order and kept as [`Mod`]s on the cursor.

use crate::sansio::LineError;
use crate::serial::SerialSettings;
use crate::time::{Duration, Instant};

/// When a happening is processed: time first, then the order it was scheduled in.
pub(super) type Key = (Instant, u64);

/// What the seeded faults did to one character for one receiver (drawn at transmit time).
#[derive(Debug, Clone, Copy)]
pub(super) struct Mod {
    /// Index of the character in its burst.
    pub k: u32,
    /// Lost on the way: nothing arrives.
    pub drop: bool,
    /// Bits inverted (a random bit flip and/or a scripted corruption).
    pub xor: u8,
    /// A random character arriving right after this one.
    pub noise: Option<u8>,
}

/// One receiver's progress through a burst.
#[derive(Debug)]
pub(super) struct Cursor {
    /// The receiving station.
    pub to: usize,
    /// Position among the burst's receivers (the seq offset within a character).
    pub rank: u64,
    /// Extra latency of the receiver's faults, fixed when the burst was sent.
    pub latency: Duration,
    /// The receiver runs another character format: every character is a framing error.
    pub mismatch: bool,
    /// The next character to deliver.
    pub k: u32,
    /// The next delivery is the noise character inserted after character `k`.
    pub noise_next: bool,
    /// Fault outcomes for this receiver, by ascending `k`.
    pub mods: Vec<Mod>,
    /// The first of `mods` not yet passed.
    pub mod_at: usize,
}

/// One transmission in flight. Kept in a pool by the simulator, so its buffers are reused.
#[derive(Debug, Default)]
pub(super) struct Burst {
    /// The transmitting station.
    pub sender: usize,
    /// The RS-485 bus it is on, if any (for collisions).
    pub bus: Option<usize>,
    /// Start of the sender's continuous run of characters this burst belongs to.
    pub t0: Instant,
    /// Index of this burst's first character within that run.
    pub first: u64,
    /// The sender's character format.
    pub settings: SerialSettings,
    /// The characters.
    pub bytes: Vec<u8>,
    /// Seq of character 0 for receiver 0.
    pub seq_base: u64,
    /// Seqs reserved per character: two per receiver.
    pub stride: u64,
    /// One per receiver (only the first `receivers` are in use; the rest are kept for reuse).
    pub cursors: Vec<Cursor>,
    /// Cursors in use.
    pub receivers: usize,
    /// Cursors that still have something to deliver.
    pub live: usize,
    /// Ranges of characters (`start..end`) garbled by a collision on the bus.
    pub garbled: Vec<(u32, u32)>,
}

impl Burst {
    /// When character `k` starts on the line.
    pub fn char_start(&self, k: u32) -> Instant {
        self.t0 + self.settings.chars_time(self.first + u64::from(k))
    }

    /// When character `k` has arrived completely (before any latency).
    pub fn char_end(&self, k: u32) -> Instant {
        self.char_start(k + 1)
    }

    /// First and last instant of the whole burst on the line.
    pub fn span(&self) -> (Instant, Instant) {
        (self.char_start(0), self.char_start(self.len()))
    }

    /// Number of characters.
    pub fn len(&self) -> u32 {
        self.bytes.len() as u32
    }

    /// The characters overlapping the interval `from..to` (as `start..end` indices): those
    /// starting before `to` and ending after `from`.
    pub fn overlapping(&self, from: Instant, to: Instant) -> (u32, u32) {
        let lo = partition_point(self.len(), |k| self.char_end(k) <= from);
        let hi = partition_point(self.len(), |k| self.char_start(k) < to);
        (lo, hi.max(lo))
    }

    /// Reset cursor `i` for a new burst (keeping its buffer).
    pub fn reset_cursor(&mut self, i: usize, to: usize, latency: Duration, mismatch: bool) {
        let c = Cursor {
            to,
            rank: i as u64,
            latency,
            mismatch,
            k: 0,
            noise_next: false,
            mods: Vec::new(),
            mod_at: 0,
        };
        match self.cursors.get_mut(i) {
            Some(old) => {
                let mut mods = core::mem::take(&mut old.mods);
                mods.clear();
                *old = Cursor { mods, ..c };
            }
            None => self.cursors.push(c),
        }
    }

    /// The key of cursor `i`'s next delivery.
    pub fn key(&self, i: usize) -> Key {
        let c = &self.cursors[i];
        let at = self.char_end(c.k) + c.latency;
        let seq =
            self.seq_base + self.stride * u64::from(c.k) + 2 * c.rank + u64::from(c.noise_next);
        (at, seq)
    }

    /// Move cursor `i` past dropped characters; its next key, or `None` when it is done.
    pub fn settle(&mut self, i: usize) -> Option<Key> {
        let len = self.len();
        let c = &mut self.cursors[i];
        while c.k < len
            && !c.noise_next
            && c.mods.get(c.mod_at).is_some_and(|m| m.k == c.k && m.drop)
        {
            c.k += 1;
            c.mod_at += 1;
        }
        (c.k < len).then(|| self.key(i))
    }

    /// Deliver cursor `i`'s next character: the receiver, what it receives, and the cursor's
    /// next key (`None` when it is done).
    pub fn advance(&mut self, i: usize) -> (usize, Result<u8, LineError>, Option<Key>) {
        let c = &mut self.cursors[i];
        let k = c.k;
        let m = c.mods.get(c.mod_at).filter(|m| m.k == k).copied();
        let item = if c.noise_next {
            c.noise_next = false;
            c.k += 1;
            c.mod_at += 1;
            Ok(m.and_then(|m| m.noise).unwrap_or_default())
        } else {
            let mut item = if c.mismatch {
                Err(LineError::Framing)
            } else {
                Ok(self.bytes[k as usize])
            };
            if let Some(m) = m {
                item = item.map(|b| b ^ m.xor);
            }
            if self.garbled.iter().any(|&(a, e)| (a..e).contains(&k)) {
                item = Err(LineError::Framing);
            }
            match m {
                Some(m) if m.noise.is_some() => c.noise_next = true,
                Some(_) => {
                    c.k += 1;
                    c.mod_at += 1;
                }
                None => c.k += 1,
            }
            item
        };
        let to = c.to;
        (to, item, self.settle(i))
    }
}

/// The first `k` in `0..n` for which `pred` is false (`pred` true then false along `k`).
fn partition_point(n: u32, pred: impl Fn(u32) -> bool) -> u32 {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}
