//! Monotonic time for Sans-IO engines.
//!
//! Engines never read a clock: every input carries the current [`Instant`], a count of
//! microseconds from an arbitrary origin chosen by the driver (the tokio driver uses the moment it
//! started, the simulator uses virtual time zero). Microseconds are fine enough for the shortest
//! interval the manuals name (one character at 115 200 bit/s is 95.5 µs) and a `u64` of them lasts
//! 584 000 years, so arithmetic saturates instead of wrapping and never panics.
//!
//! # Times and attempts: one naming scheme
//!
//! Every protocol names its times and counts alike, in its config, its CLI flags, its profile
//! keys and the gateway's file:
//!
//! - A time is a [`Duration`] field named by the manual's term in snake case, without a unit:
//!   `ack_delay` (3964(R) QVZ), `char_delay` (ZVZ), `response_timeout` (Modbus, USS, RK 512
//!   TRES), `wait_for_xon`. Setters and handle options take `impl Into<Duration>`, so a
//!   `std::time::Duration` works too.
//! - In files (TOML, JSON) and on the command line the same time is a whole number of
//!   milliseconds named `<name>_ms` / `--<name>-ms` (`ack_delay_ms`, `--response-timeout-ms`);
//!   [`millis`] maps a field to that key.
//! - `retries` counts repetitions after the first try (Modbus, USS PKW); `*_attempts` counts
//!   tries including the first, where the manual counts attempts (3964(R) connection and
//!   transmission attempts).

use core::fmt;
use core::ops::{Add, AddAssign, Sub};
use serde::{Deserialize, Serialize};

/// A point in monotonic time, in microseconds since the driver's origin.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Instant(u64);

impl Instant {
    /// The driver's origin.
    pub const ZERO: Instant = Instant(0);

    /// The instant `micros` microseconds after the origin.
    pub const fn from_micros(micros: u64) -> Self {
        Instant(micros)
    }

    /// Microseconds since the origin.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Time from `earlier` to `self`, zero if `earlier` is later.
    pub const fn saturating_since(self, earlier: Instant) -> Duration {
        Duration(self.0.saturating_sub(earlier.0))
    }

    /// The earlier of two optional deadlines (`None` = no deadline), used when an
    /// engine combines several timers into one `Wait`.
    pub fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
        match (a, b) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, None) => a,
            (None, b) => b,
        }
    }
}

impl fmt::Display for Instant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:06} s", self.0 / 1_000_000, self.0 % 1_000_000)
    }
}

/// A span of time in microseconds.
///
/// The manuals give timers in milliseconds (ZVZ 220 ms, QVZ 2000 ms) and character times in
/// fractions of a millisecond; both fit exactly.
///
/// `std::time::Duration` converts into it (rounded down to whole microseconds, saturating), so
/// every config and handle that takes a time accepts either; `Debug` prints like `Display`
/// ("50 ms"), not the raw count.
#[derive(Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Duration(u64);

impl Duration {
    /// No time at all.
    pub const ZERO: Duration = Duration(0);

    /// `micros` microseconds.
    pub const fn from_micros(micros: u64) -> Self {
        Duration(micros)
    }

    /// `millis` milliseconds.
    pub const fn from_millis(millis: u64) -> Self {
        Duration(millis.saturating_mul(1_000))
    }

    /// `secs` seconds.
    pub const fn from_secs(secs: u64) -> Self {
        Duration(secs.saturating_mul(1_000_000))
    }

    /// Whole microseconds.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Whole milliseconds, rounded down.
    pub const fn as_millis(self) -> u64 {
        self.0 / 1_000
    }

    /// `self × n`, saturating.
    pub const fn saturating_mul(self, n: u64) -> Duration {
        Duration(self.0.saturating_mul(n))
    }

    /// `self − other`, zero if `other` is longer.
    pub const fn saturating_sub(self, other: Duration) -> Duration {
        Duration(self.0.saturating_sub(other.0))
    }
}

impl fmt::Display for Duration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_multiple_of(1_000) {
            write!(f, "{} ms", self.0 / 1_000)
        } else {
            write!(f, "{}.{:03} ms", self.0 / 1_000, self.0 % 1_000)
        }
    }
}

impl fmt::Debug for Duration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl From<core::time::Duration> for Duration {
    /// Whole microseconds, rounded down; a span beyond `u64::MAX` µs saturates.
    fn from(d: core::time::Duration) -> Self {
        Duration(u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
    }
}

impl From<Duration> for core::time::Duration {
    fn from(d: Duration) -> Self {
        core::time::Duration::from_micros(d.0)
    }
}

impl Add<Duration> for Instant {
    type Output = Instant;
    fn add(self, rhs: Duration) -> Instant {
        Instant(self.0.saturating_add(rhs.0))
    }
}

impl AddAssign<Duration> for Instant {
    fn add_assign(&mut self, rhs: Duration) {
        *self = *self + rhs;
    }
}

impl Sub<Instant> for Instant {
    type Output = Duration;
    /// Saturating: an earlier minus a later instant is zero, never a panic.
    fn sub(self, rhs: Instant) -> Duration {
        self.saturating_since(rhs)
    }
}

impl Add for Duration {
    type Output = Duration;
    fn add(self, rhs: Duration) -> Duration {
        Duration(self.0.saturating_add(rhs.0))
    }
}

/// Serde for a [`Duration`] kept in files as a whole number of milliseconds (the `<name>_ms`
/// keys of the naming scheme in the [module docs](self)): `#[serde(rename = "ack_delay_ms",
/// with = "si_core::time::millis")]`. Writing rounds down to the millisecond.
pub mod millis {
    use super::Duration;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes `d` as its whole milliseconds.
    pub fn serialize<S: Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(d.as_millis())
    }

    /// Reads a whole number of milliseconds.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Duration, D::Error> {
        u64::deserialize(d).map(Duration::from_millis)
    }
}

/// Serde for an optional [`Duration`] kept in files as whole milliseconds, absent or `null` for
/// none: [`millis`] for an `Option` (`#[serde(rename = "job_timeout_ms", with =
/// "si_core::time::millis_opt", default)]`).
pub mod millis_opt {
    use super::Duration;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes `d` as its whole milliseconds, or nothing (`null`).
    pub fn serialize<S: Serializer>(d: &Option<Duration>, s: S) -> Result<S::Ok, S::Error> {
        match d {
            Some(d) => s.serialize_some(&d.as_millis()),
            None => s.serialize_none(),
        }
    }

    /// Reads a whole number of milliseconds, or nothing.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Duration>, D::Error> {
        Option::<u64>::deserialize(d).map(|ms| ms.map(Duration::from_millis))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_saturates_instead_of_panicking() {
        let t = Instant::from_micros(u64::MAX - 1);
        assert_eq!((t + Duration::from_secs(1)).as_micros(), u64::MAX);
        assert_eq!(Instant::ZERO - t, Duration::ZERO);
        assert_eq!(Duration::from_millis(u64::MAX).as_micros(), u64::MAX);
    }

    #[test]
    fn display_uses_the_manuals_units() {
        assert_eq!(Duration::from_millis(220).to_string(), "220 ms");
        assert_eq!(Duration::from_micros(1_146).to_string(), "1.146 ms");
        assert_eq!(Instant::from_micros(4_000_001).to_string(), "4.000001 s");
        assert_eq!(format!("{:?}", Duration::from_millis(50)), "50 ms");
    }

    #[test]
    fn std_durations_convert_both_ways() {
        let d: Duration = core::time::Duration::from_micros(1_500).into();
        assert_eq!(d, Duration::from_micros(1_500));
        assert_eq!(core::time::Duration::from(d).as_micros(), 1_500);
        assert_eq!(
            Duration::from(core::time::Duration::from_nanos(999)),
            Duration::ZERO
        );
        assert_eq!(
            Duration::from(core::time::Duration::MAX).as_micros(),
            u64::MAX
        );
    }

    #[test]
    fn earliest_deadline_wins() {
        let a = Some(Instant::from_micros(5));
        let b = Some(Instant::from_micros(3));
        assert_eq!(Instant::earliest(a, b), b);
        assert_eq!(Instant::earliest(None, a), a);
        assert_eq!(Instant::earliest(None, None), None);
    }
}
