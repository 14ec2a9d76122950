//! Property tests: header round trips, and decoders and engines never panic on arbitrary
//! bytes and timing ([CP 341] §2.2.3, Table 2-1, Table 2-2).

use proptest::prelude::*;
use si_core::{Duration, Engine, Instant, LineError, Output, SerialSettings};
use si_rk512::frame::{
    Address, Command, CommandHeader, ContinuationHeader, Coordination, DataType, ReactionHeader,
    Telegram,
};
use si_rk512::passive::ServerConfig;
use si_rk512::{Config, Event, Station};
use si_sim::{Faults, Simulator};

fn address() -> impl Strategy<Value = Address> {
    prop_oneof![
        (any::<u8>(), any::<u8>()).prop_map(|(db, dw)| Address::Db { db, dw }),
        (any::<u8>(), any::<u8>()).prop_map(|(db, dw)| Address::Dx { db, dw }),
        any::<u16>().prop_map(Address::Inputs),
        any::<u16>().prop_map(Address::Outputs),
        any::<u16>().prop_map(Address::Flags),
        any::<u16>().prop_map(Address::Timers),
        any::<u16>().prop_map(Address::Counters),
    ]
}

fn command() -> impl Strategy<Value = Command> {
    prop_oneof![
        Just(Command::Send),
        Just(Command::SendDx),
        Just(Command::Fetch)
    ]
}

fn data_type() -> impl Strategy<Value = DataType> {
    address().prop_map(Address::data_type)
}

proptest! {
    #[test]
    fn command_header_decode_encode_round_trips(
        command in command(),
        address in address(),
        length in any::<u16>(),
        flag_byte in any::<u8>(),
        flag_bit in 0u8..16,
        cpu in 0u8..16,
    ) {
        let h = CommandHeader {
            command,
            address,
            length,
            coordination: Coordination { flag_byte, flag_bit, cpu },
        };
        let bytes = h.encode();
        prop_assert_eq!(CommandHeader::decode(&bytes), Ok(h));
        prop_assert_eq!(Telegram::decode(&bytes), Ok(Telegram::Command(h, &[][..])));
    }

    #[test]
    fn short_headers_round_trip(command in command(), data_type in data_type(), continuation in any::<bool>(), error in any::<u8>()) {
        let c = ContinuationHeader { command, data_type };
        prop_assert_eq!(ContinuationHeader::decode(&c.encode()), Ok(c));
        let r = ReactionHeader { continuation, error };
        prop_assert_eq!(ReactionHeader::decode(&r.encode()), Ok(r));
    }

    #[test]
    fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = Telegram::decode(&bytes);
        let _ = CommandHeader::decode(&bytes);
        let _ = ContinuationHeader::decode(&bytes);
        let _ = ReactionHeader::decode(&bytes);
    }

    /// Arbitrary bytes, line errors and timeouts at arbitrary times: no panic, and the Wait
    /// deadline is always reached by draining.
    #[test]
    fn station_never_panics_on_arbitrary_input(
        steps in proptest::collection::vec(
            (0u64..3_000_000, 0u8..5, proptest::collection::vec(any::<u8>(), 0..40)),
            0..60,
        ),
        start_fetch in any::<bool>(),
    ) {
        let line = SerialSettings::default();
        let mut m = ServerConfig::default();
        m.memory.dbs.insert(1, 300);
        let mut st = Station::serving(Config::default().with_settings(line), &m).unwrap();
        let mut now = Instant::ZERO;
        if start_fetch {
            let _ = st.fetch(now, Address::Db { db: 1, dw: 0 }, Coordination::NONE, 200);
        }
        for (dt, kind, bytes) in steps {
            now += Duration::from_micros(dt);
            match kind {
                0 | 1 => st.handle_rx(now, &bytes),
                2 => st.handle_timeout(now),
                3 => st.handle_tx_done(now),
                _ => st.handle_line_error(now, if bytes.is_empty() { LineError::Break } else { LineError::Parity }),
            }
            let mut n = 0;
            while !matches!(st.poll_output(), Output::Wait(_)) {
                n += 1;
                prop_assert!(n < 10_000, "outputs never end");
            }
            prop_assert!(st.queued_telegrams() <= 2);
        }
    }

    /// Whole 3964(R) blocks carrying arbitrary telegrams to a serving station: it answers each
    /// command-like telegram with a reaction (a reaction-like one nobody waits for is dropped)
    /// and never panics.
    #[test]
    fn passive_side_answers_arbitrary_telegrams(
        telegrams in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 1..140), 1..6),
    ) {
        let line = SerialSettings::default();
        let mut sim = Simulator::new(1);
        let mut m = ServerConfig::default();
        m.memory.dbs.insert(1, 64);
        let st = sim.add_station("st", line, Station::serving(Config::default().with_settings(line), &m).unwrap());
        let raw_config = si_3964r::Config { priority: si_3964r::Priority::High, ..Default::default() };
        let raw = sim.add_station("raw", line, si_3964r::Link::new(raw_config.with_settings(line)).unwrap());
        sim.connect(st, raw);
        for t in telegrams {
            let looks_like_reaction = t.len() >= 3 && t[2] == 0;
            sim.with(raw, |l, now| l.send(now, t)).unwrap();
            let until = sim.now() + Duration::from_secs(3);
            sim.run_until(until);
            let reply = sim.with(raw, |l, now| l.take_block(now));
            if !looks_like_reaction {
                let reply = reply.expect("every command is answered");
                prop_assert!(matches!(Telegram::decode(&reply), Ok(Telegram::Reaction(..))));
            }
        }
    }

    /// Random line faults between two stations: every job ends in exactly one completion.
    #[test]
    fn every_job_ends_once_under_faults(seed in any::<u64>(), flip in 0.0f64..0.02, len in 1usize..300) {
        let line = SerialSettings::default();
        let mut sim = Simulator::new(seed);
        let mut high = Config::default();
        high.link.priority = si_3964r::Priority::High;
        let mut m = ServerConfig::default();
        m.memory.dbs.insert(1, 600);
        let a = sim.add_station("A", line, Station::new(high.with_settings(line)).unwrap());
        let b = sim.add_station("B", line, Station::serving(Config::default().with_settings(line), &m).unwrap());
        sim.connect(a, b);
        let faults = Faults { bit_flip: flip, drop: flip / 4.0, insert: flip / 4.0, ..Faults::default() };
        sim.set_faults(a, faults);
        sim.set_faults(b, faults);
        let job = sim.with(a, |s, now| s.fetch(now, Address::Db { db: 1, dw: 0 }, Coordination::NONE, len * 2)).unwrap();
        sim.run_until(Instant::from_micros(900_000_000));
        let ends = sim.take_events(a).into_iter().filter(|e| matches!(e,
            Event::Done { job: j, .. } | Event::Failed { job: j, .. } if *j == job)).count();
        prop_assert_eq!(ends, 1);
    }
}
