//! Shared pieces of the scenario tests: a scripted partner and small helpers.
#![allow(dead_code)]

use si_ascii::{Config, Event, Link};
use si_core::{
    Engine, Instant, LineError, ModemSignals, Output, Parity, SerialSettings, SignalUpdate,
};
use si_sim::{Simulator, StationId};
use std::collections::VecDeque;

/// A partner that only does what the test scripts: transmits through `Simulator::transmit`,
/// records what it receives, and drives its modem outputs on command. With `answer_rts` it
/// behaves like a modem: CTS (its RTS) follows the link's RTS at once.
#[derive(Default)]
pub struct Partner {
    pub received: Vec<(Instant, Result<u8, LineError>)>,
    pub signals: ModemSignals,
    pub answer_rts: bool,
    out: VecDeque<Output<()>>,
}

impl Partner {
    pub fn modem() -> Self {
        Partner {
            answer_rts: true,
            ..Partner::default()
        }
    }

    pub fn set(&mut self, update: SignalUpdate) {
        self.out.push_back(Output::SetSignals(update));
    }

    pub fn bytes(&self) -> Vec<u8> {
        self.received.iter().filter_map(|(_, b)| b.ok()).collect()
    }
}

impl Engine for Partner {
    type Event = ();
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.received.extend(bytes.iter().map(|&b| (now, Ok(b))));
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn handle_line_error(&mut self, now: Instant, e: LineError) {
        self.received.push((now, Err(e)));
    }
    fn handle_signals(&mut self, _: Instant, s: ModemSignals) {
        self.signals = s;
        if self.answer_rts {
            self.out.push_back(Output::SetSignals(SignalUpdate {
                rts: Some(s.cts),
                dtr: None,
            }));
        }
    }
    fn poll_output(&mut self) -> Output<()> {
        self.out.pop_front().unwrap_or(Output::Wait(None))
    }
}

pub fn settings(baud: u32) -> SerialSettings {
    SerialSettings::new(baud, 8, Parity::Even, 1).unwrap()
}

/// A link under test ("M", the module) wired to a scripted partner ("P").
pub struct Bench {
    pub sim: Simulator,
    pub link: StationId<Link>,
    pub partner: StationId<Partner>,
    pub config: Config,
}

impl Bench {
    pub fn new(config: Config) -> Self {
        Self::with_partner(config, Partner::default())
    }

    pub fn with_partner(config: Config, partner: Partner) -> Self {
        let mut sim = Simulator::new(7);
        let link = sim.add_station("M", config.settings, Link::new(config).unwrap());
        let partner = sim.add_station("P", config.settings, partner);
        sim.connect(link, partner);
        // Announce the flow-control mode now that the cable is plugged in.
        sim.with(link, |l, now| l.restart(now));
        Bench {
            sim,
            link,
            partner,
            config,
        }
    }

    /// The partner puts `bytes` on the line now (back to back).
    pub fn partner_sends(&mut self, bytes: &[u8]) {
        self.sim.transmit(self.partner, bytes);
    }

    pub fn run_for_ms(&mut self, ms: u64) {
        self.sim.run_for(si_core::Duration::from_millis(ms));
    }

    pub fn events(&mut self) -> Vec<Event> {
        self.sim.take_events(self.link)
    }

    pub fn frames(&mut self) -> Vec<Vec<u8>> {
        let mut v = Vec::new();
        while let Some(f) = self.sim.with(self.link, |l, now| l.read_frame_vec(now)) {
            v.push(f);
        }
        v
    }

    /// Arrival time of the partner's bytes at the module, in order.
    pub fn arrivals(&self) -> Vec<Instant> {
        self.sim.trace().received("M").iter().map(|r| r.0).collect()
    }
}

pub fn received(events: &[Event]) -> Vec<(usize, Instant)> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Received { len, at } => Some((*len, *at)),
            _ => None,
        })
        .collect()
}

pub fn errors(events: &[Event]) -> Vec<(u16, Instant)> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::ReceiveError { status, at } => Some((status.code(), *at)),
            _ => None,
        })
        .collect()
}
