//! A reload and the Prometheus metrics: every line keeps its counter slot, so a scrape after
//! the reload shows a kept or changed line's counters gone on from where they were (never
//! down), an added line under its own name, and no series of a removed line (a gone target's
//! series disappear, as Prometheus expects).

use crate::common::{config, read, start};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const LINES: &str = r#"
listen = "127.0.0.1:0"
metrics_listen = "127.0.0.1:0"
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

/// `GET /metrics` on `addr`: the exposition text.
async fn scrape(addr: std::net::SocketAddr) -> String {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    s.write_all(b"GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).await.unwrap();
    assert!(text.starts_with("HTTP/1.1 200"), "{text}");
    text
}

/// The answers counted for `line`'s `unit` in `text` (0 if no such series yet).
fn answers(text: &str, line: &str, unit: u8) -> u64 {
    let series =
        format!("si_gateway_requests_total{{line=\"{line}\",unit=\"{unit}\",outcome=\"answer\"}} ");
    text.lines()
        .find_map(|l| l.strip_prefix(series.as_str()))
        .map_or(0, |n| n.trim().parse().unwrap())
}

#[tokio::test]
async fn a_reload_keeps_each_lines_metrics_counters() {
    let (gateway, _slaves) = start(LINES).await;
    let extra = gateway.extra_listeners();
    assert_eq!(extra.len(), 1);
    assert_eq!(extra[0].event, "metrics_listening");
    let metrics = extra[0].addr;
    let h = gateway.handler();
    let mut t = 0;
    for (unit, times) in [(7, 3), (8, 2), (9, 1)] {
        for _ in 0..times {
            t += 1;
            assert_eq!(h.call(read(t, unit, 1)).await.unwrap().unit_pdu()[1], 0x03);
        }
    }
    let before = scrape(metrics).await;
    assert_eq!([answers(&before, "a", 7), answers(&before, "b", 8)], [3, 2]);
    assert_eq!(answers(&before, "c", 9), 1);
    gateway.reload(config(&changed())).await.unwrap();
    for unit in [7, 8, 10] {
        t += 1;
        assert_eq!(h.call(read(t, unit, 1)).await.unwrap().unit_pdu()[1], 0x03);
    }
    let after = scrape(metrics).await;
    assert_eq!(
        answers(&after, "a", 7),
        4,
        "the kept line counts on\n{after}"
    );
    assert_eq!(
        answers(&after, "b", 8),
        3,
        "the restarted line counts on\n{after}"
    );
    assert_eq!(
        answers(&after, "d", 10),
        1,
        "the added line in its own slot\n{after}"
    );
    for want in [
        "si_gateway_line_up{line=\"a\"} 1\n",
        "si_gateway_line_up{line=\"d\"} 1\n",
    ] {
        assert!(after.contains(want), "{want} not in\n{after}");
    }
    assert!(
        !after.contains("line=\"c\""),
        "the removed line's series are gone\n{after}"
    );
}

#[tokio::test]
async fn a_reload_that_moves_metrics_listen_or_rtu_over_tcp_listen_is_refused() {
    let (gateway, _slaves) = start(LINES).await;
    for moved in [
        LINES.replace(
            "metrics_listen = \"127.0.0.1:0\"",
            "metrics_listen = \"127.0.0.1:1\"",
        ),
        LINES.replace(
            "metrics_listen",
            "rtu_over_tcp_listen = \"127.0.0.1:0\"\nmetrics_listen",
        ),
    ] {
        let e = gateway.reload(config(&moved)).await.unwrap_err();
        assert!(e.to_string().contains("only with a restart"), "{e}");
    }
    assert_eq!(gateway.config().await.lines.len(), 3, "the old one runs");
}
