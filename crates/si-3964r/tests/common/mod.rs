//! Shared helpers of the scenario tests: stations, a scripted partner, trace queries.
#![allow(dead_code)]

use si_3964r::{Config, Link, Priority};
use si_core::{Duration, Engine, Instant, LineError, Output, SerialSettings};
use si_sim::{Simulator, StationId, TraceKind};

/// 9600 8E1, the manuals' default line: one character is 1146 µs.
pub fn line() -> SerialSettings {
    SerialSettings::default()
}

/// The defaults with the given priority.
pub fn with_priority(priority: Priority) -> Config {
    Config {
        priority,
        ..Config::default()
    }
}

/// Two links "A" and "B" on a point-to-point line.
pub fn pair(a: Config, b: Config) -> (Simulator, StationId<Link>, StationId<Link>) {
    let mut sim = Simulator::new(3964);
    let sa = sim.add_station("A", line(), Link::new(a.with_settings(line())).unwrap());
    let sb = sim.add_station("B", line(), Link::new(b.with_settings(line())).unwrap());
    sim.connect(sa, sb);
    (sim, sa, sb)
}

/// A scripted partner: records what it receives; the test makes it transmit with
/// `Simulator::transmit`.
#[derive(Default)]
pub struct Partner;

impl Engine for Partner {
    type Event = Result<u8, LineError>;
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
    fn handle_timeout(&mut self, _: Instant) {}
    fn poll_output(&mut self) -> Output<Self::Event> {
        Output::Wait(None)
    }
}

/// Link "A" (with `config`) facing the scripted partner "P".
pub fn scripted(config: Config) -> (Simulator, StationId<Link>, StationId<Partner>) {
    scripted_on(line(), config)
}

/// [`scripted`] on a line with `settings`.
pub fn scripted_on(
    settings: SerialSettings,
    config: Config,
) -> (Simulator, StationId<Link>, StationId<Partner>) {
    let mut sim = Simulator::new(3964);
    let a = sim.add_station(
        "A",
        settings,
        Link::new(config.with_settings(settings)).unwrap(),
    );
    let p = sim.add_station("P", settings, Partner);
    sim.connect(a, p);
    (sim, a, p)
}

/// Every byte a station put on the line, with the instant its transmission was queued.
pub fn sent(sim: &Simulator, station: &str) -> Vec<(Instant, u8)> {
    sim.trace()
        .of(station)
        .filter_map(|e| match &e.kind {
            TraceKind::Tx { bytes } => Some(bytes.iter().map(move |&b| (e.at, b))),
            _ => None,
        })
        .flatten()
        .collect()
}

/// Only the bytes a station sent.
pub fn sent_bytes(sim: &Simulator, station: &str) -> Vec<u8> {
    sent(sim, station).into_iter().map(|(_, b)| b).collect()
}

/// How often `byte` was sent as the first byte of a transmission (STX, NAK, DLE answers).
pub fn count_tx(sim: &Simulator, station: &str, byte: u8) -> usize {
    sim.trace()
        .of(station)
        .filter(|e| matches!(&e.kind, TraceKind::Tx { bytes } if bytes.first() == Some(&byte)))
        .count()
}

/// Instants at which `station` started a transmission beginning with `byte`.
pub fn tx_times(sim: &Simulator, station: &str, byte: u8) -> Vec<Instant> {
    sim.trace()
        .of(station)
        .filter(|e| matches!(&e.kind, TraceKind::Tx { bytes } if bytes.first() == Some(&byte)))
        .map(|e| e.at)
        .collect()
}

/// Run until quiet, at most a minute of virtual time.
pub fn settle(sim: &mut Simulator) {
    let limit = sim.now() + Duration::from_secs(60);
    assert!(sim.run_until_quiet(limit), "the simulation did not settle");
}

/// Run `ms` milliseconds of virtual time.
pub fn run_ms(sim: &mut Simulator, ms: u64) {
    sim.run_for(Duration::from_millis(ms));
}
