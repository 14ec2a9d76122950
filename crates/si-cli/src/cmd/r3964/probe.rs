//! `si 3964r probe`: does a partner answer `STX` with `DLE`, at each line setting, and does it
//! insist on sending (high priority)? One `STX` per setting (`si_3964r::probe`), the first
//! character back within the acknowledgement delay time; the longest it can take is printed
//! first, and Ctrl-C stops at once with what was found so far.

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_3964r::frame::STX;
use si_3964r::probe::Reply;
use si_core::SerialSettings;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// Opening and closing the port for one setting, and the write.
const OPEN_SLACK: Duration = Duration::from_millis(400);

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
        let settings = self.settings(conn)?;
        let qvz = Duration::from_millis(self.ack_delay_ms);
        let zvz = Duration::from_millis(self.char_delay_ms);
        // Each setting: the QVZ wait, then the partner's ZVZ (and its NAK) waited out.
        let per_setting = qvz + zvz * 2 + OPEN_SLACK;
        let bound = per_setting * settings.len() as u32;
        let list: Vec<String> = settings.iter().map(ToString::to_string).collect();
        out.line(
            &format!(
                "probing {} line setting(s) ({}): at most {:.1} s",
                settings.len(),
                list.join(", "),
                bound.as_secs_f64()
            ),
            serde_json::json!({"probe": "3964r", "settings": list,
                               "bound_ms": bound.as_millis() as u64}),
        );
        let ctrl_c = tokio::signal::ctrl_c();
        tokio::pin!(ctrl_c);
        let mut ready = 0;
        for s in &settings {
            let mut port = conn.open_with(s).await?;
            // What the line held before our STX is no answer to it (a partner's start-up NAK).
            // Bounded (a chattering line must not hold the probe): at most 10 reads.
            let mut stale = [0u8; 64];
            for _ in 0..10 {
                match tokio::time::timeout(Duration::from_millis(20), port.read(&mut stale)).await {
                    Ok(Ok(0)) => return Err(conn.closed()),
                    Ok(Ok(_)) => {}
                    _ => break,
                }
            }
            port.write_all(&[STX])
                .await
                .map_err(|e| CliError::new(format!("writing STX: {e}")))?;
            let mut byte = [0u8; 1];
            let first = tokio::select! {
                r = tokio::time::timeout(qvz, port.read(&mut byte)) => match r {
                    Ok(Ok(1)) => Some(byte[0]),
                    Ok(Ok(_)) => return Err(conn.closed()),
                    Ok(Err(e)) => return Err(CliError::new(format!("reading: {e}"))),
                    Err(_) => None,
                },
                _ = &mut ctrl_c => return Err(CliError::interrupted()),
            };
            let reply = Reply::of(first);
            if reply == Reply::Ready {
                ready += 1;
            }
            out.line(
                &format!("{s}  {}", reply.describe()),
                serde_json::json!({
                    "settings": s.to_string(),
                    "reply": first,
                    "ready": reply == Reply::Ready,
                    "high_priority": reply == Reply::HighPriority,
                }),
            );
            if first.is_some() {
                // The partner waits for our block (ZVZ), then answers NAK: let it, and drop
                // what it says, so the next setting starts on a quiet line.
                let quiet = tokio::time::sleep(zvz * 2);
                tokio::pin!(quiet);
                let mut drain = [0u8; 64];
                loop {
                    tokio::select! {
                        _ = &mut quiet => break,
                        r = port.read(&mut drain) => if !matches!(r, Ok(n) if n > 0) { break },
                        _ = &mut ctrl_c => return Err(CliError::interrupted()),
                    }
                }
            }
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
