//! A gateway in front of a pymodbus RTU server on a pty pair, and raw Modbus TCP frames.

use crate::common::modbus::{have_pymodbus, pymodbus_server, RTU_SERVER_19200};
use crate::common::{have_socat, pty_pair, si_command, test_dir, Kill, PtyPair};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::Stdio;
use std::sync::mpsc::{self, Receiver};
use std::time::Duration;

/// A running gateway with its RTU slave; everything is killed when dropped.
pub struct Rig {
    /// The gateway's TCP address.
    pub addr: String,
    /// The gateway's stdout lines after the first.
    pub log: Receiver<String>,
    gateway: Kill,
    _slave: Kill,
    _pairs: (PtyPair, PtyPair),
}

impl Rig {
    /// `si gateway --config` with two lines: `meters` (unit 1, the pymodbus slave) and
    /// `silent` (unit 2, a pseudo-terminal nobody answers on), both with the TOML keys
    /// `line_keys`, and the top-level keys `top_keys`; listening on a free loopback port.
    /// `None` when a peer is missing (skip).
    pub fn start(top_keys: &str, line_keys: &str) -> Option<Rig> {
        if !(have_socat() && have_pymodbus()) {
            return None;
        }
        let pair = pty_pair()?;
        let dead = pty_pair()?;
        let slave = pymodbus_server(RTU_SERVER_19200, &pair.b);
        let line = "baud = 19200\nparity = \"none\"\nstop_bits = 2\n";
        let toml = format!(
            "listen = \"127.0.0.1:0\"\n{top_keys}\n\
             [[line]]\nname = \"meters\"\ndevice = \"{}\"\nunits = \"1\"\n{line}{line_keys}\n\
             [[line]]\nname = \"silent\"\ndevice = \"{}\"\nunits = \"2\"\n{line}{line_keys}\n",
            pair.a, dead.a
        );
        let (addr, log, gateway) = launch(&toml, &pair.a);
        Some(Rig {
            addr,
            log,
            gateway,
            _slave: slave,
            _pairs: (pair, dead),
        })
    }

    /// Stop the gateway with SIGINT (as Ctrl-C) and return its last status line.
    pub fn stop(self) -> serde_json::Value {
        stop(&self.gateway, &self.log)
    }
}

/// Stop `rig`'s gateway with `signal` (`-INT`, `-TERM`) and return its last status line.
pub fn stop_with(rig: &Rig, signal: &str) -> serde_json::Value {
    signalled(&rig.gateway, &rig.log, signal)
}

/// Stop `gateway` with SIGINT (as Ctrl-C) and return the last status line of its `log`.
pub fn stop(gateway: &Kill, log: &Receiver<String>) -> serde_json::Value {
    signalled(gateway, log, "-INT")
}

/// Send `signal` to `gateway` and return the last status line of its `log`.
fn signalled(gateway: &Kill, log: &Receiver<String>, signal: &str) -> serde_json::Value {
    let pid = gateway.0.id().to_string();
    let ok = std::process::Command::new("kill")
        .args([signal, &pid])
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "kill {signal} {pid}");
    let mut last = None;
    while let Ok(line) = log.recv_timeout(Duration::from_secs(10)) {
        last = Some(line);
    }
    let last = last.expect("a status line at exit");
    serde_json::from_str(&last).expect(&last)
}

/// A last status line showing line 0 up again after one reconnect, with the 0AH it answered
/// while down counted.
pub fn reopened_once(status: &serde_json::Value) {
    let line = &status["lines"][0];
    assert_eq!(line["state"], "up", "{status}");
    assert_eq!(line["reconnects"], 1, "{status}");
    assert!(
        line["other"].as_u64() >= Some(1),
        "the 0AH is counted: {status}"
    );
}

/// The next JSON line of `log` whose `event` is `event`, waiting at most `bound` (a bound
/// only, not a timing claim); other lines are passed over.
pub fn wait_for_event(log: &Receiver<String>, event: &str, bound: Duration) -> serde_json::Value {
    let until = std::time::Instant::now() + bound;
    loop {
        let left = until.saturating_duration_since(std::time::Instant::now());
        let line = log
            .recv_timeout(left)
            .unwrap_or_else(|_| panic!("no {event} event within {bound:?}"));
        let v: serde_json::Value = serde_json::from_str(&line).expect(&line);
        if v["event"] == event {
            return v;
        }
    }
}

/// A socat pseudo-terminal pair reached through the symbolic links `a` and `b`, which a new
/// pair can take over after this one is gone (a device node that comes back under its name);
/// socat is killed when dropped, closing both ends.
pub struct LinkedPair {
    _socat: Kill,
}

impl LinkedPair {
    /// Start the pair once both links point to it (a bound of 10 s).
    pub fn start(a: &str, b: &str) -> LinkedPair {
        Self::with(a, b, "")
    }

    /// Like [`start`](Self::start), with `ignoreeof`: a process that opens its end and closes
    /// it again (`si rk512 send`) does not end the pair; killing socat still does.
    pub fn start_ignoreeof(a: &str, b: &str) -> LinkedPair {
        Self::with(a, b, ",ignoreeof")
    }

    fn with(a: &str, b: &str, options: &str) -> LinkedPair {
        for link in [a, b] {
            let _ = std::fs::remove_file(link);
        }
        let end = |link: &str| format!("pty,raw,echo=0{options},link={link}");
        let socat = std::process::Command::new("socat")
            .args([end(a), end(b)])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn socat");
        let pair = LinkedPair {
            _socat: Kill(socat),
        };
        let start = std::time::Instant::now();
        while !(std::path::Path::new(a).exists() && std::path::Path::new(b).exists()) {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "socat made no {a}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        pair
    }
}

/// `si --json gateway --config` with the configuration `toml` (written to a file named after
/// `tag`, e.g. the pty it uses): the address it listens on, its stdout lines after the first,
/// and the process (killed when dropped).
pub fn launch(toml: &str, tag: &str) -> (String, Receiver<String>, Kill) {
    let (addr, log, gateway, _) = launch_with(si_command(), toml, tag);
    (addr, log, gateway)
}

/// [`launch`] with `command` as the `si` to run (e.g. `sh -c '…; exec "$0" "$@"' si`, to start
/// it under other limits), also returning its whole "listening" event.
pub fn launch_with(
    mut command: std::process::Command,
    toml: &str,
    tag: &str,
) -> (String, Receiver<String>, Kill, serde_json::Value) {
    let path = test_dir("gateway").join(format!("{}.toml", tag.replace('/', "_")));
    std::fs::write(&path, toml).expect("write the config");
    let mut child = command
        .args(["--json", "gateway", "--config"])
        .arg(&path)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn si gateway");
    let log = stdout_lines(&mut child);
    let gateway = Kill(child);
    // A line that starts down (`allow_down_at_start`) may say so before this.
    let v = wait_for_event(&log, "listening", Duration::from_secs(20));
    let addr = v["addr"].as_str().expect("addr").to_owned();
    (addr, log, gateway, v)
}

/// The child's stdout lines, read by a thread as they come.
pub fn stdout_lines(child: &mut std::process::Child) -> Receiver<String> {
    let (tx, log) = mpsc::channel();
    let stdout = child.stdout.take().expect("stdout");
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    log
}

/// A connection sending raw MBAP frames.
pub struct Mbap(pub TcpStream);

impl Mbap {
    /// Connect, with a generous read timeout as a bound only.
    pub fn connect(addr: &str) -> Mbap {
        let s = TcpStream::connect(addr).expect("connect to the gateway");
        s.set_read_timeout(Some(Duration::from_secs(15))).unwrap();
        Mbap(s)
    }

    /// Send `unit | pdu` with transaction id `tid`.
    pub fn send(&mut self, tid: u16, unit: u8, pdu: &[u8]) {
        self.0.write_all(&frame(tid, unit, pdu)).expect("send");
    }

    /// The next answer: (transaction id, unit, PDU).
    pub fn recv(&mut self) -> (u16, u8, Vec<u8>) {
        let mut head = [0u8; 7];
        self.0.read_exact(&mut head).expect("answer header");
        let len = u16::from_be_bytes([head[4], head[5]]) as usize;
        let mut pdu = vec![0u8; len - 1];
        self.0.read_exact(&mut pdu).expect("answer PDU");
        (u16::from_be_bytes([head[0], head[1]]), head[6], pdu)
    }
}

/// An MBAP frame.
pub fn frame(tid: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let mut f = Vec::with_capacity(7 + pdu.len());
    f.extend_from_slice(&tid.to_be_bytes());
    f.extend_from_slice(&[0, 0]);
    f.extend_from_slice(&(pdu.len() as u16 + 1).to_be_bytes());
    f.push(unit);
    f.extend_from_slice(pdu);
    f
}

/// FC03 for `count` registers from `addr`.
pub fn read_holding(addr: u16, count: u16) -> Vec<u8> {
    let [a, b] = addr.to_be_bytes();
    let [c, d] = count.to_be_bytes();
    vec![0x03, a, b, c, d]
}

/// FC16 of `values` from `addr`.
pub fn write_registers(addr: u16, values: &[u16]) -> Vec<u8> {
    let mut pdu = vec![0x10];
    pdu.extend(addr.to_be_bytes());
    pdu.extend((values.len() as u16).to_be_bytes());
    pdu.push(2 * values.len() as u8);
    pdu.extend(values.iter().flat_map(|v| v.to_be_bytes()));
    pdu
}

/// A raw MBAP connection that numbers its requests and checks each answer's transaction id
/// and unit.
pub struct Client {
    /// The connection.
    pub mbap: Mbap,
    /// The last transaction id used.
    pub tid: u16,
}

impl Client {
    /// Connect to the gateway at `addr`.
    pub fn connect(addr: &str) -> Client {
        Client {
            mbap: Mbap::connect(addr),
            tid: 0,
        }
    }

    /// Send `pdu` to `unit` and return the answer's PDU.
    pub fn ask(&mut self, unit: u8, pdu: &[u8]) -> Vec<u8> {
        self.tid += 1;
        self.mbap.send(self.tid, unit, pdu);
        let (tid, u, answer) = self.mbap.recv();
        assert_eq!((tid, u), (self.tid, unit));
        answer
    }

    /// Ask until `done` holds for the answer; a generous bound, not a timing claim.
    pub fn until(&mut self, unit: u8, pdu: &[u8], done: impl Fn(&[u8]) -> bool) -> Vec<u8> {
        let start = std::time::Instant::now();
        loop {
            let answer = self.ask(unit, pdu);
            if done(&answer) {
                return answer;
            }
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "still {answer:02X?} for {pdu:02X?}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}
