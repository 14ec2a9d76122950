//! Several clients at once: a full queue answers 06H, and answers are never mixed up between
//! clients (each gets its own transaction ids and its own data).

use super::harness::{read_holding, Mbap, Rig};

/// The diagnostic unit of [`a_full_queue_answers_slave_device_busy`]'s rig.
const DIAGNOSTIC_UNIT: u8 = 247;

/// Polls the diagnostic unit's block of the silent line (line 1: input registers 32–47, see
/// the map in `cmd/gateway/counters.rs`) until the line has had `requests` requests routed to
/// it and holds `depth` in its queue (register 14 of the block). This, not a sleep, orders the
/// clients' requests; 10 s only bounds the wait.
fn until_silent_line(d: &mut Mbap, requests: u32, depth: u16) {
    let start = 16 * 2;
    let started = std::time::Instant::now();
    loop {
        d.send(0xD1, DIAGNOSTIC_UNIT, &[0x04, 0, start, 0, 15]);
        let (_, _, pdu) = d.recv();
        assert_eq!(pdu[..2], [0x04, 30], "{pdu:02X?}");
        let word = |i: usize| u16::from_be_bytes([pdu[2 + 2 * i], pdu[3 + 2 * i]]);
        let seen = (u32::from(word(0)) << 16 | u32::from(word(1)), word(14));
        if seen == (requests, depth) {
            return;
        }
        assert!(
            started.elapsed() < std::time::Duration::from_secs(10),
            "the silent line shows (requests, depth) {seen:?}, not {:?}",
            (requests, depth)
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// Queue of one, unit 2 on the silent line for 3 s per request: A's request is on the line, B's
/// waits in the queue, C's finds it full and is refused at once with 06H; A and B then get
/// 0BH with their own transaction ids.
#[test]
fn a_full_queue_answers_slave_device_busy() {
    let keys = "response_timeout_ms = 3000
retries = 0
queue = 1
pause_ms = 0";
    let Some(rig) = Rig::start(&format!("diagnostic_unit = {DIAGNOSTIC_UNIT}"), keys) else {
        return;
    };
    let (mut a, mut b, mut c, mut d) = (
        Mbap::connect(&rig.addr),
        Mbap::connect(&rig.addr),
        Mbap::connect(&rig.addr),
        Mbap::connect(&rig.addr),
    );
    a.send(0xA1, 2, &read_holding(0, 1));
    // A's request left the queue for the line: the queue is empty again.
    until_silent_line(&mut d, 1, 0);
    b.send(0xB1, 2, &read_holding(0, 1));
    // B's request waits behind it: the queue of one is full.
    until_silent_line(&mut d, 2, 1);
    c.send(0xC1, 2, &read_holding(0, 1));
    assert_eq!(c.recv(), (0xC1, 2, vec![0x83, 0x06]));
    assert_eq!(a.recv(), (0xA1, 2, vec![0x83, 0x0B]));
    assert_eq!(b.recv(), (0xB1, 2, vec![0x83, 0x0B]));
    drop(d);
    let status = rig.stop();
    assert_eq!(status["lines"][1]["busy"], 1, "{status}");
    assert_eq!(status["lines"][1]["timeouts"], 2, "{status}");
    // The refused request counts too: the outcomes add up to the requests.
    assert_eq!(status["lines"][1]["requests"], 3, "{status}");
}

/// Two clients at once, each reading its own register with its own run of transaction ids
/// (two requests per write, so the gateway also splits pipelined frames): every answer
/// carries the asking client's id and value.
#[test]
fn two_clients_answers_are_never_mixed() {
    let Some(rig) = Rig::start("", "pause_ms = 0") else {
        return;
    };
    let client = |base: u16, register: u16| {
        let addr = rig.addr.clone();
        std::thread::spawn(move || {
            let mut m = Mbap::connect(&addr);
            for i in 0..10u16 {
                let (t1, t2) = (base + 2 * i, base + 2 * i + 1);
                let mut both = super::harness::frame(t1, 1, &read_holding(register, 1));
                both.extend(super::harness::frame(t2, 1, &read_holding(register + 1, 1)));
                std::io::Write::write_all(&mut m.0, &both).expect("send");
                for (tid, value) in [(t1, register), (t2, register + 1)] {
                    let [hi, lo] = value.to_be_bytes();
                    assert_eq!(m.recv(), (tid, 1, vec![0x03, 2, hi, lo]));
                }
            }
        })
    };
    let a = client(0x1000, 20);
    let b = client(0x2000, 40);
    a.join().expect("client A got only its own answers");
    b.join().expect("client B got only its own answers");
    let status = rig.stop();
    assert_eq!(status["lines"][0]["answers"], 40, "{status}");
}
