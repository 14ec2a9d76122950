//! What the gateway reports about its lines as they go down and come back: events handed to
//! the program's sink, which prints, logs or counts them as it likes.
//!
//! A leaf module: it imports nothing of the crate.

use std::sync::Arc;

/// A line's change of state, or a unit's on it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// A line went down: its port closed (`at_start` false; it is being reopened), or could not
    /// be opened at start (`at_start`, only with `allow_down_at_start`). Its requests get 0AH
    /// meanwhile.
    LineDown {
        /// The line's counter slot: its index in the configuration as started (a reload
        /// keeps a line's slot and gives added lines new ones; `Stats::order` maps them).
        line: usize,
        /// Its name.
        name: String,
        /// Why.
        reason: String,
        /// The line was never open.
        at_start: bool,
    },
    /// A line serves: reopened after it went down (`reopened`), or opened for the first time
    /// after it started down.
    LineUp {
        /// The line's counter slot (as in [`Event::LineDown`]).
        line: usize,
        /// Its name.
        name: String,
        /// Its reconnects so far.
        reconnects: u64,
        /// It had been open before.
        reopened: bool,
    },
    /// A unit failed `failures` requests in a row and is demoted for `for_ms`: its requests
    /// get 0BH at once, nothing goes to the line (`crate::demotion`).
    UnitDemoted {
        /// The line's counter slot (as in [`Event::LineDown`]).
        line: usize,
        /// Its name.
        name: String,
        /// The unit id.
        unit: u8,
        /// The failures in a row.
        failures: u32,
        /// How long it stays demoted, in ms.
        for_ms: u64,
    },
    /// The one request that probed a demoted unit failed: demoted again for `for_ms`.
    UnitProbeFailed {
        /// The line's counter slot (as in [`Event::LineDown`]).
        line: usize,
        /// Its name.
        name: String,
        /// The unit id.
        unit: u8,
        /// How long it stays demoted, in ms.
        for_ms: u64,
    },
    /// The probe was answered: the unit is served again.
    UnitRestored {
        /// The line's counter slot (as in [`Event::LineDown`]).
        line: usize,
        /// Its name.
        name: String,
        /// The unit id.
        unit: u8,
    },
}

impl std::fmt::Display for Event {
    /// The log line: `line NAME: closed (why); reopening`, `line NAME: reopened`, ….
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Event::LineDown {
                name,
                reason,
                at_start: true,
                ..
            } => write!(
                f,
                "line {name}: not opened at start ({reason}); trying again"
            ),
            Event::LineDown { name, reason, .. } => {
                write!(f, "line {name}: closed ({reason}); reopening")
            }
            Event::LineUp {
                name,
                reopened: true,
                ..
            } => write!(f, "line {name}: reopened"),
            Event::LineUp { name, .. } => write!(f, "line {name}: opened"),
            Event::UnitDemoted {
                name,
                unit,
                failures,
                for_ms,
                ..
            } => write!(
                f,
                "line {name}: unit {unit} demoted for {for_ms} ms after {failures} failed requests"
            ),
            Event::UnitProbeFailed {
                name, unit, for_ms, ..
            } => write!(
                f,
                "line {name}: unit {unit} still not answering; demoted for {for_ms} ms more"
            ),
            Event::UnitRestored { name, unit, .. } => {
                write!(f, "line {name}: unit {unit} answers again")
            }
        }
    }
}

/// Where events go: called on the line's task, so it should not block.
pub type Events = Arc<dyn Fn(&Event) + Send + Sync>;

/// A sink that drops every event.
pub fn ignore() -> Events {
    Arc::new(|_: &Event| {})
}
