//! The user's hex arguments.
//!
//! A leaf module: the protocol commands, `si frame` and the module commands all read hex, so it
//! lives below them rather than in one of them.

use crate::error::CliError;

/// Parse the user's hex argument, turning a mistake into a one-line error. Frame commands take
/// the bytes as one quoted argument or as several words (`01 03 00 00`), joined with spaces.
pub fn parse_hex(text: &str) -> Result<Vec<u8>, CliError> {
    si_core::hex::parse(text).map_err(|e| CliError::new(format!("bad hex {text:?}: {e}")))
}
