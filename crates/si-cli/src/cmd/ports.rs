//! `si ports`: the serial ports the OS knows.

use crate::error::CliError;
use crate::output::Output;

/// List serial ports, one per line (or JSON objects with `--json`).
pub fn run(out: &Output) -> Result<(), CliError> {
    let ports = tokio_serial::available_ports()
        .map_err(|e| CliError::new(format!("cannot list serial ports: {e}")))?;
    if ports.is_empty() && !out.json {
        println!("no serial ports found");
    }
    for p in ports {
        let kind = match &p.port_type {
            tokio_serial::SerialPortType::UsbPort(u) => format!(
                "usb {:04x}:{:04x} {}",
                u.vid,
                u.pid,
                u.product.clone().unwrap_or_default()
            ),
            tokio_serial::SerialPortType::PciPort => "pci".into(),
            tokio_serial::SerialPortType::BluetoothPort => "bluetooth".into(),
            tokio_serial::SerialPortType::Unknown => "unknown".into(),
        };
        out.line(
            &format!("{}  {}", p.port_name, kind),
            serde_json::json!({"port": p.port_name, "type": kind.trim()}),
        );
    }
    Ok(())
}
