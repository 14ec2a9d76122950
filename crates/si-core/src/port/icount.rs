//! The kernel's line-error counters of a serial port (Linux `TIOCGICOUNT`), the only place an
//! overrun shows: the terminal driver does not mark it in the `PARMRK` stream
//! ([`crate::linemark`]).
//!
//! No crate in the tree wraps this ioctl (serial2, rustix and nix checked), so this module is
//! the one place of the workspace that allows `unsafe` (the workspace denies it; the root test
//! `tests/unsafe_code.rs` keeps it to this file). The one unsafe call is below with its
//! `SAFETY` reasoning.
#![allow(unsafe_code)]

use std::io;
#[cfg(target_os = "linux")]
use std::os::fd::{AsRawFd, BorrowedFd};

/// The counters a UART driver keeps since the port's driver loaded (they survive closing
/// and reopening the port; a pseudo-terminal keeps none).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LineCounters {
    /// Characters received.
    pub rx: u32,
    /// Characters sent.
    pub tx: u32,
    /// Characters received with a wrong stop bit.
    pub frame: u32,
    /// Characters lost because the UART's receive FIFO was full (the host read too late).
    pub overrun: u32,
    /// Characters received with a wrong parity bit.
    pub parity: u32,
    /// BREAK conditions seen.
    pub brk: u32,
    /// Characters lost because the kernel's receive buffer was full (the program read too
    /// late).
    pub buf_overrun: u32,
}

impl LineCounters {
    /// Characters lost either way: in the UART (`overrun`) or in the kernel's buffer
    /// (`buf_overrun`).
    pub fn lost(&self) -> u64 {
        u64::from(self.overrun) + u64::from(self.buf_overrun)
    }
}

#[cfg(target_os = "linux")]
/// `struct serial_icounter_struct` of `<linux/serial.h>`: twenty `int`s, the last nine
/// reserved.
#[repr(C)]
#[derive(Default)]
struct SerialIcounter {
    cts: libc::c_int,
    dsr: libc::c_int,
    rng: libc::c_int,
    dcd: libc::c_int,
    rx: libc::c_int,
    tx: libc::c_int,
    frame: libc::c_int,
    overrun: libc::c_int,
    parity: libc::c_int,
    brk: libc::c_int,
    buf_overrun: libc::c_int,
    reserved: [libc::c_int; 9],
}

#[cfg(target_os = "linux")]
/// Read the counters of the tty open at `fd`. A port whose driver keeps none (a
/// pseudo-terminal answers `EINVAL`, other files `ENOTTY`) gives an error of kind
/// [`io::ErrorKind::Unsupported`].
pub(super) fn read(fd: BorrowedFd<'_>) -> io::Result<LineCounters> {
    let mut counters = SerialIcounter::default();
    // SAFETY: `fd` is a borrowed, therefore open, file descriptor for the whole call.
    // TIOCGICOUNT writes exactly one `struct serial_icounter_struct` to the pointer it is
    // given (drivers/tty/tty_io.c, `tty_tiocgicount`: `copy_to_user(arg, &icount,
    // sizeof(icount))`), and `counters` is a live, exclusively borrowed value of that layout
    // (`repr(C)`, the same twenty `int`s). The ioctl keeps no pointer past its return.
    let result = unsafe {
        libc::ioctl(
            fd.as_raw_fd(),
            libc::TIOCGICOUNT,
            &mut counters as *mut SerialIcounter,
        )
    };
    if result < 0 {
        let e = io::Error::last_os_error();
        return Err(match e.raw_os_error() {
            Some(libc::EINVAL) | Some(libc::ENOTTY) => io::Error::new(
                io::ErrorKind::Unsupported,
                format!("the port's driver keeps no line-error counters (TIOCGICOUNT: {e})"),
            ),
            _ => e,
        });
    }
    // The kernel counts in `int`; a counter that wrapped past i32::MAX reads on modulo 2^32.
    let count = |v: libc::c_int| v as u32;
    Ok(LineCounters {
        rx: count(counters.rx),
        tx: count(counters.tx),
        frame: count(counters.frame),
        overrun: count(counters.overrun),
        parity: count(counters.parity),
        brk: count(counters.brk),
        buf_overrun: count(counters.buf_overrun),
    })
}

/// The line-error counters of the port at `path` (Linux): opened for this read only, without
/// becoming its controlling terminal and without waiting for a carrier, and closed again.
///
/// Errors: the port cannot be opened (the message names the path), its driver keeps no
/// counters (kind [`io::ErrorKind::Unsupported`]: a pseudo-terminal, a USB adapter whose
/// driver does not count), or not Linux (also `Unsupported`).
pub fn line_counters(path: &str) -> io::Result<LineCounters> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsFd;
        use std::os::unix::fs::OpenOptionsExt;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
            .open(path)
            .map_err(|e| io::Error::new(e.kind(), format!("cannot open {path}: {e}")))?;
        read(file.as_fd()).map_err(|e| io::Error::new(e.kind(), format!("{path}: {e}")))
    }
    #[cfg(not(target_os = "linux"))]
    {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!("{path}: line-error counters need Linux (TIOCGICOUNT)"),
        ))
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn a_file_that_is_no_tty_has_no_counters_and_says_so() {
        let e = line_counters("/dev/null").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::Unsupported, "{e}");
        assert!(e.to_string().contains("/dev/null"), "{e}");
    }

    #[test]
    fn a_missing_port_is_named() {
        let e = line_counters("/dev/si-no-such-port").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::NotFound, "{e}");
        assert!(e.to_string().contains("/dev/si-no-such-port"), "{e}");
    }

    #[test]
    fn lost_adds_both_overrun_counters() {
        let c = LineCounters {
            overrun: u32::MAX,
            buf_overrun: 2,
            ..LineCounters::default()
        };
        assert_eq!(c.lost(), u64::from(u32::MAX) + 2);
    }
}
