//! The `three_protocols` example (root package, feature `serial`): a user program of
//! 15 lines sends a block over 3964(R), reads a Modbus holding register and reads a USS
//! parameter through three alike handles, against `si` serving each partner over its own socat
//! pty pair (`si 3964r recv`, `si modbus serve`, `si uss sim-slave`). The test checks what the
//! program printed and what the partners saw.
//!
//! socat or the built example missing is a skip with a message, a failure with `CI` set.

use crate::common;

use common::modbus::{serve, served};
use common::{example, opened, pty_pair, si_command, stderr, stdout, Kill};
use std::process::{Command, Stdio};

#[test]
fn the_user_program_talks_3964r_modbus_and_uss_and_prints_each_answer() {
    let Some(example) = example("three_protocols") else {
        return;
    };
    let (Some(r3964), Some(modbus), Some(uss)) = (pty_pair(), pty_pair(), pty_pair()) else {
        return;
    };
    let recv = si_command()
        .args([
            "--json", "--port", &r3964.b, "3964r", "recv", "--count", "1",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si 3964r recv");
    let (_serve, _banner, modbus_log) = serve(&modbus.b, &[], &[]);
    let _drive = Kill(
        si_command()
            .args(["--port", &uss.b, "uss", "sim-slave", "--address", "3"])
            .stdout(Stdio::null())
            .spawn()
            .expect("start si uss sim-slave"),
    );
    opened(&_drive.0, &uss.b);

    let o = Command::new(example)
        .args([&r3964.a, &modbus.a, &uss.a])
        .output()
        .expect("run the example");
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert_eq!(
        stdout(&o).lines().collect::<Vec<_>>(),
        [
            "3964(R): sent 5 bytes",
            "Modbus: unit 1 register 0 = 0000",
            "USS: drive 3 P700 = 5",
        ]
    );

    let received = recv.wait_with_output().expect("si 3964r recv ends");
    assert!(received.status.success(), "{}", stderr(&received));
    let block: serde_json::Value =
        serde_json::from_str(stdout(&received).trim()).expect("one JSON line");
    assert_eq!(block["text"], "hello");
    let log = served(&modbus_log);
    assert!(log.contains("served FC03 address 0 quantity 1"), "{log}");
}

#[test]
fn without_ports_the_user_program_fails_with_its_usage() {
    let Some(example) = example("three_protocols") else {
        return;
    };
    let o = Command::new(example).output().expect("run the example");
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("usage: three_protocols"),
        "{}",
        stderr(&o)
    );
}
