//! The STATUS codes as the CP 341 reports them ([CP 341 Diag]), one scenario
//! per code or chain: the requester's own checks (0515, 0516), the responder's refusals
//! (060A CPU number, 0603 … 0611, 060F for a FETCH against a set coordination flag), the
//! chained reports (0703 → 051A, 07xx → 0612) through events, the FBs and S_RCV, and R
//! cancelling a running job.

use super::{active_against_script, line, memory, pair, scripted, Scripted};
use bytes::Bytes;
use si_3964r::{Link, Priority};
use si_core::fb::SRcv;
use si_core::memory::Area;
use si_core::status::common;
use si_core::{Duration, Instant, Status};
use si_rk512::fb::{FetchFb, SendFb};
use si_rk512::frame::{Address, Coordination};
use si_rk512::refusal::ServeError;
use si_rk512::status;
use si_rk512::{Config, Event, Station};
use si_sim::Simulator;

/// The 06xx codes of the station's refusals since the last call.
fn refusals(s: &mut Scripted) -> Vec<u16> {
    s.sim
        .take_events(s.station)
        .into_iter()
        .filter_map(|e| match e {
            Event::Refused { error } => Some(error.status().code()),
            _ => None,
        })
        .collect()
}

/// A FETCH command header for DB10.DW0, one word, with byte 9/10 as given.
fn fetch_db10(b9: u8, b10: u8) -> [u8; 10] {
    [0, 0, b'E', b'D', 10, 0, 0, 1, b9, b10]
}

/// Class 05H: our own flag bit above 7 is refused with 0515, a CPU number outside 0 … 4 and
/// FH with 0516, at once and without a telegram; CPU 0 … 4 and none start a job.
#[test]
fn own_flag_bit_0515_and_cpu_number_0516() {
    let mut p = pair(300);
    let at = Address::Db { db: 10, dw: 0 };
    let bad_bit = Coordination {
        flag_byte: 20,
        flag_bit: 9,
        cpu: 0,
    };
    let e = p
        .sim
        .with(p.a, |s, now| s.send(now, at, bad_bit, vec![1, 2]))
        .unwrap_err();
    assert_eq!(e.status(), status::FLAG_BIT_OUT_OF_RANGE);
    for cpu in 5..=0xE {
        let e = p
            .sim
            .with(p.a, |s, now| {
                s.fetch(now, at, Coordination::cpu_only(cpu), 2)
            })
            .unwrap_err();
        assert_eq!(e.status(), status::CPU_NUMBER_OUT_OF_RANGE, "CPU {cpu}");
    }
    assert!(!p.sim.engine(p.a).is_busy());
    // The FB shows 0516 in the call with the edge.
    let mut fb = FetchFb::default();
    let out = p.sim.with(p.a, |s, now| {
        fb.call(s, now, true, false, at, Coordination::cpu_only(7), 2)
    });
    assert!(out.result.error);
    assert_eq!(out.result.status, status::CPU_NUMBER_OUT_OF_RANGE);
    // CPU 0 … 4 and none (FH) are accepted here and by the partner.
    for cpu in [0, 1, 2, 3, 4, 0xF] {
        p.sim
            .with(p.a, |s, now| {
                s.fetch(now, at, Coordination::cpu_only(cpu), 2)
            })
            .unwrap();
        assert_eq!(p.outcome(), Ok(Bytes::from_static(&[0, 0])), "CPU {cpu}");
    }
}

/// [CP 341] §2.2.3, Table 2-1 byte 10, class 06H row 060A: the passive side serves CPU numbers 0 …
/// 4 and FH, and refuses 5H … EH with 060A (error number 14H).
#[test]
fn passive_cpu_number_accepted_0_to_4_and_none_else_060a() {
    let mut s = scripted(301);
    for cpu in [0u8, 1, 2, 3, 4, 0xF] {
        let reply = s.exchange(&fetch_db10(0xFF, (cpu << 4) | 0xF));
        assert_eq!(reply, [0, 0, 0, 0, 0, 0], "CPU {cpu:X}H");
    }
    assert_eq!(refusals(&mut s), Vec::<u16>::new());
    for cpu in 5u8..=0xE {
        let reply = s.exchange(&fetch_db10(0xFF, (cpu << 4) | 0xF));
        assert_eq!(reply, [0, 0, 0, 0x14], "CPU {cpu:X}H");
    }
    assert_eq!(refusals(&mut s), vec![0x060A; 10]);
}

/// Class 06H rows 0603, 0605, 0607, 0608, 0609 and 0611, each from a telegram that provokes
/// it, with the [inferred] error number of its reaction.
#[test]
fn passive_header_faults_0603_0605_0607_0608_0609_0611() {
    let mut s = scripted(302);
    // 0609: flag bit 9; a flag byte beyond the flag area (MB0 … MB2047 has every byte
    // number, so shrink it).
    assert_eq!(s.exchange(&fetch_db10(20, 0x09)), [0, 0, 0, 0x14]);
    let mut small = memory();
    small.memory.flags = 16;
    s.sim.with(s.station, |st, _| {
        *st.server_mut() = si_rk512::passive::Server::new(&small)
    });
    assert_eq!(s.exchange(&fetch_db10(20, 0x03)), [0, 0, 0, 0x14]);
    // 0607: DB11 (16 bytes) from DW8 = byte 16; 0608: DW7 + 2 words runs past its end, and
    // length 0.
    assert_eq!(
        s.exchange(&[0, 0, b'E', b'D', 11, 8, 0, 1, 0xFF, 0xFF]),
        [0, 0, 0, 0x14]
    );
    assert_eq!(
        s.exchange(&[0, 0, b'E', b'D', 11, 7, 0, 2, 0xFF, 0xFF]),
        [0, 0, 0, 0x14]
    );
    assert_eq!(
        s.exchange(&[0, 0, b'E', b'D', 10, 0, 0, 0, 0xFF, 0xFF]),
        [0, 0, 0, 0x14]
    );
    // 0611: 129 data bytes in one telegram.
    let mut long = vec![0, 0, b'A', b'D', 10, 0, 0, 100, 0xFF, 0xFF];
    long.extend([1u8; 129]);
    assert_eq!(s.exchange(&long), [0, 0, 0, 0x34]);
    // 0603 and 0605: a SEND of 200 bytes, continued with another command or data type.
    let mut first = vec![0, 0, b'A', b'D', 10, 0, 0, 100, 0xFF, 0xFF];
    first.extend([7u8; 128]);
    assert_eq!(s.exchange(&first), [0, 0, 0, 0]);
    assert_eq!(s.exchange(&[0xFF, 0, b'E', b'D']), [0xFF, 0, 0, 0x16]);
    assert_eq!(s.exchange(&first), [0, 0, 0, 0]);
    let mut cont = vec![0xFF, 0, b'A', b'M'];
    cont.extend([7u8; 72]);
    assert_eq!(s.exchange(&cont), [0xFF, 0, 0, 0x10]);
    assert_eq!(
        refusals(&mut s),
        [0x0609, 0x0609, 0x0607, 0x0608, 0x0608, 0x0611, 0x0603, 0x0605]
    );
}

/// Class 06H row 060C through S_RCV: a FETCH with data is refused, and S_RCV shows ERROR with
/// 060C once; R on S_RCV drops what it has not shown.
#[test]
fn s_rcv_shows_060c_for_a_fetch_with_data() {
    let mut s = scripted(303);
    let mut t = fetch_db10(0xFF, 0xFF).to_vec();
    t.push(9);
    assert_eq!(s.exchange(&t), [0, 0, 0, 0x34]);
    let mut rcv = SRcv::default();
    let mut buf = [0u8; 16];
    let r = s.sim.with(s.station, |st, now| {
        rcv.call(st, now, true, false, &mut buf)
    });
    assert!(r.error && !r.ndr);
    assert_eq!(r.status, status::FETCH_WITH_DATA);
    let r = s.sim.with(s.station, |st, now| {
        rcv.call(st, now, true, false, &mut buf)
    });
    assert!(!r.error, "shown once");
    assert_eq!(s.exchange(&t), [0, 0, 0, 0x34]);
    s.sim
        .with(s.station, |st, now| rcv.call(st, now, true, true, &mut buf));
    let r = s.sim.with(s.station, |st, now| {
        rcv.call(st, now, true, false, &mut buf)
    });
    assert!(!r.error, "R dropped it");
}

/// [CP 341] §2.2.3 read for FETCH (passive.rs docs): a FETCH naming flag M20.3 sets it once served;
/// the next FETCH with the flag is refused with 060F (32H, the requester reads 0909) until the CPU
/// program resets the flag; a FETCH without the flag is not affected.
#[test]
fn fetch_against_a_set_coordination_flag_060f_0909() {
    let mut p = pair(304);
    let at = Address::Db { db: 10, dw: 0 };
    let km = Coordination::flag(20, 3);
    let fetch = |p: &mut super::Pair, c: Coordination| {
        p.sim.with(p.a, |s, now| s.fetch(now, at, c, 2)).unwrap();
        p.outcome()
    };
    assert_eq!(fetch(&mut p, km), Ok(Bytes::from_static(&[0, 0])));
    let flag = |p: &super::Pair| {
        p.sim
            .engine(p.b)
            .server()
            .memory()
            .bit(Area::Flags, 20, 3)
            .unwrap()
    };
    assert!(flag(&p), "a served FETCH sets its flag");
    assert_eq!(fetch(&mut p, km), Err(status::PARTNER_LOCKED));
    assert!(p.sim.take_events(p.b).contains(&Event::Refused {
        error: ServeError::Locked
    }));
    assert_eq!(
        fetch(&mut p, Coordination::NONE),
        Ok(Bytes::from_static(&[0, 0]))
    );
    p.sim.with(p.b, |s, _| {
        s.server_mut()
            .memory_mut()
            .set_bit(Area::Flags, 20, 3, false)
            .unwrap()
    });
    assert_eq!(fetch(&mut p, km), Ok(Bytes::from_static(&[0, 0])));
}

/// [CP 341 Diag] chained reports through the FB: ERROR with 0703 in one call, ERROR with 051A in
/// the next.
#[test]
fn send_fb_shows_0703_then_051a() {
    let mut p = pair(305);
    p.sim.silence(p.b, Instant::ZERO);
    let mut fb = SendFb::default();
    let at = Address::Db { db: 10, dw: 0 };
    let mut errors = Vec::new();
    for _ in 0..2000 {
        let out = p.sim.with(p.a, |s, now| {
            fb.call(s, now, true, false, at, Coordination::NONE, &[1, 2])
        });
        assert!(!out.result.done);
        if out.result.error {
            errors.push(out.result.status);
        } else if !errors.is_empty() {
            break;
        }
        p.sim.run_for(Duration::from_millis(10));
    }
    assert_eq!(
        errors,
        [si_3964r::status::SETUP_TIMEOUT, status::COMMAND_NOT_SENT]
    );
}

/// [CP 341 Diag] chained reports on the passive side: our reaction cannot be delivered (the
/// partner's receive buffer stays full, so it refuses our STX), so the link's 07xx comes first and
/// then 0612, in the event stream and through S_RCV.
#[test]
fn failed_reaction_send_07xx_then_0612() {
    let mut sim = Simulator::new(306);
    let station = sim.add_station(
        "station",
        line(),
        Station::serving(Config::default().with_settings(line()), &memory()).unwrap(),
    );
    let raw_config = si_3964r::Config {
        priority: Priority::High,
        receive_buffer_blocks: 1,
        ..si_3964r::Config::default()
    };
    let raw = sim.add_station(
        "raw",
        line(),
        Link::new(raw_config.with_settings(line())).unwrap(),
    );
    sim.connect(station, raw);
    for _ in 0..2 {
        let t = Bytes::copy_from_slice(&fetch_db10(0xFF, 0xFF));
        sim.with(raw, |l, now| l.send(now, t)).unwrap();
        sim.run_for(Duration::from_secs(30));
    }
    let events: Vec<Event> = sim
        .take_events(station)
        .into_iter()
        .filter(|e| !matches!(e, Event::Served { .. }))
        .collect();
    let [Event::ProcedureError(cause), Event::ServeAborted(status)] = events[..] else {
        panic!("{events:?}");
    };
    assert_eq!(cause.class(), 0x07, "{cause}");
    assert_eq!(status, si_rk512::status::REACTION_NOT_SENT);
    let mut rcv = SRcv::default();
    let mut buf = [0u8; 4];
    let mut shown = Vec::new();
    for _ in 0..3 {
        let r = sim.with(station, |st, now| rcv.call(st, now, true, false, &mut buf));
        if r.error {
            shown.push(r.status);
        }
    }
    assert_eq!(shown, [cause, si_rk512::status::REACTION_NOT_SENT]);
}

/// R cancels the running job at once: ERROR with 1E0D, the next REQ starts a new job in the
/// next call (no 0502H), the partner's late reaction to the cancelled telegram is reported as
/// 0A01, and the new job gets its own reaction.
#[test]
fn reset_cancels_the_job_and_the_next_req_succeeds() {
    let (mut sim, st, raw) = active_against_script(307);
    let mut fb = FetchFb::default();
    let at = Address::Flags(0);
    let out = sim.with(st, |s, now| {
        fb.call(s, now, true, false, at, Coordination::NONE, 2)
    });
    assert!(!out.result.error && !out.result.done);
    // The command is acknowledged and the partner has not answered yet.
    sim.run_for(Duration::from_millis(200));
    assert!(sim.with(raw, |l, now| l.take_block(now)).is_some());
    let out = sim.with(st, |s, now| {
        fb.call(s, now, false, true, at, Coordination::NONE, 2)
    });
    assert!(out.result.error);
    assert_eq!(out.result.status, common::ABORTED_BY_RESET);
    assert!(!sim.engine(st).is_busy(), "the station forgot the job");
    let out = sim.with(st, |s, now| {
        fb.call(s, now, true, false, at, Coordination::NONE, 2)
    });
    assert!(!out.result.error, "no 0502H: {:?}", out.result.status);
    assert!(sim.engine(st).is_busy());
    sim.run_for(Duration::from_millis(200));
    assert!(sim.with(raw, |l, now| l.take_block(now)).is_some());
    // The late reaction to the cancelled FETCH, then the one to the new FETCH.
    for reaction in [[0u8, 0, 0, 0, 0xAA, 0xBB], [0, 0, 0, 0, 0x12, 0x34]] {
        sim.with(raw, |l, now| l.send(now, Bytes::copy_from_slice(&reaction)))
            .unwrap();
        sim.run_for(Duration::from_millis(200));
    }
    let mut got = None;
    for _ in 0..10 {
        let out = sim.with(st, |s, now| {
            fb.call(s, now, true, false, at, Coordination::NONE, 2)
        });
        assert!(!out.result.error, "{:?}", out.result.status);
        if out.result.done {
            got = out.data;
            break;
        }
        sim.run_for(Duration::from_millis(10));
    }
    assert_eq!(got.as_deref(), Some(&[0x12, 0x34][..]));
    let events = sim.take_events(st);
    assert!(
        events.contains(&Event::ReceiveError(status::REACTION_SEQUENCE)),
        "{events:?}"
    );
    assert_eq!(
        events
            .iter()
            .filter(|e| matches!(e, Event::Done { .. } | Event::Failed { .. }))
            .count(),
        1,
        "only the new job ends: {events:?}"
    );
}

/// A reaction for a job that was cancelled before its telegram left is a stray one: 0A01, and
/// a cancelled job leaves no outcome behind.
#[test]
fn reaction_without_a_job_is_0a01() {
    let (mut sim, st, raw) = active_against_script(308);
    let job = sim
        .with(st, |s, now| {
            s.fetch(now, Address::Flags(0), Coordination::NONE, 2)
        })
        .unwrap();
    sim.with(st, |s, _| s.cancel(job));
    assert_eq!(sim.engine(st).queued_telegrams(), 0);
    sim.run_for(Duration::from_secs(1));
    sim.with(raw, |l, now| {
        l.send(now, Bytes::from_static(&[0, 0, 0, 0, 1, 2]))
    })
    .unwrap();
    sim.run_for(Duration::from_secs(12));
    let events = sim.take_events(st);
    assert_eq!(
        events,
        [Event::ReceiveError(status::REACTION_SEQUENCE)],
        "{events:?}"
    );
    assert_eq!(
        sim.engine(st).job_outcome(job),
        None::<Result<Bytes, Status>>
    );
}

/// Class 06H row 0611, "actual frame length and header length disagree", read narrowly
/// (`[derived]`, see `ServeError::FrameLength`): a SEND telegram whose data disagree with its
/// header's length is 060B, a FETCH command with data 060C, and only a telegram with more
/// data than any header can announce in one telegram (over 128 bytes) is 0611.
#[test]
fn passive_0611_only_beyond_128_data_bytes_other_length_disagreements_060b_060c() {
    let mut s = scripted(303);
    let send = |words: u8, data: usize| {
        let mut t = vec![0, 0, b'A', b'D', 10, 0, 0, words, 0xFF, 0xFF];
        t.extend(std::iter::repeat_n(5u8, data));
        t
    };
    // 100 words = 200 bytes: the first telegram must carry 128.
    assert_eq!(s.exchange(&send(100, 127)), [0, 0, 0, 0x34]);
    assert_eq!(s.exchange(&send(1, 3)), [0, 0, 0, 0x34]);
    assert_eq!(s.exchange(&send(1, 1)), [0, 0, 0, 0x34]);
    assert_eq!(
        s.exchange(&[0, 0, b'E', b'D', 10, 0, 0, 1, 0xFF, 0xFF, 1, 2]),
        [0, 0, 0, 0x34]
    );
    assert_eq!(s.exchange(&send(1, 129)), [0, 0, 0, 0x34]);
    assert_eq!(s.exchange(&send(100, 129)), [0, 0, 0, 0x34]);
    assert_eq!(
        refusals(&mut s),
        vec![0x060B, 0x060B, 0x060B, 0x060C, 0x0611, 0x0611]
    );
}
