//! End to end on the simulators: a user program calls S_SEND through the window of module A, the
//! module runs a real line engine (si-3964r or si-ascii) on a simulated line to module B, and a
//! second user program calls S_RCV through module B's window
//! ([ET200S SI 2005] §2.12.1–§2.12.7 `[derived]`: the module answers the send job only after the
//! frame has left; [ET200S SI 2005] §2.12.7: receive errors reach the next receive job as 20H +
//! STATUS; §2.10 the FBs).
//!
//! Each DP cycle (2 ms of virtual time) every user program calls its FBs once, each host engine
//! runs one cycle and its module one cycle; then the line simulator runs for the rest of the
//! cycle. Every test counts the FB completions: each job ends exactly once.

use si_core::fb::Channel;
use si_core::job::FramePort;
use si_core::{Duration, Engine, Instant, SerialSettings, Status};
use si_dp_coord::engines;
use si_dp_coord::fb::{Done, Received, SRcv, SSend, SVset, SXon};
use si_dp_coord::line::EngineSerial;
use si_dp_coord::module::Module;
use si_dp_coord::{Host, HostConfig, WindowSize};
use si_sim::{Simulator, StationId};

/// DP cycle of the simulated master.
const CYCLE: Duration = Duration::from_millis(2);

type Station<E> = StationId<Module<EngineSerial<E>>>;

/// One DP slave as its host sees it: the module station, the host engine, the input window.
struct Side<E: Engine> {
    station: Station<E>,
    host: Host,
    input: Vec<u8>,
}

impl<E: Engine + 'static> Side<E>
where
    E::Event: 'static,
{
    fn new(
        sim: &mut Simulator,
        name: &str,
        settings: SerialSettings,
        module: Module<EngineSerial<E>>,
    ) -> Self {
        let window = module.config().window;
        let input = module.input().to_vec();
        let station = sim.add_station(name, settings, module);
        Side {
            station,
            host: Host::new(HostConfig::new(window)).unwrap(),
            input,
        }
    }

    /// The host's and the module's cycle, with the window exchange between them.
    fn dp_cycle(&mut self, sim: &mut Simulator) {
        let out = self.host.cycle(sim.now(), &self.input).to_vec();
        self.input = sim.with(self.station, |m, now| m.cycle(now, &out).to_vec());
    }
}

/// What the user programs saw: every call with DONE/ERROR or NDR/ERROR set.
#[derive(Debug, Default)]
struct Seen {
    sends: Vec<(Instant, Done)>,
    receives: Vec<(Instant, Received, Vec<u8>)>,
}

/// S_SEND (REQ on from the first call) on `a`, S_RCV (EN_R = 1) on `b`, for `cycles` DP cycles.
fn send_and_receive<A, B>(
    sim: &mut Simulator,
    a: &mut Side<A>,
    b: &mut Side<B>,
    data: &[u8],
    cycles: usize,
) -> Seen
where
    A: Engine + 'static,
    B: Engine + 'static,
    A::Event: 'static,
    B::Event: 'static,
{
    let mut s_send = SSend::default();
    let mut s_rcv = SRcv::default();
    let mut dest = [0u8; 256];
    let mut seen = Seen::default();
    for _ in 0..cycles {
        let d = s_send.call(&mut a.host, sim.now(), true, false, data);
        if d.done || d.error {
            seen.sends.push((sim.now(), d));
        }
        let r = s_rcv.call(&mut b.host, sim.now(), true, false, &mut dest);
        if r.ndr || r.error {
            seen.receives.push((sim.now(), r, dest[..r.len].to_vec()));
        }
        a.dp_cycle(sim);
        b.dp_cycle(sim);
        sim.run_for(CYCLE);
    }
    seen
}

/// 100 bytes with DLE (10H) and ETX (03H) among them, so the 3964(R) sender doubles DLEs.
fn payload(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i as u8).wrapping_mul(7) ^ 0x10).collect()
}

fn r3964r_pair(window: WindowSize) -> (Simulator, Side<si_3964r::Link>, Side<si_3964r::Link>) {
    let settings = SerialSettings::default();
    let high = si_3964r::Config {
        priority: si_3964r::config::Priority::High,
        ..si_3964r::Config::default()
    };
    let mut sim = Simulator::new(3);
    let a = engines::r3964r_module(
        window,
        si_3964r::Link::new(high.with_settings(settings)).unwrap(),
    )
    .unwrap();
    let b = engines::r3964r_module(
        window,
        si_3964r::Link::new(si_3964r::Config::default().with_settings(settings)).unwrap(),
    )
    .unwrap();
    let a = Side::new(&mut sim, "A", settings, a);
    let b = Side::new(&mut sim, "B", settings, b);
    sim.connect(a.station, b.station);
    (sim, a, b)
}

fn ascii_pair(window: WindowSize) -> (Simulator, Side<si_ascii::Link>, Side<si_ascii::Link>) {
    let config = si_ascii::Config {
        flow_control: si_ascii::FlowControl::XonXoff,
        tx_chunk: 1,
        ..si_ascii::Config::default()
    };
    let mut sim = Simulator::new(4);
    let a = engines::ascii_module(window, si_ascii::Link::new(config).unwrap()).unwrap();
    let b = engines::ascii_module(window, si_ascii::Link::new(config).unwrap()).unwrap();
    let a = Side::new(&mut sim, "A", config.settings, a);
    let b = Side::new(&mut sim, "B", config.settings, b);
    sim.connect(a.station, b.station);
    (sim, a, b)
}

fn assert_delivered_once(seen: &Seen, data: &[u8], last_char_at_b: Instant) {
    assert_eq!(seen.sends.len(), 1, "{:?}", seen.sends);
    let (done_at, d) = seen.sends[0];
    assert!(d.done && !d.error, "{d:?}");
    assert_eq!(d.status, Status::OK);
    // [ET200S SI 2005] §2.12.1–§2.12.7 [derived]: the end-of-job acknowledgement only after the
    // frame has left.
    assert!(done_at >= last_char_at_b, "{done_at} < {last_char_at_b}");
    assert_eq!(seen.receives.len(), 1, "{:?}", seen.receives);
    let (_, r, bytes) = &seen.receives[0];
    assert!(r.ndr && !r.error, "{r:?}");
    assert_eq!(r.status, Status::OK);
    assert_eq!(r.len, data.len());
    assert_eq!(bytes.as_slice(), data);
}

#[test]
fn section_2_9_s_send_module_a_3964r_module_b_s_rcv_every_window_size() {
    for window in WindowSize::ALL {
        let (mut sim, mut a, mut b) = r3964r_pair(window);
        let data = payload(100);
        let seen = send_and_receive(&mut sim, &mut a, &mut b, &data, 1_000);
        let line = sim.trace().received("B");
        let bytes: Vec<u8> = line.iter().map(|&(_, c)| c).collect();
        // The 3964(R) block on the line: STX … data with DLE doubled … DLE ETX BCC. B's
        // startup NAK and its DLEs go the other way.
        let stx = bytes.iter().position(|&c| c == 0x02).unwrap();
        let body = &bytes[stx + 1..];
        let doubled = data.iter().filter(|&&c| c == 0x10).count();
        assert_eq!(body.len(), data.len() + doubled + 3, "{window:?}");
        assert_eq!(&body[body.len() - 3..body.len() - 1], &[0x10, 0x03]);
        let bcc = body[..body.len() - 1]
            .iter()
            .fold(0x02 ^ 0x02, |x, &c| x ^ c);
        assert_eq!(body[body.len() - 1], bcc, "BCC over data, DLE, ETX");
        assert_delivered_once(&seen, &data, line.last().unwrap().0);
    }
}

#[test]
fn section_2_9_s_send_module_a_ascii_module_b_s_rcv_every_window_size() {
    for window in WindowSize::ALL {
        let (mut sim, mut a, mut b) = ascii_pair(window);
        // No XON/XOFF characters in the user data ([ET200S SI 2005] Tables 3-65 to 3-72 forbids
        // them under XON/XOFF).
        let data: Vec<u8> = (0..150u8).map(|i| b'0' + i % 64).collect();
        let seen = send_and_receive(&mut sim, &mut a, &mut b, &data, 1_000);
        let line = sim.trace().received("B");
        let bytes: Vec<u8> = line.iter().map(|&(_, c)| c).collect();
        // The ASCII driver puts the frame on the line as it is: end by character delay time.
        assert_eq!(bytes, data, "{window:?}");
        assert_delivered_once(&seen, &data, line.last().unwrap().0);
    }
}

#[test]
fn both_directions_in_turn_3964r() {
    let (mut sim, mut a, mut b) = r3964r_pair(WindowSize::Eight);
    let seen = send_and_receive(&mut sim, &mut a, &mut b, b"request", 300);
    assert_delivered_once(&seen, b"request", Instant::ZERO);
    let seen = send_and_receive(&mut sim, &mut b, &mut a, b"response", 300);
    assert_delivered_once(&seen, b"response", Instant::ZERO);
}

#[test]
fn section_2_8_partner_transmit_wire_cut_s_send_error_carries_the_3964r_status() {
    let settings = SerialSettings::default();
    let config = si_3964r::Config {
        ack_delay: si_core::Duration::from_millis(100),
        connection_attempts: 2,
        ..si_3964r::Config::default()
    };
    let mut sim = Simulator::new(5);
    let a = engines::r3964r_module(
        WindowSize::Four,
        si_3964r::Link::new(config.with_settings(settings)).unwrap(),
    )
    .unwrap();
    let b = engines::r3964r_module(
        WindowSize::Four,
        si_3964r::Link::new(config.with_settings(settings)).unwrap(),
    )
    .unwrap();
    let mut a = Side::new(&mut sim, "A", settings, a);
    let mut b = Side::new(&mut sim, "B", settings, b);
    sim.connect(a.station, b.station);
    sim.silence(b.station, Instant::ZERO);
    let seen = send_and_receive(&mut sim, &mut a, &mut b, b"hello", 2_000);
    // Each STX unanswered for QVZ, attempts used up: 0703H through the window (7xH + 0703H).
    assert_eq!(seen.sends.len(), 1, "{:?}", seen.sends);
    let d = seen.sends[0].1;
    assert!(d.error && !d.done);
    assert_eq!(d.status, si_3964r::status::SETUP_TIMEOUT);
    // B heard each STX, answered DLE into the cut wire and waited in vain for the block: its
    // S_RCV reports the character delay time (0806H); repeats of the same error collapse.
    assert!(!seen.receives.is_empty());
    for (_, r, _) in &seen.receives {
        assert!(r.error && !r.ndr);
        assert_eq!(r.status, si_3964r::status::CHARACTER_DELAY);
    }
}

#[test]
fn section_2_8_case_2_break_at_module_b_reaches_s_rcv_as_080d() {
    let (mut sim, mut a, mut b) = r3964r_pair(WindowSize::Eight);
    sim.run_for(Duration::from_millis(20));
    sim.schedule_break(b.station, sim.now() + Duration::from_millis(1));
    // S_SEND with REQ never set: drive only S_RCV.
    let mut s_rcv = SRcv::default();
    let mut dest = [0u8; 16];
    let mut seen = Vec::new();
    for _ in 0..200 {
        let r = s_rcv.call(&mut b.host, sim.now(), true, false, &mut dest);
        if r.ndr || r.error {
            seen.push(r);
        }
        a.dp_cycle(&mut sim);
        b.dp_cycle(&mut sim);
        sim.run_for(CYCLE);
    }
    assert_eq!(seen.len(), 1, "{seen:?}");
    assert!(seen[0].error && !seen[0].ndr);
    assert_eq!(seen[0].status, si_3964r::status::BREAK);
}

#[test]
fn section_2_6_s_xon_and_s_vset_through_the_window_reach_the_ascii_engine() {
    let (mut sim, mut a, mut b) = ascii_pair(WindowSize::Four);
    let mut s_xon = SXon::default();
    let mut s_vset = SVset::default();
    let mut xon_done = Vec::new();
    let mut vset_done = Vec::new();
    for _ in 0..100 {
        let d = s_xon.call(
            &mut a.host,
            true,
            false,
            0x11,
            0x13,
            Duration::from_millis(3_000),
        );
        if d.done || d.error {
            xon_done.push(d);
        }
        // Only RS-422/485 and automatic V.24 refuse S_VSET ([ET200S SI] §2.8): RTS and DTR go on
        // the line.
        let v = s_vset.call(&mut b.host, true, false, true, true);
        if v.done || v.error {
            vset_done.push(v);
        }
        a.dp_cycle(&mut sim);
        b.dp_cycle(&mut sim);
        sim.run_for(CYCLE);
    }
    assert_eq!(xon_done.len(), 1, "{xon_done:?}");
    assert!(xon_done[0].done, "{xon_done:?}");
    let a_cfg = sim.engine(a.station).serial().engine().config().xon_xoff;
    assert_eq!(a_cfg.wait_for_xon, si_core::Duration::from_millis(3_000));
    assert_eq!(vset_done.len(), 1, "{vset_done:?}");
    assert!(vset_done[0].done, "{vset_done:?}");
    let signals = sim.engine(b.station).serial().engine().signals();
    assert!(signals.rts && signals.dtr);
}

#[test]
fn section_2_6_wrong_parameter_block_is_refused_with_0550h() {
    // The ASCII module is configured for XON/XOFF; an RTS/CTS block gets 0550H; 3964(R) has no
    // flow control at all, so any block gets 0550H.
    let (mut sim, mut a, mut b) = ascii_pair(WindowSize::Eight);
    let (mut rsim, mut ra, mut rb) = r3964r_pair(WindowSize::Eight);
    let mut s_rts = si_dp_coord::fb::SRts::default();
    let mut s_xon = SXon::default();
    let mut got = Vec::new();
    for _ in 0..100 {
        let d = s_rts.call(&mut a.host, true, false, Duration::from_millis(2_000));
        let e = s_xon.call(
            &mut ra.host,
            true,
            false,
            0x11,
            0x13,
            Duration::from_millis(2_000),
        );
        got.extend([d, e].into_iter().filter(|d| d.done || d.error));
        a.dp_cycle(&mut sim);
        b.dp_cycle(&mut sim);
        sim.run_for(CYCLE);
        ra.dp_cycle(&mut rsim);
        rb.dp_cycle(&mut rsim);
        rsim.run_for(CYCLE);
    }
    assert_eq!(got.len(), 2, "{got:?}");
    for d in got {
        assert!(d.error);
        assert_eq!(d.status.code(), 0x0550);
    }
}

/// One user program, written once against si-core's [`Channel`] and any [`FramePort`]: S_SEND
/// with REQ held until DONE/ERROR, S_RCV with EN_R = 1; it logs every output with DONE, ERROR
/// or NDR set.
#[derive(Debug, Default)]
struct UserProgram {
    channel: Channel,
    dest: Vec<u8>,
    log: Vec<String>,
    sent: bool,
}

impl UserProgram {
    fn new() -> Self {
        UserProgram {
            channel: Channel::default(),
            dest: vec![0; 256],
            log: Vec::new(),
            sent: false,
        }
    }

    fn cycle<P: FramePort>(&mut self, port: &mut P, now: Instant, data: Option<&[u8]>) {
        if let Some(data) = data.filter(|_| !self.sent) {
            let d = self.channel.s_send.call(port, now, true, false, data);
            if d.done || d.error {
                self.sent = true;
                self.log.push(format!(
                    "send done={} error={} {:04X}",
                    d.done,
                    d.error,
                    d.status.code()
                ));
            }
        }
        let r = self
            .channel
            .s_rcv
            .call(port, now, true, false, &mut self.dest);
        if r.ndr || r.error {
            self.log.push(format!(
                "rcv ndr={} error={} {:04X} {:02X?}",
                r.ndr,
                r.error,
                r.status.code(),
                &self.dest[..r.len]
            ));
        }
    }
}

/// The same two user programs, first on two engines connected directly, then each behind a
/// window module: the same outputs.
fn direct_and_window<E>(
    make: impl Fn(bool) -> E,
    module: impl Fn(E) -> Module<EngineSerial<E>>,
    settings: SerialSettings,
) -> (Vec<String>, Vec<String>, Vec<String>, Vec<String>)
where
    E: Engine + FramePort + 'static,
    E::Event: 'static,
{
    let (ping, pong) = (&b"ping 0123456789"[..], &b"pong"[..]);
    // Direct: each user program owns a line engine.
    let mut sim = Simulator::new(9);
    let a = sim.add_station("A", settings, make(true));
    let b = sim.add_station("B", settings, make(false));
    sim.connect(a, b);
    let (mut pa, mut pb) = (UserProgram::new(), UserProgram::new());
    for i in 0..1_000 {
        sim.with(a, |e, now| pa.cycle(e, now, Some(ping)));
        sim.with(b, |e, now| pb.cycle(e, now, (i > 300).then_some(pong)));
        sim.run_for(CYCLE);
    }
    // Through the window: the same programs, each on the host of a module running that engine.
    let mut sim = Simulator::new(9);
    let mut a = Side::new(&mut sim, "A", settings, module(make(true)));
    let mut b = Side::new(&mut sim, "B", settings, module(make(false)));
    sim.connect(a.station, b.station);
    let (mut wa, mut wb) = (UserProgram::new(), UserProgram::new());
    for i in 0..1_000 {
        wa.cycle(&mut a.host, sim.now(), Some(ping));
        wb.cycle(&mut b.host, sim.now(), (i > 300).then_some(pong));
        a.dp_cycle(&mut sim);
        b.dp_cycle(&mut sim);
        sim.run_for(CYCLE);
    }
    (pa.log, pb.log, wa.log, wb.log)
}

#[test]
fn channel_same_user_program_on_3964r_directly_and_through_the_window() {
    let settings = SerialSettings::default();
    let make = |high: bool| {
        let priority = if high {
            si_3964r::config::Priority::High
        } else {
            si_3964r::config::Priority::Low
        };
        let config = si_3964r::Config {
            priority,
            ..si_3964r::Config::default()
        };
        si_3964r::Link::new(config.with_settings(settings)).unwrap()
    };
    let (pa, pb, wa, wb) = direct_and_window(
        make,
        |l| engines::r3964r_module(WindowSize::Eight, l).unwrap(),
        settings,
    );
    assert_eq!(
        pa,
        [
            "send done=true error=false 0000",
            "rcv ndr=true error=false 0000 [70, 6F, 6E, 67]"
        ]
    );
    assert_eq!(pb.len(), 2, "{pb:?}");
    assert_eq!((&pa, &pb), (&wa, &wb));
}

#[test]
fn channel_same_user_program_on_ascii_directly_and_through_the_window() {
    let config = si_ascii::Config {
        tx_chunk: 1,
        ..si_ascii::Config::default()
    };
    let (pa, pb, wa, wb) = direct_and_window(
        |_| si_ascii::Link::new(config).unwrap(),
        |l| engines::ascii_module(WindowSize::Four, l).unwrap(),
        config.settings,
    );
    assert_eq!(
        pb,
        [
            "rcv ndr=true error=false 0000 [70, 69, 6E, 67, 20, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39]",
            "send done=true error=false 0000"
        ]
    );
    assert_eq!(pa.len(), 2, "{pa:?}");
    assert_eq!((&pa, &pb), (&wa, &wb));
}

/// [ET200S SI 2005] §2.12.7 case 2 with a frame: frames and receive errors reach S_RCV in the order
/// the line engine reported them (the frame is taken out of the engine at the module's next cycle,
/// in turn).
#[test]
fn section_2_8_frames_and_receive_errors_keep_their_order() {
    for break_first in [false, true] {
        let (mut sim, mut a, mut b) = r3964r_pair(WindowSize::Eight);
        sim.run_for(Duration::from_millis(20));
        if break_first {
            sim.schedule_break(b.station, sim.now() + Duration::from_millis(1));
            sim.run_for(Duration::from_millis(10));
        }
        // A sends; B's user program does not read yet.
        let mut s_send = SSend::default();
        let mut done = false;
        for _ in 0..200 {
            let d = s_send.call(&mut a.host, sim.now(), true, false, b"first");
            done |= d.done;
            a.dp_cycle(&mut sim);
            b.dp_cycle(&mut sim);
            sim.run_for(CYCLE);
        }
        assert!(done);
        if !break_first {
            sim.schedule_break(b.station, sim.now() + Duration::from_millis(1));
            sim.run_for(Duration::from_millis(10));
        }
        let mut s_rcv = SRcv::default();
        let mut dest = [0u8; 16];
        let mut seen = Vec::new();
        for _ in 0..200 {
            let r = s_rcv.call(&mut b.host, sim.now(), true, false, &mut dest);
            if r.ndr {
                seen.push(format!("NDR {:?}", &dest[..r.len]));
            } else if r.error {
                seen.push(format!("ERROR {:04X}", r.status.code()));
            }
            a.dp_cycle(&mut sim);
            b.dp_cycle(&mut sim);
            sim.run_for(CYCLE);
        }
        let frame = format!("NDR {:?}", b"first");
        let error = "ERROR 080D".to_owned();
        let expected = if break_first {
            [error, frame]
        } else {
            [frame, error]
        };
        assert_eq!(seen, expected, "break first: {break_first}");
    }
}

/// [ET200S SI] §2.8 (the ASCII driver) through the window: under automatic V.24 control the driver
/// owns RTS and DTR, so S_VSET ends with ERROR and 0502H (40H + 0502H in the window, Table 2-26).
#[test]
fn write_v24_refused_by_the_ascii_engine_under_automatic_v24_is_0502h() {
    let config = si_ascii::Config {
        flow_control: si_ascii::FlowControl::AutoV24,
        tx_chunk: 1,
        ..si_ascii::Config::default()
    };
    let mut sim = Simulator::new(6);
    let a = engines::ascii_module(WindowSize::Four, si_ascii::Link::new(config).unwrap()).unwrap();
    let mut a = Side::new(&mut sim, "A", config.settings, a);
    let before = sim.engine(a.station).serial().engine().signals();
    let mut s_vset = SVset::default();
    let mut got = Vec::new();
    for _ in 0..50 {
        let d = s_vset.call(&mut a.host, true, false, !before.rts, !before.dtr);
        if d.done || d.error {
            got.push(d);
        }
        a.dp_cycle(&mut sim);
        sim.run_for(CYCLE);
    }
    assert_eq!(got.len(), 1, "{got:?}");
    assert!(got[0].error);
    assert_eq!(got[0].status, si_ascii::status::NOT_POSSIBLE_IN_MODE);
    let after = sim.engine(a.station).serial().engine().signals();
    assert_eq!((after.rts, after.dtr), (before.rts, before.dtr));
}
