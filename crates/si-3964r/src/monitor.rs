//! Passive 3964(R) decoding ([ET200S SI] §2.7): connection setup (STX → DLE),
//! the block with its DLE doubling, `DLE ETX` and BCC, the acknowledgement (DLE or NAK), and
//! the timers a listener can judge: the character delay time ZVZ between block characters and
//! the acknowledgement delay time QVZ after STX and after the block ([ET200S SI] §2.7, Table 2-11).
//!
//! The timers are the link's own ([`Params::from_config`] takes them from a
//! [`crate::Config`]: [`crate::Config::char_delay`] and [`crate::Config::ack_delay`]), so the
//! monitor judges a line by the values the engine runs with.
//!
//! A layer that rides on 3964(R) blocks names a [`Payload`] decoder for the block's user data
//! (`si_rk512::monitor` does so for RK 512 telegrams, [CP 341]).
//!
//! ```
//! use si_3964r::monitor::{Monitor, Params};
//! use si_3964r::frame::{encode, Mode, DLE, STX};
//! use si_core::monitor::{decode_all, Kind, LineChar};
//! use si_core::Instant;
//!
//! // A sends STX, B answers DLE, A sends the block, B acknowledges with DLE; 9600 8E1.
//! let ct = 1_146;
//! let mut wire = vec![(0, STX), (1, DLE)];
//! wire.extend(encode(b"hi", Mode::BlockCheck).into_iter().map(|b| (0, b)));
//! wire.push((1, DLE));
//! let chars: Vec<LineChar> = wire
//!     .iter()
//!     .enumerate()
//!     .map(|(k, &(from, b))| LineChar {
//!         at: Instant::from_micros(ct * (k as u64 + 1)),
//!         from: Some(from),
//!         to: Some(1 - from),
//!         item: Ok(b),
//!         exact: true,
//!     })
//!     .collect();
//! let mut monitor = Monitor::new(Params::from_config(
//!     &si_3964r::Config::default(),
//!     si_core::SerialSettings::default(),
//! ));
//! let records = decode_all(&mut monitor, &chars, Instant::from_micros(1_000_000));
//! let block = records.iter().find(|r| r.kind == Kind::Frame).unwrap();
//! assert_eq!(block.text, "block, 2 B user data: 68 69");
//! assert_eq!(monitor.counters().0["blocks ok"], 1);
//! # use si_core::monitor::Decoder;
//! ```
//!
//! Reading chosen: a listener cannot tell a repeated connection attempt (same transmission
//! attempt) from a new transmission attempt, so every STX from the station whose last STX or
//! block failed counts as one **retry**; a block NAKed or unacknowledged marks the next STX of
//! its sender a retry as well ([ET200S SI] §2.7 `[derived]` counts both kinds against their own
//! limits).

use crate::frame::{Decoder as BlockDecoder, FrameError, Mode, DLE, NAK, STX};
use si_core::monitor::{ms, Counters, Decoder, Flag, Kind, LineChar, Record};
use si_core::{Duration, Instant, SerialSettings};

/// Raw block characters kept for display: twice the longest block (1024 bytes, every one a
/// doubled DLE) plus the end sequence; the block decoder itself stops storing at its maximum.
const MAX_RAW: usize = 2 * 1024 + 3;

/// A block's user data read by a [`Payload`]: `(label, text)` for its record, or why the data
/// are not that layer's.
pub type Described = Result<(String, String), String>;

/// A decoder for the user data of a layer that rides on 3964(R) blocks (RK 512).
#[derive(Debug, Clone, Copy)]
pub struct Payload {
    /// The counter of blocks it decoded.
    pub ok_counter: &'static str,
    /// The counter of blocks it refused.
    pub error_counter: &'static str,
    /// The block's user data as `(label, text)` for a record, or why it is not this layer's.
    pub describe: fn(&[u8]) -> Described,
}

/// The timers and mode the listener judges against.
#[derive(Debug, Clone, Copy)]
pub struct Params {
    /// 3964(R) (BCC) or plain 3964.
    pub mode: Mode,
    /// Character delay time ZVZ.
    pub zvz: Duration,
    /// Acknowledgement delay time QVZ.
    pub qvz: Duration,
    /// The line's character format. A character is seen when it is complete, so the silence
    /// before it is its distance from the previous one less one character time, and ZVZ has
    /// run out when a character would complete later than that
    /// ([`SerialSettings::gap_limit`], as the link counts it). [`Params::from_config`] takes
    /// the manuals' default line, 9600 8E1; set it for another rate.
    pub line: SerialSettings,
    /// How to read the blocks' user data; `None`: shown as hex.
    pub payload: Option<Payload>,
}

impl Params {
    /// The mode and timers a link with `config` runs with on a line with `line`'s character
    /// format ([ET200S SI] §2.9, Table 2-11): ZVZ [`crate::Config::char_delay`],
    /// QVZ [`crate::Config::ack_delay`]. The line is needed: ZVZ is judged with the character
    /// time, which at 300 bit/s is most of the minimum ZVZ.
    pub fn from_config(config: &crate::Config, line: SerialSettings) -> Params {
        Params {
            mode: config.mode(),
            zvz: config.char_delay,
            qvz: config.ack_delay,
            line,
            payload: None,
        }
    }
}

#[derive(Debug)]
enum State {
    Idle,
    /// `by` sent STX at `at`; waiting for the partner's DLE.
    Connecting {
        by: Option<usize>,
        at: Instant,
    },
    /// Both sent STX (initialization conflict): `a` first, then `b`; the one that answers
    /// DLE yields and the other becomes the sender.
    Conflict {
        a: Option<usize>,
        b: Option<usize>,
        at: Instant,
    },
    /// `by` is sending its block.
    Block {
        by: Option<usize>,
        to: Option<usize>,
        start: Instant,
        last: LineChar,
        bytes: Vec<u8>,
        flags: Vec<Flag>,
    },
    /// `by` finished its block at `at`; waiting for DLE or NAK.
    Ack {
        by: Option<usize>,
        at: Instant,
    },
}

/// The 3964(R) listener.
pub struct Monitor {
    p: Params,
    state: State,
    block: BlockDecoder,
    /// The station whose last attempt failed: its next STX is a retry.
    failed: Option<Option<usize>>,
    counters: Counters,
}

impl Monitor {
    /// A listener with these timers.
    pub fn new(p: Params) -> Self {
        let mut counters = Counters::default();
        counters.declare(&[
            "blocks ok",
            "blocks failed",
            "retries",
            "NAKs",
            "initialization conflicts",
            "BCC errors",
            "ZVZ exceeded",
            "QVZ exceeded",
            "line errors",
        ]);
        if let Some(layer) = p.payload {
            counters.declare(&[layer.ok_counter, layer.error_counter]);
        }
        Monitor {
            p,
            state: State::Idle,
            block: BlockDecoder::new(p.mode, 1024),
            failed: None,
            counters,
        }
    }

    /// Flag the DLE record `r` if it came later than QVZ after `since` ([ET200S SI] §2.7, Table
    /// 2-11).
    fn judge_qvz(&self, r: &mut Record, since: Instant) {
        let wait = r.start.saturating_since(since);
        if wait > self.p.qvz {
            r.flags.push(Flag::error(format!(
                "DLE after {} > QVZ {}",
                ms(wait),
                ms(self.p.qvz)
            )));
        }
    }

    /// `by` starts its block, released by the partner's DLE `c`.
    fn begin_block(&mut self, by: Option<usize>, c: &LineChar) {
        self.block.reset();
        self.state = State::Block {
            by,
            to: c.from,
            start: c.at,
            last: c.clone(),
            bytes: Vec::new(),
            flags: Vec::new(),
        };
    }

    fn control(&self, c: &LineChar, label: &str, text: &str) -> Record {
        let mut r = Record::new(Kind::Control, c.at, c.at, c.from).labelled(label, text);
        r.to = c.to;
        if let Ok(b) = c.item {
            r.bytes.push(b);
        }
        r
    }

    /// Timers that ran out before `now`.
    fn overdue(&mut self, now: Instant, out: &mut Vec<Record>) {
        match &self.state {
            State::Connecting { by, at } | State::Conflict { a: by, at, .. }
                if now.saturating_since(*at) >= self.p.qvz =>
            {
                let (by, at) = (*by, *at);
                self.counters.bump("QVZ exceeded");
                out.push(Record::note(
                    at + self.p.qvz,
                    by,
                    Flag::error(format!(
                        "no DLE within QVZ {} after STX (STATUS 16#0703)",
                        ms(self.p.qvz)
                    )),
                ));
                self.failed = Some(by);
                self.state = State::Idle;
            }
            State::Block { last, .. } if now >= last.at + self.p.line.gap_limit(self.p.zvz) => {
                // The moment the receiver knows: its NAK goes out then (crate::link).
                let at = last.at + self.p.line.gap_limit(self.p.zvz);
                let State::Block {
                    by,
                    to,
                    start,
                    bytes,
                    ..
                } = std::mem::replace(&mut self.state, State::Idle)
                else {
                    return;
                };
                self.counters.bump("ZVZ exceeded");
                self.counters.bump("blocks failed");
                let mut r = Record::new(Kind::Frame, start, at, by).labelled(
                    format!("block? {} B", bytes.len()),
                    "incomplete block".to_string(),
                );
                r.bytes = bytes;
                r.to = to;
                r.flags.push(Flag::error(format!(
                    "ZVZ {} exceeded: block incomplete (STATUS 16#0706)",
                    ms(self.p.zvz)
                )));
                out.push(r);
                self.failed = Some(by);
            }
            State::Ack { by, at } if now.saturating_since(*at) >= self.p.qvz => {
                let (by, at) = (*by, *at);
                self.counters.bump("QVZ exceeded");
                self.counters.bump("blocks failed");
                out.push(Record::note(
                    at + self.p.qvz,
                    by,
                    Flag::error(format!(
                        "no acknowledgement within QVZ {} after the block (STATUS 16#0704)",
                        ms(self.p.qvz)
                    )),
                ));
                self.failed = Some(by);
                self.state = State::Idle;
            }
            _ => {}
        }
    }

    fn stx(&mut self, c: &LineChar, out: &mut Vec<Record>) {
        let mut r = self.control(c, "STX", "connection request");
        if self.failed == Some(c.from) {
            self.counters.bump("retries");
            r.flags.push(Flag::note("retry"));
            self.failed = None;
        }
        match self.state {
            State::Connecting { by, .. } if by != c.from => {
                self.counters.bump("initialization conflicts");
                r.flags.push(Flag::note(
                    "initialization conflict: both stations sent STX; the low-priority one yields",
                ));
                self.state = State::Conflict {
                    a: by,
                    b: c.from,
                    at: c.at,
                };
            }
            State::Connecting { by, at } if by == c.from => {
                // A repeated STX before QVZ: the sender gave up early (or QVZ differs).
                r.flags.push(Flag::note(format!(
                    "STX repeated after {} (before QVZ)",
                    ms(c.at.saturating_since(at))
                )));
                self.state = State::Connecting {
                    by: c.from,
                    at: c.at,
                };
            }
            _ => {
                self.state = State::Connecting {
                    by: c.from,
                    at: c.at,
                }
            }
        }
        out.push(r);
    }

    fn finish_block(
        &mut self,
        c: &LineChar,
        result: Result<(), FrameError>,
        out: &mut Vec<Record>,
    ) {
        let State::Block {
            by,
            start,
            bytes,
            mut flags,
            ..
        } = std::mem::replace(&mut self.state, State::Idle)
        else {
            return;
        };
        let payload = self.block.payload().to_vec();
        let mut text = format!("block, {} B user data", payload.len());
        let mut label = format!("block {} B {}", payload.len(), preview(&payload));
        if let Err(e) = result {
            if matches!(e, FrameError::Bcc { .. }) {
                self.counters.bump("BCC errors");
                flags.push(Flag::error(format!("{e} (STATUS 16#0708)")));
            } else {
                flags.push(Flag::error(e.to_string()));
            }
        } else if let Some(layer) = self.p.payload {
            match (layer.describe)(&payload) {
                Ok((l, t)) => {
                    self.counters.bump(layer.ok_counter);
                    label = l;
                    text = t;
                }
                Err(e) => {
                    self.counters.bump(layer.error_counter);
                    flags.push(Flag::error(e));
                }
            }
        } else {
            text.push_str(&format!(": {}", si_core::hex::format(&payload)));
        }
        let mut r = Record::new(Kind::Frame, start, c.at, by).labelled(label, text);
        r.to = c.to;
        r.bytes = bytes;
        r.flags = flags;
        out.push(r);
        self.state = State::Ack { by, at: c.at };
    }
}

/// The first user-data characters, readable: `"temperatur…"` for text, hex otherwise.
fn preview(payload: &[u8]) -> String {
    let shown = &payload[..payload.len().min(10)];
    let more = if payload.len() > shown.len() {
        "…"
    } else {
        ""
    };
    if !shown.is_empty() && shown.iter().all(|b| (0x20..0x7F).contains(b)) {
        format!("\"{}{more}\"", String::from_utf8_lossy(shown))
    } else {
        format!(
            "{}{more}",
            si_core::hex::format(&shown[..shown.len().min(4)])
        )
    }
}

impl Decoder for Monitor {
    fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
        self.overdue(c.at, out);
        let byte = match c.item {
            Ok(b) => b,
            Err(e) => {
                self.counters.bump("line errors");
                let mut r = self.control(c, "ERR", "line error");
                r.flags.push(Flag::error(format!(
                    "{e:?} error on the line (STATUS 16#0705)"
                )));
                out.push(r);
                if let State::Block { flags, last, .. } = &mut self.state {
                    flags.push(Flag::error(format!("{e:?} error inside the block")));
                    *last = c.clone();
                }
                return;
            }
        };
        match &mut self.state {
            State::Block {
                by,
                start,
                last,
                bytes,
                flags,
                ..
            } if *by == c.from => {
                if bytes.is_empty() {
                    *start = c.at;
                }
                if let Some(gap) = si_core::monitor::line::gap(Some(last), c) {
                    // The silence before `c`: from the end of the last character to `c`'s start.
                    let silence = gap.saturating_sub(self.p.line.char_time());
                    if silence > self.p.zvz {
                        flags.push(Flag::error(format!(
                            "character delay {} > ZVZ {}",
                            ms(silence),
                            ms(self.p.zvz)
                        )));
                    }
                }
                *last = c.clone();
                if bytes.len() < MAX_RAW {
                    bytes.push(byte);
                }
                if let Some(result) = self.block.push(byte) {
                    self.finish_block(c, result, out);
                }
                return;
            }
            State::Block { .. } if byte == NAK => {
                // The receiver gave up mid-block (e.g. a line error): it sends NAK.
                let State::Block { by, .. } = std::mem::replace(&mut self.state, State::Idle)
                else {
                    return;
                };
                self.counters.bump("NAKs");
                self.counters.bump("blocks failed");
                let mut r = self.control(c, "NAK", "receiver aborted the block");
                r.flags.push(Flag::error("NAK during the block"));
                out.push(r);
                self.failed = Some(by);
                return;
            }
            _ => {}
        }
        match (&self.state, byte) {
            (_, STX) => self.stx(c, out),
            (State::Connecting { by, at }, DLE) if *by != c.from => {
                let (by, at) = (*by, *at);
                let mut r = self.control(c, "DLE", "ready to receive");
                self.judge_qvz(&mut r, at);
                out.push(r);
                self.begin_block(by, c);
            }
            (State::Conflict { a, b, .. }, DLE) => {
                // The station answering DLE yields (low priority); the other one sends.
                let sender = if c.from == *a { *b } else { *a };
                let mut r = self.control(c, "DLE", "yields: ready to receive");
                r.flags.push(Flag::note("conflict resolved by priority"));
                out.push(r);
                self.begin_block(sender, c);
            }
            (State::Ack { by, at }, DLE) if *by != c.from => {
                let (by, at) = (*by, *at);
                let mut r = self.control(c, "DLE", "block acknowledged");
                self.judge_qvz(&mut r, at);
                out.push(r);
                let _ = by;
                self.counters.bump("blocks ok");
                self.state = State::Idle;
            }
            (State::Connecting { by, .. }, NAK) | (State::Ack { by, .. }, NAK) if *by != c.from => {
                let by = *by;
                let after_block = matches!(self.state, State::Ack { .. });
                self.counters.bump("NAKs");
                let mut r = self.control(
                    c,
                    "NAK",
                    if after_block {
                        "block rejected"
                    } else {
                        "connection refused"
                    },
                );
                r.flags.push(Flag::error(if after_block {
                    "NAK: block rejected (partner found an error), STATUS 16#0705"
                } else {
                    "NAK instead of DLE: connection refused, STATUS 16#0702"
                }));
                out.push(r);
                if after_block {
                    self.counters.bump("blocks failed");
                }
                self.failed = Some(by);
                self.state = State::Idle;
            }
            (State::Idle, NAK) => {
                // A station sends NAK when it starts up or gives up a job ([ET200S SI] §2.7
                // [derived] "send NAK and fail"): worth seeing, not a fault of this exchange.
                self.counters.bump("NAKs");
                let mut r = self.control(c, "NAK", "negative acknowledgement");
                r.flags.push(Flag::note(
                    "NAK outside a connection (start-up, or a sender giving up)",
                ));
                out.push(r);
            }
            (_, NAK) => {
                self.counters.bump("NAKs");
                let mut r = self.control(c, "NAK", "negative acknowledgement");
                r.flags
                    .push(Flag::error("NAK (the sender gave up or refuses)"));
                out.push(r);
                self.state = State::Idle;
            }
            (_, DLE) => {
                let mut r = self.control(c, "DLE", "unexpected DLE");
                r.flags.push(Flag::note("DLE outside a connection"));
                out.push(r);
            }
            _ => {
                let mut r = self.control(c, &format!("{byte:02X}"), "stray character");
                r.flags.push(Flag::error(
                    "character outside a block (the receiver answers NAK)",
                ));
                out.push(r);
            }
        }
    }

    fn idle(&mut self, now: Instant, out: &mut Vec<Record>) {
        self.overdue(now, out);
    }

    fn counters(&self) -> &Counters {
        &self.counters
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CT: u64 = 1_146; // 9600 8E1

    /// Characters from `from` (0 = A, 1 = B) at the given instants.
    fn line(items: &[(u64, usize, u8)]) -> Vec<LineChar> {
        items
            .iter()
            .map(|&(at, from, b)| LineChar {
                at: Instant::from_micros(at),
                from: Some(from),
                to: Some(1 - from),
                item: Ok(b),
                exact: true,
            })
            .collect()
    }

    fn run(chars: &[LineChar], end: u64) -> (Vec<Record>, Counters) {
        let mut d = Monitor::new(Params::from_config(
            &crate::Config::default(),
            SerialSettings::default(),
        ));
        let records = si_core::monitor::decode_all(&mut d, chars, Instant::from_micros(end));
        (records, d.counters().clone())
    }

    #[test]
    fn et200s_3964r_5_8_zvz_exceeded_inside_a_block_ends_it_when_a_character_would_be_late() {
        // STX, DLE, then two data characters and silence: the receiver's ZVZ runs out.
        let chars = line(&[
            (CT, 0, STX),
            (2 * CT, 1, DLE),
            (3 * CT, 0, 0x41),
            (4 * CT, 0, 0x42),
        ]);
        let (records, counters) = run(&chars, 1_000_000);
        let broken = records.last().unwrap();
        // 220 ms of silence, then the character time a next character takes, then 1 µs.
        assert_eq!(broken.end, Instant::from_micros(4 * CT + 220_000 + CT + 1));
        assert!(broken.flags[0].text.contains("ZVZ 220 ms exceeded"));
        assert_eq!(counters.0["ZVZ exceeded"], 1);
        assert_eq!(counters.0["blocks failed"], 1);
    }

    #[test]
    fn et200s_3964r_5_8_a_late_character_inside_a_block_is_flagged_with_its_gap() {
        // The block completes, but one gap is 230 ms: longer than ZVZ, shorter than the end.
        let block = [0x41, DLE, 0x03, 0x41 ^ DLE ^ 0x03];
        let mut items = vec![(CT, 0, STX), (2 * CT, 1, DLE), (3 * CT, 0, block[0])];
        items.push((3 * CT + 230_000, 0, block[1]));
        items.push((4 * CT + 230_000, 0, block[2]));
        items.push((5 * CT + 230_000, 0, block[3]));
        items.push((6 * CT + 230_000, 1, DLE));
        let (records, _) = run(&line(&items), 1_000_000);
        // The gap ran past ZVZ, so the listener already declared the block dead at 220 ms.
        assert!(records
            .iter()
            .any(|r| r.flags.iter().any(|f| f.text.contains("ZVZ"))));
    }

    /// At 300 bit/s a character takes 36.7 ms; a partner leaving exactly ZVZ (60 ms)
    /// of silence between characters is within the limit, one microsecond more is not.
    #[test]
    fn et200s_3964r_5_8_zvz_at_300_bit_s_counts_silence_not_character_distance() {
        let slow = SerialSettings::new(300, 8, si_core::Parity::Even, 1).unwrap();
        let ct = slow.char_time().as_micros();
        let zvz = 60_000;
        let judge = |extra: u64| {
            let p = Params {
                zvz: Duration::from_millis(60),
                line: slow,
                ..Params::from_config(&crate::Config::default(), SerialSettings::default())
            };
            let mut d = Monitor::new(p);
            let block = [0x41, DLE, 0x03, 0x41 ^ DLE ^ 0x03];
            let mut at = 2 * ct;
            let mut items = vec![(ct, 0, STX), (at, 1, DLE)];
            for (k, &b) in block.iter().enumerate() {
                at += ct + if k == 1 { zvz + extra } else { zvz };
                items.push((at, 0, b));
            }
            items.push((at + ct, 1, DLE));
            let records = si_core::monitor::decode_all(
                &mut d,
                &line(&items),
                Instant::from_micros(at + 10_000_000),
            );
            records
                .iter()
                .flat_map(|r| r.flags.iter())
                .any(|f| f.text.contains("ZVZ"))
        };
        assert!(!judge(0), "silence of exactly ZVZ");
        assert!(judge(1), "ZVZ + 1 µs");
    }

    #[test]
    fn et200s_3964r_5_8_late_dle_after_the_block_is_a_qvz_violation() {
        let block = [0x41, DLE, 0x03, 0x41 ^ DLE ^ 0x03];
        let mut items = vec![(CT, 0, STX), (2 * CT, 1, DLE)];
        for (k, &b) in block.iter().enumerate() {
            items.push(((3 + k as u64) * CT, 0, b));
        }
        let end = 6 * CT;
        items.push((end + 2_500_000, 1, DLE));
        let (records, counters) = run(&line(&items), 5_000_000);
        let note = records.iter().find(|r| r.kind == Kind::Note).unwrap();
        assert_eq!(note.start, Instant::from_micros(end + 2_000_000));
        assert!(note.label.contains("16#0704"));
        assert_eq!(counters.0["QVZ exceeded"], 1);
        assert_eq!(counters.0["blocks ok"], 0);
    }

    #[test]
    fn et200s_3964r_block_with_doubled_dle_decodes_its_user_data() {
        let payload = [0x01, DLE, 0x02];
        let wire = crate::frame::encode(&payload, Mode::BlockCheck);
        let mut items = vec![(CT, 0, STX), (2 * CT, 1, DLE)];
        for (k, &b) in wire.iter().enumerate() {
            items.push(((3 + k as u64) * CT, 0, b));
        }
        items.push(((3 + wire.len() as u64) * CT, 1, DLE));
        let (records, counters) = run(&line(&items), 1_000_000);
        let block = records.iter().find(|r| r.kind == Kind::Frame).unwrap();
        assert_eq!(block.text, "block, 3 B user data: 01 10 02");
        assert_eq!(block.bytes, wire);
        assert_eq!(counters.0["blocks ok"], 1);
    }
}
