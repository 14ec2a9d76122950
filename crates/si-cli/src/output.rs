//! How results reach the user: text for people or JSON lines for scripts, on a stdout that may
//! close under us.
//!
//! A leaf module: every command prints through it, and it imports nothing of the crate.

use std::sync::atomic::{AtomicBool, Ordering};

/// How results are printed.
#[derive(Debug, Clone, Copy)]
pub struct Output {
    /// JSON lines instead of text.
    pub json: bool,
}

impl Output {
    /// Print one result: `text` for people, `json` as one line for scripts.
    pub fn line(&self, text: &str, json: serde_json::Value) {
        if self.json {
            write_stdout(format_args!("{json}\n"));
        } else {
            write_stdout(format_args!("{text}\n"));
        }
    }
}

/// Set by a command that must outlive its stdout (`si gateway`, a service whose status lines
/// are a by-product): a write error is then logged once to stderr and the command goes on.
static OUTLIVE_STDOUT: AtomicBool = AtomicBool::new(false);
/// Whether the one stderr line about a failed stdout was written.
static STDOUT_FAILURE_LOGGED: AtomicBool = AtomicBool::new(false);

/// From now on a write error on stdout (EPIPE, a FIFO whose reader went away, a full disk) is
/// logged once to stderr and otherwise ignored, instead of ending the process: for a server
/// whose job is not its output.
pub fn outlive_stdout() {
    OUTLIVE_STDOUT.store(true, Ordering::Relaxed);
}

/// Write to stdout. When the reader has gone (`si monitor … | head`), end quietly with success
/// instead of panicking the way `println!` does on a closed pipe; after [`outlive_stdout`],
/// log the first failure to stderr and carry on.
pub fn write_stdout(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        if OUTLIVE_STDOUT.load(Ordering::Relaxed) {
            if !STDOUT_FAILURE_LOGGED.swap(true, Ordering::Relaxed) {
                // stderr may be gone too: nothing more to do then.
                let _ = writeln!(
                    std::io::stderr(),
                    "si: cannot write to stdout ({e}); going on without it"
                );
            }
        } else if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
    }
}
