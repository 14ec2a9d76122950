//! USS: how parameter jobs end and what the line carries around them, counted on
//! the simulated line ([Modbus/USS] §3.7.7, §3.7.8; [USS spec];
//! [MM 420] p. 115, [G120 Fieldbus] §5.3).

use super::{bus, master_config, pair, run_to, s9600};
use si_core::Instant;
use si_sim::{Simulator, StationId, TraceKind};
use si_uss::config::PkwAfterJob;
use si_uss::drive::{Drive, DriveConfig, DriveEvent, Parameter};
use si_uss::frame::{NetData, PkwWords};
use si_uss::master::{comm_status, Event, Master, ParamRequest, RequestError, Width};
use si_uss::status;

/// The master's telegrams on the line, in order.
fn sent(sim: &Simulator) -> Vec<Vec<u8>> {
    sim.trace()
        .of("master")
        .filter_map(|e| match &e.kind {
            TraceKind::Tx { bytes } => Some(bytes.clone()),
            _ => None,
        })
        .collect()
}

/// (AK, PKE PNU bits, IND) of a PKW-4/PZD-2 telegram.
fn pkw_of(telegram: &[u8]) -> (u8, u16, u16) {
    let net = NetData::parse(&telegram[3..telegram.len() - 1], PkwWords::Four, 2).unwrap();
    let p = net.pkw.unwrap();
    (p.pke.ak(), p.pke.pnu(), p.ind)
}

/// A master (WDH = `retries`, `after`) and drive 1 built from `drive`, point to point.
fn pair_with(
    retries: u16,
    after: PkwAfterJob,
    drive: impl FnOnce(&mut DriveConfig),
) -> (Simulator, StationId<Master>, StationId<Drive>) {
    let settings = s9600();
    let mut sim = Simulator::new(5);
    let mut cfg = master_config(settings, &[1], false);
    cfg.retries = retries;
    cfg.pkw_after_job = after;
    let m = sim.add_station("master", settings, Master::new(cfg).unwrap());
    let mut dc = DriveConfig::new(settings, 1);
    drive(&mut dc);
    let d = sim.add_station("drive1", settings, Drive::new(dc).unwrap());
    sim.connect(m, d);
    sim.with(m, |m, now| m.start(now));
    (sim, m, d)
}

/// Enter `request` for node 1 before the first poll, with [`Master::stop_when_idle`], run
/// until the line is quiet; the job's end.
fn last_job(sim: &mut Simulator, m: StationId<Master>, request: ParamRequest) -> Event {
    sim.with(m, |m, now| {
        let job = m.request_parameter(now, 1, request);
        m.stop_when_idle();
        job
    })
    .unwrap();
    let mut end = None;
    while sim.step() {
        end = end.or(sim.take_events(m).into_iter().find(|e| {
            matches!(
                e,
                Event::ParameterDone { .. } | Event::ParameterFailed { .. }
            )
        }));
    }
    end.expect("the job ended")
}

#[test]
fn an_absent_drive_ends_the_job_with_node_does_not_answer_after_1_plus_wdh_telegrams() {
    let (mut sim, m, d) = pair_with(2, PkwAfterJob::TaskZero, |_| {});
    sim.silence(d, Instant::ZERO);
    let end = last_job(&mut sim, m, ParamRequest::read(700, 0));
    assert!(
        matches!(end, Event::ParameterFailed { status: s, error_number: None, .. } if s == status::NO_ANSWER),
        "{end:?}"
    );
    // WDH = 2 repetitions after the first telegram: 3 telegrams, all carrying the job, and no
    // task-0 telegram after it.
    let tx = sent(&sim);
    assert_eq!(tx.len(), 3, "{tx:02X?}");
    assert!(tx.iter().all(|t| pkw_of(t) == (1, 700, 0)), "{tx:02X?}");
    let s = sim.engine(m).slave(1).unwrap();
    assert_ne!(
        s.comm_status & comm_status::PKW_INTERFACE,
        0,
        "[Modbus/USS] §3.7.7 bit 4"
    );
}

#[test]
fn response_id_8_is_a_refusal_with_its_own_code_not_an_absent_node() {
    let (mut sim, m, _) = pair_with(20, PkwAfterJob::TaskZero, |d| d.no_pkw_rights = true);
    let end = last_job(&mut sim, m, ParamRequest::write(1082, 0, 100, Width::Word));
    assert!(
        matches!(end, Event::ParameterFailed { status: s, error_number: None, .. } if s == status::PKW_INTERFACE_ERROR),
        "{end:?}"
    );
    assert_ne!(status::PKW_INTERFACE_ERROR, status::NO_ANSWER);
    assert_eq!(sent(&sim).len(), 1, "the refusal ends the job at once");
}

#[test]
fn response_id_7_carries_the_drives_error_number() {
    let (mut sim, m, _) = pair_with(20, PkwAfterJob::TaskZero, |_| {});
    let end = last_job(&mut sim, m, ParamRequest::write(964, 0, 1, Width::Word));
    assert!(
        matches!(end, Event::ParameterFailed { status: s, error_number: Some(1), .. } if s == status::PKW_ERROR),
        "{end:?}"
    );
}

#[test]
fn a_drive_answering_only_with_a_faulty_telegram_ends_the_job_with_its_code() {
    // WDH = 0: one telegram; its response arrives with a PZD bit inverted (BCC error).
    let (mut sim, m, _) = pair_with(0, PkwAfterJob::TaskZero, |_| {});
    sim.corrupt_received(m, 11, 0x01);
    let end = last_job(&mut sim, m, ParamRequest::read(700, 0));
    assert!(
        matches!(end, Event::ParameterFailed { status: s, .. } if s == status::BCC_ERROR),
        "{end:?}"
    );
    assert_eq!(sent(&sim).len(), 1);
}

#[test]
fn a_run_of_3_cycles_puts_exactly_3_telegrams_per_node_on_the_line() {
    let (mut sim, m, ds) = bus(s9600(), &[1, 2, 3], &[1, 2, 3]);
    sim.silence(ds[1], Instant::ZERO);
    sim.with(m, |m, _| m.stop_after_cycles(3));
    let mut events = Vec::new();
    while sim.step() {
        events.extend(sim.take_events(m));
    }
    let tx = sent(&sim);
    assert_eq!(tx.len(), 9, "{tx:02X?}");
    assert_eq!(sim.engine(m).counters().sent, 9);
    assert!(matches!(events.last(), Some(Event::CycleDone { cycle: 2 })));

    // The case: one node, absent.
    let (mut sim, m, ds) = bus(s9600(), &[1], &[1]);
    sim.silence(ds[0], Instant::ZERO);
    sim.with(m, |m, _| m.stop_after_cycles(3));
    while sim.step() {}
    assert_eq!(sent(&sim).len(), 3);
}

#[test]
fn a_last_job_to_a_present_drive_is_one_telegram() {
    let (mut sim, m, _) = pair(s9600());
    let end = last_job(&mut sim, m, ParamRequest::read(700, 0));
    assert!(matches!(end, Event::ParameterDone { .. }), "{end:?}");
    assert_eq!(sent(&sim).len(), 1);
}

#[test]
fn parameters_above_1999_go_through_the_page_index() {
    let (mut sim, m, d) = pair_with(20, PkwAfterJob::TaskZero, |_| {});
    let end = last_job(
        &mut sim,
        m,
        ParamRequest::write(20001, 0, 4242, Width::Word),
    );
    let Event::ParameterDone { response, .. } = end else {
        panic!("{end:?}")
    };
    // [MM 420] p. 115, [G120 Fieldbus] §5.3: 20000–21999 → page index 50H, PNU 1.
    assert_eq!(pkw_of(&sent(&sim)[0]), (2, 1, 0x5000));
    assert_eq!((response.pke.pnu(), response.ind), (1, 0x5000));
    assert_eq!(sim.engine(d).parameter(20001, 0), Some(4242));

    let r = sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::read(62_000, 0))
    });
    assert_eq!(
        r,
        Err(RequestError::ParameterNumber {
            address: 1,
            number: 62_000
        })
    );
}

/// Every refusal carries a STATUS (`RequestError::status`, reading chosen there), so a
/// status register never shows a made-up code.
#[test]
fn every_refused_job_has_a_status() {
    let (mut sim, m, _) = pair_with(20, PkwAfterJob::TaskZero, |_| {});
    let refuse = |sim: &mut Simulator, address, request| {
        let r = sim.with(m, |m, now| m.request_parameter(now, address, request));
        r.expect_err("refused").status().code()
    };
    // A PNU the page index cannot address, and a node outside the polling list: 16#1E20.
    assert_eq!(refuse(&mut sim, 1, ParamRequest::read(62_000, 0)), 0x1E20);
    assert_eq!(refuse(&mut sim, 9, ParamRequest::read(700, 0)), 0x1E20);
    // Task 15 ([Modbus/USS] §3.7.7 comm status bit 3): 16#1504.
    let text = ParamRequest {
        task: 15,
        ..ParamRequest::read(700, 0)
    };
    assert_eq!(refuse(&mut sim, 1, text), 0x1504);
    // A second job while the node's first runs (one job per slave, [Modbus/USS] §3.7.3): 16#0502.
    sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::read(700, 0))
    })
    .unwrap();
    assert_eq!(refuse(&mut sim, 1, ParamRequest::read(701, 0)), 0x0502);
    // Net data longer than the slave's PZD list: 16#1E41.
    let long = sim.with(m, |m, _| m.set_control(1, &[0; 3]));
    assert_eq!(long.expect_err("too long").status().code(), 0x1E41);
}

#[test]
fn array_writes_use_task_ids_7_and_8() {
    let (mut sim, m, d) = pair_with(20, PkwAfterJob::TaskZero, |d| {
        d.parameters
            .push(Parameter::dword(2050, 0).array(&[0, 0, 0]));
    });
    for (request, task, reply) in [
        (ParamRequest::write_array(2010, 1, 3, Width::Word), 7, 4),
        (
            ParamRequest::write_array(2050, 2, 70_000, Width::DoubleWord),
            8,
            5,
        ),
    ] {
        assert_eq!(request.task, task);
        sim.with(m, |m, now| m.request_parameter(now, 1, request))
            .unwrap();
        let (e, _) = run_to(&mut sim, m, |e| {
            matches!(
                e,
                Event::ParameterDone { .. } | Event::ParameterFailed { .. }
            )
        });
        let Event::ParameterDone { response, .. } = e else {
            panic!("{e:?}")
        };
        assert_eq!(response.pke.ak(), reply);
        assert_eq!(pkw_of(sent(&sim).last().unwrap()).0, task);
    }
    assert_eq!(sim.engine(d).parameter(2010, 1), Some(3));
    assert_eq!(sim.engine(d).parameter(2050, 2), Some(70_000));
}

#[test]
fn signed_words_are_written_and_read_as_twos_complement() {
    let (mut sim, m, d) = pair(s9600());
    let minus5 = u32::from((-5i16) as u16);
    sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::write(1120, 0, minus5, Width::Word))
    })
    .unwrap();
    run_to(&mut sim, m, |e| matches!(e, Event::ParameterDone { .. }));
    assert_eq!(sim.engine(d).parameter(1120, 0), Some(0xFFFB));
    sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::read(1120, 0))
    })
    .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterDone { .. }));
    let Event::ParameterDone { response, .. } = e else {
        unreachable!()
    };
    assert_eq!((response.value(), response.signed_value()), (0xFFFB, -5));
    // −2000 is below the drive's signed limit −1000: AK 7, error 2.
    sim.with(m, |m, now| {
        m.request_parameter(
            now,
            1,
            ParamRequest::write(1120, 0, u32::from((-2000i16) as u16), Width::Word),
        )
    })
    .unwrap();
    let (e, _) = run_to(&mut sim, m, |e| matches!(e, Event::ParameterFailed { .. }));
    assert!(matches!(
        e,
        Event::ParameterFailed {
            error_number: Some(2),
            ..
        }
    ));
}

/// A write, then three more polls: the PKW (AK, PNU) of each telegram and the drive's writes.
fn after_a_write(after: PkwAfterJob) -> (Vec<(u8, u16)>, usize) {
    let (mut sim, m, d) = pair_with(20, after, |_| {});
    sim.with(m, |m, now| {
        m.request_parameter(now, 1, ParamRequest::write(1082, 0, 120, Width::Word))
    })
    .unwrap();
    run_to(&mut sim, m, |e| matches!(e, Event::ParameterDone { .. }));
    sim.with(m, |m, _| m.stop_after_cycles(4));
    while sim.step() {}
    let pkw = sent(&sim)
        .iter()
        .map(|t| {
            let (ak, pnu, _) = pkw_of(t);
            (ak, pnu)
        })
        .collect();
    let writes = sim
        .take_events(d)
        .iter()
        .filter(|e| matches!(e, DriveEvent::Written { .. }))
        .count();
    (pkw, writes)
}

#[test]
fn after_a_job_the_pkw_area_carries_task_0_or_with_repeat_last_the_job_again() {
    // [SINAMICS CU240S] p. 229 (default): AK 0 once the job has ended.
    let (pkw, writes) = after_a_write(PkwAfterJob::TaskZero);
    assert_eq!(pkw, [(2, 1082), (0, 0), (0, 0), (0, 0)]);
    assert_eq!(writes, 1);
    // [Modbus/USS] §3.7.7 (the module's FCs): the last job again and again; the drive
    // answers the repetitions without executing them again.
    let (pkw, writes) = after_a_write(PkwAfterJob::RepeatLast);
    assert_eq!(pkw, [(2, 1082); 4]);
    assert_eq!(writes, 1);
}
