//! Finding which nodes answer on a USS bus: the parameter job a scan may send to any node, how
//! its outcome reads, and how long one cycle over the nodes may take at most.
//!
//! The probe reads parameter 0, index 0 (PKW task ID 1, [SINAMICS V20] p. 107; [Modbus/USS]
//! §3.7.7): a read changes nothing
//! in a drive, and a drive without a parameter 0 still answers, with response ID 7 and an error
//! number, which proves it is there. One telegram per node (no PKW repetition): a scan must stay
//! short and polite on a live bus.

use crate::config::{ConfigError, MasterConfig, PollEntry, MAX_ENTRIES};
use crate::master::ParamRequest;
use crate::status;
use si_core::{Duration, SerialSettings, Status};

/// The job a scan gives each node: read parameter 0, index 0.
pub fn probe() -> ParamRequest {
    ParamRequest::read(0, 0)
}

/// What one probe found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// The node answered: the value, or a PKW error (response ID 7 or 8), is an answer.
    Present,
    /// The node answered with telegrams that never matched the job, or was rejected: a
    /// device may be there at other settings or with another net-data structure.
    Garbled(Status),
    /// No answer within the response timeout.
    Absent,
}

impl Answer {
    /// How a probe's outcome reads: done, or failed with response ID 7 (`PKW_ERROR`) or 8
    /// (`PKW_INTERFACE_ERROR` with an error number) is a node that answered; `NO_ANSWER` none;
    /// anything else garbled.
    pub fn of(outcome: Result<(), (Status, Option<u16>)>) -> Answer {
        match outcome {
            Ok(()) => Answer::Present,
            Err((s, _)) if s == status::NO_ANSWER => Answer::Absent,
            Err((s, _)) if s == status::PKW_ERROR => Answer::Present,
            Err((_, Some(_))) => Answer::Present,
            Err((s, None)) => Answer::Garbled(s),
        }
    }
}

/// The longest one telegram exchange with `entry` takes with `config`: the start interval
/// (2 character times) before the request, the request, the response timeout, the response
/// within its residual run time (1.5 × its characters, [USS spec] §5.2.1.2), plus `slack` for
/// what the host adds. A scan that polls `n` nodes `c` times takes at most `n × c` times this.
pub fn telegram_bound(config: &MasterConfig, entry: &PollEntry, slack: Duration) -> Duration {
    // STX, LGE, ADR, the net data, BCC.
    let chars = 4 + entry.net_len() as u64;
    let s = config.settings;
    s.chars_time(2 + chars + (3 * chars).div_ceil(2)) + config.response_timeout + slack
}

/// What the host may add to each telegram beyond the line's own time (a USB adapter's hold,
/// scheduling), counted generously `[derived]`.
pub const TELEGRAM_SLACK: Duration = Duration::from_millis(40);

/// Opening and closing the port for one line setting `[derived]`.
pub const OPEN_SLACK: Duration = Duration::from_millis(300);

/// Cycles over the nodes the bound allows: the probe goes out in the first; a second covers
/// a cycle the master had begun before the jobs were entered `[derived]`.
pub const CYCLES: u64 = 2;

/// A node that answered something.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Found {
    /// The node's address.
    pub node: u8,
    /// The line settings it answered at.
    pub settings: SerialSettings,
    /// What it answered ([`Answer::Present`] or [`Answer::Garbled`], never `Absent`).
    pub answer: Answer,
}

/// A planned scan over real lines (run with `run`, feature `tokio`): one master per setting
/// and batch, as a polling list holds at most [`MAX_ENTRIES`] nodes (SANZ, [Modbus/USS]
/// §3.7.6, Table 3-31), so 0…31 is asked in two batches; one telegram per node (no PKW
/// repetition), the config's response timeout.
#[derive(Debug, Clone)]
pub struct Scan {
    batches: Vec<MasterConfig>,
    /// The nodes' structure (all alike), `None` for no nodes.
    first: Option<PollEntry>,
}

impl Scan {
    /// A scan of `entries` (one per node, all alike) at each of `settings`.
    pub fn new(
        entries: &[PollEntry],
        settings: &[SerialSettings],
        response_timeout: Duration,
    ) -> Result<Scan, ConfigError> {
        let mut batches = Vec::new();
        for s in settings {
            for chunk in entries.chunks(MAX_ENTRIES) {
                let mut c = MasterConfig::new(chunk.to_vec());
                c.settings = *s;
                c.response_timeout = response_timeout;
                c.retries = 0;
                c.validate()?;
                batches.push(c);
            }
        }
        Ok(Scan {
            batches,
            first: entries.first().copied(),
        })
    }

    /// The longest the scan can take: [`CYCLES`] telegrams per node ([`telegram_bound`] with
    /// [`TELEGRAM_SLACK`]) plus [`OPEN_SLACK`] per batch.
    pub fn bound(&self) -> Duration {
        let Some(first) = &self.first else {
            return Duration::ZERO;
        };
        self.batches
            .iter()
            .map(|c| {
                let telegram = telegram_bound(c, first, TELEGRAM_SLACK);
                let polls = c.polling_list.len() as u64 * CYCLES;
                Duration::from_micros(telegram.as_micros() * polls) + OPEN_SLACK
            })
            .fold(Duration::ZERO, |a, b| a + b)
    }

    /// Run it: for each batch, `open` the line at its settings, ask every node once, hand
    /// each that answered to `found`. Dropping the future stops the scan at once.
    #[cfg(feature = "tokio")]
    #[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
    pub async fn run<T, E, Fut>(
        &self,
        mut open: impl FnMut(SerialSettings) -> Fut,
        mut found: impl FnMut(Found),
    ) -> Result<(), ScanError<E>>
    where
        T: si_core::driver::Transport,
        Fut: std::future::Future<Output = Result<T, E>>,
    {
        use crate::master::{Event, Master};
        for c in &self.batches {
            let mut master = Master::new(c.clone()).map_err(ScanError::Config)?;
            let mut jobs = Vec::new();
            for entry in &c.polling_list {
                let job = master
                    .request_parameter(si_core::Instant::ZERO, entry.address, probe())
                    .map_err(ScanError::Refused)?;
                jobs.push((job, entry.address));
            }
            master.stop_when_idle();
            let transport = open(c.settings).await.map_err(ScanError::Open)?;
            let mut m = crate::tokio::Handle::spawn_engine(master, transport);
            let mut open_jobs = jobs.len();
            while open_jobs > 0 {
                let (job, outcome) = match m.next_event().await {
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
                open_jobs -= 1;
                let answer = Answer::of(outcome);
                if answer != Answer::Absent {
                    found(Found {
                        node,
                        settings: c.settings,
                        answer,
                    });
                }
            }
            // The driver ends as the master stops; let it release the port before the next
            // batch opens it again.
            drop(m);
            tokio::task::yield_now().await;
        }
        Ok(())
    }
}

/// Why a scan stopped before its end.
#[derive(Debug, thiserror::Error)]
pub enum ScanError<E> {
    /// The caller could not open the line for a setting.
    #[error("{0}")]
    Open(E),
    /// A batch's configuration is out of range.
    #[error("{0}")]
    Config(ConfigError),
    /// The master refused the probe.
    #[error("{0}")]
    Refused(crate::master::RequestError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::PkwWords;

    #[test]
    fn a_drive_that_refuses_parameter_0_is_still_there() {
        assert_eq!(Answer::of(Ok(())), Answer::Present);
        assert_eq!(
            Answer::of(Err((status::PKW_ERROR, Some(0)))),
            Answer::Present
        );
        assert_eq!(Answer::of(Err((status::NO_ANSWER, None))), Answer::Absent);
        assert_eq!(
            Answer::of(Err((status::PKW_INTERFACE_ERROR, None))),
            Answer::Garbled(status::PKW_INTERFACE_ERROR)
        );
    }

    #[test]
    fn a_telegram_takes_at_least_the_response_timeout() {
        let entry = PollEntry::new(1, PkwWords::Four, 2);
        let c = MasterConfig::new(vec![entry]);
        let bound = telegram_bound(&c, &entry, Duration::ZERO);
        assert!(bound > c.response_timeout + c.settings.chars_time(16));
    }
}
