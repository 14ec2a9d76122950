//! The files a user hands `si` whole, read through si-core's bounded reader
//! ([`si_core::config_file`]: capped size, errors naming the file, line and key), with its
//! errors as this program's error (exit code 1).
//!
//! A leaf module: it imports only the error type.

use crate::error::CliError;
use serde::de::DeserializeOwned;
use si_core::config_file as file;
use std::ops::Range;
use std::path::Path;

pub use si_core::config_file::key_span;

/// The whole text of `path`, read through the cap ([`file::read`]).
pub fn read(path: &Path) -> Result<String, CliError> {
    Ok(file::read(path)?)
}

/// [`read`], then parse the text as TOML into `T` ([`file::read_toml`]).
pub fn read_toml<T: DeserializeOwned>(path: &Path) -> Result<T, CliError> {
    Ok(file::read_toml(path)?)
}

/// Parse `text`, the contents of `path`, as TOML into `T` ([`file::parse_toml`]).
pub fn parse_toml<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T, CliError> {
    Ok(file::parse_toml(path, text)?)
}

/// An error at byte `span` of `text`, naming the file, line and key ([`file::placed`]).
pub fn placed(
    path: &Path,
    text: &str,
    span: Range<usize>,
    key: Option<&str>,
    why: impl std::fmt::Display,
) -> CliError {
    file::placed(path, text, span, key, why).into()
}

/// Refuse a table that sets two keys that exclude each other ([`file::refuse_together`]).
pub fn refuse_together(
    path: &Path,
    text: &str,
    table: &str,
    first: (&str, Option<Range<usize>>),
    second: (&str, Option<Range<usize>>),
) -> Result<(), CliError> {
    Ok(file::refuse_together(path, text, table, first, second)?)
}
