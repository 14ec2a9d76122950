//! Running a master job once or as a poll, over one or several units, as mbpoll users expect:
//! a poll keeps going after timeouts, exceptions and CRC errors, prints one line
//! per outcome, and ends with counters per unit.
//!
//! Exit status, one rule however the run ends:
//! - interrupted (Ctrl-C, SIGINT), between polls or inside a request: the counters (when
//!   polling), then exit 130 (128 + SIGINT, as shells report it); the request in flight is
//!   abandoned and not counted;
//! - a poll that ends after `--cycles N`: the counters, then 0 if every poll was answered,
//!   else 1 ("k of n polls failed");
//! - one job without `--poll`: its line, or its failure as the error (exit 1); with several
//!   units, one line per unit and exit 1 if any failed.
//!
//! A failure's kind comes from its STATUS (`si_modbus::poll_counters`). A job the master
//! refuses before sending (0E4xH) or a closed port ends the run: repeating it could only fail
//! the same way.

use super::explain::{failure, status_text};
use super::report::Report;
use clap::Args;
use serde_json::json;
use si_core::Status;
use si_modbus::frame::Request;
use si_modbus::tokio::{Error as ModbusError, Master};

use crate::error::CliError;

/// `--poll` and `--cycles`.
#[derive(Debug, Clone, Default, Args)]
pub struct PollArgs {
    /// Repeat every MS milliseconds (after the last unit's answer) until interrupted or
    /// --cycles ends it; failures print a line each and polling goes on. Ctrl-C prints the
    /// counters per unit and exits with 130 (interrupted), whether between polls or inside a
    /// request. After --cycles: the counters, exit 0 if every poll was answered, else 1.
    #[arg(long, value_name = "MS")]
    poll: Option<u64>,
    /// With --poll: stop after N cycles (a cycle asks every --unit once).
    #[arg(long, value_name = "N", requires = "poll",
          value_parser = clap::value_parser!(u64).range(1..))]
    cycles: Option<u64>,
}

impl PollArgs {
    /// `--poll` given: the jobs repeat until interrupted or `--cycles` ends them.
    pub fn is_polling(&self) -> bool {
        self.poll.is_some()
    }
}

pub use si_modbus::poll_counters::{Counters, Kind};

/// The counters as one line of text.
pub fn counters_text(c: &Counters, unit: u8) -> String {
    format!(
        "--- unit {unit}: {} polls, {} answers, {} exceptions, {} timeouts, {} other errors",
        c.polls, c.answers, c.exceptions, c.timeouts, c.other_errors
    )
}

/// A job that failed on the line: counted, printed, and the poll goes on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineFailure {
    /// What the counters count it as.
    pub kind: Kind,
    /// The module's STATUS, when there is one (a Modbus TCP gateway exception 0AH/0BH has
    /// none: the serial module never answers with it).
    pub status: Option<Status>,
    /// The STATUS with its text and remedy, or the failure described.
    pub text: String,
}

impl LineFailure {
    /// A failure with the module's STATUS.
    pub fn of(status: Status) -> Self {
        LineFailure {
            kind: Kind::of(status),
            status: Some(status),
            text: status_text(status),
        }
    }
}

/// Why a job failed.
#[derive(Debug)]
pub enum JobError {
    /// On the line: counted, the poll goes on.
    Line(LineFailure),
    /// Refused before sending, or the connection is gone: repeating could only fail the same
    /// way, so the run ends.
    Fatal(CliError),
}

/// Where a poll's jobs go: the RTU master on a serial line or device server, or a Modbus TCP
/// client (`super::tcp`). One job at a time.
pub trait Line {
    /// Run one job and print its answer through `report`.
    async fn job(
        &mut self,
        unit: u8,
        request: &Request<'_>,
        report: &Report<'_>,
    ) -> Result<(), JobError>;
}

impl Line for Master {
    async fn job(
        &mut self,
        unit: u8,
        request: &Request<'_>,
        report: &Report<'_>,
    ) -> Result<(), JobError> {
        match self.request(unit, request).await {
            Ok(c) => {
                report.completion(&c);
                Ok(())
            }
            Err(ModbusError::Failed { status, .. }) => Err(JobError::Line(LineFailure::of(status))),
            Err(e) => Err(JobError::Fatal(failure(e))),
        }
    }
}

/// How a run ended, for the counters' line.
#[derive(Debug, Clone, Copy)]
enum End {
    Interrupted,
    Cycles,
    Fatal,
}

/// Run `request` on every unit once, or as a poll.
pub async fn run(
    line: &mut impl Line,
    units: &[u8],
    request: &Request<'_>,
    polling: &PollArgs,
    report: &Report<'_>,
) -> Result<(), CliError> {
    let interrupt = tokio::signal::ctrl_c();
    tokio::pin!(interrupt);
    let mut counters = vec![Counters::default(); units.len()];
    let one_job = polling.poll.is_none() && units.len() == 1;
    let function = request.function();
    let mut cycle: u64 = 0;
    loop {
        cycle += 1;
        for (i, &unit) in units.iter().enumerate() {
            let result = tokio::select! {
                r = line.job(unit, request, report) => r,
                Ok(()) = &mut interrupt => {
                    return interrupted(units, &counters, polling, report);
                }
            };
            match result {
                Ok(()) => counters[i].answered(),
                Err(JobError::Line(f)) if one_job => return Err(CliError::new(f.text)),
                Err(JobError::Line(f)) => {
                    counters[i].failed(f.kind);
                    report.failed(unit, function, f.kind.name(), f.status, &f.text);
                }
                Err(JobError::Fatal(e)) => {
                    summary(units, &counters, polling, report, End::Fatal);
                    return Err(e);
                }
            }
        }
        let Some(ms) = polling.poll else { break };
        if polling.cycles.is_some_and(|n| cycle >= n) {
            break;
        }
        tokio::select! {
            () = tokio::time::sleep(std::time::Duration::from_millis(ms)) => {}
            Ok(()) = &mut interrupt => return interrupted(units, &counters, polling, report),
        }
    }
    summary(units, &counters, polling, report, End::Cycles);
    let polls: u64 = counters.iter().map(|c| c.polls).sum();
    let failed = polls - counters.iter().map(|c| c.answers).sum::<u64>();
    if failed == 0 {
        return Ok(());
    }
    let what = if polling.poll.is_some() {
        "polls"
    } else {
        "units"
    };
    Err(CliError::new(format!("{failed} of {polls} {what} failed")))
}

/// The counters per unit, when polling.
fn summary(units: &[u8], counters: &[Counters], polling: &PollArgs, report: &Report<'_>, end: End) {
    if polling.poll.is_none() {
        return;
    }
    let end = match end {
        End::Interrupted => "interrupted",
        End::Cycles => "cycles",
        End::Fatal => "error",
    };
    for (c, &unit) in counters.iter().zip(units) {
        report.emit(
            &counters_text(c, unit),
            json!({"summary": {"unit": unit, "polls": c.polls, "answers": c.answers,
                               "exceptions": c.exceptions, "timeouts": c.timeouts,
                               "other_errors": c.other_errors},
                   "end": end}),
        );
    }
}

/// Ctrl-C: the counters, then [`CliError::interrupted`] (exit 130, crate::error), after stdout
/// has been written and flushed (crate::output flushes every line).
fn interrupted(
    units: &[u8],
    counters: &[Counters],
    polling: &PollArgs,
    report: &Report<'_>,
) -> Result<(), CliError> {
    summary(units, counters, polling, report, End::Interrupted);
    Err(CliError::interrupted())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failures_are_counted_by_their_status() {
        let mut c = Counters::default();
        c.failed(Kind::of(si_modbus::status::RESPONSE_TIMEOUT));
        c.failed(Kind::of(si_modbus::status::EXCEPTION_ILLEGAL_DATA_ADDRESS));
        c.failed(Kind::of(si_modbus::status::EXCEPTION_NEGATIVE_ACKNOWLEDGE));
        c.failed(Kind::of(si_modbus::status::RESPONSE_CRC));
        c.failed(Kind::of(si_modbus::status::WRONG_SLAVE_ADDRESS));
        c.answered();
        assert_eq!(
            c,
            Counters {
                polls: 6,
                answers: 1,
                exceptions: 2,
                timeouts: 1,
                other_errors: 2
            }
        );
        assert_eq!(
            counters_text(&c, 5),
            "--- unit 5: 6 polls, 1 answers, 2 exceptions, 1 timeouts, 2 other errors"
        );
    }
}
