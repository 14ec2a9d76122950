//! How fast the line simulator runs virtual time, and how little a simulated link costs
//! (BENCHMARKS.md):
//!
//! - `sim_3964r_hour_19200`: an hour of a saturated 19200-baud 3964(R) link (200-byte blocks
//!   back to back, the receiver taking each one);
//! - `sim_uss_31_drives_10s`: ten seconds of a USS master polling 31 drives on an RS-485 bus;
//! - `sim_modbus_10_slaves_10s`: ten seconds of a Modbus master polling 10 slaves in turn on an
//!   RS-485 bus (FC03, 10 registers);
//! - memory: 1,000 3964(R) links (2,000 engines) in one simulator, after each has carried a
//!   block, measured with a counting allocator; printed before the timings.
//!
//! Each timing line is followed by the real-time factor (virtual seconds per real second).
//! Run: `cargo bench --bench sim`.

use bytes::Bytes;
use criterion::Criterion;
use si_core::{Duration, Instant, SerialSettings};
use si_sim::{Simulator, StationId};
use si_testkit::alloc::Stats;
use std::time::Instant as Wall;

/// Two 3964(R) links, A sending 200-byte blocks to B for `span` of virtual time; returns the
/// blocks B received.
fn r3964_saturated(span: Duration) -> u64 {
    use si_3964r::{Config, Link, Priority};
    let settings = SerialSettings::new(19_200, 8, si_core::Parity::Even, 1).unwrap();
    let mut sim = Simulator::new(1).without_trace();
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let a = sim.add_station(
        "A",
        settings,
        Link::new(high.with_settings(settings)).unwrap(),
    );
    let b = sim.add_station(
        "B",
        settings,
        Link::new(Config::default().with_settings(settings)).unwrap(),
    );
    sim.connect(a, b);
    let block = Bytes::from(vec![0x55u8; 200]);
    let end = Instant::ZERO + span;
    let mut steps = 0u64;
    while sim.now() < end {
        if !sim.engine(a).is_sending() {
            sim.with(a, |l, now| l.send(now, block.clone()).unwrap());
        }
        if sim.engine(b).received_blocks() > 0 {
            sim.with(b, |l, now| while l.take_block(now).is_some() {});
        }
        if !sim.step() {
            break;
        }
        steps += 1;
        if steps.is_multiple_of(1024) {
            sim.take_events(a);
            sim.take_events(b);
        }
    }
    sim.engine(b).counters().blocks_received
}

/// A USS master polling 31 drives on an RS-485 bus for `span`; returns answered telegrams.
fn uss_31_drives(span: Duration) -> u32 {
    use si_uss::config::{uss_settings, MasterConfig, PollEntry};
    use si_uss::drive::{Drive, DriveConfig};
    use si_uss::frame::PkwWords;
    use si_uss::Master;
    let settings = uss_settings(187_500).unwrap();
    let mut sim = Simulator::new(2).without_trace();
    let mut config = MasterConfig::new(
        (1..=31)
            .map(|a| PollEntry::new(a, PkwWords::Four, 2))
            .collect(),
    );
    config.settings = settings;
    config.local_echo = true;
    let m = sim.add_station("master", settings, Master::new(config).unwrap());
    let mut members = vec![m.index()];
    let mut drives = Vec::new();
    for address in 1..=31 {
        let cfg = DriveConfig {
            local_echo: true,
            ..DriveConfig::new(settings, address)
        };
        let d = sim.add_station("drive", settings, Drive::new(cfg).unwrap());
        members.push(d.index());
        drives.push(d);
    }
    sim.bus(&members);
    sim.with(m, |m, now| m.start(now));
    let mut t = Instant::ZERO;
    let end = Instant::ZERO + span;
    while t < end {
        t += Duration::from_millis(100);
        sim.run_until(t);
        sim.take_events(m);
        for &d in &drives {
            sim.take_events(d);
        }
    }
    sim.engine(m).counters().ok
}

/// A Modbus master polling 10 slaves in turn (FC03, 10 registers) on an RS-485 bus for
/// `span`; returns completed requests.
fn modbus_10_slaves(span: Duration) -> u64 {
    use si_modbus::frame::Request;
    use si_modbus::{Master, MasterConfig, MasterEvent, Slave, SlaveConfig, Tables};
    let settings = SerialSettings::new(19_200, 8, si_core::Parity::Even, 1).unwrap();
    let mut sim = Simulator::new(3).without_trace();
    let mut mc = MasterConfig::default();
    mc.line.settings = settings;
    mc.line.local_echo = true;
    let m = sim.add_station("master", settings, Master::new(mc).unwrap());
    let mut members = vec![m.index()];
    let mut slaves: Vec<StationId<Slave<Tables>>> = Vec::new();
    for address in 1..=10 {
        let mut sc = SlaveConfig {
            address,
            ..SlaveConfig::default()
        };
        sc.line.settings = settings;
        sc.line.local_echo = true;
        let s = sim.add_station(
            "slave",
            settings,
            Slave::new(sc, Tables::new(0, 0, 100, 0)).unwrap(),
        );
        members.push(s.index());
        slaves.push(s);
    }
    sim.bus(&members);
    let request = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 10,
    };
    let end = Instant::ZERO + span;
    let (mut unit, mut done) = (1u8, 0u64);
    while sim.now() < end {
        if !sim.engine(m).is_busy() {
            sim.with(m, |m, now| m.request(now, unit, &request).unwrap());
            unit = unit % 10 + 1;
        }
        if !sim.step() {
            break;
        }
        for e in sim.take_events(m) {
            if matches!(e, MasterEvent::Completed(_)) {
                done += 1;
            }
        }
    }
    for s in slaves {
        sim.take_events(s);
    }
    done
}

/// 1,000 3964(R) links in one simulator: live heap bytes per link (two engines, their station
/// slots, the wiring), idle after start-up and after all 1,000 have sent a 200-byte block at
/// the same instant (what that leaves behind: the simulator's pool of burst records, one per
/// block that was in flight, and its event queue, one entry per burst and timer).
fn memory_per_link() -> (f64, f64) {
    use si_3964r::{Config, Link, Priority};
    const LINKS: usize = 1_000;
    let settings = SerialSettings::default();
    let region = si_testkit::alloc::region();
    let mut sim = Simulator::new(4).without_trace();
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let mut pairs = Vec::with_capacity(LINKS);
    for _ in 0..LINKS {
        let a = sim.add_station(
            "A",
            settings,
            Link::new(high.with_settings(settings)).unwrap(),
        );
        let b = sim.add_station(
            "B",
            settings,
            Link::new(Config::default().with_settings(settings)).unwrap(),
        );
        sim.connect(a, b);
        pairs.push((a, b));
    }
    sim.run_for(Duration::from_secs(1));
    let idle = live(&region.change());
    let block = Bytes::from(vec![0x10u8; 200]);
    for &(a, _) in &pairs {
        sim.with(a, |l, now| l.send(now, block.clone()).unwrap());
    }
    sim.run_for(Duration::from_secs(2));
    for &(a, b) in &pairs {
        sim.with(b, |l, now| {
            assert_eq!(l.take_block(now).map(|b| b.len()), Some(200))
        });
        sim.take_events(a);
        sim.take_events(b);
    }
    let busy = live(&region.change());
    drop(sim);
    (idle / LINKS as f64, busy / LINKS as f64)
}

fn live(stats: &Stats) -> f64 {
    stats.bytes_allocated as f64 - stats.bytes_deallocated as f64 + stats.bytes_reallocated as f64
}

fn factor(name: &str, virtual_span: Duration, run: impl Fn()) {
    let start = Wall::now();
    run();
    let real = start.elapsed().as_secs_f64();
    let virt = virtual_span.as_micros() as f64 / 1e6;
    println!(
        "{name}: {virt:.0} s of virtual time in {real:.3} s: {:.0}x real time",
        virt / real
    );
}

fn main() {
    let (idle, busy) = memory_per_link();
    println!(
        "sim_memory_1000_links: {:.1} KiB per simulated 3964(R) link idle, {:.1} KiB after a block on every link at once",
        idle / 1024.0,
        busy / 1024.0
    );
    let hour = Duration::from_secs(3_600);
    let ten = Duration::from_secs(10);
    assert!(r3964_saturated(Duration::from_secs(60)) > 100);
    assert!(uss_31_drives(Duration::from_secs(1)) > 100);
    assert!(modbus_10_slaves(Duration::from_secs(1)) > 10);
    factor("sim_3964r_hour_19200", hour, || {
        r3964_saturated(hour);
    });
    factor("sim_uss_31_drives_10s", ten, || {
        uss_31_drives(ten);
    });
    factor("sim_modbus_10_slaves_10s", ten, || {
        modbus_10_slaves(ten);
    });

    let mut c = Criterion::default().sample_size(10).configure_from_args();
    c.bench_function("sim_3964r_hour_19200", |b| b.iter(|| r3964_saturated(hour)));
    c.bench_function("sim_uss_31_drives_10s", |b| b.iter(|| uss_31_drives(ten)));
    c.bench_function("sim_modbus_10_slaves_10s", |b| {
        b.iter(|| modbus_10_slaves(ten))
    });
    c.final_summary();
}
