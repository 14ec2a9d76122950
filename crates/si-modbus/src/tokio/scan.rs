//! A bus scan over real lines: which units answer, at which line settings. Bounded and polite:
//! one harmless read per unit and setting ([`PROBE`]), one try (no
//! retries), the response time of the config; [`Scan::bound`] is the longest it can take, to
//! be told before the first request. The caller opens the line for each setting and hears of
//! each unit that answered as it is found; dropping the future stops the scan at once with
//! what was reported so far.

use super::error::Error;
use super::master::Master;
use crate::config::{ConfigError, MasterConfig};
use crate::master;
use crate::scan::{answer, probe_bound, Answer, PROBE};
use si_core::driver::Transport;
use si_core::sweep::SweepError;
use si_core::{Duration, SerialSettings};
use std::future::Future;

/// What the host may add to each probe beyond the engine's own bound (which already counts a
/// port's latency, [`MasterConfig::port_margin`]): scheduling, counted generously `[derived]`.
pub const PROBE_SLACK: Duration = Duration::from_millis(60);

/// A unit that answered something ([`Answer::Present`] or [`Answer::Garbled`], never
/// `Absent`) at one line setting: the station is the unit's address.
pub type Found = si_core::sweep::Found<u8, Answer>;

/// Why a scan stopped before its end: the caller could not open the line for a setting
/// ([`SweepError::Open`]), or the master failed otherwise than with a STATUS
/// ([`SweepError::Run`]).
pub type ScanError<E> = SweepError<E, Error>;

/// A planned scan: the units, the settings, the master's configuration.
#[derive(Debug, Clone)]
pub struct Scan {
    config: MasterConfig,
    settings: Vec<SerialSettings>,
    units: Vec<u8>,
    /// Per setting, [`probe_bound`] of the engine the scan runs at it.
    probe_bounds: Vec<Duration>,
}

impl Scan {
    /// A scan of `units` at each of `settings`, with `config`'s response time (its retries
    /// are set to 0: one try per unit). Each setting's config is checked here, by building the
    /// engine the scan will run at it.
    pub fn new(
        mut config: MasterConfig,
        settings: Vec<SerialSettings>,
        units: Vec<u8>,
    ) -> Result<Scan, ConfigError> {
        config.retries = 0;
        config.validate()?;
        let mut scan = Scan {
            config,
            settings,
            units,
            probe_bounds: Vec::new(),
        };
        for &s in &scan.settings {
            let engine = Self::engine(scan.at(s))?;
            scan.probe_bounds.push(probe_bound(&engine, PROBE_SLACK));
        }
        Ok(scan)
    }

    /// The settings the scan tries, in order.
    pub fn settings(&self) -> &[SerialSettings] {
        &self.settings
    }

    /// The longest the scan can take: every probe's bound ([`probe_bound`] of the engine it
    /// runs on, with [`PROBE_SLACK`]) plus [`OPEN_SLACK`](si_core::sweep::OPEN_SLACK) per setting
    /// ([`si_core::sweep::total`]).
    pub fn bound(&self) -> Duration {
        let units = self.units.len() as u64;
        si_core::sweep::total(self.probe_bounds.iter().map(|p| p.saturating_mul(units)))
    }

    /// The longest one probe at `settings` can take ([`probe_bound`] with [`PROBE_SLACK`]);
    /// `None` for a setting the scan does not try.
    pub fn probe_bound(&self, settings: SerialSettings) -> Option<Duration> {
        let i = self.settings.iter().position(|s| *s == settings)?;
        self.probe_bounds.get(i).copied()
    }

    /// The engine a probe at `config` runs on; [`Scan::new`] takes its bound from the same.
    fn engine(config: MasterConfig) -> Result<master::Master, ConfigError> {
        master::Master::new(config)
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
            let engine = Self::engine(self.at(settings)).map_err(|e| ScanError::Run(e.into()))?;
            let master = Master::spawn_engine(engine, port);
            for &unit in &self.units {
                let outcome = match master.request(unit, &PROBE).await {
                    Ok(_) => Ok(()),
                    Err(e) => Err(e.status().ok_or(e).map_err(ScanError::Run)?),
                };
                let answer = answer(outcome);
                if answer != Answer::Absent {
                    found(Found {
                        station: unit,
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
