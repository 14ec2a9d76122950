//! `si ports`: the serial ports the OS knows, with USB identity and the adapter's latency
//! timer (Linux), which decides how late received bytes reach the host.

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use si_core::port::{self, PortInfo};

/// List serial ports, one per line (or JSON objects with `--json`). With `--port` and
/// `--latency-timer MS`, set that port's latency timer first.
pub fn run(conn: &Connection, out: &Output) -> Result<(), CliError> {
    if let Some(ms) = conn.latency_timer {
        let path = conn.port.as_deref().ok_or_else(|| {
            CliError::new("--latency-timer with `si ports` needs the port: --port PATH")
        })?;
        port::set_latency_timer(path, si_core::Duration::from_millis(ms))?;
    }
    let ports =
        port::list().map_err(|e| CliError::new(format!("cannot list serial ports: {e}")))?;
    if ports.is_empty() && !out.json {
        println!("no serial ports found");
    }
    for p in ports {
        out.line(&describe(&p), json(&p));
    }
    Ok(())
}

/// `/dev/ttyUSB0  usb 0403:6001 FTDI FT232R USB UART  latency 16 ms`.
fn describe(p: &PortInfo) -> String {
    let mut text = format!("{}  {}", p.path, p.kind);
    if let Some(u) = &p.usb {
        text += &format!(" {:04x}:{:04x}", u.vendor_id, u.product_id);
        for name in [&u.manufacturer, &u.product].into_iter().flatten() {
            text += &format!(" {name}");
        }
    }
    if let Some(latency) = p.latency_timer {
        text += &format!("  latency timer {} ms", latency.as_millis());
        if latency.as_millis() > 1 {
            text += " (si --latency-timer 1 … to lower it)";
        }
    }
    text
}

fn json(p: &PortInfo) -> serde_json::Value {
    serde_json::json!({
        "port": p.path,
        "type": p.kind,
        "usb": p.usb.as_ref().map(|u| serde_json::json!({
            "vid": u.vendor_id,
            "pid": u.product_id,
            "manufacturer": u.manufacturer,
            "product": u.product,
            "serial_number": u.serial_number,
        })),
        "latency_timer_ms": p.latency_timer.map(|l| l.as_millis()),
    })
}
