//! What a port needs from the driver that runs an engine over it, beside the bytes.
//!
//! A transport describes its port once ([`PortFacts`]); the tokio driver acts on it so that the
//! engine sees a clean line: it tells the engine the port's delivery latency
//! ([`Engine::set_rx_latency`](crate::Engine::set_rx_latency)), decodes a `PARMRK`-marked
//! stream into line errors ([`crate::linemark`]), switches an RS-485 transmitter with RTS
//! around each transmission ([`RtsToggle`]) and drops the port's own echo
//! ([`crate::echo`]). These are plain data, so a test or another driver can use them too.

use crate::sansio::LineError;
use crate::serial::SerialSettings;
use crate::time::Duration;

/// Facts about a port that change how a driver must treat it (module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PortFacts {
    /// The port hands received bytes over up to this late, in packets (a USB adapter's latency
    /// timer). The driver passes it to the engine before the first byte.
    pub rx_latency: Option<Duration>,
    /// The received stream is `PARMRK`-marked; a marked bad character is reported as this
    /// error ([`crate::linemark::bad_char_error`]). `None`: plain bytes.
    pub marked_errors: Option<LineError>,
    /// The driver raises RTS before each transmission and drops it after (RS-485 direction
    /// control for adapters without automatic switching).
    pub rts_toggle: Option<RtsToggle>,
    /// The port hears its own transmission: drop the echo ([`crate::echo::EchoFilter`]).
    pub local_echo: bool,
    /// The line's character format, as the port was opened with it. The driver times RS-485
    /// direction control and the echo window to the last byte's end on the wire from it, even
    /// for an engine whose tx-done is reported when the write returns (a write to a serial port
    /// returns once the kernel holds the bytes, long before they have left at low baud rates).
    pub wire: Option<SerialSettings>,
}

/// RS-485 direction control by the driver: RTS on, wait `before`, write, and RTS off `after`
/// the last byte has left the transmitter (tx-done, which the driver computes from the
/// character time).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RtsToggle {
    /// Wait after RTS on before the first byte (the transceiver's enable time).
    pub before: Duration,
    /// Keep RTS on this long after tx-done (so the last stop bit is not cut off by a slow
    /// UART FIFO report).
    pub after: Duration,
}

impl PortFacts {
    /// These facts, with `other`'s where these have none (local echo where either asks).
    pub fn or(self, other: PortFacts) -> PortFacts {
        PortFacts {
            rx_latency: self.rx_latency.or(other.rx_latency),
            marked_errors: self.marked_errors.or(other.marked_errors),
            rts_toggle: self.rts_toggle.or(other.rts_toggle),
            local_echo: self.local_echo || other.local_echo,
            wire: self.wire.or(other.wire),
        }
    }
}
