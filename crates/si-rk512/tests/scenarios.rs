//! RK 512 scenarios on the line simulator, named after the sections of
//! [CP 341] §2.2.3, §2.3.2 they show, each asserting the STATUS the job ends with.

#[path = "scenarios/usb_adapter.rs"]
mod usb_adapter;

#[path = "scenarios/cp341_status.rs"]
mod cp341_status;

use bytes::Bytes;
use si_3964r::{Link, Priority};
use si_core::memory::Area;
use si_core::{Duration, Instant, SerialSettings, Status};
use si_rk512::frame::{Address, Coordination};
use si_rk512::passive::ServerConfig;
use si_rk512::refusal::ServeError;
use si_rk512::status;
use si_rk512::{Command, Config, Event, Station};
use si_sim::{Faults, Simulator, StationId, TraceKind};

/// 9600 8E1, the manual's default.
fn line() -> SerialSettings {
    SerialSettings::default()
}

fn high() -> Config {
    let mut c = Config::default();
    c.link.priority = Priority::High;
    c
}

fn memory() -> ServerConfig {
    let mut m = ServerConfig::default();
    m.memory.dbs.insert(10, 2048);
    m.memory.dbs.insert(11, 16);
    m.dx.insert(3, 64);
    m
}

struct Pair {
    sim: Simulator,
    a: StationId<Station>,
    b: StationId<Station>,
}

/// A = active host (high priority), B = serving PLC.
fn pair(seed: u64) -> Pair {
    let mut sim = Simulator::new(seed);
    let a = sim.add_station(
        "A",
        line(),
        Station::new(high().with_settings(line())).unwrap(),
    );
    let b = sim.add_station(
        "B",
        line(),
        Station::serving(Config::default().with_settings(line()), &memory()).unwrap(),
    );
    sim.connect(a, b);
    Pair { sim, a, b }
}

impl Pair {
    fn settle(&mut self) {
        let limit = self.sim.now() + Duration::from_secs(600);
        assert!(self.sim.run_until_quiet(limit), "simulation did not settle");
    }

    /// Run a job to its end and return its outcome.
    fn outcome(&mut self) -> Result<Bytes, Status> {
        self.settle();
        let events = self.sim.take_events(self.a);
        let outcomes: Vec<_> = events
            .iter()
            .filter_map(|e| match e {
                Event::Done { data, .. } => Some(Ok(data.clone())),
                Event::Failed { status, .. } => Some(Err(*status)),
                _ => None,
            })
            .collect();
        assert_eq!(outcomes.len(), 1, "exactly one completion: {events:?}");
        outcomes.into_iter().next().unwrap()
    }

    fn send(&mut self, to: Address, c: Coordination, data: &[u8]) -> Result<(), Status> {
        let data = Bytes::copy_from_slice(data);
        self.sim
            .with(self.a, |s, now| s.send(now, to, c, data))
            .unwrap();
        self.outcome().map(|d| assert!(d.is_empty()))
    }

    fn fetch(&mut self, from: Address, len: usize) -> Result<Bytes, Status> {
        self.sim
            .with(self.a, |s, now| s.fetch(now, from, Coordination::NONE, len))
            .unwrap();
        self.outcome()
    }
}

fn pattern(len: usize, seed: u8) -> Vec<u8> {
    (0..len).map(|i| (i as u8).wrapping_mul(7) ^ seed).collect()
}

/// [CP 341] §2.2.3: SEND and FETCH of 1, 128, 129 and the maximum (1024) bytes, split into
/// telegrams of 128 bytes and reassembled. SEND counts words (D), so its odd sizes round up to
/// the next word; FETCH of flag bytes (M) shows the odd sizes.
#[test]
fn s4_5_send_and_fetch_of_1_128_129_and_max_bytes() {
    let mut p = pair(1);
    for (i, len) in [2usize, 128, 130, 1024].into_iter().enumerate() {
        let data = pattern(len, i as u8);
        let at = Address::Db { db: 10, dw: 3 };
        assert_eq!(p.send(at, Coordination::NONE, &data), Ok(()), "SEND {len}");
        let plc = p.sim.engine(p.b).server().memory();
        assert_eq!(&plc.bytes(Area::Db(10)).unwrap()[6..6 + len], &data[..]);
        assert_eq!(p.fetch(at, len).unwrap(), &data[..], "FETCH {len}");
    }
    // Flag bytes are counted in bytes: 1 and 129.
    let flags = pattern(256, 9);
    p.sim.with(p.b, |s, _| {
        s.server_mut()
            .memory_mut()
            .write(Area::Flags, 100, &flags)
            .unwrap()
    });
    for len in [1usize, 128, 129, 1024] {
        assert_eq!(
            p.fetch(Address::Flags(100), len.min(256)).unwrap(),
            &flags[..len.min(256)]
        );
    }
    // Telegrams: 1024 bytes = 8 telegrams each way; the passive side reported each job once.
    let served: Vec<_> = p
        .sim
        .take_events(p.b)
        .into_iter()
        .filter(|e| matches!(e, Event::Served { .. }))
        .collect();
    assert_eq!(served.len(), 12);
    assert!(served.contains(&Event::Served {
        command: Command::Send,
        address: Address::Db { db: 10, dw: 3 },
        len: 1024
    }));
}

/// [CP 341] §2.2.3 with line faults: bit flips and lost characters are repaired by 3964(R)
/// repetitions; the job still ends with exactly one completion, and with the data intact when it is
/// DONE.
#[test]
fn s4_5_jobs_survive_line_faults() {
    let mut done = 0;
    for seed in 1..=12u64 {
        let mut p = pair(seed);
        let faults = Faults {
            bit_flip: 0.002,
            drop: 0.001,
            ..Faults::default()
        };
        p.sim.set_faults(p.a, faults);
        p.sim.set_faults(p.b, faults);
        let data = pattern(600, seed as u8);
        let at = Address::Db { db: 10, dw: 0 };
        if p.send(at, Coordination::NONE, &data).is_ok() {
            if let Ok(back) = p.fetch(at, 600) {
                assert_eq!(back, &data[..]);
                done += 1;
            }
        }
    }
    assert!(done >= 8, "most jobs get through: {done}/12");
}

/// [CP 341] §2.2.3 with line faults, for every size: 1 word, 128, 130 and 1024 bytes each way.
#[test]
fn s4_5_every_size_with_line_faults() {
    let faults = Faults {
        bit_flip: 0.001,
        drop: 0.0005,
        ..Faults::default()
    };
    for (i, len) in [2usize, 128, 130, 1024].into_iter().enumerate() {
        let mut p = pair(200 + i as u64);
        p.sim.set_faults(p.a, faults);
        p.sim.set_faults(p.b, faults);
        let data = pattern(len, 3);
        let at = Address::Db { db: 10, dw: 0 };
        assert_eq!(p.send(at, Coordination::NONE, &data), Ok(()), "SEND {len}");
        assert_eq!(p.fetch(at, len).unwrap(), &data[..], "FETCH {len}");
        // The faults did happen and were repaired by 3964(R) repetitions.
        let reps = p.sim.engine(p.a).link().counters().repetitions
            + p.sim.engine(p.b).link().counters().repetitions;
        if len == 1024 {
            assert!(reps > 0, "no repetition in a 1024-byte job with faults");
        }
    }
}

/// Address mapping: DX through command 'O', timers and counters as words, inputs and outputs.
#[test]
fn s4_2_every_data_type_is_served() {
    let mut p = pair(2);
    let dx = Address::Dx { db: 3, dw: 4 };
    assert_eq!(p.send(dx, Coordination::NONE, &[1, 2, 3, 4]), Ok(()));
    assert_eq!(
        &p.sim.engine(p.b).server().dx().bytes(Area::Db(3)).unwrap()[8..12],
        &[1, 2, 3, 4]
    );
    assert_eq!(p.fetch(dx, 4).unwrap(), &[1, 2, 3, 4][..]);
    p.sim.with(p.b, |s, _| {
        let m = s.server_mut().memory_mut();
        m.set_element(Area::Timers, 7, 0x1234).unwrap();
        m.set_element(Area::Counters, 2, 0xBEEF).unwrap();
        m.write(Area::Inputs, 4, &[0xAA]).unwrap();
        m.write(Area::Outputs, 5, &[0x55]).unwrap();
    });
    assert_eq!(p.fetch(Address::Timers(7), 2).unwrap(), &[0x12, 0x34][..]);
    assert_eq!(
        p.fetch(Address::Counters(1), 4).unwrap(),
        &[0, 0, 0xBE, 0xEF][..]
    );
    assert_eq!(p.fetch(Address::Inputs(4), 1).unwrap(), &[0xAA][..]);
    assert_eq!(p.fetch(Address::Outputs(5), 1).unwrap(), &[0x55][..]);
}

/// [CP 341] §2.2.3: a SEND naming a coordination flag sets it; the next SEND is refused with 32H
/// (STATUS 0909) until the partner's program resets the flag.
#[test]
fn s4_8_coordination_flag_interlock_0909() {
    let mut p = pair(3);
    let at = Address::Db { db: 10, dw: 0 };
    let km = Coordination::flag(20, 3);
    assert_eq!(p.send(at, km, &[1, 2]), Ok(()));
    assert!(p
        .sim
        .engine(p.b)
        .server()
        .memory()
        .bit(Area::Flags, 20, 3)
        .unwrap());
    assert_eq!(p.send(at, km, &[3, 4]), Err(status::PARTNER_LOCKED));
    // The first data are untouched.
    assert_eq!(
        p.sim
            .engine(p.b)
            .server()
            .memory()
            .word(Area::Db(10), 0)
            .unwrap(),
        0x0102
    );
    // A SEND without the flag, and a FETCH, are not affected.
    assert_eq!(p.fetch(at, 2).unwrap(), &[1, 2][..]);
    // The partner program consumes the data and resets the flag: the SEND goes through.
    p.sim.with(p.b, |s, _| {
        s.server_mut()
            .memory_mut()
            .set_bit(Area::Flags, 20, 3, false)
            .unwrap()
    });
    assert_eq!(p.send(at, km, &[3, 4]), Ok(()));
    assert_eq!(
        p.sim
            .engine(p.b)
            .server()
            .memory()
            .word(Area::Db(10), 0)
            .unwrap(),
        0x0304
    );
}

/// [CP 341] §2.2.3, Table 2-2, [CP 341 Diag]: errors the passive side finds (06xx), read back by
/// the active side as class 09H: 0606/0608 → 14H → 0903, 060D in STOP → 2AH → 090D, 060D not
/// served → 0AH → 0902.
#[test]
fn s4_3_partner_errors_reach_the_requester_as_class_09() {
    let mut p = pair(4);
    // 14H: DB missing, and a DB too short for the job.
    assert_eq!(
        p.fetch(Address::Db { db: 99, dw: 0 }, 2),
        Err(status::PARTNER_NO_SUCH_DB)
    );
    assert_eq!(
        p.send(
            Address::Db { db: 11, dw: 1 },
            Coordination::NONE,
            &[0; 16][..]
        ),
        Err(status::PARTNER_NO_SUCH_DB)
    );
    // 2AH: the partner CPU is in STOP.
    p.sim.with(p.b, |s, _| s.server_mut().set_running(false));
    assert_eq!(
        p.fetch(Address::Flags(0), 1),
        Err(status::PARTNER_NOT_RUNNING)
    );
    p.sim.with(p.b, |s, _| s.server_mut().set_running(true));
    let refused: Vec<_> = p
        .sim
        .take_events(p.b)
        .into_iter()
        .filter_map(|e| match e {
            Event::Refused { error } => Some(error.status().code()),
            _ => None,
        })
        .collect();
    assert_eq!(refused, [0x0606, 0x0608, 0x060D]);
    // 0AH: an active-only station refuses every command.
    let mut sim = Simulator::new(5);
    let a = sim.add_station(
        "A",
        line(),
        Station::new(high().with_settings(line())).unwrap(),
    );
    let b = sim.add_station(
        "B",
        line(),
        Station::new(Config::default().with_settings(line())).unwrap(),
    );
    sim.connect(a, b);
    let q = &mut Pair { sim, a, b };
    assert_eq!(q.fetch(Address::Flags(0), 1), Err(status::PARTNER_NO_AREA));
    assert!(q.sim.take_events(q.b).contains(&Event::Refused {
        error: ServeError::NotServed
    }));
}

// --- scripted partners: a bare 3964(R) link sends exact telegrams ----------------------------

struct Scripted {
    sim: Simulator,
    station: StationId<Station>,
    raw: StationId<Link>,
}

/// A station (low priority, serving) and a bare 3964(R) link (high priority).
fn scripted(seed: u64) -> Scripted {
    scripted_with(seed, Config::default())
}

fn scripted_with(seed: u64, config: Config) -> Scripted {
    let mut sim = Simulator::new(seed);
    let station = sim.add_station(
        "station",
        line(),
        Station::serving(config.with_settings(line()), &memory()).unwrap(),
    );
    let raw_config = si_3964r::Config {
        priority: Priority::High,
        ..si_3964r::Config::default()
    };
    let raw = sim.add_station(
        "raw",
        line(),
        Link::new(raw_config.with_settings(line())).unwrap(),
    );
    sim.connect(station, raw);
    Scripted { sim, station, raw }
}

impl Scripted {
    /// Send one telegram from the raw side and return the station's reaction telegram.
    fn exchange(&mut self, telegram: &[u8]) -> Vec<u8> {
        let t = Bytes::copy_from_slice(telegram);
        self.sim.with(self.raw, |l, now| l.send(now, t)).unwrap();
        let limit = self.sim.now() + Duration::from_secs(5);
        self.sim.run_until(limit);
        self.sim
            .with(self.raw, |l, now| l.take_block(now))
            .map(|b| b.to_vec())
            .unwrap_or_default()
    }
}

/// [CP 341] §2.2.3, Table 2-2 and Fig. 2-19: every error number the passive side sends, from a
/// telegram that provokes it, with the 06xx it reports ([CP 341 Diag] class 06H; the byte per
/// 06xx is the [inferred] reverse mapping of §2.1).
#[test]
fn s4_3_every_reaction_error_number_is_reachable() {
    let mut s = scripted(6);
    let send_db10 = |len_words: u8, data: usize| {
        let mut t = vec![0, 0, b'A', b'D', 10, 0, 0, len_words, 0xFF, 0xFF];
        t.extend(std::iter::repeat_n(0x11, data));
        t
    };
    // 0604 → 10H: 'A' with data type 'X' (SEND DB must name D). 0601 → 10H: first byte
    // neither 00 nor FF.
    assert_eq!(
        s.exchange(&[0, 0, b'A', b'X', 3, 0, 0, 1, 0xFF, 0xFF, 1, 2]),
        [0, 0, 0, 0x10]
    );
    assert_eq!(s.exchange(&[0x12, 0, b'E', b'D']), [0, 0, 0, 0x10]);
    // 0602 → 16H: unknown command letter.
    assert_eq!(
        s.exchange(&[0, 0, b'Q', b'D', 10, 0, 0, 1, 0xFF, 0xFF]),
        [0, 0, 0, 0x16]
    );
    // 34H: 060B length 2 words but 3 data bytes; 0610 a header cut short; 060C FETCH with
    // data ([derived]).
    assert_eq!(s.exchange(&send_db10(2, 3)), [0, 0, 0, 0x34]);
    assert_eq!(s.exchange(&[0, 0, b'E', b'D', 10]), [0, 0, 0, 0x34]);
    assert_eq!(
        s.exchange(&[0, 0, b'E', b'D', 10, 0, 0, 1, 0xFF, 0xFF, 9]),
        [0, 0, 0, 0x34]
    );
    // 060E → 36H: a continuation with no job running.
    assert_eq!(s.exchange(&[0xFF, 0, b'A', b'D', 1, 2]), [0xFF, 0, 0, 0x36]);
    // 0606 → 14H: DB missing.
    assert_eq!(
        s.exchange(&[0, 0, b'E', b'D', 77, 0, 0, 1, 0xFF, 0xFF]),
        [0, 0, 0, 0x14]
    );
    // 060F → 32H: flag M20.3 set.
    s.sim.with(s.station, |st, _| {
        st.server_mut()
            .memory_mut()
            .set_bit(Area::Flags, 20, 3, true)
            .unwrap()
    });
    assert_eq!(
        s.exchange(&[0, 0, b'A', b'D', 10, 0, 0, 1, 20, 0x03, 1, 2]),
        [0, 0, 0, 0x32]
    );
    // 060D → 2AH: CPU in STOP.
    s.sim
        .with(s.station, |st, _| st.server_mut().set_running(false));
    assert_eq!(s.exchange(&send_db10(1, 2)), [0, 0, 0, 0x2A]);
    s.sim
        .with(s.station, |st, _| st.server_mut().set_running(true));
    // 060D → 0AH: SEND not accepted.
    let mut closed = memory();
    closed.accept_send = false;
    let mut t = scripted(7);
    t.sim.with(t.station, |st, _| {
        *st.server_mut() = si_rk512::passive::Server::new(&closed)
    });
    assert_eq!(t.exchange(&send_db10(1, 2)), [0, 0, 0, 0x0A]);
    // And a good SEND in between works: 00H.
    assert_eq!(s.exchange(&send_db10(1, 2)), [0, 0, 0, 0]);
    let refused: Vec<_> = s
        .sim
        .take_events(s.station)
        .into_iter()
        .filter_map(|e| match e {
            Event::Refused { error } => Some((error.status().code(), error.error_number().code())),
            _ => None,
        })
        .collect();
    assert_eq!(
        refused,
        [
            (0x0604, 0x10),
            (0x0601, 0x10),
            (0x0602, 0x16),
            (0x060B, 0x34),
            (0x0610, 0x34),
            (0x060C, 0x34),
            (0x060E, 0x36),
            (0x0606, 0x14),
            (0x060F, 0x32),
            (0x060D, 0x2A),
        ]
    );
}

/// Fig. 2-19: the passive side waits TRES for the continuation; when none comes the job is
/// aborted (060E, `[derived]`) and a late continuation is answered with 36H (060E).
#[test]
fn s4_7_passive_side_gives_up_after_tres_060e() {
    let mut s = scripted(8);
    let mut first = vec![0, 0, b'A', b'D', 10, 0, 0, 100, 0xFF, 0xFF];
    first.extend([7u8; 128]);
    assert_eq!(s.exchange(&first), [0, 0, 0, 0]);
    s.sim.run_for(Duration::from_secs(11));
    assert!(s
        .sim
        .take_events(s.station)
        .contains(&Event::ServeAborted(status::SEQUENCE)));
    let mut cont = vec![0xFF, 0, b'A', b'D'];
    cont.extend([7u8; 72]);
    assert_eq!(s.exchange(&cont), [0xFF, 0, 0, 0x36]);
}

/// Fig. 2-19: a first command telegram where a continuation was due aborts the running job
/// (060E) and is served itself.
#[test]
fn s4_7_first_telegram_instead_of_continuation_060e() {
    let mut s = scripted(9);
    let mut first = vec![0, 0, b'A', b'D', 10, 0, 0, 100, 0xFF, 0xFF];
    first.extend([7u8; 128]);
    assert_eq!(s.exchange(&first), [0, 0, 0, 0]);
    assert_eq!(
        s.exchange(&[0, 0, b'E', b'D', 10, 0, 0, 1, 0xFF, 0xFF]),
        [0, 0, 0, 0, 7, 7]
    );
    assert!(s
        .sim
        .take_events(s.station)
        .contains(&Event::ServeAborted(status::SEQUENCE)));
}

/// A station whose partner is a bare link that answers with scripted reactions.
fn active_against_script(seed: u64) -> (Simulator, StationId<Station>, StationId<Link>) {
    let mut sim = Simulator::new(seed);
    let station = sim.add_station(
        "station",
        line(),
        Station::new(high().with_settings(line())).unwrap(),
    );
    let raw = sim.add_station(
        "raw",
        line(),
        Link::new(si_3964r::Config::default().with_settings(line())).unwrap(),
    );
    sim.connect(station, raw);
    (sim, station, raw)
}

fn run_job(
    sim: &mut Simulator,
    station: StationId<Station>,
    raw: StationId<Link>,
    start: impl FnOnce(&mut Station, Instant),
    reactions: &[&[u8]],
) -> Status {
    sim.with(station, |s, now| start(s, now));
    for reaction in reactions {
        let limit = sim.now() + Duration::from_secs(3);
        sim.run_until(limit);
        while sim.with(raw, |l, now| l.take_block(now)).is_some() {}
        let r = Bytes::copy_from_slice(reaction);
        sim.with(raw, |l, now| l.send(now, r)).unwrap();
    }
    let limit = sim.now() + Duration::from_secs(30);
    sim.run_until(limit);
    let events = sim.take_events(station);
    let outcomes: Vec<Status> = events
        .iter()
        .filter_map(|e| match e {
            Event::Done { .. } => Some(Status::OK),
            Event::Failed { status, .. } => Some(*status),
            _ => None,
        })
        .collect();
    assert_eq!(outcomes.len(), 1, "{events:?}");
    outcomes[0]
}

/// [CP 341] §2.2.3, Table 2-2, [CP 341 Diag] `[derived]`: each error number in a reaction ends the
/// job with its class 09H STATUS, one job per row of the [inferred] table; unknown numbers with
/// 090E.
#[test]
fn s4_3_reaction_error_numbers_map_to_their_status() {
    let at = Address::Db { db: 1, dw: 0 };
    let rows: [(u8, u16); 13] = [
        (0x0A, 0x0902),
        (0x0C, 0x0905),
        (0x10, 0x090B),
        (0x11, 0x0902),
        (0x14, 0x0903),
        (0x16, 0x090A),
        (0x2A, 0x090D),
        (0x32, 0x0909),
        (0x34, 0x090C),
        (0x36, 0x0908),
        (0x01, 0x090E),
        (0x12, 0x090E),
        (0xFF, 0x090E),
    ];
    for (i, (byte, code)) in rows.into_iter().enumerate() {
        let (mut sim, st, raw) = active_against_script(20 + i as u64);
        let got = run_job(
            &mut sim,
            st,
            raw,
            |s, now| {
                s.fetch(now, at, Coordination::NONE, 2).unwrap();
            },
            &[&[0, 0, 0, byte]],
        );
        assert_eq!(got.code(), code, "error number {byte:02X}H");
        assert_eq!(got, status::lookup(code), "{code:04X} is in the catalog");
    }
}

/// [CP 341] §2.2.3, Fig. 2-18/2-19, Fig. 2-18: no reaction within TRES (10 s) ends the job with
/// 0A05.
#[test]
fn s4_7_no_reaction_within_tres_0a05() {
    let (mut sim, st, raw) = active_against_script(50);
    let got = run_job(
        &mut sim,
        st,
        raw,
        |s, now| {
            s.send(
                now,
                Address::Db { db: 1, dw: 0 },
                Coordination::NONE,
                vec![1, 2],
            )
            .unwrap();
        },
        &[],
    );
    assert_eq!(got, status::NO_REACTION);
    // TRES runs from the partner's DLE for our telegram to the failure: exactly 10 s.
    let received = sim.trace().received("station");
    let ack = received.iter().rev().find(|(_, b)| *b == 0x10).unwrap().0;
    let failed = sim
        .trace()
        .of("station")
        .find(|e| matches!(&e.kind, TraceKind::Event { text } if text.starts_with("Failed")))
        .unwrap()
        .at;
    assert_eq!(failed - ack, Duration::from_secs(10));
}

/// A.12 as a setting: TRES of 5 s (the flowcharts' shortest value).
#[test]
fn s4_7_tres_is_a_setting() {
    let mut sim = Simulator::new(51);
    let mut c = high();
    c.response_timeout = si_core::Duration::from_millis(5000);
    let st = sim.add_station(
        "station",
        line(),
        Station::new(c.with_settings(line())).unwrap(),
    );
    let raw = sim.add_station(
        "raw",
        line(),
        Link::new(si_3964r::Config::default().with_settings(line())).unwrap(),
    );
    sim.connect(st, raw);
    sim.with(st, |s, now| {
        s.fetch(now, Address::Flags(0), Coordination::NONE, 1)
    })
    .unwrap();
    sim.run_until(Instant::from_micros(5_500_000));
    assert!(sim.take_events(st).contains(&Event::Failed {
        job: si_rk512::JobId(1),
        status: status::NO_REACTION
    }));
}

/// `[derived]`: counters go out as 'Z' by default and as 'C' with `CounterLetter::C`; the passive
/// side serves both.
#[test]
fn a10_counter_letter_z_by_default_c_as_a_setting() {
    for (letter, byte) in [
        (si_rk512::CounterLetter::Z, b'Z'),
        (si_rk512::CounterLetter::C, b'C'),
    ] {
        let mut sim = Simulator::new(53);
        let mut c = high();
        c.counter_letter = letter;
        let a = sim.add_station("A", line(), Station::new(c.with_settings(line())).unwrap());
        let b = sim.add_station(
            "B",
            line(),
            Station::serving(Config::default().with_settings(line()), &memory()).unwrap(),
        );
        sim.connect(a, b);
        sim.with(b, |s, _| {
            s.server_mut()
                .memory_mut()
                .set_element(Area::Counters, 3, 0x0042)
                .unwrap()
        });
        let mut p = Pair { sim, a, b };
        assert_eq!(p.fetch(Address::Counters(3), 2).unwrap(), &[0, 0x42][..]);
        let sent: Vec<u8> = p
            .sim
            .trace()
            .received("B")
            .iter()
            .map(|(_, b)| *b)
            .collect();
        let header = [0u8, 0, b'E', byte, 0, 3, 0, 1];
        assert!(sent.windows(8).any(|w| w == header), "{letter:?}");
    }
}

/// [Public RK 512]: a partner whose byte 6 is a byte offset ("DW 64 = 80H") is served with
/// `DwUnit::Bytes`.
#[test]
fn s4_2_dw_number_as_byte_offset_setting() {
    let bytes_config = Config {
        dw_unit: si_rk512::DwUnit::Bytes,
        ..Config::default()
    };
    let mut s = scripted_with(52, bytes_config);
    // SEND 1 word to DB10 "DW 0x80": byte offset 128, not 256.
    assert_eq!(
        s.exchange(&[0, 0, b'A', b'D', 10, 0x80, 0, 1, 0xFF, 0xFF, 0xCA, 0xFE]),
        [0, 0, 0, 0]
    );
    let m = s.sim.engine(s.station).server().memory();
    assert_eq!(m.word(Area::Db(10), 128).unwrap(), 0xCAFE);
    assert_eq!(m.word(Area::Db(10), 256).unwrap(), 0);
}

/// Fig. 2-18, [CP 341 Diag] class 0AH: a first reaction where the continuation
/// reaction was due ends the job with 0A01; byte 1 neither 00H nor FFH with 0A02; a FETCH
/// reaction with missing data with 0A03; a SEND reaction with data with 0A04.
#[test]
fn s4_7_faulty_reactions_0a01_to_0a04() {
    /// SEND to this DB (`Some`) or FETCH of flag bytes (`None`), and the length.
    type Job = (Option<Address>, usize);
    let send = |len: usize| (Some(Address::Db { db: 1, dw: 0 }), len);
    let fetch = |len: usize| (None, len);
    let cases: [(Job, &[&[u8]], Status); 4] = [
        (
            send(200),
            &[&[0, 0, 0, 0], &[0, 0, 0, 0]],
            status::REACTION_SEQUENCE,
        ),
        (
            fetch(3),
            &[&[0, 0, 0, 0, 1, 2]],
            status::REACTION_DATA_AMOUNT,
        ),
        (
            send(2),
            &[&[0, 0, 0, 0, 9]],
            status::SEND_REACTION_WITH_DATA,
        ),
        (fetch(1), &[&[0x12, 0, 0, 0, 7]], status::REACTION_HEADER),
    ];
    for (i, ((to, len), reactions, expected)) in cases.into_iter().enumerate() {
        let (mut sim, st, raw) = active_against_script(60 + i as u64);
        let got = run_job(
            &mut sim,
            st,
            raw,
            move |s, now| {
                match to {
                    Some(to) => s.send(now, to, Coordination::NONE, vec![0; len]),
                    None => s.fetch(now, Address::Flags(0), Coordination::NONE, len),
                }
                .unwrap();
            },
            reactions,
        );
        assert_eq!(got, expected, "case {i}");
    }
}

/// Fig. 2-13 on the wire: the SEND telegram of 50 data words to DB10 from DW1 goes out as one
/// 3964(R) block after `STX`/`DLE`, header first.
#[test]
fn fig_2_13_send_telegram_on_the_wire() {
    let (mut sim, st, raw) = active_against_script(70);
    let data: Vec<u8> = (0..100).collect();
    sim.with(st, |s, now| {
        s.send(
            now,
            Address::Db { db: 10, dw: 1 },
            Coordination::cpu_only(1),
            data.clone(),
        )
    })
    .unwrap();
    sim.run_for(Duration::from_secs(1));
    let block = sim.with(raw, |l, now| l.take_block(now)).unwrap();
    assert_eq!(
        &block[..10],
        &[0x00, 0x00, 0x41, 0x44, 0x0A, 0x01, 0x00, 0x32, 0xFF, 0x1F]
    );
    assert_eq!(&block[10..], &data[..]);
}

/// [CP 341] §2.2.3, Fig. 2-17 quasi-full-duplex: both stations serve and both start a
/// multi-telegram job at once; telegrams interleave and both jobs complete.
#[test]
fn s4_6_both_sides_run_jobs_at_once() {
    let mut sim = Simulator::new(80);
    let mut ha = high();
    ha.link.receive_buffer_blocks = 2;
    let a = sim.add_station(
        "A",
        line(),
        Station::serving(ha.with_settings(line()), &memory()).unwrap(),
    );
    let b = sim.add_station(
        "B",
        line(),
        Station::serving(Config::default().with_settings(line()), &memory()).unwrap(),
    );
    sim.connect(a, b);
    let da = pattern(400, 1);
    let db = pattern(300, 2);
    let to = Address::Db { db: 10, dw: 0 };
    let (x, y) = (da.clone(), db.clone());
    let ja = sim
        .with(a, |s, now| s.send(now, to, Coordination::NONE, x))
        .unwrap();
    let jb = sim
        .with(b, |s, now| s.send(now, to, Coordination::NONE, y))
        .unwrap();
    sim.run_until_quiet(Instant::from_micros(120_000_000));
    let ea = sim.take_events(a);
    let eb = sim.take_events(b);
    assert!(
        ea.contains(&Event::Done {
            job: ja,
            data: Bytes::new()
        }),
        "{ea:?}"
    );
    assert!(
        eb.contains(&Event::Done {
            job: jb,
            data: Bytes::new()
        }),
        "{eb:?}"
    );
    assert_eq!(
        &sim.engine(b).server().memory().bytes(Area::Db(10)).unwrap()[..400],
        &da[..]
    );
    assert_eq!(
        &sim.engine(a).server().memory().bytes(Area::Db(10)).unwrap()[..300],
        &db[..]
    );
}

/// [CP 341] §2.2.3, Fig. 2-17: one job at a time; bad requests are refused with their FB STATUS.
#[test]
fn s4_6_one_job_at_a_time_and_request_checks() {
    let mut p = pair(90);
    let at = Address::Db { db: 10, dw: 0 };
    p.sim
        .with(p.a, |s, now| s.fetch(now, at, Coordination::NONE, 2))
        .unwrap();
    let busy = p
        .sim
        .with(p.a, |s, now| s.fetch(now, at, Coordination::NONE, 2))
        .unwrap_err();
    assert_eq!(busy.status(), si_core::status::common::NOT_POSSIBLE_IN_MODE);
    p.outcome().unwrap();
    let odd = p
        .sim
        .with(p.a, |s, now| s.send(now, at, Coordination::NONE, vec![1]))
        .unwrap_err();
    assert_eq!(odd.status(), si_core::status::common::INVALID_LEN);
    let big = p
        .sim
        .with(p.a, |s, now| s.fetch(now, at, Coordination::NONE, 1026))
        .unwrap_err();
    assert_eq!(big.status(), si_core::status::common::INVALID_LEN);
    let to_m = p
        .sim
        .with(p.a, |s, now| {
            s.send(now, Address::Flags(0), Coordination::NONE, vec![1])
        })
        .unwrap_err();
    assert_eq!(
        to_m.status(),
        si_core::status::common::PARAMETER_OUT_OF_RANGE
    );
}

/// [CP 341] §2.2.2, §2.3.1 under §2.2.3, §2.3.2, [CP 341 Diag] "chained reports": when the partner
/// never acknowledges, the link's 0703 is reported first and the job ends with 051A.
#[test]
fn s4_1_link_failure_0703_then_051a() {
    let mut p = pair(100);
    p.sim.silence(p.b, Instant::ZERO);
    let job = p
        .sim
        .with(p.a, |s, now| {
            s.fetch(now, Address::Flags(0), Coordination::NONE, 1)
        })
        .unwrap();
    p.settle();
    assert_eq!(
        p.sim.take_events(p.a),
        [
            Event::ProcedureError(si_3964r::status::SETUP_TIMEOUT),
            Event::Failed {
                job,
                status: status::COMMAND_NOT_SENT
            }
        ]
    );
    assert_eq!(
        p.sim.engine(p.a).last_cause(),
        Some(si_3964r::status::SETUP_TIMEOUT)
    );
}
