//! Every framing option `si modbus read` takes is also a flag on `si modbus serve` (issue 16):
//! the lists of framing flags match, and `--char-delay-multiplier` really sets the slave's gap
//! (§3.5: tZVZ = tZVZ_TAB × fMUL) or is refused with the manual's 0E21H when out of range.

mod common;

use common::modbus::serve;
use common::{pty_pair, si, stderr, stdout};

/// The `--long` flags a subcommand's help lists.
fn flags(sub: &str) -> Vec<String> {
    let o = si(&["modbus", sub, "--help"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut v: Vec<String> = stdout(&o)
        .split_whitespace()
        .filter(|w| w.starts_with("--"))
        .map(|w| {
            w.trim_end_matches(|c: char| !c.is_ascii_alphanumeric())
                .to_owned()
        })
        .collect();
    v.sort();
    v.dedup();
    v
}

#[test]
fn serve_takes_every_framing_flag_read_takes() {
    let read = flags("read");
    let serve = flags("serve");
    // Master-only job options: which slave, how long to wait, how often to retry or poll, and
    // what to read.
    let master_only = [
        "--unit",
        "--timeout",
        "--retries",
        "--poll",
        "--addr",
        "--count",
        "--help",
    ];
    for f in read.iter().filter(|f| !master_only.contains(&f.as_str())) {
        assert!(serve.contains(f), "serve lacks {f}: {serve:?}");
    }
    for f in ["--mode", "--char-delay-multiplier", "--frame-end"] {
        assert!(serve.contains(&f.to_owned()), "serve lacks {f}");
    }
}

#[test]
fn serve_refuses_a_char_delay_multiplier_out_of_range_with_0e21h() {
    let o = si(&[
        "--port",
        "/dev/null",
        "modbus",
        "serve",
        "--unit",
        "1",
        "--char-delay-multiplier",
        "11",
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("16#0E21") && err.contains("11"), "{err}");
}

#[test]
fn serve_char_delay_multiplier_sets_the_gap() {
    let Some(pair) = pty_pair() else { return };
    // 9600 bit/s: tZVZ_TAB = 4 ms; × 3 = 12 ms.
    let (_serve, banner, _) = serve(&pair.a, &[], &["--char-delay-multiplier", "3"]);
    assert!(banner.contains("end-of-frame gap 12 ms"), "{banner}");
}
