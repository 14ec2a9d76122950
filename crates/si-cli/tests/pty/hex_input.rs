//! One hex rule for every command that takes bytes (`crate::hex` in si-cli): the bytes
//! as separate words, mixed with a quoted group and `0x`, reach the partner over a
//! pseudo-terminal pair made by socat (`apt-get install socat`; a skip with a message when it is
//! missing, a failure with `CI` set).

use std::process::{Output, Stdio};

use crate::common;

use common::{opened, pty_pair_ignoreeof, si_command, text};

/// Start `si --json --port B <receiver>`, wait until it holds the port open, run `si --port A <sender>`,
/// and return the sender's output and the receiver's stdout.
fn send_to(receiver: &[&str], sender: &[&str]) -> Option<(Output, String)> {
    let pair = pty_pair_ignoreeof()?;
    let recv = si_command()
        .args(["--json", "--port", &pair.b])
        .args(receiver)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the receiver");
    opened(&recv, &pair.b);
    let sent = si_command()
        .args(["--port", &pair.a])
        .args(sender)
        .output()
        .expect("run the sender");
    if !sent.status.success() {
        // Nothing will come: closing the line ends the receiver.
        drop(pair);
    }
    let got = recv.wait_with_output().expect("the receiver ends");
    Some((sent, String::from_utf8_lossy(&got.stdout).into_owned()))
}

#[test]
fn r3964r_send_takes_the_bytes_as_separate_words() {
    let Some((sent, got)) = send_to(
        &["3964r", "recv", "--count", "1", "--priority", "low"],
        &[
            "3964r",
            "send",
            "--priority",
            "high",
            "01",
            "02",
            "10",
            "03",
        ],
    ) else {
        return;
    };
    assert!(sent.status.success(), "{}", text(&sent));
    assert!(got.contains(r#""hex":"01 02 10 03""#), "{got}");
}

#[test]
fn ascii_send_takes_words_a_quoted_group_and_0x() {
    let Some((sent, got)) = send_to(
        &[
            "ascii",
            "recv",
            "--end",
            "fixed",
            "4",
            "--count",
            "1",
            "--timeout",
            "20",
        ],
        &["ascii", "send", "41", "0x42", "43 44"],
    ) else {
        return;
    };
    assert!(sent.status.success(), "{}", text(&sent));
    assert!(got.contains(r#""frame":"41 42 43 44""#), "{got}");
}

#[test]
fn rk512_send_takes_the_data_as_separate_words() {
    let Some((sent, got)) = send_to(
        &["rk512", "serve", "--count", "1"],
        &[
            "rk512", "send", "--db", "1", "--dw", "0", "12", "34", "0x56", "78",
        ],
    ) else {
        return;
    };
    assert!(sent.status.success(), "{}\n{got}", text(&sent));
    assert!(text(&sent).contains("16#0000"), "{}", text(&sent));
}
