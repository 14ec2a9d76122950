//! Serial ports from the library, one call (feature `serial`).
//!
//! [`open`] takes the [`SerialSettings`] the engine's config already holds, so the line's
//! format is written once, and returns a [`SerialPort`]: a [`Transport`] that every protocol's
//! async handle accepts (`si_modbus::tokio::Master::spawn`, `si_3964r::tokio::Handle::spawn`, …).
//!
//! ```no_run
//! # async fn demo() -> std::io::Result<()> {
//! use si_core::port::{self, PortOptions};
//! use si_core::SerialSettings;
//!
//! let line = SerialSettings::default(); // 9600 8E1, the modules' default
//! let port = port::open("/dev/ttyUSB0", &line, &PortOptions::default())?; // or "COM3"
//! println!("{:?}", port.info()); // USB vendor/product, the adapter's latency timer
//! # Ok(()) }
//! ```
//!
//! What the port tells the driver ([`Transport::attach`]) is then acted on without further
//! settings: the adapter's latency timer reaches the engine (`Engine::set_rx_latency`), line
//! errors arrive as [`LineError`](crate::LineError)s, the RS-485 transmitter is switched (RTS
//! either polarity or a sysfs file, [`TxEnable`]) and our own
//! echo is dropped when [`PortOptions`] asks for it.
//!
//! # Platforms
//!
//! Opening, the character format, modem signals, driver-side RS-485 switching (RTS or a
//! file) and echo suppression work wherever `tokio-serial` does (Linux, macOS, the BSDs,
//! Windows `COMn` names). **Linux only**, through the sysfs and termios of the Linux kernel:
//!
//! - line errors: the port is put in `PARMRK` mode ([`crate::linemark`] says what is marked
//!   and how). Elsewhere the port is opened as `tokio-serial` leaves it: a bad character
//!   arrives as a plain byte and no line error is reported. (macOS and the BSDs offer the same
//!   termios flags, untested here; Windows reports errors only per read through
//!   `ClearCommError`, not per character.)
//! - mark and space parity (`CMSPAR`); elsewhere [`open`] refuses them.
//! - the kernel's RS-485 mode ([`Rs485::Kernel`], `TIOCSRS485`), where the port's driver
//!   supports it;
//! - overruns: the kernel does not mark them in the stream; the port reads the UART driver's
//!   counters (`TIOCGICOUNT`, [`line_counters`]) after each read the driver makes, and a rise of
//!   `overrun` or `buf_overrun` reaches the engine as one [`LineError::Overrun`](crate::LineError)
//!   after that read's bytes ([`Transport::new_overruns`]). Each protocol reports it as its
//!   receive error: 3964(R), the ASCII driver and Modbus as 080CH "transmission error (parity,
//!   stop bit, overrun)" ([ET200S SI] §2.13, Table 2-28; [Modbus/USS] §3.6, which name overrun
//!   there, so no parity code stands in for it), the USS master in its overrun counter. A port
//!   whose driver keeps no counters (a pseudo-terminal) is read without them.
//! - the USB adapter's latency timer (`/sys/bus/usb-serial/devices/<tty>/latency_timer`):
//!   read on open, set with [`PortOptions::latency_timer`] or [`set_latency_timer`]. Elsewhere
//!   the latency is unknown to the driver (Windows sets it in the FTDI driver's port
//!   properties).

mod busy;
#[cfg(target_os = "linux")]
pub mod check;
mod device_server;
mod icount;
mod info;
#[cfg(target_os = "linux")]
mod linux;
#[cfg(target_os = "linux")]
pub mod loopback;
#[cfg(target_os = "linux")]
pub mod parity_check;
mod rs485;
mod stream;
mod tx_enable;

pub use device_server::{device_server, ConnectError, CONNECT_TIMEOUT, KEEPALIVE};
pub use icount::{line_counters, LineCounters};

pub use crate::sweep::settings as settings_sweep;
pub use info::{
    describe, latency_timer, list, set_latency_timer, PortInfo, UsbIds, LATENCY_TIMER_MS,
};
#[cfg(target_os = "linux")]
pub use linux::TermiosMode;
pub use rs485::{Rs485, Rs485Mode, Rs485ModeError};
pub use stream::SerialPort;
pub use tx_enable::{TxEnable, TxEnableOutput};

use crate::driver::{PortFacts, Transport};
use crate::linemark::bad_char_error;
use crate::serial::{Parity, SerialSettings};
use crate::time::Duration;
use std::io;

/// How to open a port beyond its character format.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PortOptions {
    /// Set the USB adapter's latency timer to this before use (Linux; 1–255 ms). 1 ms makes an
    /// FTDI-type adapter hand over received bytes almost at once, at the cost of more USB
    /// traffic. `None` leaves it as it is (and the driver allows for it).
    pub latency_timer: Option<Duration>,
    /// How late the port hands received bytes over, declared where nothing can be read from
    /// sysfs (a CH340 or CP210x adapter, a device server mapped to a pseudo-terminal): the
    /// engine is told it ([`crate::Engine::set_rx_latency`]); zero declares a port that
    /// delivers byte by byte. `None` uses the adapter's latency timer if sysfs has one, else
    /// leaves the port undeclared, which the engines treat as a default USB adapter until
    /// reads prove otherwise ([`crate::delivery`]).
    pub rx_latency: Option<Duration>,
    /// RS-485 direction control; `None` for RS-232/RS-422 or an adapter that switches by
    /// itself.
    pub rs485: Option<Rs485>,
    /// The port hears its own transmission (two-wire RS-485 with the receiver always on):
    /// drop the echo before the engine sees it, comparing byte by byte. Use it *instead of*
    /// the Modbus and USS configs' own `local_echo` (the module's parameter, which discards
    /// as many characters as were sent, matching or not), not together with it: the engine
    /// would then discard the partner's answer.
    pub local_echo: bool,
    /// Do not put the port in line-error marking mode (Linux): bad characters then arrive
    /// as plain bytes, as on other platforms.
    pub no_line_errors: bool,
}

/// Whether the port at `path` has the kernel's RS-485 mode ([`Rs485::Kernel`], Linux
/// `TIOCGRS485`): `Ok(true)` on, `Ok(false)` available and off. Opens a second handle for the
/// call and changes nothing. Errors: the port cannot be opened, or its driver has no RS-485
/// mode (kind `Unsupported`; a pseudo-terminal, most USB adapters), or not Linux.
pub fn kernel_rs485(path: &str) -> io::Result<bool> {
    #[cfg(target_os = "linux")]
    {
        let control = linux::Control::open(path)
            .map_err(|e| io::Error::new(e.kind(), format!("cannot open {path}: {e}")))?;
        control.rs485().map_err(|e| {
            let kind = match e.raw_os_error() {
                Some(libc::ENOTTY) | Some(libc::EINVAL) => io::ErrorKind::Unsupported,
                _ => e.kind(),
            };
            io::Error::new(kind, format!("{path}: no kernel RS-485 mode ({e})"))
        })
    }
    #[cfg(not(target_os = "linux"))]
    {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!("{path}: the kernel's RS-485 mode needs Linux"),
        ))
    }
}

/// The modem inputs of the port at `path` as `[CTS, DSR, DCD, RI]` (Linux `TIOCMGET`), read
/// through a second handle that changes no setting. Errors: the port cannot be opened, it has
/// no modem lines (a pseudo-terminal: kind `Unsupported`), or not Linux.
pub fn modem_inputs(path: &str) -> io::Result<[bool; 4]> {
    #[cfg(target_os = "linux")]
    {
        let control = linux::Control::open(path)
            .map_err(|e| io::Error::new(e.kind(), format!("cannot open {path}: {e}")))?;
        control.modem_inputs().map_err(|e| {
            let kind = match e.raw_os_error() {
                Some(libc::ENOTTY) | Some(libc::EINVAL) => io::ErrorKind::Unsupported,
                _ => e.kind(),
            };
            io::Error::new(kind, format!("{path}: no modem lines ({e})"))
        })
    }
    #[cfg(not(target_os = "linux"))]
    {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!("{path}: reading the modem lines without opening the port needs Linux"),
        ))
    }
}

/// Open `path` (`/dev/ttyUSB0`, `/dev/serial/by-id/…`, `COM3`) with the line format `settings`
/// and `options`. Call it inside a tokio runtime (the port registers with its reactor).
///
/// Errors: the port cannot be opened or configured, a parity this platform cannot set (mark
/// or space outside Linux), an option this platform or port does not support (kernel RS-485
/// mode, the latency timer), each with the path in the message.
pub fn open(
    path: &str,
    settings: &SerialSettings,
    options: &PortOptions,
) -> io::Result<SerialPort> {
    let context = |e: io::Error| io::Error::new(e.kind(), format!("{path}: {e}"));
    if let Some(ms) = options.latency_timer {
        set_latency_timer(path, ms)?;
    }
    let portable_parity = match settings.parity() {
        Parity::None => Some(tokio_serial::Parity::None),
        Parity::Even => Some(tokio_serial::Parity::Even),
        Parity::Odd => Some(tokio_serial::Parity::Odd),
        Parity::Mark | Parity::Space => None,
    };
    if portable_parity.is_none() && !cfg!(target_os = "linux") {
        return Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!(
                "{path}: parity {} needs Linux (CMSPAR); use none, even or odd",
                settings.parity()
            ),
        ));
    }
    let mut stream = open_stream(
        path,
        settings,
        portable_parity.unwrap_or(tokio_serial::Parity::None),
    )?;
    let tx_enable = match &options.rs485 {
        Some(Rs485::Driver { output, .. }) => {
            Some(receiving(&mut stream, output.clone()).map_err(context)?)
        }
        _ => None,
    };
    let info = describe(path);
    let facts = PortFacts {
        rx_latency: options.rx_latency.or(info.latency_timer),
        rts_toggle: match &options.rs485 {
            Some(Rs485::Driver { toggle, .. }) => Some(*toggle),
            _ => None,
        },
        local_echo: options.local_echo,
        wire: Some(*settings),
        // Marking is set up below, on Linux only (module docs, "Platforms").
        marked_errors: (cfg!(target_os = "linux") && !options.no_line_errors)
            .then(|| bad_char_error(settings)),
    };
    #[cfg(target_os = "linux")]
    let port = {
        let mut control = linux::Control::open(path).map_err(context)?;
        control
            .set_line(settings, facts.marked_errors.is_some())
            .map_err(context)?;
        if let Some(Rs485::Kernel {
            delay_before,
            delay_after,
        }) = &options.rs485
        {
            control
                .set_rs485(*delay_before, *delay_after)
                .map_err(context)?;
        }
        // Our second handle is open: from now on no other program may open the port.
        stream
            .set_exclusive(true)
            .map_err(|e| context(io::Error::from(e)))?;
        SerialPort::new(stream, info, facts, tx_enable, Some(control))
    };
    #[cfg(not(target_os = "linux"))]
    let port = {
        if matches!(options.rs485, Some(Rs485::Kernel { .. })) {
            return Err(context(io::Error::new(
                io::ErrorKind::Unsupported,
                "the kernel's RS-485 mode needs Linux; use driver-side RTS toggling",
            )));
        }
        SerialPort::new(stream, info, facts, tx_enable)
    };
    Ok(port)
}

/// The transmitter's enable output for driver-side direction control, opened and set to
/// receive: direction control starts receiving, and a port without modem lines (for the RTS
/// kinds) or a missing GPIO file says so here rather than stopping the driver at the first
/// transmission.
fn receiving(
    stream: &mut tokio_serial::SerialStream,
    output: TxEnable,
) -> io::Result<TxEnableOutput> {
    let mut enable = TxEnableOutput::open(output)?;
    enable
        .receive(stream)
        .map_err(|e| match enable.how().file() {
            Some(_) => e,
            None => io::Error::new(
                e.kind(),
                format!("cannot drive RTS for RS-485 ({e}): the port has no modem lines"),
            ),
        })?;
    Ok(enable)
}

/// The portable part: `tokio-serial` with the character format. On Linux shared (not
/// exclusive) while the second handle for termios is opened; exclusive again afterwards.
fn open_stream(
    path: &str,
    s: &SerialSettings,
    parity: tokio_serial::Parity,
) -> io::Result<tokio_serial::SerialStream> {
    use tokio_serial::{DataBits, FlowControl, SerialPortBuilderExt, StopBits};
    let builder = tokio_serial::new(path, s.baud())
        .data_bits(if s.data_bits() == 7 {
            DataBits::Seven
        } else {
            DataBits::Eight
        })
        .parity(parity)
        .stop_bits(if s.stop_bits() == 2 {
            StopBits::Two
        } else {
            StopBits::One
        })
        .flow_control(FlowControl::None);
    #[cfg(target_os = "linux")]
    let builder = builder.exclusive(false);
    builder.open_native_async().map_err(|e| {
        if busy::is_lock_failure(&e.description) {
            return busy::already_open(path);
        }
        io::Error::new(
            io::Error::from(e.clone()).kind(),
            format!("cannot open {path}: {e}"),
        )
    })
}

impl Transport for SerialPort {
    fn set_signals(&mut self, update: crate::SignalUpdate) -> io::Result<()> {
        SerialPort::set_signals(self, update)
    }

    fn read_signals(&mut self) -> io::Result<Option<crate::ModemSignals>> {
        self.stream_mut().read_signals()
    }

    fn attach(&mut self) -> PortFacts {
        SerialPort::attach(self)
    }

    fn new_overruns(&mut self) -> u64 {
        SerialPort::new_overruns(self)
    }
}
