//! `kind = "rk512"` lines whose port goes away and comes back, as
//! `reconnect.rs` does for a Modbus RTU line: socat's pty pair behind symbolic links is the
//! adapter; killing socat pulls it, a new socat on the same links plugs it in again. An active
//! line answers 0AH while down and serves the new partner after; a passive line's memory (the
//! gateway's own) still holds what the partner and a Modbus client wrote before; a
//! `kind = "3964r"` line still shows the partner's latest block. Skips without socat (fails
//! with `CI` set).

use super::harness::{
    launch, read_holding, reopened_once, stop, wait_for_event, write_registers, Client, LinkedPair,
};
use super::rk512::{rk512_on, serve};
use crate::common::{have_socat, si_command, test_dir};
use std::sync::mpsc::Receiver;
use std::time::Duration;

/// The pair's links `NAME-line` (the gateway's end) and `NAME-partner`, in the test directory.
fn links(name: &str) -> (String, String) {
    let dir = test_dir("gateway-rk512-reconnect");
    let link = |end: &str| dir.join(format!("{name}-{end}")).display().to_string();
    (link("line"), link("partner"))
}

/// `si --port PORT 3964r send BYTES…`: the partner sends one block.
fn send_block(port: &str, bytes: &[&str]) {
    let o = si_command()
        .args(["--port", port, "3964r", "send"])
        .args(bytes)
        .output()
        .expect("run si 3964r send");
    assert!(o.status.success(), "{o:?}");
}

/// `si gateway` with one rk512 line `name` on `device`, unit 1, and the extra keys `keys`.
fn gateway(
    name: &str,
    device: &str,
    keys: &str,
) -> (String, Receiver<String>, crate::common::Kill) {
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"{name}\"\nkind = \"rk512\"\n\
         device = \"{device}\"\nunits = \"1\"\n{keys}"
    );
    launch(&toml, device)
}

/// The adapter is pulled (`pair` dropped): line `name` says it is down and answers `probe`
/// with 0AH; it is plugged in again by `replug` (whose result the caller keeps): the line says
/// it is up after one reconnect.
fn replugged<T>(
    pair: LinkedPair,
    c: &mut Client,
    log: &Receiver<String>,
    name: &str,
    probe: &[u8],
    replug: impl FnOnce() -> T,
) -> T {
    drop(pair);
    let down = wait_for_event(log, "line_down", Duration::from_secs(10));
    assert_eq!(down["line"], name, "{down}");
    let unavailable = [probe[0] | 0x80, 0x0A];
    assert_eq!(c.ask(1, probe), unavailable, "gateway path unavailable");
    let again = replug();
    let up = wait_for_event(log, "line_up", Duration::from_secs(40));
    assert_eq!(up["reconnects"], 1, "{up}");
    again
}

#[test]
fn an_active_rk512_line_answers_0ah_while_down_and_serves_the_partner_after() {
    if !have_socat() {
        return;
    }
    let (a, b) = links("active");
    let pair = LinkedPair::start(&a, &b);
    let plc = serve(&b);
    let (addr, log, gateway) = gateway("plc", &a, "");
    let mut c = Client::connect(&addr);
    // FC16 at R 10 → SEND to DB6.DW10; FC03 FETCHes it back.
    assert_eq!(
        c.ask(1, &write_registers(10, &[0x1234])),
        [0x10, 0, 10, 0, 1]
    );
    assert_eq!(c.ask(1, &read_holding(10, 1)), [0x03, 2, 0x12, 0x34]);

    drop(plc);
    // Plugged in again, with a partner whose DB6 is fresh: served again through the new port.
    let _again = replugged(pair, &mut c, &log, "plc", &read_holding(0, 1), || {
        (LinkedPair::start(&a, &b), serve(&b))
    });
    let echo = [0x10, 0, 11, 0, 1];
    c.until(1, &write_registers(11, &[0xBEEF]), |a| a == echo);
    assert_eq!(
        c.ask(1, &read_holding(10, 2)),
        [0x03, 4, 0, 0, 0xBE, 0xEF],
        "the new partner's DB6"
    );
    reopened_once(&stop(&gateway, &log));
}

#[test]
fn a_passive_rk512_lines_memory_survives_the_port_closing() {
    if !have_socat() {
        return;
    }
    let (a, b) = links("passive");
    let pair = LinkedPair::start_ignoreeof(&a, &b);
    let (addr, log, gateway) = gateway("own", &a, "role = \"passive\"\n");
    let mut c = Client::connect(&addr);
    // The partner SENDs DBW0 and DBW2 of DB6; a Modbus client writes DBW4.
    rk512_on(&b, &["send", "--db", "6", "--dw", "0", "1122", "3344"]);
    assert_eq!(
        c.ask(1, &[0x06, 0, 2, 0x55, 0x66]),
        [0x06, 0, 2, 0x55, 0x66]
    );

    let _again = replugged(pair, &mut c, &log, "own", &read_holding(0, 1), || {
        LinkedPair::start_ignoreeof(&a, &b)
    });
    let all = [0x03, 6, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66];
    assert_eq!(
        c.ask(1, &read_holding(0, 3)),
        all,
        "kept across the reopening"
    );
    let fetched = rk512_on(&b, &["fetch", "--db", "6", "--dw", "0", "--count", "3"]);
    assert_eq!(fetched["hex"], "11 22 33 44 55 66", "{fetched}");
    reopened_once(&stop(&gateway, &log));
}

#[test]
fn a_3964r_line_keeps_the_latest_block_across_the_port_closing() {
    if !have_socat() {
        return;
    }
    let (a, b) = links("blocks");
    let pair = LinkedPair::start_ignoreeof(&a, &b);
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"blocks\"\nkind = \"3964r\"\n\
         device = \"{a}\"\nunits = \"1\"\n"
    );
    let (addr, log, gateway) = launch(&toml, &a);
    let mut c = Client::connect(&addr);
    let latest = [0x04, 6, 0, 1, 0, 2, 0x0A, 0x0B];
    send_block(&b, &["0A", "0B"]);
    c.until(1, &[0x04, 0, 0, 0, 3], |r| r == latest);

    // Down as a whole: the latest block is not shown while the line is down.
    let _again = replugged(pair, &mut c, &log, "blocks", &[0x04, 0, 0, 0, 3], || {
        LinkedPair::start_ignoreeof(&a, &b)
    });
    assert_eq!(
        c.ask(1, &[0x04, 0, 0, 0, 3]),
        latest,
        "kept across the reopening"
    );
    send_block(&b, &["0C"]);
    c.until(1, &[0x04, 0, 0, 0, 3], |r| {
        r == [0x04, 6, 0, 2, 0, 1, 0x0C, 0]
    });
    reopened_once(&stop(&gateway, &log));
}
