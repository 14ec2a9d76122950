use super::*;
use crate::serial::Parity;

/// A probe engine: reports every character, line error, timeout and tx-done with its time, and
/// can be told to transmit or to set a timer.
#[derive(Default)]
struct Probe {
    outbox: VecDeque<Output<Seen>>,
    deadline: Option<Instant>,
}

#[derive(Debug, Clone, PartialEq)]
enum Seen {
    Byte(Instant, u8),
    Error(Instant, LineError),
    Timeout(Instant),
    TxDone(Instant),
    Signals(ModemSignals),
}

impl Probe {
    fn send(&mut self, bytes: &[u8]) {
        self.outbox
            .push_back(Output::Transmit(bytes::Bytes::copy_from_slice(bytes)));
    }
}

impl Engine for Probe {
    type Event = Seen;
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        for &b in bytes {
            self.outbox.push_back(Output::Event(Seen::Byte(now, b)));
        }
    }
    fn handle_timeout(&mut self, now: Instant) {
        if self.deadline.is_some_and(|d| now >= d) {
            self.deadline = None;
            self.outbox.push_back(Output::Event(Seen::Timeout(now)));
        }
    }
    fn handle_tx_done(&mut self, now: Instant) {
        self.outbox.push_back(Output::Event(Seen::TxDone(now)));
    }
    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.outbox
            .push_back(Output::Event(Seen::Error(now, error)));
    }
    fn handle_signals(&mut self, _: Instant, s: ModemSignals) {
        self.outbox.push_back(Output::Event(Seen::Signals(s)));
    }
    fn poll_output(&mut self) -> Output<Seen> {
        self.outbox
            .pop_front()
            .unwrap_or(Output::Wait(self.deadline))
    }
}

fn s8e1() -> SerialSettings {
    SerialSettings::new(9_600, 8, Parity::Even, 1).unwrap()
}

fn bytes_of(events: &[Seen]) -> Vec<(Instant, u8)> {
    events
        .iter()
        .filter_map(|e| match e {
            Seen::Byte(t, b) => Some((*t, *b)),
            _ => None,
        })
        .collect()
}

#[test]
fn ten_bytes_at_9600_8e1_arrive_at_k_times_11_over_9600() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    sim.run_until(Instant::from_micros(500));
    let t0 = sim.now();
    let payload: Vec<u8> = (0..10).collect();
    sim.with(a, |p, _| p.send(&payload));
    assert!(sim.run_until_quiet(Instant::from_micros(1_000_000)));

    let got = bytes_of(&sim.take_events(b));
    assert_eq!(got.len(), 10);
    for (k, (at, byte)) in got.iter().enumerate() {
        let k = k as u64 + 1;
        // k · 11 / 9600 s, in µs, rounded up once (never early, never drifting).
        let exact = (k * 11 * 1_000_000).div_ceil(9_600);
        assert_eq!(at.as_micros() - t0.as_micros(), exact, "byte {k}");
        assert_eq!(*byte, k as u8 - 1);
    }
    // The tenth ends at 11 458.33 µs: 11 459, where ten rounded char times would give 11 460.
    assert_eq!(got[9].0 - t0, Duration::from_micros(11_459));
    // The sender hears tx-done when the last character has left.
    assert_eq!(sim.take_events(a), vec![Seen::TxDone(got[9].0)]);
}

#[test]
fn back_to_back_transmits_continue_the_burst_without_a_gap() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    sim.with(a, |p, _| {
        p.send(&[1]);
        p.send(&[2, 3]);
    });
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let times: Vec<u64> = bytes_of(&sim.take_events(b))
        .iter()
        .map(|(t, _)| t.as_micros())
        .collect();
    assert_eq!(times, vec![1_146, 2_292, 3_438]);
}

#[test]
fn rs485_collision_garbles_both_and_every_sender_hears_it() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    let c = sim.add_station("C", s8e1(), Probe::default());
    sim.bus(&[a.index(), b.index(), c.index()]);

    // A alone: everybody, A included (echo), receives the character intact.
    sim.with(a, |p, _| p.send(&[0x41]));
    sim.run_until_quiet(Instant::from_micros(100_000));
    for id in [a, b, c] {
        let got = bytes_of(&sim.take_events(id));
        assert_eq!(got, vec![(Instant::from_micros(1_146), 0x41)]);
    }

    // A and B start half a character apart: their characters overlap and are garbled for all.
    sim.with(a, |p, _| p.send(&[0x41]));
    sim.run_for(Duration::from_micros(500));
    sim.with(b, |p, _| p.send(&[0x42]));
    sim.run_until_quiet(Instant::from_micros(200_000));
    for id in [a, b, c] {
        let events = sim.take_events(id);
        let errors = events
            .iter()
            .filter(|e| matches!(e, Seen::Error(_, LineError::Framing)))
            .count();
        assert_eq!(errors, 2, "{events:?}");
        assert!(bytes_of(&events).is_empty(), "{events:?}");
    }
}

fn noisy_run(seed: u64) -> Trace {
    let mut sim = Simulator::new(seed);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    let faults = Faults {
        bit_flip: 0.1,
        drop: 0.1,
        insert: 0.1,
        extra_latency: Duration::from_micros(50),
    };
    sim.set_faults(b, faults);
    sim.set_faults(a, faults);
    let payload: Vec<u8> = (0..=255).collect();
    sim.with(a, |p, _| p.send(&payload));
    sim.with(b, |p, _| p.send(&payload));
    sim.run_until_quiet(Instant::from_micros(10_000_000));
    sim.trace().clone()
}

#[test]
fn faults_are_reproducible_from_the_seed() {
    let first = noisy_run(1234);
    assert_eq!(first, noisy_run(1234));
    assert_ne!(first, noisy_run(1235));
    // The faults really happened: B did not receive the payload as sent.
    let received: Vec<u8> = first.received("B").iter().map(|(_, b)| *b).collect();
    assert_ne!(received, (0..=255).collect::<Vec<u8>>());
    // Extra latency: the first character arrives 50 µs late (unless it was dropped).
    assert!(first.received("B")[0].0 >= Instant::from_micros(1_196));
}

#[test]
fn timers_fire_at_their_deadline_and_stale_ones_are_ignored() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    sim.with(a, |p, now| {
        p.deadline = Some(now + Duration::from_millis(220))
    });
    // Re-arming moves the deadline; the earlier schedule must not fire.
    sim.with(a, |p, now| {
        p.deadline = Some(now + Duration::from_millis(400))
    });
    sim.run_until_quiet(Instant::from_micros(10_000_000));
    assert_eq!(
        sim.take_events(a),
        vec![Seen::Timeout(Instant::from_micros(400_000))]
    );
}

#[test]
fn scripted_corruption_hits_exactly_the_nth_character() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    sim.corrupt_received(b, 2, 0x01);
    sim.with(a, |p, _| p.send(&[0x10, 0x20, 0x30, 0x40]));
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let got: Vec<u8> = bytes_of(&sim.take_events(b))
        .iter()
        .map(|(_, b)| *b)
        .collect();
    assert_eq!(got, vec![0x10, 0x20, 0x31, 0x40]);
}

#[test]
fn silence_break_and_format_mismatch() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    sim.silence(a, Instant::from_micros(10));
    sim.schedule_break(b, Instant::from_micros(5_000));
    sim.run_until(Instant::from_micros(10));
    sim.with(a, |p, _| p.send(&[1, 2, 3]));
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    assert_eq!(
        sim.take_events(b),
        vec![Seen::Error(Instant::from_micros(5_000), LineError::Break)]
    );

    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let other = SerialSettings::new(19_200, 8, Parity::Even, 1).unwrap();
    let b = sim.add_station("B", other, Probe::default());
    sim.connect(a, b);
    sim.with(a, |p, _| p.send(&[0x55]));
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    assert!(matches!(
        sim.take_events(b)[..],
        [Seen::Error(_, LineError::Framing)]
    ));
}

#[test]
fn null_modem_crosses_rts_to_cts_and_dtr_to_dsr() {
    #[derive(Default)]
    struct RtsRaiser(bool);
    impl Engine for RtsRaiser {
        type Event = ();
        fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
        fn handle_timeout(&mut self, _: Instant) {}
        fn poll_output(&mut self) -> Output<()> {
            if std::mem::take(&mut self.0) {
                Output::SetSignals(SignalUpdate {
                    rts: Some(true),
                    dtr: Some(true),
                })
            } else {
                Output::Wait(None)
            }
        }
    }
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), RtsRaiser(false));
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    sim.with(a, |e, _| e.0 = true);
    let want = ModemSignals {
        cts: true,
        dsr: true,
        dcd: true,
        ..ModemSignals::default()
    };
    assert_eq!(sim.take_events(b), vec![Seen::Signals(want)]);
}
