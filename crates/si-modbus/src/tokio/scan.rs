//! A bus scan over real lines: which units answer, at which line settings. Bounded and polite:
//! one harmless read per unit and setting ([`PROBE`]), one try (no
//! retries), the response time of the config; [`Scan::bound`] is the longest it can take, to
//! be told before the first request. The caller opens the line for each setting and hears of
//! each unit that answered as it is found; dropping the future stops the scan at once with
//! what was reported so far.

use super::error::Error;
use super::master::Master;
use crate::config::{ConfigError, MasterConfig};
use crate::scan::{probe_bound, Answer, PROBE};
use si_core::driver::Transport;
use si_core::{Duration, SerialSettings};
use std::future::Future;

/// What the host may add to each probe beyond the line's own time: a USB adapter's hold on
/// the response (16 ms by default) and scheduling, counted generously `[derived]`.
pub const PROBE_SLACK: Duration = Duration::from_millis(60);

/// Opening and closing the port for one line setting `[derived]`.
pub const OPEN_SLACK: Duration = Duration::from_millis(300);

/// A unit that answered something.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Found {
    /// The unit.
    pub unit: u8,
    /// The line settings it answered at.
    pub settings: SerialSettings,
    /// What it answered ([`Answer::Present`] or [`Answer::Garbled`], never `Absent`).
    pub answer: Answer,
}

/// Why a scan stopped before its end.
#[derive(Debug, thiserror::Error)]
pub enum ScanError<E> {
    /// The caller could not open the line for a setting.
    #[error("{0}")]
    Open(E),
    /// The master failed otherwise than with a STATUS.
    #[error("{0}")]
    Master(Error),
}

/// A planned scan: the units, the settings, the master's configuration.
#[derive(Debug, Clone)]
pub struct Scan {
    config: MasterConfig,
    settings: Vec<SerialSettings>,
    units: Vec<u8>,
}

impl Scan {
    /// A scan of `units` at each of `settings`, with `config`'s response time (its retries
    /// are set to 0: one try per unit).
    pub fn new(
        mut config: MasterConfig,
        settings: Vec<SerialSettings>,
        units: Vec<u8>,
    ) -> Result<Scan, ConfigError> {
        config.retries = 0;
        config.validate()?;
        Ok(Scan {
            config,
            settings,
            units,
        })
    }

    /// The settings the scan tries, in order.
    pub fn settings(&self) -> &[SerialSettings] {
        &self.settings
    }

    /// The longest the scan can take: every probe's bound ([`probe_bound`] with
    /// [`PROBE_SLACK`]) plus [`OPEN_SLACK`] per setting.
    pub fn bound(&self) -> Duration {
        self.settings
            .iter()
            .map(|s| {
                let probe = probe_bound(&self.at(*s), PROBE_SLACK);
                Duration::from_micros(probe.as_micros() * self.units.len() as u64) + OPEN_SLACK
            })
            .fold(Duration::ZERO, |a, b| a + b)
    }

    fn at(&self, settings: SerialSettings) -> MasterConfig {
        let mut c = self.config;
        c.line.settings = settings;
        c
    }

    /// Run it: for each setting, `open` the line, ask every unit once, hand each that
    /// answered to `found`, close the port (returns once it is released, so the next setting
    /// can open it again).
    pub async fn run<T, E, Fut>(
        &self,
        mut open: impl FnMut(SerialSettings) -> Fut,
        mut found: impl FnMut(Found),
    ) -> Result<(), ScanError<E>>
    where
        T: Transport,
        Fut: Future<Output = Result<T, E>>,
    {
        for &settings in &self.settings {
            let port = open(settings).await.map_err(ScanError::Open)?;
            let master = Master::spawn(self.at(settings), port).map_err(ScanError::Master)?;
            for &unit in &self.units {
                let outcome = match master.request(unit, &PROBE).await {
                    Ok(_) => Ok(()),
                    Err(e) => Err(e.status().ok_or(e).map_err(ScanError::Master)?),
                };
                let answer = Answer::of(outcome);
                if answer != Answer::Absent {
                    found(Found {
                        unit,
                        settings,
                        answer,
                    });
                }
            }
            master.close().await.ok();
        }
        Ok(())
    }
}
