//! How late the port hands received bytes over, and how much slack the silence-judging timers
//! therefore need.
//!
//! A UART that delivers every character the moment its stop bit ends lets a receiver time the
//! silence between characters exactly, and the manuals' timers (Modbus end-of-frame gap
//! tZVZ, the ASCII character delay time, the USS residual run time, response-start timeouts)
//! assume it. Most hosts do not have such a UART. A USB-serial adapter (FTDI FT232R and
//! relatives) collects received characters and hands them to the host in USB packets: when it
//! holds 62 data bytes, or when its *latency timer* (1–255 ms, 16 ms by default) runs out with
//! bytes pending. A serial device server does the same with its packing delay. Seen from the
//! engine, a long frame arrives as bursts with holes of up to the latency between them, and a
//! timer that takes a 16 ms hole for silence ends the frame in the middle.
//!
//! [`Delivery`] is the one place that knows this, shared by every engine (not one copy per
//! protocol). It keeps
//!
//! - the character time of the line;
//! - the latency the driver **declared** ([`Engine::set_rx_latency`](crate::Engine::set_rx_latency):
//!   the tokio driver reads it from the adapter on Linux, the simulator's adapter model knows its
//!   own);
//! - what it **learns** from reads ([`observe`](Delivery::observe)): a read of `n` bytes at once
//!   proves the port held its first byte for at least `n − 1` character times, because the wire
//!   cannot carry them faster (counted up to one adapter packet, [`PACKET_BYTES`]: a longer
//!   read is several packets, or a port with no wire at all). The lower bound only grows
//!   (monotonic learning).
//!
//! From these it gives each silence-judging timer its [`allowance`](Delivery::allowance): zero
//! on a port that has delivered every byte on its own and declared no latency, so the manual's
//! timing is kept exactly there; otherwise the port's latency (declared, or learnt as the hold
//! plus one character time, the most the last byte of a full packet can have waited) plus one
//! character time, never more than [`MAX_LATENCY`] plus one character time.
//!
//! What learning cannot know: before the first read of two or more bytes, a port without a
//! declared latency looks exactly like a byte-by-byte line (a first packet of one byte is
//! indistinguishable from a single character). A frame longer than one packet that arrives
//! before anything was learnt can still be cut at its first hole; the next one is not.
//! Declaring the latency (or setting the adapter's latency timer to 1 ms) removes that case.

use crate::serial::SerialSettings;
use crate::status::Status;
use crate::time::Duration;

/// The remedy a framing error gets when bytes reached the host faster than the wire can carry
/// them ([`Delivery::annotate`]), instead of the manual's "check the partner".
pub const ADAPTER_REMEDY: &str = "bytes reached this host faster than the line can carry them, \
so a USB-serial adapter or device server hands them over in packets, late: lower the adapter's \
latency timer (`si --latency-timer 1`, or write 1 to \
/sys/bus/usb-serial/devices/<tty>/latency_timer), or tell the engine the port's latency \
(Engine::set_rx_latency)";

/// The most data bytes one USB packet of an FTDI-type adapter carries (64 bytes less 2 of modem
/// status). A read of more bytes holds several packets (or comes from a port with no wire at
/// all, a pseudo-terminal or a pipe) and proves no longer a hold than one full packet does.
pub const PACKET_BYTES: usize = 62;

/// The largest latency timer of a USB-serial adapter (FTDI: 1–255 ms). Declared latencies are
/// clamped to it, learnt ones never exceed it.
pub const MAX_LATENCY: Duration = Duration::from_millis(255);

/// The port's delivery latency, declared and learnt, and the allowance it gives silence timers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Delivery {
    char_time: Duration,
    declared: Duration,
    /// The longest hold a read has proven: (n − 1) character times for a read of n bytes.
    held: Duration,
}

impl Delivery {
    /// A port on a line with this character format, delivering byte by byte until told or shown
    /// otherwise.
    pub fn new(settings: &SerialSettings) -> Self {
        Self::with_char_time(settings.char_time())
    }

    /// The same from a character time.
    pub const fn with_char_time(char_time: Duration) -> Self {
        Delivery {
            char_time,
            declared: Duration::ZERO,
            held: Duration::ZERO,
        }
    }

    /// The driver says the port hands bytes over up to `latency` late (clamped to
    /// [`MAX_LATENCY`]); zero withdraws the declaration (what was learnt stays).
    pub fn declare(&mut self, latency: Duration) {
        self.declared = min(latency, MAX_LATENCY);
    }

    /// The latency the driver declared.
    pub fn declared(&self) -> Duration {
        self.declared
    }

    /// One read of `n` bytes handed over at once. Two or more prove the port packetises; the
    /// hold learnt counts at most one packet ([`PACKET_BYTES`]).
    pub fn observe(&mut self, n: usize) {
        if n >= 2 {
            let n = n.min(PACKET_BYTES) as u64;
            let held = min(self.char_time.saturating_mul(n - 1), MAX_LATENCY);
            self.held = max(self.held, held);
        }
    }

    /// The longest hold reads have proven so far (never decreases).
    pub fn learnt(&self) -> Duration {
        self.held
    }

    /// True once the port is known to hand bytes over in packets: a latency was declared, or a
    /// read brought two or more bytes at once.
    pub fn packetises(&self) -> bool {
        self.declared > Duration::ZERO || self.held > Duration::ZERO
    }

    /// The best estimate of how late a byte can reach the engine: the declared latency, or the
    /// learnt hold plus one character time, whichever is larger; at most [`MAX_LATENCY`].
    pub fn latency(&self) -> Duration {
        let learnt = if self.held > Duration::ZERO {
            self.held + self.char_time
        } else {
            Duration::ZERO
        };
        min(max(self.declared, learnt), MAX_LATENCY)
    }

    /// The allowance while a frame's own length says more bytes are coming (a Modbus frame
    /// whose header predicts its length, a USS telegram after LGE): on a packetising port the
    /// longest hold any port has, [`MAX_LATENCY`] plus one character time, because a learnt
    /// latency is only a lower bound and the host's scheduling adds to it; zero on a port that
    /// delivers byte by byte. Costs nothing on a good frame, which ends by its length.
    pub fn patience(&self) -> Duration {
        if self.packetises() {
            MAX_LATENCY + self.char_time
        } else {
            Duration::ZERO
        }
    }

    /// `status` as the engine reports a framing failure (a frame cut short, a CRC or length
    /// error, a character delay exceeded): with [`ADAPTER_REMEDY`] once reads have shown bytes
    /// arriving faster than the wire could carry them, unchanged otherwise. The STATUS code
    /// stays the manual's.
    pub fn annotate(&self, status: Status) -> Status {
        if self.held > Duration::ZERO {
            status.with_remedy(ADAPTER_REMEDY)
        } else {
            status
        }
    }

    /// What a timer that judges silence on the line adds to the manual's time: zero on a port
    /// that delivers byte by byte, else [`latency`](Self::latency) plus one character time (a
    /// byte can reach the adapter just after a hand-over and wait a whole latency after that).
    pub fn allowance(&self) -> Duration {
        if self.packetises() {
            self.latency() + self.char_time
        } else {
            Duration::ZERO
        }
    }
}

const fn min(a: Duration, b: Duration) -> Duration {
    if a.as_micros() <= b.as_micros() {
        a
    } else {
        b
    }
}

const fn max(a: Duration, b: Duration) -> Duration {
    if a.as_micros() >= b.as_micros() {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ct() -> Duration {
        SerialSettings::default().char_time()
    }

    #[test]
    fn a_byte_by_byte_port_gets_no_allowance() {
        let mut d = Delivery::new(&SerialSettings::default());
        for _ in 0..100 {
            d.observe(1);
        }
        assert!(!d.packetises());
        assert_eq!(d.allowance(), Duration::ZERO);
    }

    #[test]
    fn a_read_longer_than_a_packet_teaches_one_packets_hold() {
        let mut d = Delivery::new(&SerialSettings::default());
        d.observe(200);
        assert_eq!(d.learnt(), ct().saturating_mul(61));
    }

    #[test]
    fn a_declared_latency_gives_it_plus_a_character_time() {
        let mut d = Delivery::new(&SerialSettings::default());
        d.declare(Duration::from_millis(16));
        assert!(d.packetises());
        assert_eq!(d.allowance(), Duration::from_millis(16) + ct());
        d.declare(Duration::from_secs(1));
        assert_eq!(d.declared(), MAX_LATENCY);
    }

    #[test]
    fn a_read_of_fourteen_bytes_teaches_thirteen_character_times_held() {
        // 9600 8E1: a 16 ms FTDI packet holds 14 characters of 1.146 ms.
        let mut d = Delivery::new(&SerialSettings::default());
        d.observe(14);
        assert_eq!(d.learnt(), ct().saturating_mul(13));
        assert_eq!(d.allowance(), ct().saturating_mul(15));
        assert!(d.allowance() >= Duration::from_millis(16) + Duration::from_micros(1));
    }

    #[test]
    fn framing_errors_name_the_adapter_once_bytes_came_too_fast() {
        let status = crate::status::common::INVALID_LEN;
        let mut d = Delivery::new(&SerialSettings::default());
        assert_eq!(d.annotate(status).remedy(), status.remedy());
        d.observe(2);
        let annotated = d.annotate(status);
        assert_eq!(annotated, status);
        let remedy = annotated.remedy().unwrap();
        assert!(remedy.contains("latency timer") && remedy.contains("--latency-timer 1"));
        assert!(remedy.contains("set_rx_latency"));
    }

    proptest! {
        #[test]
        fn allowance_is_bounded_and_learning_monotonic(
            baud in prop::sample::select(crate::serial::BAUD_RATES.to_vec()),
            reads in prop::collection::vec(0usize..2000, 0..40),
            declared in prop::option::of(0u64..10_000_000),
        ) {
            let settings = SerialSettings::new(baud, 8, crate::Parity::Even, 1).unwrap();
            let mut d = Delivery::new(&settings);
            if let Some(us) = declared {
                d.declare(Duration::from_micros(us));
            }
            let mut before = (d.learnt(), d.allowance());
            for n in reads {
                d.observe(n);
                let now = (d.learnt(), d.allowance());
                prop_assert!(now.0 >= before.0);
                prop_assert!(now.1 >= before.1);
                prop_assert!(now.1 <= MAX_LATENCY + settings.char_time());
                prop_assert!(d.patience() <= MAX_LATENCY + settings.char_time());
                prop_assert!(d.patience() >= d.allowance());
                before = now;
            }
        }
    }
}
