//! A bound on every ASCII job under noise: against a partner that only ever puts noise on the
//! line (silent, random bytes, 01H every 2 ms, an endless frame, floods, noise that stops; the
//! patterns are si-testkit's [`issue_patterns`]), a send job that waits for the partner ends
//! with a non-zero STATUS within the wait time the manual gives it, and the receiver reports
//! every fault with a STATUS and never stores more than the maximum frame length. Virtual time
//! on the line simulator.
//!
//! The ASCII driver sends without an acknowledgement ([ET200S SI] §2.8), so noise alone cannot
//! fail a send: a send fails only while it waits for the partner's handshake. The jobs here
//! therefore run with each flow control that waits: automatic V.24 (0818H while DSR or CTS
//! is OFF, at the latest when the data output wait time ends), RTS/CTS (0708H when CTS stays OFF for the
//! wait time for CTS) and XON/XOFF against a partner that sends XOFF (0708H after the wait time
//! for XON). A noise peer never sets RTS, so the simulator's null-modem cable keeps our CTS OFF.
//! Without flow control the send ends with its last character on the line, noise or not.

use si_ascii::status::{DSR_CTS_OFF, FRAME_TOO_LONG, XON_CTS_TIMEOUT};
use si_ascii::{Config, EndCriterion, Event, FlowControl, Link};
use si_core::{Duration, Instant, SerialSettings, Status};
use si_testkit::job_run::run_while;
use si_testkit::noise::{facing, issue_patterns, Facing, Noise, Pattern, Source};

/// The frame every send job carries: 20 bytes, no XON or XOFF in it.
const FRAME: &[u8] = b"ASCII under noise\r\n!";

fn line() -> SerialSettings {
    Config::default().settings
}

/// Every pattern of si-testkit, and an XOFF (13H) flood: a partner that holds us for ever.
fn patterns() -> Vec<Pattern> {
    let mut all = issue_patterns(line().char_time());
    all.push(Pattern {
        name: "XOFF flood",
        noise: Noise::Flood(Source::Fixed(0x13)),
        until: None,
    });
    all
}

fn with_flow(flow_control: FlowControl) -> Config {
    let mut c = Config {
        flow_control,
        // Hand out one character at a time, as the module does (si_ascii::Config::tx_chunk).
        tx_chunk: 1,
        ..Config::default()
    };
    c.auto_v24.data_wait_time = si_core::Duration::from_millis(100);
    c.rts_cts.wait_for_cts = si_core::Duration::from_millis(200);
    c.xon_xoff.wait_for_xon = si_core::Duration::from_millis(300);
    c
}

/// The link facing `pattern`: after 50 ms of noise it sends [`FRAME`]; runs until the job ends
/// (failing past `bound`) and returns how long the job took and its outcome.
fn send_into(config: Config, pattern: Pattern, bound: Duration) -> (Duration, Result<(), Status>) {
    let Facing {
        mut sim,
        engine: link,
        ..
    } = facing(7, line(), Link::new(config).unwrap(), pattern);
    sim.run_for(Duration::from_millis(50));
    let start = sim.now();
    let job = sim
        .with(link, |l, now| l.send(now, FRAME.into()))
        .unwrap_or_else(|e| panic!("{}: {e}", pattern.name));
    let end = run_while(&mut sim, start + bound, |sim| sim.engine(link).is_sending());
    let outcome = sim.engine(link).send_result(job);
    let ends: Vec<_> = sim
        .take_events(link)
        .into_iter()
        .filter(|e| matches!(e, Event::Sent { .. } | Event::SendFailed { .. }))
        .collect();
    match (ends.as_slice(), outcome) {
        ([Event::Sent { job: j, .. }], Some(Ok(()))) if *j == job => {}
        ([Event::SendFailed { job: j, status, .. }], Some(Err(s))) if *j == job => {
            assert_eq!(*status, s, "{}", pattern.name);
        }
        _ => panic!("{}: one end per job, {ends:?} / {outcome:?}", pattern.name),
    }
    (end.saturating_since(start), outcome.unwrap())
}

/// The frame's own time on the line: what a send takes once nothing holds it.
fn frame_time() -> Duration {
    line().chars_time(FRAME.len() as u64)
}

/// Automatic V.24: the noise peer sets neither DTR nor RTS, so our DSR is OFF and the send
/// ends at once with 0818H ("DSR = OFF or CTS = OFF before or during a send"), well inside
/// the data output wait time that would end it otherwise.
#[test]
fn automatic_v24_ends_every_send_with_0818h_within_the_data_output_wait_time() {
    let config = with_flow(FlowControl::AutoV24);
    let wait = Duration::from_millis(100);
    for pattern in patterns() {
        let (took, outcome) = send_into(config, pattern, wait);
        assert_eq!(outcome, Err(DSR_CTS_OFF), "{}", pattern.name);
        assert_eq!(took, Duration::ZERO, "{}", pattern.name);
    }
}

#[test]
fn rts_cts_ends_every_send_with_0708h_at_the_wait_time_for_cts() {
    let config = with_flow(FlowControl::RtsCts);
    let wait = Duration::from_millis(200);
    for pattern in patterns() {
        let (took, outcome) = send_into(config, pattern, wait);
        assert_eq!(outcome, Err(XON_CTS_TIMEOUT), "{}", pattern.name);
        assert_eq!(took, wait, "{}", pattern.name);
    }
}

/// XON/XOFF: noise holding XOFF (13H) and no XON (11H) after it ends the job with 0708H
/// within the wait time for XON of the last hold; any other noise lets the frame go out. The
/// bound: each character may be held once for up to the wait time (a random XON releases it
/// just before), so the frame time plus one wait per character.
#[test]
fn xon_xoff_ends_every_send_within_one_wait_per_character() {
    let config = with_flow(FlowControl::XonXoff);
    let wait = Duration::from_millis(300);
    let bound = frame_time() + wait.saturating_mul(FRAME.len() as u64 + 1);
    for pattern in patterns() {
        let (took, outcome) = send_into(config, pattern, bound);
        let holds = matches!(pattern.noise, Noise::Flood(Source::Fixed(0x13)));
        if holds {
            assert_eq!(outcome, Err(XON_CTS_TIMEOUT), "{}", pattern.name);
            assert_eq!(took, wait, "{}", pattern.name);
        } else if let Err(status) = outcome {
            assert_eq!(status, XON_CTS_TIMEOUT, "{}", pattern.name);
        }
    }
}

#[test]
fn without_flow_control_noise_cannot_hold_a_send() {
    for pattern in patterns() {
        let (took, outcome) = send_into(Config::default(), pattern, frame_time());
        assert_eq!(outcome, Ok(()), "{}", pattern.name);
        assert_eq!(took, frame_time(), "{}", pattern.name);
    }
}

/// The receiver under 3 s of each pattern, with each end criterion and a maximum of 64 bytes:
/// every receive error carries a STATUS of the manual, no stored frame is longer than the
/// maximum, and the receiver is idle again once the noise stops.
#[test]
fn the_receiver_reports_every_fault_with_a_status_and_stores_no_frame_over_the_maximum() {
    let criteria = [
        EndCriterion::CharDelay,
        EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        EndCriterion::FixedLength { len: 32 },
    ];
    for end in criteria {
        for pattern in patterns() {
            let config = Config {
                end,
                max_frame_len: 64,
                ..Config::default()
            };
            let Facing {
                mut sim,
                engine: link,
                ..
            } = facing(3, line(), Link::new(config).unwrap(), pattern);
            let mut buf = [0u8; 64];
            let mut too_long = 0;
            for _ in 0..30 {
                sim.run_for(Duration::from_millis(100));
                for event in sim.take_events(link) {
                    match event {
                        Event::Received { len, .. } => {
                            assert!(len <= 64, "{end:?} {}: {len}", pattern.name);
                            let n = sim.with(link, |l, now| l.read_frame(now, &mut buf));
                            assert_eq!(n, Some(len), "{end:?} {}", pattern.name);
                        }
                        Event::ReceiveError { status, .. } => {
                            assert!(
                                status.code() != 0 && status.info().is_some(),
                                "{end:?} {}: {status:?}",
                                pattern.name
                            );
                            too_long += usize::from(status == FRAME_TOO_LONG);
                        }
                        other => panic!("{end:?} {}: {other:?}", pattern.name),
                    }
                }
            }
            // 01H never ends a frame by its end characters: the first 65 characters of a
            // flood of it are one frame too long.
            let endless =
                pattern.name == "01H flood" && matches!(end, EndCriterion::EndChars { .. });
            if endless {
                assert!(too_long >= 1, "{end:?} {}", pattern.name);
            }
        }
    }
}

/// An endless frame under the end-character criterion is cut off with 0850H right after its
/// 65th character, not held until the partner stops.
#[test]
fn an_endless_frame_is_cut_off_with_0850h_after_the_maximum_length() {
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        max_frame_len: 64,
        ..Config::default()
    };
    let flood = Pattern {
        name: "01H flood",
        noise: Noise::Flood(Source::Fixed(0x01)),
        until: None,
    };
    let Facing {
        mut sim,
        engine: link,
        ..
    } = facing(1, line(), Link::new(config).unwrap(), flood);
    sim.run_until(Instant::ZERO + line().chars_time(64));
    assert!(sim.take_events(link).is_empty());
    sim.run_until(Instant::ZERO + line().chars_time(66));
    assert!(
        matches!(
            sim.take_events(link)[..],
            [Event::ReceiveError { status, .. }] if status == FRAME_TOO_LONG
        ),
        "0850H after the 65th character"
    );
}
