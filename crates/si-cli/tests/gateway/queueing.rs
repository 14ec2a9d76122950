//! Several clients at once: a full queue answers 06H, and answers are never mixed up between
//! clients (each gets its own transaction ids and its own data).

use super::harness::{read_holding, Mbap, Rig};

/// Queue of one, unit 2 on the silent line for 3 s per request: A's request is on the line, B's
/// waits in the queue, C's finds it full and is refused at once with 06H; A and B then get
/// 0BH with their own transaction ids.
#[test]
fn a_full_queue_answers_slave_device_busy() {
    let keys = "response_timeout_ms = 3000
retries = 0
queue = 1
pause_ms = 0";
    let Some(rig) = Rig::start("", keys) else {
        return;
    };
    let (mut a, mut b, mut c) = (
        Mbap::connect(&rig.addr),
        Mbap::connect(&rig.addr),
        Mbap::connect(&rig.addr),
    );
    // The sleeps only order the three requests; no assertion is about time.
    let settle = || std::thread::sleep(std::time::Duration::from_millis(300));
    a.send(0xA1, 2, &read_holding(0, 1));
    settle();
    b.send(0xB1, 2, &read_holding(0, 1));
    settle();
    c.send(0xC1, 2, &read_holding(0, 1));
    assert_eq!(c.recv(), (0xC1, 2, vec![0x83, 0x06]));
    assert_eq!(a.recv(), (0xA1, 2, vec![0x83, 0x0B]));
    assert_eq!(b.recv(), (0xB1, 2, vec![0x83, 0x0B]));
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
