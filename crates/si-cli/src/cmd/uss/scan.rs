//! `si uss scan`: which nodes answer, at which line settings. Bounded and polite: one read of
//! parameter 0 per node and setting (`si_uss::scan::probe`), one telegram each (no PKW
//! repetition), the response timeout of the config; the longest it can take is printed before
//! the first telegram, and Ctrl-C stops at once with what was found so far.

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_core::{Duration, Instant, SerialSettings};
use si_uss::config::{MasterConfig, PollEntry, MAX_ENTRIES, USS_BAUD_RATES};
use si_uss::frame::PkwWords;
use si_uss::master::{Event, Master};
use si_uss::scan::{self, Answer};
use si_uss::tokio::Handle;

/// What the host may add to each telegram beyond the line's own time (a USB adapter's hold,
/// scheduling), counted generously.
const TELEGRAM_SLACK: Duration = Duration::from_millis(40);

/// Opening and closing the port for one line setting.
const OPEN_SLACK: Duration = Duration::from_millis(300);

/// Cycles over the nodes the bound allows: the probe goes out in the first; a second covers
/// a cycle the master had begun before the jobs were entered `[derived]`.
const CYCLES: u64 = 2;

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
        // One master per setting and batch: a polling list holds at most 31 nodes (SANZ,
        // [Modbus/USS] §3.7.6, Table 3-31), so 0…31 is asked in two batches.
        let mut batches: Vec<MasterConfig> = Vec::new();
        for s in &settings {
            for chunk in entries.chunks(MAX_ENTRIES) {
                let mut c = MasterConfig::new(chunk.to_vec());
                c.settings = *s;
                c.response_timeout = Duration::from_millis(self.response_timeout_ms);
                c.retries = 0;
                c.validate().map_err(CliError::bad_argument)?;
                batches.push(c);
            }
        }
        let bound = batches
            .iter()
            .map(|c| {
                let telegram = scan::telegram_bound(c, &entries[0], TELEGRAM_SLACK);
                let polls = c.polling_list.len() as u64 * CYCLES;
                Duration::from_micros(telegram.as_micros() * polls) + OPEN_SLACK
            })
            .fold(Duration::ZERO, |a, b| a + b);
        let list: Vec<String> = settings.iter().map(ToString::to_string).collect();
        out.line(
            &format!(
                "scanning {} node(s) at {} line setting(s) ({}): at most {:.1} s",
                nodes.len(),
                settings.len(),
                list.join(", "),
                bound.as_micros() as f64 / 1e6
            ),
            serde_json::json!({
                "scan": "uss", "nodes": nodes.len(), "settings": list,
                "bound_ms": bound.as_millis(),
            }),
        );
        let ctrl_c = tokio::signal::ctrl_c();
        tokio::pin!(ctrl_c);
        let mut present = 0;
        for c in batches {
            let mut master = Master::new(c.clone()).map_err(CliError::bad_argument)?;
            let mut jobs = Vec::new();
            for entry in &c.polling_list {
                let job = master
                    .request_parameter(Instant::ZERO, entry.address, scan::probe())
                    .map_err(|e| CliError::new(e.to_string()))?;
                jobs.push((job, entry.address));
            }
            master.stop_when_idle();
            let transport = conn.open_with(&c.settings).await?;
            let mut m = Handle::spawn_engine(master, transport);
            let mut open = jobs.len();
            while open > 0 {
                let event = tokio::select! {
                    e = m.next_event() => e,
                    _ = &mut ctrl_c => {
                        if !out.json {
                            println!("{present} node(s) answered (interrupted)");
                        }
                        return Err(CliError::interrupted());
                    }
                };
                let (job, outcome) = match event {
                    None => break,
                    Some(Event::ParameterDone { job, .. }) => (job, Ok(())),
                    Some(Event::ParameterFailed {
                        job,
                        status,
                        error_number,
                        ..
                    }) => (job, Err((status, error_number))),
                    Some(_) => continue,
                };
                let Some(&(_, node)) = jobs.iter().find(|(j, _)| *j == job) else {
                    continue;
                };
                open -= 1;
                let answer = Answer::of(outcome);
                if answer == Answer::Present {
                    present += 1;
                }
                if answer != Answer::Absent {
                    print_found(node, c.settings, answer, out);
                }
            }
            // The driver ends as the master stops; let it release the port before the next
            // batch opens it again.
            drop(m);
            tokio::task::yield_now().await;
        }
        if !out.json {
            println!("{present} node(s) answered");
        }
        Ok(())
    }

    /// Every combination of the baud rates and parities asked for, the rest of the character
    /// format from the line flags.
    fn settings(&self, conn: &Connection) -> Result<Vec<SerialSettings>, CliError> {
        let base = conn.settings_for(&USS_BAUD_RATES)?;
        self.sweep.settings(base, base.data_bits(), &USS_BAUD_RATES)
    }
}

/// `node 5    9600 8E1  answered`.
fn print_found(node: u8, settings: SerialSettings, answer: Answer, out: &Output) {
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
