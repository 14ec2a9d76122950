//! A decoder fed character by character whose records come out in start order, as
//! `crate::monitor::decode_all` sorts them, without holding the whole trace's records.
//!
//! A decoder reports a frame when it ends, so a later short frame (a DLE) can be reported
//! before an earlier note. Records are held until the line has passed their start by
//! [`HORIZON`] `[derived]`: every timer the monitors judge (QVZ 2 s, the Modbus response
//! timeout, USS's response delay) and every frame they delimit end well within it, so the
//! order is the sorted one, and the memory is a minute of line at most.

use crate::monitor::reorder::Reorder;
use crate::monitor::{Decoder, LineChar, Record};
use crate::{Duration, Instant};

/// How long a record is held before it is handed on.
pub const HORIZON: Duration = Duration::from_millis(60_000);

/// A decoder and the records it has made but not yet handed on.
pub struct Ordered {
    /// The protocol's monitor.
    pub decoder: Box<dyn Decoder + Send>,
    /// By start, then the line's records before the engines' events (`--events`), then
    /// arrival.
    held: Reorder<Record>,
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
            held: Reorder::default(),
            scratch: Vec::new(),
            first: None,
            last: Instant::ZERO,
        }
    }

    fn hold(&mut self, class: u8, r: Record) {
        self.held.hold(r.start, class, r);
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
        while let Some(r) = self.held.pop_before(horizon) {
            each(r)?;
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
        while let Some(r) = self.held.pop() {
            each(r)?;
        }
        Ok(())
    }
}
