//! How late the port hands received bytes over, and how much slack the silence-judging timers
//! therefore need.
//!
//! A UART that delivers every character the moment its stop bit ends lets a receiver time the
//! silence between characters exactly, and the manuals' timers (Modbus end-of-frame gap
//! tZVZ, the ASCII character delay time, the USS residual run time, response-start timeouts)
//! assume it. Most hosts do not have such a UART. A USB-serial adapter (FTDI FT232R and
//! relatives) collects received characters and hands them to the host in USB packets: when it
//! holds 62 data bytes, or when its *latency timer* (1–255 ms, 16 ms by default) runs out with
//! bytes pending. A serial device server does the same with its packing delay, and a native
//! 16550-type UART with a receive FIFO interrupts only at its trigger level (1, 4, 8 or 14
//! bytes) or after a character timeout of about 4 character times. Seen from the engine, a long
//! frame arrives as bursts with holes between them, and a timer that takes such a hole for
//! silence ends the frame in the middle.
//!
//! [`Delivery`] is the one place that knows this, shared by every engine (not one copy per
//! protocol). It keeps the character time of the line, what the driver **declared**
//! ([`Engine::set_rx_latency`](crate::Engine::set_rx_latency)), what reads have **proven**
//! ([`observe`](Delivery::observe)), and from these a current **hold estimate**
//! ([`latency`](Delivery::latency)): how late a byte can reach the engine.
//!
//! # The rule
//!
//! 1. **Unknown is packetising.** A port nobody declared (a real port with no latency timer in
//!    sysfs: CH340, CP210x, a device server mapped to a pseudo-terminal, a pty) starts with the
//!    hold estimate [`ASSUMED_HOLD`], a USB adapter's default latency timer (16 ms): until reads
//!    prove otherwise, it is treated as such an adapter.
//! 2. **A declaration sets the estimate.** `set_rx_latency(d)` says the port holds bytes up to
//!    `d` (clamped to [`MAX_LATENCY`]); `set_rx_latency(Duration::ZERO)` declares a port that
//!    delivers byte by byte ([`Delivery::exact`]): the simulator's direct stations, a driver
//!    that knows its port. A declaration replaces the assumption of rule 1.
//! 3. **A multi-byte read raises it.** A read of `n ≥ 2` bytes proves the port held its first
//!    byte for at least `n − 1` character times, because the wire cannot carry them faster
//!    (counted up to one adapter packet, [`PACKET_BYTES`]: a longer read is several packets, or
//!    a port with no wire at all). The estimate becomes at least that hold plus one character
//!    time (the most the last byte of a full packet can have waited). The largest hold proven
//!    ([`learnt`](Delivery::learnt)) never decreases.
//! 4. **Single bytes at wire pace lower it.** [`PROOF_READS`] single-byte reads in a row, each
//!    0.5 to 1.5 character times after the one before, are only possible on a port that held
//!    none of them for long (a holding port would have handed two or more over together; on a
//!    port not declared byte by byte, two single bytes less than half a character time apart
//!    are one packet read in pieces and count as a read of two, rule 3). Such
//!    a run **halves** the estimate, and an estimate below one character time becomes zero. A
//!    port that never packetised (nothing declared, no multi-byte read) goes to zero at the
//!    first run: exact manual timing from the fifth byte of the first frame on.
//!
//! Bound: at every moment the estimate is at most the largest of [`ASSUMED_HOLD`] (unknown
//! ports), the declared latency and the largest proven hold plus one character time, and never
//! more than [`MAX_LATENCY`]. From it each silence-judging timer gets its
//! [`allowance`](Delivery::allowance) (the estimate plus one character time; zero when the
//! estimate is zero, so the manual's timing is kept exactly there), and a timer waiting for
//! bytes the frame's own length still predicts gets [`patience`](Delivery::patience)
//! ([`PATIENCE_FACTOR`] times the estimate plus one character time, at most [`MAX_LATENCY`]
//! plus one). Each frame end is
//! still decided by the manual's rule wherever the bytes allow it: a frame whose length or end
//! character ends it ends there, at once; the allowance only lengthens the silence that the
//! manual's timers wait for.
//!
//! # What it costs
//!
//! On a port that really delivers byte by byte but declared nothing, the first frame's
//! silence-judged end (a Modbus gap, an ASCII character delay time, a USS residual run time)
//! comes up to [`ASSUMED_HOLD`] plus a character time later than the manual's time, and the
//! first response timeout likewise, until four single bytes at wire pace have been read; a
//! frame of four bytes or fewer ends that late every time until a longer one came. Declaring
//! the port (`set_rx_latency(Duration::ZERO)`, `--rx-latency 0`) removes the cost; declaring
//! an adapter's latency removes the risk on a packetising port.

use crate::serial::SerialSettings;
use crate::status::Status;
use crate::time::{Duration, Instant};

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

/// The hold an undeclared port is assumed to have until reads prove otherwise: the default
/// latency timer of an FTDI-type USB adapter.
pub const ASSUMED_HOLD: Duration = Duration::from_millis(16);

/// How many hold estimates a frame whose length predicts more bytes waits for them
/// ([`Delivery::patience`]): the estimate can lag the port's real hold, and a loaded host
/// stalls its reader on top (a pty relay of a 16 ms adapter on a busy two-core machine showed
/// holes above twice the hold).
pub const PATIENCE_FACTOR: u64 = 4;

/// How many single-byte reads in a row, each at wire pace, prove a run of undelayed delivery
/// (rule 4 of the [module docs](self)).
pub const PROOF_READS: u8 = 4;

/// The port's delivery latency, declared, proven and estimated, and the allowance it gives
/// silence timers (the rule is in the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Delivery {
    char_time: Duration,
    /// What the driver declared; `None` while nobody did (rule 1).
    declared: Option<Duration>,
    /// The longest hold a read has proven: (n − 1) character times for a read of n bytes.
    held: Duration,
    /// The current hold estimate (rules 1–4).
    estimate: Duration,
    /// Single-byte reads in a row at wire pace, and when the last single-byte read came.
    run: u8,
    last_single: Option<Instant>,
}

impl Delivery {
    /// A port on a line with this character format that nobody declared: packetising like a
    /// default USB adapter ([`ASSUMED_HOLD`]) until reads show otherwise.
    pub fn new(settings: &SerialSettings) -> Self {
        Self::with_char_time(settings.char_time())
    }

    /// The same from a character time.
    pub const fn with_char_time(char_time: Duration) -> Self {
        Delivery {
            char_time,
            declared: None,
            held: Duration::ZERO,
            estimate: ASSUMED_HOLD,
            run: 0,
            last_single: None,
        }
    }

    /// A port known to deliver byte by byte: exact manual timing from the first byte.
    pub fn exact(settings: &SerialSettings) -> Self {
        let mut d = Self::new(settings);
        d.declare(Duration::ZERO);
        d
    }

    /// The driver says the port hands bytes over up to `latency` late (clamped to
    /// [`MAX_LATENCY`]); zero declares a port that delivers byte by byte. Replaces the
    /// assumption for an unknown port; what reads proved stays.
    pub fn declare(&mut self, latency: Duration) {
        let declared = min(latency, MAX_LATENCY);
        self.declared = Some(declared);
        self.estimate = max(declared, self.proven_latency());
        self.run = 0;
    }

    /// The latency the driver declared (zero for a port declared byte by byte, or while
    /// nothing was declared).
    pub fn declared(&self) -> Duration {
        self.declared.unwrap_or(Duration::ZERO)
    }

    /// True once a driver declared the port's delivery (a latency, or byte by byte).
    pub fn is_declared(&self) -> bool {
        self.declared.is_some()
    }

    /// One read of `n` bytes handed over at `now`. Two or more prove the port holds bytes and
    /// raise the estimate (rule 3); a run of single bytes at wire pace lowers it (rule 4).
    /// Returns true when the estimate changed, so an engine that caches a timer length
    /// recomputes it.
    #[inline]
    pub fn observe(&mut self, now: Instant, n: usize) -> bool {
        match n {
            0 => false,
            1 => self.observe_single(now),
            _ => self.observe_packet(n),
        }
    }

    #[inline]
    fn observe_single(&mut self, now: Instant) -> bool {
        let half = Duration::from_micros(self.char_time.as_micros() / 2);
        let gap = self.last_single.map(|last| now.saturating_since(last));
        if gap.is_some_and(|gap| gap < half) && self.declared != Some(Duration::ZERO) {
            // Two single bytes closer than the wire can carry them: one packet read in pieces.
            return self.observe_packet(2);
        }
        let at_wire_pace = gap.is_some_and(|gap| gap <= self.char_time + half);
        self.last_single = Some(now);
        self.run = if at_wire_pace {
            self.run.saturating_add(1)
        } else {
            1
        };
        if self.run < PROOF_READS || self.estimate == Duration::ZERO {
            return false;
        }
        self.run = 1;
        let never_packetised = self.held == Duration::ZERO && self.declared().as_micros() == 0;
        let halved = Duration::from_micros(self.estimate.as_micros() / 2);
        self.estimate = if never_packetised || halved < self.char_time {
            Duration::ZERO
        } else {
            halved
        };
        true
    }

    #[cold]
    fn observe_packet(&mut self, n: usize) -> bool {
        self.run = 0;
        self.last_single = None;
        let n = n.min(PACKET_BYTES) as u64;
        let held = min(self.char_time.saturating_mul(n - 1), MAX_LATENCY);
        self.held = max(self.held, held);
        let before = self.estimate;
        self.estimate = max(self.estimate, self.proven_latency());
        self.estimate != before
    }

    /// The latency the proven hold stands for: the hold plus one character time (zero before
    /// any multi-byte read), at most [`MAX_LATENCY`].
    fn proven_latency(&self) -> Duration {
        if self.held > Duration::ZERO {
            min(self.held + self.char_time, MAX_LATENCY)
        } else {
            Duration::ZERO
        }
    }

    /// The longest hold reads have proven so far (never decreases).
    pub fn learnt(&self) -> Duration {
        self.held
    }

    /// True while the port is taken to hand bytes over in packets: unknown and not yet proven
    /// byte by byte, a latency declared, or a multi-byte read, and not since worn down by runs
    /// of single bytes at wire pace.
    pub fn packetises(&self) -> bool {
        self.estimate > Duration::ZERO
    }

    /// The current hold estimate: how late a byte can reach the engine (rules 1–4 of the module
    /// docs); at most [`MAX_LATENCY`].
    pub fn latency(&self) -> Duration {
        self.estimate
    }

    /// The allowance while a frame's own length says more bytes are coming (a Modbus frame
    /// whose header predicts its length, a USS telegram after LGE): [`PATIENCE_FACTOR`] times
    /// the hold estimate plus one character time on a packetising port (the estimate can lag a port's real hold
    /// until a longer read proves more, and the host's scheduling adds to it), at most
    /// [`MAX_LATENCY`] plus one character time; zero on a port that delivers byte by byte.
    /// Costs nothing on a good frame, which ends by its length, and stays short enough that a
    /// fragment on a busy bus is judged over before the next request starts.
    pub fn patience(&self) -> Duration {
        if self.packetises() {
            min(self.estimate.saturating_mul(PATIENCE_FACTOR), MAX_LATENCY) + self.char_time
        } else {
            Duration::ZERO
        }
    }

    /// [`patience`](Self::patience) as an undeclared port gets it before reads prove anything
    /// ([`PATIENCE_FACTOR`] times [`ASSUMED_HOLD`], plus one character time), whatever this
    /// port has proven: for a receiver that waits for predicted bytes on any port, because
    /// what pauses inside a frame there is the partner or a relay in between, not the port
    /// (see si-modbus's master with `FrameEnd::Length`).
    pub fn assumed_patience(&self) -> Duration {
        ASSUMED_HOLD.saturating_mul(PATIENCE_FACTOR) + self.char_time
    }

    /// The allowance for a frame that only its own content can end and that nothing else on
    /// the line can follow (an ASCII frame with end characters or a fixed length): the longest
    /// hold any port has, [`MAX_LATENCY`] plus one character time, on a packetising port, so
    /// host scheduling on top of the port's holes never cuts it; zero on a byte-by-byte port.
    /// Where a fragment could swallow the next frame (a Modbus or USS bus) the engines use
    /// [`patience`](Self::patience) instead.
    pub fn longest_patience(&self) -> Duration {
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
            self.estimate + self.char_time
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

    /// `count` single-byte reads one character time apart from `from`; returns the next instant.
    fn singles(d: &mut Delivery, from: Instant, count: u64) -> Instant {
        let mut at = from;
        for _ in 0..count {
            d.observe(at, 1);
            at += ct();
        }
        at
    }

    #[test]
    fn an_unknown_port_is_packetising_until_single_bytes_at_wire_pace_prove_otherwise() {
        let mut d = Delivery::new(&SerialSettings::default());
        assert!(d.packetises());
        assert_eq!(d.latency(), ASSUMED_HOLD);
        assert_eq!(d.allowance(), ASSUMED_HOLD + ct());
        let next = singles(&mut d, Instant::ZERO, u64::from(PROOF_READS) - 1);
        assert!(d.packetises(), "three bytes prove nothing yet");
        singles(&mut d, next, 1);
        assert!(!d.packetises());
        assert_eq!(d.allowance(), Duration::ZERO);
    }

    #[test]
    fn single_bytes_faster_than_the_wire_are_a_packet_read_in_pieces() {
        let mut d = Delivery::new(&SerialSettings::default());
        for k in 0..20u64 {
            d.observe(Instant::from_micros(k * 10), 1);
        }
        assert_eq!(d.latency(), ASSUMED_HOLD, "never proven byte by byte");
        assert_eq!(d.learnt(), ct());
    }

    #[test]
    fn single_bytes_far_apart_prove_nothing() {
        let mut d = Delivery::new(&SerialSettings::default());
        for k in 0..100u64 {
            d.observe(Instant::from_micros(k * 20_000), 1);
        }
        assert_eq!(d.latency(), ASSUMED_HOLD);
    }

    #[test]
    fn a_port_declared_exact_gets_no_allowance() {
        let mut d = Delivery::exact(&SerialSettings::default());
        assert!(d.is_declared());
        for k in 0..100u64 {
            d.observe(Instant::from_micros(k * 50_000), 1);
        }
        assert!(!d.packetises());
        assert_eq!(d.allowance(), Duration::ZERO);
        assert_eq!(d.patience(), Duration::ZERO);
    }

    #[test]
    fn a_read_longer_than_a_packet_teaches_one_packets_hold() {
        let mut d = Delivery::exact(&SerialSettings::default());
        assert!(d.observe(Instant::ZERO, 200));
        assert_eq!(d.learnt(), ct().saturating_mul(61));
        assert_eq!(d.latency(), ct().saturating_mul(62));
    }

    #[test]
    fn a_declared_latency_gives_it_plus_a_character_time() {
        let mut d = Delivery::new(&SerialSettings::default());
        d.declare(Duration::from_millis(4));
        assert!(d.packetises());
        assert_eq!(d.allowance(), Duration::from_millis(4) + ct());
        d.declare(Duration::from_secs(1));
        assert_eq!(d.declared(), MAX_LATENCY);
    }

    #[test]
    fn a_read_of_fourteen_bytes_teaches_thirteen_character_times_held() {
        // 9600 8E1: a 16 ms FTDI packet holds 14 characters of 1.146 ms.
        let mut d = Delivery::exact(&SerialSettings::default());
        d.observe(Instant::ZERO, 14);
        assert_eq!(d.learnt(), ct().saturating_mul(13));
        assert_eq!(d.allowance(), ct().saturating_mul(15));
        assert!(d.allowance() >= Duration::from_millis(16) + Duration::from_micros(1));
    }

    #[test]
    fn a_learnt_hold_decays_by_halves_after_runs_at_wire_pace_and_comes_back() {
        let mut d = Delivery::exact(&SerialSettings::default());
        d.observe(Instant::ZERO, 14);
        let high = d.latency();
        let mut at = Instant::from_micros(100_000);
        at = singles(&mut d, at, u64::from(PROOF_READS));
        assert_eq!(d.latency(), Duration::from_micros(high.as_micros() / 2));
        for _ in 0..10 {
            at = singles(&mut d, at, u64::from(PROOF_READS));
        }
        assert_eq!(d.latency(), Duration::ZERO);
        assert_eq!(
            d.learnt(),
            ct().saturating_mul(13),
            "the largest hold stays known"
        );
        // Any multi-byte read brings back the largest hold proven, plus a character time.
        assert!(d.observe(at + Duration::from_millis(50), 3));
        assert_eq!(d.latency(), ct().saturating_mul(14));
    }

    #[test]
    fn framing_errors_name_the_adapter_once_bytes_came_too_fast() {
        let status = crate::status::common::INVALID_LEN;
        let mut d = Delivery::new(&SerialSettings::default());
        assert_eq!(d.annotate(status).remedy(), status.remedy());
        d.observe(Instant::ZERO, 2);
        let annotated = d.annotate(status);
        assert_eq!(annotated, status);
        let remedy = annotated.remedy().unwrap();
        assert!(remedy.contains("latency timer") && remedy.contains("--latency-timer 1"));
        assert!(remedy.contains("set_rx_latency"));
    }

    proptest! {
        #[test]
        fn the_estimate_stays_within_its_bound(
            baud in prop::sample::select(crate::serial::BAUD_RATES.to_vec()),
            reads in prop::collection::vec((0usize..2000, 0u64..5_000), 0..60),
            declared in prop::option::of(0u64..10_000_000),
        ) {
            let settings = SerialSettings::new(baud, 8, crate::Parity::Even, 1).unwrap();
            let ct = settings.char_time();
            let mut d = Delivery::new(&settings);
            if let Some(us) = declared {
                d.declare(Duration::from_micros(us));
            }
            let mut at = Instant::ZERO;
            let mut learnt = d.learnt();
            for (n, gap) in reads {
                // Bytes 1..=2 per read mostly, to exercise the runs.
                let n = if n % 3 == 0 { n } else { n % 2 };
                at += Duration::from_micros(gap);
                d.observe(at, n);
                let assumed = if d.is_declared() { Duration::ZERO } else { ASSUMED_HOLD };
                let proven = if d.learnt() > Duration::ZERO { d.learnt() + ct } else { Duration::ZERO };
                let bound = max(max(assumed, d.declared()), proven);
                prop_assert!(d.learnt() >= learnt);
                learnt = d.learnt();
                prop_assert!(d.latency() <= min(bound, MAX_LATENCY));
                prop_assert!(d.allowance() <= MAX_LATENCY + ct);
                prop_assert!(d.patience() <= MAX_LATENCY + ct);
                prop_assert!(d.patience() >= d.allowance());
            }
        }
    }
}
