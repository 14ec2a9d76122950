//! The one error type of the command line: a line of text for the user, exit code 1.
//!
//! A leaf module: every command returns it, and it imports nothing of the crate.

/// An error for the user: one line, exit code 1.
#[derive(Debug)]
pub struct CliError(pub(crate) String);

impl CliError {
    /// An error with this text.
    pub fn new(text: impl Into<String>) -> Self {
        CliError(text.into())
    }
}

impl<E: std::error::Error> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError(e.to_string())
    }
}
