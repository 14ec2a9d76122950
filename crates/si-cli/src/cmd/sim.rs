//! `si sim <scenario>`: stations on the deterministic line simulator, with the line trace.
//!
//! Each protocol module lists its scenarios in `SCENARIOS`; this module adds the ones that show
//! the simulator itself (character timing, an RS-485 collision) and prints the trace.
//!
//! `--record FILE` (the global option) writes the trace a scenario prints as a trace file
//! (`si_core::tracefile`, with the protocol and settings in its header) for `si monitor
//! --trace`; `--svg FILE` decodes it with the monitor and draws the sequence diagram. Both
//! hook into `crate::scenario::print_trace`, which every scenario calls once with its trace, or
//! `record_trace` for a scenario that prints its own reading (`dp-coord-send`'s windows).

use crate::cmd::{ascii, dpcoord, modbus, r3964, rk512, uss};
use crate::error::CliError;
use crate::output::Output;
use crate::scenario::{self, print_trace, Scenario, SimOptions, Sink};
use clap::Args;
use si_core::{Instant, SerialSettings};
use si_sim::{Simulator, Terminal};
use std::path::{Path, PathBuf};

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
        let protocol = protocol_of(name);
        let sink = (record.is_some() || self.svg.is_some()).then(|| Sink {
            protocol,
            settings,
            record: record.map(Path::to_path_buf),
            svg: self.svg.clone(),
        });
        scenario::run(scenario, (name, protocol), &options, sink, out)
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
