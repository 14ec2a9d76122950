//! [`SerialPort`]: the opened port, a `tokio-serial` stream plus what the driver must know.

use super::PortInfo;
use crate::driver::PortFacts;
use crate::linemark::{MarkDecoder, Marked};
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// A serial port opened by [`open`](super::open): read and write it, or hand it to a
/// protocol's async handle (it is a [`Transport`](crate::driver::Transport)).
pub struct SerialPort {
    stream: tokio_serial::SerialStream,
    info: PortInfo,
    facts: PortFacts,
    /// Plain readers get clean bytes: a marked stream is decoded here and its line errors
    /// dropped (as every portable serial API drops them) until a driver attaches and takes
    /// the marked stream itself.
    clean: Option<MarkDecoder>,
    /// The transmitter's enable output when the driver switches RS-485 direction: the RTS
    /// updates it makes are mapped there ([`super::TxEnableOutput`]).
    tx_enable: Option<super::TxEnableOutput>,
    /// A second handle on the same tty for what `tokio-serial` does not offer (termios
    /// flags, RS-485 mode).
    #[cfg(target_os = "linux")]
    control: Option<super::linux::Control>,
    /// Characters lost so far by the kernel's count (`overrun` + `buf_overrun`), from the
    /// driver's attach on; `None` while no driver is attached or the port keeps no counters.
    lost: Option<u64>,
}

impl std::fmt::Debug for SerialPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialPort")
            .field("info", &self.info)
            .field("facts", &self.facts)
            .finish_non_exhaustive()
    }
}

impl Drop for SerialPort {
    /// A port closed while its transmitter is on would hold the RS-485 bus for every other
    /// station: leave it receiving (the driver's "off `after` tx-done" may not have come when a
    /// command ends on the answer, or the task is cancelled). Nothing to report an error to
    /// here; the port is going away.
    fn drop(&mut self) {
        if let Some(enable) = &mut self.tx_enable {
            let _ = enable.release(&mut self.stream);
        }
    }
}

impl SerialPort {
    #[cfg(target_os = "linux")]
    pub(super) fn new(
        stream: tokio_serial::SerialStream,
        info: PortInfo,
        facts: PortFacts,
        tx_enable: Option<super::TxEnableOutput>,
        control: Option<super::linux::Control>,
    ) -> Self {
        SerialPort {
            stream,
            info,
            clean: facts.marked_errors.map(MarkDecoder::new),
            facts,
            tx_enable,
            control,
            lost: None,
        }
    }

    #[cfg(not(target_os = "linux"))]
    pub(super) fn new(
        stream: tokio_serial::SerialStream,
        info: PortInfo,
        facts: PortFacts,
        tx_enable: Option<super::TxEnableOutput>,
    ) -> Self {
        SerialPort {
            stream,
            info,
            clean: facts.marked_errors.map(MarkDecoder::new),
            facts,
            tx_enable,
            lost: None,
        }
    }

    /// The port's path, USB identity and the adapter's latency timer when it was opened.
    pub fn info(&self) -> &PortInfo {
        &self.info
    }

    /// What the driver does for this port: the adapter latency it passes to the engine,
    /// whether line errors are decoded, RS-485 RTS toggling, echo suppression.
    pub fn port_facts(&self) -> &PortFacts {
        &self.facts
    }

    /// A driver takes over (`Transport::attach`): reads return the marked stream from now on.
    pub(super) fn attach(&mut self) -> PortFacts {
        self.clean = None;
        self.lost = self.line_counters().ok().map(|c| c.lost());
        self.facts
    }

    /// The UART driver's line-error counters now (Linux `TIOCGICOUNT`; they count since the
    /// driver loaded, not since this port was opened). Kind `Unsupported` where the port keeps
    /// none (a pseudo-terminal) or not on Linux.
    pub fn line_counters(&self) -> io::Result<super::LineCounters> {
        #[cfg(target_os = "linux")]
        if let Some(control) = &self.control {
            return control.counters();
        }
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "no line-error counters for this port",
        ))
    }

    /// How many characters the kernel counted as lost (overrun in the UART or the kernel's
    /// buffer) since the last call, from the driver's attach on; 0 where the port keeps no
    /// counters. A failing read of the counters counts nothing: the bytes go on.
    pub(super) fn new_overruns(&mut self) -> u64 {
        let Some(seen) = self.lost else {
            return 0;
        };
        let Ok(now) = self.line_counters().map(|c| c.lost()) else {
            return 0;
        };
        self.lost = Some(now);
        // The kernel's counters only grow (modulo their wrap, which `lost` sums without).
        now.saturating_sub(seen)
    }

    /// Set RTS/DTR; with driver-side RS-485 direction control, RTS is the direction and goes
    /// to the transmitter's enable output at its polarity.
    pub(super) fn set_signals(&mut self, update: crate::SignalUpdate) -> io::Result<()> {
        use crate::driver::Transport as _;
        match &mut self.tx_enable {
            Some(enable) => enable.set_signals(&mut self.stream, update),
            None => self.stream.set_signals(update),
        }
    }

    /// The underlying `tokio-serial` stream (modem lines, buffers, exclusivity).
    pub fn stream_mut(&mut self) -> &mut tokio_serial::SerialStream {
        &mut self.stream
    }

    /// The flags the kernel holds for this port now, read back with `TCGETS2` (Linux): how a
    /// test or a doubtful user sees that line-error marking and the parity are set.
    #[cfg(target_os = "linux")]
    pub fn termios_mode(&self) -> io::Result<super::TermiosMode> {
        match &self.control {
            Some(control) => control.termios_mode(),
            None => Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "no control handle",
            )),
        }
    }
}

impl AsyncRead for SerialPort {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        loop {
            let before = buf.filled().len();
            std::task::ready!(Pin::new(&mut this.stream).poll_read(cx, buf))?;
            let Some(decoder) = &mut this.clean else {
                return Poll::Ready(Ok(()));
            };
            if buf.filled().len() == before {
                return Poll::Ready(Ok(())); // end of file
            }
            // Decoding never lengthens the stream, so the decoded bytes fit where the marked
            // ones were.
            let marked = buf.filled()[before..].to_vec();
            buf.set_filled(before);
            decoder.feed(&marked, |piece| {
                if let Marked::Data(run) = piece {
                    buf.put_slice(run);
                }
            });
            if buf.filled().len() > before {
                return Poll::Ready(Ok(()));
            }
            // Only marks: read on (the port registers the waker when nothing more is there).
        }
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
