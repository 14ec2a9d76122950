//! Sequence diagrams of a decoded line as SVG: one lane per station, time running down,
//! frames and control characters as labelled arrows, errors in red with their reason beside
//! them — the kind of figure the manuals draw for 3964(R) ([ET200S SI] §2.7, the
//! STX/DLE/block/DLE exchange) and for the window protocol.
//!
//! Time is drawn as a sequence, not to scale: every record gets a row, its time at the left,
//! and a silence longer than [`GAP_MARK`] gets a dashed break with its length, so a 2-second
//! exchange and a 12-second run of QVZ retries read the same way. A long recording (more than
//! [`MAX_ROWS`] records) is **summarised**: every record with an error or remark is kept with
//! a little context, and each run of uneventful records between them becomes one row that says
//! how many frames passed and over what time; the counters close the figure.

use crate::monitor::{Analysis, Kind, Record, Severity};
use crate::{Duration, Instant};
use std::fmt::Write;

/// Most rows drawn before the diagram is summarised.
pub const MAX_ROWS: usize = 240;

/// A silence longer than this between two records gets a break mark.
pub const GAP_MARK: Duration = Duration::from_millis(50);

const ROW: u32 = 24;
const LEFT: u32 = 120;
const LANE: u32 = 230;
const NOTES: u32 = 470;
const TOP: u32 = 76;

enum Row {
    Record(Record),
    Gap(Duration),
    Summary {
        count: usize,
        from: Instant,
        to: Instant,
    },
}

/// Records kept from the start of a long recording.
const HEAD: usize = 30;
/// Records kept at its end.
const TAIL: usize = 10;
/// Records kept before a remark (the exchange it belongs to).
const BEFORE: usize = 3;

/// The diagram's rows, built as the records arrive, in bounded memory (a live
/// monitor under a flood grew to 312 MB keeping every record for the figure).
///
/// Up to [`MAX_ROWS`] records every record is drawn. Beyond, the figure keeps the first 30,
/// the last 10, and every record with an error or remark together with the three before it
/// and the one after, as long as the [`MAX_ROWS`] budget lasts (first remarks first); each run
/// of the others becomes one summary row. A record's fate is decided when it is `TAIL` (10)
/// records old, so at most `MAX_ROWS + TAIL` records are held, plus the kept rows.
pub struct Diagram {
    /// Records seen.
    seen: usize,
    /// Every record while there are at most [`MAX_ROWS`]; dropped beyond.
    all: Vec<Record>,
    /// The last [`TAIL`] records, not yet decided (the last of them may be the tail).
    recent: std::collections::VecDeque<Record>,
    /// Whether the record just decided had a remark (its successor is its context).
    previous_flagged: bool,
    /// Rows left for remarks and their context.
    budget: usize,
    rows: RowBuilder,
    first_start: Option<Instant>,
}

impl Default for Diagram {
    fn default() -> Self {
        Diagram {
            seen: 0,
            all: Vec::new(),
            recent: std::collections::VecDeque::with_capacity(TAIL + 1),
            previous_flagged: false,
            budget: MAX_ROWS - HEAD - TAIL,
            rows: RowBuilder::default(),
            first_start: None,
        }
    }
}

impl Diagram {
    /// An empty diagram.
    pub fn new() -> Self {
        Diagram::default()
    }

    /// Add the next record (in time order). Its raw bytes and decoded text are not drawn, so
    /// they are not kept.
    pub fn push(&mut self, mut record: Record) {
        record.bytes = Vec::new();
        record.text = String::new();
        self.first_start.get_or_insert(record.start);
        self.seen += 1;
        if self.seen <= MAX_ROWS {
            self.all.push(record.clone());
        } else {
            self.all = Vec::new();
        }
        self.recent.push_back(record);
        if self.recent.len() > TAIL {
            self.decide();
        }
    }

    /// The oldest undecided record is `TAIL` records old: it is not in the tail, and the
    /// records after it that could make it context are known.
    fn decide(&mut self) {
        let Some(record) = self.recent.pop_front() else {
            return;
        };
        let index = self.seen - self.recent.len() - 1;
        let flagged = !record.flags.is_empty();
        let remark_soon = self.recent.iter().take(BEFORE).any(|r| !r.flags.is_empty());
        let keep = if index < HEAD {
            true
        } else if (flagged || remark_soon || self.previous_flagged) && self.budget > 0 {
            self.budget -= 1;
            true
        } else {
            false
        };
        self.previous_flagged = flagged;
        self.rows.push(record, keep);
    }

    /// Records seen.
    #[cfg(test)]
    fn seen(&self) -> usize {
        self.seen
    }

    /// Records and rows held: at most about `MAX_ROWS + TAIL` records and `3 × MAX_ROWS` rows,
    /// however many records were pushed.
    #[cfg(test)]
    fn held(&self) -> usize {
        self.all.len() + self.recent.len() + self.rows.out.len()
    }

    /// The rows to draw.
    fn finish(self) -> Vec<Row> {
        if self.seen <= MAX_ROWS {
            let mut rows = RowBuilder::default();
            for r in self.all {
                rows.push(r, true);
            }
            return rows.finish();
        }
        let mut rows = self.rows;
        for r in self.recent {
            rows.push(r, true);
        }
        rows.finish()
    }

    /// The first record's start, if any.
    pub fn first_start(&self) -> Option<Instant> {
        self.first_start
    }

    /// Draw the diagram: the lanes of `a.stations`, its protocol, counters and span (its
    /// `records` are not read; they came through [`Diagram::push`]).
    pub fn render(self, a: &Analysis) -> String {
        let count = self.seen;
        render_rows(a, count, &self.finish())
    }
}

/// Turns kept and skipped records into rows: a summary for each run of skipped ones, a gap
/// mark before a kept record after a long silence.
#[derive(Default)]
struct RowBuilder {
    out: Vec<Row>,
    skipped: Option<(usize, Instant, Instant)>,
    prev_end: Option<Instant>,
}

impl RowBuilder {
    fn push(&mut self, r: Record, keep: bool) {
        if !keep {
            let s = self.skipped.get_or_insert((0, r.start, r.end));
            s.0 += 1;
            s.2 = r.end;
            return;
        }
        if let Some((count, from, to)) = self.skipped.take() {
            self.out.push(Row::Summary { count, from, to });
            self.prev_end = Some(to);
        }
        if let Some(p) = self.prev_end {
            let gap = r.start.saturating_since(p);
            if gap > GAP_MARK {
                self.out.push(Row::Gap(gap));
            }
        }
        self.prev_end = Some(self.prev_end.map_or(r.end, |p| p.max(r.end)));
        self.out.push(Row::Record(r));
    }

    fn finish(mut self) -> Vec<Row> {
        if let Some((count, from, to)) = self.skipped.take() {
            self.out.push(Row::Summary { count, from, to });
        }
        self.out
    }
}

/// Escape text for XML character data and attribute values.
pub fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            '\'' => s.push_str("&apos;"),
            c if (c as u32) < 0x20 && c != '\n' && c != '\t' => s.push('?'),
            c => s.push(c),
        }
    }
    s
}

fn time(at: Instant) -> String {
    let us = at.as_micros();
    if us < 10_000_000 {
        format!("{:.3} ms", us as f64 / 1000.0)
    } else {
        let s = us as f64 / 1e6;
        if s < 60.0 {
            format!("{s:.4} s")
        } else {
            format!("{}:{:07.4}", (s / 60.0) as u64, s % 60.0)
        }
    }
}

fn span(d: Duration) -> String {
    let us = d.as_micros();
    if us < 1_000_000 {
        format!("{:.1} ms", us as f64 / 1000.0)
    } else {
        format!("{:.3} s", us as f64 / 1e6)
    }
}

fn clip(text: &str, max: usize) -> String {
    if text.chars().count() <= max {
        text.to_owned()
    } else {
        let mut s: String = text.chars().take(max.saturating_sub(1)).collect();
        s.push('…');
        s
    }
}

/// Colour of a control character's box, so STX, DLE and NAK stand out as in the manuals.
fn control_colour(label: &str) -> &'static str {
    match label {
        "STX" => "#1f5fbf",
        "DLE" => "#2e8b57",
        "NAK" => "#c0392b",
        "XON" | "XOFF" => "#8e44ad",
        _ => "#555555",
    }
}

/// Draw the analysis as an SVG document.
pub fn render(a: &Analysis) -> String {
    let mut diagram = Diagram::new();
    for r in &a.records {
        diagram.push(r.clone());
    }
    diagram.render(a)
}

/// Draw `rows` of a recording of `count` records.
fn render_rows(a: &Analysis, count: usize, rows: &[Row]) -> String {
    let lanes = a.stations.len().max(2);
    let lane_x = |i: usize| LEFT + LANE / 2 + LANE * i as u32;
    let counters: Vec<_> = a.counters.0.iter().collect();
    let footer = 40 + 16 * counters.len().div_ceil(2) as u32;
    let width = LEFT + LANE * lanes as u32 + NOTES;
    let body = ROW * rows.len() as u32;
    let height = TOP + body + 30 + footer;
    let bottom = TOP + body + 10;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r##"<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="DejaVu Sans, Arial, sans-serif" font-size="12">
<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerUnits="userSpaceOnUse" markerWidth="10" markerHeight="10" orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="context-stroke"/></marker>
<marker id="arrow-red" viewBox="0 0 10 10" refX="10" refY="5" markerUnits="userSpaceOnUse" markerWidth="10" markerHeight="10" orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#c0392b"/></marker>
<marker id="arrow-black" viewBox="0 0 10 10" refX="10" refY="5" markerUnits="userSpaceOnUse" markerWidth="10" markerHeight="10" orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#222222"/></marker></defs>
<rect width="100%" height="100%" fill="white"/>"##
    );
    let summarised = rows.iter().any(|r| matches!(r, Row::Summary { .. }));
    let _ = writeln!(
        s,
        r#"<text x="12" y="22" font-size="15" font-weight="bold">{} — {} records, {} … {}{}</text>"#,
        escape(&a.protocol),
        count,
        time(a.span.0),
        time(a.span.1),
        if summarised { " (summarised)" } else { "" }
    );
    // Lanes.
    for i in 0..lanes {
        let x = lane_x(i);
        let name = a.stations.get(i).map_or("?", String::as_str);
        let _ = writeln!(
            s,
            r##"<rect x="{}" y="34" width="140" height="24" rx="4" fill="#eef2f7" stroke="#445"/><text x="{x}" y="51" text-anchor="middle" font-weight="bold">{}</text>
<line x1="{x}" y1="58" x2="{x}" y2="{bottom}" stroke="#889" stroke-width="1.5"/>"##,
            x - 70,
            escape(&clip(name, 18))
        );
    }
    let notes_x = LEFT + LANE * lanes as u32 + 8;
    let _ = writeln!(
        s,
        r##"<text x="8" y="70" fill="#666">time</text><text x="{notes_x}" y="70" fill="#666">errors and remarks</text>"##
    );
    for (k, row) in rows.iter().enumerate() {
        let y = TOP + ROW * k as u32 + ROW / 2 + 4;
        match row {
            Row::Gap(d) => {
                let _ = writeln!(
                    s,
                    r##"<rect x="{LEFT}" y="{}" width="{}" height="{}" fill="white"/><line x1="{LEFT}" y1="{y}" x2="{}" y2="{y}" stroke="#aaa" stroke-dasharray="4 4"/><text x="{}" y="{}" fill="#777" font-style="italic">⋯ {} of silence ⋯</text>"##,
                    y - 8,
                    LANE * lanes as u32,
                    16,
                    LEFT + LANE * lanes as u32,
                    LEFT + 6,
                    y - 2,
                    span(*d)
                );
            }
            Row::Summary { count, from, to } => {
                let _ = writeln!(
                    s,
                    r##"<rect x="{}" y="{}" width="{}" height="18" fill="#f4f4f4" stroke="#bbb"/><text x="{}" y="{}" text-anchor="middle" fill="#444" font-style="italic">⋯ {count} records without remarks, {} to {} ⋯</text>"##,
                    LEFT + 4,
                    y - 13,
                    LANE * lanes as u32 - 8,
                    LEFT + LANE * lanes as u32 / 2,
                    y,
                    time(*from),
                    time(*to)
                );
            }
            Row::Record(r) => draw_record(&mut s, r, y, lanes, &lane_x, notes_x),
        }
    }
    // Counters.
    let fy = bottom + 28;
    let _ = writeln!(
        s,
        r#"<text x="12" y="{fy}" font-weight="bold">{} counters</text>"#,
        escape(&a.protocol)
    );
    for (k, (name, value)) in counters.iter().enumerate() {
        let x = 12 + (k % 2) as u32 * 340;
        let y = fy + 18 + 16 * (k / 2) as u32;
        let colour = if **value > 0 && is_fault_counter(name) {
            "#c0392b"
        } else {
            "#222"
        };
        let _ = writeln!(
            s,
            r#"<text x="{x}" y="{y}" fill="{colour}">{}: {value}</text>"#,
            escape(name)
        );
    }
    s.push_str("</svg>\n");
    s
}

fn is_fault_counter(name: &str) -> bool {
    let ok = [
        "ok",
        "messages",
        "telegrams",
        "frames",
        "broadcasts",
        "windows",
        "XON",
        "XOFF",
    ];
    !ok.iter().any(|w| name.ends_with(w) || name == *w)
}

fn draw_record(
    s: &mut String,
    r: &Record,
    y: u32,
    lanes: usize,
    lane_x: &dyn Fn(usize) -> u32,
    notes_x: u32,
) {
    let error = r.has_error();
    let colour = if error { "#c0392b" } else { "#222222" };
    let _ = writeln!(
        s,
        r##"<text x="8" y="{y}" fill="#555">{}</text>"##,
        time(r.start)
    );
    let from = r.from.unwrap_or(0).min(lanes - 1);
    let fx = lane_x(from);
    if r.kind == Kind::Event {
        let _ = writeln!(
            s,
            r##"<rect x="{}" y="{}" width="8" height="8" fill="#7f8c8d"/><text x="{}" y="{y}" fill="#7f8c8d" font-style="italic" font-size="11">{}</text>"##,
            fx - 4,
            y - 8,
            fx + 8,
            escape(&clip(&r.label, 34))
        );
        return;
    }
    if r.kind == Kind::Note {
        let _ = writeln!(
            s,
            r##"<circle cx="{fx}" cy="{}" r="7" fill="white" stroke="{colour}" stroke-width="2"/><path d="M{} {} l6 6 m0 -6 l-6 6" stroke="{colour}" stroke-width="2"/><line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{colour}" stroke-dasharray="2 3"/>"##,
            y - 4,
            fx - 3,
            y - 7,
            fx + 8,
            y - 4,
            notes_x - 6,
            y - 4
        );
    } else {
        // A bus character reaches everyone: draw it to the master's lane (the first) when a
        // slave sends, else across to the last lane, with a dot on every lane it passes.
        let bus = r.to.is_none();
        let target = match r.to {
            Some(t) => t.min(lanes - 1),
            None if from == 0 => lanes - 1,
            None => 0,
        };
        let targets = [target];
        let marker = if error { "arrow-red" } else { "arrow-black" };
        let tx = lane_x(target);
        let (x1, x2) = if tx > fx {
            (fx + 2, tx - 2)
        } else {
            (fx - 2, tx + 2)
        };
        let dash = if bus {
            r#" stroke-dasharray="7 3""#
        } else {
            ""
        };
        let width = if r.kind == Kind::Frame { 2.2 } else { 1.4 };
        let _ = writeln!(
            s,
            r##"<line x1="{x1}" y1="{y}" x2="{x2}" y2="{y}" stroke="{colour}" stroke-width="{width}"{dash} marker-end="url(#{marker})"/>"##
        );
        if bus {
            for i in (0..lanes).filter(|&i| i != from && i != target) {
                let _ = writeln!(
                    s,
                    r#"<circle cx="{}" cy="{y}" r="3" fill="{colour}"/>"#,
                    lane_x(i)
                );
            }
        }
        let far = targets
            .iter()
            .map(|&t| lane_x(t))
            .max_by_key(|&tx| tx.abs_diff(fx))
            .unwrap_or(fx);
        let mid = (fx + far) / 2;
        let label = escape(&clip(&r.label, 26));
        if r.kind == Kind::Control {
            let c = if error {
                "#c0392b"
            } else {
                control_colour(&r.label)
            };
            let w = 9 * r.label.chars().count().min(26) as u32 + 10;
            let _ = writeln!(
                s,
                r##"<rect x="{}" y="{}" width="{w}" height="15" rx="3" fill="{c}"/><text x="{mid}" y="{}" text-anchor="middle" fill="white" font-weight="bold" font-size="11">{label}</text>"##,
                mid - w / 2,
                y - 18,
                y - 7
            );
        } else {
            let _ = writeln!(
                s,
                r##"<text x="{mid}" y="{}" text-anchor="middle" fill="{colour}">{label}</text>"##,
                y - 5
            );
        }
    }
    // Remarks beside the lanes.
    let mut text = String::new();
    for f in &r.flags {
        if !text.is_empty() {
            text.push_str("; ");
        }
        text.push_str(&f.text);
    }
    if !text.is_empty() {
        let worst = r.flags.iter().map(|f| f.severity).max();
        let (fill, style) = match worst {
            Some(Severity::Error) => ("#c0392b", "font-weight=\"bold\""),
            _ => ("#666666", "font-style=\"italic\""),
        };
        let _ = writeln!(
            s,
            r##"<text x="{notes_x}" y="{y}" fill="{fill}" {style}><title>{}</title>{}</text>"##,
            escape(&text),
            escape(&clip(&text, 62))
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_leaves_no_markup_characters() {
        let nasty = "<DLE> & \"STX\" 'x' \u{1}";
        assert_eq!(
            escape(nasty),
            "&lt;DLE&gt; &amp; &quot;STX&quot; &apos;x&apos; ?"
        );
    }

    fn analysis(records: Vec<Record>) -> Analysis {
        Analysis {
            protocol: "modbus".to_owned(),
            stations: vec!["A".to_owned(), "B".to_owned()],
            span: (Instant::ZERO, Instant::from_micros(1_000)),
            records,
            counters: Default::default(),
        }
    }

    /// Record `i` of a steady exchange, 1 ms apart, with a fault where `faulty` says.
    fn record(i: usize, faulty: bool) -> Record {
        let at = Instant::from_micros(1_000 * i as u64);
        let mut r = Record::new(Kind::Frame, at, at, Some(i % 2));
        r.to = Some((i + 1) % 2);
        r.label = format!("frame {i}");
        r.text = "a decoded text the diagram does not draw".repeat(4);
        r.bytes = vec![0x55; 256];
        if faulty {
            r.flags.push(crate::monitor::Flag::error("CRC wrong"));
        }
        r
    }

    #[test]
    fn a_short_recording_draws_every_record() {
        let records: Vec<Record> = (0..MAX_ROWS).map(|i| record(i, i == 100)).collect();
        let svg = render(&analysis(records));
        assert!(svg.contains(&format!("{MAX_ROWS} records")));
        assert!(!svg.contains("summarised") && !svg.contains("without remarks"));
        for i in [0, 100, MAX_ROWS - 1] {
            assert!(svg.contains(&format!(">frame {i}<")), "record {i} drawn");
        }
    }

    /// Head 30, the remark at 500 with three before and one after, tail 10; the runs between
    /// become summary rows.
    #[test]
    fn a_long_recording_keeps_head_remarks_with_context_and_tail() {
        let records: Vec<Record> = (0..1000).map(|i| record(i, i == 500)).collect();
        let svg = render(&analysis(records));
        assert!(svg.contains("1000 records") && svg.contains("(summarised)"));
        assert!(svg.contains("⋯ 467 records without remarks"), "30 … 496");
        assert!(svg.contains("⋯ 488 records without remarks"), "502 … 989");
        for kept in [0, 29, 497, 500, 501, 990, 999] {
            assert!(svg.contains(&format!(">frame {kept}<")), "{kept} kept");
        }
        for skipped in [30, 496, 502, 989] {
            assert!(
                !svg.contains(&format!(">frame {skipped}<")),
                "{skipped} skipped"
            );
        }
    }

    /// A flood of records, every tenth with a fault, holds a bounded number of
    /// records and rows, and still draws the budget's worth of remarks.
    #[test]
    fn a_flood_is_summarised_as_it_arrives() {
        let mut d = Diagram::new();
        let mut most = 0;
        for i in 0..200_000 {
            d.push(record(i, i % 10 == 0));
            most = most.max(d.held());
        }
        assert_eq!(d.seen(), 200_000);
        assert!(most <= MAX_ROWS + TAIL + 3 * MAX_ROWS, "held {most}");
        let svg = d.render(&analysis(Vec::new()));
        assert!(svg.contains("200000 records") && svg.contains("(summarised)"));
        assert!(svg.len() < 200_000, "{} bytes", svg.len());
        assert!(svg.contains(">frame 199999<"), "the tail is drawn");
    }

    #[test]
    fn clip_and_time_stay_short() {
        assert_eq!(clip("abcdef", 4), "abc…");
        assert_eq!(time(Instant::from_micros(1_146)), "1.146 ms");
        assert_eq!(time(Instant::from_micros(12_500_000)), "12.5000 s");
        assert_eq!(time(Instant::from_micros(600_000_000)), "10:00.0000");
    }
}
