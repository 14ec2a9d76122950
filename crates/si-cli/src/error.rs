//! The one error type of the command line: a line of text for the user and the exit code that
//! says what kind of failure it was.
//!
//! A leaf module: every command returns it, and it imports nothing of the crate. The exit codes
//! are the ones `si --help` documents ([`EXIT_CODES`]).

/// Exit code of a protocol or I/O failure (a STATUS, a line that closed, a file not read).
pub const EXIT_FAILURE: u8 = 1;
/// Exit code of a usage error: what clap exits with for a bad argument, and what our own
/// checks of the arguments exit with before a port is opened.
pub const EXIT_USAGE: u8 = 2;
/// Exit code after Ctrl-C (SIGINT): 128 + 2, what a shell reports for a program SIGINT ended.
pub const EXIT_INTERRUPTED: u8 = 130;

/// The exit codes as `si --help` shows them (its `after_help`).
pub const EXIT_CODES: &str = "Exit codes:
  0    done
  1    protocol or I/O failure (a STATUS other than 16#0000, the line closed, a file not read)
  2    usage (a bad or missing argument)
  130  interrupted (Ctrl-C, SIGINT)";

/// An error for the user: one line, and the exit code of its kind.
#[derive(Debug)]
pub struct CliError {
    text: String,
    code: u8,
}

impl CliError {
    /// A protocol or I/O failure with this text: exit code 1.
    pub fn new(text: impl Into<String>) -> Self {
        CliError {
            text: text.into(),
            code: EXIT_FAILURE,
        }
    }

    /// Arguments our own checks reject (before any port is opened): exit code 2, as clap's.
    pub fn usage(text: impl Into<String>) -> Self {
        CliError {
            text: text.into(),
            code: EXIT_USAGE,
        }
    }

    /// A library's refusal of values the user typed (a parameter out of the manual's range, a
    /// baud rate not in the list), before any port is opened: a usage error, exit code 2.
    pub fn bad_argument(e: impl std::fmt::Display) -> Self {
        CliError::usage(e.to_string())
    }

    /// Ended by Ctrl-C (SIGINT), after whatever the command prints at its end: exit code 130.
    pub fn interrupted() -> Self {
        CliError {
            text: "interrupted".into(),
            code: EXIT_INTERRUPTED,
        }
    }

    /// The line the user reads (without the `si: error: ` prefix).
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The process exit code.
    pub fn code(&self) -> u8 {
        self.code
    }
}

impl<E: std::error::Error> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError::new(e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_has_its_documented_exit_code() {
        assert_eq!(CliError::new("x").code(), 1);
        assert_eq!(CliError::usage("x").code(), 2);
        assert_eq!(CliError::interrupted().code(), 130);
        for code in ["0 ", "1 ", "2 ", "130 "] {
            assert!(EXIT_CODES.contains(&format!("  {code}")), "{code}");
        }
    }
}
