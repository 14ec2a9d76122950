//! The `si` binary on pseudo-terminals, one module per protocol or topic: each talks to a peer
//! (another `si`, socat, pymodbus, mbpoll) over a pty pair. A missing peer is a skip with a
//! message, a failure with `CI` set (common/mod.rs).

#[path = "pty/ascii.rs"]
mod ascii;
#[path = "pty/ascii_usb_relay.rs"]
mod ascii_usb_relay;
mod common;
#[path = "pty/dpcoord.rs"]
mod dpcoord;
#[path = "pty/hex_input.rs"]
mod hex_input;
#[path = "pty/logs.rs"]
mod logs;
#[path = "pty/lost_line.rs"]
mod lost_line;
#[path = "pty/modbus_frame_end.rs"]
mod modbus_frame_end;
#[path = "pty/modbus_interop.rs"]
mod modbus_interop;
#[path = "pty/modbus_poll.rs"]
mod modbus_poll;
#[path = "pty/modbus_scan.rs"]
mod modbus_scan;
#[path = "pty/modbus_serial_example.rs"]
mod modbus_serial_example;
#[path = "pty/modbus_serve_map.rs"]
mod modbus_serve_map;
#[path = "pty/modbus_tcp.rs"]
mod modbus_tcp;
#[path = "pty/modbus_usb_relay.rs"]
mod modbus_usb_relay;
#[path = "pty/monitor.rs"]
mod monitor;
#[path = "pty/monitor_flood.rs"]
mod monitor_flood;
#[path = "pty/noise_links.rs"]
mod noise_links;
#[path = "pty/noise_masters.rs"]
mod noise_masters;
#[path = "pty/port_check.rs"]
mod port_check;
#[path = "pty/port_flags.rs"]
mod port_flags;
#[path = "pty/profile.rs"]
mod profile;
#[path = "pty/r3964.rs"]
mod r3964;
#[path = "pty/r3964_probe.rs"]
mod r3964_probe;
#[path = "pty/rk512.rs"]
mod rk512;
#[path = "pty/rs485_sysfs.rs"]
mod rs485_sysfs;
#[path = "pty/servers_flooded.rs"]
mod servers_flooded;
#[path = "pty/three_protocols_example.rs"]
mod three_protocols_example;
#[path = "pty/uss.rs"]
mod uss;
#[path = "pty/uss_scan.rs"]
mod uss_scan;
#[path = "pty/uss_usb_relay.rs"]
mod uss_usb_relay;
