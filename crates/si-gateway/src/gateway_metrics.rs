//! The gateway's metric families for Prometheus (served on `metrics_listen`, see
//! `metrics_http`), kept in one [`Registry`] for the whole process so no counter ever goes
//! down across reconnects or reloads. Lines are indexed by their counter slot (which a line
//! keeps across reloads; a line added by a reload gets the next one, [`GatewayMetrics::add_line`])
//! and labelled by name; a `unit` label is the slave's address on the line (the TCP unit id
//! unless the line's `unit_map` remaps it), as demotion judges units.
//!
//! | family | type | labels | what |
//! |---|---|---|---|
//! | `si_gateway_requests_total` | counter | line, unit, outcome | requests routed to a line, by what became of them: `answer`, `exception` (the slave's), `timeout` (0BH), `busy` (06H), `other` (0AH, 01H, 03H, 04H), `sent` (a broadcast), `demoted` (refused with 0BH at once: the unit is demoted, [`crate::demotion`]) |
//! | `si_gateway_exceptions_total` | counter | line, unit, code | exception answers returned to clients, the slave's and the gateway's own, by code (`0x0B`, …) |
//! | `si_gateway_retries_total` | counter | line, unit | requests repeated on the line after a failed attempt |
//! | `si_gateway_crc_errors_total` | counter | line, unit | answers with a wrong CRC, also those a retry cured |
//! | `si_gateway_demotion_events_total` | counter | line, event | `demoted`, `probe_failed`, `restored` |
//! | `si_gateway_reconnects_total` | counter | line | times the line's port was reopened |
//! | `si_gateway_line_up` | gauge | line | 1 while the line serves, 0 while its port is being reopened |
//! | `si_gateway_queue_depth` | gauge | line | requests waiting for the line |
//! | `si_gateway_demoted_units` | gauge | line | units whose requests are refused with 0BH now |
//! | `si_gateway_response_time_seconds` | histogram | line | time a request spent on the line, retries included |
//! | `si_gateway_rtu_over_tcp_frames_total` | counter | outcome | frames on `rtu_over_tcp_listen`: `ok`, `crc_error` (dropped), `dropped` (no frame) |

use super::metrics::{Counter, Gauge, Histogram, Labels, Registry, RESPONSE_TIME_BUCKETS};

/// What a scrape reads from a line's state at that moment.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LineNow {
    /// The line serves (its port is open).
    pub up: bool,
    /// Requests waiting.
    pub queue_depth: u64,
    /// Units demoted now.
    pub demoted: u64,
    /// Reopenings so far.
    pub reconnects: u64,
}

/// What a scrape reads from the RTU-over-TCP listener's counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RtuNow {
    /// Frames with a valid CRC.
    pub frames: u64,
    /// Frames dropped for a wrong CRC.
    pub crc_errors: u64,
    /// Other bytes dropped.
    pub dropped: u64,
}

/// The registry with the gateway's families, and the line names its labels use.
#[derive(Debug, Clone)]
pub struct GatewayMetrics {
    registry: Registry,
    lines: Vec<String>,
    /// By slot: the line was removed by a reload (its series are gone).
    removed: Vec<bool>,
    requests: Counter,
    exceptions: Counter,
    retries: Counter,
    crc_errors: Counter,
    demotion_events: Counter,
    reconnects: Counter,
    line_up: Gauge,
    queue_depth: Gauge,
    demoted: Gauge,
    response_time: Histogram,
    rtu_frames: Counter,
}

impl Default for GatewayMetrics {
    fn default() -> Self {
        GatewayMetrics::new(Vec::new())
    }
}

impl GatewayMetrics {
    /// The families, empty, for lines named `lines` in slot order.
    pub fn new(lines: Vec<String>) -> Self {
        let mut r = Registry::new();
        let requests = r.counter(
            "si_gateway_requests_total",
            "Requests routed to a line, by unit and outcome.",
        );
        let exceptions = r.counter(
            "si_gateway_exceptions_total",
            "Exception answers returned to clients, the slave's and the gateway's, by code.",
        );
        let retries = r.counter(
            "si_gateway_retries_total",
            "Requests repeated on the line after a failed attempt.",
        );
        let crc_errors = r.counter(
            "si_gateway_crc_errors_total",
            "Answers with a wrong CRC, also those a retry cured.",
        );
        let demotion_events = r.counter(
            "si_gateway_demotion_events_total",
            "Units demoted, failed probes and units restored.",
        );
        let reconnects = r.counter(
            "si_gateway_reconnects_total",
            "Times the line's port was reopened after it closed.",
        );
        let line_up = r.gauge(
            "si_gateway_line_up",
            "1 while the line serves, 0 while its port is being reopened.",
        );
        let queue_depth = r.gauge("si_gateway_queue_depth", "Requests waiting for the line.");
        let demoted = r.gauge(
            "si_gateway_demoted_units",
            "Units whose requests are answered 0BH at once.",
        );
        let response_time = r.histogram(
            "si_gateway_response_time_seconds",
            "Time a request spent on the line, retries included.",
            RESPONSE_TIME_BUCKETS,
        );
        let rtu_frames = r.counter(
            "si_gateway_rtu_over_tcp_frames_total",
            "Frames on the RTU-over-TCP listener, by outcome.",
        );
        GatewayMetrics {
            rtu_frames,
            registry: r,
            removed: vec![false; lines.len()],
            lines,
            requests,
            exceptions,
            retries,
            crc_errors,
            demotion_events,
            reconnects,
            line_up,
            queue_depth,
            demoted,
            response_time,
        }
    }

    /// Label the next line slot `name` (a line started, or added by a reload).
    pub fn add_line(&mut self, name: String) {
        self.lines.push(name);
        self.removed.push(false);
    }

    /// The line in slot `index` was removed: its series (every family's with its `line`
    /// label) disappear from the scrape, as a gone target's do in Prometheus, and it is no
    /// longer reported. A line of the same name added later starts its series from 0, a
    /// counter reset Prometheus's `rate()` and `increase()` handle.
    pub fn remove_line(&mut self, index: usize) {
        let Some(removed) = self.removed.get_mut(index) else {
            return;
        };
        *removed = true;
        let name = self.line(index);
        self.registry
            .drop_series(|labels| labels.iter().any(|(k, v)| *k == "line" && *v == name));
    }

    fn line(&self, index: usize) -> String {
        self.lines
            .get(index)
            .cloned()
            .unwrap_or_else(|| index.to_string())
    }

    fn unit_labels(&self, index: usize, unit: u8) -> Labels {
        vec![("line", self.line(index)), ("unit", unit.to_string())]
    }

    /// Count one request to `unit` on line `index`: its outcome (a name of the table above),
    /// the exception code it was answered with if any, and the corrupt answers it met.
    pub fn request(
        &mut self,
        index: usize,
        unit: u8,
        outcome: &'static str,
        exception: Option<u8>,
        crc_errors: u64,
    ) {
        let mut labels = self.unit_labels(index, unit);
        labels.push(("outcome", outcome.to_string()));
        self.registry.inc(self.requests, labels, 1);
        if let Some(code) = exception {
            let mut labels = self.unit_labels(index, unit);
            labels.push(("code", format!("0x{code:02X}")));
            self.registry.inc(self.exceptions, labels, 1);
        }
        // Also by 0: the series exists from the unit's first request, as `retries_total`'s
        // does, so `rate()` and `increase()` see the first error.
        let labels = self.unit_labels(index, unit);
        self.registry.inc(self.crc_errors, labels, crc_errors);
    }

    /// Count the retries one request to `unit` on line `index` needed.
    pub fn retried(&mut self, index: usize, unit: u8, retries: u64) {
        let labels = self.unit_labels(index, unit);
        if retries > 0 {
            self.registry.inc(self.retries, labels, retries);
        } else {
            self.registry.touch(self.retries, labels);
        }
    }

    /// Record how long one request spent on line `index`.
    pub fn response_time(&mut self, index: usize, seconds: f64) {
        let labels = vec![("line", self.line(index))];
        self.registry.observe(self.response_time, labels, seconds);
    }

    /// Count a demotion event (`demoted`, `probe_failed`, `restored`) on line `index`.
    pub fn demotion_event(&mut self, index: usize, event: &'static str) {
        let labels = vec![("line", self.line(index)), ("event", event.to_string())];
        self.registry.inc(self.demotion_events, labels, 1);
    }

    /// The text exposition, with the gauges and reconnects read from `now` (one per slot) and
    /// the RTU-over-TCP listener's counters if it runs.
    pub fn render(&mut self, now: &[LineNow], rtu: Option<RtuNow>) -> String {
        if let Some(c) = rtu {
            for (outcome, n) in [
                ("ok", c.frames),
                ("crc_error", c.crc_errors),
                ("dropped", c.dropped),
            ] {
                let labels = vec![("outcome", outcome.to_string())];
                self.registry.raise(self.rtu_frames, labels, n);
            }
        }
        for (index, l) in now.iter().enumerate() {
            if self.removed.get(index) == Some(&true) {
                continue;
            }
            let labels = vec![("line", self.line(index))];
            let r = &mut self.registry;
            r.set(self.line_up, labels.clone(), f64::from(u8::from(l.up)));
            r.set(self.queue_depth, labels.clone(), l.queue_depth as f64);
            r.set(self.demoted, labels.clone(), l.demoted as f64);
            r.raise(self.reconnects, labels, l.reconnects);
        }
        self.registry.render()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_counts_its_outcome_code_and_crc_errors() {
        let mut m = GatewayMetrics::new(vec!["a".into()]);
        m.request(0, 7, "timeout", Some(0x0B), 2);
        m.request(0, 7, "answer", None, 0);
        m.retried(0, 7, 2);
        m.response_time(0, 0.02);
        let text = m.render(
            &[LineNow {
                up: true,
                queue_depth: 1,
                demoted: 0,
                reconnects: 3,
            }],
            Some(RtuNow {
                frames: 4,
                crc_errors: 1,
                dropped: 0,
            }),
        );
        for want in [
            "si_gateway_requests_total{line=\"a\",unit=\"7\",outcome=\"timeout\"} 1\n",
            "si_gateway_requests_total{line=\"a\",unit=\"7\",outcome=\"answer\"} 1\n",
            "si_gateway_exceptions_total{line=\"a\",unit=\"7\",code=\"0x0B\"} 1\n",
            "si_gateway_crc_errors_total{line=\"a\",unit=\"7\"} 2\n",
            "si_gateway_retries_total{line=\"a\",unit=\"7\"} 2\n",
            "si_gateway_reconnects_total{line=\"a\"} 3\n",
            "si_gateway_line_up{line=\"a\"} 1\n",
            "si_gateway_queue_depth{line=\"a\"} 1\n",
            "si_gateway_response_time_seconds_bucket{line=\"a\",le=\"0.025\"} 1\n",
            "si_gateway_response_time_seconds_count{line=\"a\"} 1\n",
            "si_gateway_rtu_over_tcp_frames_total{outcome=\"crc_error\"} 1\n",
        ] {
            assert!(text.contains(want), "{want} not in\n{text}");
        }
    }

    #[test]
    fn a_units_crc_error_series_exists_from_its_first_request() {
        let mut m = GatewayMetrics::new(vec!["a".into()]);
        m.request(0, 4, "answer", None, 0);
        let text = m.render(&[LineNow::default()], None);
        assert!(
            text.contains("si_gateway_crc_errors_total{line=\"a\",unit=\"4\"} 0\n"),
            "{text}"
        );
    }

    #[test]
    fn a_removed_lines_series_disappear() {
        let mut m = GatewayMetrics::new(vec!["a".into(), "b".into()]);
        m.request(0, 7, "answer", None, 0);
        m.request(1, 8, "answer", None, 0);
        m.response_time(1, 0.02);
        m.remove_line(1);
        let text = m.render(&[LineNow::default(), LineNow::default()], None);
        assert!(!text.contains("line=\"b\""), "{text}");
        assert!(
            text.contains("si_gateway_line_up{line=\"a\"} 0\n"),
            "{text}"
        );
        assert!(
            text.contains(
                "si_gateway_requests_total{line=\"a\",unit=\"7\",outcome=\"answer\"} 1\n"
            ),
            "{text}"
        );
    }

    #[test]
    fn reconnects_never_go_down() {
        let mut m = GatewayMetrics::new(vec!["a".into()]);
        let at = |n| LineNow {
            reconnects: n,
            ..LineNow::default()
        };
        m.render(&[at(5)], None);
        let text = m.render(&[at(0)], None);
        assert!(
            text.contains("si_gateway_reconnects_total{line=\"a\"} 5\n"),
            "{text}"
        );
    }
}
