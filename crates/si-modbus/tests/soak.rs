//! Soak: a master and a slave on a faulty line (bit flips, lost and inserted
//! characters) for a day of virtual time, the master alternating an FC16 write of a sequence
//! number into 10 registers with an FC03 read of them.
//!
//! What Modbus RTU can guarantee, asserted: every request ends in exactly one event, done or
//! failed with a nonzero STATUS; the CRC lets no corrupted frame through (every read returns
//! the 10 registers of one single write); nothing is lost or goes back in time (a read returns
//! the last acknowledged write or a later attempted one: a write whose response was lost may
//! still have been executed, which the protocol cannot tell the master); and the line stays
//! usable. The short test runs in every `cargo test`; the day runs with
//! `cargo test --release -p si-modbus --test soak -- --ignored`.

use si_core::{Duration, Instant, SerialSettings};
use si_modbus::frame::{Registers, Request, Response};
use si_modbus::{Master, MasterConfig, MasterEvent, Slave, SlaveConfig, Tables};
use si_sim::{Faults, Simulator};

struct Outcome {
    done: u64,
    failed: u64,
    reads: u64,
}

fn soak(span: Duration, seed: u64) -> Outcome {
    let settings = SerialSettings::new(19_200, 8, si_core::Parity::Even, 1).unwrap();
    let mut sim = Simulator::new(seed).without_trace();
    let mut mc = MasterConfig::default();
    mc.line.settings = settings;
    mc.retries = 2;
    let m = sim.add_station("master", settings, Master::new(mc).unwrap());
    let mut sc = SlaveConfig {
        address: 7,
        ..SlaveConfig::default()
    };
    sc.line.settings = settings;
    let s = sim.add_station(
        "slave",
        settings,
        Slave::new(sc, Tables::new(0, 0, 16, 0)).unwrap(),
    );
    sim.connect(m, s);
    let faults = Faults {
        bit_flip: 0.000_5,
        drop: 0.000_5,
        insert: 0.000_5,
        extra_latency: Duration::ZERO,
    };
    sim.set_faults(m, faults);
    sim.set_faults(s, faults);

    let mut seq: u16 = 0;
    let mut acknowledged: u16 = 0;
    let mut attempted: u16 = 0;
    let mut writing = false;
    let mut open = false;
    let mut out = Outcome {
        done: 0,
        failed: 0,
        reads: 0,
    };
    let end = Instant::ZERO + span;
    while sim.now() < end {
        if !open {
            writing = !writing;
            let request = if writing {
                seq = seq.wrapping_add(1).max(1);
                attempted = seq;
                Request::WriteMultipleRegisters {
                    address: 0,
                    values: Registers::Words(&[seq; 10]),
                }
            } else {
                Request::ReadHoldingRegisters {
                    address: 0,
                    quantity: 10,
                }
            };
            sim.with(m, |m, now| m.request(now, 7, &request))
                .expect("the master is idle");
            open = true;
        }
        sim.run_for(Duration::from_millis(20));
        for event in sim.take_events(m) {
            match event {
                MasterEvent::Completed(c) => {
                    assert!(open, "a completion without a request");
                    open = false;
                    out.done += 1;
                    match c.response() {
                        Some(Response::WriteMultipleRegisters { .. }) => acknowledged = attempted,
                        Some(Response::ReadHoldingRegisters(regs)) => {
                            out.reads += 1;
                            let values: Vec<u16> = regs.iter().collect();
                            assert_eq!(values.len(), 10);
                            assert!(
                                values.iter().all(|&v| v == values[0]),
                                "registers from two writes (a corrupted frame got through): {values:?}"
                            );
                            let v = values[0];
                            assert!(
                                v == 0 || (v >= acknowledged && v <= attempted),
                                "read {v}, acknowledged {acknowledged}, attempted {attempted}"
                            );
                        }
                        other => panic!("unexpected response {other:?}"),
                    }
                }
                MasterEvent::Failed { status, .. } => {
                    assert!(open, "a failure without a request");
                    assert!(
                        status.code() != 0 && status.info().is_some(),
                        "a failure carries a STATUS of the manual: {status:?}"
                    );
                    open = false;
                    out.failed += 1;
                }
                MasterEvent::Diagnostic(status) => {
                    assert!(status.code() != 0 && status.info().is_some())
                }
            }
        }
        sim.take_events(s);
    }
    eprintln!(
        "modbus soak {:?}: {} done, {} failed, {} reads, master {:?}, slave {:?}",
        span,
        out.done,
        out.failed,
        out.reads,
        sim.engine(m).counters(),
        sim.engine(s).counters()
    );
    // The line is faulty but usable: most requests succeed.
    assert!(
        out.done > 20 * out.failed,
        "{} done, {} failed",
        out.done,
        out.failed
    );
    out
}

#[test]
fn ten_minutes_of_faults_every_request_ends_once_and_reads_are_consistent() {
    let out = soak(Duration::from_secs(600), 0x5EED);
    assert!(out.reads > 1_000);
}

#[test]
#[ignore = "a day of virtual time: run in release (see the module docs)"]
fn a_day_of_faults_every_request_ends_once_and_reads_are_consistent() {
    let out = soak(Duration::from_secs(24 * 3600), 0xDA7);
    assert!(out.reads > 100_000);
}
