//! Simulator scenarios: what a protocol command offers to `si sim`, and where a scenario's trace
//! goes (the screen, a trace file, an SVG diagram).
//!
//! A leaf below the commands: each protocol module lists its `SCENARIOS` with the types here and
//! prints through [`print_trace`]; `si sim` (`crate::cmd::sim`) collects the lists and runs one
//! with [`run`]. Neither imports the other's command module, so there is no circle.

use crate::cmd::monitor::MonitorArgs;
use crate::error::CliError;
use crate::line_names::Naming;
use crate::output::{write_stdout, Output};
use si_core::trace_names::named_trace;
use si_core::SerialSettings;
use si_sim::Trace;
use std::cell::{Cell, RefCell};
use std::path::PathBuf;

/// A named simulation.
pub struct Scenario {
    /// What the user types: `si sim <name>`.
    pub name: &'static str,
    /// One line for the list.
    pub about: &'static str,
    /// Run it and print its trace and result.
    pub run: fn(&SimOptions, &Output) -> Result<(), CliError>,
}

/// What every scenario gets from the command line.
#[derive(Debug, Clone, Copy)]
pub struct SimOptions {
    /// Seed of the fault generator.
    pub seed: u64,
    /// Character format of the simulated line.
    pub settings: SerialSettings,
}

/// Where the trace of the running scenario goes besides the screen.
pub struct Sink {
    /// The protocol named in the trace header (picks the monitor's decoder).
    pub protocol: Option<&'static str>,
    /// The simulated line's character format.
    pub settings: SerialSettings,
    /// `--record FILE`: the trace file to write.
    pub record: Option<PathBuf>,
    /// `--svg FILE`: the diagram to draw.
    pub svg: Option<PathBuf>,
}

/// The sink of the running scenario and whether its trace has been saved.
struct Active {
    sink: Sink,
    written: Result<bool, String>,
}

thread_local! {
    /// Set by [`run`] around one scenario; read by [`print_trace`].
    static SINK: RefCell<Option<Active>> = const { RefCell::new(None) };
    /// The running scenario's protocol, set by [`run`]: how [`print_trace`] names its control
    /// characters.
    static NAMING: Cell<Option<Naming>> = const { Cell::new(None) };
}

/// Run `scenario` (called `name`, speaking `protocol` on its line) with `options`, saving its
/// trace to `sink` if given.
pub fn run(
    scenario: &Scenario,
    (name, protocol): (&str, Option<&'static str>),
    options: &SimOptions,
    sink: Option<Sink>,
    out: &Output,
) -> Result<(), CliError> {
    NAMING.with(|n| n.set(protocol.and_then(Naming::for_protocol)));
    SINK.with(|s| {
        *s.borrow_mut() = sink.map(|sink| Active {
            sink,
            written: Ok(false),
        })
    });
    let result = (scenario.run)(options, out);
    let active = SINK.with(|s| s.borrow_mut().take());
    result?;
    match active.map(|a| a.written) {
        None | Some(Ok(true)) => Ok(()),
        Some(Ok(false)) => Err(CliError::new(format!(
            "scenario {name} printed no trace to record or draw"
        ))),
        Some(Err(e)) => Err(CliError::new(e)),
    }
}

/// Write the trace file and the diagram the running scenario asked for.
fn save(sink: &Sink, trace: &Trace) -> Result<(), String> {
    let stations = trace.stations();
    let mut header = si_core::tracefile::Header::new("sim")
        .settings(sink.settings)
        .stations(&stations);
    if let Some(p) = sink.protocol {
        header = header.protocol(p);
    }
    if let Some(path) = &sink.record {
        let file = std::fs::File::create(path)
            .map_err(|e| format!("cannot record to {}: {e}", path.display()))?;
        si_core::tracefile::write(std::io::BufWriter::new(file), &header, trace)
            .map_err(|e| format!("cannot record to {}: {e}", path.display()))?;
    }
    if let Some(path) = &sink.svg {
        let file = si_core::tracefile::TraceFile {
            header: Some(header),
            trace: trace.clone(),
        };
        let args = <MonitorArgs as clap::FromArgMatches>::from_arg_matches(
            &<MonitorArgs as clap::Args>::augment_args(clap::Command::new("m"))
                .get_matches_from(["m"]),
        )
        .map_err(|e| e.to_string())?;
        let analysis = args
            .analyse(&file, sink.settings)
            .map_err(|e| format!("{e:?}"))?;
        std::fs::write(path, si_core::diagram::render(&analysis))
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

/// Save a trace the running scenario does not print (it prints its own reading) when `si sim`
/// was asked to `--record` or draw (`--svg`) it; `protocol` goes into the trace header and
/// picks the monitor's decoder (`dp-coord`: DP windows, `si_dp_coord::monitor`).
pub fn record_trace(trace: &Trace, protocol: &'static str) {
    SINK.with(|s| {
        if let Some(sink) = s.borrow_mut().as_mut() {
            sink.sink.protocol = Some(protocol);
            sink.written = save(&sink.sink, trace).map(|()| true);
        }
    });
}

/// Print a trace: the human table, or one JSON object per entry. When `si sim` was asked to
/// `--record` or draw (`--svg`), the trace is saved here too.
pub fn print_trace(trace: &Trace, out: &Output) {
    SINK.with(|s| {
        if let Some(sink) = s.borrow_mut().as_mut() {
            sink.written = save(&sink.sink, trace).map(|()| true);
        }
    });
    if out.json {
        for entry in &trace.entries {
            write_stdout(format_args!(
                "{}\n",
                serde_json::to_string(entry).unwrap_or_default()
            ));
        }
    } else {
        match NAMING.with(Cell::get) {
            Some(naming) => write_stdout(format_args!(
                "{}",
                named_trace(trace, |b| naming.transmission(b))
            )),
            None => write_stdout(format_args!("{trace}")),
        }
    }
}
