//! `si dp-coord module --protocol ascii` over a Linux pseudo-terminal pair made by socat: the test
//! is the DP master (it writes the host's output windows to the module's stdin and reads the
//! input windows back) and the serial partner (the other end of the pair). A send job puts the
//! frame on the line and ends with 7xH only after that ([ET200S SI 2005] §2.12.1–§2.12.7
//! `[derived]`); a frame from the partner is offered (0001H) and fetched with a receive job (Table
//! 2-24). The 3964(R) module is checked against `si 3964r send|recv` as the partner.
//! Skips with a message when socat is not installed (`apt-get install socat`); with the
//! environment variable `CI` set it fails instead (`common::pty_pair`).

use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Child, ChildStdin, ChildStdout, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::common;

use common::{opened, pty_pair, si_command};

/// The module process, cycled one window at a time.
struct ModuleProcess {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
}

impl ModuleProcess {
    /// One DP cycle: writes the host's output window, returns the module's input window.
    fn cycle(&mut self, output: &str) -> String {
        writeln!(self.stdin, "{output}").expect("module stdin");
        let mut line = String::new();
        self.stdout.read_line(&mut line).expect("module stdout");
        line.trim().to_owned()
    }

    /// Cycles `output` every 10 ms until the input window starts with `prefix`.
    fn cycle_until(&mut self, output: &str, prefix: &str) -> String {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let input = self.cycle(output);
            if input.starts_with(prefix) {
                return input;
            }
            assert!(
                Instant::now() < deadline,
                "no {prefix}… after {output}: {input}"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for ModuleProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The partner's end of the line: the pty to write to, and what arrives on it, read on its own
/// thread.
fn open_partner(path: &str) -> (std::fs::File, mpsc::Receiver<u8>) {
    let partner = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .expect("open partner pty");
    let mut reader = partner.try_clone().expect("clone pty");
    let (tx, rx) = mpsc::channel::<u8>();
    std::thread::spawn(move || {
        let mut buf = [0u8; 64];
        while let Ok(n) = reader.read(&mut buf) {
            if n == 0 || buf[..n].iter().any(|&b| tx.send(b).is_err()) {
                break;
            }
        }
    });
    (partner, rx)
}

fn start_module(args: &[&str]) -> ModuleProcess {
    start_module_logging(args, Stdio::inherit())
}

/// [`start_module`] with its log (stderr) going to `stderr`.
fn start_module_logging(args: &[&str], stderr: Stdio) -> ModuleProcess {
    let mut child = si_command()
        .args(["dp-coord", "module"])
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(stderr)
        .spawn()
        .expect("start si dp-coord module");
    let stdin = child.stdin.take().expect("piped stdin");
    let stdout = BufReader::new(child.stdout.take().expect("piped stdout"));
    ModuleProcess {
        child,
        stdin,
        stdout,
    }
}

/// `si 3964r send` of the block 41 42 10 43 from the partner end `partner`, once the module's
/// port is open (its startup NAK sent): the input window that offers the received block.
fn partner_sends_abc(m: &mut ModuleProcess, partner: &str) -> String {
    assert_eq!(
        m.cycle("00 00 00 00 00 00 00 00"),
        "00 00 00 00 00 00 00 00"
    );
    std::thread::sleep(Duration::from_millis(300));
    let sent = si_command()
        .args(["3964r", "send", "--port", partner, "--priority", "high"])
        .arg("41 42 10 43")
        .output()
        .expect("si 3964r send");
    assert!(sent.status.success(), "{sent:?}");
    m.cycle_until("00 00 00 00 00 00 00 00", "00 00 01")
}

#[test]
fn module_3964r_receives_from_si_3964r_send_and_sends_to_si_3964r_recv() {
    let Some(pair) = pty_pair() else { return };
    let mut m = start_module(&["--window", "8", "--protocol", "3964r", "--port", &pair.a]);
    // The block (with its DLE) is offered and fetched through the window.
    assert_eq!(
        partner_sends_abc(&mut m, &pair.b),
        "00 00 01 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle("20 00 00 00 00 00 00 00"),
        "21 00 04 41 42 10 43 00"
    );
    assert_eq!(
        m.cycle("21 00 00 00 00 00 00 00"),
        "00 00 00 00 00 00 00 00"
    );

    // The other way: si 3964r recv gets what the host sends through the window.
    let recv = si_command()
        .args([
            "3964r",
            "recv",
            "--port",
            &pair.b,
            "--priority",
            "high",
            "--count",
            "1",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("si 3964r recv");
    opened(&recv, &pair.b);
    assert_eq!(
        m.cycle("10 00 00 00 00 00 00 00"),
        "10 00 00 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle("11 00 02 10 03 00 00 00"),
        "11 00 00 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle_until("11 00 02 10 03 00 00 00", "71"),
        "71 00 00 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle("00 00 00 00 00 00 00 00"),
        "00 00 00 00 00 00 00 00"
    );
    let out = recv.wait_with_output().expect("si 3964r recv ends");
    assert!(out.status.success(), "{out:?}");
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "10 03");
}

#[test]
fn module_ascii_sends_through_the_window_and_offers_received_frames() {
    let Some(pair) = pty_pair() else { return };
    let mut m = start_module(&[
        "--window",
        "4",
        "--protocol",
        "ascii",
        "--flow-control",
        "xon-xoff",
        "--port",
        &pair.a,
    ]);
    let (mut partner, rx) = open_partner(&pair.b);

    // Send "abc" (Table 2-23 in small): request, two segments, end of job after the line.
    assert_eq!(m.cycle("00 00 00 00"), "00 00 00 00");
    assert_eq!(m.cycle("10 00 00 00"), "10 00 00 00");
    assert_eq!(m.cycle("11 00 03 61"), "11 00 00 00");
    assert_eq!(m.cycle("12 62 63 00"), "12 00 00 00");
    assert_eq!(m.cycle_until("12 62 63 00", "72"), "72 00 00 00");
    let mut line = Vec::new();
    while line.len() < 3 {
        let b = rx
            .recv_timeout(Duration::from_secs(5))
            .expect("bytes on the line");
        // Under XON/XOFF the driver announces itself with XON (11H) at startup.
        if b != 0x11 {
            line.push(b);
        }
    }
    assert_eq!(line, b"abc");
    assert_eq!(m.cycle("00 00 00 00"), "00 00 00 00");

    // The partner sends "hello"; after the character delay time the module offers it.
    partner.write_all(b"hello").unwrap();
    partner.flush().unwrap();
    assert_eq!(m.cycle_until("00 00 00 00", "00 00 01"), "00 00 01 00");
    assert_eq!(m.cycle("20 00 00 00"), "21 00 05 68");
    assert_eq!(m.cycle("21 00 00 00"), "22 65 6C 6C");
    assert_eq!(m.cycle("22 00 00 00"), "23 6F 00 00");
    assert_eq!(m.cycle("23 00 00 00"), "00 00 00 00");

    // Table 2-28: the XON/XOFF block reaches the ASCII engine; an RTS/CTS block gets 0550H.
    assert_eq!(m.cycle("50 00 00 00"), "50 00 00 00");
    assert_eq!(m.cycle("51 20 00 04"), "51 00 00 00");
    assert_eq!(m.cycle("52 11 13 00"), "52 00 00 00");
    assert_eq!(m.cycle("53 C8 00 00"), "53 00 00 00");
    assert_eq!(m.cycle_until("53 C8 00 00", "7"), "73 00 00 00");
    assert_eq!(m.cycle("00 00 00 00"), "00 00 00 00");
    assert_eq!(m.cycle("50 00 00 00"), "50 00 00 00");
    assert_eq!(m.cycle("51 21 00 02"), "51 00 00 00");
    assert_eq!(m.cycle("52 00 C8 00"), "52 00 00 00");
    assert_eq!(m.cycle_until("52 00 C8 00", "7"), "72 05 50 00");
    assert_eq!(m.cycle("00 00 00 00"), "00 00 00 00");
}

/// The whole chain from the command line: `si dp-coord host … send` as the DP master, the test
/// as the DP exchange (each output window to the module, each input window back to the host),
/// `si dp-coord module --protocol 3964r` on one end of the line and `si 3964r recv` on the other.
#[test]
fn host_and_module_processes_joined_by_the_test_deliver_a_block_to_si_3964r_recv() {
    let Some(pair) = pty_pair() else { return };
    let mut m = start_module(&["--window", "4", "--protocol", "3964r", "--port", &pair.a]);
    let recv = si_command()
        .args([
            "3964r",
            "recv",
            "--port",
            &pair.b,
            "--priority",
            "high",
            "--count",
            "1",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("si 3964r recv");
    opened(&recv, &pair.b);
    let mut host = si_command()
        .args([
            "dp-coord",
            "host",
            "--window",
            "4",
            "send",
            "48 65 6C 6C 6F 10",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("si dp-coord host");
    let mut host_in = host.stdin.take().unwrap();
    // The host's lines, read on their own thread: one window per input window, then the result.
    let host_out = BufReader::new(host.stdout.take().unwrap());
    let (tx, lines) = mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in host_out.lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut input = m.cycle("00 00 00 00");
    let deadline = Instant::now() + Duration::from_secs(20);
    let last = loop {
        writeln!(host_in, "{input}").unwrap();
        let output = lines
            .recv_timeout(Duration::from_secs(5))
            .expect("a window from the host");
        if let Ok(result) = lines.recv_timeout(Duration::from_millis(100)) {
            break result;
        }
        assert!(Instant::now() < deadline, "the job did not end");
        input = m.cycle(&output);
    };
    assert_eq!(last, "done STATUS=0000");
    assert!(host.wait().unwrap().success());
    let out = recv.wait_with_output().expect("si 3964r recv ends");
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        "48 65 6C 6C 6F 10"
    );
}

/// `si dp-coord module --protocol modbus`, the test as the Modbus slave on the other end: the
/// send job's S_SEND source area ([Modbus/USS] §3.4.5–§3.4.16) leaves as an RTU request, the
/// end-of-job acknowledgement comes once the response is in, and the receive job brings the
/// registers ([Modbus/USS] §3.4.5–§3.4.16). A request nobody answers ends with 7xH + 0830H after
/// the response time, and the receive job reports the same (20H + 0830H).
#[test]
fn module_modbus_asks_the_slave_and_offers_the_response() {
    let Some(pair) = pty_pair() else { return };
    let mut m = start_module(&[
        "--window",
        "8",
        "--protocol",
        "modbus",
        "--response-ms",
        "500",
        "--port",
        &pair.a,
    ]);
    let (mut partner, rx) = open_partner(&pair.b);
    let idle = "00 00 00 00 00 00 00 00";
    let take = |n: usize| -> Vec<u8> {
        (0..n)
            .map(|_| {
                rx.recv_timeout(Duration::from_secs(5))
                    .expect("the request on the line")
            })
            .collect()
    };

    // FC03, slave 1, registers 0 and 1: LEN 6, then 5 + 1 bytes in two segments.
    assert_eq!(m.cycle(idle), idle);
    assert_eq!(
        m.cycle("10 00 00 00 00 00 00 00"),
        "10 00 00 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle("11 00 06 01 03 00 00 00"),
        "11 00 00 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle("12 02 00 00 00 00 00 00"),
        "12 00 00 00 00 00 00 00"
    );
    assert_eq!(take(8), [0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B]);
    partner
        .write_all(&[0x01, 0x03, 0x04, 0x12, 0x34, 0x56, 0x78, 0x81, 0x07])
        .unwrap();
    partner.flush().unwrap();
    assert_eq!(
        m.cycle_until("12 02 00 00 00 00 00 00", "72"),
        "72 00 00 00 00 00 00 00"
    );
    assert_eq!(m.cycle(idle), "00 00 01 00 00 00 00 00");
    assert_eq!(
        m.cycle("20 00 00 00 00 00 00 00"),
        "21 00 04 12 34 56 78 00"
    );
    assert_eq!(m.cycle("21 00 00 00 00 00 00 00"), idle);

    // The same job to slave 2, which is not there.
    assert_eq!(m.cycle(idle), idle);
    assert_eq!(
        m.cycle("10 00 00 00 00 00 00 00"),
        "10 00 00 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle("11 00 06 02 03 00 00 00"),
        "11 00 00 00 00 00 00 00"
    );
    assert_eq!(
        m.cycle("12 02 00 00 00 00 00 00"),
        "12 00 00 00 00 00 00 00"
    );
    assert_eq!(take(8)[..2], [0x02, 0x03]);
    assert_eq!(
        m.cycle_until("12 02 00 00 00 00 00 00", "72"),
        "72 08 30 00 00 00 00 00"
    );
    assert_eq!(m.cycle(idle), "00 00 01 00 00 00 00 00");
    assert_eq!(
        m.cycle("20 00 00 00 00 00 00 00"),
        "20 08 30 00 00 00 00 00"
    );
    assert_eq!(m.cycle(idle), idle);
}

#[test]
fn module_v_logs_the_frames_of_its_line_decoded_as_the_procedure() {
    let Some(pair) = pty_pair() else { return };
    let args = [
        "-v",
        "--window",
        "8",
        "--protocol",
        "3964r",
        "--port",
        &pair.a,
    ];
    let mut m = start_module_logging(&args, Stdio::piped());
    partner_sends_abc(&mut m, &pair.b);
    // The block was acknowledged before it was offered: its lines are in the pipe, which
    // stays readable after the module is killed.
    let mut stderr = m.child.stderr.take().expect("piped stderr");
    drop(m);
    let mut log = String::new();
    stderr.read_to_string(&mut log).expect("module log");
    assert!(log.contains("received STX: connection request"), "{log}");
    assert!(log.contains("received block 4 B 41 42 10 43"), "{log}");
    assert!(log.contains("sent DLE: block acknowledged"), "{log}");
    assert!(!log.contains("Received {"), "events stay at DEBUG: {log}");
}
