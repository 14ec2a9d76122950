//! The faults a hostile-input probe found, each fixed: a gateway whose stdout closes keeps
//! serving, SIGTERM ends it with the final counters as SIGINT does, and quantities outside the
//! Modbus application protocol's ranges are answered 03H without reaching the line.

use super::harness::{launch, read_holding, stop_with, Client, Rig};
use crate::common::fifo::mkfifo;
use crate::common::modbus::{have_pymodbus, pymodbus_server, RTU_SERVER_19200};
use crate::common::{have_socat, pty_pair, si_command, test_dir, Kill};
use std::io::{BufRead, BufReader, Read};
use std::process::Stdio;
use std::sync::mpsc;
use std::time::Duration;

#[test]
fn sigterm_ends_the_gateway_with_its_final_counters() {
    let Some(rig) = Rig::start("", "response_timeout_ms = 100\nretries = 0\npause_ms = 0") else {
        return;
    };
    let mut c = Client::connect(&rig.addr);
    assert_eq!(c.ask(1, &read_holding(3, 1)), [0x03, 2, 0, 3]);
    let status = stop_with(&rig, "-TERM");
    assert_eq!(status["lines"][0]["answers"], 1, "{status}");
}

#[test]
fn a_closed_stdout_leaves_the_gateway_serving() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let pair = pty_pair().unwrap();
    let _slave = pymodbus_server(RTU_SERVER_19200, &pair.b);
    let dir = test_dir("gateway-stdout");
    let toml = dir.join("gw.toml");
    std::fs::write(
        &toml,
        format!(
            "listen = \"127.0.0.1:0\"\n[[line]]\ndevice = \"{}\"\nunits = \"1\"\nbaud = 19200\n\
             parity = \"none\"\nstop_bits = 2\nresponse_timeout_ms = 300\npause_ms = 0\n",
            pair.a
        ),
    )
    .unwrap();
    let fifo = dir.join("out");
    mkfifo(&fifo);
    // The reader takes the first line (the listening address) and goes away.
    let (tx, first) = mpsc::channel();
    let path = fifo.clone();
    let reader = std::thread::spawn(move || {
        let f = std::fs::File::open(&path).expect("open the FIFO");
        let mut line = String::new();
        BufReader::new(f).read_line(&mut line).expect("read");
        tx.send(line).unwrap();
    });
    let gateway = si_command()
        .args(["--json", "gateway", "--status-every", "1", "--config"])
        .arg(&toml)
        // Opening the FIFO's write end waits for the reader above.
        .stdout(std::fs::OpenOptions::new().write(true).open(&fifo).unwrap())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn si gateway");
    let mut gateway = Kill(gateway);
    let line = first
        .recv_timeout(Duration::from_secs(20))
        .expect("listening");
    reader.join().unwrap();
    let v: serde_json::Value = serde_json::from_str(&line).expect(&line);
    let addr = v["addr"].as_str().expect("addr").to_owned();
    // Two status ticks with nobody reading: the first write fails.
    std::thread::sleep(Duration::from_millis(2500));
    assert!(
        gateway.0.try_wait().unwrap().is_none(),
        "the gateway stopped when its stdout closed"
    );
    let mut c = Client::connect(&addr);
    assert_eq!(c.ask(1, &read_holding(3, 1)), [0x03, 2, 0, 3]);
    let _ = gateway.0.kill();
    let mut err = String::new();
    gateway
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert_eq!(err.matches("cannot write to stdout").count(), 1, "{err}");
}

#[test]
fn quantities_over_the_limit_are_answered_03h_and_never_reach_the_line() {
    if !have_socat() {
        return;
    }
    let pair = pty_pair().unwrap();
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\ndevice = \"{}\"\nunits = \"1\"\nbaud = 19200\n\
         response_timeout_ms = 50\nretries = 0\npause_ms = 0\n",
        pair.a
    );
    // The slave's end: everything the line carries, as it comes.
    let mut slave = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&pair.b)
        .expect("open the slave's end");
    let (tx, heard) = mpsc::channel();
    std::thread::spawn(move || {
        let mut buf = [0u8; 512];
        while let Ok(n) = slave.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                break;
            }
        }
    });
    let (addr, log, gateway) = launch(&toml, &pair.a);
    let mut c = Client::connect(&addr);
    let quantity = |fc: u8, q: u16| {
        let [hi, lo] = q.to_be_bytes();
        vec![fc, 0, 0, hi, lo]
    };
    for (fc, q) in [(3, 126), (4, 126), (1, 2001), (2, 2001), (3, 0)] {
        assert_eq!(
            c.ask(1, &quantity(fc, q)),
            [fc | 0x80, 0x03],
            "FC{fc:02X} of {q}"
        );
    }
    // FC15 of 1969 coils fits a PDU (247 data bytes); FC16 of 124 registers would not, so its
    // byte count stays short (the quantity is checked first).
    let mut fc15 = vec![0x0F, 0, 0, 0x07, 0xB1, 247];
    fc15.extend(std::iter::repeat_n(0, 247));
    assert_eq!(c.ask(1, &fc15), [0x8F, 0x03], "FC15 of 1969");
    assert_eq!(
        c.ask(1, &[0x10, 0, 0, 0, 124, 2, 0, 0]),
        [0x90, 0x03],
        "FC16 of 124"
    );
    // A request in range does go out (nobody answers: 0BH); it is the first thing on the line.
    assert_eq!(c.ask(1, &quantity(3, 125)), [0x83, 0x0B]);
    let mut on_line = Vec::new();
    while on_line.len() < 8 {
        on_line.extend(
            heard
                .recv_timeout(Duration::from_secs(10))
                .expect("bytes on the line"),
        );
    }
    assert_eq!(on_line[..6], [1, 3, 0, 0, 0, 125], "{on_line:02X?}");
    drop((log, gateway));
}

/// Unit 1's answer to a one-register FC03 read: the register's own address as its value.
fn own_address_answer(request: &[u8]) -> Vec<u8> {
    let mut v = vec![1, 3, 2, request[2], request[3]];
    let crc = si_modbus::frame::crc16(&v).to_le_bytes();
    v.extend_from_slice(&crc);
    v
}

#[test]
fn a_late_answer_never_reaches_another_clients_request() {
    if !have_socat() {
        return;
    }
    let pair = pty_pair().unwrap();
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\ndevice = \"{}\"\nunits = \"1\"\nbaud = 19200\n\
         response_timeout_ms = 500\nretries = 0\npause_ms = 0\n",
        pair.a
    );
    // A slave whose register N holds N, answering HR 10 only after 0.7 s, one request at a
    // time as a real slave does.
    let slave = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&pair.b)
        .expect("open the slave's end");
    std::thread::spawn(move || {
        use std::io::Write;
        let (mut rx, mut tx) = (slave.try_clone().unwrap(), slave);
        let mut pending = Vec::new();
        let mut buf = [0u8; 256];
        while let Ok(n) = rx.read(&mut buf) {
            if n == 0 {
                break;
            }
            pending.extend_from_slice(&buf[..n]);
            while pending.len() >= 8 {
                let request: Vec<u8> = pending.drain(..8).collect();
                if request[3] == 10 {
                    std::thread::sleep(Duration::from_millis(700));
                }
                if tx.write_all(&own_address_answer(&request)).is_err() {
                    return;
                }
            }
        }
    });
    let (addr, _log, _gateway) = launch(&toml, &pair.a);
    let clients: Vec<_> = [(10u16, 0u64), (20, 50), (30, 100)]
        .into_iter()
        .map(|(register, delay)| {
            let addr = addr.clone();
            std::thread::spawn(move || {
                let mut c = Client::connect(&addr);
                std::thread::sleep(Duration::from_millis(delay));
                (register, c.ask(1, &read_holding(register, 1)))
            })
        })
        .collect();
    for client in clients {
        let (register, answer) = client.join().unwrap();
        let [hi, lo] = register.to_be_bytes();
        assert!(
            answer == [0x03, 2, hi, lo] || answer[0] == 0x83,
            "HR {register}: its own value or an exception, got {answer:02X?}"
        );
    }
}
