//! Passive Modbus RTU decoding ([Modbus/USS] §3.3.5–§3.3.6, Table 3-11, Table 3-12, §3.4): frames
//! end at the end-of-frame gap tZVZ_TAB of Table 3-11 (`crate::config::gap_table`), the CRC is
//! checked, requests and responses are decoded with si-modbus' own decoders, exception
//! responses are named, and a request without a response within the response timeout is
//! flagged.
//!
//! Counters follow the Modbus serial-line diagnostic counters a master or a bus analyser keeps
//! (bus messages, bus communication errors = CRC, exception responses, slave messages, no
//! response, broadcasts); the ET 200S slave itself keeps none ([Modbus/USS] §3.4, "no event
//! counters").
//!
//! Reading chosen: a frame is a **request** if no request is waiting for its response, or if
//! it comes from the station that sent the waiting request (that request then went unanswered);
//! otherwise it is the **response**. This needs no knowledge of who is master, so it also works
//! on a one-sided live capture of a bus.
//!
//! The timers are the master's own ([`Params::from_config`]): the end-of-frame gap
//! [`crate::config::LineConfig::gap`] (tZVZ_TAB × fMUL) and the response timeout
//! [`crate::config::MasterConfig::response_timeout`].
//!
//! ```
//! use si_modbus::config::MasterConfig;
//! use si_modbus::monitor::{Monitor, Params};
//! use si_core::monitor::{decode_all, Decoder, LineChar};
//! use si_core::Instant;
//!
//! // FC03 to slave 1, address 0, one register; nobody answers within the 2 s response time.
//! let request = [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A];
//! let chars: Vec<LineChar> = request
//!     .iter()
//!     .enumerate()
//!     .map(|(k, &b)| LineChar { at: Instant::from_micros(1_146 * (k as u64 + 1)), from: Some(0), to: Some(1), item: Ok(b), exact: true })
//!     .collect();
//! let mut monitor = Monitor::new(Params::from_config(&MasterConfig::default()), false);
//! let records = decode_all(&mut monitor, &chars, Instant::from_micros(3_000_000));
//! assert_eq!(records[0].label, "FC03 req → 1");
//! assert_eq!(monitor.counters().0["no response"], 1);
//! ```

use crate::frame::{crc_ok, decode_request, decode_response, Response};
use si_core::monitor::exchange::{Exchange, Request};
use si_core::monitor::framer::{Frame, Framer};
use si_core::monitor::{ms, Counters, Decoder, Flag, Kind, LineChar, Record};
use si_core::{Duration, Instant, SerialSettings};

/// What the listener judges against.
#[derive(Debug, Clone, Copy)]
pub struct Params {
    /// Character format (for the 1.5-character gap).
    pub settings: SerialSettings,
    /// End-of-frame gap.
    pub end_gap: Duration,
    /// Response timeout of the master.
    pub timeout: Duration,
}

impl Params {
    /// The character format, end-of-frame gap and response timeout a master with `config`
    /// runs with ([Modbus/USS] §3.3.5, Table 3-11, §3.4.3, Table 3-17).
    pub fn from_config(config: &crate::config::MasterConfig) -> Params {
        Params {
            settings: config.line.settings,
            end_gap: config.line.gap(),
            timeout: config.response_timeout,
        }
    }
}

/// What a request asked: the slave and the function code.
#[derive(Debug, Clone, Copy)]
struct Asked {
    unit: u8,
    function: u8,
}

/// The Modbus RTU listener.
pub struct Monitor {
    p: Params,
    framer: Framer,
    /// Requests and responses (`si_core::monitor::exchange`'s reading, the one above).
    exchange: Exchange<Asked>,
    counters: Counters,
}

impl Monitor {
    /// A listener; `one_sided` when every character comes from the same (unknown) sender.
    pub fn new(p: Params, one_sided: bool) -> Self {
        let mut counters = Counters::default();
        counters.declare(&[
            "bus messages",
            "bus communication errors (CRC)",
            "exception responses",
            "slave messages",
            "no response",
            "broadcasts",
            "line errors",
        ]);
        Monitor {
            p,
            // One byte over the longest ADU, so an endless stream shows as frames too long.
            framer: Framer::new(p.end_gap, crate::frame::MAX_ADU + 1),
            exchange: Exchange::new(one_sided),
            counters,
        }
    }

    fn overdue(&mut self, now: Instant, out: &mut Vec<Record>) {
        let timeout = self.p.timeout;
        if let Some(pd) = self
            .exchange
            .expire(|pd| now.saturating_since(pd.end) >= timeout)
        {
            self.counters.bump("no response");
            out.push(Record::note(
                pd.end + timeout,
                pd.from,
                Flag::error(format!(
                    "no response from slave {} to FC{:02} within {} (STATUS 16#0E54)",
                    pd.what.unit,
                    pd.what.function,
                    ms(timeout)
                )),
            ));
        }
    }

    fn frame(&mut self, f: Frame, out: &mut Vec<Record>) {
        self.counters.bump("bus messages");
        let mut r = Record::new(Kind::Frame, f.start, f.end, f.from);
        r.to = f.to;
        r.bytes = f.bytes.clone();
        for e in &f.line_errors {
            self.counters.bump("line errors");
            r.flags
                .push(Flag::error(format!("{e:?} error inside the frame")));
        }
        let t15 = Duration::from_micros(self.p.settings.char_time().as_micros() * 3 / 2);
        if f.longest_gap > t15 {
            r.flags.push(Flag::note(format!(
                "gap of {} inside the frame (> 1.5 characters)",
                ms(f.longest_gap)
            )));
        }
        let is_response = self.exchange.is_answer(f.from);
        let adu = &f.bytes;
        if !crc_ok(adu) {
            self.counters.bump("bus communication errors (CRC)");
            r.label = format!("CRC error {} B", adu.len());
            r.text = si_core::hex::format(adu);
            r.flags.push(Flag::error(if is_response {
                "CRC error: the master discards the response (STATUS 16#0E57)"
            } else {
                "CRC error: the slave ignores the frame (STATUS 16#0836)"
            }));
            if is_response {
                self.exchange.take();
            }
            out.push(r);
            return;
        }
        let late = if is_response {
            None
        } else {
            let unit = decode_response(adu).ok().map(|(unit, _)| unit);
            self.exchange
                .late_answer(f.from, |asked| Some(asked.unit) == unit)
        };
        if let Some(pd) = late {
            // Already counted under "no response" when the timeout ran out.
            let wait = f
                .start
                .saturating_since(pd.end + self.p.settings.char_time());
            r.label = format!("late response {} B", adu.len());
            r.text = si_core::hex::format(adu);
            r.flags.push(Flag::error(format!(
                "response after {} > timeout {}",
                ms(wait),
                ms(self.p.timeout)
            )));
            out.push(r);
            return;
        }
        if is_response {
            let pd = self.exchange.take();
            match decode_response(adu) {
                Ok((unit, resp)) => {
                    self.counters.bump("slave messages");
                    r.label = format!("FC{:02} resp", resp.function() & 0x7F);
                    r.text = format!("slave {unit}: {resp:#}");
                    if let Response::Exception { function, code } = resp {
                        self.counters.bump("exception responses");
                        r.label = format!("FC{:02} exception {:02X}", function, code.code());
                        r.flags.push(Flag::error(code.to_string()));
                    }
                    if let Some(pd) = pd {
                        if unit != pd.what.unit {
                            r.flags.push(Flag::error(format!(
                                "answer from slave {unit} to a request for slave {}",
                                pd.what.unit
                            )));
                        }
                        let first_start = f
                            .start
                            .saturating_since(pd.end + self.p.settings.char_time());
                        let wait = Duration::from_micros(first_start.as_micros());
                        if wait > self.p.timeout {
                            r.flags.push(Flag::error(format!(
                                "response after {} > timeout {}",
                                ms(wait),
                                ms(self.p.timeout)
                            )));
                        }
                    }
                }
                Err(e) => {
                    r.label = "bad response".into();
                    r.text = si_core::hex::format(adu);
                    r.flags.push(Flag::error(e.to_string()));
                }
            }
        } else {
            self.overdue_unanswered(f.start, out);
            match decode_request(adu) {
                Ok((unit, req)) => {
                    r.label = format!("FC{:02} req → {unit}", req.function());
                    r.text = format!("to slave {unit}: {req:#}");
                    if unit == crate::frame::BROADCAST {
                        self.counters.bump("broadcasts");
                        r.label = format!("FC{:02} broadcast", req.function());
                    } else {
                        self.exchange.wait_for(Request {
                            from: f.from,
                            end: f.end,
                            what: Asked {
                                unit,
                                function: req.function(),
                            },
                        });
                    }
                }
                Err(e) => {
                    r.label = "bad request".into();
                    r.text = si_core::hex::format(adu);
                    r.flags.push(Flag::error(e.to_string()));
                }
            }
        }
        out.push(r);
    }

    /// A new request while one waits: the old one went unanswered.
    fn overdue_unanswered(&mut self, at: Instant, out: &mut Vec<Record>) {
        if let Some(pd) = self.exchange.take() {
            self.counters.bump("no response");
            out.push(Record::note(
                at,
                pd.from,
                Flag::error(format!(
                    "slave {} did not answer FC{:02} before the next request",
                    pd.what.unit, pd.what.function
                )),
            ));
        }
    }
}

impl Decoder for Monitor {
    fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
        if let Some(f) = self.framer.idle(c.at) {
            self.frame(f, out);
        }
        self.overdue(c.at, out);
        if let Some(f) = self.framer.push(c) {
            self.frame(f, out);
        }
    }

    fn idle(&mut self, now: Instant, out: &mut Vec<Record>) {
        if let Some(f) = self.framer.idle(now) {
            self.frame(f, out);
        }
        self.overdue(now, out);
    }

    fn finish(&mut self, now: Instant, out: &mut Vec<Record>) {
        if let Some(f) = self.framer.flush() {
            self.frame(f, out);
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

    fn frame(from: usize, at: u64, pace: u64, bytes: &[u8]) -> Vec<LineChar> {
        bytes
            .iter()
            .enumerate()
            .map(|(k, &b)| LineChar {
                at: Instant::from_micros(at + k as u64 * pace),
                from: Some(from),
                to: Some(1 - from),
                item: Ok(b),
                exact: true,
            })
            .collect()
    }

    fn run(chars: &[LineChar]) -> (Vec<Record>, Counters) {
        let mut d = Monitor::new(
            Params::from_config(&crate::config::MasterConfig::default()),
            false,
        );
        let end = chars.last().map_or(Instant::ZERO, |c| c.at) + Duration::from_millis(10);
        let records = si_core::monitor::decode_all(&mut d, chars, end);
        (records, d.counters().clone())
    }

    /// FC03, slave 1, address 0, one register: the Modbus spec's example with CRC 84 0A.
    const REQUEST: [u8; 8] = [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A];

    #[test]
    fn et200s_modbus_3_5_a_gap_of_two_characters_inside_a_frame_is_noted_not_cut() {
        // 2.3 ms between characters: over 1.5 characters, under the 4 ms end-of-frame gap.
        let (records, counters) = run(&frame(0, 1_146, 2_300, &REQUEST));
        assert_eq!(records.len(), 1, "{records:?}");
        assert_eq!(records[0].label, "FC03 req → 1");
        assert!(records[0].flags[0].text.contains("> 1.5 characters"));
        assert_eq!(counters.0["bus communication errors (CRC)"], 0);
    }

    #[test]
    fn et200s_modbus_4_4_a_response_after_the_timeout_is_late_not_a_request() {
        // FC03 response, slave 1, one register 0x002A (CRC computed by si-modbus).
        let mut resp = vec![0x01, 0x03, 0x02, 0x00, 0x2A];
        let crc = crate::frame::crc16(&resp);
        resp.extend_from_slice(&crc.to_le_bytes());
        let mut chars = frame(0, 1_146, 1_146, &REQUEST);
        let request_end = 8 * 1_146;
        chars.extend(frame(1, request_end + 2_500_000, 1_146, &resp));
        let (records, counters) = run(&chars);
        assert_eq!(counters.0["no response"], 1);
        let late = records.last().unwrap();
        assert_eq!(late.label, "late response 7 B");
        assert!(
            late.flags[0].text.starts_with("response after 2498.854 ms"),
            "{late:?}"
        );
    }

    #[test]
    fn et200s_modbus_3_5_a_gap_of_the_table_value_cuts_the_frame_in_two() {
        let mut chars = frame(0, 1_146, 1_146, &REQUEST[..3]);
        chars.extend(frame(0, 3 * 1_146 + 5_000, 1_146, &REQUEST[3..]));
        let (records, counters) = run(&chars);
        assert_eq!(records.len(), 2);
        assert_eq!(counters.0["bus communication errors (CRC)"], 2);
    }
}
