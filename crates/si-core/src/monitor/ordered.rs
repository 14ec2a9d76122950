//! A decoder fed character by character whose records come out in start order, as
//! `crate::monitor::decode_all` sorts them, without holding the whole trace's records.
//!
//! A decoder reports a frame when it ends, so a later short frame (a DLE) can be reported
//! before an earlier note. Records are held until the line has passed their start by
//! [`HORIZON`] `[derived]`: every timer the monitors judge (QVZ 2 s, the Modbus response
//! timeout, USS's response delay) and every frame they delimit end well within it, so the
//! order is the sorted one, and the memory is a minute of line at most.

use crate::monitor::{Decoder, LineChar, Record};
use crate::{Duration, Instant};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// How long a record is held before it is handed on.
pub const HORIZON: Duration = Duration::from_millis(60_000);

/// A record waiting for its turn: by start, then the line's records before the engines'
/// events (`--events`), then arrival.
struct Held {
    key: (Instant, u8, u64),
    r: Record,
}

impl PartialEq for Held {
    fn eq(&self, other: &Self) -> bool {
        self.key == other.key
    }
}
impl Eq for Held {}
impl PartialOrd for Held {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Held {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.key.cmp(&other.key)
    }
}

/// A decoder and the records it has made but not yet handed on.
pub struct Ordered {
    /// The protocol's monitor.
    pub decoder: Box<dyn Decoder + Send>,
    held: BinaryHeap<Reverse<Held>>,
    seq: u64,
    scratch: Vec<Record>,
    /// The first character's time.
    pub first: Option<Instant>,
    /// The last character's time.
    pub last: Instant,
}

impl Ordered {
    /// Around `decoder`.
    pub fn new(decoder: Box<dyn Decoder + Send>) -> Self {
        Ordered {
            decoder,
            held: BinaryHeap::new(),
            seq: 0,
            scratch: Vec::new(),
            first: None,
            last: Instant::ZERO,
        }
    }

    fn hold(&mut self, class: u8, r: Record) {
        self.seq += 1;
        self.held.push(Reverse(Held {
            key: (r.start, class, self.seq),
            r,
        }));
    }

    /// Feed one character; records whose turn has come go to `each`.
    pub fn push<E>(
        &mut self,
        c: &LineChar,
        each: &mut impl FnMut(Record) -> Result<(), E>,
    ) -> Result<(), E> {
        self.first.get_or_insert(c.at);
        self.last = c.at;
        let mut out = std::mem::take(&mut self.scratch);
        self.decoder.push(c, &mut out);
        for r in out.drain(..) {
            self.hold(0, r);
        }
        self.scratch = out;
        let horizon = Instant::from_micros(c.at.as_micros().saturating_sub(HORIZON.as_micros()));
        while let Some(Reverse(h)) = self.held.peek() {
            if h.key.0 >= horizon {
                break;
            }
            if let Some(Reverse(h)) = self.held.pop() {
                each(h.r)?;
            }
        }
        Ok(())
    }

    /// A record that did not come from the decoder (an engine's event), placed after the
    /// line's records of the same instant.
    pub fn event(&mut self, r: Record) {
        self.hold(1, r);
    }

    /// The end of the line at `end`: the decoder finishes, and every record is handed on.
    pub fn finish<E>(
        &mut self,
        end: Instant,
        each: &mut impl FnMut(Record) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut out = Vec::new();
        self.decoder.finish(end, &mut out);
        for r in out {
            self.hold(0, r);
        }
        while let Some(Reverse(h)) = self.held.pop() {
            each(h.r)?;
        }
        Ok(())
    }
}
