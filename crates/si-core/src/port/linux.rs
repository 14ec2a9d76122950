//! What Linux offers beyond the portable serial API: termios input flags for line-error
//! marking, mark/space parity, the kernel's RS-485 mode. Through `serial2`'s safe calls on a
//! second handle of the same tty (termios and RS-485 mode belong to the device, not the
//! handle).

use super::icount::{self, LineCounters};
use crate::serial::{Parity, SerialSettings};
use crate::time::Duration;
use std::io;

/// The second handle.
pub(super) struct Control(serial2::SerialPort);

impl Control {
    pub(super) fn open(path: &str) -> io::Result<Self> {
        serial2::SerialPort::open(path, serial2::KeepSettings).map(Control)
    }

    /// Mark/space parity, and line-error marking if `mark_errors` (linemark.rs says which
    /// flags and why): `PARMRK`, `INPCK` where a parity bit is checked, and nothing that drops
    /// or strips a bad character or turns a BREAK into a signal.
    pub(super) fn set_line(&mut self, s: &SerialSettings, mark_errors: bool) -> io::Result<()> {
        let mut settings = self.0.get_configuration()?;
        let termios = settings.as_termios_mut();
        match s.parity() {
            Parity::Mark => termios.c_cflag |= libc::PARENB | libc::CMSPAR | libc::PARODD,
            Parity::Space => {
                termios.c_cflag |= libc::PARENB | libc::CMSPAR;
                termios.c_cflag &= !libc::PARODD;
            }
            _ => {}
        }
        if mark_errors {
            termios.c_iflag |= libc::PARMRK;
            termios.c_iflag &= !(libc::IGNPAR | libc::IGNBRK | libc::BRKINT | libc::ISTRIP);
            // INPCK also gates framing errors in the line discipline: on for every line
            // whose parity is checked, and on a line without parity (nothing to check, so
            // only framing errors are marked). Off for the manuals' "any" (space) parity,
            // which is not checked on receive (serial.rs).
            if s.parity() == Parity::Space {
                termios.c_iflag &= !libc::INPCK;
            } else {
                termios.c_iflag |= libc::INPCK;
            }
        }
        self.0.set_configuration(&settings).map_err(|e| {
            if matches!(s.parity(), Parity::Mark | Parity::Space) {
                // serial2 reads the settings back: a port whose driver drops CMSPAR (a
                // pseudo-terminal) fails here.
                io::Error::new(
                    e.kind(),
                    format!("the port does not take {} parity (CMSPAR): {e}", s.parity()),
                )
            } else {
                e
            }
        })
    }

    /// The kernel's RS-485 mode with RTS on while sending.
    pub(super) fn set_rs485(&self, before: Duration, after: Duration) -> io::Result<()> {
        let mut config = serial2::rs4xx::Rs485Config::new();
        config.set_delay_before_send(before.into());
        config.set_delay_after_send(after.into());
        self.0.set_rs4xx_mode(config).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!(
                    "cannot switch to the kernel's RS-485 mode ({e}): the port's driver has none; \
                     let this program toggle RTS instead"
                ),
            )
        })
    }

    /// Whether the port's driver has the kernel's RS-485 mode (`TIOCGRS485` answers) and
    /// whether it is on.
    pub(super) fn rs485(&self) -> io::Result<bool> {
        self.0
            .get_rs4xx_mode()
            .map(|mode| matches!(mode, serial2::rs4xx::TransceiverMode::Rs485(_)))
    }

    /// The modem inputs (`TIOCMGET`): CTS, DSR, DCD, RI.
    pub(super) fn modem_inputs(&self) -> io::Result<[bool; 4]> {
        Ok([
            self.0.read_cts()?,
            self.0.read_dsr()?,
            self.0.read_cd()?,
            self.0.read_ri()?,
        ])
    }

    /// The UART driver's line-error counters (`TIOCGICOUNT`).
    pub(super) fn counters(&self) -> io::Result<LineCounters> {
        use std::os::fd::AsFd;
        icount::read(self.0.as_fd())
    }

    pub(super) fn termios_mode(&self) -> io::Result<TermiosMode> {
        let settings = self.0.get_configuration()?;
        let termios = settings.as_termios();
        let on = |flag| termios.c_iflag & flag != 0;
        let control = |flag| termios.c_cflag & flag != 0;
        Ok(TermiosMode {
            parmrk: on(libc::PARMRK),
            inpck: on(libc::INPCK),
            ignpar: on(libc::IGNPAR),
            brkint: on(libc::BRKINT),
            ignbrk: on(libc::IGNBRK),
            istrip: on(libc::ISTRIP),
            parenb: control(libc::PARENB),
            parodd: control(libc::PARODD),
            cmspar: control(libc::CMSPAR),
        })
    }
}

/// The termios flags that decide how line errors reach a reader and which parity the line
/// has (termios(3)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TermiosMode {
    /// `PARMRK`: bad characters and BREAKs are marked in the stream.
    pub parmrk: bool,
    /// `INPCK`: received parity is checked.
    pub inpck: bool,
    /// `IGNPAR`: bad characters are dropped silently.
    pub ignpar: bool,
    /// `BRKINT`: a BREAK flushes the queues and signals the process.
    pub brkint: bool,
    /// `IGNBRK`: BREAKs are dropped silently.
    pub ignbrk: bool,
    /// `ISTRIP`: the eighth bit is cleared.
    pub istrip: bool,
    /// `PARENB`: a parity bit is sent and received.
    pub parenb: bool,
    /// `PARODD`: odd parity (with `CMSPAR`: mark).
    pub parodd: bool,
    /// `CMSPAR`: the parity bit is fixed, mark or space.
    pub cmspar: bool,
}
