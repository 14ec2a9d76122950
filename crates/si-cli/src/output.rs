//! How results reach the user: text for people or JSON lines for scripts, on a stdout that may
//! close under us.
//!
//! A leaf module: every command prints through it, and it imports nothing of the crate.

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

/// Write to stdout. When the reader has gone (`si monitor … | head`), end quietly with success
/// instead of panicking the way `println!` does on a closed pipe.
pub fn write_stdout(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
    }
}
