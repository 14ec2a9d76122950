//! `/metrics` scraped from a running `si gateway` and parsed by Prometheus's own text parser
//! (`prometheus_client.parser`, in `metrics_scrape.py` beside this file): exact counts after a
//! known sequence of requests, and exactly 100 more 0BH exceptions after 100 requests to a dead
//! unit.

use super::harness::{wait_for_event, Rig};
use std::time::Duration;

/// Is prometheus_client importable (a skip, or a failure with `CI` set, if not)?
fn have_prometheus_client() -> bool {
    si_testkit::peers::peer(
        "prometheus_client",
        std::process::Command::new("python3").args(["-c", "import prometheus_client"]),
        "pip install prometheus_client==0.26.0",
    )
}

#[test]
fn a_scrape_parsed_by_prometheus_has_exact_counts() {
    if !have_prometheus_client() {
        return;
    }
    let Some(rig) = Rig::start(
        "metrics_listen = \"127.0.0.1:0\"",
        "retries = 0\nresponse_timeout_ms = 100\npause_ms = 0\ndemote_after = 3\n",
    ) else {
        return;
    };
    let metrics = wait_for_event(&rig.log, "metrics_listening", Duration::from_secs(10));
    let metrics = metrics["addr"].as_str().expect("addr").to_owned();
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/gateway/metrics_scrape.py"
    );
    let out = std::process::Command::new("python3")
        .args([script, &rig.addr, &metrics])
        .output()
        .expect("run python3");
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "OK");
    let status = rig.stop();
    assert_eq!(status["lines"][1]["timeouts"], 103, "{status}");
}
