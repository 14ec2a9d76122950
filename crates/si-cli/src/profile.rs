//! Named line profiles from a settings file: `--profile plc1` instead of typing `--port --baud
//! --parity` every time.
//!
//! The file is TOML, read from `$SI_CONFIG` if set, else the platform's configuration
//! directory: `$XDG_CONFIG_HOME/si/config.toml` or `~/.config/si/config.toml` (Linux and other
//! Unix), `~/Library/Application Support/si/config.toml` (macOS), `%APPDATA%\si\config.toml`
//! (Windows). It is read only when `--profile` is given. Each profile is a table of the line
//! options, named as the flags with `_` for `-`:
//!
//! ```toml
//! [profile.plc1]
//! port = "/dev/ttyUSB0"
//! baud = 19200
//! parity = "even"      # none, even, odd, mark, space
//! data_bits = 8
//! stop_bits = 1
//! ```
//!
//! Also `tcp`, `latency_timer`, `rx_latency_ms` (the port's delivery latency declared to the
//! engine, 0–255 ms, as `--rx-latency`), `rs485` (`kernel`, `rts`, `rts-inverted`, `sysfs`,
//! `sysfs-inverted`), `rs485_file`, `rs485_delay_before`, `rs485_delay_after`, `local_echo`,
//! `no_line_errors`. The file is read through [`crate::config_file`] (at most 4 MiB). An
//! unknown key is refused with its line, and so are `port` and `tcp` together (a line is one
//! or the other);
//! baud, data bits, parity and stop bits are checked with the same errors as the flags
//! ([`SerialSettings`]), naming the file, line and key. The baud rate is checked against the
//! widest list (USS adds 187 500 bit/s); the command then checks its own list, as for the flag.
//!
//! Precedence: a flag on the command line (or its environment variable, `SI_PORT`) wins over
//! the profile, which wins over the default. A `--port` or `--tcp` flag replaces both of the
//! profile's `port` and `tcp`: a line is chosen as a whole.

use crate::config_file;
use crate::conn::Connection;
use crate::error::CliError;
use clap::parser::ValueSource;
use clap::ArgMatches;
use serde::Deserialize;
use si_core::port::Rs485Mode;
use si_core::{Parity, SerialSettings};
use std::collections::BTreeMap;
use std::path::PathBuf;
use toml::Spanned;

/// The settings file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SettingsFile {
    /// The named profiles.
    #[serde(default)]
    profile: BTreeMap<String, Profile>,
}

/// One named profile: the line options it supplies.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct Profile {
    port: Option<Spanned<String>>,
    tcp: Option<Spanned<String>>,
    baud: Option<Spanned<u32>>,
    data_bits: Option<Spanned<u8>>,
    parity: Option<Spanned<String>>,
    stop_bits: Option<Spanned<u8>>,
    latency_timer: Option<Spanned<u64>>,
    rx_latency_ms: Option<Spanned<u64>>,
    rs485: Option<Rs485Mode>,
    rs485_file: Option<PathBuf>,
    rs485_delay_before: Option<u64>,
    rs485_delay_after: Option<u64>,
    local_echo: Option<bool>,
    no_line_errors: Option<bool>,
}

/// Where the settings file is: `$SI_CONFIG`, else `si/config.toml` in the platform's
/// configuration directory (see the module doc).
pub fn settings_path() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("SI_CONFIG") {
        return Some(PathBuf::from(p));
    }
    config_dir().map(|d| d.join("si").join("config.toml"))
}

/// The platform's per-user configuration directory, by the platform's own rule (the few lines
/// the `dirs` crate would add a dependency for).
fn config_dir() -> Option<PathBuf> {
    let var = |name: &str| {
        std::env::var_os(name)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if cfg!(windows) {
        var("APPDATA")
    } else if cfg!(target_os = "macos") {
        var("HOME").map(|h| h.join("Library/Application Support"))
    } else {
        var("XDG_CONFIG_HOME").or_else(|| var("HOME").map(|h| h.join(".config")))
    }
}

/// Fill the line options the user did not give on the command line from `--profile`, if any.
pub fn apply(conn: &mut Connection, matches: &ArgMatches) -> Result<(), CliError> {
    let Some(name) = conn.profile.clone() else {
        return Ok(());
    };
    let path = settings_path()
        .ok_or_else(|| CliError::new("--profile: no settings file: set SI_CONFIG or HOME"))?;
    let text = config_file::read(&path)
        .map_err(|e| CliError::new(format!("--profile {name}: {}", e.text())))?;
    let mut file: SettingsFile = config_file::parse_toml(&path, &text)?;
    let profile = file.profile.remove(&name).ok_or_else(|| {
        let names: Vec<_> = file.profile.keys().map(String::as_str).collect();
        CliError::new(format!(
            "{}: no profile {name:?}; the file has: {}",
            path.display(),
            names.join(", ")
        ))
    })?;
    let table = format!("[profile.{name}]");
    let at = |key: &str, span: std::ops::Range<usize>, e: &dyn std::fmt::Display| {
        config_file::placed(&path, &text, span, Some(&format!("{table} {key}")), e)
    };
    config_file::refuse_together(
        &path,
        &text,
        &table,
        ("port", profile.port.as_ref().map(Spanned::span)),
        ("tcp", profile.tcp.as_ref().map(Spanned::span)),
    )?;
    profile.check(&at)?;
    profile.fill(conn, |id| explicit(matches, id));
    Ok(())
}

/// Places an error in the settings file: key, its span in the text, why.
type Placed<'a> = dyn Fn(&str, std::ops::Range<usize>, &dyn std::fmt::Display) -> CliError + 'a;

impl Profile {
    /// Check the character format with the flags' own errors ([`SerialSettings`]), each value
    /// on its own so the error names the key; `at` places the error in the file.
    fn check(&self, at: &Placed<'_>) -> Result<(), CliError> {
        let rates = &si_uss::config::USS_BAUD_RATES;
        let format =
            |baud, bits, stop| SerialSettings::with_rates(baud, bits, Parity::Even, stop, rates);
        if let Some(b) = &self.baud {
            format(*b.get_ref(), 8, 1).map_err(|e| at("baud", b.span(), &e))?;
        }
        if let Some(d) = &self.data_bits {
            format(9600, *d.get_ref(), 1).map_err(|e| at("data_bits", d.span(), &e))?;
        }
        if let Some(s) = &self.stop_bits {
            format(9600, 8, *s.get_ref()).map_err(|e| at("stop_bits", s.span(), &e))?;
        }
        if let Some(p) = &self.parity {
            p.get_ref()
                .parse::<Parity>()
                .map_err(|e| at("parity", p.span(), &e))?;
        }
        // Checked here, not only when the port opens, so the error names the file and key.
        if let Some(t) = &self.latency_timer {
            let range = si_core::port::LATENCY_TIMER_MS;
            if !range.contains(t.get_ref()) {
                let why = format!(
                    "latency timer {} ms out of range: {} … {} ms",
                    t.get_ref(),
                    range.start(),
                    range.end()
                );
                return Err(at("latency_timer", t.span(), &why));
            }
        }
        if let Some(t) = &self.rx_latency_ms {
            if *t.get_ref() > 255 {
                let why = format!("rx latency {} ms out of range: 0 … 255 ms", t.get_ref());
                return Err(at("rx_latency_ms", t.span(), &why));
            }
        }
        Ok(())
    }

    /// Set each option the profile has and the command line did not give (`explicit`).
    fn fill(self, conn: &mut Connection, explicit: impl Fn(&str) -> bool) {
        fn set<T>(field: &mut T, value: Option<T>, given: bool) {
            if let (Some(v), false) = (value, given) {
                *field = v;
            }
        }
        let line_given = explicit("port") || explicit("tcp");
        if !line_given && (self.port.is_some() || self.tcp.is_some()) {
            conn.port = self.port.map(Spanned::into_inner);
            conn.tcp = self.tcp.map(Spanned::into_inner);
        }
        set(
            &mut conn.baud,
            self.baud.map(Spanned::into_inner),
            explicit("baud"),
        );
        set(
            &mut conn.data_bits,
            self.data_bits.map(Spanned::into_inner),
            explicit("data_bits"),
        );
        set(
            &mut conn.parity,
            self.parity.map(Spanned::into_inner),
            explicit("parity"),
        );
        set(
            &mut conn.stop_bits,
            self.stop_bits.map(Spanned::into_inner),
            explicit("stop_bits"),
        );
        set(
            &mut conn.latency_timer,
            self.latency_timer.map(|t| Some(t.into_inner())),
            explicit("latency_timer"),
        );
        set(
            &mut conn.rx_latency,
            self.rx_latency_ms.map(|t| Some(t.into_inner())),
            explicit("rx_latency"),
        );
        set(&mut conn.rs485, self.rs485.map(Some), explicit("rs485"));
        set(
            &mut conn.rs485_file,
            self.rs485_file.map(Some),
            explicit("rs485_file"),
        );
        set(
            &mut conn.rs485_delay_before,
            self.rs485_delay_before,
            explicit("rs485_delay_before"),
        );
        set(
            &mut conn.rs485_delay_after,
            self.rs485_delay_after,
            explicit("rs485_delay_after"),
        );
        set(
            &mut conn.local_echo,
            self.local_echo,
            explicit("local_echo"),
        );
        set(
            &mut conn.no_line_errors,
            self.no_line_errors,
            explicit("no_line_errors"),
        );
    }
}

/// Did the user give this option (flag or environment variable), at any level of the
/// subcommands?
fn explicit(matches: &ArgMatches, id: &str) -> bool {
    matches!(
        crate::conn::value_source(matches, id),
        Some(ValueSource::CommandLine | ValueSource::EnvVariable)
    )
}
