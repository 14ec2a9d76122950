//! Shared test helpers: window patterns with don't-care bytes, and a host–module link with
//! seeded random DP-cycle lag and fault injection.
#![allow(dead_code)]

use si_core::{Instant, Status};
use si_dp_coord::host::{Host, Job, Outcome};
use si_dp_coord::module::{LoopbackSerial, Module};
#[allow(unused_imports)]
pub use si_dp_coord::sim::{DpFaults as Faults, DpLink};
use si_dp_coord::{HostConfig, ModuleConfig};

/// Parses "11 00 16 'a' xx …": hex bytes, quoted ASCII characters, `xx` = don't care.
pub fn pattern(text: &str) -> Vec<Option<u8>> {
    text.split_whitespace()
        .map(|t| {
            if t == "xx" || t == "nn" {
                None
            } else if t.len() == 3 && t.starts_with('\'') && t.ends_with('\'') {
                Some(t.as_bytes()[1])
            } else {
                Some(u8::from_str_radix(t, 16).unwrap_or_else(|_| panic!("bad token {t}")))
            }
        })
        .collect()
}

/// A window for a pattern, don't-care bytes as 00H.
pub fn bytes(text: &str) -> Vec<u8> {
    pattern(text).into_iter().map(|b| b.unwrap_or(0)).collect()
}

/// Asserts that `actual` matches the pattern (same length, every fixed byte equal).
#[track_caller]
pub fn assert_window(what: &str, actual: &[u8], expected: &str) {
    let p = pattern(expected);
    let ok = p.len() == actual.len()
        && p.iter()
            .zip(actual)
            .all(|(e, a)| e.is_none() || *e == Some(*a));
    assert!(
        ok,
        "{what}: got {}, expected {expected}",
        si_core::hex::format(actual)
    );
}

/// The `n`-th millisecond.
pub fn ms(n: u64) -> Instant {
    Instant::from_micros(n * 1_000)
}

/// The library's DP link with the loopback serial side.
pub type Link = DpLink<LoopbackSerial>;

/// A link between a fresh host and a fresh loopback module.
pub fn link(host: HostConfig, module: ModuleConfig, seed: u64) -> Link {
    DpLink::new(
        Host::new(host).unwrap(),
        Module::new(module, LoopbackSerial::new()).unwrap(),
        seed,
    )
}

/// Runs a job to completion, asserting it ends exactly once within the budget.
pub trait RunJob {
    /// The job's result.
    fn run(&mut self, job: Job, budget: usize) -> Result<Outcome, Status>;
}

impl RunJob for Link {
    #[track_caller]
    fn run(&mut self, job: Job, budget: usize) -> Result<Outcome, Status> {
        let id = self.host.submit(job).expect("submit");
        assert!(
            self.run_until(budget, |l| l.completion(id).is_some()),
            "job {id:?} did not complete within {budget} steps"
        );
        assert_eq!(self.completions_of(id), 1);
        self.completion(id).unwrap().clone()
    }
}
