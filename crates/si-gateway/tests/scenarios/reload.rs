//! Reloading while serving: unchanged lines keep their port, clients, queue and counters;
//! changed lines restart, removed lines answer 0AH, added lines start; a reload that would
//! change what is bound is refused and the old configuration keeps running.

use crate::common::{config, read, start};
use si_gateway::Reloaded;
use si_modbus::frame::Request;
use std::time::Duration;

const LINES: &str = r#"
listen = "127.0.0.1:0"
[[line]]
name = "a"
device = "7"
units = "7"
pause_ms = 0
[[line]]
name = "b"
device = "8"
units = "8"
pause_ms = 0
[[line]]
name = "c"
device = "9"
units = "9"
pause_ms = 0
"#;

/// `LINES` with b changed, c removed and d added.
fn changed() -> String {
    let b_changed = LINES.replace("units = \"8\"\npause_ms = 0", "units = \"8\"\npause_ms = 1");
    let without_c = b_changed
        .split("[[line]]\nname = \"c\"")
        .next()
        .unwrap()
        .to_owned();
    without_c + "[[line]]\nname = \"d\"\ndevice = \"10\"\nunits = \"10\"\npause_ms = 0\n"
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_reload_while_a_client_polls_another_line_at_10_hz_fails_none_of_its_requests() {
    let (gateway, slaves) = start(LINES).await;
    let gateway = std::sync::Arc::new(gateway);
    let addr = gateway.listeners()[0].addr;
    let serving = {
        let g = std::sync::Arc::clone(&gateway);
        tokio::spawn(async move { g.run().await })
    };
    let client = tokio::spawn(async move {
        let c = si_modbus::tokio::tcp::Client::connect(addr).await.unwrap();
        let r = Request::ReadHoldingRegisters {
            address: 1,
            quantity: 1,
        };
        let mut answers = Vec::new();
        for _ in 0..12 {
            answers.push(c.request_adu(7, &r).await.map(|a| a.unit_pdu().to_vec()));
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        // The client goes back with its connection open, to be counted below.
        (answers, c)
    });
    tokio::time::sleep(Duration::from_millis(350)).await;
    let before = gateway.stats();
    assert_eq!(before.clients.len(), 1, "the poller is connected");
    let done = gateway.reload(config(&changed())).await.unwrap();
    assert_eq!(
        done,
        Reloaded {
            kept: vec!["a".into()],
            restarted: vec!["b".into()],
            added: vec!["d".into()],
            removed: vec!["c".into()],
        }
    );
    let h = gateway.handler();
    assert_eq!(
        h.call(read(1, 9, 0)).await.unwrap().unit_pdu(),
        [9, 0x83, 0x0A]
    );
    assert_eq!(
        h.call(read(2, 10, 1)).await.unwrap().unit_pdu(),
        [10, 0x03, 2, 0x03, 0xE9],
        "the added line serves"
    );
    assert_eq!(
        h.call(read(3, 8, 1)).await.unwrap().unit_pdu(),
        [8, 0x03, 2, 0x03, 0x21],
        "the restarted line serves"
    );
    let (answers, _connected) = client.await.unwrap();
    for (i, a) in answers.iter().enumerate() {
        assert_eq!(
            a.as_deref().ok(),
            Some(&[7, 0x03, 2, 0x02, 0xBD][..]),
            "poll {i}: {a:?}"
        );
    }
    let after = gateway.stats();
    assert_eq!(after.lines.len(), 3, "a, b, d");
    assert_eq!(after.lines[0].answers, 12, "a's counters went on");
    assert_eq!(after.lines[1].answers, 1, "b's counters went on");
    assert_eq!(after.lines[2].answers, 1);
    // One connection throughout: one client counted every poll.
    let (_, poller) = after.clients.iter().next().expect("still connected");
    assert_eq!(poller.counters.requests, 12);
    // a kept its pipe; b and d were opened at the reload: 3 + 2.
    assert_eq!(slaves.lock().unwrap().len(), 5);
    // Only the first run serves; end it.
    gateway.shutdown_handle().shutdown();
    assert_eq!(serving.await.unwrap(), Ok(()));
}

#[tokio::test]
async fn a_reload_that_changes_the_listening_addresses_is_refused_and_the_old_one_runs() {
    let (gateway, _slaves) = start(LINES).await;
    let moved = LINES.replace(
        "[[line]]\nname = \"c\"",
        "[[line]]\nlisten = \"127.0.0.1:1\"\nname = \"c\"",
    );
    let e = gateway.reload(config(&moved)).await.unwrap_err();
    assert!(e.to_string().contains("only with a restart"), "{e}");
    let running = gateway.config().await;
    assert_eq!(running.lines.len(), 3);
    assert_eq!(running.lines[2].listen, None);
    let h = gateway.handler();
    assert_eq!(h.call(read(1, 9, 0)).await.unwrap().unit_pdu()[1], 0x03);
}

#[tokio::test]
async fn a_reload_whose_changed_line_cannot_start_is_refused_and_that_line_keeps_serving() {
    let (gateway, slaves) = start(LINES).await;
    let h = gateway.handler();
    assert_eq!(h.call(read(1, 8, 1)).await.unwrap().unit_pdu()[1], 0x03);
    // b changed to a character format its Modbus RTU master refuses (8 data bits only), and
    // d added: the file checks, but b's engine cannot be built.
    let refused = changed().replace(
        "units = \"8\"\npause_ms = 1",
        "units = \"8\"\ndata_bits = 7",
    );
    let e = gateway.reload(config(&refused)).await.unwrap_err();
    assert!(e.to_string().contains("line b"), "{e}");
    let running = gateway.config().await;
    assert_eq!(running.lines.len(), 3, "the old configuration runs");
    assert_eq!(running.lines[2].name, "c");
    for (t, unit, want) in [(2, 7, 0x02BD), (3, 8, 0x0321), (4, 9, 0x0385)] {
        // A bound only, so that a line left without its task fails here instead of hanging.
        let answer = tokio::time::timeout(Duration::from_secs(10), h.call(read(t, unit, 1)));
        let got = answer.await.expect("an answer").unwrap();
        assert_eq!(
            got.unit_pdu(),
            [unit, 0x03, 2, (want >> 8) as u8, want as u8],
            "unit {unit} is served as before"
        );
    }
    assert_eq!(
        h.call(read(5, 10, 1)).await.unwrap().unit_pdu(),
        [10, 0x83, 0x0A],
        "the line the refused file adds is not there"
    );
    assert_eq!(gateway.stats().lines.len(), 3, "no slot was added");
    // Nothing was opened for the refused file: b kept its pipe.
    assert_eq!(slaves.lock().unwrap().len(), 3);
}
