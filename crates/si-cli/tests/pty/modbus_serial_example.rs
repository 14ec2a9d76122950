//! The `modbus_serial` example (root package, feature `serial`) reads registers from
//! `si modbus serve` over a socat pty pair: a library user's program, with the port opened by
//! `si_core::port::open`, against the command line's slave.
//!
//! The example is built by `cargo test --workspace --all-features` (examples are built with
//! the tests); alone, build it with `cargo build --example modbus_serial --features serial`.
//! Missing, it is a skip with that message, a failure with `CI` set.

use crate::common;

use common::modbus::serve;
use common::{example, pty_pair, stderr, stdout};
use std::process::Command;

#[test]
fn modbus_serial_example_reads_what_it_wrote_from_si_modbus_serve() {
    let Some(example) = example("modbus_serial") else {
        return;
    };
    let Some(pair) = pty_pair() else { return };
    let (_serve, _banner, served) = serve(&pair.b, &[], &[]);
    let o = Command::new(example)
        .arg(&pair.a)
        .arg("1")
        .output()
        .expect("run the example");
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert_eq!(stdout(&o).trim(), "holding 0…3: [1234, 0000, 0000, 0000]");
    let log = common::modbus::served(&served);
    assert!(log.contains("served FC06 address 0 quantity 1"), "{log}");
    assert!(log.contains("served FC03 address 0 quantity 4"), "{log}");
}
