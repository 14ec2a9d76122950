//! Modbus TCP clients served by Modbus RTU lines, as mbusd does, several lines in one process,
//! and by USS, RK 512 and 3964(R) lines: the gateway of the `si gateway` command, as a library.
//!
//! Requests are routed by unit id to a line ([`router`]); a Modbus RTU or RK 512 line has a
//! bounded queue served in round-robin order between clients ([`queue`]) by a task driving the
//! line's master ([`mod@line`]), USS and 3964(R) lines answer from their images at once;
//! counters per line and per client are kept ([`counters`]) and readable on a diagnostic unit.
//! The configuration is a TOML file ([`config`]); the RS-485 direction modes (`kernel`, `rts`,
//! `rts-inverted`, `sysfs`, `sysfs-inverted`) apply to every line kind. Lines are opened
//! ([`open`]) and started ([`start`]); a line whose port closes is reopened while its requests
//! get 0AH ([`reopen`]), and says so through the program's event sink ([`event`]); with
//! `allow_down_at_start` a line whose port cannot be opened at start starts that way.
//! A `kind = "uss"` line serves USS drives instead: each drive is a unit id whose PZD and
//! parameter window are registers ([`uss`], keys in [`uss_config`]). A `kind = "rk512"` line
//! serves an RK 512 partner's S7 memory through S_MODB's conversion DB, or the gateway's own
//! memory as a passive partner ([`rk512`], [`rk512_own`], keys in [`rk512_config`], spans in
//! [`rk512_spans`]); a `kind = "3964r"` line shows a plain 3964(R) partner's latest block as
//! input registers and sends a block for a register write ([`r3964`], keys in
//! [`r3964_config`]). Every line kind is reopened the same way when its port closes. A line
//! may have its own listening address ([`faces`]), so that more than 255 lines fit in one
//! process.
//!
//! A Modbus RTU unit that stops answering is demoted for a while so it does not slow the live
//! ones ([`demotion`]); the counters per line, unit and outcome are served to Prometheus on
//! `metrics_listen` ([`gateway_metrics`], [`metrics`], [`metrics_http`]); raw RTU frames over
//! TCP are accepted on `rtu_over_tcp_listen` ([`rtu_listener`]); both extra listeners start
//! with the gateway ([`listeners`]).

pub mod backend;
pub mod config;
pub mod counters;
pub mod demotion;
mod error;
pub mod event;
pub mod faces;
mod gateway;
pub mod gateway_metrics;
pub mod limits;
pub mod line;
pub mod listeners;
pub mod metrics;
pub mod metrics_http;
pub mod open;
pub mod port_config;
pub mod quantities;
pub mod queue;
pub mod r3964;
pub mod r3964_config;
pub mod reopen;
pub mod report;
pub mod rk512;
pub mod rk512_config;
pub mod rk512_own;
pub mod rk512_spans;
pub mod router;
pub mod rtu_config;
pub mod rtu_listener;
pub mod start;
mod sync;
pub mod tcp_config;
pub mod tcp_line;
pub mod uss;
pub mod uss_config;

pub use error::Error;
pub use event::{Event, Events};
pub use gateway::{Gateway, Handler, Listener, Options, Reloaded, Shutdown};
