//! Round trips and "never panics" over arbitrary bytes and timing.

use proptest::prelude::*;
use si_core::{Engine, Instant, LineError, Output};
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::{decode, encode, Adr, NetData, Pke, Pkw, PkwWords, Pzd, MAX_TELEGRAM};
use si_uss::master::{Master, ParamRequest, Width};

fn pkw_words() -> impl Strategy<Value = PkwWords> {
    prop_oneof![
        Just(PkwWords::None),
        Just(PkwWords::Three),
        Just(PkwWords::Four),
        Just(PkwWords::Variable)
    ]
}

/// Drain an engine, counting outputs; the contract says it ends with Wait.
fn drain<E: Engine>(e: &mut E) -> Option<Instant> {
    for _ in 0..10_000 {
        if let Output::Wait(d) = e.poll_output() {
            return d;
        }
    }
    panic!("engine did not reach Wait");
}

proptest! {
    #[test]
    fn telegram_round_trips(adr in any::<u8>(), net in proptest::collection::vec(any::<u8>(), 0..=252)) {
        let mut buf = [0u8; MAX_TELEGRAM];
        let n = encode(Adr(adr), &net, &mut buf).unwrap();
        let t = decode(&buf[..n]).unwrap();
        prop_assert_eq!(t.adr, Adr(adr));
        prop_assert_eq!(t.net, &net[..]);
    }

    #[test]
    fn net_data_round_trips(
        words in pkw_words(),
        pke in any::<u16>(), ind in any::<u16>(),
        pwe in proptest::collection::vec(any::<u16>(), 1..20),
        pzd in proptest::collection::vec(any::<u16>(), 0..=16),
    ) {
        let pwe_len = match words { PkwWords::Three => 1, PkwWords::Four => 2, _ => pwe.len() };
        let pkw = (words != PkwWords::None).then(|| Pkw::new(Pke(pke), ind, &pwe[..pwe_len.min(pwe.len())]));
        prop_assume!(words != PkwWords::Four || pwe.len() >= 2);
        let net = NetData { pkw, pzd: Pzd::new(&pzd) };
        let mut buf = [0u8; 252];
        let n = net.write(&mut buf).unwrap();
        prop_assert_eq!(NetData::parse(&buf[..n], words, pzd.len()).unwrap(), net);
    }

    #[test]
    fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = decode(&bytes);
        let _ = NetData::parse(&bytes, PkwWords::Variable, 16);
        let _ = NetData::parse(&bytes, PkwWords::Three, 3);
    }

    #[test]
    fn engines_never_panic_on_arbitrary_bytes_and_timing(
        chunks in proptest::collection::vec(
            (0u64..30_000, proptest::collection::vec(any::<u8>(), 0..40), 0u8..6), 0..40),
        echo in any::<bool>(),
    ) {
        let settings = uss_settings(9600).unwrap();
        let mut cfg = MasterConfig::new(vec![
            PollEntry::new(1, PkwWords::Four, 2),
            PollEntry::new(2, PkwWords::Variable, 1),
            PollEntry::new(1, PkwWords::Four, 2),
        ]);
        cfg.local_echo = echo;
        cfg.settings = settings;
        let mut m = Master::new(cfg).unwrap();
        let mut d = Drive::new(DriveConfig { local_echo: echo, ..DriveConfig::new(settings, 1) }).unwrap();
        let mut now = Instant::ZERO;
        m.start(now);
        let _ = m.request_parameter(now, 1, ParamRequest::read(700, 0));
        let _ = m.mirror(now, 2, &[1, 2, 3]);
        let _ = m.broadcast(now, &[0, 1]);
        for (dt, bytes, kind) in chunks {
            now += si_core::Duration::from_micros(dt);
            match kind {
                0 => { m.handle_timeout(now); d.handle_timeout(now); }
                1 => { m.handle_line_error(now, LineError::Framing); d.handle_line_error(now, LineError::Break); }
                _ => { m.handle_rx(now, &bytes); d.handle_rx(now, &bytes); }
            }
            if let Some(t) = drain(&mut m) { prop_assert!(t.as_micros() < u64::MAX); }
            drain(&mut d);
        }
    }
}

/// Step the simulator for `span`, failing if the engines keep it busy at one instant (a timer
/// asked for at a time already past, over and over).
fn run_without_spinning(sim: &mut si_sim::Simulator, span: si_core::Duration) {
    let end = sim.now() + span;
    let (mut at, mut same) = (sim.now(), 0);
    while sim.now() <= end && sim.step() {
        if sim.now() == at {
            same += 1;
            assert!(same < 1_000, "busy loop at {at}");
        } else {
            (at, same) = (sim.now(), 0);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Seeded line faults (bit flips, lost and inserted characters): nothing panics, the cycle
    /// keeps going, and every parameter job ends in exactly one completion event.
    #[test]
    fn every_job_ends_exactly_once_under_line_faults(seed in any::<u64>(), flip in 0.0f64..0.02, drop in 0.0f64..0.02, insert in 0.0f64..0.02) {
        use si_sim::{Faults, Simulator};
        use si_uss::master::Event;
        let settings = uss_settings(19_200).unwrap();
        let mut cfg = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2), PollEntry::new(2, PkwWords::Four, 2)]);
        cfg.settings = settings;
        cfg.retries = 3;
        cfg.local_echo = true;
        let mut sim = Simulator::new(seed).without_trace();
        let m = sim.add_station("master", settings, Master::new(cfg).unwrap());
        let d1 = sim.add_station("d1", settings, Drive::new(DriveConfig { local_echo: true, ..DriveConfig::new(settings, 1) }).unwrap());
        let d2 = sim.add_station("d2", settings, Drive::new(DriveConfig { local_echo: true, ..DriveConfig::new(settings, 2) }).unwrap());
        sim.bus(&[m.index(), d1.index(), d2.index()]);
        let faults = Faults { bit_flip: flip, drop, insert, ..Faults::default() };
        sim.set_faults(m, faults);
        sim.set_faults(d1, faults);
        sim.set_faults(d2, faults);
        // Our own echo is clean on the simulator's bus (faults hit only what others send).
        sim.with(m, |m, now| m.start(now));
        let mut jobs = Vec::new();
        let mut ended = Vec::new();
        for round in 0..20u16 {
            for a in [1u8, 2] {
                let r = sim.with(m, |m, now| m.request_parameter(now, a, ParamRequest::write(1082, 0, u32::from(round), Width::Word)));
                if let Ok(j) = r { jobs.push(j); }
            }
            run_without_spinning(&mut sim, si_core::Duration::from_millis(100));
            for e in sim.take_events(m) {
                match e {
                    Event::ParameterDone { job, .. } | Event::ParameterFailed { job, .. } => ended.push(job),
                    _ => {}
                }
            }
        }
        run_without_spinning(&mut sim, si_core::Duration::from_secs(2));
        for e in sim.take_events(m) {
            if let Event::ParameterDone { job, .. } | Event::ParameterFailed { job, .. } = e { ended.push(job); }
        }
        let mut sorted = ended.clone();
        sorted.sort();
        sorted.dedup();
        prop_assert_eq!(sorted.len(), ended.len(), "a job ended twice");
        prop_assert_eq!(ended.len(), jobs.len(), "a job never ended");
        prop_assert!(sim.engine(m).cycle() > 50);
    }
}
