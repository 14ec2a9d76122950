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

/// What one probe found: si-core's, shared by every bus scan ([`answer`] says how a USS
/// outcome reads).
pub use si_core::sweep::Answer;

/// How a probe's outcome reads: done, or failed with response ID 7 (`PKW_ERROR`) or 8
/// (`PKW_INTERFACE_ERROR` with an error number) is a node that answered; `NO_ANSWER` none;
/// anything else garbled (telegrams that never matched the job, or a rejection: a device may
/// be there at other settings or with another net-data structure).
pub fn answer(outcome: Result<(), (Status, Option<u16>)>) -> Answer {
    match outcome {
        Ok(()) => Answer::Present,
        Err((s, _)) if s == status::NO_ANSWER => Answer::Absent,
        Err((s, _)) if s == status::PKW_ERROR => Answer::Present,
        Err((_, Some(_))) => Answer::Present,
        Err((s, None)) => Answer::Garbled(s),
    }
}

/// The longest one batch takes, from the master's start to its last probe's end, whatever the
/// line does: the engine's own bound for a parameter job, [`MasterConfig::job_bound`] (with
/// `config`'s retries, 0 in a scan: one telegram per node; every probe is entered before the
/// start, so each ends within it), plus `slack` per telegram for what the host adds. It counts
/// what a noisy line can make a poll last (the wait for the start interval's silence, a
/// garbled answer up to the longest telegram's residual run time, a port's latency) and the
/// cycle pause, not just a valid answer's characters; not a formula of the scan's own.
pub fn batch_bound(config: &MasterConfig, slack: Duration) -> Duration {
    let telegrams = config.polling_list.len() as u64 * (u64::from(config.retries) + CYCLES);
    config.job_bound() + slack.saturating_mul(telegrams)
}

/// What the host may add to each telegram beyond the engine's bound (which already counts a
/// port's latency, [`MasterConfig::port_margin`]): scheduling, counted generously `[derived]`.
pub const TELEGRAM_SLACK: Duration = Duration::from_millis(40);

/// Cycles a parameter job spans beyond its repetitions ([`MasterConfig::job_bound`]'s `+ 2`):
/// the probe goes out in the first whole cycle; the other covers a cycle the master had
/// begun before the job was entered.
pub const CYCLES: u64 = 2;

/// A node that answered something ([`Answer::Present`] or [`Answer::Garbled`], never
/// `Absent`) at one line setting: the station is the node's address.
pub type Found = si_core::sweep::Found<u8, Answer>;

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

    /// The longest the scan can take: every batch's [`batch_bound`] with [`TELEGRAM_SLACK`],
    /// plus [`OPEN_SLACK`](si_core::sweep::OPEN_SLACK) per batch ([`si_core::sweep::total`]).
    pub fn bound(&self) -> Duration {
        if self.first.is_none() {
            return Duration::ZERO;
        }
        si_core::sweep::total(self.batches.iter().map(|c| batch_bound(c, TELEGRAM_SLACK)))
    }

    /// The batches: one master configuration each, in the order they run.
    pub fn batches(&self) -> &[MasterConfig] {
        &self.batches
    }

    /// The engine of one batch (`config`, from [`Scan::batches`]), as the scan runs it: the
    /// probe entered for each node of its polling list, to stop when all have ended; not yet
    /// started. With each probe's job and node.
    pub fn batch_master(
        config: &MasterConfig,
    ) -> Result<(crate::master::Master, Vec<(si_core::job::JobId, u8)>), BatchError> {
        let mut master = crate::master::Master::new(config.clone()).map_err(BatchError::Config)?;
        let mut jobs = Vec::new();
        for entry in &config.polling_list {
            let job = master
                .request_parameter(si_core::Instant::ZERO, entry.address, probe())
                .map_err(BatchError::Refused)?;
            jobs.push((job, entry.address));
        }
        master.stop_when_idle();
        Ok((master, jobs))
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
        use crate::master::Event;
        for c in &self.batches {
            let (master, jobs) = Self::batch_master(c).map_err(ScanError::Run)?;
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
                let answer = answer(outcome);
                if answer != Answer::Absent {
                    found(Found {
                        station: node,
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

/// Why a scan stopped before its end: the caller could not open the line for a setting
/// ([`SweepError::Open`](si_core::sweep::SweepError::Open)), or a batch's engine could not be
/// built ([`SweepError::Run`](si_core::sweep::SweepError::Run) with a [`BatchError`]).
pub type ScanError<E> = si_core::sweep::SweepError<E, BatchError>;

/// Why a batch's engine could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// The batch's configuration is out of range.
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
        assert_eq!(answer(Ok(())), Answer::Present);
        assert_eq!(answer(Err((status::PKW_ERROR, Some(0)))), Answer::Present);
        assert_eq!(answer(Err((status::NO_ANSWER, None))), Answer::Absent);
        assert_eq!(
            answer(Err((status::PKW_INTERFACE_ERROR, None))),
            Answer::Garbled(status::PKW_INTERFACE_ERROR)
        );
    }

    #[test]
    fn a_batch_is_bounded_by_the_engines_own_job_bound() {
        let entry = PollEntry::new(1, PkwWords::Four, 2);
        let mut c = MasterConfig::new(vec![entry, PollEntry::new(2, PkwWords::Four, 2)]);
        c.retries = 0;
        assert_eq!(batch_bound(&c, Duration::ZERO), c.job_bound());
        assert_eq!(
            batch_bound(&c, Duration::from_millis(1)),
            c.job_bound() + Duration::from_millis(4)
        );
    }
}
