//! Sequence diagrams of a decoded line as SVG: one lane per station, time running down,
//! frames and control characters as labelled arrows, errors in red with their reason beside
//! them — the kind of figure the manuals draw for 3964(R) (et200s-si-3964r-ascii.md §5, the
//! STX/DLE/block/DLE exchange) and for the window protocol.
//!
//! Time is drawn as a sequence, not to scale: every record gets a row, its time at the left,
//! and a silence longer than [`GAP_MARK`] gets a dashed break with its length, so a 2-second
//! exchange and a 12-second run of QVZ retries read the same way. A long recording (more than
//! [`MAX_ROWS`] records) is **summarised**: every record with an error or remark is kept with
//! a little context, and each run of uneventful records between them becomes one row that says
//! how many frames passed and over what time; the counters close the figure.

use si_core::monitor::{Analysis, Kind, Record, Severity};
use si_core::{Duration, Instant};
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

enum Row<'a> {
    Record(&'a Record),
    Gap(Duration),
    Summary {
        count: usize,
        from: Instant,
        to: Instant,
    },
}

/// Choose the rows: every record, or a summary of a long recording.
fn rows(records: &[Record]) -> Vec<Row<'_>> {
    let keep: Vec<bool> = if records.len() <= MAX_ROWS {
        vec![true; records.len()]
    } else {
        let mut keep = vec![false; records.len()];
        let head = 30.min(records.len());
        keep[..head].iter_mut().for_each(|k| *k = true);
        let tail = records.len().saturating_sub(10);
        keep[tail..].iter_mut().for_each(|k| *k = true);
        let mut budget = MAX_ROWS.saturating_sub(head + 10);
        for (i, r) in records.iter().enumerate() {
            if budget == 0 {
                break;
            }
            if !r.flags.is_empty() {
                // The remark, the three records before it (the exchange it belongs to) and the
                // one after (how the line recovered).
                let last = (i + 1).min(records.len() - 1);
                for k in &mut keep[i.saturating_sub(3)..=last] {
                    if !*k && budget > 0 {
                        *k = true;
                        budget -= 1;
                    }
                }
            }
        }
        keep
    };
    let mut out = Vec::new();
    let mut skipped: Option<(usize, Instant, Instant)> = None;
    let mut prev_end: Option<Instant> = None;
    for (r, k) in records.iter().zip(keep) {
        if !k {
            let s = skipped.get_or_insert((0, r.start, r.end));
            s.0 += 1;
            s.2 = r.end;
            continue;
        }
        if let Some((count, from, to)) = skipped.take() {
            out.push(Row::Summary { count, from, to });
            prev_end = Some(to);
        }
        if let Some(p) = prev_end {
            let gap = r.start.saturating_since(p);
            if gap > GAP_MARK {
                out.push(Row::Gap(gap));
            }
        }
        out.push(Row::Record(r));
        prev_end = Some(prev_end.map_or(r.end, |p| p.max(r.end)));
    }
    if let Some((count, from, to)) = skipped {
        out.push(Row::Summary { count, from, to });
    }
    out
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
    let lanes = a.stations.len().max(2);
    let lane_x = |i: usize| LEFT + LANE / 2 + LANE * i as u32;
    let rows = rows(&a.records);
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
        a.records.len(),
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

    #[test]
    fn clip_and_time_stay_short() {
        assert_eq!(clip("abcdef", 4), "abc…");
        assert_eq!(time(Instant::from_micros(1_146)), "1.146 ms");
        assert_eq!(time(Instant::from_micros(12_500_000)), "12.5000 s");
        assert_eq!(time(Instant::from_micros(600_000_000)), "10:00.0000");
    }
}
