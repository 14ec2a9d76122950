//! [ET200S SI] §2.13, Table 2-28: character errors are reported with the ASCII driver's codes
//! (0810H parity, 0811H character frame, 080CH overrun, 080DH BREAK), the broken frame is
//! discarded and the next one is clean; RS-485 half duplex on the simulator's bus.

use crate::common;

use common::{errors, received, settings, Bench, Partner};
use si_ascii::{status, Config, EndCriterion, Event, Interface, Link};
use si_core::{Duration, Engine, Instant, LineError, Output, Parity, SerialSettings};
use si_sim::{Faults, Simulator};

fn drain(link: &mut Link) -> Vec<Event> {
    let mut v = Vec::new();
    while let Output::Event(e) = link.poll_output() {
        v.push(e);
    }
    v
}

#[test]
fn s11_3_parity_error_is_0810_and_the_frame_is_discarded() {
    let c = Config {
        end: EndCriterion::DEFAULT_END_CHARS,
        ..Config::default()
    };
    let mut link = Link::new(c).unwrap();
    let t = |us| Instant::from_micros(us);
    link.handle_rx(t(1_000), b"ab");
    link.handle_line_error(t(2_000), LineError::Parity);
    link.handle_rx(t(3_000), b"c\x03");
    let events = drain(&mut link);
    assert_eq!(
        events,
        vec![Event::ReceiveError {
            status: status::PARITY_ERROR,
            at: t(2_000)
        }]
    );
    assert_eq!(
        link.read_frame_vec(t(4_000)),
        None,
        "the broken frame is gone"
    );
    link.handle_rx(t(10_000), b"ok\x03");
    assert!(matches!(
        drain(&mut link)[..],
        [Event::Received { len: 3, .. }]
    ));
    assert_eq!(link.read_frame_vec(t(11_000)).unwrap(), b"ok\x03");
    // S_RCV sees the error once.
    assert_eq!(link.take_receive_error(), Some(status::PARITY_ERROR));
    assert_eq!(link.take_receive_error(), None);
}

#[test]
fn s11_3_each_line_error_has_its_code() {
    for (e, code) in [
        (LineError::Parity, 0x0810),
        (LineError::Framing, 0x0811),
        (LineError::Overrun, 0x080C),
        (LineError::Break, 0x080D),
    ] {
        let mut link = Link::new(Config::default()).unwrap();
        link.handle_line_error(Instant::ZERO, e);
        assert_eq!(
            drain(&mut link),
            vec![Event::ReceiveError {
                status: status::lookup(code),
                at: Instant::ZERO
            }]
        );
    }
}

#[test]
fn s11_3_character_frame_errors_on_the_line_are_0811() {
    // The partner talks 8N1 to a module set to 8E1: every character is a frame error.
    let c = Config {
        settings: settings(9_600),
        ..Config::default()
    };
    let mut sim = Simulator::new(5);
    let m = sim.add_station("M", c.settings, Link::new(c).unwrap());
    let p = sim.add_station(
        "P",
        SerialSettings::new(9_600, 8, Parity::None, 1).unwrap(),
        Partner::default(),
    );
    sim.connect(m, p);
    sim.transmit(p, b"xyz");
    sim.run_for(Duration::from_millis(100));
    let events = sim.take_events(m);
    assert!(received(&events).is_empty());
    assert!(!errors(&events).is_empty());
    assert!(errors(&events).iter().all(|e| e.0 == 0x0811));
}

#[test]
fn s6_3_bit_flips_never_deliver_a_frame_of_the_wrong_length_in_fixed_mode() {
    // Seeded faults: lost characters make frames short (0806H), never merge silently.
    let c = Config {
        settings: settings(19_200),
        end: EndCriterion::FixedLength { len: 10 },
        ..Config::default()
    };
    let mut b = Bench::new(c);
    b.sim.set_faults(
        b.link,
        Faults {
            drop: 0.05,
            ..Faults::default()
        },
    );
    for _ in 0..50 {
        b.partner_sends(b"0123456789");
        b.run_for_ms(50);
    }
    let events = b.events();
    assert!(received(&events).iter().all(|r| r.0 == 10));
    assert!(errors(&events).iter().all(|e| e.0 == 0x0806));
    assert!(!errors(&events).is_empty());
    assert!(b.frames().iter().all(|f| f == b"0123456789"));
}

#[test]
fn rs485_half_duplex_ignores_its_own_echo_and_waits_for_a_quiet_line() {
    let c = Config {
        settings: settings(9_600),
        interface: Interface::Rs485,
        end: EndCriterion::DEFAULT_END_CHARS,
        ..Config::default()
    };
    let mut sim = Simulator::new(9);
    let m = sim.add_station("M", c.settings, Link::new(c).unwrap());
    let p = sim.add_station("P", c.settings, Partner::default());
    sim.bus(&[m.index(), p.index()]);
    // Own frame: the echo is not received as a frame.
    sim.with(m, |l, now| l.send(now, "ping\x03".into()))
        .unwrap();
    sim.run_for(Duration::from_millis(50));
    let events = sim.take_events(m);
    assert!(matches!(events[..], [Event::Sent { .. }]), "{events:?}");
    assert_eq!(sim.engine(p).bytes(), b"ping\x03");
    // A send requested while a partner frame is on the line waits for it to end.
    sim.transmit(p, b"pong\x03");
    sim.run_for(Duration::from_micros(2_000)); // "po" received
    sim.with(m, |l, now| l.send(now, "next\x03".into()))
        .unwrap();
    sim.run_for(Duration::from_millis(50));
    let events = sim.take_events(m);
    assert!(
        matches!(
            events[..],
            [Event::Received { len: 5, .. }, Event::Sent { .. }]
        ),
        "{events:?}"
    );
    assert_eq!(
        sim.with(m, |l, now| l.read_frame_vec(now)).unwrap(),
        b"pong\x03"
    );
    // The partner hears its own echo too (the bus), then our frame after its own.
    assert_eq!(sim.engine(p).bytes(), b"ping\x03pong\x03next\x03");
    // No collision: the partner heard clean characters only.
    assert!(sim.engine(p).received.iter().all(|r| r.1.is_ok()));
}
