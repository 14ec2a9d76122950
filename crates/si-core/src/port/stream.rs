//! [`SerialPort`]: the opened port, a `tokio-serial` stream plus what the driver must know.

use crate::driver::PortFacts;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// A serial port opened by [`open`](super::open): read and write it, or hand it to a
/// protocol's async handle (it is a [`Transport`](crate::driver::Transport)).
pub struct SerialPort {
    stream: tokio_serial::SerialStream,
    facts: PortFacts,
    /// A second handle on the same tty for what `tokio-serial` does not offer (termios
    /// flags, RS-485 mode).
    #[cfg(target_os = "linux")]
    control: Option<super::linux::Control>,
}

impl std::fmt::Debug for SerialPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialPort")
            .field("facts", &self.facts)
            .finish_non_exhaustive()
    }
}

impl SerialPort {
    #[cfg(target_os = "linux")]
    pub(super) fn new(
        stream: tokio_serial::SerialStream,
        facts: PortFacts,
        control: Option<super::linux::Control>,
    ) -> Self {
        SerialPort {
            stream,
            facts,
            control,
        }
    }

    #[cfg(not(target_os = "linux"))]
    pub(super) fn new(stream: tokio_serial::SerialStream, facts: PortFacts) -> Self {
        SerialPort { stream, facts }
    }

    /// What the driver does for this port: the adapter latency it passes to the engine,
    /// whether line errors are decoded, RS-485 RTS toggling, echo suppression.
    pub fn port_facts(&self) -> &PortFacts {
        &self.facts
    }

    /// The underlying `tokio-serial` stream (modem lines, buffers, exclusivity).
    pub fn stream_mut(&mut self) -> &mut tokio_serial::SerialStream {
        &mut self.stream
    }

    /// The input flags the kernel holds for this port now, read back with `TCGETS2` (Linux):
    /// how a test or a doubtful user sees that line-error marking is on.
    #[cfg(target_os = "linux")]
    pub fn input_mode(&self) -> io::Result<InputMode> {
        match &self.control {
            Some(control) => control.input_mode(),
            None => Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "no control handle",
            )),
        }
    }
}

/// The termios input flags that decide how line errors reach a reader (termios(3)).
#[cfg(target_os = "linux")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputMode {
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
}

impl AsyncRead for SerialPort {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_read(cx, buf)
    }
}

impl AsyncWrite for SerialPort {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write(cx, buf)
    }
    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }
    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }
}
