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
//!
//! A request is counted without building a label or allocating: each line's series, and
//! those of the units it serves, are looked up once when the line is added (at the start, or
//! by a reload) and counted by their ids ([`crate::metrics::SeriesId`]). A unit the line was
//! not configured with (a broadcast's 0), or an exception code first seen, is looked up the
//! first time only.

use super::metrics::{Counter, Gauge, Histogram, Registry, SeriesId, RESPONSE_TIME_BUCKETS};
use std::collections::BTreeMap;

/// The `outcome` label values of `si_gateway_requests_total`, the table's order.
const OUTCOMES: [&str; 7] = [
    "answer",
    "exception",
    "timeout",
    "busy",
    "other",
    "sent",
    "demoted",
];

/// The `event` label values of `si_gateway_demotion_events_total`.
const DEMOTION_EVENTS: [&str; 3] = ["demoted", "probe_failed", "restored"];

/// One unit's series on one line.
#[derive(Debug, Clone)]
struct UnitSeries {
    /// `requests_total`, by [`OUTCOMES`].
    requests: [SeriesId; OUTCOMES.len()],
    crc_errors: SeriesId,
    retries: SeriesId,
    /// `exceptions_total` by code, as they occur.
    exceptions: Vec<(u8, SeriesId)>,
}

/// One line's series, and its units'.
#[derive(Debug, Clone)]
struct LineSeries {
    /// The line's `line` label value.
    name: String,
    units: BTreeMap<u8, UnitSeries>,
    response_time: SeriesId,
    /// `demotion_events_total`, by [`DEMOTION_EVENTS`].
    demotion_events: [SeriesId; DEMOTION_EVENTS.len()],
    reconnects: SeriesId,
    line_up: SeriesId,
    queue_depth: SeriesId,
    demoted: SeriesId,
}

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

/// The registry with the gateway's families, and each line's series.
#[derive(Debug, Clone)]
pub struct GatewayMetrics {
    registry: Registry,
    /// By slot: the line's series (`None`: removed by a reload, its series are gone).
    lines: Vec<Option<LineSeries>>,
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
    /// The families, empty, for lines named `lines` in slot order (their units looked up as
    /// they come).
    pub fn new(lines: Vec<String>) -> Self {
        let mut m = GatewayMetrics::families();
        for name in lines {
            m.add_line(name, &[]);
        }
        m
    }

    /// The families, empty, with no line.
    fn families() -> Self {
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
            lines: Vec::new(),
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

    /// Label the next line slot `name` (a line started, or added by a reload), and look up
    /// its series and those of the slave addresses `units` it serves, so their requests are
    /// counted without allocating.
    pub fn add_line(&mut self, name: String, units: &[u8]) {
        let line = || vec![("line", name.clone())];
        let r = &mut self.registry;
        let with = |key, value: &str| {
            let mut l = line();
            l.push((key, value.to_string()));
            l
        };
        let mut series = LineSeries {
            response_time: r.histogram_series(self.response_time, line()),
            demotion_events: DEMOTION_EVENTS
                .map(|e| r.counter_series(self.demotion_events, with("event", e))),
            reconnects: r.counter_series(self.reconnects, line()),
            line_up: r.gauge_series(self.line_up, line()),
            queue_depth: r.gauge_series(self.queue_depth, line()),
            demoted: r.gauge_series(self.demoted, line()),
            units: BTreeMap::new(),
            name: name.clone(),
        };
        for &unit in units {
            self.unit_series(&name, &mut series.units, unit);
        }
        self.lines.push(Some(series));
    }

    /// Line slot `index`'s series, taken out to count (put back with [`Self::put`]); a slot
    /// never added is labelled by its number, as counters kept without names are; `None` for
    /// a removed line.
    fn take(&mut self, index: usize) -> Option<LineSeries> {
        while self.lines.len() <= index {
            self.add_line(self.lines.len().to_string(), &[]);
        }
        self.lines[index].take()
    }

    /// Put line slot `index`'s series back after [`Self::take`].
    fn put(&mut self, index: usize, line: LineSeries) {
        self.lines[index] = Some(line);
    }

    /// Unit `unit`'s series among line `name`'s `units`, looked up the first time.
    fn unit_series<'a>(
        &mut self,
        name: &str,
        units: &'a mut BTreeMap<u8, UnitSeries>,
        unit: u8,
    ) -> &'a mut UnitSeries {
        let r = &mut self.registry;
        let (requests, crc_errors, retries) = (self.requests, self.crc_errors, self.retries);
        units.entry(unit).or_insert_with(|| {
            let labels = || vec![("line", name.to_string()), ("unit", unit.to_string())];
            let with_outcome = |o: &str| {
                let mut l = labels();
                l.push(("outcome", o.to_string()));
                l
            };
            UnitSeries {
                requests: OUTCOMES.map(|o| r.counter_series(requests, with_outcome(o))),
                crc_errors: r.counter_series(crc_errors, labels()),
                retries: r.counter_series(retries, labels()),
                exceptions: Vec::new(),
            }
        })
    }

    /// The line in slot `index` was removed: its series (every family's with its `line`
    /// label) disappear from the scrape, as a gone target's do in Prometheus, and it is no
    /// longer reported. A line of the same name added later starts its series from 0, a
    /// counter reset Prometheus's `rate()` and `increase()` handle.
    pub fn remove_line(&mut self, index: usize) {
        let Some(line) = self.lines.get_mut(index).and_then(Option::take) else {
            return;
        };
        let name = line.name;
        self.registry
            .drop_series(|labels| labels.iter().any(|(k, v)| *k == "line" && *v == name));
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
        let Some(mut line) = self.take(index) else {
            return;
        };
        let exceptions = self.exceptions;
        let name = line.name.as_str();
        let u = self.unit_series(name, &mut line.units, unit);
        let at = OUTCOMES.iter().position(|&o| o == outcome);
        let (requests, crc) = (at.map(|at| u.requests[at]), u.crc_errors);
        let code = exception.map(|code| match u.exceptions.iter().find(|(c, _)| *c == code) {
            Some(&(_, id)) => id,
            None => {
                let labels = vec![
                    ("line", name.to_string()),
                    ("unit", unit.to_string()),
                    ("code", format!("0x{code:02X}")),
                ];
                let id = self.registry.counter_series(exceptions, labels);
                u.exceptions.push((code, id));
                id
            }
        });
        self.put(index, line);
        if let Some(id) = requests {
            self.registry.add(id, 1);
        }
        if let Some(id) = code {
            self.registry.add(id, 1);
        }
        // Also by 0: the series exists from the unit's first request, as `retries_total`'s
        // does, so `rate()` and `increase()` see the first error.
        self.registry.add(crc, crc_errors);
    }

    /// Count the retries one request to `unit` on line `index` needed.
    pub fn retried(&mut self, index: usize, unit: u8, retries: u64) {
        let Some(mut line) = self.take(index) else {
            return;
        };
        let id = self.unit_series(&line.name, &mut line.units, unit).retries;
        self.put(index, line);
        // By 0 too: the series exists from the unit's first request.
        self.registry.add(id, retries);
    }

    /// Record how long one request spent on line `index`.
    pub fn response_time(&mut self, index: usize, seconds: f64) {
        if let Some(line) = self.take(index) {
            self.registry.record(line.response_time, seconds);
            self.put(index, line);
        }
    }

    /// Count a demotion event (`demoted`, `probe_failed`, `restored`) on line `index`.
    pub fn demotion_event(&mut self, index: usize, event: &'static str) {
        let Some(line) = self.take(index) else {
            return;
        };
        if let Some(at) = DEMOTION_EVENTS.iter().position(|&e| e == event) {
            self.registry.add(line.demotion_events[at], 1);
        }
        self.put(index, line);
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
        if let Some(last) = now.len().checked_sub(1) {
            // Slots never added are labelled by their number.
            if let Some(line) = self.take(last) {
                self.put(last, line);
            }
        }
        for (line, l) in self.lines.iter().zip(now) {
            let Some(line) = line else { continue };
            let r = &mut self.registry;
            r.set_to(line.line_up, f64::from(u8::from(l.up)));
            r.set_to(line.queue_depth, l.queue_depth as f64);
            r.set_to(line.demoted, l.demoted as f64);
            r.raise_to(line.reconnects, l.reconnects);
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

    /// A sequence touching every family: two lines, units, outcomes, codes, retries, times,
    /// demotion events, gauges and the RTU listener's counters.
    fn sequence(m: &mut GatewayMetrics) -> String {
        m.request(0, 7, "answer", None, 0);
        m.request(0, 7, "timeout", Some(0x0B), 2);
        m.request(0, 3, "exception", Some(0x02), 0);
        m.request(1, 12, "answer", None, 1);
        m.request(1, 0, "sent", None, 0);
        m.request(0, 7, "demoted", Some(0x0B), 0);
        m.request(1, 12, "other", Some(0x0A), 0);
        m.retried(0, 7, 2);
        m.retried(0, 3, 0);
        m.retried(1, 12, 1);
        m.response_time(0, 0.004);
        m.response_time(0, 0.3);
        m.response_time(1, 12.0);
        m.demotion_event(0, "demoted");
        m.demotion_event(0, "restored");
        m.demotion_event(1, "probe_failed");
        let now = |up, depth, demoted, reconnects| LineNow {
            up,
            queue_depth: depth,
            demoted,
            reconnects,
        };
        let rtu = RtuNow {
            frames: 5,
            crc_errors: 1,
            dropped: 2,
        };
        m.render(&[now(true, 2, 1, 0), now(false, 0, 0, 3)], Some(rtu))
    }

    /// The exposition of [`sequence`] as the registry rendered it when every request built
    /// its labels: counting by precomputed series must not change a byte of it.
    const EXPOSITION: &str = include_str!("../tests/data/metrics_exposition.prom");

    #[test]
    fn counting_by_precomputed_series_renders_byte_for_byte_as_before() {
        let names = || vec!["a".to_string(), "b \"q\"".to_string()];
        // Units looked up as they come.
        assert_eq!(sequence(&mut GatewayMetrics::new(names())), EXPOSITION);
        // Units looked up when the line is added, one (5) never asked: not in the scrape.
        let mut m = GatewayMetrics::families();
        m.add_line("a".into(), &[3, 5, 7]);
        m.add_line("b \"q\"".into(), &[12]);
        assert_eq!(sequence(&mut m), EXPOSITION);
    }
}
