//! The gateway's one error type: what was refused or failed, as one line for the user.
//!
//! A leaf module: it imports nothing of the crate.

/// Why the gateway could not start or stopped.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The configuration was refused (a key out of range, settings a line cannot have): no
    /// retry can mend it.
    #[error("{0}")]
    Config(String),
    /// A line's serial port or device server could not be opened (missing, busy, refused):
    /// it may be back later.
    #[error("{0}")]
    Port(String),
    /// Anything else: a listening address taken, a socket that failed.
    #[error("{0}")]
    Io(String),
}

impl Error {
    /// An [`Error::Io`] of this text.
    pub fn new(text: impl Into<String>) -> Self {
        Error::Io(text.into())
    }

    /// The line the user reads.
    pub fn text(&self) -> &str {
        match self {
            Error::Config(t) | Error::Port(t) | Error::Io(t) => t,
        }
    }

    /// The same kind of error with `prefix` before its text (`line NAME: `).
    pub fn prefixed(self, prefix: &str) -> Self {
        match self {
            Error::Config(t) => Error::Config(format!("{prefix}{t}")),
            Error::Port(t) => Error::Port(format!("{prefix}{t}")),
            Error::Io(t) => Error::Io(format!("{prefix}{t}")),
        }
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Io(e.to_string())
    }
}
