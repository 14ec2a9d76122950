//! The gateway's counters per line and per client, as JSON status lines and as the diagnostic
//! unit's input registers.
//!
//! # Register map of the diagnostic unit (FC 04, read input registers)
//!
//! Blocks of [`BLOCK`] = 16 registers. Block 0 (registers 0–15) holds the counters of the
//! connection that asks; block 1 + i (registers 16 + 16·i …) those of line i, in the order of
//! the configuration. In each block, counters are 32 bits, high word first, wrapping:
//!
//! | offset | counter |
//! |---|---|
//! | 0–1 | requests (every request received; for a line, every one routed to it) |
//! | 2–3 | answers (normal responses returned) |
//! | 4–5 | exceptions (exception responses of the slave, passed through) |
//! | 6–7 | timeouts (no answer after the retries, or the unit is demoted: 0BH returned) |
//! | 8–9 | CRC errors: every answer with a wrong CRC the master received, also one a retry then cured |
//! | 10–11 | busy (queue full: 06H returned) |
//! | 12–13 | other failures (0AH no route or line down, 01H/03H refused, 04H for an answer still corrupt after the retries, as mbusd does, or otherwise bad) |
//! | 14 | queue depth now (for a client: its requests waiting) |
//! | 15 | reconnects: times the line was reopened after its port closed, low 16 bits ([`super::reopen`]; 0 for a client) |
//!
//! Every request ends in one of answers, exceptions, timeouts, busy or other (a broadcast
//! without an answer in none), so those add up to the requests once the queue is empty; a
//! client's broadcast goes to every line that allows them, and a full queue on one of them
//! counts busy for the client once per line. CRC
//! errors count the line's corrupt answers instead, several for one request when its retries
//! met them too (a retry that cures a CRC error must not hide it).
//!
//! Any other function code on the diagnostic unit is answered with exception 01H, registers
//! past the last block with 02H, and a quantity outside 1–125 with 03H.

use crate::demotion::{DemotionConfig, LineHealth};
use crate::gateway_metrics::{GatewayMetrics, LineNow};
use serde::Serialize;
use std::collections::BTreeMap;
use std::net::SocketAddr;

/// Registers per block of the diagnostic map.
pub const BLOCK: usize = 16;

/// What became of one request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// A normal response.
    Answer,
    /// The slave's exception, passed through.
    Exception,
    /// No answer: 0BH.
    Timeout,
    /// Queue full: 06H.
    Busy,
    /// Anything else the gateway answered itself (0AH, 01H, 03H, 04H).
    Other,
    /// A broadcast, sent without an answer.
    Sent,
    /// Its unit is demoted: 0BH at once, nothing sent ([`crate::demotion`]); counted with the
    /// timeouts.
    Demoted,
}

impl Outcome {
    /// Its name in metrics labels.
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Answer => "answer",
            Outcome::Exception => "exception",
            Outcome::Timeout => "timeout",
            Outcome::Busy => "busy",
            Outcome::Other => "other",
            Outcome::Sent => "sent",
            Outcome::Demoted => "demoted",
        }
    }
}

/// Counters of one line or one client.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Requests received (client) or queued (line).
    pub requests: u64,
    /// Normal responses.
    pub answers: u64,
    /// Slave exceptions passed through.
    pub exceptions: u64,
    /// No answer (0BH).
    pub timeouts: u64,
    /// Answers with a wrong CRC, on any attempt (module docs).
    pub crc_errors: u64,
    /// Refused with 06H, queue full.
    pub busy: u64,
    /// Other failures.
    pub other: u64,
    /// Requests waiting now.
    pub queue_depth: u64,
    /// Times the line was reopened after its port closed (always 0 for a client).
    pub reconnects: u64,
}

impl Counters {
    /// Count what became of a request.
    pub fn count(&mut self, outcome: Outcome) {
        let c = match outcome {
            Outcome::Answer => &mut self.answers,
            Outcome::Exception => &mut self.exceptions,
            Outcome::Timeout | Outcome::Demoted => &mut self.timeouts,
            Outcome::Busy => &mut self.busy,
            Outcome::Other => &mut self.other,
            Outcome::Sent => return,
        };
        *c += 1;
    }

    /// The block of the diagnostic register map (module docs).
    pub fn registers(&self) -> [u16; BLOCK] {
        let mut r = [0u16; BLOCK];
        let counts = [
            self.requests,
            self.answers,
            self.exceptions,
            self.timeouts,
            self.crc_errors,
            self.busy,
            self.other,
        ];
        for (i, v) in counts.into_iter().enumerate() {
            let v = v as u32;
            r[2 * i] = (v >> 16) as u16;
            r[2 * i + 1] = v as u16;
        }
        r[14] = self.queue_depth.min(u16::MAX.into()) as u16;
        r[15] = self.reconnects as u16;
        r
    }
}

/// One connected client's counters.
#[derive(Debug, Clone, Serialize)]
pub struct Client {
    /// Its address.
    pub peer: SocketAddr,
    /// Its counters.
    #[serde(flatten)]
    pub counters: Counters,
}

/// Every counter of the gateway.
#[derive(Debug, Clone, Default)]
pub struct Stats {
    /// Per line slot: each line counts in its own slot, which it keeps across reloads (a
    /// removed line's slot stays, unused); [`order`](Self::order) lists the configured lines'.
    pub lines: Vec<Counters>,
    /// Per line slot: why it is down (its port closed and is being reopened), `None` while it
    /// serves.
    pub down: Vec<Option<String>>,
    /// The slots of the configured lines, in configuration order.
    pub order: Vec<usize>,
    /// Per connected client, by connection number (gone when it disconnects).
    pub clients: BTreeMap<u64, Client>,
    /// Per line slot: the units demoted and why ([`crate::demotion`]), kept across
    /// reconnects.
    pub health: Vec<LineHealth>,
    /// Counters per line, unit and outcome for Prometheus ([`crate::gateway_metrics`]),
    /// indexed by slot and labelled by line name; they only grow, across reconnects and
    /// reloads.
    pub metrics: GatewayMetrics,
}

impl Stats {
    /// Counters for `lines` lines and no client yet.
    pub fn new(lines: usize) -> Self {
        Stats {
            lines: vec![Counters::default(); lines],
            down: vec![None; lines],
            order: (0..lines).collect(),
            clients: BTreeMap::new(),
            health: vec![LineHealth::default(); lines],
            metrics: GatewayMetrics::default(),
        }
    }

    /// A new slot, last in the configuration's order, for the line `name` (started, or
    /// added by a reload) demoting its units by `demotion`: its number. Its metrics series,
    /// and those of the slave addresses `units` it serves, are looked up now, so counting a
    /// request allocates nothing ([`GatewayMetrics::add_line`]).
    pub fn add_line(&mut self, name: String, demotion: DemotionConfig, units: &[u8]) -> usize {
        self.lines.push(Counters::default());
        self.down.push(None);
        self.health.push(LineHealth::new(demotion));
        self.metrics.add_line(name, units);
        let slot = self.lines.len() - 1;
        self.order.push(slot);
        slot
    }

    /// The line in slot `slot` is no longer configured: its metrics series go
    /// ([`GatewayMetrics::remove_line`]); its counters stay for the diagnostic unit's totals.
    pub fn remove_line(&mut self, slot: usize) {
        self.metrics.remove_line(slot);
    }

    /// The line-state a scrape reads ([`crate::gateway_metrics::LineNow`]), one per slot; a
    /// slot no configured line uses reads as down, with nothing queued or demoted (its
    /// counters stay).
    pub fn lines_now(&self) -> Vec<LineNow> {
        let mut configured = vec![false; self.lines.len()];
        for &s in &self.order {
            configured[s] = true;
        }
        (0..self.lines.len())
            .map(|i| LineNow {
                up: configured[i] && self.down[i].is_none(),
                queue_depth: self.lines[i].queue_depth,
                demoted: self.health.get(i).map_or(0, |h| h.demoted() as u64),
                reconnects: self.lines[i].reconnects,
            })
            .collect()
    }

    /// Count one request to `unit` on line slot `slot` for Prometheus: its outcome and, if
    /// its answer is an exception, the code.
    pub fn count_request(
        &mut self,
        slot: usize,
        unit: u8,
        outcome: Outcome,
        answer: Option<&si_modbus::mbap::TcpAdu>,
        crc_errors: u64,
    ) {
        let code = answer
            .filter(|a| a.function() & 0x80 != 0)
            .and_then(|a| a.unit_pdu().get(2).copied());
        self.metrics
            .request(slot, unit, outcome.name(), code, crc_errors);
    }

    /// These counters with the configured lines only, in configuration order (slot `i` is
    /// line `i`).
    pub fn in_order(&self) -> Stats {
        Stats {
            lines: self.order.iter().map(|&s| self.lines[s]).collect(),
            down: self.order.iter().map(|&s| self.down[s].clone()).collect(),
            order: (0..self.order.len()).collect(),
            clients: self.clients.clone(),
            health: self
                .order
                .iter()
                .map(|&s| self.health.get(s).cloned().unwrap_or_default())
                .collect(),
            // Labelled by line name, so the order does not matter.
            metrics: self.metrics.clone(),
        }
    }

    /// The client's counters (a request before `connected`, e.g. from a test, gets none).
    pub fn client(&mut self, id: u64) -> Option<&mut Counters> {
        self.clients.get_mut(&id).map(|c| &mut c.counters)
    }

    /// The diagnostic registers as seen by client `id` (module docs).
    pub fn registers(&self, id: u64) -> Vec<u16> {
        let own = self
            .clients
            .get(&id)
            .map(|c| c.counters)
            .unwrap_or_default();
        std::iter::once(own)
            .chain(self.order.iter().map(|&s| self.lines[s]))
            .flat_map(|c| c.registers())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_are_32_bit_high_word_first_in_their_block() {
        let c = Counters {
            requests: 0x1_0002,
            timeouts: 7,
            crc_errors: 4,
            queue_depth: 3,
            reconnects: 0x1_0002,
            ..Counters::default()
        };
        let r = c.registers();
        assert_eq!(&r[0..2], [1, 2]);
        assert_eq!(&r[6..8], [0, 7]);
        assert_eq!(&r[8..10], [0, 4]);
        assert_eq!(r[14], 3);
        assert_eq!(r[15], 2, "reconnects: the low 16 bits");
    }

    #[test]
    fn block_0_is_the_asking_client_and_lines_follow() {
        let mut s = Stats::new(2);
        s.lines[1].answers = 9;
        s.clients.insert(
            4,
            Client {
                peer: "127.0.0.1:1".parse().unwrap(),
                counters: Counters {
                    busy: 5,
                    ..Counters::default()
                },
            },
        );
        let r = s.registers(4);
        assert_eq!(r.len(), 3 * BLOCK);
        assert_eq!(r[11], 5);
        assert_eq!(r[2 * BLOCK + 3], 9);
        assert_eq!(s.registers(99)[11], 0, "another client sees its own block");
    }
}
