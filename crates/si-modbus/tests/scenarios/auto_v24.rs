//! Automatic use of the V.24 signals ([Modbus/USS] §3.2.2) around the master's requests
//! and the slave's responses: DTR = ON and RTS = OFF on entering the mode, RTS = ON and the data
//! at CTS = ON, 0818H when CTS does not come within the data output wait time, RTS = OFF after the
//! RTS-off time, and nothing received while DSR = OFF. The engines are driven by hand so every
//! signal change is placed exactly.

use si_core::v24::AutoV24Times;
use si_core::{Duration, Engine, Instant, ModemSignals, Output, SignalUpdate};
use si_modbus::config::LineConfig;
use si_modbus::frame::crc16;
use si_modbus::master::{Master, MasterEvent};
use si_modbus::slave::{Slave, SlaveEvent, Tables};
use si_modbus::{status, MasterConfig, Request, SlaveConfig};

/// What an engine put out after one input, in order.
#[derive(Debug, PartialEq)]
enum Out<E> {
    Tx(Vec<u8>),
    Rts(bool),
    Dtr(bool),
    Event(E),
}

fn drain<E: Engine>(engine: &mut E) -> Vec<Out<E::Event>> {
    let mut outs = Vec::new();
    loop {
        match engine.poll_output() {
            Output::Transmit(b) => outs.push(Out::Tx(b.to_vec())),
            Output::SetSignals(SignalUpdate { dtr, rts }) => {
                outs.extend(dtr.map(Out::Dtr));
                outs.extend(rts.map(Out::Rts));
            }
            Output::Event(e) => outs.push(Out::Event(e)),
            Output::Wait(_) => return outs,
        }
    }
}

fn ms(n: u64) -> Instant {
    Instant::ZERO + Duration::from_millis(n)
}

fn line() -> LineConfig {
    LineConfig {
        auto_v24: Some(AutoV24Times {
            time_rts_off: si_core::Duration::from_millis(20),
            data_wait_time: si_core::Duration::from_millis(50),
        }),
        ..LineConfig::default()
    }
}

fn signals(dsr: bool, cts: bool) -> ModemSignals {
    ModemSignals {
        dsr,
        cts,
        ..ModemSignals::default()
    }
}

fn with_crc(mut v: Vec<u8>) -> Vec<u8> {
    let c = crc16(&v).to_le_bytes();
    v.extend_from_slice(&c);
    v
}

fn master() -> Master {
    let config = MasterConfig {
        line: line(),
        ..MasterConfig::default()
    };
    Master::new(config).unwrap()
}

const READ: Request<'static> = Request::ReadHoldingRegisters {
    address: 0,
    quantity: 1,
};

#[test]
fn s2_2_entering_the_mode_sets_dtr_on_and_rts_off() {
    let mut m = master();
    assert_eq!(drain(&mut m), vec![Out::Dtr(true), Out::Rts(false)]);
}

#[test]
fn s2_2_master_request_goes_out_at_cts_and_rts_drops_after_the_rts_off_time() {
    let mut m = master();
    drain(&mut m);
    m.handle_signals(ms(0), signals(true, false));
    m.request(ms(1), 1, &READ).unwrap();
    assert_eq!(
        drain(&mut m),
        vec![Out::Rts(true)],
        "RTS on, data held for CTS"
    );
    m.handle_signals(ms(5), signals(true, true));
    let request = with_crc(vec![1, 3, 0, 0, 0, 1]);
    assert_eq!(drain(&mut m), vec![Out::Tx(request)]);
    m.handle_tx_done(ms(14));
    assert!(drain(&mut m).is_empty());
    m.handle_timeout(ms(33));
    assert!(
        drain(&mut m).is_empty(),
        "RTS stays on until the RTS-off time"
    );
    m.handle_timeout(ms(34));
    assert_eq!(drain(&mut m), vec![Out::Rts(false)]);
    m.handle_rx(ms(40), &with_crc(vec![1, 3, 2, 0x12, 0x34]));
    m.handle_timeout(ms(50));
    let outs = drain(&mut m);
    assert!(
        matches!(outs.as_slice(), [Out::Event(MasterEvent::Completed(_))]),
        "{outs:?}"
    );
}

#[test]
fn s2_2_no_cts_within_the_data_output_wait_time_fails_the_job_with_0818() {
    let mut m = master();
    drain(&mut m);
    m.handle_signals(ms(0), signals(true, false));
    m.request(ms(0), 1, &READ).unwrap();
    drain(&mut m);
    m.handle_timeout(ms(49));
    assert!(drain(&mut m).is_empty());
    m.handle_timeout(ms(50));
    assert_eq!(
        drain(&mut m),
        vec![
            Out::Rts(false),
            Out::Event(MasterEvent::Failed {
                job: si_core::job::JobId(1),
                unit: 1,
                function: 3,
                status: status::DSR_CTS_OFF
            })
        ]
    );
    assert!(!m.is_busy());
}

#[test]
fn s2_2_a_request_while_dsr_is_off_fails_at_once_and_never_raises_rts() {
    let mut m = master();
    drain(&mut m);
    m.request(ms(0), 1, &READ).unwrap();
    assert_eq!(
        drain(&mut m),
        vec![Out::Event(MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 1,
            function: 3,
            status: status::DSR_CTS_OFF
        })]
    );
}

#[test]
fn s2_2_dsr_dropping_aborts_the_reception_of_a_response() {
    let mut m = master();
    drain(&mut m);
    m.handle_signals(ms(0), signals(true, true));
    m.request(ms(0), 1, &READ).unwrap();
    m.handle_tx_done(ms(10));
    drain(&mut m);
    m.handle_rx(ms(40), &[1, 3]);
    m.handle_signals(ms(41), signals(false, true));
    let outs = drain(&mut m);
    assert!(outs.contains(&Out::Event(MasterEvent::Failed {
        job: si_core::job::JobId(1),
        unit: 1,
        function: 3,
        status: status::DSR_CTS_OFF
    })));
    // The rest of the response arrives while DSR = OFF: not received, no second event.
    m.handle_rx(ms(42), &[2, 0x12, 0x34]);
    m.handle_timeout(ms(100));
    assert!(drain(&mut m).is_empty());
}

/// A master whose request has left the line at 10 ms with DSR and CTS on: RTS drops at 30 ms
/// (the RTS-off time, 20 ms), and the response time runs to 1 010 ms.
fn master_after_tx_done() -> Master {
    let mut m = master();
    m.handle_signals(ms(0), signals(true, true));
    m.request(ms(0), 1, &READ).unwrap();
    m.handle_tx_done(ms(10));
    drain(&mut m);
    m
}

const ABORTED: MasterEvent = MasterEvent::Failed {
    job: si_core::job::JobId(1),
    unit: 1,
    function: 3,
    status: status::DSR_CTS_OFF,
};

#[test]
fn s2_2_dsr_dropping_during_the_rts_off_time_aborts_the_job_at_once_with_0818() {
    let mut m = master_after_tx_done();
    m.handle_signals(ms(20), signals(false, true));
    assert_eq!(
        drain(&mut m),
        vec![Out::Rts(false), Out::Event(ABORTED)],
        "the send job is not done before RTS is off: DSR dropping aborts it (item 7)"
    );
    assert!(!m.is_busy());
    m.handle_timeout(ms(2_000));
    assert!(drain(&mut m).is_empty(), "no 0830H after the response time");
}

#[test]
fn s2_2_dsr_dropping_before_the_first_answer_byte_aborts_the_job_at_once_with_0818() {
    let mut m = master_after_tx_done();
    m.handle_timeout(ms(30));
    assert_eq!(drain(&mut m), vec![Out::Rts(false)]);
    m.handle_signals(ms(40), signals(false, true));
    assert_eq!(drain(&mut m), vec![Out::Event(ABORTED)]);
    assert!(!m.is_busy());
    m.handle_timeout(ms(2_000));
    assert!(drain(&mut m).is_empty(), "no 0830H after the response time");
}

#[test]
fn s2_2_dsr_dropping_after_a_broadcast_aborts_it_during_the_turnaround_delay() {
    let mut m = master();
    m.handle_signals(ms(0), signals(true, true));
    let write = Request::WriteSingleRegister {
        address: 0,
        value: 1,
    };
    m.request(ms(0), 0, &write).unwrap();
    m.handle_tx_done(ms(10));
    m.handle_timeout(ms(30));
    drain(&mut m);
    assert!(m.is_busy(), "the turnaround delay is still running");
    m.handle_signals(ms(40), signals(false, true));
    assert_eq!(
        drain(&mut m),
        vec![Out::Event(MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 0,
            function: 6,
            status: status::DSR_CTS_OFF
        })]
    );
}

#[test]
fn s2_2_slave_holds_its_response_for_cts_and_ignores_requests_while_dsr_is_off() {
    let config = SlaveConfig {
        line: line(),
        address: 1,
    };
    let mut s = Slave::new(config, Tables::new(8, 8, 8, 8)).unwrap();
    assert_eq!(drain(&mut s), vec![Out::Dtr(true), Out::Rts(false)]);
    let request = with_crc(vec![1, 3, 0, 0, 0, 1]);
    s.handle_rx(ms(0), &request);
    s.handle_timeout(ms(20));
    assert!(
        drain(&mut s).is_empty(),
        "DSR = OFF: the request was not received"
    );

    s.handle_signals(ms(30), signals(true, false));
    s.handle_rx(ms(40), &request);
    s.handle_timeout(ms(60));
    let outs = drain(&mut s);
    assert_eq!(outs.first(), Some(&Out::Rts(true)), "{outs:?}");
    assert!(
        !outs.iter().any(|o| matches!(o, Out::Tx(_))),
        "held for CTS"
    );
    s.handle_signals(ms(61), signals(true, true));
    let outs = drain(&mut s);
    assert!(
        matches!(outs.as_slice(), [Out::Tx(b)] if b[..3] == [1, 3, 2]),
        "{outs:?}"
    );
    s.handle_tx_done(ms(70));
    s.handle_timeout(ms(90));
    assert_eq!(drain(&mut s), vec![Out::Rts(false)]);
}

#[test]
fn s2_2_slave_reports_0818_when_cts_never_comes() {
    let config = SlaveConfig {
        line: line(),
        address: 1,
    };
    let mut s = Slave::new(config, Tables::new(8, 8, 8, 8)).unwrap();
    s.handle_signals(ms(0), signals(true, false));
    s.handle_rx(ms(1), &with_crc(vec![1, 3, 0, 0, 0, 1]));
    s.handle_timeout(ms(20));
    drain(&mut s);
    s.handle_timeout(ms(70));
    assert_eq!(
        drain(&mut s),
        vec![
            Out::Rts(false),
            Out::Event(SlaveEvent::Error(status::DSR_CTS_OFF))
        ]
    );
}

#[test]
fn s2_2_slave_dsr_dropping_during_the_rts_off_time_aborts_its_response_with_0818() {
    let config = SlaveConfig {
        line: line(),
        address: 1,
    };
    let mut s = Slave::new(config, Tables::new(8, 8, 8, 8)).unwrap();
    s.handle_signals(ms(0), signals(true, true));
    s.handle_rx(ms(1), &with_crc(vec![1, 3, 0, 0, 0, 1]));
    s.handle_timeout(ms(20));
    drain(&mut s);
    s.handle_tx_done(ms(30));
    assert!(
        drain(&mut s).is_empty(),
        "RTS stays on for the RTS-off time"
    );
    s.handle_signals(ms(40), signals(false, true));
    assert_eq!(
        drain(&mut s),
        vec![
            Out::Rts(false),
            Out::Event(SlaveEvent::Error(status::DSR_CTS_OFF))
        ]
    );
    s.handle_timeout(ms(60));
    assert!(drain(&mut s).is_empty(), "RTS is already off");
}

#[test]
fn s2_2_times_off_the_10_ms_grid_are_refused_naming_the_parameter() {
    let mut config = MasterConfig::default();
    config.line.auto_v24 = Some(AutoV24Times {
        time_rts_off: si_core::Duration::from_millis(15),
        data_wait_time: si_core::Duration::from_millis(10),
    });
    let err = Master::new(config).unwrap_err();
    assert_eq!(err.range.parameter, "time to RTS off");
    assert_eq!((err.range.value.as_str(), err.range.unit), ("15", " ms"));
}

#[test]
fn without_the_option_no_signal_is_touched() {
    let mut m = Master::new(MasterConfig::default()).unwrap();
    m.request(ms(0), 1, &READ).unwrap();
    let outs = drain(&mut m);
    assert!(matches!(outs.as_slice(), [Out::Tx(_)]), "{outs:?}");
}
