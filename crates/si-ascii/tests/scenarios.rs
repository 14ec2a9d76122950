//! The ASCII driver's scenarios, one module per topic of the manual ([ET200S SI]
//! [ET200S SI] §2.8–§2.10, [CP 341] §2.2.4, §2.3.3): end criteria, flow control, the function
//! blocks, line errors, the maximum frame length and its module presets, the receive buffer, the
//! tokio handle and USB adapters.

mod common;
#[path = "scenarios/end_criteria.rs"]
mod end_criteria;
#[path = "scenarios/fifo_uart.rs"]
mod fifo_uart;
#[path = "scenarios/flow_control.rs"]
mod flow_control;
#[path = "scenarios/function_blocks.rs"]
mod function_blocks;
#[path = "scenarios/line_errors.rs"]
mod line_errors;
#[path = "scenarios/max_frame.rs"]
mod max_frame;
#[path = "scenarios/receive_buffer.rs"]
mod receive_buffer;
#[path = "scenarios/tokio_duplex.rs"]
mod tokio_duplex;
#[path = "scenarios/usb_adapter.rs"]
mod usb_adapter;
