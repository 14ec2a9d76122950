//! Transmissions in flight: one record per burst instead of one queue entry per character.
//!
//! A burst is what a station's engine handed over in one `Output::Transmit` (or a scripted
//! [`Simulator::transmit`](super::Simulator::transmit)): its bytes, when its characters start
//! and end, one [`Cursor`] per receiver (its faults) and one [`Lane`] per distinct receive
//! latency, walking the characters in the order they reach the receivers. The event queue
//! holds one entry per lane, keyed by the (time, seq) of its next delivery; popping it delivers
//! that character and moves the key on. So a 200-byte block on a 32-station bus costs one
//! queue entry, not 6 400, and an hour of saturated traffic runs in a fraction of a second.
//!
//! Ordering is exactly that of one entry per character and receiver: at transmit time the
//! burst reserves two sequence numbers per character and receiver (the character, then an
//! inserted noise character) in the order the characters used to be scheduled (character by
//! character, receiver by receiver), so ties with every other happening resolve as before.
//! Receivers with the same latency get each character at the same instant, so walking them
//! character by character, receiver by receiver, *is* their (time, seq) order: one lane.
//! Seeded faults are drawn at transmit time in that same order and kept as [`Mod`]s.

use si_core::LineError;
use si_core::SerialSettings;
use si_core::{Duration, Instant};

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

/// One receiver of a burst.
#[derive(Debug)]
pub(super) struct Cursor {
    /// The receiving station.
    pub to: usize,
    /// The receiver runs another character format: every character is a framing error.
    pub mismatch: bool,
    /// Extra latency of the receiver's faults, fixed when the burst was sent.
    pub latency: Duration,
    /// Fault outcomes for this receiver, by ascending `k`.
    pub mods: Vec<Mod>,
    /// The first of `mods` not yet passed.
    pub mod_at: usize,
}

impl Cursor {
    /// The fault outcome for character `k`, if any (`k` never behind `mod_at`).
    fn mod_for(&self, k: u32) -> Option<Mod> {
        self.mods.get(self.mod_at).filter(|m| m.k == k).copied()
    }
}

/// `n × bits × 10⁶` as `q × baud + r`: [`SerialSettings::chars_time`] stepped one character at
/// a time without a division.
#[derive(Debug, Default, Clone, Copy)]
struct CharClock {
    q: u64,
    r: u64,
}

/// A receiver as its lane walks it: what the short path needs without a look at its cursor.
#[derive(Debug, Clone, Copy)]
struct Member {
    /// Index of its cursor, which is also its rank among the burst's receivers.
    cursor: u32,
    /// The receiving station.
    to: usize,
    /// It runs another character format.
    mismatch: bool,
}

/// The receivers of a burst that share one latency, walked character by character, receiver
/// by receiver: their (time, seq) order.
#[derive(Debug, Default)]
pub(super) struct Lane {
    /// Their latency.
    latency: Duration,
    /// Indices into the burst's cursors, ascending.
    members: Vec<Member>,
    /// The character being delivered.
    k: u32,
    /// The member receiving it next (index into `members`).
    at_member: usize,
    /// The next delivery is the noise character inserted after the current one.
    noise_next: bool,
    /// End of character `k` from the burst's start of run.
    end: CharClock,
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
    /// Lanes (only the first `lanes` are in use).
    lane_pool: Vec<Lane>,
    /// Lanes in use.
    lanes: usize,
    /// Lanes that still have something to deliver.
    pub live: usize,
    /// Ranges of characters (`start..end`) garbled by a collision on the bus.
    pub garbled: Vec<(u32, u32)>,
    /// `bits × 10⁶` as `q × baud + r`: one character's step of a [`CharClock`].
    step: CharClock,
    /// Some receiver has fault outcomes (else every delivery takes the short path).
    has_mods: bool,
}

impl Burst {
    /// Start filling this (pooled) burst for a new transmission.
    #[allow(clippy::too_many_arguments)]
    pub fn begin(
        &mut self,
        sender: usize,
        bus: Option<usize>,
        t0: Instant,
        first: u64,
        settings: SerialSettings,
        bytes: &[u8],
        seq_base: u64,
        receivers: usize,
    ) {
        self.sender = sender;
        self.bus = bus;
        self.t0 = t0;
        self.first = first;
        self.settings = settings;
        self.bytes.clear();
        self.bytes.extend_from_slice(bytes);
        self.seq_base = seq_base;
        self.stride = 2 * receivers as u64;
        self.receivers = 0;
        self.lanes = 0;
        self.live = 0;
        self.garbled.clear();
        let (bits, baud) = self.clock_units();
        self.step = CharClock {
            q: bits / baud,
            r: bits % baud,
        };
    }

    /// `bits × 10⁶` and the baud rate (at least 1).
    fn clock_units(&self) -> (u64, u64) {
        let bits = u64::from(self.settings.bits_per_char()).saturating_mul(1_000_000);
        (bits, u64::from(self.settings.baud()).max(1))
    }

    /// Add the next receiver (in the order the characters used to be scheduled).
    pub fn add_receiver(&mut self, to: usize, latency: Duration, mismatch: bool) {
        let i = self.receivers;
        self.receivers += 1;
        match self.cursors.get_mut(i) {
            Some(c) => {
                c.to = to;
                c.mismatch = mismatch;
                c.latency = latency;
                c.mods.clear();
                c.mod_at = 0;
            }
            None => self.cursors.push(Cursor {
                to,
                mismatch,
                latency,
                mods: Vec::new(),
                mod_at: 0,
            }),
        }
    }

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

    /// Group the receivers into lanes by latency and put each at its first delivery; the
    /// number of lanes with something to deliver (also in `live`). Call after the faults are
    /// drawn.
    pub fn start_lanes(&mut self) -> usize {
        for i in 0..self.receivers {
            let latency = self.cursors[i].latency;
            let lane = match self.lane_pool[..self.lanes]
                .iter()
                .position(|l| l.latency == latency)
            {
                Some(lane) => lane,
                None => {
                    let lane = self.lanes;
                    self.lanes += 1;
                    if lane == self.lane_pool.len() {
                        self.lane_pool.push(Lane::default());
                    }
                    let (bits, baud) = self.clock_units();
                    let n = (self.first + 1).saturating_mul(bits);
                    let l = &mut self.lane_pool[lane];
                    l.latency = latency;
                    l.members.clear();
                    l.k = 0;
                    l.at_member = 0;
                    l.noise_next = false;
                    l.end = CharClock {
                        q: n / baud,
                        r: n % baud,
                    };
                    lane
                }
            };
            let c = &self.cursors[i];
            let member = Member {
                cursor: i as u32,
                to: c.to,
                mismatch: c.mismatch,
            };
            self.lane_pool[lane].members.push(member);
        }
        self.has_mods = self.cursors[..self.receivers]
            .iter()
            .any(|c| !c.mods.is_empty());
        self.live = 0;
        for lane in 0..self.lanes {
            if self.settle(lane) {
                self.live += 1;
            }
        }
        self.live
    }

    /// Lanes in use.
    pub fn lanes(&self) -> usize {
        self.lanes
    }

    /// The key of lane `lane`'s first delivery, `None` if it has nothing to deliver.
    pub fn key_if_live(&self, lane: usize) -> Option<Key> {
        (self.lane_pool[lane].k < self.len()).then(|| self.key(lane))
    }

    /// The key of lane `lane`'s next delivery.
    #[inline]
    pub fn key(&self, lane: usize) -> Key {
        let l = &self.lane_pool[lane];
        let end = l.end.q + u64::from(l.end.r > 0);
        let at = self.t0 + Duration::from_micros(end) + l.latency;
        let rank = u64::from(l.members[l.at_member].cursor);
        let seq = self.seq_base + self.stride * u64::from(l.k) + 2 * rank + u64::from(l.noise_next);
        (at, seq)
    }

    /// Move lane `lane` on by one (character, receiver) pair.
    #[inline]
    fn next_pair(&mut self, lane: usize) {
        let step = self.step;
        let baud = u64::from(self.settings.baud()).max(1);
        let l = &mut self.lane_pool[lane];
        l.at_member += 1;
        if l.at_member == l.members.len() {
            l.at_member = 0;
            l.k += 1;
            l.end.q = l.end.q.saturating_add(step.q);
            l.end.r += step.r;
            if l.end.r >= baud {
                l.end.r -= baud;
                l.end.q = l.end.q.saturating_add(1);
            }
        }
    }

    /// Move lane `lane` past dropped characters; false when it has nothing left to deliver.
    fn settle(&mut self, lane: usize) -> bool {
        let len = self.len();
        loop {
            let l = &self.lane_pool[lane];
            if l.k >= len {
                return false;
            }
            if l.noise_next {
                return true;
            }
            let k = l.k;
            let c = &mut self.cursors[l.members[l.at_member].cursor as usize];
            match c.mod_for(k) {
                Some(m) if m.drop => c.mod_at += 1,
                _ => return true,
            }
            self.next_pair(lane);
        }
    }

    /// Deliver lane `lane`'s next character: the receiver, what it receives, and the lane's
    /// next key (`None` when it is done).
    #[inline]
    pub fn advance(&mut self, lane: usize) -> (usize, Result<u8, LineError>, Option<Key>) {
        if !self.has_mods {
            // No faults drawn: every character arrives as sent (or garbled, or mismatched).
            let l = &self.lane_pool[lane];
            let k = l.k;
            let member = l.members[l.at_member];
            let to = member.to;
            let item = if member.mismatch || self.is_garbled(k) {
                Err(LineError::Framing)
            } else {
                Ok(self.bytes[k as usize])
            };
            self.next_pair(lane);
            return (to, item, self.key_if_live(lane));
        }
        let l = &mut self.lane_pool[lane];
        let k = l.k;
        let noise = l.noise_next;
        let c = &mut self.cursors[l.members[l.at_member].cursor as usize];
        let m = c.mod_for(k);
        let to = c.to;
        let item = if noise {
            l.noise_next = false;
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
                if m.noise.is_some() {
                    l.noise_next = true;
                } else {
                    c.mod_at += 1;
                }
            }
            if self.is_garbled(k) {
                item = Err(LineError::Framing);
            }
            item
        };
        if !self.lane_pool[lane].noise_next {
            self.next_pair(lane);
        }
        let next = self.settle(lane).then(|| self.key(lane));
        (to, item, next)
    }
}

impl Burst {
    /// Character `k` collided on the bus.
    #[inline]
    fn is_garbled(&self, k: u32) -> bool {
        !self.garbled.is_empty() && self.garbled.iter().any(|&(a, e)| (a..e).contains(&k))
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
