//! A deterministic DP link between a [`Host`] and a [`Module`], for tests, demos and `si sim`.
//!
//! The host cycle, the module cycle and the DP exchange are asynchronous
//! ([ET200S SI 2005] §2.12.1, Fig. 2-23, §2.12.2, §2.12.3, §2.11): each [`DpLink::step`] does one
//! of the three, chosen by a seeded generator, so each side reads the other's window late by a
//! random number of cycles, and an output written twice between two exchanges is never seen. Faults
//! can be injected on the exchange ([`DpFaults`]): out-of-order segments in either direction
//! ([ET200S SI 2005] §2.12.7) and foreign job requests ([ET200S SI 2005] §2.12.1 rule 3). The
//! host's view of every cycle can be recorded as a [`DpRecord`] table, the shape of the manual's
//! example tables.

use crate::coord::{CoordByte, JobCode};
use crate::frame::Window;
use crate::host::{Host, HostEvent, Job, JobId, Outcome, SubmitError};
use crate::module::{LoopbackSerial, Module, SerialSide};
use bytes::Bytes;
use si_core::{Duration, Instant, Status};
use si_sim::SplitMix64;

/// Faults injected on the DP exchange, as probabilities per exchange.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DpFaults {
    /// A send/parameter segment reaching the module carries a wrong exec number (2 or 3 ahead,
    /// never the expected or the repeated one).
    pub out_of_order_out: f64,
    /// A receive segment reaching the host carries a wrong exec number.
    pub out_of_order_in: f64,
    /// A job request reaching the idle module is replaced by another job's request (30H, or 40H
    /// when the host asked for 30H): what a second writer of byte 0 would cause.
    pub foreign_request: f64,
}

/// What one [`DpLink::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DpStep {
    /// The host ran one cycle.
    Host,
    /// The module ran one cycle.
    Module,
    /// The DP master exchanged the windows.
    Exchange,
}

/// One host cycle as the manual's tables show it: what the host read and what it wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DpRecord {
    /// When.
    pub at: Instant,
    /// The input window the host read (module → host).
    pub input: Window,
    /// The output window the host wrote (host → module).
    pub output: Window,
}

/// Host cycles kept in the record (older ones are dropped).
const RECORD_LIMIT: usize = 100_000;

/// A host and a module joined by a simulated DP exchange with seeded random lag.
#[derive(Debug)]
pub struct DpLink<S: SerialSide = LoopbackSerial> {
    /// The host engine.
    pub host: Host,
    /// The module engine.
    pub module: Module<S>,
    /// Faults injected on the exchange.
    pub faults: DpFaults,
    /// Shortest and longest virtual time per step.
    pub step_time: (Duration, Duration),
    rng: SplitMix64,
    now: Instant,
    host_out: Window,
    module_sees: Window,
    module_out: Window,
    host_sees: Window,
    events: Vec<HostEvent>,
    injected: u64,
    record: Option<Vec<DpRecord>>,
    collect: bool,
}

impl<S: SerialSide> DpLink<S> {
    /// Joins `host` and `module` (both must use the same window size); `seed` fixes the order
    /// of cycles and the faults.
    pub fn new(host: Host, module: Module<S>, seed: u64) -> Self {
        let out = Window::from_bytes(host.output()).unwrap_or(Window::new(host.config().window));
        let inp = Window::from_bytes(module.input()).unwrap_or(Window::new(module.config().window));
        DpLink {
            host,
            module,
            faults: DpFaults::default(),
            step_time: (Duration::from_micros(100), Duration::from_micros(1_000)),
            rng: SplitMix64::new(seed),
            now: Instant::ZERO,
            host_out: out,
            module_sees: out,
            module_out: inp,
            host_sees: inp,
            events: Vec::new(),
            injected: 0,
            record: None,
            collect: true,
        }
    }

    /// Leaves the host's events in the host (for FB equivalents, which take their own
    /// completions with [`Host::take_completion`]); [`events`](Self::events) stays empty.
    pub fn without_event_collection(mut self) -> Self {
        self.collect = false;
        self
    }

    /// Records every host cycle from now on (see [`records`](Self::records)).
    pub fn with_record(mut self) -> Self {
        self.record = Some(Vec::new());
        self
    }

    /// The virtual time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Faults injected so far.
    pub fn injected(&self) -> u64 {
        self.injected
    }

    /// Host events so far, oldest first.
    pub fn events(&self) -> &[HostEvent] {
        &self.events
    }

    /// Takes the host events collected so far.
    pub fn take_events(&mut self) -> Vec<HostEvent> {
        core::mem::take(&mut self.events)
    }

    /// The recorded host cycles (empty unless [`with_record`](Self::with_record)).
    pub fn records(&self) -> &[DpRecord] {
        self.record.as_deref().unwrap_or(&[])
    }

    /// Submits a job to the host.
    pub fn submit(&mut self, job: Job) -> Result<JobId, SubmitError> {
        self.host.submit(job)
    }

    /// One random step; returns what it was.
    pub fn step(&mut self) -> DpStep {
        let (lo, hi) = self.step_time;
        let span = hi
            .as_micros()
            .saturating_sub(lo.as_micros())
            .saturating_add(1);
        self.now += lo + Duration::from_micros(self.rng.below(span));
        match self.rng.below(3) {
            0 => {
                let out = self.host.cycle(self.now, self.host_sees.as_bytes());
                self.host_out = Window::from_bytes(out).unwrap_or(self.host_out);
                if self.collect {
                    self.events
                        .extend(std::iter::from_fn(|| self.host.poll_event()));
                }
                if let Some(r) = &mut self.record {
                    if r.len() >= RECORD_LIMIT {
                        r.remove(0);
                    }
                    r.push(DpRecord {
                        at: self.now,
                        input: self.host_sees,
                        output: self.host_out,
                    });
                }
                DpStep::Host
            }
            1 => {
                let inp = self.module.cycle(self.now, self.module_sees.as_bytes());
                self.module_out = Window::from_bytes(inp).unwrap_or(self.module_out);
                DpStep::Module
            }
            _ => {
                self.exchange();
                DpStep::Exchange
            }
        }
    }

    fn exchange(&mut self) {
        self.module_sees = self.host_out;
        self.host_sees = self.module_out;
        let o = self.module_sees.coord();
        if matches!(o.job, JobCode::Send | JobCode::Parameters)
            && o.exec != 0
            && !o.error
            && self.rng.chance(self.faults.out_of_order_out)
        {
            let shifted = shift_exec(o, 2 + self.rng.below(2) as u8);
            self.module_sees.set_coord(shifted);
            self.injected += 1;
        }
        if o.exec == 0
            && !o.error
            && o.job != JobCode::Idle
            && self.module.is_idle()
            && self.rng.chance(self.faults.foreign_request)
        {
            let foreign = if o.job == JobCode::ReadV24 {
                JobCode::WriteV24
            } else {
                JobCode::ReadV24
            };
            self.module_sees.clear();
            self.module_sees.set_coord(CoordByte::new(foreign, 0));
            self.injected += 1;
        }
        let i = self.host_sees.coord();
        if i.job == JobCode::Receive
            && i.exec != 0
            && !i.error
            && self.rng.chance(self.faults.out_of_order_in)
        {
            let shifted = shift_exec(i, 2 + self.rng.below(2) as u8);
            self.host_sees.set_coord(shifted);
            self.injected += 1;
        }
    }

    /// Steps until `done(self)` holds or `budget` steps have run; returns whether it held.
    pub fn run_until(&mut self, budget: usize, mut done: impl FnMut(&Self) -> bool) -> bool {
        for _ in 0..budget {
            if done(self) {
                return true;
            }
            self.step();
        }
        done(self)
    }

    /// The completion of `id`, if it has arrived (and was not taken).
    pub fn completion(&self, id: JobId) -> Option<&Result<Outcome, Status>> {
        self.events.iter().find_map(|e| match e {
            HostEvent::Completed { id: i, result, .. } if *i == id => Some(result),
            _ => None,
        })
    }

    /// How many completions `id` got (the protocol promises exactly one).
    pub fn completions_of(&self, id: JobId) -> usize {
        self.events
            .iter()
            .filter(|e| matches!(e, HostEvent::Completed { id: i, .. } if *i == id))
            .count()
    }

    /// Submits `job` and steps until it completes; `None` if `budget` steps were not enough.
    pub fn run_job(&mut self, job: Job, budget: usize) -> Option<Result<Outcome, Status>> {
        let id = self.host.submit(job).ok()?;
        self.run_until(budget, |l| l.completion(id).is_some());
        self.completion(id).cloned()
    }

    /// Frames received by completed receive jobs so far.
    pub fn received(&self) -> Vec<Bytes> {
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

    /// The STATUS of every failed completion so far.
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

/// The exec number `by` steps further in the 1…7 cycle.
fn shift_exec(c: CoordByte, by: u8) -> CoordByte {
    let e = c.exec.max(1);
    CoordByte::new(c.job, (e - 1 + by) % 7 + 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{HostConfig, ModuleConfig};
    use crate::frame::WindowSize;

    #[test]
    fn shifted_exec_is_never_the_expected_or_repeated_one() {
        for e in 1..=7u8 {
            for by in 2..=3 {
                let s = shift_exec(CoordByte::new(JobCode::Send, e), by).exec;
                assert!((1..=7).contains(&s));
                assert_ne!(s, e);
                assert_ne!(s, crate::coord::ExecWrap::ToOne.next(e));
            }
        }
    }

    #[test]
    fn records_show_the_host_view_of_a_send() {
        let host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
        let module =
            Module::new(ModuleConfig::new(WindowSize::Eight), LoopbackSerial::new()).unwrap();
        let mut link = DpLink::new(host, module, 1).with_record();
        let r = link.run_job(Job::Send(Bytes::from_static(b"abc")), 1_000);
        assert_eq!(r, Some(Ok(Outcome::Sent)));
        let outs: Vec<u8> = link
            .records()
            .iter()
            .map(|r| r.output.as_bytes()[0])
            .collect();
        assert!(outs.contains(&0x10) && outs.contains(&0x11));
        assert!(link.records().iter().any(|r| r.input.as_bytes()[0] == 0x71));
    }
}
