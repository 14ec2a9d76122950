//! The tokio driver in virtual time (feature `tokio`): its timers, a late host, RS-485 direction
//! control and logs.
//! The timer thread's own test stays in driver_timer_thread.rs: it counts the process's threads,
//! which other tests running beside it in one binary would disturb.

#[path = "scenarios/driver_late_host.rs"]
mod driver_late_host;
#[path = "scenarios/driver_rs485.rs"]
mod driver_rs485;
#[path = "scenarios/driver_timers.rs"]
mod driver_timers;
#[path = "scenarios/driver_tx_enable.rs"]
mod driver_tx_enable;
