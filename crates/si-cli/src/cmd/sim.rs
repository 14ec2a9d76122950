//! `si sim <scenario>`: stations on the deterministic line simulator, with the line trace.
//!
//! Each protocol module lists its scenarios in `SCENARIOS`; this module adds the ones that show
//! the simulator itself (character timing, an RS-485 collision) and prints the trace.
//!
//! `--record FILE` (the global option) writes the trace a scenario prints as a trace file
//! (`si_core::tracefile`, with the protocol and settings in its header) for `si monitor
//! --trace`; `--svg FILE` decodes it with the monitor and draws the sequence diagram. Both
//! hook into [`print_trace`], which every scenario calls once with its trace, or
//! [`record_trace`] for a scenario that prints its own reading (`dp-coord-send`'s windows).

use crate::cmd::{ascii, dpcoord, modbus, r3964, rk512, uss};
use crate::{CliError, Output};
use clap::Args;
use si_core::sim::{Simulator, Trace};
use si_core::{Engine, Instant, LineError, Output as EngineOutput, SerialSettings};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};

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

/// `si sim`.
#[derive(Debug, Args)]
pub struct SimArgs {
    /// The scenario to run; without one, the list of scenarios.
    scenario: Option<String>,
    /// Seed for the simulator's faults: the same seed gives the same run.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Draw the scenario as an SVG sequence diagram (decoded like `si monitor`).
    #[arg(long, value_name = "FILE")]
    svg: Option<PathBuf>,
}

/// Where the trace of the running scenario goes besides the screen.
struct Sink {
    protocol: Option<&'static str>,
    settings: SerialSettings,
    record: Option<PathBuf>,
    svg: Option<PathBuf>,
    written: Result<bool, String>,
}

thread_local! {
    /// Set by [`SimArgs::run`] around one scenario; read by [`print_trace`].
    static SINK: RefCell<Option<Sink>> = const { RefCell::new(None) };
}

/// The protocol a scenario's trace speaks, from the list it comes from.
fn protocol_of(name: &str) -> Option<&'static str> {
    let lists: [(&[Scenario], &'static str); 6] = [
        (r3964::SCENARIOS, "3964r"),
        (rk512::SCENARIOS, "rk512"),
        (ascii::SCENARIOS, "ascii"),
        (modbus::SCENARIOS, "modbus"),
        (uss::SCENARIOS, "uss"),
        // The line of `dp-coord-e2e` is 3964(R); `dp-coord-send` has no line and records its
        // windows as protocol `dp-coord` ([`record_trace`]).
        (dpcoord::SCENARIOS, "3964r"),
    ];
    lists
        .iter()
        .find(|(list, _)| list.iter().any(|s| s.name == name))
        .map(|(_, p)| *p)
}

/// The simulator's own scenarios.
const CORE: &[Scenario] = &[
    Scenario {
        name: "line-timing",
        about: "10 bytes back to back: each arrives exactly one character time after the last",
        run: line_timing,
    },
    Scenario {
        name: "rs485-collision",
        about: "two stations transmit at once on an RS-485 bus; everyone hears framing errors",
        run: rs485_collision,
    },
];

fn all() -> impl Iterator<Item = &'static Scenario> {
    CORE.iter()
        .chain(r3964::SCENARIOS)
        .chain(rk512::SCENARIOS)
        .chain(ascii::SCENARIOS)
        .chain(modbus::SCENARIOS)
        .chain(uss::SCENARIOS)
        .chain(dpcoord::SCENARIOS)
}

impl SimArgs {
    /// Run the named scenario (recording its trace to `record` and drawing it to `--svg`), or
    /// list them.
    pub fn run(
        &self,
        settings: SerialSettings,
        record: Option<&Path>,
        out: &Output,
    ) -> Result<(), CliError> {
        let Some(name) = &self.scenario else {
            for s in all() {
                out.line(
                    &format!("{:<22} {}", s.name, s.about),
                    serde_json::json!({"scenario": s.name, "about": s.about}),
                );
            }
            return Ok(());
        };
        let scenario = all().find(|s| s.name == name).ok_or_else(|| {
            let names: Vec<_> = all().map(|s| s.name).collect();
            CliError::new(format!(
                "unknown scenario {name:?}; choose one of: {}",
                names.join(", ")
            ))
        })?;
        let options = SimOptions {
            seed: self.seed,
            settings,
        };
        let wanted = record.is_some() || self.svg.is_some();
        SINK.with(|s| {
            *s.borrow_mut() = wanted.then(|| Sink {
                protocol: protocol_of(name),
                settings,
                record: record.map(Path::to_path_buf),
                svg: self.svg.clone(),
                written: Ok(false),
            })
        });
        let result = (scenario.run)(&options, out);
        let sink = SINK.with(|s| s.borrow_mut().take());
        result?;
        match sink.map(|s| s.written) {
            None | Some(Ok(true)) => Ok(()),
            Some(Ok(false)) => Err(CliError::new(format!(
                "scenario {name} printed no trace to record or draw"
            ))),
            Some(Err(e)) => Err(CliError::new(e)),
        }
    }
}

/// Write the trace file and the diagram the running scenario asked for.
fn save(sink: &Sink, trace: &Trace) -> Result<(), String> {
    let stations: Vec<String> = {
        let mut names: Vec<String> = Vec::new();
        for e in &trace.entries {
            if !names.contains(&e.station) {
                names.push(e.station.clone());
            }
        }
        names
    };
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
        let args = <crate::cmd::monitor::MonitorArgs as clap::FromArgMatches>::from_arg_matches(
            &<crate::cmd::monitor::MonitorArgs as clap::Args>::augment_args(clap::Command::new(
                "m",
            ))
            .get_matches_from(["m"]),
        )
        .map_err(|e| e.to_string())?;
        let analysis = args
            .analyse(&file, sink.settings)
            .map_err(|e| format!("{e:?}"))?;
        std::fs::write(path, crate::svg::render(&analysis))
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
            sink.protocol = Some(protocol);
            sink.written = save(sink, trace).map(|()| true);
        }
    });
}

/// Print a trace: the human table, or one JSON object per entry. When `si sim` was asked to
/// `--record` or draw (`--svg`), the trace is saved here too.
pub fn print_trace(trace: &Trace, out: &Output) {
    SINK.with(|s| {
        if let Some(sink) = s.borrow_mut().as_mut() {
            sink.written = save(sink, trace).map(|()| true);
        }
    });
    if out.json {
        for entry in &trace.entries {
            crate::write_stdout(format_args!(
                "{}\n",
                serde_json::to_string(entry).unwrap_or_default()
            ));
        }
    } else {
        crate::write_stdout(format_args!("{trace}"));
    }
}

/// A raw terminal: transmits what it is told, reports every character and line error.
#[derive(Default)]
struct Terminal {
    events: VecDeque<Result<u8, LineError>>,
}

impl Engine for Terminal {
    type Event = Result<u8, LineError>;
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        self.events.extend(bytes.iter().map(|&b| Ok(b)));
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn handle_line_error(&mut self, _: Instant, error: LineError) {
        self.events.push_back(Err(error));
    }
    fn poll_output(&mut self) -> EngineOutput<Self::Event> {
        match self.events.pop_front() {
            Some(e) => EngineOutput::Event(e),
            None => EngineOutput::Wait(None),
        }
    }
}

fn line_timing(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let mut sim = Simulator::new(o.seed);
    let a = sim.add_station("A", o.settings, Terminal::default());
    let b = sim.add_station("B", o.settings, Terminal::default());
    sim.connect(a, b);
    sim.transmit(a, b"0123456789");
    sim.run_until_quiet(Instant::from_micros(60_000_000));
    print_trace(sim.trace(), out);
    let last = sim.trace().received("B").last().map(|r| r.0);
    out.line(
        &format!(
            "{}: character time {}, 10 characters in {}",
            o.settings,
            o.settings.char_time(),
            o.settings.chars_time(10)
        ),
        serde_json::json!({"settings": o.settings.to_string(),
            "char_time_us": o.settings.char_time().as_micros(),
            "last_arrival_us": last.map(Instant::as_micros)}),
    );
    Ok(())
}

fn rs485_collision(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let mut sim = Simulator::new(o.seed);
    let a = sim.add_station("A", o.settings, Terminal::default());
    let b = sim.add_station("B", o.settings, Terminal::default());
    let c = sim.add_station("C", o.settings, Terminal::default());
    sim.bus(&[a.index(), b.index(), c.index()]);
    sim.transmit(a, &[0x11, 0x22]);
    sim.transmit(b, &[0x33, 0x44]);
    sim.run_until_quiet(Instant::from_micros(60_000_000));
    print_trace(sim.trace(), out);
    let heard = sim.take_events(c);
    let garbled = heard.iter().filter(|e| e.is_err()).count();
    let clean = heard.len() - garbled;
    out.line(
        &format!("listener C: {garbled} garbled characters, {clean} clean ones"),
        serde_json::json!({"garbled_at_c": garbled, "clean_at_c": clean}),
    );
    Ok(())
}
