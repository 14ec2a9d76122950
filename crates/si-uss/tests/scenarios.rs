//! Scenario tests on the line simulator, named after the manual section they prove
//! ([Modbus/USS] §3.7, [USS spec]).

#[path = "scenarios/fb.rs"]
mod fb;
#[path = "scenarios/fifo_uart.rs"]
mod fifo_uart;
#[path = "scenarios/frame_golden.rs"]
mod frame_golden;
#[path = "scenarios/param_pke.rs"]
mod param_pke;
#[path = "scenarios/pkw_jobs.rs"]
mod pkw_jobs;
#[path = "scenarios/tokio_duplex.rs"]
mod tokio_duplex;
#[path = "scenarios/usb_adapter.rs"]
mod usb_adapter;

use si_core::{Duration, Engine, Instant, LineError, Output, SerialSettings};
use si_sim::{Simulator, StationId, TraceKind};
use si_uss::config::{residual_run_time, start_interval, uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{stw, zsw, Drive, DriveConfig, DriveEvent};
use si_uss::frame::{self, Adr, DecodeError, PkwWords, MAX_TELEGRAM};
use si_uss::master::{comm_error, comm_status, Event, Master, ParamRequest, Width};
use si_uss::status;

type M = StationId<Master>;
type D = StationId<Drive>;

fn master_config(settings: SerialSettings, addresses: &[u8], echo: bool) -> MasterConfig {
    let mut c = MasterConfig::new(
        addresses
            .iter()
            .map(|&a| PollEntry::new(a, PkwWords::Four, 2))
            .collect(),
    );
    c.settings = settings;
    c.local_echo = echo;
    c
}

/// A master and drives on one RS-485 bus (everybody hears their own echo).
fn bus(settings: SerialSettings, polled: &[u8], drives: &[u8]) -> (Simulator, M, Vec<D>) {
    let mut sim = Simulator::new(7);
    let m = sim.add_station(
        "master",
        settings,
        Master::new(master_config(settings, polled, true)).unwrap(),
    );
    let mut ids = vec![m.index()];
    let ds: Vec<D> = drives
        .iter()
        .map(|&a| {
            let cfg = DriveConfig {
                local_echo: true,
                ..DriveConfig::new(settings, a)
            };
            let d = sim.add_station(&format!("drive{a}"), settings, Drive::new(cfg).unwrap());
            ids.push(d.index());
            d
        })
        .collect();
    sim.bus(&ids);
    sim.with(m, |m, now| m.start(now));
    (sim, m, ds)
}

/// A master and one drive point to point (no echo).
fn pair(settings: SerialSettings) -> (Simulator, M, D) {
    let mut sim = Simulator::new(3);
    let m = sim.add_station(
        "master",
        settings,
        Master::new(master_config(settings, &[1], false)).unwrap(),
    );
    let d = sim.add_station(
        "drive1",
        settings,
        Drive::new(DriveConfig::new(settings, 1)).unwrap(),
    );
    sim.connect(m, d);
    sim.with(m, |m, now| m.start(now));
    (sim, m, d)
}

fn s9600() -> SerialSettings {
    uss_settings(9_600).unwrap()
}

/// Run until the master reports an event matching `want`; returns it and the time.
fn run_to(sim: &mut Simulator, m: M, want: impl Fn(&Event) -> bool) -> (Event, Instant) {
    for _ in 0..1_000_000 {
        assert!(sim.step(), "simulation went quiet");
        if let Some(e) = sim.take_events(m).into_iter().find(|e| want(e)) {
            return (e, sim.now());
        }
    }
    panic!("event never came");
}

#[test]
fn s6_1_polling_cycle_goes_on_past_a_silent_slave() {
    let (mut sim, m, ds) = bus(s9600(), &[1, 2, 3], &[1, 2, 3]);
    sim.silence(ds[1], Instant::ZERO);
    let mut events = Vec::new();
    while sim.engine(m).cycle() < 3 {
        assert!(sim.step());
        events.extend(sim.take_events(m));
    }
    let summary: Vec<String> = events
        .iter()
        .map(|e| match e {
            Event::Response { cycle, address, .. } => format!("{cycle}:ok{address}"),
            Event::NoAnswer { cycle, address } => format!("{cycle}:none{address}"),
            Event::CycleDone { cycle } => format!("{cycle}:done"),
            other => format!("{other:?}"),
        })
        .collect();
    assert_eq!(
        summary,
        [
            "0:ok1", "0:none2", "0:ok3", "0:done", "1:ok1", "1:none2", "1:ok3", "1:done", "2:ok1",
            "2:none2", "2:ok3", "2:done"
        ]
    );
    let master = sim.engine(m);
    let silent = master.slave(2).unwrap();
    assert_eq!(silent.comm_error, comm_error::MONITORING_TIME);
    assert_ne!(silent.comm_status & comm_status::GROUP_ERROR, 0);
    assert_eq!(silent.last_status, status::NO_ANSWER);
    assert_eq!(silent.failed, 3);
    let good = master.slave(3).unwrap();
    assert_eq!(
        (good.comm_error, good.comm_status & comm_status::GROUP_ERROR),
        (0, 0)
    );
    assert_eq!(
        good.status_word().unwrap() & zsw::PLC_REQUESTED,
        zsw::PLC_REQUESTED
    );
    let c = master.counters();
    assert_eq!((c.no_answer, c.ok, c.sent, c.cycles), (3, 6, 9, 3));
    assert_eq!(c.rejected, 0);
}

#[test]
fn s6_1_node_does_not_answer_after_exactly_20_ms_from_the_request_end() {
    let (mut sim, m, ds) = bus(s9600(), &[2], &[2]);
    sim.silence(ds[0], Instant::ZERO);
    let (_, at) = run_to(&mut sim, m, |e| matches!(e, Event::NoAnswer { .. }));
    let tx = sim
        .trace()
        .of("master")
        .find_map(|e| match &e.kind {
            TraceKind::Tx { bytes } => Some((e.at, bytes.len())),
            _ => None,
        })
        .unwrap();
    let request_end = tx.0 + s9600().chars_time(tx.1 as u64);
    assert_eq!(at, request_end + Duration::from_millis(20));
}

#[test]
fn s6_8_a_slave_listed_twice_is_polled_twice_per_cycle() {
    let (mut sim, m, _) = bus(s9600(), &[1, 2, 1], &[1, 2]);
    let mut order = Vec::new();
    while sim.engine(m).cycle() < 1 {
        assert!(sim.step());
        for e in sim.take_events(m) {
            if let Event::Response { address, .. } = e {
                order.push(address);
            }
        }
    }
    assert_eq!(order, [1, 2, 1]);
}

#[test]
fn s3_corrupted_response_is_discarded_by_bcc_and_the_next_cycle_recovers() {
    let (mut sim, m, _) = pair(s9600());
    // Byte 11 of the first response (a PZD byte) arrives with bit 0 inverted.
    sim.corrupt_received(m, 11, 0x01);
    let (e, _) = run_to(&mut sim, m, |e| !matches!(e, Event::CycleDone { .. }));
    match e {
        Event::Rejected {
            status: s,
            error: Some(DecodeError::Bcc { offset: 15, .. }),
            address: 1,
            ..
        } => assert_eq!(s, status::BCC_ERROR),
        other => panic!("expected a BCC rejection, got {other:?}"),
    }
    let slave = sim.engine(m).slave(1).unwrap();
    assert_eq!(slave.comm_error, comm_error::BCC);
    assert_eq!(sim.engine(m).counters().bcc, 1);
    let (e, _) = run_to(&mut sim, m, |e| !matches!(e, Event::CycleDone { .. }));
    assert!(matches!(e, Event::Response { cycle: 1, .. }), "{e:?}");
    assert_eq!(sim.engine(m).slave(1).unwrap().comm_error, 0);
}

#[test]
fn s3_corrupted_request_is_discarded_by_the_drive_which_does_not_answer() {
    let (mut sim, m, d) = pair(s9600());
    sim.corrupt_received(d, 4, 0x80);
    let (e, _) = run_to(&mut sim, m, |e| !matches!(e, Event::CycleDone { .. }));
    assert_eq!(
        e,
        Event::NoAnswer {
            cycle: 0,
            address: 1
        }
    );
    assert!(sim.take_events(d).contains(&DriveEvent::Discarded {
        reason: "BCC, LGE or STX error"
    }));
}

#[test]
fn s6_7_pkw_read_and_write_complete_with_matching_responses() {
    let (mut sim, m, d) = pair(s9600());
    let job = sim
        .with(m, |m, now| {
            m.request_parameter(now, 1, ParamRequest::read(700, 0))
        })
        .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterDone { .. }));
    let Event::ParameterDone {
        job: j,
        response,
        address: 1,
    } = e
    else {
        panic!("{e:?}")
    };
    assert_eq!(
        (j, response.pke.ak(), response.pke.pnu(), response.value()),
        (job, 1, 700, 5)
    );
    let s = sim.engine(m).slave(1).unwrap();
    assert_eq!(s.comm_status & 0x7, comm_status::PKW_DONE);

    sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::write(1082, 0, 100, Width::Word))
    })
    .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterDone { .. }));
    assert!(matches!(e, Event::ParameterDone { response, .. } if response.value() == 100));
    assert_eq!(sim.engine(d).parameter(1082, 0), Some(100));

    // Double word above 2000: page bits in IND.
    sim.with(m, |m, now| {
        m.request_parameter(
            now,
            1,
            ParamRequest::write(2000, 0, 123_456, Width::DoubleWord),
        )
    })
    .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterDone { .. }));
    assert!(
        matches!(e, Event::ParameterDone { response, .. } if response.pke.ak() == 2 && response.ind == 0x8000)
    );
    assert_eq!(sim.engine(d).parameter(2000, 0), Some(123_456));

    // Array element of P2010: PKE PNU 10, IND page bit 80H and sub-index 1.
    sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::read_array(2010, 1))
    })
    .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterDone { .. }));
    assert!(
        matches!(e, Event::ParameterDone { response, .. } if response.pke.ak() == 4 && response.pke.pnu() == 10 && response.ind == 0x8001 && response.value() == 6),
        "{e:?}"
    );
    // After the job the PKW area carries AK 0 again.
    run_to(&mut sim, m, |e| matches!(e, Event::Response { .. }));
    let last_tx = sim
        .trace()
        .of("master")
        .filter_map(|e| match &e.kind {
            TraceKind::Tx { bytes } => Some(bytes.clone()),
            _ => None,
        })
        .last()
        .unwrap();
    assert_eq!(&last_tx[3..5], &[0x00, 0x00]);
}

#[test]
fn s6_7_ak7_errors_carry_their_numbers_and_set_status_bit_2() {
    let (mut sim, m, d) = pair(s9600());
    for (request, number) in [
        (ParamRequest::write(1082, 0, 1000, Width::Word), 2), // limit
        (ParamRequest::read(999, 0), 0),                      // no such parameter
        (ParamRequest::write(964, 0, 1, Width::Word), 1),     // read-only
        (ParamRequest::read_array(700, 0), 4),                // no array
    ] {
        sim.with(m, |m, now| m.request_parameter(now, 1, request))
            .unwrap();
        let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterFailed { .. }));
        match e {
            Event::ParameterFailed {
                status: s,
                error_number,
                ..
            } => {
                assert_eq!(s, status::PKW_ERROR);
                assert_eq!(error_number, Some(number), "{request:?}");
            }
            other => panic!("{other:?}"),
        }
        let cs = sim.engine(m).slave(1).unwrap().comm_status;
        assert_eq!(cs & 0x7, comm_status::PKW_ERROR);
    }
    assert_eq!(sim.engine(d).parameter(1082, 0), Some(50));
    assert_eq!(sim.engine(m).counters().pkw_failed, 4);
}

#[test]
fn s6_7_invalid_task_sets_status_bit_3_and_is_refused() {
    let (mut sim, m, _) = pair(s9600());
    let r = sim.with(m, |m, now| {
        m.request_parameter(
            now,
            1,
            ParamRequest {
                task: frame::task::READ_DESCRIPTION,
                ..ParamRequest::read(700, 255)
            },
        )
    });
    assert!(r.is_err());
    assert_ne!(
        sim.engine(m).slave(1).unwrap().comm_status & comm_status::PKW_INVALID,
        0
    );
    let r = sim.with(m, |m, now| {
        m.request_parameter(now, 9, ParamRequest::read(1, 0))
    });
    assert!(r.is_err());
}

/// The manual's invalid request IDs (15; 4 with index 255) and the reserved ID 10, refused
/// here as a `[derived]` reading (the USS task-ID table reserves it): each sets status bit 3
/// and reports 1504H; task 9, its neighbour, is accepted.
#[test]
fn s6_7_task_ids_15_and_reserved_10_are_refused_with_1504() {
    let (mut sim, m, _) = pair(s9600());
    for task in [frame::task::TEXT, 10] {
        let r = sim.with(m, |m, now| {
            m.request_parameter(
                now,
                1,
                ParamRequest {
                    task,
                    ..ParamRequest::read(700, 0)
                },
            )
        });
        let e = r.unwrap_err();
        assert_eq!(e.status(), status::PKW_INVALID_TASK, "task {task}");
        let cs = sim.engine(m).slave(1).unwrap().comm_status;
        assert_ne!(cs & comm_status::PKW_INVALID, 0, "task {task}");
    }
    let r = sim.with(m, |m, now| {
        m.request_parameter(
            now,
            1,
            ParamRequest {
                task: frame::task::READ_ARRAY_LEN,
                ..ParamRequest::read(700, 0)
            },
        )
    });
    assert!(r.is_ok());
}

#[test]
fn s6_8_wdh_repetitions_exceeded_is_a_pkw_interface_error() {
    let settings = s9600();
    let mut sim = Simulator::new(1);
    let mut cfg = master_config(settings, &[1], false);
    cfg.retries = 2;
    let m = sim.add_station("master", settings, Master::new(cfg).unwrap());
    let d = sim.add_station(
        "drive1",
        settings,
        Drive::new(DriveConfig::new(settings, 1)).unwrap(),
    );
    sim.connect(m, d);
    sim.silence(d, Instant::ZERO);
    sim.with(m, |m, now| m.start(now));
    sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::read(700, 0))
    })
    .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterFailed { .. }));
    assert!(
        matches!(e, Event::ParameterFailed { status: s, error_number: None, .. } if s == status::NO_ANSWER),
        "a silent drive is an absent node, not a refusal: {e:?}"
    );
    let master = sim.engine(m);
    assert_eq!(
        master.slave(1).unwrap().failed,
        3,
        "first send + 2 repetitions"
    );
    assert_eq!(master.counters().pkw_repeats, 2);
    assert_ne!(
        master.slave(1).unwrap().comm_status & comm_status::PKW_INTERFACE,
        0
    );
}

#[test]
fn s3_broadcast_reaches_every_drive_unanswered_and_mirror_comes_back_unchanged() {
    let (mut sim, m, ds) = bus(s9600(), &[1, 2], &[1, 2]);
    let mut net = [0u8; 12];
    net[8..10].copy_from_slice(&stw::RUN.to_be_bytes());
    net[10..12].copy_from_slice(&3000u16.to_be_bytes());
    let b = sim.with(m, |m, now| m.broadcast(now, &net)).unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::BroadcastDone { .. }));
    assert_eq!(e, Event::BroadcastDone { job: b });
    sim.run_for(Duration::from_millis(30));
    for d in &ds {
        assert!(sim.take_events(*d).contains(&DriveEvent::Broadcast));
    }
    let adrs: Vec<u8> = sim
        .trace()
        .of("master")
        .filter_map(|e| match &e.kind {
            TraceKind::Tx { bytes } => Some(bytes[2]),
            _ => None,
        })
        .collect();
    assert!(adrs.contains(&0x20));

    let job = sim
        .with(m, |m, now| m.mirror(now, 2, &[0xDE, 0xAD, 0xBE, 0xEF]))
        .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| {
        matches!(e, Event::MirrorDone { .. } | Event::MirrorFailed { .. })
    });
    assert_eq!(e, Event::MirrorDone { job, address: 2 });
    assert!(sim.take_events(ds[1]).contains(&DriveEvent::Mirrored));

    sim.silence(ds[0], sim.now());
    let job = sim.with(m, |m, now| m.mirror(now, 1, &[1])).unwrap();
    let (e, _) = run_to(&mut sim, m, |e| {
        matches!(e, Event::MirrorDone { .. } | Event::MirrorFailed { .. })
    });
    assert_eq!(
        e,
        Event::MirrorFailed {
            job,
            address: 1,
            status: status::NO_ANSWER
        }
    );
}

#[test]
fn drive_status_word_follows_the_control_word_and_the_actual_value_ramps() {
    let (mut sim, m, _) = pair(s9600());
    sim.with(m, |m, _| m.set_control(1, &[stw::RUN, 3000]))
        .unwrap();
    let mut actuals = Vec::new();
    let mut last_zsw = 0;
    while actuals.last() != Some(&3000) {
        let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::Response { .. }));
        if let Event::Response { net, .. } = e {
            last_zsw = net.pzd.first().unwrap();
            assert_ne!(last_zsw & zsw::RUNNING, 0);
            actuals.push(net.pzd.second().unwrap());
        }
        assert!(actuals.len() < 100, "{actuals:?}");
    }
    assert!(actuals.windows(2).all(|w| w[0] <= w[1]), "{actuals:?}");
    assert!(actuals.len() > 3, "ramps over several cycles: {actuals:?}");
    assert_ne!(last_zsw & zsw::SETPOINT_REACHED, 0);
    let cs = sim.engine(m).slave(1).unwrap().comm_status;
    assert_ne!(cs & comm_status::PLC_CONTROL, 0, "ZSW bit 9 and STW bit 10");
    // Stop: the status word drops RUNNING and the actual value ramps down.
    sim.with(m, |m, _| m.set_control(1, &[stw::STOP, 3000]))
        .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::Response { .. }));
    let Event::Response { net, .. } = e else {
        unreachable!()
    };
    assert_eq!(net.pzd.first().unwrap() & zsw::RUNNING, 0);
}

#[test]
fn a_break_during_a_response_is_counted_and_the_cycle_goes_on() {
    let (mut sim, m, _) = pair(s9600());
    // The first response arrives around 20 ms; a BREAK in the middle of it.
    sim.schedule_break(m, Instant::from_micros(30_000));
    sim.run_until(Instant::from_micros(400_000));
    let c = *sim.engine(m).counters();
    assert_eq!(c.breaks, 1);
    assert!(c.ok >= 5);
}

/// A station that does nothing, for scripted bytes.
struct Script;
impl Engine for Script {
    type Event = ();
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
    fn handle_timeout(&mut self, _: Instant) {}
    fn handle_line_error(&mut self, _: Instant, _: LineError) {}
    fn poll_output(&mut self) -> Output<()> {
        Output::Wait(None)
    }
}

fn timing_at(baud: u32) {
    let settings = uss_settings(baud).unwrap();
    let t = settings.char_time();
    let si = start_interval(&settings);
    assert_eq!(si, settings.chars_time(2));

    // Start interval: between a response's last character and the next request's first, and
    // between a request's last character and the drive's response.
    let (mut sim, m, _) = pair(settings);
    sim.run_until(Instant::from_micros(200_000));
    let entries = &sim.trace().entries;
    let mut checked = 0;
    for (i, e) in entries.iter().enumerate() {
        let TraceKind::Tx { .. } = e.kind else {
            continue;
        };
        let receiver = &e.station;
        // The last character this station received before transmitting.
        let last_rx = entries[..i]
            .iter()
            .rev()
            .find(|p| &p.station == receiver && matches!(p.kind, TraceKind::Rx { .. }));
        if let Some(p) = last_rx {
            assert_eq!(e.at - p.at, si, "{receiver} at {}", e.at);
            checked += 1;
        }
    }
    assert!(checked > 6, "checked {checked}");
    let c = sim.engine(m).counters();
    assert_eq!(c.no_answer + c.rejected, 0);

    // Residual run time: a slave that pauses inside its response.
    let mut sim = Simulator::new(5);
    let m = sim.add_station(
        "master",
        settings,
        Master::new(master_config(settings, &[1], false)).unwrap(),
    );
    let s = sim.add_station("script", settings, Script);
    sim.connect(m, s);
    sim.with(m, |m, now| m.start(now));
    let request_end = si + settings.chars_time(16);
    sim.run_until(Instant::ZERO + request_end + si);
    let mut reply = [0u8; MAX_TELEGRAM];
    let n = frame::encode(Adr(1), &[0u8; 12], &mut reply).unwrap();
    sim.transmit(s, &reply[..3]);
    let stx_at = sim.now() + t;
    // The rest comes after a pause that pushes the end past 1.5 × (n + 3) character times.
    sim.run_for(residual_run_time(&settings, 12));
    sim.transmit(s, &reply[3..n]);
    let (e, at) = run_to(&mut sim, m, |e| matches!(e, Event::Rejected { .. }));
    assert!(
        matches!(e, Event::Rejected { status: s, .. } if s == status::RESIDUAL_TIME),
        "{e:?}"
    );
    assert_eq!(at, stx_at + residual_run_time(&settings, 12));
    assert_eq!(
        sim.engine(m).slave(1).unwrap().comm_error,
        comm_error::MONITORING_TIME
    );
    assert_eq!(sim.engine(m).counters().residual_time, 1);
}

#[test]
fn public_facts_3_start_interval_and_residual_run_time_at_9600() {
    timing_at(9_600);
}

#[test]
fn public_facts_3_start_interval_and_residual_run_time_at_187500() {
    timing_at(187_500);
}

#[test]
fn a_stray_telegram_between_polls_delays_the_next_request_without_spinning() {
    // A scripted partner starts a long telegram right after the master's cycle pause began and
    // stops sending: the master waits for the residual run time, counts the stray telegram and
    // goes on; it never asks to be woken at an instant already past (a busy loop).
    let settings = s9600();
    let mut sim = Simulator::new(9);
    let mut cfg = master_config(settings, &[1], false);
    cfg.cycle_pause = Duration::from_millis(50);
    let m = sim.add_station("master", settings, Master::new(cfg).unwrap());
    let s = sim.add_station("script", settings, Script);
    sim.connect(m, s);
    sim.with(m, |m, now| m.start(now));
    let (e, at) = run_to(&mut sim, m, |e| matches!(e, Event::NoAnswer { .. }));
    assert!(matches!(e, Event::NoAnswer { cycle: 0, .. }));
    // STX, LGE 254 (the longest telegram, residual run time 1.5 × 255 characters ≈ 438 ms),
    // ADR, a few bytes, then nothing: the telegram is still "being received" when the pause ends.
    sim.run_until(at + Duration::from_millis(5));
    sim.transmit(s, &[0x02, 0xFE, 0x01, 0, 0, 0, 0]);
    let mut steps = 0;
    while sim.engine(m).counters().sent < 3 {
        assert!(sim.step());
        steps += 1;
        assert!(steps < 10_000, "spinning");
    }
    let c = sim.engine(m).counters();
    assert_eq!(c.residual_time, 1, "the stretched stray telegram");
}

#[test]
fn a_drive_with_the_wrong_parity_is_heard_as_framing_errors_and_counted() {
    let settings = s9600();
    let odd = SerialSettings::with_rates(
        9_600,
        8,
        si_core::Parity::Odd,
        1,
        &si_uss::config::USS_BAUD_RATES,
    )
    .unwrap();
    let mut sim = Simulator::new(2);
    let m = sim.add_station(
        "master",
        settings,
        Master::new(master_config(settings, &[1], false)).unwrap(),
    );
    let d = sim.add_station("drive1", odd, Drive::new(DriveConfig::new(odd, 1)).unwrap());
    sim.connect(m, d);
    sim.with(m, |m, now| m.start(now));
    let (e, _) = run_to(&mut sim, m, |e| !matches!(e, Event::CycleDone { .. }));
    // The drive hears only framing errors too, so it never answers.
    assert_eq!(
        e,
        Event::NoAnswer {
            cycle: 0,
            address: 1
        }
    );
    assert!(sim.take_events(d).is_empty());
    let c = sim.engine(m).counters();
    assert_eq!((c.framing, c.ok), (0, 0));
    // Now a scripted partner with the wrong parity answers: every character is a framing error.
    let mut sim = Simulator::new(2);
    let m = sim.add_station(
        "master",
        settings,
        Master::new(master_config(settings, &[1], false)).unwrap(),
    );
    let s = sim.add_station("script", odd, Script);
    sim.connect(m, s);
    sim.with(m, |m, now| m.start(now));
    sim.run_until(Instant::from_micros(25_000));
    sim.transmit(s, &[0x02, 0x0E, 0x01, 0, 0, 0]);
    let (e, _) = run_to(&mut sim, m, |e| !matches!(e, Event::CycleDone { .. }));
    assert_eq!(
        e,
        Event::NoAnswer {
            cycle: 0,
            address: 1
        }
    );
    assert_eq!(sim.engine(m).counters().framing, 6);
}

#[test]
fn stop_ends_a_running_parameter_job_exactly_once() {
    let (mut sim, m, d) = pair(s9600());
    sim.silence(d, Instant::ZERO);
    let job = sim
        .with(m, |m, now| {
            m.request_parameter(now, 1, ParamRequest::read(700, 0))
        })
        .unwrap();
    sim.run_for(Duration::from_millis(50));
    sim.with(m, |m, now| m.stop(now));
    sim.run_for(Duration::from_millis(500));
    let ends: Vec<Event> = sim
        .take_events(m)
        .into_iter()
        .filter(|e| {
            matches!(
                e,
                Event::ParameterDone { .. } | Event::ParameterFailed { .. }
            )
        })
        .collect();
    assert_eq!(
        ends,
        [Event::ParameterFailed {
            job,
            address: 1,
            status: si_core::status::common::ABORTED_BY_RESET,
            error_number: None
        }]
    );
    assert_eq!(sim.engine(m).counters().sent, 2, "nothing sent after stop");
}

#[test]
fn s6_7_parameter_change_report_sets_bit_5_once_until_acknowledged_by_the_toggle_bit() {
    let (mut sim, m, d) = pair(s9600());
    run_to(&mut sim, m, |e| matches!(e, Event::CycleDone { cycle: 1 }));
    assert!(sim.with(d, |d, _| d.change_locally(1082, 0, 77)));
    for _ in 0..5 {
        run_to(&mut sim, m, |e| matches!(e, Event::CycleDone { .. }));
    }
    let reports = sim
        .trace()
        .of("master")
        .filter(
            |e| matches!(&e.kind, TraceKind::Event { text } if text.starts_with("ChangeReport")),
        )
        .count();
    assert_eq!(reports, 1, "reported once while repeated");
    let s = sim.engine(m).slave(1).unwrap();
    assert_ne!(s.comm_status & comm_status::CHANGE_REPORT, 0);
    let r = s.pkw_response.unwrap();
    assert_eq!(
        (r.pke.ak(), r.pke.spm(), r.pke.pnu(), r.value()),
        (9, true, 1082, 77)
    );

    sim.with(m, |m, _| m.acknowledge_change_report(1)).unwrap();
    for _ in 0..3 {
        run_to(&mut sim, m, |e| matches!(e, Event::CycleDone { .. }));
    }
    let s = sim.engine(m).slave(1).unwrap();
    assert_eq!(s.comm_status & comm_status::CHANGE_REPORT, 0);
    assert_eq!(
        s.pkw_response.unwrap().pke.ak(),
        0,
        "the drive took the acknowledgement"
    );

    // The next report flips the toggle bit and is reported again.
    sim.with(d, |d, _| d.change_locally(700, 0, 2));
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ChangeReport { .. }));
    let Event::ChangeReport { report, .. } = e else {
        unreachable!()
    };
    assert_eq!(
        (report.pke.spm(), report.pke.pnu(), report.value()),
        (false, 700, 2)
    );
}
