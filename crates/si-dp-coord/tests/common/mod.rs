//! Shared test helpers: window patterns with don't-care bytes, and a host–module link with
//! seeded random DP-cycle lag and fault injection.
#![allow(dead_code)]

use si_core::sim::SplitMix64;
use si_core::Status;
use si_core::{Duration, Instant};
use si_dp_coord::coord::{CoordByte, JobCode};
use si_dp_coord::host::{Host, HostEvent, Job, JobId, Outcome};
use si_dp_coord::module::{LoopbackSerial, Module};
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

/// Faults injected on the DP exchange.
#[derive(Debug, Clone, Copy, Default)]
pub struct Faults {
    /// Probability that a send/parameter segment reaching the module carries a wrong exec number.
    pub out_of_order_out: f64,
    /// Probability that a receive segment reaching the host carries a wrong exec number.
    pub out_of_order_in: f64,
    /// Probability that a job request reaching the idle module is replaced by another job code.
    pub foreign_request: f64,
}

/// A host and a module joined by a DP "bus" whose exchanges, host cycles and module cycles
/// happen in a seeded random order, so each side sees the other with a random lag.
pub struct Link {
    pub host: Host,
    pub module: Module<LoopbackSerial>,
    pub rng: SplitMix64,
    pub faults: Faults,
    pub now: Instant,
    /// What the host last wrote / what the module last read.
    host_out: Vec<u8>,
    module_sees: Vec<u8>,
    /// What the module last wrote / what the host last read.
    module_out: Vec<u8>,
    host_sees: Vec<u8>,
    pub events: Vec<HostEvent>,
    pub injected: u64,
}

impl Link {
    pub fn new(host: HostConfig, module: ModuleConfig, seed: u64) -> Link {
        let host = Host::new(host).unwrap();
        let module = Module::new(module, LoopbackSerial::new()).unwrap();
        let idle_out = host.output().to_vec();
        let idle_in = module.input().to_vec();
        Link {
            host,
            module,
            rng: SplitMix64::new(seed),
            faults: Faults::default(),
            now: Instant::ZERO,
            host_out: idle_out.clone(),
            module_sees: idle_out,
            module_out: idle_in.clone(),
            host_sees: idle_in,
            events: Vec::new(),
            injected: 0,
        }
    }

    fn shift_exec(byte: u8, by: u8) -> u8 {
        let e = byte & 7;
        (byte & !7) | ((e - 1 + by) % 7 + 1)
    }

    /// One random step: a host cycle, a module cycle or a DP exchange.
    pub fn step(&mut self) {
        self.now += Duration::from_micros(100 + self.rng.below(900));
        match self.rng.below(3) {
            0 => {
                self.host_out = self.host.cycle(self.now, &self.host_sees).to_vec();
                while let Some(e) = self.host.poll_event() {
                    self.events.push(e);
                }
            }
            1 => {
                self.module_out = self.module.cycle(self.now, &self.module_sees).to_vec();
            }
            _ => {
                self.module_sees = self.host_out.clone();
                self.host_sees = self.module_out.clone();
                let o = CoordByte::decode(self.module_sees[0]);
                if matches!(o.job, JobCode::Send | JobCode::Parameters)
                    && o.exec != 0
                    && !o.error
                    && self.rng.chance(self.faults.out_of_order_out)
                {
                    let by = 2 + self.rng.below(2) as u8;
                    self.module_sees[0] = Self::shift_exec(self.module_sees[0], by);
                    self.injected += 1;
                }
                if o.exec == 0
                    && !o.error
                    && o.job != JobCode::Idle
                    && self.module.is_idle()
                    && self.rng.chance(self.faults.foreign_request)
                {
                    let foreign = if o.job == JobCode::ReadV24 {
                        0x40
                    } else {
                        0x30
                    };
                    self.module_sees = vec![0; self.module_sees.len()];
                    self.module_sees[0] = foreign;
                    self.injected += 1;
                }
                let i = CoordByte::decode(self.host_sees[0]);
                if i.job == JobCode::Receive
                    && i.exec != 0
                    && !i.error
                    && self.rng.chance(self.faults.out_of_order_in)
                {
                    let by = 2 + self.rng.below(2) as u8;
                    self.host_sees[0] = Self::shift_exec(self.host_sees[0], by);
                    self.injected += 1;
                }
            }
        }
    }

    /// Steps until `done(self)` or the step budget runs out; returns whether `done` held.
    pub fn run_until(&mut self, budget: usize, mut done: impl FnMut(&Link) -> bool) -> bool {
        for _ in 0..budget {
            if done(self) {
                return true;
            }
            self.step();
        }
        done(self)
    }

    /// The completion of `id`, if it has arrived.
    pub fn completion(&self, id: JobId) -> Option<&Result<Outcome, Status>> {
        self.events.iter().find_map(|e| match e {
            HostEvent::Completed { id: i, result, .. } if *i == id => Some(result),
            _ => None,
        })
    }

    /// Number of completions of `id` (must never exceed 1).
    pub fn completions_of(&self, id: JobId) -> usize {
        self.events
            .iter()
            .filter(|e| matches!(e, HostEvent::Completed { id: i, .. } if *i == id))
            .count()
    }

    /// Submits `job` and runs until it completes; returns its result.
    #[track_caller]
    pub fn run_job(&mut self, job: Job, budget: usize) -> Result<Outcome, Status> {
        let id = self.host.submit(job).expect("submit");
        assert!(
            self.run_until(budget, |l| l.completion(id).is_some()),
            "job {id:?} did not complete within {budget} steps"
        );
        assert_eq!(self.completions_of(id), 1);
        self.completion(id).unwrap().clone()
    }

    /// Received frames reported by completions so far (automatic or explicit receive jobs).
    pub fn received(&self) -> Vec<bytes::Bytes> {
        self.events
            .iter()
            .filter_map(|e| match e {
                HostEvent::Completed {
                    result: Ok(Outcome::Received(f)),
                    ..
                } => Some(f.clone()),
                _ => None,
            })
            .collect()
    }

    /// Failed completions so far.
    pub fn failures(&self) -> Vec<Status> {
        self.events
            .iter()
            .filter_map(|e| match e {
                HostEvent::Completed { result: Err(s), .. } => Some(*s),
                _ => None,
            })
            .collect()
    }

    /// Back-off notices so far.
    pub fn backoffs(&self) -> usize {
        self.events
            .iter()
            .filter(|e| matches!(e, HostEvent::BackedOff { .. }))
            .count()
    }
}
