//! `si sim <scenario>`: stations on the deterministic line simulator, with the line trace.
//!
//! Each protocol module lists its scenarios in `SCENARIOS`; this module adds the ones that show
//! the simulator itself (character timing, an RS-485 collision) and prints the trace.

use crate::cmd::{ascii, dpcoord, modbus, r3964, rk512, uss};
use crate::{CliError, Output};
use clap::Args;
use si_core::sim::{Simulator, Trace};
use si_core::{Engine, Instant, LineError, Output as EngineOutput, SerialSettings};
use std::collections::VecDeque;

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
    /// Run the named scenario, or list them.
    pub fn run(&self, settings: SerialSettings, out: &Output) -> Result<(), CliError> {
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
        (scenario.run)(&options, out)
    }
}

/// Print a trace: the human table, or one JSON object per entry.
pub fn print_trace(trace: &Trace, out: &Output) {
    if out.json {
        for entry in &trace.entries {
            println!("{}", serde_json::to_string(entry).unwrap_or_default());
        }
    } else {
        print!("{trace}");
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
