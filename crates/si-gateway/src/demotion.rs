//! Auto-demotion: a unit that stops answering is taken off its line for a while, so a dead
//! slave does not slow every live one on the same line. Pure state, time passed in.
//!
//! Gateway behaviour, not a manual's `[derived]`: Kepware's "auto-demotion" and Neuron's
//! `device_degrade` do the same; the module has no gateway. Per unit of a line:
//!
//! - after [`DemotionConfig::demote_after`] consecutive **failed** requests (no valid answer:
//!   a timeout, or an answer still corrupt after the retries) the unit is **demoted** for
//!   [`DemotionConfig::demote_for`];
//! - while demoted its requests are refused at once ([`Admit::Refuse`]: the gateway answers
//!   0BH, "gateway target device failed to respond", [Modbus AP] §7) and no byte goes to the
//!   line;
//! - once that time is over, exactly **one** request probes it ([`Admit::Probe`]); requests
//!   arriving while the probe is out are still refused. A probe that succeeds restores the unit,
//!   one that fails demotes it again for the whole time;
//! - a slave's exception is an answer: the unit is alive.
//!
//! `demote_after = 0` disables demotion. Every change is a [`Change`]; [`DemotionCounters`]
//! only grow.

use serde::{Deserialize, Serialize};
use si_core::{Duration, Instant};
use std::collections::BTreeMap;

/// Failures in a row that demote a unit, by default.
pub const DEFAULT_DEMOTE_AFTER: u32 = 3;
/// How long a unit stays demoted, by default: 30 s.
pub const DEFAULT_DEMOTE_FOR: Duration = Duration::from_secs(30);

/// The demotion settings of a line (file keys `demote_after`, `demote_for_ms`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DemotionConfig {
    /// Consecutive failed requests that demote a unit; 0 disables demotion.
    pub demote_after: u32,
    /// How long a demoted unit's requests are refused before one probes it.
    #[serde(rename = "demote_for_ms", with = "si_core::time::millis")]
    pub demote_for: Duration,
}

impl Default for DemotionConfig {
    fn default() -> Self {
        DemotionConfig {
            demote_after: DEFAULT_DEMOTE_AFTER,
            demote_for: DEFAULT_DEMOTE_FOR,
        }
    }
}

impl DemotionConfig {
    /// True if units are ever demoted.
    pub fn enabled(&self) -> bool {
        self.demote_after > 0
    }
}

/// What to do with a request for a unit now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Admit {
    /// Send it to the line.
    Send,
    /// Send it: it is the one request that probes a demoted unit.
    Probe,
    /// Answer 0BH at once; nothing goes to the line.
    Refuse,
}

/// A change of a unit's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// The unit failed `failures` requests in a row and is demoted until `for_ms` from now.
    Demoted {
        /// The unit id.
        unit: u8,
        /// The failures in a row that demoted it.
        failures: u32,
        /// How long it stays demoted, in ms.
        for_ms: u64,
    },
    /// The probe failed: demoted again for the whole time.
    ProbeFailed {
        /// The unit id.
        unit: u8,
        /// How long it stays demoted, in ms.
        for_ms: u64,
    },
    /// The probe was answered: the unit is served again.
    Restored {
        /// The unit id.
        unit: u8,
    },
}

/// What demotion did on a line, never reset.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct DemotionCounters {
    /// Times a unit was demoted after its failures in a row (a failed probe not included).
    pub demotions: u64,
    /// Requests refused with 0BH because their unit was demoted.
    pub refused: u64,
    /// Requests sent as probes.
    pub probes: u64,
    /// Probes that failed.
    pub probes_failed: u64,
    /// Units restored by a successful probe.
    pub restorations: u64,
}

/// The state of one unit.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum UnitState {
    /// Served; `failures` in a row so far.
    #[default]
    Healthy,
    /// Refused until `until`.
    Demoted {
        /// When one request may probe it.
        until: Instant,
    },
    /// The one probe is out.
    Probing,
}

/// One unit's health.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UnitHealth {
    state: UnitState,
    /// Failed requests in a row while healthy.
    failures: u32,
}

impl UnitHealth {
    /// Its state.
    #[cfg(test)]
    pub fn state(&self) -> UnitState {
        self.state
    }

    /// True while its requests are refused (demoted, or its probe is out).
    pub fn is_demoted(&self) -> bool {
        !matches!(self.state, UnitState::Healthy)
    }
}

/// The health of every unit of one line.
#[derive(Debug, Clone, Default)]
pub struct LineHealth {
    config: DemotionConfig,
    units: BTreeMap<u8, UnitHealth>,
    counters: DemotionCounters,
}

impl LineHealth {
    /// Every unit healthy.
    pub fn new(config: DemotionConfig) -> Self {
        LineHealth {
            config,
            units: BTreeMap::new(),
            counters: DemotionCounters::default(),
        }
    }

    /// The counters so far (the gateway counts the same through its metrics).
    #[cfg(test)]
    pub fn counters(&self) -> DemotionCounters {
        self.counters
    }

    /// One unit's health (healthy if never seen).
    #[cfg(test)]
    pub fn unit(&self, unit: u8) -> UnitHealth {
        self.units.get(&unit).copied().unwrap_or_default()
    }

    /// Units whose requests are refused now (the gauge "demoted units").
    pub fn demoted(&self) -> usize {
        self.units.values().filter(|u| u.is_demoted()).count()
    }

    /// Whether a request for `unit` at `now` goes to the line. A refusal is counted.
    pub fn admit(&mut self, unit: u8, now: Instant) -> Admit {
        let Some(health) = self.units.get_mut(&unit) else {
            return Admit::Send;
        };
        match health.state {
            UnitState::Healthy => Admit::Send,
            UnitState::Demoted { until } if now >= until => {
                health.state = UnitState::Probing;
                self.counters.probes += 1;
                Admit::Probe
            }
            UnitState::Demoted { .. } | UnitState::Probing => {
                self.counters.refused += 1;
                Admit::Refuse
            }
        }
    }

    /// A request sent to `unit` got a valid answer (a slave exception included). A demoted
    /// unit is restored by it, whether it was the probe or a request sent before the unit was
    /// demoted that ended after it: either way its requests go to the line again, which the
    /// program is told ([`Change::Restored`]).
    pub fn succeeded(&mut self, unit: u8) -> Option<Change> {
        let health = self.units.remove(&unit)?;
        health.is_demoted().then(|| {
            self.counters.restorations += 1;
            Change::Restored { unit }
        })
    }

    /// A request admitted for `unit` says nothing about it (the gateway refused it itself, or
    /// the port closed under it): a probe out is taken back, so the next request probes.
    pub fn inconclusive(&mut self, unit: u8, now: Instant) {
        if let Some(health) = self.units.get_mut(&unit) {
            if health.state == UnitState::Probing {
                health.state = UnitState::Demoted { until: now };
            }
        }
    }

    /// A request sent to `unit` got no valid answer (timeout, corrupt after the retries).
    pub fn failed(&mut self, unit: u8, now: Instant) -> Option<Change> {
        if !self.config.enabled() {
            return None;
        }
        let for_ms = self.config.demote_for.as_millis();
        let until = now + self.config.demote_for;
        let health = self.units.entry(unit).or_default();
        match health.state {
            UnitState::Probing => {
                health.state = UnitState::Demoted { until };
                self.counters.probes_failed += 1;
                Some(Change::ProbeFailed { unit, for_ms })
            }
            // A request sent before the unit was demoted ends after it: no new demotion.
            UnitState::Demoted { .. } => None,
            UnitState::Healthy => {
                health.failures += 1;
                if health.failures < self.config.demote_after {
                    return None;
                }
                let failures = health.failures;
                *health = UnitHealth {
                    state: UnitState::Demoted { until },
                    failures: 0,
                };
                self.counters.demotions += 1;
                Some(Change::Demoted {
                    unit,
                    failures,
                    for_ms,
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(ms: u64) -> Instant {
        Instant::from_micros(ms * 1000)
    }

    fn line() -> LineHealth {
        LineHealth::new(DemotionConfig::default())
    }

    #[test]
    fn three_failures_in_a_row_demote_for_thirty_seconds() {
        let mut h = line();
        assert_eq!(h.failed(5, at(0)), None);
        assert_eq!(h.failed(5, at(1)), None);
        assert_eq!(h.admit(5, at(2)), Admit::Send);
        assert_eq!(
            h.failed(5, at(2)),
            Some(Change::Demoted {
                unit: 5,
                failures: 3,
                for_ms: 30_000
            })
        );
        assert_eq!(h.admit(5, at(3)), Admit::Refuse);
        assert_eq!(h.admit(5, at(30_001)), Admit::Refuse);
        assert_eq!(h.demoted(), 1);
        // Other units are not touched.
        assert_eq!(h.admit(6, at(3)), Admit::Send);
        assert_eq!(h.counters().refused, 2);
        assert_eq!(h.counters().demotions, 1);
    }

    #[test]
    fn an_answer_resets_the_failures_in_a_row() {
        let mut h = line();
        h.failed(5, at(0));
        h.failed(5, at(1));
        assert_eq!(h.succeeded(5), None);
        h.failed(5, at(2));
        h.failed(5, at(3));
        assert_eq!(h.unit(5).state(), UnitState::Healthy);
        assert!(h.failed(5, at(4)).is_some());
    }

    #[test]
    fn exactly_one_probe_after_the_time_then_restored() {
        let mut h = line();
        for t in 0..3 {
            h.failed(9, at(t));
        }
        assert_eq!(h.admit(9, at(30_002)), Admit::Probe);
        // While the probe is out, the others are refused.
        assert_eq!(h.admit(9, at(30_003)), Admit::Refuse);
        assert_eq!(h.admit(9, at(30_004)), Admit::Refuse);
        assert_eq!(h.succeeded(9), Some(Change::Restored { unit: 9 }));
        assert_eq!(h.admit(9, at(30_005)), Admit::Send);
        assert_eq!(h.demoted(), 0);
        let c = h.counters();
        assert_eq!((c.probes, c.restorations, c.refused), (1, 1, 2));
    }

    #[test]
    fn a_failed_probe_restarts_the_whole_time() {
        let mut h = line();
        for t in 0..3 {
            h.failed(9, at(t));
        }
        assert_eq!(h.admit(9, at(40_000)), Admit::Probe);
        assert_eq!(
            h.failed(9, at(40_500)),
            Some(Change::ProbeFailed {
                unit: 9,
                for_ms: 30_000
            })
        );
        assert_eq!(h.admit(9, at(70_499)), Admit::Refuse);
        assert_eq!(h.admit(9, at(70_500)), Admit::Probe);
        assert_eq!(h.counters().probes_failed, 1);
        assert_eq!(
            h.counters().demotions,
            1,
            "a failed probe is no new demotion"
        );
    }

    #[test]
    fn an_inconclusive_probe_lets_the_next_request_probe() {
        let mut h = line();
        for t in 0..3 {
            h.failed(9, at(t));
        }
        assert_eq!(h.admit(9, at(30_002)), Admit::Probe);
        h.inconclusive(9, at(30_003));
        assert_eq!(h.admit(9, at(30_004)), Admit::Probe);
        assert_eq!(h.succeeded(9), Some(Change::Restored { unit: 9 }));
        // A healthy unit is not touched.
        h.inconclusive(9, at(30_005));
        assert_eq!(h.admit(9, at(30_006)), Admit::Send);
    }

    #[test]
    fn a_late_failure_of_a_request_sent_before_the_demotion_changes_nothing() {
        let mut h = line();
        for t in 0..3 {
            h.failed(9, at(t));
        }
        assert_eq!(h.failed(9, at(4)), None);
        assert_eq!(h.unit(9).state(), UnitState::Demoted { until: at(30_002) });
    }

    #[test]
    fn an_answer_after_the_demotion_restores_the_unit_and_says_so() {
        let mut h = line();
        for t in 0..3 {
            h.failed(9, at(t));
        }
        assert!(h.unit(9).is_demoted());
        // A request admitted before the demotion, answered after it.
        assert_eq!(h.succeeded(9), Some(Change::Restored { unit: 9 }));
        assert_eq!(h.admit(9, at(4)), Admit::Send);
        assert_eq!(h.demoted(), 0);
        assert_eq!(h.counters().restorations, 1);
        // A healthy unit's answer changes nothing.
        assert_eq!(h.succeeded(9), None);
    }

    #[test]
    fn zero_disables_demotion() {
        let mut h = LineHealth::new(DemotionConfig {
            demote_after: 0,
            ..DemotionConfig::default()
        });
        for t in 0..100 {
            assert_eq!(h.failed(1, at(t)), None);
            assert_eq!(h.admit(1, at(t)), Admit::Send);
        }
    }

    #[test]
    fn file_keys_and_defaults() {
        let c: DemotionConfig =
            serde_json::from_str(r#"{"demote_after": 5, "demote_for_ms": 1500}"#).unwrap();
        assert_eq!(c.demote_after, 5);
        assert_eq!(c.demote_for, Duration::from_millis(1500));
        let d: DemotionConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(d, DemotionConfig::default());
        assert_eq!(d.demote_for, Duration::from_millis(30_000));
        assert!(serde_json::from_str::<DemotionConfig>(r#"{"demote_for": 1}"#).is_err());
    }
}
