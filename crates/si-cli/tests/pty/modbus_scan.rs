//! `si modbus scan` on a pty: a Modbus slave that answers only at its own baud rate is found
//! at its unit and that rate among four line settings, and nothing else is reported; the scan
//! ends within the time it announced before it started.
//!
//! The slave is a small Python peer, not pymodbus: pymodbus 3.16's serial server answers every
//! unit address (exception 04 for the ones it does not serve, even with
//! `ignore_missing_devices`: its datastore raises a plain error there, not the missing-device
//! one that option silences), so "nothing else" could not hold. The peer reads the line settings si set on the pty (termios calls on a pty master act
//! on its slave) and stays silent at any other baud rate, as a real device would hear only
//! garbage. Parity cannot be told apart on a pty (the kernel clears PARENB on pseudo-terminals),
//! so the four settings differ in their baud rate.

use crate::common;

use common::{si_command, stdout, text, Kill};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

const SLAVE: &str = r#"
import os, pty, sys, termios, select, tty, fcntl, struct, time
UNIT = int(sys.argv[1]); BAUD = int(sys.argv[2])
TCGETS2 = 0x802C542A  # struct termios2 (44 bytes): the speed in bit/s, as serial libraries set it
master, slave = pty.openpty()
tty.setraw(slave)
print(os.ttyname(slave), flush=True)
def crc(b):
    c = 0xFFFF
    for x in b:
        c ^= x
        for _ in range(8):
            c = (c >> 1) ^ 0xA001 if c & 1 else c >> 1
    return bytes([c & 0xFF, c >> 8])
buf = b""
while True:
    r, _, _ = select.select([master], [], [], 0.05)
    if not r:
        buf = b""  # silence: a frame ends
        continue
    try:
        buf += os.read(master, 256)
    except OSError:  # si closed the pty between two line settings
        buf = b""
        time.sleep(0.01)
        continue
    # Termios calls on a pty master act on the slave: the settings si set.
    raw = fcntl.ioctl(master, TCGETS2, bytes(44))
    speed = struct.unpack_from("I", raw, 40)[0]
    if speed != BAUD:
        buf = b""  # wrong settings: garbage to this station, no answer
        continue
    if len(buf) >= 8 and buf[0] == UNIT and buf[1] == 3 and crc(buf[:6]) == buf[6:8]:
        body = bytes([UNIT, 3, 2, 0x12, 0x34])
        os.write(master, body + crc(body))
        buf = b""
"#;

/// The Python slave for `unit` at `baud`: the process (killed when dropped) and its pty.
fn slave(unit: u8, baud: u32) -> (Kill, String) {
    let mut child = Command::new("python3")
        .args(["-c", SLAVE, &unit.to_string(), &baud.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn python3");
    let mut path = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut path)
        .expect("the slave prints its pty");
    (Kill(child), path.trim().to_owned())
}

#[test]
fn a_scan_finds_the_one_unit_at_its_baud_rate_within_the_announced_time() {
    let (_slave, port) = slave(7, 19200);
    let started = std::time::Instant::now();
    let o = si_command()
        .args([
            "--json", "--port", &port, "modbus", "scan", "--units", "1-9",
        ])
        .args(["--bauds", "4800,9600,19200,38400", "--parities", "none"])
        .args(["--response-timeout-ms", "100"])
        .output()
        .expect("run si");
    let took = started.elapsed();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let lines: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    let bound_ms = lines[0]["bound_ms"].as_u64().expect("the announced bound");
    assert_eq!(lines[0]["units"], 9, "{t}");
    let found: Vec<_> = lines[1..]
        .iter()
        .map(|l| {
            (
                l["unit"].clone(),
                l["settings"].clone(),
                l["answered"].clone(),
            )
        })
        .collect();
    assert_eq!(
        found,
        vec![(7.into(), "19200 8N1".into(), true.into())],
        "{t}"
    );
    assert!(
        took.as_millis() as u64 <= bound_ms,
        "took {took:?}, announced {bound_ms} ms"
    );
}

/// Ctrl-C (SIGINT) during a scan that would take minutes: it ends at once, exit 130, with
/// the unit found so far printed.
#[test]
fn ctrl_c_stops_the_scan_at_once_with_what_was_found() {
    let (_slave, port) = slave(1, 9600);
    let mut scan = si_command()
        .args(["--port", &port, "--baud", "9600", "modbus", "scan"])
        .args(["--units", "1-247", "--parities", "none"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run si");
    let mut lines = BufReader::new(scan.stdout.take().expect("stdout")).lines();
    let announced = lines.next().expect("the bound").expect("a line");
    assert!(announced.contains("at most"), "{announced}");
    let found = lines.next().expect("unit 1").expect("a line");
    assert!(found.starts_with("unit 1 "), "{found}");
    // Unit 2 is silent: the scan now waits its 2 s response time.
    let sent = Command::new("kill")
        .args(["-INT", &scan.id().to_string()])
        .status()
        .expect("run kill");
    assert!(sent.success());
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = scan.try_wait().expect("wait") {
            break status;
        }
        assert!(
            start.elapsed() < std::time::Duration::from_secs(1),
            "the scan did not stop at once"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    assert_eq!(status.code(), Some(130));
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(
        rest.iter()
            .any(|l| l.contains("1 unit(s) answered (interrupted)")),
        "{rest:?}"
    );
}
