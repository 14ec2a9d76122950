//! A bounded soak: 32 clients at once, mixing valid requests, requests to a unit
//! that never answers, malformed and oversize MBAP headers, and disconnects in the middle of a
//! request, against a queue small enough to overflow. Every answer a client gets is for its
//! own request (its transaction id, and the register it asked for), and the gateway serves a
//! fresh client afterwards with nothing left queued.

use super::harness::{frame, read_holding, Mbap, Rig};

/// Clients at once: mbusd's default connection limit, and the gateway's.
const CLIENTS: u16 = 32;
/// Steps per client.
const STEPS: u16 = 12;

/// One client's run; returns how many of its valid requests got the slave's data (each answer
/// is checked against its request; a 06H for a full queue is allowed, and not counted).
fn client(addr: &str, index: u16) -> u32 {
    let mut m = Mbap::connect(addr);
    let mut answered = 0;
    for step in 0..STEPS {
        let tid = index << 8 | step;
        // Holding register n holds n on the slave: the value names the request.
        let register = (index * 3 + step) % 90;
        match (index + step) % 6 {
            // A header the server cannot frame (protocol id 1), or one announcing 300 bytes:
            // the gateway closes that connection; the client connects again.
            0 | 1 => {
                let mut bad = frame(tid, 1, &read_holding(register, 1));
                if step % 2 == 0 {
                    bad[2..4].copy_from_slice(&[0, 1]);
                } else {
                    bad[4..6].copy_from_slice(&300u16.to_be_bytes());
                }
                std::io::Write::write_all(&mut m.0, &bad).ok();
                let mut rest = Vec::new();
                let closed = std::io::Read::read_to_end(&mut m.0, &mut rest);
                assert!(
                    closed.is_ok() && rest.is_empty(),
                    "closed without an answer"
                );
                m = Mbap::connect(addr);
            }
            // A request, then gone before the answer.
            2 => {
                m.send(tid, 1, &read_holding(register, 1));
                m = Mbap::connect(addr);
            }
            // The unit that never answers: 0BH, or 06H when its line's queue is full.
            3 => {
                m.send(tid, 2, &read_holding(register, 1));
                let (t, unit, pdu) = m.recv();
                assert_eq!((t, unit), (tid, 2));
                assert!(pdu == [0x83, 0x0B] || pdu == [0x83, 0x06], "{pdu:02X?}");
            }
            _ => {
                m.send(tid, 1, &read_holding(register, 1));
                let (t, unit, pdu) = m.recv();
                assert_eq!((t, unit), (tid, 1), "client {index} got another's answer");
                if pdu != [0x83, 0x06] {
                    let [hi, lo] = register.to_be_bytes();
                    assert_eq!(pdu, [0x03, 2, hi, lo], "client {index} step {step}");
                    answered += 1;
                }
            }
        }
    }
    answered
}

#[test]
fn thirty_two_clients_with_bad_input_never_get_anothers_answer() {
    let keys = "response_timeout_ms = 100\nretries = 0\npause_ms = 0\nqueue = 8";
    // Room for the connections clients left in the middle of a request: each holds its slot
    // until its answer is ready (the limit itself is si-modbus's server's, tested there).
    let Some(rig) = Rig::start("max_connections = 256", keys) else {
        return;
    };
    let threads: Vec<_> = (0..CLIENTS)
        .map(|i| {
            let addr = rig.addr.clone();
            std::thread::spawn(move || client(&addr, i))
        })
        .collect();
    let answered: u32 = threads
        .into_iter()
        .map(|t| t.join().expect("a client saw a wrong answer"))
        .sum();
    // 128 of the 384 steps are valid requests to unit 1; about 55 get data here, the rest a
    // full queue's 06H. One for every other client (16) is a floor a loaded machine clears,
    // and it fails if the slave's data stopped coming through at all.
    assert!(answered >= u32::from(CLIENTS) / 2, "{answered} answers");
    let mut m = Mbap::connect(&rig.addr);
    m.send(0xFFFF, 1, &read_holding(7, 1));
    assert_eq!(m.recv(), (0xFFFF, 1, vec![0x03, 2, 0, 7]));
    drop(m);
    let status = rig.stop();
    for line in status["lines"].as_array().expect("lines") {
        assert_eq!(line["queue_depth"], 0, "{status}");
    }
    // Both kinds of answer happened: the slave's data and the silent unit's 0BH.
    // The line counted every answer a client checked (and those of the clients gone before
    // theirs came, and the fresh client's).
    assert!(
        status["lines"][0]["answers"].as_u64() > Some(u64::from(answered)),
        "{answered}: {status}"
    );
    assert!(
        status["lines"][1]["timeouts"].as_u64() > Some(0),
        "{status}"
    );
}
