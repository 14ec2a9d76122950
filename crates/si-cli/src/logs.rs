//! `-v`, `-vv`, `-vvv`: the `tracing` subscriber that prints si's logs on stderr.
//!
//! A leaf module: `main` calls [`init`] once, before any command runs.
//!
//! The levels (the driver's module docs, "Logs", say who emits what): INFO is each frame sent
//! and received, decoded as text; DEBUG adds the raw bytes in hex and the engines' events;
//! TRACE adds the timers. Only si's own crates log at the level asked for; dependencies (tokio,
//! mio) stay at WARN. `RUST_LOG` replaces the whole filter when set. Every line carries its
//! wall-clock time (RFC 3339, UTC). Colour only when stderr is a terminal and `NO_COLOR` is
//! unset or empty (<https://no-color.org>): never escape codes into a pipe or a file.

use std::io::IsTerminal;
use tracing_subscriber::EnvFilter;

/// The crates whose logs `-v` raises (tracing targets start with the crate name).
const OURS: [&str; 9] = [
    "si",
    "si_core",
    "si_3964r",
    "si_rk512",
    "si_ascii",
    "si_modbus",
    "si_uss",
    "si_dp_coord",
    "si_module",
];

/// The filter for `verbose` times `-v`: WARN for everyone, our crates at the level asked for.
pub fn filter(verbose: u8) -> String {
    let level = match verbose {
        0 => return "warn".to_owned(),
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let ours: Vec<String> = OURS.iter().map(|c| format!("{c}={level}")).collect();
    format!("warn,{}", ours.join(","))
}

/// Colour on stderr: a terminal, and no `NO_COLOR` with a value.
pub fn colour(is_terminal: bool, no_color: Option<std::ffi::OsString>) -> bool {
    is_terminal && no_color.is_none_or(|v| v.is_empty())
}

/// Install the subscriber for `verbose` times `-v`.
pub fn init(verbose: u8) {
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(filter(verbose)));
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(colour(
            std::io::stderr().is_terminal(),
            std::env::var_os("NO_COLOR"),
        ))
        // The module a line comes from matters for debugging, not for reading frames.
        .with_target(verbose >= 2)
        .with_env_filter(filter)
        .init();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_our_crates_are_raised() {
        assert_eq!(filter(0), "warn");
        let f = filter(3);
        assert!(f.starts_with("warn,"));
        assert!(f.contains("si_core=trace") && f.contains("si_modbus=trace"));
        assert!(!f.contains("mio") && !f.contains("tokio"));
        // Every directive parses.
        assert!(EnvFilter::try_new(&f).is_ok());
    }

    #[test]
    fn colour_needs_a_terminal_and_no_no_color() {
        assert!(colour(true, None));
        assert!(colour(true, Some("".into())));
        assert!(!colour(true, Some("1".into())));
        assert!(!colour(false, None));
    }
}
