//! A slave behind a 16550-type FIFO UART (si-sim's [`FifoUart`], announcing nothing, as a
//! `ttyS` port under the tokio driver) with default configs at 9600 and 19 200 bit/s: on an
//! RS-485 bus with a master polling it and two other slaves (direct), turnaround garbage after
//! every answer and random noise bursts, it answers every clean request to its unit at once,
//! never a frame for another unit or a corrupt one, and answers again at most one request after
//! a noise burst; and a master behind the same UART completes its polls
//! ([Modbus/USS] §3.3.5, Table 3-11: the frame ends at the gap wherever the bytes allow it).

use si_core::{Duration, Engine, Instant, Interface, Output, Parity, SerialSettings};
use si_modbus::config::LineConfig;
use si_modbus::frame::{crc16, Request};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::slave::{Slave, SlaveEvent, Tables};
use si_modbus::{MasterConfig, SlaveConfig};
use si_sim::{FifoUart, Simulator, SplitMix64, StationId};

/// A station that only puts scripted bytes on the bus (garbage, noise, corrupt frames).
struct Noise;

impl Engine for Noise {
    type Event = ();
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
    fn handle_timeout(&mut self, _: Instant) {}
    fn poll_output(&mut self) -> Output<()> {
        Output::Wait(None)
    }
}

fn line(baud: u32) -> LineConfig {
    LineConfig {
        settings: SerialSettings::new(baud, 8, Parity::Even, 1).unwrap(),
        // The bus lets every transceiver hear itself (a host extension, off by default).
        local_echo: true,
        ..LineConfig::default()
    }
}

struct Bus {
    sim: Simulator,
    master: StationId<Master>,
    target: StationId<Slave<Tables>>,
    noise: StationId<Noise>,
}

fn bus(baud: u32, uart: FifoUart, seed: u64) -> Bus {
    let mut sim = Simulator::new(seed).without_trace();
    let l = line(baud);
    let master = sim.add_station(
        "master",
        l.settings,
        Master::new(MasterConfig {
            line: l,
            ..MasterConfig::default()
        })
        .unwrap()
        .with_interface(Interface::Rs485),
    );
    let mut members = vec![master.index()];
    let mut target = None;
    for address in 1..=3u8 {
        let slave = Slave::new(
            SlaveConfig { address, line: l },
            Tables::new(50, 50, 50, 50),
        );
        let slave = slave.unwrap().with_interface(Interface::Rs485);
        let id = sim.add_station(&format!("slave{address}"), l.settings, slave);
        members.push(id.index());
        if address == 1 {
            target = Some(id);
        }
    }
    let noise = sim.add_station("noise", l.settings, Noise);
    members.push(noise.index());
    sim.bus(&members);
    let target = target.unwrap();
    sim.set_uart(target, uart).unwrap();
    Bus {
        sim,
        master,
        target,
        noise,
    }
}

/// How many requests the slave behind the UART answered since the last call.
fn answers(b: &mut Bus) -> u64 {
    b.sim
        .take_events(b.target)
        .iter()
        .filter(|e| matches!(e, SlaveEvent::Served { .. } | SlaveEvent::Exception { .. }))
        .count() as u64
}

/// The longest a poll of unit 1 may take: request, response and the UART's delays take
/// about 30 ms at 9600 bit/s; a request glued to a fragment is found only when the fragment
/// is judged over, which must come well before the next request could (here 100 ms).
const POLL_LIMIT: Duration = Duration::from_millis(100);

/// One request from the master to `unit`; true if it completed within [`POLL_LIMIT`].
fn poll(b: &mut Bus, unit: u8) -> bool {
    let request = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 4,
    };
    // The master refuses while the line is busy (garbage still arriving): retry each ms.
    for _ in 0..1_000 {
        if b.sim
            .with(b.master, |e, now| e.request(now, unit, &request))
            .is_ok()
        {
            break;
        }
        b.sim.run_for(Duration::from_millis(1));
    }
    let start = b.sim.now();
    // The job's end (a diagnostic event about a line error may come before it).
    let event = 'job: loop {
        for e in b.sim.take_events(b.master) {
            if matches!(e, MasterEvent::Completed(_) | MasterEvent::Failed { .. }) {
                break 'job e;
            }
        }
        assert!(b.sim.step(), "the job ended without an event");
    };
    let took = b.sim.now() - start;
    // Let the bus settle (the master's own gap, the slaves' frame ends).
    b.sim.run_for(Duration::from_millis(10));
    let ok =
        matches!(event, MasterEvent::Completed(ref c) if c.unit() == unit) && took <= POLL_LIMIT;
    if !ok {
        eprintln!("unit {unit} after {took}: {event:?}");
    }
    ok
}

fn busy_bus(baud: u32, trigger: u8) {
    let uart = FifoUart::LINUX_16550A.with_trigger(trigger);
    let mut b = bus(baud, uart, 28 + u64::from(trigger));
    let mut rng = SplitMix64::new(u64::from(baud) + u64::from(trigger));
    let mut after_noise = false;
    for round in 0..40 {
        for unit in [1u8, 2, 3] {
            answers(&mut b);
            let ok = poll(&mut b, unit);
            let answered = answers(&mut b);
            if unit == 1 {
                assert!(
                    ok || after_noise,
                    "{baud} bit/s, trigger {trigger}, round {round}: unit 1 did not answer"
                );
                assert!(answered <= 1);
                if ok {
                    after_noise = false;
                }
            } else {
                assert!(ok, "{baud} bit/s, round {round}: unit {unit}");
                assert_eq!(answered, 0, "unit 1 answered a frame for unit {unit}");
            }
            // Turnaround garbage: one byte as a driver switches direction.
            b.sim.transmit(b.noise, &[0xFF]);
            b.sim.run_for(Duration::from_millis(10));
        }
        if round % 5 == 4 {
            // A corrupt request to unit 1: never answered.
            let mut frame = vec![1, 3, 0, 0, 0, 4];
            let crc = crc16(&frame) ^ 0x0101;
            frame.extend_from_slice(&crc.to_le_bytes());
            answers(&mut b);
            b.sim.transmit(b.noise, &frame);
            b.sim.run_for(Duration::from_millis(100));
            assert_eq!(answers(&mut b), 0, "unit 1 answered a corrupt frame");
        }
        if round % 7 == 3 {
            // A random noise burst.
            let n = 3 + (rng.next_u64() % 20) as usize;
            let burst: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
            b.sim.transmit(b.noise, &burst);
            let settings = SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
            b.sim
                .run_for(settings.chars_time(n as u64) + Duration::from_millis(5));
            after_noise = true;
        }
    }
}

#[test]
fn a_slave_behind_a_fifo_uart_on_a_busy_bus_answers_only_its_own_clean_requests_at_9600() {
    for trigger in FifoUart::TRIGGERS {
        busy_bus(9_600, trigger);
    }
}

#[test]
fn a_slave_behind_a_fifo_uart_on_a_busy_bus_answers_only_its_own_clean_requests_at_19200() {
    for trigger in FifoUart::TRIGGERS {
        busy_bus(19_200, trigger);
    }
}

#[test]
fn a_master_behind_a_fifo_uart_completes_short_and_long_reads() {
    for baud in [9_600, 19_200] {
        for trigger in FifoUart::TRIGGERS {
            let mut sim = Simulator::new(7).without_trace();
            let l = LineConfig {
                settings: SerialSettings::new(baud, 8, Parity::Even, 1).unwrap(),
                ..LineConfig::default()
            };
            let m = sim.add_station(
                "master",
                l.settings,
                Master::new(MasterConfig {
                    line: l,
                    ..MasterConfig::default()
                })
                .unwrap(),
            );
            let slave = Slave::new(
                SlaveConfig {
                    address: 1,
                    line: l,
                },
                Tables::new(200, 200, 200, 200),
            );
            let s = sim.add_station("slave", l.settings, slave.unwrap());
            sim.connect(m, s);
            sim.set_uart(m, FifoUart::LINUX_16550A.with_trigger(trigger))
                .unwrap();
            for quantity in [125u16, 10, 125, 2] {
                let request = Request::ReadHoldingRegisters {
                    address: 0,
                    quantity,
                };
                sim.with(m, |e, now| e.request(now, 1, &request)).unwrap();
                let event = loop {
                    if let Some(e) = sim.take_events(m).pop() {
                        break e;
                    }
                    assert!(sim.step());
                };
                assert!(
                    matches!(event, MasterEvent::Completed(_)),
                    "{baud} bit/s, trigger {trigger}, {quantity} registers: {event:?}"
                );
            }
        }
    }
}
