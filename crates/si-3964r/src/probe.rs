//! Probing a partner: does it answer `STX` with `DLE`, and how does it meet a conflict?
//!
//! A probe sends one `STX` and reads the first character back within the acknowledgement delay
//! time (QVZ, [ET200S SI] §2.7, sending: connection setup):
//!
//! - `DLE`: the partner is ready to receive at these line settings. It then waits for a block
//!   that never comes and, after the character delay time, answers NAK and reports a receive
//!   error on its side (0806 on a module): the one trace a probe leaves.
//! - `NAK`: the partner heard `STX` and refuses (busy, or it is set up for something else).
//! - `STX`: the partner sends `STX` itself: an initialization conflict it does not yield, so
//!   it holds the **high** priority, and we must be low (`[derived]`: a low-priority side
//!   yields and answers `DLE`, [CP 341] §2.2.2, [Public 3964R]). A partner that answers `DLE`
//!   is low priority or simply idle; a probe cannot tell which.
//! - anything else: a character at other line settings, or another protocol.
//! - nothing: no partner, or one that hears garbage at these settings.
//!
//! The probe writes and reads the port itself rather than run a [`Link`](crate::link::Link):
//! a link's send job goes on with a whole block once the partner answers `DLE` (the partner
//! would receive data, not just a connection setup it drops), and it reports the partner's
//! first character only as the job's STATUS or a conflict it resolved by its own priority,
//! never as the character; a probe must send `STX` alone and say what came back. What it
//! shares with the bus scans (the settings tried, [`Found`], [`ProbeError`], the total bound)
//! is si-core's `sweep`.

use crate::frame::{DLE, NAK, STX};
use si_core::{Duration, SerialSettings};

/// What the partner's first character says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    /// `DLE`: ready to receive.
    Ready,
    /// `NAK`: refused.
    Refused,
    /// `STX`: the partner sends too and does not yield: it has high priority.
    HighPriority,
    /// Another character.
    Other(u8),
    /// Nothing within the acknowledgement delay time.
    Silent,
}

impl Reply {
    /// The partner's first character after our `STX`, if any.
    pub fn of(first: Option<u8>) -> Reply {
        match first {
            Some(DLE) => Reply::Ready,
            Some(NAK) => Reply::Refused,
            Some(STX) => Reply::HighPriority,
            Some(c) => Reply::Other(c),
            None => Reply::Silent,
        }
    }

    /// The character that gave this reply (`None`: nothing came).
    pub fn first(self) -> Option<u8> {
        match self {
            Reply::Ready => Some(DLE),
            Reply::Refused => Some(NAK),
            Reply::HighPriority => Some(STX),
            Reply::Other(c) => Some(c),
            Reply::Silent => None,
        }
    }

    /// One line for a person.
    pub fn describe(self) -> String {
        match self {
            Reply::Ready => "answers STX with DLE: a 3964(R) partner at these settings".into(),
            Reply::Refused => "answers STX with NAK: a partner that refuses to receive".into(),
            Reply::HighPriority => {
                "answers STX with STX: it sends too and does not yield (high priority; be low)"
                    .into()
            }
            Reply::Other(c) => format!("answers {c:02X}H: other settings or another protocol?"),
            Reply::Silent => "no answer".into(),
        }
    }
}

/// Reads of what the line held before the probe (a partner's start-up NAK) at most: a line that
/// chatters cannot hold the probe longer than this many [`STALE_WAIT`]s.
pub const STALE_READS: u32 = 10;

/// How long one read of the line's stale bytes waits; a line silent this long is clear.
pub const STALE_WAIT: Duration = Duration::from_millis(20);

/// What one setting's probe saw: the partner's [`Reply`] (its first character back within
/// the acknowledgement delay time, [`Reply::first`]) at those settings. A point-to-point
/// partner has no address: the station is `()`.
pub type Found = si_core::sweep::Found<(), Reply>;

/// A probe of each of a list of line settings (run with `run`, feature `tokio`).
#[derive(Debug, Clone)]
pub struct Probe {
    settings: Vec<SerialSettings>,
    ack_delay: Duration,
    char_delay: Duration,
}

impl Probe {
    /// A probe at each of `settings`, giving the partner `ack_delay` (QVZ) to answer and
    /// waiting twice its `char_delay` (ZVZ, and its NAK) out after an answer.
    pub fn new(
        settings: Vec<SerialSettings>,
        ack_delay: impl Into<Duration>,
        char_delay: impl Into<Duration>,
    ) -> Probe {
        Probe {
            settings,
            ack_delay: ack_delay.into(),
            char_delay: char_delay.into(),
        }
    }

    /// The settings probed, in order.
    pub fn settings(&self) -> &[SerialSettings] {
        &self.settings
    }

    /// The longest the probe of one setting takes once its port is open, whatever the line
    /// does: the stale bytes read ([`STALE_READS`] × [`STALE_WAIT`] on a line that chatters),
    /// the QVZ wait, and the partner's ZVZ (and its NAK) waited out after an answer.
    pub fn setting_bound(&self) -> Duration {
        STALE_WAIT.saturating_mul(u64::from(STALE_READS))
            + self.ack_delay
            + self.char_delay
            + self.char_delay
    }

    /// The longest the probe can take: per setting [`Probe::setting_bound`] and
    /// [`OPEN_SLACK`](si_core::sweep::OPEN_SLACK) ([`si_core::sweep::total`]).
    pub fn bound(&self) -> Duration {
        si_core::sweep::total(self.settings.iter().map(|_| self.setting_bound()))
    }

    /// Run it: for each setting, `open` the line, drop what it held (a partner's start-up
    /// NAK; at most [`STALE_READS`] reads, so a chattering line cannot hold the probe), send `STX`, read
    /// the first character back within QVZ, hand it to `found`, and after an answer wait the
    /// partner's ZVZ out so the next setting starts on a quiet line. Dropping the future
    /// stops the probe at once.
    #[cfg(feature = "tokio")]
    #[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
    pub async fn run<T, E, Fut>(
        &self,
        mut open: impl FnMut(SerialSettings) -> Fut,
        mut found: impl FnMut(Found),
    ) -> Result<(), ProbeError<E>>
    where
        T: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin,
        Fut: std::future::Future<Output = Result<T, E>>,
    {
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        let std = core::time::Duration::from;
        for &settings in &self.settings {
            let mut port = open(settings).await.map_err(ProbeError::Open)?;
            let mut stale = [0u8; 64];
            for _ in 0..STALE_READS {
                let read = port.read(&mut stale);
                match tokio::time::timeout(std(STALE_WAIT), read).await {
                    Ok(Ok(0)) => return Err(ProbeError::Run(ProbeFault::Closed)),
                    Ok(Ok(_)) => {}
                    _ => break,
                }
            }
            port.write_all(&[STX])
                .await
                .map_err(|e| ProbeError::Run(ProbeFault::Io(e)))?;
            let mut byte = [0u8; 1];
            let first = match tokio::time::timeout(std(self.ack_delay), port.read(&mut byte)).await
            {
                Ok(Ok(1)) => Some(byte[0]),
                Ok(Ok(_)) => return Err(ProbeError::Run(ProbeFault::Closed)),
                Ok(Err(e)) => return Err(ProbeError::Run(ProbeFault::Io(e))),
                Err(_) => None,
            };
            found(Found {
                station: (),
                settings,
                answer: Reply::of(first),
            });
            if first.is_some() {
                let quiet = tokio::time::sleep(std(self.char_delay + self.char_delay));
                tokio::pin!(quiet);
                let mut drain = [0u8; 64];
                loop {
                    tokio::select! {
                        _ = &mut quiet => break,
                        r = port.read(&mut drain) => if !matches!(r, Ok(n) if n > 0) { break },
                    }
                }
            }
        }
        Ok(())
    }
}

/// Why a probe stopped before its end: the caller could not open the line for a setting
/// ([`SweepError::Open`](si_core::sweep::SweepError::Open)), or the line failed under the probe
/// ([`SweepError::Run`](si_core::sweep::SweepError::Run) with a [`ProbeFault`]).
pub type ProbeError<E> = si_core::sweep::SweepError<E, ProbeFault>;

/// How the line failed under a probe.
#[derive(Debug, thiserror::Error)]
pub enum ProbeFault {
    /// The line closed under the probe.
    #[error("the line closed")]
    Closed,
    /// Writing `STX` or reading the answer failed.
    #[error("{0}")]
    Io(std::io::Error),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_character_says_what_the_partner_is() {
        assert_eq!(Reply::of(Some(DLE)), Reply::Ready);
        assert_eq!(Reply::of(Some(NAK)), Reply::Refused);
        assert_eq!(Reply::of(Some(STX)), Reply::HighPriority);
        assert_eq!(Reply::of(Some(0x41)), Reply::Other(0x41));
        assert_eq!(Reply::of(None), Reply::Silent);
        assert!(Reply::Other(0xFE).describe().contains("FEH"));
        for first in [Some(DLE), Some(NAK), Some(STX), Some(0x41), None] {
            assert_eq!(Reply::of(first).first(), first);
        }
    }
}
