//! Host against module with seeded random DP-cycle lag on both sides, in the 4-, 8- and 32-byte
//! windows ([ET200S SI 2005] §2.12.1–§2.12.7, §2.12.7, §2.12.2, §2.12.3, §2.11 `[derived]`: the DP
//! cycle and the host cycle are asynchronous, so each side sees the other late by a random number
//! of cycles).

use crate::common;

use bytes::Bytes;
use common::{Faults, Link, RunJob};
use si_dp_coord::config::ReceiveErrorPolicy;
use si_dp_coord::host::{HostEvent, Job, Outcome, SubmitError};
use si_dp_coord::status::{INVALID_FRAME_LENGTH, INVALID_LEN, NO_MESSAGE, TRANSFER_ERROR_TO_CPU};
use si_dp_coord::{HostConfig, ModuleConfig, ParamBlock, V24Signals, WindowSize};

fn frame(len: usize, seed: usize) -> Bytes {
    (0..len).map(|i| (i * 31 + seed * 7 + 1) as u8).collect()
}

fn link(window: WindowSize, seed: u64) -> Link {
    common::link(HostConfig::new(window), ModuleConfig::new(window), seed)
}

/// Every frame from 1 byte to the maximum (224) goes host → module → line (loopback) → module
/// buffer → host intact, in every window size.
#[test]
fn section_2_9_every_length_round_trips_in_every_window() {
    for window in WindowSize::ALL {
        let mut l = link(window, 0xD9C0 + window.bytes() as u64);
        for len in 1..=224 {
            let f = frame(len, len);
            assert_eq!(l.run(Job::Send(f.clone()), 20_000), Ok(Outcome::Sent));
            assert_eq!(
                l.module.serial().sent().last(),
                Some(&f),
                "{window} len {len}"
            );
            assert_eq!(
                l.run(Job::Receive, 20_000),
                Ok(Outcome::Received(f)),
                "{window} len {len}"
            );
        }
        assert!(l.failures().is_empty());
        assert_eq!(l.host.stats().resends, 0);
        assert_eq!(l.module.stats().out_of_order, 0);
    }
}

/// The same with the host's automatic receive (S_RCV with EN_R = 1): frames arriving on the line
/// are fetched without explicit jobs, in order.
#[test]
fn auto_receive_fetches_every_line_frame_in_order() {
    for window in WindowSize::ALL {
        let cfg = HostConfig {
            auto_receive: true,
            ..HostConfig::new(window)
        };
        let mut l = common::link(cfg, ModuleConfig::new(window), 77);
        // 900 bytes in all: within the module's 1024-byte buffer.
        let frames: Vec<Bytes> = (0..30).map(|i| frame(1 + i * 2, i)).collect();
        for f in &frames {
            l.module.serial_mut().inject_frame(f.clone());
        }
        assert!(l.run_until(400_000, |l| l.received().len() == frames.len()));
        assert_eq!(l.received(), frames);
        assert!(l.failures().is_empty());
    }
}

/// [ET200S SI 2005] §2.12.7: a send segment arriving out of order makes the module set the error
/// bit with the last valid number; the host resends from the next one and the frame arrives intact.
#[test]
fn section_2_8_out_of_order_send_segments_recover_through_the_error_bit() {
    for window in WindowSize::ALL {
        let mut l = link(window, 4242);
        l.faults = Faults {
            out_of_order_out: 0.2,
            ..Faults::default()
        };
        for (i, len) in [1, 2, 5, 30, 100, 224].into_iter().enumerate() {
            let f = frame(len, i);
            assert_eq!(l.run(Job::Send(f.clone()), 200_000), Ok(Outcome::Sent));
            assert_eq!(l.module.serial().sent().last(), Some(&f));
        }
        assert_eq!(
            l.run(Job::Parameters(ParamBlock::XON_XOFF_DEFAULT), 50_000),
            Ok(Outcome::ParametersSet)
        );
        assert!(l.injected() > 0, "{window}: no fault injected");
        assert!(l.module.stats().out_of_order > 0, "{window}");
        assert!(l.host.stats().resends > 0, "{window}");
        assert!(l.failures().is_empty(), "{window}: {:?}", l.failures());
    }
}

/// [ET200S SI 2005] §2.12.7 / Table 2-21 (default reading): a receive segment out of order makes
/// the host set the error bit; the module aborts with 0551H and offers the frame again, which the
/// automatic receive then fetches intact.
#[test]
fn section_2_8_out_of_order_receive_segments_abort_with_0551_and_reoffer() {
    for window in WindowSize::ALL {
        let cfg = HostConfig {
            auto_receive: true,
            ..HostConfig::new(window)
        };
        let mut l = common::link(cfg, ModuleConfig::new(window), 99);
        l.faults = Faults {
            out_of_order_in: 0.05,
            ..Faults::default()
        };
        let frames: Vec<Bytes> = [1, 3, 8, 40, 120, 224]
            .iter()
            .enumerate()
            .map(|(i, &n)| frame(n, i))
            .collect();
        for f in &frames {
            l.module.serial_mut().inject_frame(f.clone());
        }
        assert!(l.run_until(2_000_000, |l| l.received().len() == frames.len()));
        assert_eq!(l.received(), frames, "{window}");
        assert!(l.host.stats().errors_signalled > 0, "{window}");
        assert!(!l.failures().is_empty());
        assert!(l.failures().iter().all(|s| *s == TRANSFER_ERROR_TO_CPU));
    }
}

/// The alternative reading (the general go-back rule in the receive direction): no job
/// fails, the module resends from the segment after the last valid one.
#[test]
fn section_2_8_receive_go_back_policy_recovers_without_failures() {
    for window in WindowSize::ALL {
        let cfg = HostConfig {
            auto_receive: true,
            ..HostConfig::new(window)
        };
        let mcfg = ModuleConfig {
            receive_error_policy: ReceiveErrorPolicy::GoBack,
            ..ModuleConfig::new(window)
        };
        let mut l = common::link(cfg, mcfg, 1234);
        l.faults = Faults {
            out_of_order_in: 0.1,
            ..Faults::default()
        };
        let frames: Vec<Bytes> = (0..10).map(|i| frame(1 + i * 22, i)).collect();
        for f in &frames {
            l.module.serial_mut().inject_frame(f.clone());
        }
        assert!(l.run_until(2_000_000, |l| l.received().len() == frames.len()));
        assert_eq!(l.received(), frames);
        assert!(l.host.stats().errors_signalled > 0);
        assert!(l.failures().is_empty(), "{:?}", l.failures());
    }
}

/// [ET200S SI 2005] §2.12.1 rule 3: a job that reads the acknowledgement of another job code writes
/// idle, waits for idle and repeats; every job still completes exactly once with the right result.
#[test]
fn section_2_4_conflicting_job_codes_back_off() {
    for window in WindowSize::ALL {
        let mut l = link(window, 555);
        l.faults = Faults {
            foreign_request: 0.3,
            ..Faults::default()
        };
        l.module.serial_mut().inputs = V24Signals {
            dcd: true,
            ..V24Signals::default()
        };
        for i in 0..20 {
            let f = frame(10 + i * 7, i);
            assert_eq!(l.run(Job::Send(f.clone()), 200_000), Ok(Outcome::Sent));
            assert_eq!(
                l.run(Job::Receive, 200_000),
                Ok(Outcome::Received(f.clone()))
            );
            let Ok(Outcome::Signals(s)) = l.run(Job::ReadV24, 200_000) else {
                panic!("read V.24 failed");
            };
            assert!(s.dcd);
        }
        assert!(l.backoffs() > 0, "{window}: no back-off");
        assert_eq!(l.host.stats().backoffs as usize, l.backoffs());
        assert!(l.failures().is_empty(), "{:?}", l.failures());
        let first_backoff = l
            .events()
            .iter()
            .find(|e| matches!(e, HostEvent::BackedOff { .. }))
            .unwrap();
        let HostEvent::BackedOff { seen, .. } = first_backoff else {
            unreachable!()
        };
        assert!(matches!(
            seen.job,
            si_dp_coord::JobCode::ReadV24 | si_dp_coord::JobCode::WriteV24
        ));
    }
}

/// [ET200S SI 2005] §2.12.7 case 1: a send longer than the maximum is refused by the module with
/// the end-of-job acknowledgement and 050EH (the host's own LEN check is relaxed to get it there).
/// With the default host the FB-level check refuses it first with 1E41H.
#[test]
fn section_2_8_frame_over_the_maximum_is_refused_with_050e() {
    for window in WindowSize::ALL {
        let host = HostConfig {
            max_frame_len: 1000,
            ..HostConfig::new(window)
        };
        let mut l = common::link(host, ModuleConfig::new(window), 9);
        for len in [225, 226, 400, 1000] {
            assert_eq!(
                l.run(Job::Send(frame(len, 0)), 50_000),
                Err(INVALID_FRAME_LENGTH),
                "{window} len {len}"
            );
        }
        // The module is usable again right after.
        let f = frame(224, 3);
        assert_eq!(l.run(Job::Send(f.clone()), 50_000), Ok(Outcome::Sent));
        assert_eq!(l.module.serial().sent().count(), 1);

        let mut l = link(window, 10);
        let err = l.host.submit(Job::Send(frame(225, 0))).unwrap_err();
        assert_eq!(err, SubmitError::InvalidLength { len: 225, max: 224 });
        assert_eq!(err.status(), INVALID_LEN);
        assert!(l.host.submit(Job::Send(Bytes::new())).is_err());
    }
}

/// [ET200S SI 2005] §2.12.7 case 3: a receive job with nothing buffered is answered 20H + 0101H,
/// "not an error". Case 2: a buffered receive error is delivered as 20H + its STATUS.
#[test]
fn section_2_8_receive_without_message_and_with_erroneous_frame() {
    for window in WindowSize::ALL {
        let mut l = link(window, 3);
        assert_eq!(l.run(Job::Receive, 10_000), Ok(Outcome::NoMessage));
        let bcc = si_core::Status::from_code(0x0808);
        l.module.serial_mut().inject_error(bcc);
        l.module.serial_mut().inject_frame(&b"ok"[..]);
        assert_eq!(l.run(Job::Receive, 10_000), Err(bcc));
        assert_eq!(
            l.run(Job::Receive, 10_000),
            Ok(Outcome::Received(Bytes::from_static(b"ok")))
        );
        assert_eq!(l.run(Job::Receive, 10_000), Ok(Outcome::NoMessage));
        assert_eq!(NO_MESSAGE.code(), 0x0101);
    }
}

/// Write V.24 then read V.24 through the module: RTS and DTR come back as set (§2.12.4/§2.12.5).
#[test]
fn section_2_7_write_then_read_v24() {
    for window in WindowSize::ALL {
        let mut l = link(window, 21);
        for (rts, dtr) in [(true, false), (false, true), (true, true), (false, false)] {
            assert_eq!(
                l.run(Job::WriteV24 { rts, dtr }, 10_000),
                Ok(Outcome::SignalsWritten)
            );
            let Ok(Outcome::Signals(s)) = l.run(Job::ReadV24, 10_000) else {
                panic!("read V.24 failed")
            };
            assert_eq!((s.rts, s.dtr), (rts, dtr));
        }
    }
}

/// Table 2-27 / [ET200S SI 2005] §2.12.2–§2.12.6 `[derived]`: a block of another flow-control type
/// than configured gets 0550H.
#[test]
fn section_2_6_parameter_block_mismatch_is_0550() {
    let mut l = link(WindowSize::Eight, 5);
    assert_eq!(
        l.run(Job::Parameters(ParamBlock::RTS_CTS_DEFAULT), 10_000),
        Err(si_dp_coord::status::FLOW_CONTROL_MISMATCH)
    );
    assert_eq!(
        l.run(Job::Parameters(ParamBlock::XON_XOFF_DEFAULT), 10_000),
        Ok(Outcome::ParametersSet)
    );
}

/// A send the line fails reports the line's STATUS in the end-of-job acknowledgement.
#[test]
fn send_failure_on_the_line_is_reported_in_7x() {
    let mut l = link(WindowSize::Eight, 6);
    let qvz = si_core::Status::from_code(0x0703);
    l.module.serial_mut().fail_next_send = Some(qvz);
    assert_eq!(l.run(Job::Send(frame(50, 1)), 10_000), Err(qvz));
    assert_eq!(l.run(Job::Send(frame(50, 2)), 10_000), Ok(Outcome::Sent));
}

/// A frame longer than the host may hold (its `max_frame_len` below the module's) is read to
/// its end and dropped with 0850H, so the module does not offer it forever; the next one arrives.
#[test]
fn frame_longer_than_the_host_holds_is_dropped_with_0850() {
    for window in WindowSize::ALL {
        let host = HostConfig {
            max_frame_len: 10,
            ..HostConfig::new(window)
        };
        let mut l = common::link(host, ModuleConfig::new(window), 31);
        l.module.serial_mut().inject_frame(frame(50, 1));
        l.module.serial_mut().inject_frame(frame(10, 2));
        assert_eq!(
            l.run(Job::Receive, 50_000),
            Err(si_dp_coord::status::RECEIVED_FRAME_TOO_LONG)
        );
        assert_eq!(
            l.run(Job::Receive, 50_000),
            Ok(Outcome::Received(frame(10, 2)))
        );
        assert_eq!(l.module.buffered(), 0);
    }
}
