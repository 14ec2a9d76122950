//! The ASCII driver behind a USB-serial adapter: with default configs and each end
//! criterion ([ET200S SI] §2.8: character delay time, end character, fixed length), frames longer
//! than one adapter packet arrive whole through a 16 ms / 62-byte adapter at 9600 and 19 200 bit/s,
//! announced or learnt; and without the adapter the character delay time still ends a frame at
//! the manual's instant.

use crate::common;

use common::{errors, received, settings, Bench};
use si_ascii::{Config, EndCriterion};
use si_core::Duration;
use si_sim::UsbAdapter;

const BAUDS: [u32; 2] = [9_600, 19_200];

/// 100 bytes with no end character in them, and the criterion's end.
fn frame(end: EndCriterion) -> Vec<u8> {
    let mut f: Vec<u8> = (0..100).map(|i| b'A' + (i % 26) as u8).collect();
    if let EndCriterion::EndChars { first, .. } = end {
        f[99] = first;
    }
    f
}

fn criteria() -> [EndCriterion; 3] {
    [
        EndCriterion::CharDelay,
        EndCriterion::DEFAULT_END_CHARS,
        EndCriterion::FixedLength { len: 100 },
    ]
}

fn exchange(baud: u32, end: EndCriterion, adapter: UsbAdapter) {
    let config = Config {
        settings: settings(baud),
        end,
        ..Config::default()
    };
    let mut b = Bench::new(config);
    b.sim.set_adapter(b.link, adapter).unwrap();
    let f = frame(end);
    for _ in 0..3 {
        b.partner_sends(&f);
        b.run_for_ms(1_000);
    }
    let events = b.events();
    let what = format!("{baud} bit/s, {end:?}, {adapter:?}");
    assert!(errors(&events).is_empty(), "{what}: {events:?}");
    assert_eq!(b.frames(), vec![f.clone(), f.clone(), f], "{what}");
}

#[test]
fn each_end_criterion_gets_whole_frames_through_an_announced_16ms_adapter() {
    for baud in BAUDS {
        for end in criteria() {
            exchange(baud, end, UsbAdapter::FTDI_DEFAULT);
        }
    }
}

#[test]
fn each_end_criterion_gets_whole_frames_through_an_unannounced_16ms_adapter() {
    // The link learns the hold from the first packet (14 bytes at 9600, 28 at 19 200) before
    // the first hole between packets is judged.
    for baud in BAUDS {
        for end in criteria() {
            exchange(baud, end, UsbAdapter::FTDI_DEFAULT.unannounced());
        }
    }
}

#[test]
fn without_an_adapter_the_char_delay_time_ends_the_frame_at_the_manuals_instant() {
    for baud in BAUDS {
        let config = Config {
            settings: settings(baud),
            ..Config::default()
        };
        let mut b = Bench::new(config);
        b.partner_sends(&frame(EndCriterion::CharDelay));
        b.run_for_ms(1_000);
        let last = *b.arrivals().last().unwrap();
        let cdt = config.char_delay;
        let end = last + cdt + config.settings.char_time() + Duration::from_micros(1);
        assert_eq!(received(&b.events()), vec![(100, end)], "{baud} bit/s");
    }
}

/// Feeds `first` at 0 and `second` `hole_ms` later to a link behind a port that declared a
/// 16 ms latency, running its timers in between; the frames it cut and its error events.
fn split_by_hole(
    end: EndCriterion,
    first: &[u8],
    second: &[u8],
    hole_ms: u64,
) -> (Vec<Vec<u8>>, usize) {
    use si_ascii::{Event, Link};
    use si_core::{Engine, Instant, Output};
    let mut link = Link::new(Config {
        end,
        ..Config::default()
    })
    .unwrap();
    link.set_rx_latency(Duration::from_millis(16));
    let mut errors = 0;
    let mut run_until = |link: &mut Link, until: Instant| loop {
        match link.poll_output() {
            Output::Event(Event::ReceiveError { .. }) => errors += 1,
            Output::Wait(Some(d)) if d <= until => link.handle_timeout(d),
            Output::Wait(_) => break,
            _ => {}
        }
    };
    let second_at = Instant::ZERO + Duration::from_millis(hole_ms);
    link.handle_rx(Instant::ZERO, first);
    run_until(&mut link, second_at);
    link.handle_rx(second_at, second);
    run_until(&mut link, second_at + Duration::from_secs(2));
    let mut frames = Vec::new();
    while let Some(f) = link.read_frame_vec(second_at) {
        frames.push(f);
    }
    (frames, errors)
}

#[test]
fn behind_an_adapter_a_frame_ended_by_its_content_survives_a_100ms_hole() {
    // Host scheduling on top of the adapter's 16 ms: the end character still decides.
    let (frames, errors) = split_by_hole(EndCriterion::DEFAULT_END_CHARS, b"abc", b"def\x03", 100);
    assert_eq!((frames, errors), (vec![b"abcdef\x03".to_vec()], 0));
    let fixed = EndCriterion::FixedLength { len: 6 };
    let (frames, errors) = split_by_hole(fixed, b"abc", b"def", 100);
    assert_eq!((frames, errors), (vec![b"abcdef".to_vec()], 0));
}

#[test]
fn behind_an_adapter_the_char_delay_time_still_ends_a_frame_at_a_100ms_hole() {
    // In character-delay mode the silence is the frame end: CDT 4 ms + 16 ms + a character.
    let (frames, _) = split_by_hole(EndCriterion::CharDelay, b"abc", b"def", 100);
    assert_eq!(frames, vec![b"abc".to_vec(), b"def".to_vec()]);
}
