//! `kind = "rk512"` lines: `si rk512 serve` (DB1–DB16 of 512 bytes) on one end of a socat pty
//! pair, `si gateway` on the other, raw MBAP frames from a std socket; a passive line that
//! `si rk512 send` / `fetch` reach from the other end; and a `kind = "3964r"` line with
//! `si 3964r send` / `recv` at the other end. Skips without socat (fails with `CI`).

use crate::common::{opened, pty_pair, pty_pair_ignoreeof, si_command, Kill, PtyPair};
use crate::harness::{launch, read_holding, stdout_lines, write_registers, Client};
use std::process::Stdio;
use std::sync::mpsc::Receiver;
use std::time::Duration;

impl Client {
    /// Line `line`'s 32-bit counter at `offset` of its block on diagnostic unit 247.
    fn counter(&mut self, line: u16, offset: u16) -> u32 {
        let start = 16 * (1 + line) + offset;
        let a = self.ask(247, &[0x04, (start >> 8) as u8, start as u8, 0, 2]);
        u32::from_be_bytes([a[2], a[3], a[4], a[5]])
    }
}

/// `si --json rk512 serve` on `port` (low priority, DB1–DB16): the process and its lines.
pub fn serve(port: &str) -> (Kill, Receiver<String>) {
    let mut child = si_command()
        .args(["--json", "--port", port, "rk512", "serve"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start si rk512 serve");
    let log = stdout_lines(&mut child);
    // Let it open the port and send its startup NAK before the gateway's station starts.
    std::thread::sleep(Duration::from_millis(300));
    (Kill(child), log)
}

/// The partner's next log line, as JSON (a generous bound).
fn next(log: &Receiver<String>) -> serde_json::Value {
    let line = log
        .recv_timeout(Duration::from_secs(20))
        .expect("a line from si rk512 serve");
    serde_json::from_str(&line).expect(&line)
}

/// `si --json --port PORT rk512 ARGS` (a partner's one job): its JSON line.
pub fn rk512_on(port: &str, args: &[&str]) -> serde_json::Value {
    let o = si_command()
        .args(["--json", "--port", port, "rk512"])
        .args(args)
        .output()
        .expect("run si rk512");
    assert!(o.status.success(), "{o:?}");
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    serde_json::from_str::<serde_json::Value>(out.trim()).expect(&out)
}

fn rk512_line(name: &str, pair: &PtyPair, unit: u8, keys: &str) -> String {
    format!(
        "[[line]]\nname = \"{name}\"\nkind = \"rk512\"\ndevice = \"{}\"\nunits = \"{unit}\"\n{keys}",
        pair.a
    )
}

#[test]
fn a_partner_db_is_written_by_send_and_read_by_fetch() {
    let Some(pair) = pty_pair() else { return };
    let Some(dead) = pty_pair() else { return };
    let Some(imaged) = pty_pair() else { return };
    let (_plc, log) = serve(&pair.b);
    let (_plc2, log2) = serve(&imaged.b);
    let toml = format!(
        "listen = \"127.0.0.1:0\"\ndiagnostic_unit = 247\n{}\n{}\n{}",
        rk512_line("plc", &pair, 1, ""),
        rk512_line(
            "silent",
            &dead,
            2,
            "ack_delay_ms = 50\nresponse_timeout_ms = 200\n"
        ),
        rk512_line(
            "image",
            &imaged,
            3,
            "refresh_ms = 100\nrefresh = [\"DB6:0-9\"]\n"
        ),
    );
    let (addr, _glog, _gateway) = launch(&toml, &pair.a);
    let mut c = Client::connect(&addr);

    // FC16 at R 10 (conversion DB base DB6) → SEND to DB6.DW10, which the partner served.
    assert_eq!(
        c.ask(1, &write_registers(10, &[0x1234, 0x5678])),
        [0x10, 0, 10, 0, 2]
    );
    let served = next(&log);
    assert_eq!(served["served"], "SEND", "{served}");
    assert_eq!(
        (&served["address"], &served["len"]),
        (&"DB6.DW10".into(), &4.into())
    );
    // FC03 is FETCHed from the partner, on demand.
    assert_eq!(
        c.ask(1, &read_holding(9, 3)),
        [0x03, 6, 0, 0, 0x12, 0x34, 0x56, 0x78]
    );
    let served = next(&log);
    assert_eq!(served["served"], "FETCH", "{served}");
    assert_eq!(
        (&served["address"], &served["len"]),
        (&"DB6.DW9".into(), &6.into())
    );

    // DB17 (R 11 × 512) the partner lacks: it refuses the FETCH, 04H as S_MODB answers for a
    // missing DB.
    assert_eq!(c.ask(1, &read_holding(11 * 512, 1)), [0x83, 0x04]);
    assert!(next(&log).get("refused").is_some());
    // DW 300 is beyond RK 512's one header byte, coils beyond what SEND writes: no job.
    assert_eq!(c.ask(1, &read_holding(300, 1)), [0x83, 0x02]);
    assert_eq!(c.ask(1, &[0x05, 0, 0, 0xFF, 0]), [0x85, 0x01]);
    // Past DB_Max (6) of the conversion DB: the write limit's 02H.
    assert_eq!(c.ask(1, &write_registers(512, &[1])), [0x90, 0x02]);
    // Nobody on the line: 0BH once the 3964(R) attempts are spent.
    assert_eq!(c.ask(2, &read_holding(0, 1)), [0x83, 0x0B]);

    // The refresh line: a write is sent at once; reads come from the image, refreshed every
    // 100 ms, so the written words show there once a refresh has run after the SEND.
    assert_eq!(c.ask(3, &write_registers(2, &[0xCAFE])), [0x10, 0, 2, 0, 1]);
    // The image partner's log: refresh FETCHes from before, then the SEND of the write, then
    // (the proof the image was refreshed, not just mirrored from the write) a FETCH of DB6.
    let mut after_send = std::iter::repeat_with(|| next(&log2))
        .skip_while(|l| !(l["served"] == "SEND" && l["address"] == "DB6.DW2"));
    assert_eq!(after_send.next().map(|l| l["len"].clone()), Some(2.into()));
    let refresh = after_send
        .find(|l| l.get("served").is_some())
        .expect("a line after the SEND");
    assert_eq!(refresh["served"], "FETCH", "{refresh}");
    assert!(
        refresh["address"]
            .as_str()
            .is_some_and(|a| a.starts_with("DB6.")),
        "{refresh}"
    );
    c.until(3, &read_holding(2, 1), |a| a == [0x03, 2, 0xCA, 0xFE]);
    assert_eq!(
        c.ask(3, &read_holding(10, 1)),
        [0x83, 0x02],
        "outside the image"
    );

    // The counters: line 0 answered 2 and refused 4 (04, 02, 01, 02); line 1 timed out once.
    assert_eq!(c.counter(0, 2), 2);
    assert_eq!(c.counter(0, 4), 4);
    assert_eq!(c.counter(1, 6), 1);
}

#[test]
fn a_passive_line_serves_the_gateways_own_memory() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n{}",
        rk512_line("own", &pair, 1, "role = \"passive\"\n")
    );
    let (addr, _glog, _gateway) = launch(&toml, &pair.a);
    let mut c = Client::connect(&addr);
    let rk512 = |args: &[&str]| rk512_on(&pair.b, args);
    // A partner SENDs into DB6 (the default memory: DB1–DB6, 1024 bytes): Modbus reads it.
    rk512(&["send", "--db", "6", "--dw", "0", "1122", "3344"]);
    assert_eq!(
        c.ask(1, &read_holding(0, 2)),
        [0x03, 4, 0x11, 0x22, 0x33, 0x44]
    );
    // Modbus writes DBW4: the partner FETCHes it.
    assert_eq!(
        c.ask(1, &[0x06, 0, 2, 0x55, 0x66]),
        [0x06, 0, 2, 0x55, 0x66]
    );
    let fetched = rk512(&["fetch", "--db", "6", "--dw", "1", "--count", "2"]);
    assert_eq!(fetched["hex"], "33 44 55 66", "{fetched}");
    // Flags through the conversion DB: coils 0… are MB500…, which the partner can FETCH too.
    assert_eq!(c.ask(1, &[0x05, 0, 1, 0xFF, 0]), [0x05, 0, 1, 0xFF, 0]);
    let flags = rk512(&["fetch", "--area", "m", "--start", "500", "--count", "1"]);
    assert_eq!(flags["hex"], "02", "{flags}");
}

#[test]
fn a_3964r_partners_blocks_are_registers() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"blocks\"\nkind = \"3964r\"\n\
         device = \"{}\"\nunits = \"4\"\n",
        pair.a
    );
    let (addr, _glog, _gateway) = launch(&toml, &pair.a);
    let mut c = Client::connect(&addr);
    assert_eq!(c.ask(4, &[0x04, 0, 0, 0, 2]), [0x04, 4, 0, 0, 0, 0]);
    // The partner sends a block: count 1, 3 bytes, the data high byte first.
    let o = si_command()
        .args(["--port", &pair.b, "3964r", "send", "01", "02", "03"])
        .output()
        .expect("run si 3964r send");
    assert!(o.status.success(), "{o:?}");
    c.until(4, &[0x04, 0, 0, 0, 4], |a| {
        a == [0x04, 8, 0, 1, 0, 3, 0x01, 0x02, 0x03, 0]
    });
    // A register write sends a block the partner receives.
    let mut recv = si_command()
        .args(["--json", "--port", &pair.b, "3964r", "recv", "--count", "1"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start si 3964r recv");
    let log = stdout_lines(&mut recv);
    let _recv = Kill(recv);
    opened(&_recv.0, &pair.b);
    assert_eq!(
        c.ask(4, &write_registers(0, &[3, 0x4142, 0x4300])),
        [0x10, 0, 0, 0, 3]
    );
    let got = next(&log);
    assert_eq!(
        (&got["hex"], &got["len"]),
        (&"41 42 43".into(), &3.into()),
        "{got}"
    );
}
