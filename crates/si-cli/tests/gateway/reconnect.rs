//! A line whose port goes away and comes back: socat's pty pair behind symbolic
//! links stands for a USB adapter's device node; killing socat closes both ends, as pulling
//! the adapter does, and a new socat on the same links is the adapter plugged in again.
//! Skips without socat or pymodbus (fails with `CI` set).

use super::harness::{launch, read_holding, reopened_once, stop, wait_for_event, LinkedPair, Mbap};
use crate::common::modbus::{have_pymodbus, pymodbus_server, RTU_SERVER_19200};
use crate::common::{have_socat, test_dir};
use std::time::{Duration, Instant};

/// Ask unit 1 for holding register 7 until the answer is not `[0x83, 0x0A]` (the line still
/// down) or `[0x83, 0x0B]` (the new slave not yet listening); a bound of 20 s, no timing claim.
fn read_until_answered(m: &mut Mbap, tid: &mut u16) -> Vec<u8> {
    let start = Instant::now();
    loop {
        *tid += 1;
        m.send(*tid, 1, &read_holding(7, 1));
        let (t, _, pdu) = m.recv();
        assert_eq!(t, *tid);
        if pdu != [0x83, 0x0A] && pdu != [0x83, 0x0B] {
            return pdu;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "still {pdu:02X?}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn a_line_whose_port_closes_answers_0ah_and_is_reopened() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let dir = test_dir("gateway-reconnect");
    let (a, b) = (dir.join("line"), dir.join("slave"));
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let pair = LinkedPair::start(a, b);
    let slave = pymodbus_server(RTU_SERVER_19200, b);
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"meters\"\ndevice = \"{a}\"\nunits = \"1\"\n\
         baud = 19200\nparity = \"none\"\nstop_bits = 2\nresponse_timeout_ms = 300\n\
         retries = 1\npause_ms = 0\n"
    );
    let (addr, log, gateway) = launch(&toml, a);
    let mut m = Mbap::connect(&addr);
    let mut tid = 0;
    assert_eq!(read_until_answered(&mut m, &mut tid), [0x03, 2, 0, 7]);

    // The adapter is pulled: both ends close, the line goes down and says why.
    drop(slave);
    drop(pair);
    let down = wait_for_event(&log, "line_down", Duration::from_secs(10));
    assert_eq!(down["line"], "meters", "{down}");
    assert!(
        down["reason"].as_str().is_some_and(|r| !r.is_empty()),
        "{down}"
    );
    tid += 1;
    m.send(tid, 1, &read_holding(7, 1));
    assert_eq!(
        m.recv(),
        (tid, 1, vec![0x83, 0x0A]),
        "gateway path unavailable"
    );

    // Plugged in again under the same name: reopened, and served again.
    let _pair = LinkedPair::start(a, b);
    let _slave = pymodbus_server(RTU_SERVER_19200, b);
    let up = wait_for_event(&log, "line_up", Duration::from_secs(40));
    assert_eq!(up["reconnects"], 1, "{up}");
    assert_eq!(read_until_answered(&mut m, &mut tid), [0x03, 2, 0, 7]);

    reopened_once(&stop(&gateway, &log));
}

/// With `allow_down_at_start` a line whose adapter is not plugged in yet does not stop the
/// gateway: it starts down (0AH), and is served once its device appears.
#[test]
fn a_line_missing_at_start_may_start_down_and_is_opened_when_it_appears() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let dir = test_dir("gateway-start-down");
    let (a, b) = (dir.join("line"), dir.join("slave"));
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let toml = format!(
        "listen = \"127.0.0.1:0\"\nallow_down_at_start = true\n[[line]]\nname = \"meters\"\n\
         device = \"{a}\"\nunits = \"1\"\nbaud = 19200\nparity = \"none\"\nstop_bits = 2\n\
         response_timeout_ms = 300\nretries = 1\npause_ms = 0\n"
    );
    let (addr, log, gateway) = launch(&toml, a);
    let mut m = Mbap::connect(&addr);
    m.send(1, 1, &read_holding(7, 1));
    assert_eq!(m.recv(), (1, 1, vec![0x83, 0x0A]), "down: path unavailable");

    let _pair = LinkedPair::start(a, b);
    let _slave = pymodbus_server(RTU_SERVER_19200, b);
    let up = wait_for_event(&log, "line_up", Duration::from_secs(40));
    assert_eq!(up["reconnects"], 0, "a first opening is no reconnect: {up}");
    let mut tid = 1;
    assert_eq!(read_until_answered(&mut m, &mut tid), [0x03, 2, 0, 7]);
    let status = stop(&gateway, &log);
    assert_eq!(status["lines"][0]["state"], "up", "{status}");
}

/// `allow_down_at_start` covers a missing device, not a configuration no retry can mend: a
/// character format the line cannot have stops the gateway as without it.
#[test]
fn allow_down_at_start_still_stops_on_a_bad_line_configuration() {
    let toml = "allow_down_at_start = true\n[[line]]\ndevice = \"/nonexistent/tty\"\n\
                units = \"1\"\ndata_bits = 9\n";
    let path = test_dir("gateway-start-down").join("bad.toml");
    std::fs::write(&path, toml).expect("write the config");
    let o = crate::common::si(&["gateway", "--config", path.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", crate::common::stderr(&o));
    assert!(
        crate::common::stderr(&o).contains("data bits 9 out of range"),
        "{}",
        crate::common::stderr(&o)
    );
}
