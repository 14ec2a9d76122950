//! Modbus RTU scenarios, one module per topic ([Modbus/USS] §3.2–§3.5): the master, the
//! slave, the automatic V.24 signals, frames ended by length, USB adapters, FIFO UARTs, and read jobs
//! through S_SEND/S_RCV at the 200-byte limit.

#[path = "scenarios/auto_v24.rs"]
mod auto_v24;
#[path = "scenarios/fifo_uart.rs"]
mod fifo_uart;
#[path = "scenarios/frame_end_length.rs"]
mod frame_end_length;
#[path = "scenarios/master.rs"]
mod master;
#[path = "scenarios/pass_through.rs"]
mod pass_through;
#[path = "scenarios/quiet_guard.rs"]
mod quiet_guard;
#[path = "scenarios/s_send_read_limit.rs"]
mod s_send_read_limit;
#[path = "scenarios/slave.rs"]
mod slave;
#[path = "scenarios/spec_gap.rs"]
mod spec_gap;
#[path = "scenarios/usb_adapter.rs"]
mod usb_adapter;
