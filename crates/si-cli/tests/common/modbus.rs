//! The Modbus peers and `si modbus serve` as the interop tests use them (modbus_interop.rs at
//! 19 200 bit/s, modbus_frame_end.rs at 115 200 bit/s): one copy, the line passed in.

use super::{peer, si_command, Kill};
use std::io::{BufRead, BufReader};
use std::process::{Command, Output, Stdio};
use std::sync::mpsc::Receiver;
use std::time::Duration;

/// Run the pymodbus client `script` with its one argument (a port, or the server's address),
/// which must end well and print OK; else fail with what it printed.
pub fn pymodbus_client_ok(script: &str, arg: &str) {
    let out = Command::new("python3")
        .args(["-c", script, arg])
        .output()
        .expect("run python3");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    assert!(
        out.status.success() && text(&out.stdout).contains("OK"),
        "pymodbus client failed:\n{}\n{}",
        text(&out.stdout),
        text(&out.stderr)
    );
}

/// pymodbus and pyserial are importable (else a skip message, or a failure under CI).
pub use si_testkit::peers::have_pymodbus_serial as have_pymodbus;

pub use si_testkit::peers::have_mbpoll;

/// `si --port <port> <line> <args>`, run to its end.
pub fn si_on(port: &str, line: &[&str], args: &[&str]) -> Output {
    si_command()
        .args(["--port", port])
        .args(line)
        .args(args)
        .output()
        .expect("run si")
}

/// `si --port <port> <line> modbus serve --unit 1 <extra>`: the process (killed when dropped),
/// its first line (the banner, checked), and the lines it prints later.
pub fn serve(port: &str, line: &[&str], extra: &[&str]) -> (Kill, String, Receiver<String>) {
    let mut child = si_command()
        .args(["--port", port])
        .args(line)
        .args(["modbus", "serve", "--unit", "1"])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn si modbus serve");
    let stdout = child.stdout.take().expect("stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let first = rx
        .recv_timeout(Duration::from_secs(10))
        .expect("serve starts");
    assert!(first.starts_with("serving as slave 1"), "{first}");
    (Kill(child), first, rx)
}

/// `si modbus serve --unit 1` on one end of a fresh pty pair at 19 200 bit/s 8N1, answering
/// on the other: the pair, the server process, its later lines, and the master's line flags.
/// `None` when socat is missing (a skip, see [`super::pty_pair`]).
pub fn serving_8n1() -> Option<(
    super::PtyPair,
    Kill,
    Receiver<String>,
    &'static [&'static str],
)> {
    const LINE: &[&str] = &["--baud", "19200", "--parity", "none"];
    let pair = super::pty_pair()?;
    let (server, _, log) = serve(&pair.a, LINE, &[]);
    wait_for_echo(&pair.b, LINE, &[]);
    Some((pair, server, log, LINE))
}

/// What `serve` printed so far, one line per served request, after giving it 200 ms to log
/// its last answers.
pub fn served(rx: &Receiver<String>) -> String {
    std::thread::sleep(Duration::from_millis(200));
    rx.try_iter().collect::<Vec<_>>().join("\n")
}

/// A pymodbus serial server running `script` (which prints "ready" once its data is set up)
/// on `port`, killed when dropped.
pub fn pymodbus_server(script: &str, port: &str) -> Kill {
    let (server, ready) = pymodbus_first_line(script, &[port]);
    assert_eq!(ready, "ready");
    server
}

/// `python3 -c script ARGS` (a pymodbus peer): the process, killed when dropped, and the
/// first line it printed, trimmed (its "ready", or the port it listens on).
pub fn pymodbus_first_line(script: &str, args: &[&str]) -> (Kill, String) {
    let mut child = Command::new("python3")
        .args(["-c", script])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn pymodbus peer");
    let mut first = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut first)
        .expect("the pymodbus peer prints a first line");
    (Kill(child), first.trim().to_owned())
}

/// Ask the slave on `port` for an FC08 echo until it answers (a server just started may not
/// have opened its port yet), at most 15 s; `extra` goes after the command (e.g.
/// `--frame-end length`).
pub fn wait_for_echo(port: &str, line: &[&str], extra: &[&str]) {
    let start = std::time::Instant::now();
    loop {
        let args = [
            &[
                "modbus",
                "diag",
                "--unit",
                "1",
                "--response-timeout-ms",
                "500",
            ][..],
            extra,
        ]
        .concat();
        let o = si_on(port, line, &args);
        if o.status.success() {
            let out = String::from_utf8_lossy(&o.stdout);
            assert_eq!(out.trim(), "unit 1 diagnostics echo 0xA537"); // FC08
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(15),
            "the slave never answered"
        );
    }
}

/// `si --port <port> <line> <args>` that must succeed: its stdout trimmed (a failure fails the
/// test, showing the arguments and stderr).
pub fn si_ok(port: &str, line: &[&str], args: &[&str]) -> String {
    let o = si_on(port, line, args);
    assert!(
        o.status.success(),
        "si {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).trim().to_owned()
}

/// A pymodbus RTU server answering unit 1 (and executing broadcasts) at 19 200 bit/s 8N2
/// (pyserial cannot set even parity on a pseudo-terminal), for [`pymodbus_server`]: holding
/// register n holds n, input register n holds 1000 + n, discrete inputs alternate 0 1, 100 of
/// each (pymodbus 3.x data blocks start at 1 for wire address 0).
pub const RTU_SERVER_19200: &str = r#"
import sys, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
dev = ModbusDeviceContext(
    di=ModbusSequentialDataBlock(1, [False, True] * 50),
    co=ModbusSequentialDataBlock(1, [False] * 100),
    hr=ModbusSequentialDataBlock(1, list(range(100))),
    ir=ModbusSequentialDataBlock(1, [1000 + i for i in range(100)]),
)
ctx = ModbusServerContext(devices={1: dev}, single=False)
print("ready", flush=True)
StartSerialServer(context=ctx, port=sys.argv[1], baudrate=19200, parity="N", stopbits=2, bytesize=8, broadcast_enable=True)
"#;
