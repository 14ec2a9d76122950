//! A small metrics registry rendered in the Prometheus text exposition format (version 0.0.4):
//! counters, gauges and histograms with fixed buckets, labelled series, no dependency.
//!
//! Gateway behaviour, not a manual's `[derived]`. The format, as Prometheus documents it: per
//! family a `# HELP name text` line (backslash and line feed escaped) and a `# TYPE name kind`
//! line, then one `name{label="value",…} number` line per series (label values with
//! backslash, double quote and line feed escaped). A histogram's series are
//! `name_bucket{…,le="bound"}` with cumulative counts, the last bucket `le="+Inf"`, then
//! `name_sum` and `name_count`.
//!
//! Families are registered once and addressed by typed ids ([`Counter`], [`Gauge`],
//! [`Histogram`]), so a counter can only be increased: it never goes down while the registry
//! lives (keep one registry for the process and counters survive reconnects and reloads).
//! Families render in registration order, series sorted by their labels, so a scrape is
//! deterministic.
//!
//! A series can also be looked up once ([`Registry::counter_series`] and its siblings) and
//! then counted by its [`SeriesId`], with no label built and nothing allocated: the hot path
//! of a program counting per request. A series looked up so is not in the scrape until it is
//! first counted, set or observed, exactly as if it had been created then.

use std::collections::BTreeMap;
use std::fmt::Write;

/// Response-time buckets in seconds: Prometheus client libraries' defaults, which span a fast
/// RTU answer (a few ms at 115 200 bit/s) to a slave's longest timeout.
pub const RESPONSE_TIME_BUCKETS: &[f64] = &[
    0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0,
];

/// The labels of one series: names are fixed by the code, values come from the configuration.
pub type Labels = Vec<(&'static str, String)>;

/// A counter family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Counter(usize);
/// A gauge family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gauge(usize);
/// A histogram family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Histogram(usize);

#[derive(Debug, Clone)]
enum Series {
    Counter(u64),
    Gauge(f64),
    Histogram {
        /// Observations per bucket, not cumulative; one more than the bounds (+Inf).
        counts: Vec<u64>,
        sum: f64,
    },
}

/// One series of a registry, looked up by its labels once and counted by this id after.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeriesId(usize);

#[derive(Debug, Clone)]
struct Family {
    name: &'static str,
    help: &'static str,
    kind: &'static str,
    bounds: &'static [f64],
    /// The series by their labels: indices in [`Registry::values`].
    series: BTreeMap<Labels, usize>,
}

/// A series' value, and whether it shows in the scrape yet.
#[derive(Debug, Clone)]
struct Value {
    series: Series,
    shown: bool,
    /// Its family (a histogram's bounds).
    family: usize,
}

/// The registry: families in registration order.
#[derive(Debug, Clone, Default)]
pub struct Registry {
    families: Vec<Family>,
    /// Every series' value, by [`SeriesId`]. A dropped series' value stays, unreachable
    /// ([`Registry::drop_series`]; reloads that remove lines are rare).
    values: Vec<Value>,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Registry::default()
    }

    fn family(
        &mut self,
        name: &'static str,
        help: &'static str,
        kind: &'static str,
        bounds: &'static [f64],
    ) -> usize {
        debug_assert!(valid_name(name), "metric name {name:?}");
        self.families.push(Family {
            name,
            help,
            kind,
            bounds,
            series: BTreeMap::new(),
        });
        self.families.len() - 1
    }

    /// Register a counter family (its name should end in `_total`).
    pub fn counter(&mut self, name: &'static str, help: &'static str) -> Counter {
        Counter(self.family(name, help, "counter", &[]))
    }

    /// Register a gauge family.
    pub fn gauge(&mut self, name: &'static str, help: &'static str) -> Gauge {
        Gauge(self.family(name, help, "gauge", &[]))
    }

    /// Register a histogram family with these upper bounds, ascending (the `+Inf` bucket is
    /// added).
    pub fn histogram(
        &mut self,
        name: &'static str,
        help: &'static str,
        bounds: &'static [f64],
    ) -> Histogram {
        Histogram(self.family(name, help, "histogram", bounds))
    }

    /// The series of family `family` with `labels`, created empty and unshown if new.
    fn series(&mut self, family: usize, labels: Labels) -> SeriesId {
        let f = &mut self.families[family];
        if let Some(&at) = f.series.get(&labels) {
            return SeriesId(at);
        }
        let series = match f.kind {
            "counter" => Series::Counter(0),
            "gauge" => Series::Gauge(0.0),
            _ => Series::Histogram {
                counts: vec![0; f.bounds.len() + 1],
                sum: 0.0,
            },
        };
        let at = self.values.len();
        f.series.insert(labels, at);
        self.values.push(Value {
            series,
            shown: false,
            family,
        });
        SeriesId(at)
    }

    /// A counter's series with `labels`, to count by its id (not in the scrape until counted).
    pub fn counter_series(&mut self, counter: Counter, labels: Labels) -> SeriesId {
        self.series(counter.0, labels)
    }

    /// A gauge's series with `labels`, to set by its id (not in the scrape until set).
    pub fn gauge_series(&mut self, gauge: Gauge, labels: Labels) -> SeriesId {
        self.series(gauge.0, labels)
    }

    /// A histogram's series with `labels`, to observe by its id (not in the scrape until an
    /// observation).
    pub fn histogram_series(&mut self, histogram: Histogram, labels: Labels) -> SeriesId {
        self.series(histogram.0, labels)
    }

    /// Add `by` to counter series `id` (0 too: it is then in the scrape).
    pub fn add(&mut self, id: SeriesId, by: u64) {
        let v = &mut self.values[id.0];
        v.shown = true;
        if let Series::Counter(n) = &mut v.series {
            *n = n.saturating_add(by);
        }
    }

    /// Raise counter series `id` to `total` if it is below; never lowers it.
    pub fn raise_to(&mut self, id: SeriesId, total: u64) {
        let v = &mut self.values[id.0];
        v.shown = true;
        if let Series::Counter(n) = &mut v.series {
            *n = (*n).max(total);
        }
    }

    /// Set gauge series `id`.
    pub fn set_to(&mut self, id: SeriesId, value: f64) {
        let v = &mut self.values[id.0];
        v.shown = true;
        if let Series::Gauge(g) = &mut v.series {
            *g = value;
        }
    }

    /// Record one observation in histogram series `id`.
    pub fn record(&mut self, id: SeriesId, value: f64) {
        let v = &mut self.values[id.0];
        v.shown = true;
        let bounds = self.families[v.family].bounds;
        if let Series::Histogram { counts, sum } = &mut v.series {
            let at = bounds
                .iter()
                .position(|&b| value <= b)
                .unwrap_or(bounds.len());
            counts[at] += 1;
            *sum += value;
        }
    }

    /// Add `by` to a counter's series (created at 0 if new).
    pub fn inc(&mut self, counter: Counter, labels: Labels, by: u64) {
        let id = self.counter_series(counter, labels);
        self.add(id, by);
    }

    /// Raise a counter's series to `total` if it is below (a count kept elsewhere that only
    /// grows, read at scrape time); never lowers it.
    pub fn raise(&mut self, counter: Counter, labels: Labels, total: u64) {
        let id = self.counter_series(counter, labels);
        self.raise_to(id, total);
    }

    /// Create a counter's series at 0 if it does not exist, so a scrape shows it before its
    /// first event.
    pub fn touch(&mut self, counter: Counter, labels: Labels) {
        self.inc(counter, labels, 0);
    }

    /// Drop every series whose labels `gone` says so, of every family (a target that is gone:
    /// its series disappear from the scrape, as Prometheus expects). Their ids count nowhere
    /// visible after.
    pub fn drop_series(&mut self, gone: impl Fn(&Labels) -> bool) {
        for f in &mut self.families {
            f.series.retain(|labels, _| !gone(labels));
        }
    }

    /// A counter's value (0 if the series does not exist).
    #[cfg(test)]
    pub fn counter_value(&self, counter: Counter, labels: &Labels) -> u64 {
        match self.families[counter.0].series.get(labels) {
            Some(&at) => match self.values[at].series {
                Series::Counter(v) => v,
                _ => 0,
            },
            None => 0,
        }
    }

    /// Set a gauge's series.
    pub fn set(&mut self, gauge: Gauge, labels: Labels, value: f64) {
        let id = self.gauge_series(gauge, labels);
        self.set_to(id, value);
    }

    /// Record one observation (seconds, for response times) in a histogram's series.
    pub fn observe(&mut self, histogram: Histogram, labels: Labels, value: f64) {
        let id = self.histogram_series(histogram, labels);
        self.record(id, value);
    }

    /// The text exposition of every family.
    pub fn render(&self) -> String {
        let mut out = String::new();
        for f in &self.families {
            let _ = writeln!(out, "# HELP {} {}", f.name, escape_help(f.help));
            let _ = writeln!(out, "# TYPE {} {}", f.name, f.kind);
            for (labels, &at) in &f.series {
                let value = &self.values[at];
                if !value.shown {
                    continue;
                }
                match &value.series {
                    Series::Counter(v) => {
                        let _ = writeln!(out, "{}{} {v}", f.name, label_set(labels, None));
                    }
                    Series::Gauge(v) => {
                        let _ =
                            writeln!(out, "{}{} {}", f.name, label_set(labels, None), number(*v));
                    }
                    Series::Histogram { counts, sum } => {
                        let mut cumulative = 0;
                        for (i, n) in counts.iter().enumerate() {
                            cumulative += n;
                            let le = f
                                .bounds
                                .get(i)
                                .map_or_else(|| "+Inf".to_string(), |b| number(*b));
                            let _ = writeln!(
                                out,
                                "{}_bucket{} {cumulative}",
                                f.name,
                                label_set(labels, Some(&le))
                            );
                        }
                        let set = label_set(labels, None);
                        let _ = writeln!(out, "{}_sum{set} {}", f.name, number(*sum));
                        let _ = writeln!(out, "{}_count{set} {cumulative}", f.name);
                    }
                }
            }
        }
        out
    }
}

/// `{a="x",b="y"}` (with `le` last if given), or nothing without labels.
fn label_set(labels: &Labels, le: Option<&str>) -> String {
    let mut pairs: Vec<String> = labels
        .iter()
        .map(|(k, v)| format!("{k}=\"{}\"", escape_value(v)))
        .collect();
    if let Some(le) = le {
        pairs.push(format!("le=\"{le}\""));
    }
    if pairs.is_empty() {
        String::new()
    } else {
        format!("{{{}}}", pairs.join(","))
    }
}

/// A sample value: integers without a fraction, `+Inf`/`-Inf`/`NaN` as the format spells them.
fn number(v: f64) -> String {
    if v.is_nan() {
        "NaN".into()
    } else if v.is_infinite() {
        if v > 0.0 { "+Inf" } else { "-Inf" }.into()
    } else {
        format!("{v}")
    }
}

fn escape_help(s: &str) -> String {
    s.replace('\\', "\\\\").replace('\n', "\\n")
}

fn escape_value(s: &str) -> String {
    s.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// `[a-zA-Z_:][a-zA-Z0-9_:]*`, the format's metric names.
fn valid_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_' || c == ':')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':')
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(name: &str) -> Labels {
        vec![("line", name.to_string())]
    }

    #[test]
    fn counters_render_with_help_type_and_sorted_series() {
        let mut r = Registry::new();
        let c = r.counter("si_requests_total", "Requests routed to a line.");
        r.inc(c, line("b"), 2);
        r.inc(c, line("a"), 1);
        r.inc(c, line("b"), 3);
        r.touch(c, line("c"));
        assert_eq!(
            r.render(),
            "# HELP si_requests_total Requests routed to a line.\n\
             # TYPE si_requests_total counter\n\
             si_requests_total{line=\"a\"} 1\n\
             si_requests_total{line=\"b\"} 5\n\
             si_requests_total{line=\"c\"} 0\n"
        );
        assert_eq!(r.counter_value(c, &line("b")), 5);
        r.raise(c, line("b"), 4);
        assert_eq!(
            r.counter_value(c, &line("b")),
            5,
            "a counter never goes down"
        );
        r.raise(c, line("b"), 7);
        assert_eq!(r.counter_value(c, &line("b")), 7);
    }

    #[test]
    fn gauges_are_set_not_added() {
        let mut r = Registry::new();
        let g = r.gauge("si_line_up", "1 while the line's port is open.");
        r.set(g, line("x"), 1.0);
        r.set(g, line("x"), 0.0);
        let q = r.gauge("si_temperature", "no labels");
        r.set(q, vec![], 0.5);
        assert_eq!(
            r.render(),
            "# HELP si_line_up 1 while the line's port is open.\n\
             # TYPE si_line_up gauge\n\
             si_line_up{line=\"x\"} 0\n\
             # HELP si_temperature no labels\n\
             # TYPE si_temperature gauge\n\
             si_temperature 0.5\n"
        );
    }

    #[test]
    fn histogram_buckets_are_cumulative_with_inf_sum_and_count() {
        let mut r = Registry::new();
        let h = r.histogram("si_rt_seconds", "Response time.", &[0.01, 0.1]);
        for v in [0.005, 0.01, 0.05, 3.0] {
            r.observe(h, line("l"), v);
        }
        assert_eq!(
            r.render(),
            "# HELP si_rt_seconds Response time.\n\
             # TYPE si_rt_seconds histogram\n\
             si_rt_seconds_bucket{line=\"l\",le=\"0.01\"} 2\n\
             si_rt_seconds_bucket{line=\"l\",le=\"0.1\"} 3\n\
             si_rt_seconds_bucket{line=\"l\",le=\"+Inf\"} 4\n\
             si_rt_seconds_sum{line=\"l\"} 3.065\n\
             si_rt_seconds_count{line=\"l\"} 4\n"
        );
    }

    #[test]
    fn label_values_and_help_are_escaped() {
        let mut r = Registry::new();
        let c = r.counter("x_total", "a \\ b\nc");
        r.inc(c, vec![("line", "q\"u\\o\nte".into())], 1);
        assert_eq!(
            r.render(),
            "# HELP x_total a \\\\ b\\nc\n\
             # TYPE x_total counter\n\
             x_total{line=\"q\\\"u\\\\o\\nte\"} 1\n"
        );
    }

    #[test]
    fn a_series_looked_up_shows_once_counted_as_if_created_then() {
        let mut r = Registry::new();
        let c = r.counter("x_total", "x");
        let h = r.histogram("t_seconds", "t", &[0.1]);
        let id = r.counter_series(c, line("a"));
        let t = r.histogram_series(h, line("a"));
        let empty = "# HELP x_total x\n# TYPE x_total counter\n\
                     # HELP t_seconds t\n# TYPE t_seconds histogram\n";
        assert_eq!(r.render(), empty);
        assert_eq!(r.counter_series(c, line("a")), id, "one series per labels");
        r.add(id, 2);
        r.inc(c, line("a"), 1);
        r.record(t, 0.05);
        assert_eq!(
            r.render(),
            "# HELP x_total x\n# TYPE x_total counter\nx_total{line=\"a\"} 3\n\
             # HELP t_seconds t\n# TYPE t_seconds histogram\n\
             t_seconds_bucket{line=\"a\",le=\"0.1\"} 1\n\
             t_seconds_bucket{line=\"a\",le=\"+Inf\"} 1\n\
             t_seconds_sum{line=\"a\"} 0.05\n\
             t_seconds_count{line=\"a\"} 1\n"
        );
    }

    #[test]
    fn dropped_series_disappear_and_the_others_stay() {
        let mut r = Registry::new();
        let c = r.counter("x_total", "x");
        let g = r.gauge("y", "y");
        r.inc(c, line("a"), 1);
        r.inc(c, line("b"), 2);
        r.set(g, line("a"), 1.0);
        r.drop_series(|l| l == &line("a"));
        assert_eq!(
            r.render(),
            "# HELP x_total x\n# TYPE x_total counter\nx_total{line=\"b\"} 2\n# HELP y y\n# TYPE y gauge\n"
        );
    }

    #[test]
    fn names_are_checked() {
        assert!(valid_name("si_gateway_requests_total"));
        assert!(valid_name("a:b_c9"));
        assert!(!valid_name("9a"));
        assert!(!valid_name("a-b"));
        assert!(!valid_name(""));
        assert_eq!(number(f64::INFINITY), "+Inf");
        assert_eq!(number(2.0), "2");
    }
}
