//! [ET200S SI] §2.8, Table 2-9: the three receive end criteria on the simulator, at
//! several baud rates, with frames cut at exactly the right byte and the right time.

use crate::common;

use common::{errors, received, settings, Bench};
use si_ascii::config::min_char_delay_ms;
use si_ascii::{status, Config, EndCriterion};
use si_core::Duration;

/// The clock's resolution: a gap is longer than the CDT one microsecond after it equals it.
const US1: Duration = Duration::from_micros(1);

const BAUDS: [u32; 5] = [110, 1_200, 4_800, 9_600, 19_200];

fn config(baud: u32, end: EndCriterion) -> Config {
    Config {
        settings: settings(baud),
        end,
        char_delay: Duration::from_millis(min_char_delay_ms(baud).into()),
        ..Config::default()
    }
}

fn cdt(c: &Config) -> Duration {
    c.char_delay
}

#[test]
fn s6_3_char_delay_expiry_ends_the_frame_one_cdt_after_the_last_character() {
    for baud in BAUDS {
        let c = config(baud, EndCriterion::CharDelay);
        let mut b = Bench::new(c);
        b.partner_sends(b"HELLO");
        b.run_for_ms(3_000);
        let last = *b.arrivals().last().unwrap();
        let events = b.events();
        // The next character would have had to *start* within the CDT: complete within
        // CDT + one character time of the last one.
        assert_eq!(
            received(&events),
            vec![(5, last + cdt(&c) + c.settings.char_time() + US1)],
            "{baud} bit/s"
        );
        assert_eq!(b.frames(), vec![b"HELLO".to_vec()]);
    }
}

#[test]
fn s6_3_a_gap_of_exactly_the_cdt_keeps_the_frame_one_microsecond_more_splits_it() {
    for baud in BAUDS {
        let c = config(baud, EndCriterion::CharDelay);
        // Gap == CDT: one frame.
        let mut b = Bench::new(c);
        b.partner_sends(b"AB");
        let end_of_b = b.sim.now() + c.settings.chars_time(2);
        b.sim.run_until(end_of_b + cdt(&c));
        b.partner_sends(b"C");
        b.run_for_ms(3_000);
        assert_eq!(b.frames(), vec![b"ABC".to_vec()], "{baud} bit/s, gap = CDT");
        // Gap == CDT + 1 µs: two frames.
        let mut b = Bench::new(c);
        b.partner_sends(b"AB");
        let end_of_b = b.sim.now() + c.settings.chars_time(2);
        b.sim
            .run_until(end_of_b + cdt(&c) + Duration::from_micros(1));
        b.partner_sends(b"C");
        b.run_for_ms(3_000);
        assert_eq!(
            b.frames(),
            vec![b"AB".to_vec(), b"C".to_vec()],
            "{baud} bit/s, gap = CDT + 1 µs"
        );
        assert!(errors(&b.events()).is_empty());
    }
}

#[test]
fn s6_3_end_character_cuts_at_the_end_character_including_it() {
    for baud in BAUDS {
        let c = config(baud, EndCriterion::DEFAULT_END_CHARS);
        let mut b = Bench::new(c);
        b.partner_sends(b"ab\x03cde\x03");
        b.run_for_ms(3_000);
        let arrivals = b.arrivals();
        assert_eq!(
            received(&b.events()),
            vec![(3, arrivals[2]), (4, arrivals[6])],
            "{baud} bit/s: cut the moment the end character arrives"
        );
        assert_eq!(b.frames(), vec![b"ab\x03".to_vec(), b"cde\x03".to_vec()]);
    }
}

#[test]
fn s6_3_two_end_characters_are_a_sequence() {
    for baud in [1_200, 9_600, 19_200] {
        let c = config(
            baud,
            EndCriterion::EndChars {
                first: 0x0D,
                second: 0x0A,
            },
        );
        let mut b = Bench::new(c);
        b.partner_sends(b"a\rb\nc\r\nline2\r\n");
        b.run_for_ms(2_000);
        let arrivals = b.arrivals();
        assert_eq!(
            received(&b.events()),
            vec![(7, arrivals[6]), (7, arrivals[13])]
        );
        assert_eq!(
            b.frames(),
            vec![b"a\rb\nc\r\n".to_vec(), b"line2\r\n".to_vec()]
        );
    }
}

#[test]
fn s6_3_end_character_missing_is_0806_after_the_cdt_and_the_fragment_is_discarded() {
    for baud in BAUDS {
        let c = config(baud, EndCriterion::DEFAULT_END_CHARS);
        let mut b = Bench::new(c);
        b.partner_sends(b"ab\x03cd");
        b.run_for_ms(3_000);
        let last = *b.arrivals().last().unwrap();
        let events = b.events();
        assert_eq!(received(&events).len(), 1);
        assert_eq!(
            errors(&events),
            vec![(0x0806, last + cdt(&c) + c.settings.char_time() + US1)],
            "{baud} bit/s"
        );
        assert_eq!(b.frames(), vec![b"ab\x03".to_vec()], "cd discarded");
    }
}

#[test]
fn cp341_5_3_characters_after_the_end_character_merge_with_the_next_frame_within_the_cdt() {
    let c = config(9_600, EndCriterion::DEFAULT_END_CHARS);
    let mut b = Bench::new(c);
    b.partner_sends(b"ab\x03cd");
    b.run_for_ms(1); // well within the 4 ms CDT after "d"
    b.partner_sends(b"e\x03");
    b.run_for_ms(100);
    assert_eq!(b.frames(), vec![b"ab\x03".to_vec(), b"cde\x03".to_vec()]);
    assert!(errors(&b.events()).is_empty());
}

#[test]
fn s6_3_fixed_length_cuts_at_the_nth_character() {
    for baud in BAUDS {
        let c = config(baud, EndCriterion::FixedLength { len: 4 });
        let mut b = Bench::new(c);
        b.partner_sends(b"ABCDEFGH");
        b.run_for_ms(3_000);
        let arrivals = b.arrivals();
        assert_eq!(
            received(&b.events()),
            vec![(4, arrivals[3]), (4, arrivals[7])],
            "{baud} bit/s"
        );
        assert_eq!(b.frames(), vec![b"ABCD".to_vec(), b"EFGH".to_vec()]);
    }
}

#[test]
fn s6_3_fixed_length_short_frame_is_0806_and_discarded() {
    for baud in BAUDS {
        let c = config(baud, EndCriterion::FixedLength { len: 4 });
        let mut b = Bench::new(c);
        b.partner_sends(b"ABCDEF");
        b.run_for_ms(3_000);
        let last = *b.arrivals().last().unwrap();
        let events = b.events();
        assert_eq!(
            errors(&events),
            vec![(0x0806, last + cdt(&c) + c.settings.char_time() + US1)]
        );
        // The surplus "EF" started the next frame, which was then too short.
        assert_eq!(b.frames(), vec![b"ABCD".to_vec()], "{baud} bit/s");
    }
}

#[test]
fn public_facts_4_fixed_length_surplus_starts_the_next_frame_within_the_monitoring_time() {
    let c = config(19_200, EndCriterion::FixedLength { len: 4 });
    let mut b = Bench::new(c);
    b.partner_sends(b"ABCDEF");
    b.run_for_ms(5); // < 4 ms CDT + one character after "F"
    b.partner_sends(b"GH");
    b.run_for_ms(100);
    assert_eq!(b.frames(), vec![b"ABCD".to_vec(), b"EFGH".to_vec()]);
    assert!(errors(&b.events()).is_empty());
}

#[test]
fn maximum_length_guard_reports_0850_and_the_next_frame_is_clean() {
    let c = config(19_200, EndCriterion::CharDelay);
    let mut b = Bench::new(c);
    b.partner_sends(&[0x55; 201]);
    b.run_for_ms(200);
    b.partner_sends(b"next");
    b.run_for_ms(200);
    let events = b.events();
    assert_eq!(
        errors(&events).iter().map(|e| e.0).collect::<Vec<_>>(),
        vec![status::FRAME_TOO_LONG.code()]
    );
    assert_eq!(b.frames(), vec![b"next".to_vec()]);
    // Exactly 200 bytes is allowed.
    let mut b = Bench::new(c);
    b.partner_sends(&[0xAA; 200]);
    b.run_for_ms(200);
    assert_eq!(b.frames(), vec![vec![0xAA; 200]]);
}

#[test]
fn s6_2_inter_frame_pause_keeps_two_sent_frames_apart_for_a_cdt_partner() {
    for baud in [1_200, 9_600, 19_200] {
        let c = config(baud, EndCriterion::CharDelay);
        let mut sim = si_sim::Simulator::new(3);
        let a = sim.add_station("A", c.settings, si_ascii::Link::new(c).unwrap());
        let b = sim.add_station("B", c.settings, si_ascii::Link::new(c).unwrap());
        sim.connect(a, b);
        sim.with(a, |l, now| l.send(now, "one".into())).unwrap();
        // Step until the first frame has left, then ask for the second at that very instant.
        while sim.engine(a).is_sending() {
            assert!(sim.step());
        }
        let done_at = sim.now();
        sim.with(a, |l, now| l.send(now, "two".into())).unwrap();
        sim.run_until_quiet(sim.now() + Duration::from_secs(1));
        let mut frames = Vec::new();
        while let Some(f) = sim.with(b, |l, now| l.read_frame_vec(now)) {
            frames.push(f);
        }
        assert_eq!(frames, vec![b"one".to_vec(), b"two".to_vec()], "{baud}");
        // The second frame's first byte left just more than one CDT after the first ended.
        let tx: Vec<_> = sim
            .trace()
            .of("A")
            .filter(|e| matches!(e.kind, si_sim::TraceKind::Tx { .. }))
            .map(|e| e.at)
            .collect();
        assert_eq!(tx[1], done_at + cdt(&c) + US1, "{baud}: {tx:?}");
    }
}
