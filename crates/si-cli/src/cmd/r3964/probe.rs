//! `si 3964r probe`: does a partner answer `STX` with `DLE`, at each line setting, and does it
//! insist on sending (high priority)? The probe is si-3964r's (`si_3964r::probe::Probe`:
//! one `STX` per setting, the first character back within the acknowledgement delay time);
//! this prints the longest it can take first and each setting's answer, and Ctrl-C stops it at
//! once with what was found so far.

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_3964r::probe::{Found, Probe, ProbeError, ProbeFault, Reply};
use si_core::{Duration, SerialSettings};

/// `si 3964r probe` arguments.
#[derive(Debug, Clone, Args)]
pub struct ProbeArgs {
    #[command(flatten)]
    sweep: crate::setting_sweep::Sweep,
    /// Acknowledgement delay time QVZ in ms: how long the partner has to answer (default
    /// 2000, the 3964(R) default, [ET200S SI] §2.7).
    #[arg(long, default_value_t = 2000, value_name = "MS")]
    ack_delay_ms: u64,
    /// Character delay time ZVZ in ms: after a DLE the partner waits this long for our block
    /// before it gives up; the probe waits it out before the next setting (default 220).
    #[arg(long, default_value_t = 220, value_name = "MS")]
    char_delay_ms: u64,
}

impl ProbeArgs {
    /// Run the probe.
    pub async fn run(&self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let probe = Probe::new(
            self.settings(conn)?,
            Duration::from_millis(self.ack_delay_ms),
            Duration::from_millis(self.char_delay_ms),
        );
        let bound = probe.bound();
        crate::setting_sweep::announce(
            out,
            "probing",
            None,
            probe.settings(),
            bound,
            serde_json::json!({"probe": "3964r"}),
        );
        let mut ready = 0;
        let run = probe.run(
            |s| async move { conn.open_with(&s).await },
            |f| {
                ready += usize::from(f.answer == Reply::Ready);
                print_found(&f, out);
            },
        );
        tokio::select! {
            r = run => r.map_err(|e| match e {
                ProbeError::Open(e) => e,
                ProbeError::Run(ProbeFault::Closed) => conn.closed(),
                ProbeError::Run(ProbeFault::Io(e)) => CliError::new(format!("probing: {e}")),
            })?,
            _ = tokio::signal::ctrl_c() => return Err(CliError::interrupted()),
        }
        if !out.json {
            println!("{ready} setting(s) with a partner that answers DLE");
        }
        Ok(())
    }

    /// Every combination of the baud rates and parities asked for.
    fn settings(&self, conn: &Connection) -> Result<Vec<SerialSettings>, CliError> {
        let base = conn.settings()?;
        self.sweep
            .settings(base, base.data_bits(), &si_core::BAUD_RATES)
    }
}

/// `9600 8E1  answers STX with DLE: …`.
fn print_found(f: &Found, out: &Output) {
    out.line(
        &format!("{}  {}", f.settings, f.answer.describe()),
        serde_json::json!({
            "settings": f.settings.to_string(),
            "reply": f.answer.first(),
            "ready": f.answer == Reply::Ready,
            "high_priority": f.answer == Reply::HighPriority,
        }),
    );
}
