//! Automatic use of the V.24 (RS-232C) secondary signals: one sequence for every driver that
//! offers it, the ASCII driver ([ET200S SI] §2.8) and Modbus
//! ([Modbus/USS] §3.2.2). Both manuals describe the same sequence:
//!
//! 1. On entering the mode the module sets **DTR = ON** and **RTS = OFF**.
//! 2. A send job sets **RTS = ON** and starts the *data output wait time*; the data go out once
//!    **CTS = ON**. If CTS is not ON when the wait time ends, or drops during sending, the job
//!    is aborted.
//! 3. After the last character, **RTS = OFF** once the *RTS-off time* has passed; the module does
//!    not wait for CTS to drop. Only then is the send job done.
//! 4. Receiving is possible while **DSR = ON**; DSR going OFF aborts a running send job and a
//!    running reception.
//!
//! # Readings
//!
//! - **Data output wait time** (`[derived]`; [ET200S SI] §2.8, and the same sentence pair in
//!   [Modbus/USS] §3.2.2 items 3 and 4): "when the wait time has expired and CTS = ON the data
//!   are sent", but also "if CTS does not come ON within that time, the job is aborted". We read
//!   it as a timeout: the data go out as soon as CTS = ON, and the job fails if CTS is still OFF
//!   when the time ends. A fixed delay would make CTS meaningless whenever it is ON early.
//! - **A send job while DSR = OFF** is aborted at once (ASCII [ET200S SI] §2.8: "a send job is
//!   aborted", [Modbus/USS] §3.2.2 item 7 for DSR dropping).
//! - **DSR dropping during the RTS-off time** aborts the send job and drops RTS at once
//!   ([Modbus/USS] §3.2.2 item 7, [ET200S SI] §2.8: "an active send job … aborted"). The
//!   manuals end the send job only when RTS is OFF (step 3), so it is still active then
//!   `[derived]`. CTS dropping in that time aborts nothing: the module "does not wait for CTS".
//! - **Ranges** (0 … 655 350 ms in 10 ms steps, default 10 ms) are the ASCII driver's S_V24 block
//!   (Table 2-26, block 22H); the Modbus manual gives none, [Modbus/USS] §3.2.2, so Modbus takes
//!   the same.
//!
//! The sequence is a small state machine that owns the RTS/DTR outputs and knows nothing of
//! frames: an engine asks [`AutoV24::begin`] before it transmits, reports the end of its
//! transmission with [`AutoV24::sent`], and passes timeouts and modem-signal changes through.
//! Every answer is a [`Step`] the engine acts on.

use crate::param_block::ten_ms_count;
use crate::range::RangeError;
use crate::sansio::{ModemSignals, Output, SignalUpdate};
use crate::time::{Duration, Instant};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// The two times of the automatic V.24 sequence (S_V24, ASCII Table 2-26 block 22H).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(default)]
pub struct AutoV24Times {
    /// Time from the last byte sent until RTS = OFF, 0 … 655 350 ms in 10 ms steps, default 10 ms.
    /// In files `time_rts_off_ms`.
    #[serde(rename = "time_rts_off_ms", with = "crate::time::millis")]
    pub time_rts_off: Duration,
    /// Time to wait for CTS = ON after RTS = ON, 0 … 655 350 ms in 10 ms steps, default 10 ms.
    /// In files `data_wait_time_ms`.
    #[serde(rename = "data_wait_time_ms", with = "crate::time::millis")]
    pub data_wait_time: Duration,
}

impl Default for AutoV24Times {
    fn default() -> Self {
        AutoV24Times {
            time_rts_off: Duration::from_millis(10),
            data_wait_time: Duration::from_millis(10),
        }
    }
}

/// The largest value of either time: 65 535 steps of 10 ms.
pub const MAX_TIME_MS: u32 = 655_350;

impl AutoV24Times {
    /// Every time outside 0 … 655 350 ms or off the 10 ms grid.
    pub fn validate_all(&self) -> Vec<RangeError> {
        [
            ("time to RTS off", self.time_rts_off),
            ("data output wait time", self.data_wait_time),
        ]
        .into_iter()
        .filter_map(|(parameter, time)| ten_ms_count(parameter, time, Duration::ZERO).err())
        .collect()
    }

    fn rts_off(&self) -> Duration {
        self.time_rts_off
    }

    fn data_wait(&self) -> Duration {
        self.data_wait_time
    }
}

/// Where the send side of the sequence stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// No send job; RTS = OFF.
    Idle,
    /// RTS = ON, waiting for CTS = ON until `until`.
    WaitCts {
        /// End of the data output wait time.
        until: Instant,
    },
    /// The data are going out.
    Sending,
    /// All sent; RTS goes OFF at `at`, and then the job is done.
    RtsOff {
        /// End of the RTS-off time.
        at: Instant,
    },
}

/// What the engine must do after an input to the sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Nothing (yet).
    Nothing,
    /// Transmit the job's data now.
    Send,
    /// The send job is aborted: DSR = OFF, CTS not ON within the data output wait time, CTS
    /// dropped while sending, or DSR dropped at any time before RTS = OFF (the RTS-off time
    /// included). RTS is already OFF again.
    Abort,
    /// RTS is OFF after the RTS-off time: the send job is done.
    Done,
}

/// The automatic V.24 sequence of one port.
#[derive(Debug, Clone)]
pub struct AutoV24 {
    times: AutoV24Times,
    phase: Phase,
    inputs: ModemSignals,
    rts: bool,
    dtr: bool,
}

impl AutoV24 {
    /// The sequence with these times, before entering the mode ([`enter`](Self::enter)).
    pub fn new(times: AutoV24Times) -> Self {
        AutoV24 {
            times,
            phase: Phase::Idle,
            inputs: ModemSignals::default(),
            rts: false,
            dtr: false,
        }
    }

    /// New times; they apply from the next send job.
    pub fn set_times(&mut self, times: AutoV24Times) {
        self.times = times;
    }

    /// Enter the mode (startup, a restart): DTR = ON, and RTS = OFF unless a send job holds it.
    pub fn enter<E>(&mut self, out: &mut VecDeque<Output<E>>) {
        let idle = self.phase == Phase::Idle;
        self.dtr = true;
        self.rts &= !idle;
        out.push_back(Output::SetSignals(SignalUpdate {
            dtr: Some(true),
            rts: idle.then_some(false),
        }));
    }

    /// A send job wants the line: RTS = ON, and [`Step::Send`] at once if CTS is ON,
    /// [`Step::Nothing`] while waiting for it, [`Step::Abort`] if the partner is not ready
    /// (DSR = OFF).
    pub fn begin<E>(&mut self, now: Instant, out: &mut VecDeque<Output<E>>) -> Step {
        if !self.inputs.dsr {
            self.phase = Phase::Idle;
            return Step::Abort;
        }
        self.set_rts(true, out);
        if self.inputs.cts {
            self.phase = Phase::Sending;
            Step::Send
        } else {
            self.phase = Phase::WaitCts {
                until: now + self.times.data_wait(),
            };
            Step::Nothing
        }
    }

    /// The last character has left the transmitter: RTS goes OFF after the RTS-off time
    /// ([`Step::Done`] at once when that time is 0).
    pub fn sent<E>(&mut self, now: Instant, out: &mut VecDeque<Output<E>>) -> Step {
        if self.phase != Phase::Sending {
            return Step::Nothing;
        }
        self.phase = Phase::RtsOff {
            at: now + self.times.rts_off(),
        };
        self.on_timeout(now, out)
    }

    /// The clock reached [`deadline`](Self::deadline) (early calls are harmless).
    pub fn on_timeout<E>(&mut self, now: Instant, out: &mut VecDeque<Output<E>>) -> Step {
        match self.phase {
            Phase::WaitCts { until } if now >= until => self.abort(out),
            Phase::RtsOff { at } if now >= at => {
                self.phase = Phase::Idle;
                self.set_rts(false, out);
                Step::Done
            }
            _ => Step::Nothing,
        }
    }

    /// The modem inputs changed. Returns the step for the send side and whether DSR went from
    /// ON to OFF (which also aborts a running reception, [ET200S SI] §2.8 / [Modbus/USS] §3.2.2
    /// item 7).
    pub fn on_signals<E>(
        &mut self,
        signals: ModemSignals,
        out: &mut VecDeque<Output<E>>,
    ) -> (Step, bool) {
        let dsr_dropped = self.inputs.dsr && !signals.dsr;
        self.inputs = signals;
        let step = match self.phase {
            // The send job runs until RTS is OFF (step 3), so DSR dropping during the RTS-off
            // time aborts it too ("an active send job", step 4): RTS goes OFF at once.
            Phase::WaitCts { .. } | Phase::Sending | Phase::RtsOff { .. } if dsr_dropped => {
                self.abort(out)
            }
            Phase::WaitCts { .. } if signals.cts => {
                self.phase = Phase::Sending;
                Step::Send
            }
            Phase::Sending if !signals.cts => self.abort(out),
            _ => Step::Nothing,
        };
        (step, dsr_dropped)
    }

    /// The engine ended the send job for its own reasons (a reset, a refused frame): RTS = OFF.
    pub fn cancel<E>(&mut self, out: &mut VecDeque<Output<E>>) {
        self.phase = Phase::Idle;
        if self.rts {
            self.set_rts(false, out);
        }
    }

    /// When [`on_timeout`](Self::on_timeout) has something to do.
    pub fn deadline(&self) -> Option<Instant> {
        match self.phase {
            Phase::WaitCts { until } => Some(until),
            Phase::RtsOff { at } => Some(at),
            Phase::Idle | Phase::Sending => None,
        }
    }

    /// Where the send side stands.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Characters are received only while DSR = ON.
    pub fn may_receive(&self) -> bool {
        self.inputs.dsr
    }

    /// The outputs as set by the sequence.
    pub fn rts(&self) -> bool {
        self.rts
    }

    /// DTR as set by the sequence (ON once the mode is entered).
    pub fn dtr(&self) -> bool {
        self.dtr
    }

    fn abort<E>(&mut self, out: &mut VecDeque<Output<E>>) -> Step {
        self.cancel(out);
        Step::Abort
    }

    fn set_rts<E>(&mut self, on: bool, out: &mut VecDeque<Output<E>>) {
        self.rts = on;
        out.push_back(Output::SetSignals(SignalUpdate {
            dtr: None,
            rts: Some(on),
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Out = VecDeque<Output<()>>;

    fn ready() -> ModemSignals {
        ModemSignals {
            dsr: true,
            cts: true,
            ..ModemSignals::default()
        }
    }

    fn rts_changes(out: &mut Out) -> Vec<bool> {
        out.drain(..)
            .filter_map(|o| match o {
                Output::SetSignals(SignalUpdate { rts, .. }) => rts,
                _ => None,
            })
            .collect()
    }

    fn at(ms: u64) -> Instant {
        Instant::from_micros(ms * 1_000)
    }

    #[test]
    fn entering_the_mode_sets_dtr_on_and_rts_off() {
        let mut v = AutoV24::new(AutoV24Times::default());
        let mut out = Out::new();
        v.enter(&mut out);
        assert_eq!(
            out.pop_front(),
            Some(Output::SetSignals(SignalUpdate {
                dtr: Some(true),
                rts: Some(false)
            }))
        );
        assert!(v.dtr() && !v.rts());
    }

    #[test]
    fn rts_on_send_at_cts_then_rts_off_after_the_rts_off_time() {
        let mut v = AutoV24::new(AutoV24Times::default());
        let mut out = Out::new();
        v.on_signals(
            ModemSignals {
                dsr: true,
                ..ModemSignals::default()
            },
            &mut out,
        );
        assert_eq!(v.begin(at(0), &mut out), Step::Nothing);
        assert_eq!(v.deadline(), Some(at(10)));
        assert_eq!(v.on_signals(ready(), &mut out), (Step::Send, false));
        assert_eq!(v.sent(at(50), &mut out), Step::Nothing);
        assert_eq!(v.on_timeout(at(59), &mut out), Step::Nothing);
        assert_eq!(v.on_timeout(at(60), &mut out), Step::Done);
        assert_eq!(rts_changes(&mut out), vec![true, false]);
        assert_eq!(v.phase(), Phase::Idle);
    }

    #[test]
    fn cts_not_on_within_the_data_wait_time_aborts_and_drops_rts() {
        let mut v = AutoV24::new(AutoV24Times::default());
        let mut out = Out::new();
        v.on_signals(
            ModemSignals {
                dsr: true,
                ..ModemSignals::default()
            },
            &mut out,
        );
        v.begin(at(0), &mut out);
        assert_eq!(v.on_timeout(at(10), &mut out), Step::Abort);
        assert_eq!(rts_changes(&mut out), vec![true, false]);
    }

    #[test]
    fn dsr_off_refuses_a_job_and_dsr_dropping_aborts_one() {
        let mut v = AutoV24::new(AutoV24Times::default());
        let mut out = Out::new();
        assert_eq!(v.begin(at(0), &mut out), Step::Abort);
        assert!(rts_changes(&mut out).is_empty(), "RTS never went on");
        v.on_signals(ready(), &mut out);
        assert_eq!(v.begin(at(1), &mut out), Step::Send);
        let (step, dropped) = v.on_signals(ModemSignals::default(), &mut out);
        assert_eq!((step, dropped), (Step::Abort, true));
        assert!(!v.may_receive());
        assert_eq!(rts_changes(&mut out), vec![true, false]);
    }

    #[test]
    fn dsr_dropping_during_the_rts_off_time_aborts_and_drops_rts_at_once() {
        let mut v = AutoV24::new(AutoV24Times::default());
        let mut out = Out::new();
        v.on_signals(ready(), &mut out);
        v.begin(at(0), &mut out);
        assert_eq!(v.sent(at(5), &mut out), Step::Nothing);
        let (step, dropped) = v.on_signals(ModemSignals::default(), &mut out);
        assert_eq!((step, dropped), (Step::Abort, true));
        assert_eq!(rts_changes(&mut out), vec![true, false]);
        assert_eq!((v.phase(), v.deadline()), (Phase::Idle, None));
    }

    #[test]
    fn cts_dropping_during_the_rts_off_time_does_not_abort() {
        let mut v = AutoV24::new(AutoV24Times::default());
        let mut out = Out::new();
        v.on_signals(ready(), &mut out);
        v.begin(at(0), &mut out);
        v.sent(at(5), &mut out);
        let only_dsr = ModemSignals {
            dsr: true,
            ..ModemSignals::default()
        };
        assert_eq!(v.on_signals(only_dsr, &mut out), (Step::Nothing, false));
        assert_eq!(v.on_timeout(at(15), &mut out), Step::Done);
    }

    #[test]
    fn cts_dropping_while_sending_aborts() {
        let mut v = AutoV24::new(AutoV24Times::default());
        let mut out = Out::new();
        v.on_signals(ready(), &mut out);
        v.begin(at(0), &mut out);
        let (step, dropped) = v.on_signals(
            ModemSignals {
                dsr: true,
                ..ModemSignals::default()
            },
            &mut out,
        );
        assert_eq!((step, dropped), (Step::Abort, false));
    }

    #[test]
    fn a_zero_rts_off_time_ends_the_job_with_the_last_byte() {
        let times = AutoV24Times {
            time_rts_off: Duration::ZERO,
            data_wait_time: Duration::ZERO,
        };
        let mut v = AutoV24::new(times);
        let mut out = Out::new();
        v.on_signals(ready(), &mut out);
        assert_eq!(v.begin(at(0), &mut out), Step::Send);
        assert_eq!(v.sent(at(3), &mut out), Step::Done);
    }

    #[test]
    fn times_outside_the_range_or_grid_are_named() {
        let times = AutoV24Times {
            time_rts_off: Duration::from_millis(655_360),
            data_wait_time: Duration::from_millis(5),
        };
        let errors = times.validate_all();
        assert_eq!(errors.len(), 2);
        assert_eq!(
            errors[0].to_string(),
            "time to RTS off = 655360 ms is out of range: 0 … 655350 ms in 10 ms steps"
        );
        assert!(AutoV24Times::default().validate_all().is_empty());
    }
}
