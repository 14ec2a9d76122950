//! What the machine knows about its serial ports: USB identity and the adapter's latency
//! timer (a USB adapter hands received bytes over in packets, at the latest when its
//! latency timer runs out, 16 ms by default on FTDI chips).

use crate::time::Duration;
use std::io;
use std::path::{Path, PathBuf};

/// One serial port of this machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    /// The name to open it by (`/dev/ttyUSB0`, `COM3`).
    pub path: String,
    /// USB identity, for USB adapters.
    pub usb: Option<UsbIds>,
    /// The USB adapter's latency timer (Linux, usb-serial adapters that have one).
    pub latency_timer: Option<Duration>,
    /// What kind of port the OS says it is, for ports that are not USB (`pci`, `bluetooth`,
    /// `unknown`).
    pub kind: &'static str,
}

/// A USB adapter's identity.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UsbIds {
    /// USB vendor id (0403 for FTDI).
    pub vendor_id: u16,
    /// USB product id.
    pub product_id: u16,
    /// Manufacturer string, if the device gives one.
    pub manufacturer: Option<String>,
    /// Product string, if the device gives one.
    pub product: Option<String>,
    /// Serial number, if the device gives one.
    pub serial_number: Option<String>,
}

/// The serial ports of this machine, with USB identity and latency timer where known.
pub fn list() -> io::Result<Vec<PortInfo>> {
    let ports = tokio_serial::available_ports().map_err(io::Error::from)?;
    Ok(ports
        .into_iter()
        .map(|p| {
            let (usb, kind) = match p.port_type {
                tokio_serial::SerialPortType::UsbPort(u) => (
                    Some(UsbIds {
                        vendor_id: u.vid,
                        product_id: u.pid,
                        manufacturer: u.manufacturer,
                        product: u.product,
                        serial_number: u.serial_number,
                    }),
                    "usb",
                ),
                tokio_serial::SerialPortType::PciPort => (None, "pci"),
                tokio_serial::SerialPortType::BluetoothPort => (None, "bluetooth"),
                tokio_serial::SerialPortType::Unknown => (None, "unknown"),
            };
            PortInfo {
                latency_timer: latency_timer(&p.port_name),
                path: p.port_name,
                usb,
                kind,
            }
        })
        .collect())
}

/// What the machine knows about the port at `path`: its entry in [`list`] (matched after
/// following links such as `/dev/serial/by-id/…`), or just its path and latency timer when
/// the OS does not list it (a pseudo-terminal).
pub fn describe(path: &str) -> PortInfo {
    let real = |p: &str| std::fs::canonicalize(p).unwrap_or_else(|_| PathBuf::from(p));
    let wanted = real(path);
    list()
        .ok()
        .and_then(|ports| ports.into_iter().find(|p| real(&p.path) == wanted))
        .map(|listed| PortInfo {
            path: path.to_owned(),
            ..listed
        })
        .unwrap_or_else(|| PortInfo {
            path: path.to_owned(),
            usb: None,
            latency_timer: latency_timer(path),
            kind: "unknown",
        })
}

/// The sysfs file of a USB serial adapter's latency timer (Linux): the tty's name after
/// following links such as `/dev/serial/by-id/…`.
fn latency_file(path: &str) -> Option<PathBuf> {
    let real = std::fs::canonicalize(path).unwrap_or_else(|_| PathBuf::from(path));
    let tty = real.file_name()?;
    Some(
        Path::new("/sys/bus/usb-serial/devices")
            .join(tty)
            .join("latency_timer"),
    )
}

/// The adapter's latency timer, if the port has one the OS shows (Linux usb-serial adapters;
/// `None` for other ports and other platforms).
pub fn latency_timer(path: &str) -> Option<Duration> {
    if !cfg!(target_os = "linux") {
        return None;
    }
    let text = std::fs::read_to_string(latency_file(path)?).ok()?;
    text.trim().parse().ok().map(Duration::from_millis)
}

/// The range the adapter's latency timer takes (FTDI: 1–255 ms).
pub const LATENCY_TIMER_MS: std::ops::RangeInclusive<u64> = 1..=255;

/// Set the adapter's latency timer (Linux; 1–255 ms). Errors say why: not a USB serial
/// adapter with a latency timer, no permission (the file belongs to root unless a udev rule
/// says otherwise), out of range, or not Linux.
pub fn set_latency_timer(path: &str, latency: Duration) -> io::Result<()> {
    let ms = latency.as_millis();
    if !LATENCY_TIMER_MS.contains(&ms) || !latency.as_micros().is_multiple_of(1_000) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("latency timer {latency} out of range: whole milliseconds, 1 … 255"),
        ));
    }
    if !cfg!(target_os = "linux") {
        return Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "setting the latency timer needs Linux (on Windows: the FTDI driver's port properties)",
        ));
    }
    let file = latency_file(path).ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::NotFound,
            format!("{path}: not a device path"),
        )
    })?;
    if !file.exists() {
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!(
                "{path} has no latency timer to set (no {}): not a USB serial adapter with one",
                file.display()
            ),
        ));
    }
    std::fs::write(&file, format!("{ms}\n")).map_err(|e| {
        let hint = if e.kind() == io::ErrorKind::PermissionDenied {
            " (run as root, or allow it with a udev rule: ATTR{latency_timer}=\"1\")"
        } else {
            ""
        };
        io::Error::new(
            e.kind(),
            format!(
                "cannot set the latency timer of {path} ({}): {e}{hint}",
                file.display()
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unlisted_port_is_described_by_its_path() {
        let info = describe("/dev/null");
        assert_eq!(info.path, "/dev/null");
        assert_eq!((info.usb, info.latency_timer), (None, None));
    }

    #[test]
    fn a_port_without_sysfs_entry_has_no_latency_timer_and_says_so() {
        assert_eq!(latency_timer("/dev/null"), None);
        let e = set_latency_timer("/dev/null", Duration::from_millis(1)).unwrap_err();
        if cfg!(target_os = "linux") {
            assert_eq!(e.kind(), io::ErrorKind::NotFound);
            assert!(e.to_string().contains("no latency timer"), "{e}");
        }
    }

    #[test]
    fn the_latency_timer_range_is_checked_first() {
        for bad in [
            Duration::ZERO,
            Duration::from_millis(256),
            Duration::from_micros(1_500),
        ] {
            let e = set_latency_timer("/dev/ttyUSB0", bad).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{bad}");
        }
    }
}
