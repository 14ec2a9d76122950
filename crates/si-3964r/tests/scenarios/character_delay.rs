//! The character delay time ZVZ at low baud rates ([ET200S SI] §2.7, receiving: character delay
//! monitoring, §2.7, Table 2-11: "longest gap between two received characters"). A partner that
//! leaves gaps of exactly ZVZ between its characters is received; one microsecond more ends the
//! reception with NAK and 0806H at the moment the gap is known to be too long. At 300 bit/s one
//! character takes 36.7 ms against the 60 ms ZVZ minimum, at 110 bit/s 100 ms against 170 ms,
//! so a deadline that leaves the character time out fails the first half of these tests.

use crate::common;

use common::*;
use si_3964r::frame::{encode, Mode, DLE, NAK, STX};
use si_3964r::status::{CHARACTER_DELAY, IDLE_GARBAGE};
use si_3964r::{Config, Event};
use si_core::{Duration, Instant, Parity, SerialSettings};

/// The slow rates with their ZVZ minimum ([CP 341] §2.2.2, §2.3.1, 110 bit/s derived; see
/// si_3964r::config).
const SLOW: [(u32, u32); 2] = [(300, 60), (110, 170)];

const US1: Duration = Duration::from_micros(1);

/// What link "A" at `baud` with ZVZ `zvz_ms` reports when the partner sends the block "ab"
/// character by character, with `gap(k)` of silence before character `k` (0 is the first
/// character after A's DLE), and when A sent its first NAK after the startup NAK.
fn receive_with_gaps(
    baud: u32,
    zvz_ms: u32,
    gap: impl Fn(usize) -> Duration,
) -> (Vec<Event>, Option<Instant>, Vec<Instant>) {
    let line = SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
    let config = Config {
        char_delay: Duration::from_millis(zvz_ms.into()),
        ack_delay: Duration::from_millis(zvz_ms.max(2000).into()),
        transmission_attempts: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted_on(line, config);
    let c = line.char_time();
    sim.transmit(p, &[STX]);
    sim.run_until(sim.now() + c);
    let dle_at = *tx_times(&sim, "A", DLE)
        .first()
        .expect("A answers STX with DLE");
    // The partner starts each character `gap(k)` after the previous one (A's DLE first) ended.
    let mut ended = dle_at + c;
    let mut ends = Vec::new();
    for (k, byte) in encode(b"ab", Mode::BlockCheck).into_iter().enumerate() {
        let start = ended + gap(k);
        sim.run_until(start);
        sim.transmit(p, &[byte]);
        ended = start + c;
        ends.push(ended);
    }
    settle(&mut sim);
    let nak = tx_times(&sim, "A", NAK).into_iter().nth(1);
    (sim.take_events(a), nak, ends)
}

/// 0806H first; the partner's characters after it arrive in idle, where they are answered
/// with NAK and 0802H once the line is quiet ([ET200S SI] §2.7, receiving: idle).
fn zvz_expired(events: &[Event]) -> bool {
    events.first() == Some(&Event::ReceiveError(CHARACTER_DELAY))
        && events[1..]
            .iter()
            .all(|e| *e == Event::ReceiveError(IDLE_GARBAGE))
}

#[test]
fn s5_4_gaps_of_exactly_zvz_at_300_and_110_bit_s_are_one_block() {
    for (baud, zvz_ms) in SLOW {
        let zvz = Duration::from_millis(zvz_ms.into());
        let (events, nak, _) = receive_with_gaps(baud, zvz_ms, |_| zvz);
        assert_eq!(events, vec![Event::Received { len: 2 }], "{baud} bit/s");
        assert_eq!(nak, None, "{baud} bit/s: no NAK");
    }
}

#[test]
fn s5_4_a_gap_of_zvz_plus_1_us_inside_the_block_is_0806() {
    for (baud, zvz_ms) in SLOW {
        let zvz = Duration::from_millis(zvz_ms.into());
        // The gap before the third character ("b" after "a") is one microsecond too long.
        let (events, nak, ends) =
            receive_with_gaps(baud, zvz_ms, |k| if k == 2 { zvz + US1 } else { zvz });
        assert!(zvz_expired(&events), "{baud} bit/s: {events:?}");
        // NAK the moment the gap after the second character is known to exceed ZVZ: when the
        // next character, had it started in time, would have been complete.
        let line = SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
        assert_eq!(
            nak,
            Some(ends[1] + zvz + line.char_time() + US1),
            "{baud} bit/s"
        );
    }
}

#[test]
fn s5_4_the_first_character_after_dle_gets_zvz_too() {
    for (baud, zvz_ms) in SLOW {
        let zvz = Duration::from_millis(zvz_ms.into());
        let late = |k| if k == 0 { zvz + US1 } else { zvz };
        let (events, nak, _) = receive_with_gaps(baud, zvz_ms, late);
        assert!(zvz_expired(&events), "{baud} bit/s: {events:?}");
        assert!(nak.is_some(), "{baud} bit/s");
    }
}
