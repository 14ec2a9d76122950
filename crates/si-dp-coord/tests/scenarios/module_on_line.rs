//! The module as a station on the line simulator (si_sim), its serial side a line engine
//! behind [`EngineSerial`]: a host's send job puts the frame on the line with baud-accurate
//! timing, and the end-of-job acknowledgement comes only after the last character has left
//! ([ET200S SI 2005] §2.12.1–§2.12.7 `[derived]`: "the module sends the end-of-job ack only after
//! the frame has been transmitted to the partner"). A frame from the partner reaches the host
//! through a receive job.
//!
//! The line engine here is a minimal framer written for this test (frames end after a 4 ms gap,
//! like the ASCII driver's character delay time): any engine plugs in through its [`LineHooks`].
//! The real 3964(R) and ASCII engines do so in `si_dp_coord::engines`, and `end_to_end.rs` runs
//! them between two modules.

use bytes::{Bytes, BytesMut};
use si_core::{Duration, Engine, Instant, Output, SerialSettings, Status};
use si_dp_coord::host::{Host, HostEvent, Job, Outcome};
use si_dp_coord::line::{EngineSerial, LineHooks};
use si_dp_coord::module::{Module, SerialEvent};
use si_dp_coord::{HostConfig, ModuleConfig, WindowSize};
use si_sim::Simulator;
use std::collections::VecDeque;

#[derive(Debug, Clone, PartialEq, Eq)]
enum FramerEvent {
    Frame(Bytes),
    Sent,
}

/// Frames end after 4 ms of silence; a send is done when the transmitter reports it.
#[derive(Debug, Default)]
struct GapFramer {
    rx: BytesMut,
    deadline: Option<Instant>,
    out: VecDeque<Output<FramerEvent>>,
    sending: bool,
    /// What the driver declared with `set_rx_latency`.
    latency: Option<Duration>,
}

const GAP: Duration = Duration::from_millis(4);

impl GapFramer {
    fn send(&mut self, _now: Instant, frame: &[u8]) -> Result<(), Status> {
        if self.sending {
            return Err(Status::from_code(0x0502));
        }
        self.sending = true;
        self.out
            .push_back(Output::Transmit(Bytes::copy_from_slice(frame)));
        Ok(())
    }
}

impl Engine for GapFramer {
    type Event = FramerEvent;
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.rx.extend_from_slice(bytes);
        self.deadline = Some(now + GAP);
    }
    fn set_rx_latency(&mut self, latency: Duration) {
        self.latency = Some(latency);
    }
    fn handle_timeout(&mut self, now: Instant) {
        if self.deadline.is_some_and(|d| now >= d) {
            self.deadline = None;
            let frame = self.rx.split().freeze();
            self.out.push_back(Output::Event(FramerEvent::Frame(frame)));
        }
    }
    fn handle_tx_done(&mut self, _now: Instant) {
        if self.sending {
            self.sending = false;
            self.out.push_back(Output::Event(FramerEvent::Sent));
        }
    }
    fn poll_output(&mut self) -> Output<FramerEvent> {
        self.out.pop_front().unwrap_or(Output::Wait(self.deadline))
    }
}

const HOOKS: LineHooks<GapFramer> = LineHooks {
    send: GapFramer::send,
    classify: |e| match e {
        FramerEvent::Frame(f) => Some(SerialEvent::Received(f.clone()).into()),
        FramerEvent::Sent => Some(SerialEvent::SendDone(Ok(())).into()),
    },
    take_frame: None,
    set_signals: None,
    set_flow_control: None,
};

#[test]
fn module_station_sends_on_the_line_and_delivers_received_frames() {
    let settings = SerialSettings::default(); // 9600 8E1: 1.146 ms a character
    let mut sim = Simulator::new(7);
    let module = Module::new(
        ModuleConfig::new(WindowSize::Eight),
        EngineSerial::new(GapFramer::default(), HOOKS),
    )
    .unwrap();
    let m = sim.add_station("module", settings, module);
    let p = sim.add_station("partner", settings, GapFramer::default());
    sim.connect(m, p);

    let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    let text = Bytes::from_static(b"abcdefghijklmnopqrstuv");
    let send = host.submit(Job::Send(text.clone())).unwrap();

    // DP cycle 2 ms: the host and the module exchange windows every cycle.
    let mut events = Vec::new();
    let mut input = sim.engine(m).input().to_vec();
    let mut sent_at = None;
    for _ in 0..200 {
        let out = host.cycle(sim.now(), &input).to_vec();
        input = sim.with(m, |module, now| module.cycle(now, &out).to_vec());
        events.extend(std::iter::from_fn(|| host.poll_event()));
        if sent_at.is_none()
            && events
                .iter()
                .any(|e| matches!(e, HostEvent::Completed { id, .. } if *id == send))
        {
            sent_at = Some(sim.now());
        }
        sim.run_for(Duration::from_millis(2));
    }
    assert!(matches!(
        events.as_slice(),
        [HostEvent::Completed { id, result: Ok(Outcome::Sent), .. }] if *id == send
    ));
    // The partner got the 22 characters; the host heard "done" only after the last one left.
    assert_eq!(sim.take_events(p), [FramerEvent::Frame(text.clone())]);
    let last_char = sim.trace().received("partner").last().unwrap().0;
    assert!(sent_at.unwrap() >= last_char, "{:?} < {last_char}", sent_at);
    // 22 characters × 11 bits at 9600 bit/s = 25.2 ms on the line.
    assert!(last_char.as_micros() >= 25_208);

    // The partner answers; the module buffers the frame and the host fetches it.
    sim.with(p, |partner, now| partner.send(now, b"reply").unwrap());
    sim.run_for(Duration::from_millis(20));
    let recv = host.submit(Job::Receive).unwrap();
    for _ in 0..50 {
        let out = host.cycle(sim.now(), &input).to_vec();
        input = sim.with(m, |module, now| module.cycle(now, &out).to_vec());
        sim.run_for(Duration::from_millis(2));
    }
    let done: Vec<_> = std::iter::from_fn(|| host.poll_event()).collect();
    assert_eq!(
        done,
        [HostEvent::Completed {
            id: recv,
            code: si_dp_coord::JobCode::Receive,
            result: Ok(Outcome::Received(Bytes::from_static(b"reply")))
        }]
    );
}

#[test]
fn write_v24_reaches_the_line_as_signal_change() {
    let mut sim = Simulator::new(8);
    let module = Module::new(
        ModuleConfig::new(WindowSize::Four),
        EngineSerial::new(GapFramer::default(), HOOKS),
    )
    .unwrap();
    let settings = SerialSettings::default();
    let m = sim.add_station("module", settings, module);
    let p = sim.add_station("partner", settings, GapFramer::default());
    sim.connect(m, p);
    let mut host = Host::new(HostConfig::new(WindowSize::Four)).unwrap();
    host.submit(Job::WriteV24 {
        rts: true,
        dtr: true,
    })
    .unwrap();
    host.submit(Job::ReadV24).unwrap();
    let mut input = sim.engine(m).input().to_vec();
    for _ in 0..30 {
        let out = host.cycle(sim.now(), &input).to_vec();
        input = sim.with(m, |module, now| module.cycle(now, &out).to_vec());
        sim.run_for(Duration::from_millis(2));
    }
    let done: Vec<_> = std::iter::from_fn(|| host.poll_event()).collect();
    assert_eq!(done.len(), 2);
    let HostEvent::Completed {
        result: Ok(Outcome::Signals(s)),
        ..
    } = &done[1]
    else {
        panic!("{done:?}")
    };
    assert!(s.rts && s.dtr);
    // Null-modem wiring: the module's RTS is the partner's CTS, its DTR the partner's DSR/DCD,
    // and the partner's outputs (off) are the module's inputs.
    assert!(!s.cts && !s.dsr);
}

/// The module as a line station hands the port's latency (here a USB adapter's,
/// announced by the simulator) to its line engine, whose timers judge the line's silences.
#[test]
fn the_module_forwards_the_ports_latency_to_its_line_engine() {
    let mut sim = Simulator::new(16);
    let module = Module::new(
        ModuleConfig::new(WindowSize::Eight),
        EngineSerial::new(GapFramer::default(), HOOKS),
    )
    .unwrap();
    let m = sim.add_station("module", SerialSettings::default(), module);
    assert_eq!(sim.engine(m).serial().engine().latency, None);
    sim.set_adapter(m, si_sim::UsbAdapter::FTDI_DEFAULT)
        .unwrap();
    assert_eq!(
        sim.engine(m).serial().engine().latency,
        Some(Duration::from_millis(16))
    );
}
