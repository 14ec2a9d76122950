//! CRC errors a retry cured are counted: a slave on a socat pty pair that corrupts
//! the CRC of its first answer, and of every answer for register 99. Skips without socat
//! (fails with `CI` set).

use super::harness::{launch, read_holding, stop, Mbap};
use crate::common::pty_pair;
use si_modbus::frame::crc16;
use std::io::{Read, Write};

/// Answer FC03 requests for one register on `port` with the register's address as its value;
/// the first answer and those for register 99 with a wrong CRC. Ends when the pty closes.
fn corrupting_slave(port: &str) {
    let mut tty = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(port)
        .expect("open the slave's end");
    std::thread::spawn(move || {
        let mut first = true;
        let mut request = [0u8; 8];
        while tty.read_exact(&mut request).is_ok() {
            let address = u16::from_be_bytes([request[2], request[3]]);
            let mut answer = vec![request[0], 0x03, 2];
            answer.extend(address.to_be_bytes());
            answer.extend(crc16(&answer).to_le_bytes());
            if first || address == 99 {
                answer[6] ^= 0xFF;
            }
            first = false;
            if tty.write_all(&answer).is_err() {
                break;
            }
        }
    });
}

/// The 32-bit counter at `offset` of a block of diagnostic registers (`[fc, bytes, words…]`).
fn counter(pdu: &[u8], offset: usize) -> u32 {
    let word = |i: usize| u32::from(u16::from_be_bytes([pdu[2 + 2 * i], pdu[3 + 2 * i]]));
    word(offset) << 16 | word(offset + 1)
}

#[test]
fn a_corrupt_answer_cured_by_the_retry_is_still_a_crc_error() {
    let Some(pair) = pty_pair() else { return };
    corrupting_slave(&pair.b);
    let toml = format!(
        "listen = \"127.0.0.1:0\"\ndiagnostic_unit = 247\n[[line]]\nname = \"meters\"\n\
         device = \"{}\"\nunits = \"1\"\nbaud = 19200\nparity = \"none\"\nstop_bits = 2\n\
         response_timeout_ms = 300\nretries = 1\npause_ms = 0\n",
        pair.a
    );
    let (addr, log, gateway) = launch(&toml, &pair.a);
    let mut m = Mbap::connect(&addr);

    // The first answer is corrupt, the retry's is good: the client sees only the answer.
    m.send(1, 1, &read_holding(7, 1));
    assert_eq!(m.recv(), (1, 1, vec![0x03, 2, 0, 7]));
    // Every answer corrupt: 04H after the retry, two more CRC errors.
    m.send(2, 1, &read_holding(99, 1));
    assert_eq!(m.recv(), (2, 1, vec![0x83, 0x04]));

    // The asking client's block (0) and the line's (16): CRC errors at offsets 8–9.
    for (tid, start) in [(3u16, 0u16), (4, 16)] {
        let mut pdu = read_holding(start, 16);
        pdu[0] = 0x04;
        m.send(tid, 247, &pdu);
        let (t, _, answer) = m.recv();
        assert_eq!(t, tid);
        assert_eq!(
            counter(&answer, 8),
            3,
            "CRC errors in block {start}: {answer:02X?}"
        );
        assert_eq!(counter(&answer, 2), 1, "one answer in block {start}");
    }

    let status = stop(&gateway, &log);
    let line = &status["lines"][0];
    assert_eq!(line["crc_errors"], 3, "{status}");
    assert_eq!(line["answers"], 1, "{status}");
    assert_eq!(line["other"], 1, "the 04H: {status}");
    assert_eq!(line["reconnects"], 0, "{status}");
    assert_eq!(line["state"], "up", "{status}");
}
