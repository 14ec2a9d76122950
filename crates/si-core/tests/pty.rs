//! The driver and the serial port on pseudo-terminals (Linux; feature `serial`).

#[path = "pty/driver.rs"]
mod driver;
#[path = "pty/port.rs"]
mod port;
