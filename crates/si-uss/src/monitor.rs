//! Passive USS decoding ([USS spec] §4–§6; [Modbus/USS] §3.6):
//! a telegram starts with STX after a start interval of at least two character times and is
//! `LGE + 2` characters long; the BCC is checked, the residual run time `1.5 × (n + 3)`
//! character times from STX is judged, and the slave's response delay must stay within 20 ms.
//!
//! The timers are the engine's: [`crate::config::start_interval`],
//! [`crate::config::residual_run_time`] (rounded up to a microsecond, as the master's receiver
//! sets its deadline) and [`crate::config::RESPONSE_DELAY_MAX`]. A telegram the master accepts
//! is never flagged here (an earlier version of the monitor rounded the residual run time down and
//! flagged telegrams that ended in the last microsecond).
//!
//! Counters are the USS specification's recommended diagnostic counters ([USS spec] §5.2.3):
//! telegrams ok, telegrams rejected, framing, overrun and parity errors, start not identified,
//! residual run time exceeded, BCC errors, length errors, monitoring time (no answer). A
//! listener cannot see "overflow" of a receiver's buffer and counts overrun only when the UART
//! reported it.
//!
//! Reading chosen: master telegrams and slave telegrams have the same shape, so, as for Modbus,
//! a telegram is the **response** when a master telegram is waiting and it comes from another
//! station (or the capture is one-sided); otherwise it is a master telegram.
//!
//! ```
//! use si_uss::frame::{encode, Adr};
//! use si_uss::monitor::Monitor;
//! use si_core::monitor::{decode_all, Decoder, LineChar};
//! use si_core::{Instant, SerialSettings};
//!
//! // The master (station 0) polls node 1, the drive (station 1) answers 5 ms later; 9600 8E1.
//! let ct = 1_146;
//! let mut buf = [0u8; 256];
//! let mut chars = Vec::new();
//! let mut at = 10_000;
//! for (from, net) in [(0, [0u8; 4]), (1, [1u8; 4])] {
//!     let n = encode(Adr(1), &net, &mut buf).unwrap();
//!     for &b in &buf[..n] {
//!         chars.push(LineChar { at: Instant::from_micros(at), from: Some(from), to: Some(1 - from), item: Ok(b), exact: true });
//!         at += ct;
//!     }
//!     at += 5_000;
//! }
//! let mut monitor = Monitor::new(SerialSettings::default(), false);
//! let records = decode_all(&mut monitor, &chars, Instant::from_micros(at + 100_000));
//! assert_eq!(records[1].label, "answer 1 (4 B)");
//! assert_eq!(monitor.counters().0["telegrams ok"], 2);
//! ```

use crate::config::{residual_run_time, start_interval, RESPONSE_DELAY_MAX};
use crate::frame::{decode, DecodeError, STX};
use si_core::monitor::exchange::{Exchange, Request};
use si_core::monitor::{ms, Counters, Decoder, Flag, Kind, LineChar, Record};
use si_core::{Duration, Instant, LineError, SerialSettings};

/// The slave's longest response delay ([USS spec] §5.2.1.1), the engine's own constant.
pub const RESPONSE_DELAY: Duration = RESPONSE_DELAY_MAX;

struct Telegram {
    from: Option<usize>,
    to: Option<usize>,
    start: Instant,
    end: Instant,
    bytes: Vec<u8>,
    errors: Vec<LineError>,
}

/// The USS listener.
pub struct Monitor {
    settings: SerialSettings,
    cur: Option<Telegram>,
    last: Option<LineChar>,
    /// Master telegrams (their ADR byte) and answers, `si_core::monitor::exchange`'s reading.
    exchange: Exchange<u8>,
    one_sided: bool,
    counters: Counters,
}

impl Monitor {
    /// A listener for `settings`; `one_sided` when senders are unknown.
    pub fn new(settings: SerialSettings, one_sided: bool) -> Self {
        let mut counters = Counters::default();
        counters.declare(&[
            "telegrams ok",
            "telegrams rejected",
            "framing errors",
            "overrun errors",
            "parity errors",
            "start not identified",
            "residual run time exceeded",
            "BCC errors",
            "length errors",
            "monitoring time (no answer)",
        ]);
        Monitor {
            settings,
            cur: None,
            last: None,
            exchange: Exchange::new(one_sided),
            one_sided,
            counters,
        }
    }

    fn overdue(&mut self, now: Instant, out: &mut Vec<Record>) {
        let limit = RESPONSE_DELAY + self.settings.chars_time(3);
        if let Some(pd) = self
            .exchange
            .expire(|pd| now.saturating_since(pd.end) > limit)
        {
            self.counters.bump("monitoring time (no answer)");
            out.push(Record::note(
                pd.end + RESPONSE_DELAY,
                pd.from,
                Flag::error(format!(
                    "node {} does not answer within {} (response delay)",
                    pd.what & 0x1F,
                    ms(RESPONSE_DELAY)
                )),
            ));
        }
        // A telegram that stopped short: end it when its residual run time has passed.
        if let Some(t) = &self.cur {
            let n = t.bytes.get(1).map_or(crate::frame::MAX_NET, |&lge| {
                usize::from(lge).saturating_sub(2)
            });
            let limit = self.residual(n);
            if now.saturating_since(t.start) > limit + self.settings.char_time() {
                let t = self.cur.take();
                if let Some(t) = t {
                    self.telegram(t, true, out);
                }
            }
        }
    }

    /// Residual run time for `n` net bytes, from the end of STX: the engine's rule.
    fn residual(&self, n: usize) -> Duration {
        residual_run_time(&self.settings, n)
    }

    fn telegram(&mut self, t: Telegram, cut_short: bool, out: &mut Vec<Record>) {
        let mut r = Record::new(Kind::Frame, t.start, t.end, t.from);
        r.to = t.to;
        r.bytes = t.bytes.clone();
        let mut rejected = false;
        for e in &t.errors {
            rejected = true;
            self.counters.bump(match e {
                LineError::Framing | LineError::Break => "framing errors",
                LineError::Overrun => "overrun errors",
                LineError::Parity => "parity errors",
            });
            r.flags
                .push(Flag::error(format!("{e:?} error in the telegram")));
        }
        let n = t.bytes.len().saturating_sub(4);
        if t.end.saturating_since(t.start) > self.residual(n) {
            rejected = true;
            self.counters.bump("residual run time exceeded");
            r.flags.push(Flag::error(format!(
                "residual run time {} exceeded",
                ms(self.residual(n))
            )));
        }
        let is_response = self.exchange.is_answer(t.from);
        let late = if is_response {
            None
        } else {
            let node = decode(&t.bytes).ok().map(|tg| tg.adr.address());
            self.exchange
                .late_answer(t.from, |&adr| Some(adr & 0x1F) == node)
        };
        if let Some(pd) = late {
            // Already counted as "no answer" when the response delay ran out.
            let wait = t.start.saturating_since(pd.end + self.settings.char_time());
            r.label = format!("late answer {} B", t.bytes.len());
            r.text = si_core::hex::format(&t.bytes);
            r.flags.push(Flag::error(format!(
                "answer after {} (response delay {})",
                ms(wait),
                ms(RESPONSE_DELAY)
            )));
            self.counters.bump("telegrams rejected");
            out.push(r);
            return;
        }
        match decode(&t.bytes) {
            Ok(tg) => {
                let role = if is_response { "answer" } else { "to" };
                r.label = format!("{role} {} ({} B)", tg.adr.address(), tg.net.len());
                r.text = format!(
                    "ADR {:02X}H, net {}",
                    tg.adr.0,
                    si_core::hex::format(tg.net)
                );
                if is_response {
                    if let Some(pd) = self.exchange.take() {
                        if tg.adr.address() != pd.what & 0x1F {
                            r.flags.push(Flag::error(format!(
                                "answer from node {} to a telegram for node {}",
                                tg.adr.address(),
                                pd.what & 0x1F
                            )));
                        }
                        let wait = t.start.saturating_since(pd.end + self.settings.char_time());
                        if wait > RESPONSE_DELAY {
                            r.flags.push(Flag::error(format!(
                                "response delay {} > {}",
                                ms(wait),
                                ms(RESPONSE_DELAY)
                            )));
                        }
                    }
                } else {
                    self.unanswered(t.start, out);
                    if !tg.adr.is_broadcast() {
                        self.exchange.wait_for(Request {
                            from: t.from,
                            end: t.end,
                            what: tg.adr.0,
                        });
                    }
                }
            }
            Err(e) => {
                rejected = true;
                r.label = format!("bad telegram {} B", t.bytes.len());
                r.text = si_core::hex::format(&t.bytes);
                match e {
                    DecodeError::Bcc { .. } => self.counters.bump("BCC errors"),
                    DecodeError::LgeOutOfRange { .. }
                    | DecodeError::WrongLength { .. }
                    | DecodeError::TooShort { .. }
                    | DecodeError::Oversize { .. } => self.counters.bump("length errors"),
                    _ => {}
                }
                if cut_short {
                    r.flags.push(Flag::error("telegram incomplete"));
                }
                r.flags.push(Flag::error(e.to_string()));
                if is_response {
                    self.exchange.take();
                }
            }
        }
        self.counters.bump(if rejected {
            "telegrams rejected"
        } else {
            "telegrams ok"
        });
        out.push(r);
    }

    fn unanswered(&mut self, at: Instant, out: &mut Vec<Record>) {
        if let Some(pd) = self.exchange.take() {
            self.counters.bump("monitoring time (no answer)");
            out.push(Record::note(
                at,
                pd.from,
                Flag::error(format!(
                    "node {} did not answer before the next telegram",
                    pd.what & 0x1F
                )),
            ));
        }
    }
}

impl Decoder for Monitor {
    fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
        self.overdue(c.at, out);
        let silence = si_core::monitor::line::gap(self.last.as_ref(), c);
        self.last = Some(c.clone());
        if let Some(t) = &mut self.cur {
            if t.from == c.from || self.one_sided {
                t.end = c.at;
                match c.item {
                    Ok(b) => t.bytes.push(b),
                    Err(e) => t.errors.push(e),
                }
                let complete = t.bytes.len() >= 2
                    && (t.bytes.len() >= usize::from(t.bytes[1]) + 2
                        || !(2..=254).contains(&t.bytes[1]));
                if complete {
                    if let Some(t) = self.cur.take() {
                        self.telegram(t, false, out);
                    }
                }
                return;
            }
            // Another station started talking: the telegram in progress ends short.
            if let Some(t) = self.cur.take() {
                self.telegram(t, true, out);
            }
        }
        match c.item {
            Ok(STX) => {
                let start_interval = start_interval(&self.settings);
                let mut t = Telegram {
                    from: c.from,
                    to: c.to,
                    start: c.at,
                    end: c.at,
                    bytes: vec![STX],
                    errors: Vec::new(),
                };
                if silence.is_some_and(|g| g < start_interval + self.settings.char_time()) {
                    self.counters.bump("start not identified");
                    t.errors.clear();
                    let mut r = Record::new(Kind::Control, c.at, c.at, c.from)
                        .labelled("STX?", "STX without the start interval");
                    r.flags.push(Flag::note(format!(
                        "less than the start interval {} of silence before STX",
                        ms(start_interval)
                    )));
                    out.push(r);
                }
                self.cur = Some(t);
            }
            item => {
                self.counters.bump("start not identified");
                let mut r = Record::new(Kind::Control, c.at, c.at, c.from);
                r.to = c.to;
                match item {
                    Ok(b) => {
                        r.label = format!("{b:02X}");
                        r.bytes.push(b);
                    }
                    Err(e) => r.label = format!("{e:?}"),
                }
                r.text = "character outside a telegram".into();
                r.flags
                    .push(Flag::error("character outside a telegram (no STX)"));
                out.push(r);
            }
        }
    }

    fn idle(&mut self, now: Instant, out: &mut Vec<Record>) {
        self.overdue(now, out);
    }

    fn finish(&mut self, now: Instant, out: &mut Vec<Record>) {
        if let Some(t) = self.cur.take() {
            self.telegram(t, true, out);
        }
        self.overdue(now, out);
    }

    fn counters(&self) -> &Counters {
        &self.counters
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{uss_settings, USS_BAUD_RATES};
    use crate::rx::{Receiver, RxOutcome};

    fn telegram(adr: u8, net: &[u8]) -> Vec<u8> {
        let mut out = [0u8; 256];
        let n = crate::frame::encode(crate::frame::Adr(adr), net, &mut out).unwrap();
        out[..n].to_vec()
    }

    /// `bytes` from `from`, starting at `at` µs, one character time apart (or `pace` apart).
    fn push(chars: &mut Vec<LineChar>, from: usize, at: u64, pace: u64, bytes: &[u8]) {
        for (k, &b) in bytes.iter().enumerate() {
            chars.push(LineChar {
                at: Instant::from_micros(at + k as u64 * pace),
                from: Some(from),
                to: None,
                item: Ok(b),
                exact: true,
            });
        }
    }

    fn run(chars: &[LineChar]) -> (Vec<Record>, Counters) {
        let mut d = Monitor::new(SerialSettings::default(), false);
        let end = chars.last().map_or(Instant::ZERO, |c| c.at) + Duration::from_millis(100);
        let records = si_core::monitor::decode_all(&mut d, chars, end);
        (records, d.counters().clone())
    }

    #[test]
    fn uss_5_2_1_answer_within_20_ms_is_ok_and_a_bcc_error_is_counted() {
        let ct = 1_146;
        let mut chars = Vec::new();
        let req = telegram(1, &[0; 4]);
        push(&mut chars, 0, 10_000, ct, &req);
        let req_end = 10_000 + (req.len() as u64 - 1) * ct;
        let mut ans = telegram(1, &[1; 4]);
        push(&mut chars, 1, req_end + 5_000, ct, &ans);
        // The next request comes back with its BCC flipped.
        let next = 200_000;
        push(&mut chars, 0, next, ct, &req);
        *ans.last_mut().unwrap() ^= 0x01;
        push(&mut chars, 1, next + 20_000, ct, &ans);
        let (records, counters) = run(&chars);
        assert_eq!(counters.0["telegrams ok"], 3);
        assert_eq!(counters.0["BCC errors"], 1);
        assert_eq!(counters.0["telegrams rejected"], 1);
        assert!(records[1].flags.is_empty(), "{:?}", records[1]);
    }

    #[test]
    fn uss_5_2_1_2_residual_run_time_is_judged_from_stx() {
        // 8 characters at twice the character time: 1.5 × (4 + 3) character times exceeded.
        let mut chars = Vec::new();
        push(
            &mut chars,
            0,
            10_000,
            2 * 1_146 + 300,
            &telegram(1, &[0; 4]),
        );
        let (records, counters) = run(&chars);
        assert_eq!(counters.0["residual run time exceeded"], 1);
        assert!(records[0].has_error());
    }

    #[test]
    fn uss_5_2_1_1_a_late_answer_breaks_the_response_delay() {
        let ct = 1_146;
        let mut chars = Vec::new();
        let req = telegram(2, &[0; 4]);
        push(&mut chars, 0, 10_000, ct, &req);
        let req_end = 10_000 + (req.len() as u64 - 1) * ct;
        // The answer's first character ends 30 ms after the request.
        push(&mut chars, 1, req_end + 30_000, ct, &telegram(2, &[0; 4]));
        let (records, counters) = run(&chars);
        assert_eq!(counters.0["monitoring time (no answer)"], 1);
        let note = records.iter().find(|r| r.kind == Kind::Note).unwrap();
        assert_eq!(note.start, Instant::from_micros(req_end) + RESPONSE_DELAY);
        let late = records.last().unwrap();
        assert_eq!(late.label, "late answer 8 B");
        assert!(
            late.flags[0].text.starts_with("answer after 28.854 ms"),
            "{late:?}"
        );
    }

    /// The residual-run-time deadline the master's receiver sets for a telegram with `n` net
    /// bytes whose STX ended at `t0`.
    fn engine_deadline(settings: SerialSettings, t0: Instant, n: usize) -> Instant {
        let mut rx = Receiver::new(settings);
        rx.set_rx_latency(Duration::ZERO); // the monitor judges the wire: a byte-by-byte port
        assert_eq!(rx.push(t0, STX), RxOutcome::Pending);
        assert_eq!(
            rx.push(t0 + settings.char_time(), n as u8 + 2),
            RxOutcome::Pending
        );
        rx.deadline().expect("receiving")
    }

    /// One telegram with `n` net bytes: STX at `t0`, the last character at `last`.
    fn stretched(t0: Instant, last: Instant, n: usize) -> Vec<LineChar> {
        let bytes = telegram(1, &vec![0x5A; n]);
        let span = last.saturating_since(t0).as_micros();
        let k = bytes.len() as u64 - 1;
        bytes
            .iter()
            .enumerate()
            .map(|(i, &b)| LineChar {
                at: t0 + Duration::from_micros(span * i as u64 / k),
                from: Some(0),
                to: None,
                item: Ok(b),
                exact: true,
            })
            .collect()
    }

    fn exceeded(settings: SerialSettings, chars: &[LineChar]) -> bool {
        let mut d = Monitor::new(settings, false);
        let end = chars.last().map_or(Instant::ZERO, |c| c.at) + Duration::from_secs(1);
        si_core::monitor::decode_all(&mut d, chars, end);
        d.counters().0["residual run time exceeded"] > 0
    }

    #[test]
    fn uss_5_2_1_2_monitor_and_master_agree_on_the_residual_run_time() {
        // An earlier monitor rounded 1.5 × (n + 3) character times down while the engine
        // rounds up, so a telegram ending in the engine's last microsecond was flagged. Now a
        // telegram ending exactly at the master receiver's deadline passes, one a microsecond
        // later is flagged, at every USS baud rate and telegram length.
        let mut odd = 0;
        for baud in USS_BAUD_RATES {
            let settings = uss_settings(baud).unwrap();
            for n in [0, 1, 2, 3, 4, 7, 12, 20, 35, 100, 252] {
                let t0 = Instant::from_micros(1_000_000);
                let deadline = engine_deadline(settings, t0, n);
                odd += usize::from(settings.chars_time(3 * (n as u64 + 3)).as_micros() % 2 == 1);
                assert!(
                    !exceeded(settings, &stretched(t0, deadline, n)),
                    "{baud} bit/s, {n} net bytes: ends at the engine's deadline"
                );
                assert!(
                    exceeded(
                        settings,
                        &stretched(t0, deadline + Duration::from_micros(1), n)
                    ),
                    "{baud} bit/s, {n} net bytes: ends after the engine's deadline"
                );
            }
        }
        assert!(odd > 0, "some case must be one the old rounding got wrong");
    }

    #[test]
    fn uss_5_1_2_monitor_and_master_agree_on_the_start_interval() {
        // The master's receiver takes an STX after at least the start interval of silence
        // (arrival − one character − last end ≥ 2 character times); the monitor notes
        // "STX without the start interval" exactly when the receiver would not identify it.
        let settings = SerialSettings::default();
        let ct = settings.char_time();
        let need = start_interval(&settings) + ct;
        for silence in [Duration::from_micros(need.as_micros() - 1), need] {
            let mut rx = Receiver::new(settings);
            rx.resync();
            let t0 = Instant::from_micros(1_000_000);
            rx.push(t0, 0x00);
            let engine_ok = rx.push(t0 + silence, STX) == RxOutcome::Pending;
            let mut chars = Vec::new();
            push(&mut chars, 0, t0.as_micros(), 0, &[0x00]);
            push(
                &mut chars,
                0,
                (t0 + silence).as_micros(),
                ct.as_micros(),
                &telegram(1, &[0; 4]),
            );
            let mut d = Monitor::new(settings, false);
            si_core::monitor::decode_all(&mut d, &chars, t0 + Duration::from_secs(1));
            let monitor_ok = d.counters().0["start not identified"] == 1; // the 00H only
            assert_eq!(monitor_ok, engine_ok, "silence {silence}");
        }
    }
}
