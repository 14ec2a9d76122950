//! The gateway in-process: lines over `tokio::io::duplex` pipes to simulated slaves, reached
//! through the library's API (no ports, no `si` binary).

#[path = "scenarios/common.rs"]
mod common;

#[path = "scenarios/api.rs"]
mod api;

#[path = "scenarios/config_kinds.rs"]
mod config_kinds;

#[path = "scenarios/unit_map.rs"]
mod unit_map;

#[path = "scenarios/reload.rs"]
mod reload;

#[path = "scenarios/reload_metrics.rs"]
mod reload_metrics;

#[path = "scenarios/rtu_over_tcp.rs"]
mod rtu_over_tcp;

#[path = "scenarios/modbus_tcp.rs"]
mod modbus_tcp;

#[path = "scenarios/queueing.rs"]
mod queueing;
