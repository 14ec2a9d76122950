use super::*;
use si_core::Parity;

/// A probe engine: reports every character, line error, timeout and tx-done with its time, and
/// can be told to transmit or to set a timer.
#[derive(Default)]
struct Probe {
    outbox: VecDeque<Output<Seen>>,
    deadline: Option<Instant>,
    /// Re-arm the timer this long after every received character (like a character delay
    /// monitor).
    rearm: Option<Duration>,
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
        if let Some(delay) = self.rearm {
            self.deadline = Some(now + delay);
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

/// FNV-1a of the trace's text: a fingerprint of every time, byte and error of a run.
fn fingerprint(trace: &Trace) -> u64 {
    trace
        .to_string()
        .bytes()
        .fold(0xcbf2_9ce4_8422_2325, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3)
        })
}

/// Three stations on a bus with every kind of seeded fault, transmitting over each other, and
/// a receiver that re-arms its timer at every character.
fn noisy_bus_run(seed: u64) -> Trace {
    let mut sim = Simulator::new(seed);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    let c = sim.add_station("C", s8e1(), Probe::default());
    sim.bus(&[a.index(), b.index(), c.index()]);
    let faults = Faults {
        bit_flip: 0.05,
        drop: 0.05,
        insert: 0.05,
        extra_latency: Duration::from_micros(30),
    };
    sim.set_faults(b, faults);
    sim.with(b, |p, _| p.rearm = Some(Duration::from_micros(2_500)));
    sim.set_faults(
        c,
        Faults {
            drop: 0.2,
            ..Faults::default()
        },
    );
    sim.corrupt_received(c, 5, 0x80);
    let payload: Vec<u8> = (0..64).collect();
    for round in 0..4u64 {
        sim.with(a, |p, _| p.send(&payload));
        sim.run_for(Duration::from_micros(3_000 + 7_000 * round));
        sim.with(b, |p, now| {
            p.send(&payload[..16]);
            p.deadline = Some(now + Duration::from_micros(1_146 * 3));
        });
        sim.run_for(Duration::from_micros(20_000));
        sim.with(c, |p, _| p.send(&[0xAA, 0x55]));
        sim.run_until_quiet(sim.now() + Duration::from_secs(1));
    }
    sim.trace().clone()
}

#[test]
fn seeded_runs_match_the_per_character_simulator() {
    // Fingerprints taken with the simulator that queued every character of every receiver on
    // its own (before bursts and lazy timers): same seed, same faults, same times, same order.
    assert_eq!(fingerprint(&noisy_run(1234)), GOLDEN_P2P, "point to point");
    assert_eq!(fingerprint(&noisy_bus_run(99)), GOLDEN_BUS, "bus");
}

const GOLDEN_P2P: u64 = 0xe0a1_51bd_0136_6c31;
const GOLDEN_BUS: u64 = 0xfa06_62cc_ad4b_9513;

#[test]
fn a_timer_re_armed_at_every_character_fires_once_after_the_last() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    let delay = Duration::from_micros(2 * 1_146);
    sim.with(b, |p, _| p.rearm = Some(delay));
    sim.with(a, |p, _| p.send(&[0x42; 200]));
    let mut most_queued = 0;
    while sim.step() {
        most_queued = most_queued.max(sim.queue.len() + usize::from(sim.hot.is_some()));
    }
    // One entry for the burst's receiver, one for A's tx-done, one for B's timer: not one per
    // character, not one per re-arm.
    assert!(most_queued <= 3, "{most_queued} queue entries");
    let events = sim.take_events(b);
    let last = bytes_of(&events).last().unwrap().0;
    let timeouts: Vec<&Seen> = events
        .iter()
        .filter(|e| matches!(e, Seen::Timeout(_)))
        .collect();
    assert_eq!(timeouts, vec![&Seen::Timeout(last + delay)]);
}

#[test]
fn a_timer_moved_earlier_fires_early_and_only_once() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    sim.with(a, |p, now| {
        p.deadline = Some(now + Duration::from_millis(400))
    });
    sim.with(a, |p, now| {
        p.deadline = Some(now + Duration::from_millis(220))
    });
    sim.run_until_quiet(Instant::from_micros(10_000_000));
    assert_eq!(
        sim.take_events(a),
        vec![Seen::Timeout(Instant::from_micros(220_000))]
    );
}

#[test]
fn a_cancelled_timer_never_fires() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    sim.with(a, |p, now| {
        p.deadline = Some(now + Duration::from_millis(220))
    });
    sim.with(a, |p, _| p.deadline = None);
    sim.run_until_quiet(Instant::from_micros(10_000_000));
    assert_eq!(sim.take_events(a), vec![]);
}

/// What B sees when its timer and A's character fall on the same instant (1 146 µs), with
/// B arming its timer through `arm` before A transmits and re-arming it through `rearm` after.
fn tie(arm: &[u64], rearm: &[u64]) -> Vec<Seen> {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    for &at in arm {
        sim.with(b, |p, _| p.deadline = Some(Instant::from_micros(at)));
    }
    sim.with(a, |p, _| p.send(&[0x55]));
    for &at in rearm {
        sim.with(b, |p, _| p.deadline = Some(Instant::from_micros(at)));
    }
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    sim.take_events(b)
}

#[test]
fn same_instant_timer_and_character_keep_the_order_they_were_scheduled_in() {
    let (byte, timeout) = (
        Seen::Byte(Instant::from_micros(1_146), 0x55),
        Seen::Timeout(Instant::from_micros(1_146)),
    );
    // Armed before the character was sent: the timer first.
    assert_eq!(tie(&[1_146], &[]), vec![timeout.clone(), byte.clone()]);
    // Armed after: the character first.
    assert_eq!(tie(&[], &[1_146]), vec![byte.clone(), timeout.clone()]);
    // Moved later, then earlier to a time before the queued entry... and later again.
    assert_eq!(tie(&[5_000], &[1_146]), vec![byte.clone(), timeout.clone()]);
    assert_eq!(
        tie(&[1_000, 1_146], &[]),
        vec![timeout.clone(), byte.clone()]
    );
    // Queued at 1 146 before the character, moved away and back after it: the re-arm counts,
    // so the character first (the queued entry is re-queued with the re-arm's place).
    assert_eq!(
        tie(&[1_146], &[5_000, 1_146]),
        vec![byte.clone(), timeout.clone()]
    );
}

#[test]
fn a_burst_interrupted_by_the_receivers_timer_keeps_its_character_times() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    sim.with(b, |p, _| p.deadline = Some(Instant::from_micros(4_000)));
    sim.with(a, |p, _| p.send(&[1, 2, 3, 4, 5, 6]));
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let events = sim.take_events(b);
    let times: Vec<u64> = events
        .iter()
        .map(|e| match e {
            Seen::Byte(t, _) | Seen::Timeout(t) => t.as_micros(),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(times, vec![1_146, 2_292, 3_438, 4_000, 4_584, 5_730, 6_875]);
    assert_eq!(events[3], Seen::Timeout(Instant::from_micros(4_000)));
}

#[test]
fn a_collision_garbles_exactly_the_overlapping_characters() {
    let mut sim = Simulator::new(0);
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    let c = sim.add_station("C", s8e1(), Probe::default());
    sim.bus(&[a.index(), b.index(), c.index()]);
    // A's characters occupy 0..1146, 1146..2292, 2292..3438; C's one 1146..2292: it collides
    // with A's second only (touching is not overlapping).
    sim.with(a, |p, _| p.send(&[0x41, 0x42, 0x43]));
    sim.run_until(Instant::from_micros(1_146));
    sim.with(c, |p, _| p.send(&[0x63]));
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let framing = |at| Seen::Error(Instant::from_micros(at), LineError::Framing);
    for id in [a, b, c] {
        let got: Vec<Seen> = sim
            .take_events(id)
            .into_iter()
            .filter(|e| !matches!(e, Seen::TxDone(_)))
            .collect();
        assert_eq!(
            got,
            vec![
                Seen::Byte(Instant::from_micros(1_146), 0x41),
                framing(2_292),
                framing(2_292),
                Seen::Byte(Instant::from_micros(3_438), 0x43),
            ]
        );
    }
}

#[test]
fn bursts_reuse_their_buffers() {
    let mut sim = Simulator::new(0).without_trace();
    let a = sim.add_station("A", s8e1(), Probe::default());
    let b = sim.add_station("B", s8e1(), Probe::default());
    sim.connect(a, b);
    for _ in 0..100 {
        sim.with(a, |p, _| p.send(&[7; 64]));
        sim.with(b, |p, _| p.send(&[8; 64]));
        sim.run_until_quiet(sim.now() + Duration::from_secs(1));
        assert_eq!(bytes_of(&sim.take_events(b)).len(), 64);
        sim.take_events(a);
    }
    assert_eq!(sim.bursts.len(), 2, "one in flight each way at most");
    assert!(sim.queue.capacity() <= 8);
}
