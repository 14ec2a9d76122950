//! `si uss scan`: which nodes answer, at which line settings. Bounded and polite: one read of
//! parameter 0 per node and setting (`si_uss::scan::probe`), one telegram each (no PKW
//! repetition), the response timeout of the config; the longest it can take is printed before
//! the first telegram, and Ctrl-C stops at once with what was found so far.

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_core::{Duration, SerialSettings};
use si_uss::config::{PollEntry, USS_BAUD_RATES};
use si_uss::frame::PkwWords;
use si_uss::scan::{Answer, BatchError, Found, Scan, ScanError};

/// `si uss scan` arguments.
#[derive(Debug, Clone, Args)]
pub struct ScanArgs {
    /// The nodes to ask: a range (0-31) or a list (0,1,5-9).
    #[arg(long, default_value = "0-31", value_name = "NODES")]
    nodes: String,
    #[command(flatten)]
    sweep: crate::setting_sweep::Sweep,
    /// PKW words of the drives' net-data structure: 3 or 4.
    #[arg(long, default_value_t = 4)]
    pkw_words: u8,
    /// PZD words: 0…16.
    #[arg(long, default_value_t = 2)]
    pzd_words: u8,
    /// Response timeout in ms (the USS spec's 20 ms; more for converters and device servers).
    #[arg(long, default_value_t = 20)]
    response_timeout_ms: u64,
}

impl ScanArgs {
    /// Run the scan.
    pub async fn run(&self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let nodes = parse_nodes(&self.nodes)?;
        let pkw = match self.pkw_words {
            3 => PkwWords::Three,
            4 => PkwWords::Four,
            n => {
                return Err(CliError::usage(format!(
                    "--pkw-words {n}: a scan reads a parameter, so 3 or 4"
                )))
            }
        };
        let entries: Vec<PollEntry> = nodes
            .iter()
            .map(|&a| PollEntry::new(a, pkw, self.pzd_words))
            .collect();
        let settings = self.settings(conn)?;
        let response_timeout = Duration::from_millis(self.response_timeout_ms);
        let scan =
            Scan::new(&entries, &settings, response_timeout).map_err(CliError::bad_argument)?;
        let bound = scan.bound();
        crate::setting_sweep::announce(
            out,
            "scanning",
            Some(("node", nodes.len())),
            &settings,
            bound,
            serde_json::json!({"scan": "uss"}),
        );
        let mut present = 0;
        let run = scan.run(
            |s| async move { conn.open_with(&s).await },
            |f| {
                present += usize::from(f.answer == Answer::Present);
                print_found(&f, out);
            },
        );
        let interrupted = tokio::select! {
            r = run => {
                r.map_err(|e| match e {
                    ScanError::Open(e) => e,
                    ScanError::Run(BatchError::Config(e)) => CliError::bad_argument(e),
                    ScanError::Run(BatchError::Refused(e)) => CliError::new(e.to_string()),
                })?;
                false
            }
            _ = tokio::signal::ctrl_c() => true,
        };
        crate::setting_sweep::summary(out, present, "node", interrupted)
    }

    /// Every combination of the baud rates and parities asked for, the rest of the character
    /// format from the line flags.
    fn settings(&self, conn: &Connection) -> Result<Vec<SerialSettings>, CliError> {
        let base = conn.settings_for(&USS_BAUD_RATES)?;
        self.sweep.settings(base, base.data_bits(), &USS_BAUD_RATES)
    }
}

/// `node 5    9600 8E1  answered`.
fn print_found(f: &Found, out: &Output) {
    let (node, settings, answer) = (f.station, f.settings, f.answer);
    let (what, status) = match answer {
        Answer::Present => ("answered".to_owned(), None),
        Answer::Garbled(s) => (
            format!("something answered, garbled ({s}): another setting or net-data structure?"),
            Some(format!("{:04X}", s.code())),
        ),
        Answer::Absent => ("no answer".to_owned(), None),
    };
    out.line(
        &format!("node {node:<3}  {settings}  {what}"),
        serde_json::json!({
            "node": node,
            "settings": settings.to_string(),
            "answered": answer == Answer::Present,
            "status": status,
        }),
    );
}

/// `0-31`, `0,1,5-9`: the nodes in order, each once; 0–31 (USS addresses, [USS spec] §4.3).
fn parse_nodes(text: &str) -> Result<Vec<u8>, CliError> {
    crate::address_list::parse(text, 0, 31).ok_or_else(|| {
        CliError::usage(format!(
            "--nodes {text:?}: give nodes 0-31 as a range (0-31) or a list (0,1,5-9)"
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_are_ranges_and_lists_within_0_to_31() {
        assert_eq!(parse_nodes("0-2,1,9").unwrap(), vec![0, 1, 2, 9]);
        assert_eq!(parse_nodes("0-31").unwrap().len(), 32);
        for bad in ["0-32", "5-1", "x"] {
            assert!(parse_nodes(bad).is_err(), "{bad}");
        }
    }
}
