//! The USB-serial adapter model: a station's received characters reach its engine in packets.
//!
//! An FTDI-type adapter (FT232R and relatives) collects what its UART receives and hands it to
//! the host in USB bulk packets of 64 bytes, 2 of them modem status, so **62 data bytes** at
//! most; it sends a packet when it holds that many, or when its **latency timer** (1–255 ms,
//! 16 ms by default) runs out with bytes pending.
//!
//! Which start the latency timer has is modelled as **`latency` after the first pending byte**.
//! The chip's timer really runs from the last USB hand-over, so a byte arriving on an idle
//! adapter waits somewhere between 0 and `latency`; counting from the first pending byte is
//! that worst case, every time, and keeps runs deterministic without a free-running clock
//! per adapter. Bytes keep arriving paced at the character time (the simulator's wire), so a
//! long frame reaches the engine as packets of about `latency / character time` bytes with
//! holes of up to `latency` between them, as on the real adapter.
//!
//! Line errors (parity, framing, overrun, BREAK) take a place in the packet like the character
//! they stand for (the chip reports them in the status bytes of the packet carrying that
//! character) and reach the engine in order with the bytes around them.

use si_core::Duration;
use si_core::LineError;

/// A USB-serial adapter in front of a station's receiver ([`Simulator::set_adapter`]).
///
/// [`Simulator::set_adapter`]: super::Simulator::set_adapter
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UsbAdapter {
    /// Data bytes per USB packet: 1–62 (an FTDI packet is 64 bytes, 2 of them status).
    pub packet_bytes: usize,
    /// The latency timer: 1–255 ms (FTDI; 16 ms by default).
    pub latency: Duration,
    /// Whether the host tells the engine the latency ([`Engine::set_rx_latency`]), as the tokio
    /// driver does from sysfs on Linux. `false` models a host that cannot know it (Windows, a
    /// TCP serial device server): the engine must learn it from the packets.
    ///
    /// [`Engine::set_rx_latency`]: si_core::Engine::set_rx_latency
    pub announce_latency: bool,
}

impl UsbAdapter {
    /// The most data bytes an FTDI USB packet carries.
    pub const MAX_PACKET_BYTES: usize = 62;
    /// The latency timer's range in milliseconds (FTDI).
    pub const LATENCY_MS: core::ops::RangeInclusive<u64> = 1..=255;

    /// An FTDI adapter as it comes out of the box: 62-byte packets, a 16 ms latency timer,
    /// announced to the engine.
    pub const FTDI_DEFAULT: UsbAdapter = UsbAdapter {
        packet_bytes: 62,
        latency: Duration::from_millis(16),
        announce_latency: true,
    };

    /// The same adapter on a host that does not announce its latency.
    pub const fn unannounced(self) -> Self {
        UsbAdapter {
            announce_latency: false,
            ..self
        }
    }

    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), AdapterError> {
        if !(1..=Self::MAX_PACKET_BYTES).contains(&self.packet_bytes) {
            return Err(AdapterError {
                parameter: "packet_bytes",
                range: "1..=62",
                value: self.packet_bytes.to_string(),
            });
        }
        let us = self.latency.as_micros();
        if !us.is_multiple_of(1000) || !Self::LATENCY_MS.contains(&(us / 1000)) {
            return Err(AdapterError {
                parameter: "latency",
                range: "1..=255 ms (whole milliseconds)",
                value: self.latency.to_string(),
            });
        }
        Ok(())
    }
}

impl Default for UsbAdapter {
    fn default() -> Self {
        Self::FTDI_DEFAULT
    }
}

/// An adapter parameter out of range: names the parameter, the range and the value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("USB adapter {parameter} = {value} is out of range {range}")]
pub struct AdapterError {
    /// The parameter.
    pub parameter: &'static str,
    /// The allowed range.
    pub range: &'static str,
    /// The value given.
    pub value: String,
}

/// An adapter's state: what it holds and which flush is armed.
#[derive(Debug)]
pub(super) struct Held {
    pub config: UsbAdapter,
    /// Characters (or the errors standing for them) not yet handed over, in order.
    pub pending: Vec<Result<u8, LineError>>,
    /// Bumped at every hand-over, so a latency flush armed before it is a no-op.
    pub generation: u64,
    /// A run of bytes being handed over (reused, no allocation per packet).
    pub scratch: Vec<u8>,
}

impl Held {
    pub fn new(config: UsbAdapter) -> Self {
        Held {
            config,
            pending: Vec::with_capacity(config.packet_bytes),
            generation: 0,
            scratch: Vec::with_capacity(config.packet_bytes),
        }
    }
}

/// Hands a packet to the engine: each run of bytes in one call, each error between them on its
/// own, in order.
pub(super) fn runs(
    packet: &[Result<u8, LineError>],
    mut each: impl FnMut(Result<&[u8], LineError>),
    scratch: &mut Vec<u8>,
) {
    scratch.clear();
    for item in packet {
        match item {
            Ok(b) => scratch.push(*b),
            Err(e) => {
                if !scratch.is_empty() {
                    each(Ok(scratch));
                    scratch.clear();
                }
                each(Err(*e));
            }
        }
    }
    if !scratch.is_empty() {
        each(Ok(scratch));
    }
}
