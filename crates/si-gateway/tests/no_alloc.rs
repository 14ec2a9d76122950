//! Counting a request in the gateway's metrics allocates nothing once its line's series were
//! looked up (when the line was added, at the start or by a reload): the calls a line task
//! makes for each request run under a counting global allocator.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use si_gateway::gateway_metrics::GatewayMetrics;
use si_testkit::alloc::{assert_no_alloc, counted};

fn main() {
    a_request_counted_in_the_metrics_allocates_nothing();
    println!("no_alloc: a request counted in the metrics allocates nothing: ok");
}

fn a_request_counted_in_the_metrics_allocates_nothing() {
    let mut m = GatewayMetrics::new(Vec::new());
    m.add_line("meters".into(), &[1, 2, 3]);
    // The first 0BH of unit 2 looks its code's series up, once.
    m.request(0, 2, "timeout", Some(0x0B), 0);
    assert_no_alloc("1000 rounds of requests counted", || {
        for _ in 0..1000 {
            for unit in [1, 2, 3] {
                m.request(0, unit, "answer", None, 0);
                m.retried(0, unit, 1);
                m.response_time(0, 0.012);
            }
            m.request(0, 2, "timeout", Some(0x0B), 2);
            m.request(0, 2, "demoted", Some(0x0B), 0);
            m.demotion_event(0, "demoted");
        }
    });
    // A unit the line was not configured with is looked up at its first request only.
    let ((), first) = counted(|| m.request(0, 9, "answer", None, 0));
    assert!(first.allocations > 0, "the lookup allocates: {first:?}");
    assert_no_alloc("a looked-up unit's request", || {
        m.request(0, 9, "answer", None, 0)
    });
}
