//! Cutting a character stream into frames by sender and silence, for the protocols whose frames
//! end at a gap (Modbus RTU, ASCII with the character delay criterion) or at a length (USS).

use super::LineChar;
use crate::{Duration, Instant, LineError};

/// A frame being collected, or a finished one.
#[derive(Debug, Clone, Default)]
pub struct Frame {
    /// Sender.
    pub from: Option<usize>,
    /// Receiver.
    pub to: Option<usize>,
    /// First character's end.
    pub start: Instant,
    /// Last character's end.
    pub end: Instant,
    /// The characters.
    pub bytes: Vec<u8>,
    /// Line errors met inside it.
    pub line_errors: Vec<LineError>,
    /// Longest judged gap between two of its characters.
    pub longest_gap: Duration,
}

/// Collects characters into frames; a frame ends when the sender changes, when the silence
/// reaches `end_gap`, when it holds `max_len` characters (a line that never pauses cannot grow
/// memory), or when the caller says so.
#[derive(Debug, Default)]
pub struct Framer {
    cur: Option<Frame>,
    last: Option<LineChar>,
    end_gap: Duration,
    max_len: usize,
}

impl Framer {
    /// A framer that ends frames at `end_gap` of silence or at `max_len` characters.
    pub fn new(end_gap: Duration, max_len: usize) -> Self {
        Framer {
            cur: None,
            last: None,
            end_gap,
            max_len: max_len.max(1),
        }
    }

    /// Feed `c`; returns the frame it ended (the character then starts a new one).
    pub fn push(&mut self, c: &LineChar) -> Option<Frame> {
        let gap = self
            .last
            .as_ref()
            .map(|l| c.at.saturating_since(l.at))
            .unwrap_or(Duration::from_secs(3600));
        let judged = super::line::gap(self.last.as_ref(), c);
        let ended = match &self.cur {
            Some(f) => {
                f.from != c.from
                    || gap >= self.end_gap
                    || f.bytes.len() + f.line_errors.len() >= self.max_len
            }
            None => false,
        };
        let done = if ended { self.cur.take() } else { None };
        let f = self.cur.get_or_insert_with(|| Frame {
            from: c.from,
            to: c.to,
            start: c.at,
            end: c.at,
            ..Frame::default()
        });
        if !f.bytes.is_empty() || !f.line_errors.is_empty() {
            if let Some(g) = judged {
                f.longest_gap = f.longest_gap.max(g);
            }
        }
        f.end = c.at;
        match c.item {
            Ok(b) => f.bytes.push(b),
            Err(e) => f.line_errors.push(e),
        }
        self.last = Some(c.clone());
        done
    }

    /// End the frame in progress if the line has been silent for the end gap by `now`.
    pub fn idle(&mut self, now: Instant) -> Option<Frame> {
        match &self.cur {
            Some(f) if now.saturating_since(f.end) >= self.end_gap => self.cur.take(),
            _ => None,
        }
    }

    /// End the frame in progress now.
    pub fn flush(&mut self) -> Option<Frame> {
        self.cur.take()
    }
}
