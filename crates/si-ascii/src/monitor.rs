//! Passive ASCII-driver decoding ([ET200S SI] §2.8): frames end by the
//! configured criterion — the character delay time (the default), end-of-text characters, or
//! a fixed length (`crate::frame::Cutter` decides the last two) — and XON/XOFF characters
//! are shown as control characters when flow control is on.
//!
//! [`Params::from_config`] takes the criterion, the character delay time and the XON/XOFF
//! characters from the link's own [`crate::Config`], so the monitor cuts frames as the link does.
//!
//! ```
//! use si_ascii::config::EndCriterion;
//! use si_ascii::monitor::{Monitor, Params};
//! use si_core::monitor::{decode_all, LineChar};
//! use si_core::Instant;
//!
//! let config = si_ascii::Config { end: EndCriterion::EndChars { first: b'\r', second: b'\n' }, ..Default::default() };
//! let chars: Vec<LineChar> = b"AB\r\nCD\r\n"
//!     .iter()
//!     .enumerate()
//!     .map(|(k, &b)| LineChar { at: Instant::from_micros(1_146 * (k as u64 + 1)), from: Some(0), to: Some(1), item: Ok(b), exact: true })
//!     .collect();
//! let mut monitor = Monitor::new(Params::from_config(&config));
//! let records = decode_all(&mut monitor, &chars, Instant::from_micros(100_000));
//! assert_eq!(records.len(), 2);
//! assert_eq!(records[0].bytes, b"AB\r\n");
//! ```

use crate::config::{EndCriterion, FlowControl};
use crate::frame::{Cut, Cutter};
use si_core::monitor::framer::Framer;
use si_core::monitor::{ms, Counters, Decoder, Flag, Kind, LineChar, Record};
use si_core::{Duration, Instant};

/// What the listener judges against.
#[derive(Debug, Clone, Copy)]
pub struct Params {
    /// The end criterion.
    pub end: EndCriterion,
    /// Character delay time: ends frames under [`EndCriterion::CharDelay`], and is the longest
    /// allowed gap inside a frame otherwise.
    pub char_delay: Duration,
    /// XON/XOFF characters, if flow control is on.
    pub xon_xoff: Option<(u8, u8)>,
    /// The longest frame ([`Config::max_frame_len`](crate::Config::max_frame_len)); a longer
    /// one is flagged as the link would report it (0850H).
    pub max_frame_len: usize,
}

impl Params {
    /// The criterion, character delay time and flow-control characters a link with `config`
    /// runs with ([ET200S SI] §2.9, Table 2-10).
    pub fn from_config(config: &crate::Config) -> Params {
        Params {
            end: config.end,
            char_delay: config.char_delay,
            xon_xoff: (config.flow_control == FlowControl::XonXoff)
                .then_some((config.xon_xoff.xon, config.xon_xoff.xoff)),
            max_frame_len: config.max_frame(),
        }
    }
}

/// The ASCII listener.
pub struct Monitor {
    p: Params,
    framer: Framer,
    cutter: Cutter,
    counters: Counters,
}

impl Monitor {
    /// A listener with these parameters.
    pub fn new(p: Params) -> Self {
        let mut counters = Counters::default();
        counters.declare(&["frames", "line errors", "frames too long", "XON", "XOFF"]);
        Monitor {
            p,
            framer: Framer::new(p.char_delay, p.max_frame_len + 1),
            cutter: Cutter::new(p.end, p.max_frame_len),
            counters,
        }
    }

    fn frame(
        &mut self,
        f: si_core::monitor::framer::Frame,
        cut_by_gap: bool,
        out: &mut Vec<Record>,
    ) {
        self.cutter.reset();
        if f.bytes.is_empty() && f.line_errors.is_empty() {
            return;
        }
        self.counters.bump("frames");
        let mut r = Record::new(Kind::Frame, f.start, f.end, f.from)
            .labelled(format!("frame {} B", f.bytes.len()), printable(&f.bytes));
        r.to = f.to;
        r.bytes = f.bytes;
        for e in &f.line_errors {
            self.counters.bump("line errors");
            r.flags
                .push(Flag::error(format!("{e:?} error in the frame")));
        }
        if cut_by_gap && self.p.end != EndCriterion::CharDelay {
            r.flags.push(Flag::error(format!(
                "character delay time {} exceeded before the end criterion (STATUS 16#0806)",
                ms(self.p.char_delay)
            )));
        }
        out.push(r);
    }
}

/// Text with control characters in angle brackets: `Hello<CR><LF>`.
fn printable(bytes: &[u8]) -> String {
    let mut s = String::new();
    for &b in bytes {
        match b {
            0x20..=0x7E => s.push(b as char),
            0x02 => s.push_str("<STX>"),
            0x03 => s.push_str("<ETX>"),
            0x0A => s.push_str("<LF>"),
            0x0D => s.push_str("<CR>"),
            _ => s.push_str(&format!("<{b:02X}>")),
        }
    }
    s
}

impl Decoder for Monitor {
    fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
        if let Some(f) = self.framer.idle(c.at) {
            self.frame(f, true, out);
        }
        if let (Some((xon, xoff)), Ok(b)) = (self.p.xon_xoff, c.item) {
            if b == xon || b == xoff {
                let name = if b == xon { "XON" } else { "XOFF" };
                self.counters.bump(name);
                let mut r = Record::new(Kind::Control, c.at, c.at, c.from).labelled(
                    name,
                    if b == xon {
                        "resume sending"
                    } else {
                        "stop sending"
                    },
                );
                r.to = c.to;
                r.bytes.push(b);
                out.push(r);
                return;
            }
        }
        if let Some(f) = self.framer.push(c) {
            let by_gap = f.from == c.from;
            self.frame(f, by_gap, out);
        }
        if let Ok(b) = c.item {
            match self.cutter.push(b) {
                Cut::Continue => {}
                Cut::Complete => {
                    if let Some(f) = self.framer.flush() {
                        self.frame(f, false, out);
                    }
                }
                Cut::TooLong => {
                    self.counters.bump("frames too long");
                    if let Some(f) = self.framer.flush() {
                        let at = f.end;
                        self.frame(f, false, out);
                        if let Some(last) = out.last_mut() {
                            last.flags.push(Flag::error(format!(
                                "frame longer than {} characters (STATUS 16#0850)",
                                self.p.max_frame_len
                            )));
                            let _ = at;
                        }
                    }
                }
            }
        }
    }

    fn idle(&mut self, now: Instant, out: &mut Vec<Record>) {
        if let Some(f) = self.framer.idle(now) {
            self.frame(f, true, out);
        }
    }

    fn finish(&mut self, _now: Instant, out: &mut Vec<Record>) {
        if let Some(f) = self.framer.flush() {
            let by_delay = self.p.end == EndCriterion::CharDelay;
            self.frame(f, !by_delay, out);
        }
    }

    fn counters(&self) -> &Counters {
        &self.counters
    }
}
