//! `si gateway` end to end, loopback only: Modbus TCP clients (pymodbus, and raw MBAP frames
//! from std sockets) → `si gateway` → a socat pseudo-terminal pair → a pymodbus RTU serial
//! server (a simulated USS drive behind a `uss` line, `si rk512 serve` behind an `rk512`
//! line), and a bounded soak of 32 clients with bad input; a line whose pty goes away and comes
//! back (RTU, RK 512 in both roles), and a slave whose corrupt answers a retry cures. A missing peer (socat, pymodbus)
//! skips with a message, and fails with `CI` set (common/mod.rs).

mod common;
#[path = "gateway/config_errors.rs"]
mod config_errors;
#[path = "gateway/crc_errors.rs"]
mod crc_errors;
#[path = "gateway/forwarding.rs"]
mod forwarding;
#[path = "gateway/harness.rs"]
mod harness;
#[path = "gateway/many_lines.rs"]
mod many_lines;
#[path = "gateway/mbusd_itests.rs"]
mod mbusd_itests;
#[path = "gateway/metrics_scrape.rs"]
mod metrics_scrape;
#[path = "gateway/pass_through.rs"]
mod pass_through;
#[path = "gateway/probe.rs"]
mod probe;
#[path = "gateway/queueing.rs"]
mod queueing;
#[path = "gateway/reconnect.rs"]
mod reconnect;
#[path = "gateway/reload.rs"]
mod reload;
#[path = "gateway/rk512.rs"]
mod rk512;
#[path = "gateway/rk512_reconnect.rs"]
mod rk512_reconnect;
#[path = "gateway/rs485.rs"]
mod rs485;
#[path = "gateway/rtu_over_tcp.rs"]
mod rtu_over_tcp;
#[path = "gateway/soak.rs"]
mod soak;
#[path = "gateway/uss.rs"]
mod uss;
