//! A `kind = "uss"` line: `si uss sim-slave --address 5` on one end of a socat pty pair,
//! `si gateway` polling it on the other, raw MBAP frames from a std socket. Unit 5 is the drive;
//! unit 6 is drive address 6, which nobody answers. Skips without socat (fails with `CI` set).

use crate::common::{have_socat, opened, pty_pair, si_command, test_dir, Kill};
use crate::harness::{
    launch, read_holding, stop, wait_for_event, write_registers, Client, LinkedPair,
};
use std::process::Stdio;
use std::time::Duration;

/// FC04 for `count` registers from `addr`.
fn read_input(addr: u16, count: u16) -> Vec<u8> {
    let mut pdu = read_holding(addr, count);
    pdu[0] = 0x04;
    pdu
}

/// The words of a read answer (`[fc, bytes, words…]`).
fn words(pdu: &[u8]) -> Vec<u16> {
    assert!(pdu[0] & 0x80 == 0, "an exception: {pdu:02X?}");
    pdu[2..]
        .chunks(2)
        .map(|w| u16::from_be_bytes([w[0], w[1]]))
        .collect()
}

impl Client {
    /// Run a parameter job through unit 5's window (registers 100…104) and return the window
    /// (100…107) once it is no longer busy.
    fn job(&mut self, pnu: u16, value: u32, command: u16) -> Vec<u16> {
        let window = [pnu, 0, (value >> 16) as u16, value as u16, command];
        assert_eq!(
            self.ask(5, &write_registers(100, &window)),
            [0x10, 0, 100, 0, 5]
        );
        let answer = self.until(5, &read_holding(100, 8), |a| words(a)[5] != 1);
        words(&answer)
    }
}

/// `si uss sim-slave --address 5` on `port`, killed when dropped.
fn drive(port: &str) -> Kill {
    let drive = Kill(
        si_command()
            .args(["uss", "sim-slave", "--address", "5", "--port", port])
            .stdout(Stdio::null())
            .spawn()
            .expect("start sim-slave"),
    );
    opened(&drive.0, port);
    drive
}

#[test]
fn a_simulated_drive_is_served_as_pzd_registers_and_a_parameter_window() {
    let Some(pair) = pty_pair() else { return };
    let _drive = drive(&pair.b);
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"drives\"\nkind = \"uss\"\n\
         device = \"{}\"\nunits = \"5,6\"\nresponse_timeout_ms = 200\nretries = 2\n",
        pair.a
    );
    let (addr, _log, _gateway) = launch(&toml, &pair.a);
    let mut c = Client::connect(&addr);

    // ZSW and HIW once the drive has answered; a drive that never answers is 0BH.
    c.until(5, &read_input(0, 2), |a| a[0] == 0x04);
    assert_eq!(c.ask(6, &read_input(0, 2)), [0x84, 0x0B]);
    // Outside the map: past the PZD, across into the window, an unknown function.
    assert_eq!(c.ask(5, &read_input(1, 2)), [0x84, 0x02]);
    assert_eq!(c.ask(5, &read_holding(2, 1)), [0x83, 0x02]);
    assert_eq!(c.ask(5, &read_holding(104, 5)), [0x83, 0x02]);
    assert_eq!(c.ask(5, &[0x01, 0, 0, 0, 1]), [0x81, 0x01]);
    assert_eq!(c.ask(5, &write_registers(105, &[0])), [0x90, 0x02]);
    assert_eq!(
        c.ask(5, &write_registers(100, &[700, 0, 0, 0, 9])),
        [0x90, 0x03]
    );

    // STW "run" and HSW 2000 as holding registers; they read back and the drive follows:
    // running (ZSW bit 2), HIW ramps to the setpoint, "setpoint reached" (bit 10) comes on.
    assert_eq!(
        c.ask(5, &write_registers(0, &[0x047F, 2000])),
        [0x10, 0, 0, 0, 2]
    );
    assert_eq!(words(&c.ask(5, &read_holding(0, 2))), [0x047F, 2000]);
    let running = c.until(5, &read_input(0, 2), |a| words(a)[1] == 2000);
    let zsw = words(&running)[0];
    assert_ne!(zsw & 0x0004, 0, "ZSW {zsw:04X}");
    assert_ne!(zsw & 0x0400, 0, "ZSW {zsw:04X}");
    // FC06 on HSW alone.
    assert_eq!(
        c.ask(5, &[0x06, 0, 1, 0x01, 0xF4]),
        [0x06, 0, 1, 0x01, 0xF4]
    );
    c.until(5, &read_input(1, 1), |a| words(a) == [500]);

    // The parameter window: read P700 (the simulated drive's 5), write P1082 = 120 and read
    // it back, and a write past its limit fails with 16#1503 and AK 7 error number 2.
    let w = c.job(700, 0, 1);
    assert_eq!((w[3], w[4], w[5]), (5, 1, 2), "{w:?}");
    let w = c.job(1082, 120, 2);
    assert_eq!((w[3], w[5]), (120, 2), "{w:?}");
    let w = c.job(1082, 0, 1);
    assert_eq!((w[0], w[3], w[5]), (1082, 120, 2), "{w:?}");
    let w = c.job(1082, 1000, 2);
    assert_eq!((w[5], w[6], w[7]), (3, 0x1503, 2), "{w:?}");
    // A PNU the page index cannot address: the master refuses the job with its STATUS,
    // 16#1E20 "parameter out of range" (`RequestError::status`), never a made-up FFFFH.
    let w = c.job(62_000, 0, 1);
    assert_eq!((w[5], w[6]), (3, 0x1E20), "{w:?}");
    // Unit 6 never answers: its job fails with "node does not answer" (16#1408).
    c.tid += 1;
    c.mbap
        .send(c.tid, 6, &write_registers(100, &[700, 0, 0, 0, 1]));
    assert_eq!(c.mbap.recv().2, [0x10, 0, 100, 0, 5]);
    let w = c.until(6, &read_holding(105, 2), |a| words(a)[0] != 1);
    assert_eq!(words(&w), [3, 0x1408]);
}

/// The USS line goes down with its port like an RTU line (`reopen`): 0AH for its drives, the
/// window included, until the port is back under its name; then the drive is polled again.
#[test]
fn a_uss_line_whose_port_closes_answers_0ah_and_is_reopened() {
    if !have_socat() {
        return;
    }
    let dir = test_dir("gateway-uss-reconnect");
    let (a, b) = (dir.join("line"), dir.join("drive"));
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    let pair = LinkedPair::start(a, b);
    let sim = drive(b);
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"drives\"\nkind = \"uss\"\n\
         device = \"{a}\"\nunits = \"5\"\nresponse_timeout_ms = 200\nretries = 2\n"
    );
    let (addr, log, gateway) = launch(&toml, a);
    let mut c = Client::connect(&addr);
    c.until(5, &read_input(0, 2), |a| a[0] == 0x04);

    drop(sim);
    drop(pair);
    wait_for_event(&log, "line_down", Duration::from_secs(10));
    assert_eq!(c.ask(5, &read_input(0, 2)), [0x84, 0x0A]);
    assert_eq!(c.ask(5, &read_holding(100, 8)), [0x83, 0x0A]);

    let _pair = LinkedPair::start(a, b);
    let _sim = drive(b);
    wait_for_event(&log, "line_up", Duration::from_secs(40));
    c.until(5, &read_input(0, 2), |a| a[0] == 0x04);
    let status = stop(&gateway, &log);
    assert_eq!(status["lines"][0]["reconnects"], 1, "{status}");
    assert_eq!(status["lines"][0]["state"], "up", "{status}");
}
