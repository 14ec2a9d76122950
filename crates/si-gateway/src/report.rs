//! What the gateway says about itself, as a line of text for people and a JSON object for
//! scripts: the addresses it listens on, its lines' events and its counters (the `si gateway`
//! command prints these; a program embedding the gateway may print or log them alike).

use crate::config::Config;
use crate::counters::Stats;
use crate::event::Event;
use crate::listeners::Extra;
use crate::Listener;
use serde_json::{json, Value};

/// The status: every configured line's counters and state, and every client's, from
/// [`Gateway::stats`](crate::Gateway::stats) (lines in configuration order).
pub fn status_text(gw: &Config, s: &Stats) -> String {
    let text = gw
        .lines
        .iter()
        .zip(s.lines.iter().zip(&s.down))
        .map(|(l, (c, down))| {
            let state = down.as_ref().map(|why| format!(" (down: {why})")).unwrap_or_default();
            format!(
                "{}{state}: {} requests, {} answers, {} exceptions, {} timeouts, {} CRC errors, {} busy, {} other, queue {}, {} reconnects",
                l.name, c.requests, c.answers, c.exceptions, c.timeouts, c.crc_errors, c.busy, c.other, c.queue_depth, c.reconnects
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    format!("status: {text}; {} client(s)", s.clients.len())
}

/// [`status_text`] as JSON: `{"event": "status", "lines": [...], "clients": [...]}`.
pub fn status_json(gw: &Config, s: &Stats) -> Value {
    let lines: Vec<_> = gw
        .lines
        .iter()
        .zip(s.lines.iter().zip(&s.down))
        .map(|(l, (c, down))| {
            let mut v = serde_json::to_value(c).unwrap_or_default();
            v["name"] = l.name.clone().into();
            v["state"] = if down.is_some() { "down" } else { "up" }.into();
            if let Some(why) = down {
                v["down_reason"] = why.clone().into();
            }
            v
        })
        .collect();
    let clients: Vec<_> = s
        .clients
        .iter()
        .map(|(id, c)| {
            let mut v = serde_json::to_value(c).unwrap_or_default();
            v["id"] = (*id).into();
            v
        })
        .collect();
    json!({"event": "status", "lines": lines, "clients": clients})
}

/// Faces listed by address in the text of the "listening" line; more are counted only.
const LISTED_FACES: usize = 8;

/// The "listening" line: the top-level address and the line count, then the other addresses.
pub fn listening_text(gw: &Config, faces: &[Listener]) -> String {
    let mut text = format!(
        "gateway listening on {}, {} line(s)",
        faces[0].addr,
        gw.lines.len()
    );
    for f in faces.iter().skip(1).take(LISTED_FACES) {
        let names: Vec<_> = f.lines.iter().map(|&i| gw.lines[i].name.as_str()).collect();
        text += &format!("; {}: {}", f.addr, names.join(", "));
    }
    if faces.len() > LISTED_FACES + 1 {
        text += &format!("; {} more address(es)", faces.len() - LISTED_FACES - 1);
    }
    text
}

/// The "listening" event: `addr` (the top-level face) and every line's name, and
/// `listeners`, every face's address with its lines' names (the top-level face first).
pub fn listening_json(gw: &Config, faces: &[Listener]) -> Value {
    let names = |lines: &[usize]| -> Vec<&str> {
        lines.iter().map(|&i| gw.lines[i].name.as_str()).collect()
    };
    let listeners: Vec<_> = faces
        .iter()
        .map(|f| json!({"addr": f.addr.to_string(), "lines": names(&f.lines)}))
        .collect();
    json!({"event": "listening", "addr": faces[0].addr.to_string(),
        "lines": gw.lines.iter().map(|l| &l.name).collect::<Vec<_>>(),
        "listeners": listeners})
}

/// An extra listener's line: `metrics: listening on ADDR`, `rtu-over-tcp: listening on ADDR`.
pub fn extra_text(e: &Extra) -> String {
    let name = e.event.trim_end_matches("_listening").replace('_', "-");
    format!("{name}: listening on {}", e.addr)
}

/// [`extra_text`] as JSON: `{"event": "metrics_listening", "addr": ...}` (or
/// `rtu_over_tcp_listening`).
pub fn extra_json(e: &Extra) -> Value {
    json!({"event": e.event, "addr": e.addr.to_string()})
}

/// A line's event as JSON (`line_down` with the reason, `line_up` with the reconnects,
/// `unit_demoted`, `unit_probe_failed`, `unit_restored`); its text is its `Display`.
pub fn event_json(event: &Event) -> Value {
    match event {
        Event::LineDown {
            name,
            reason,
            at_start,
            ..
        } => json!({"event": "line_down", "line": name, "reason": reason, "at_start": at_start}),
        Event::LineUp {
            name, reconnects, ..
        } => json!({"event": "line_up", "line": name, "reconnects": reconnects}),
        Event::UnitDemoted {
            name,
            unit,
            failures,
            for_ms,
            ..
        } => json!({"event": "unit_demoted", "line": name, "unit": unit,
            "failures": failures, "for_ms": for_ms}),
        Event::UnitProbeFailed {
            name, unit, for_ms, ..
        } => json!({"event": "unit_probe_failed", "line": name, "unit": unit,
            "for_ms": for_ms}),
        Event::UnitRestored { name, unit, .. } => {
            json!({"event": "unit_restored", "line": name, "unit": unit})
        }
    }
}
