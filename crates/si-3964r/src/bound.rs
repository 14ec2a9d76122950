//! # Bounds: the longest a send job may take, whatever the line does
//!
//! The manual bounds every *step* of a send job: the partner answers `STX` within the
//! acknowledgement delay time QVZ, gaps within a block are shorter than the character delay time
//! ZVZ, and a job is given up after the configured connection and transmission attempts
//! ([ET200S SI] §2.7, Table 2-11 `[derived]`). It does not bound the *job*: a partner that
//! never stops sending keeps the driver waiting for a quiet line ([ET200S SI] §2.7, sending:
//! partner interrupts the send, §2.7, receiving: idle) or receiving (a low-priority side yields to
//! every `STX`, [ET200S SI] §2.7, Fig. 2-16), and the job never starts or never ends. A host needs
//! that bound, so the link adds one where the manual has none:
//!
//! - **An overlong block ends at once** (`[derived]` from the receive buffer, [ET200S SI] §2.7,
//!   receiving: STX with a free buffer and [ET200S SI 2005] Table 2-29 "received frame longer than
//!   … the configured length", 0850H). The manual lets a reception with an error run to the
//!   partner's `DLE ETX` ([ET200S SI] §2.7, receiving: cleardown and errors during reception), but
//!   a block longer than the maximum cannot be stored, so the link answers NAK as soon as the first
//!   byte too many arrives, as a sender is answered whose block the receiver cannot take
//!   ([ET200S SI] §2.7, sending: partner interrupts the send: a NAK during a send makes the partner
//!   abort and repeat). A partner that sends `STX` and then data for ever, or `DLE`-doubled data
//!   with no `ETX`, is thereby cut off after at most `2 × max + 3` characters.
//! - **Every send job ends by its deadline** (`[derived]`): [`Config::send_job_bound`] after
//!   [`Link::send`](crate::Link::send). It is the longest the manual's own procedure takes on a
//!   line that answers nothing, or answers wrongly, at every step:
//!
//!   ```text
//!   per transmission attempt = Ncon × (t_char + QVZ)             connection attempts ([ET200S SI] §2.7, sending: connection setup)
//!                            + t_block(len)                      our block: 2·len + 3 characters
//!                            + QVZ                               end acknowledgement ([ET200S SI] §2.7, sending: cleardown)
//!                            + gap(ZVZ) + t_char                 quiet wait and NAK ([ET200S SI] §2.7, sending: partner interrupts the send)
//!   job bound                = Ntx × per transmission attempt    ([ET200S SI] §2.7, sending: retry limit)
//!                            + t_block(max) + gap(ZVZ)           one yielded reception ([ET200S SI] §2.7, Fig. 2-16)
//!   ```
//!
//!   `t_char` is one character time, `t_block(n)` the time of `2·n + 3` characters (every byte a
//!   doubled `DLE`, then `DLE ETX BCC`), `gap(ZVZ)` = ZVZ + `t_char` + 1 µs the gap limit of
//!   [`SerialSettings::gap_limit`]. On a port with delivery latency QVZ and ZVZ get the port's
//!   allowance, as everywhere in the link (at most [`si_core::delivery::MAX_LATENCY`] plus one
//!   character; the job's deadline grows with the allowance if it is learnt while the job runs). Time spent receiving the partner's blocks while our
//!   job waits counts against the bound. When the deadline passes, the job ends with
//!   [`Event::SendFailed`](crate::Event::SendFailed) carrying the first error of the job, or
//!   0703H (no connection set up within QVZ) when the line never let it get as far as an error,
//!   070BH when it met a high-priority partner's `STX` at high priority; a job that was on the
//!   line is given up with NAK ([ET200S SI] §2.7, sending: retry limit). A reception in progress
//!   runs on.
//!
//! At 9600 bit/s with the defaults (QVZ 2 s, ZVZ 220 ms, 6 and 6 attempts, 200-byte blocks) a
//! send job of a maximum block ends within 88.83 s; a silent partner ends it after the six
//! connection attempts, 6 × 2.001 s, with 0703H:
//!
//! ```
//! use si_3964r::Config;
//! use si_core::{Duration, SerialSettings};
//!
//! let line = SerialSettings::default(); // 9600 8E1: 1146 µs per character
//! let bound = Config::default().send_job_bound(&line, 200);
//! assert_eq!(bound, Duration::from_micros(88_828_558));
//! let short = Config { ack_delay: si_core::Duration::from_millis(200), connection_attempts: 2, transmission_attempts: 2, ..Config::default() };
//! assert_eq!(short.send_job_bound(&line, 1).as_millis(), 2_343);
//! ```

use crate::config::Config;
use si_core::{Duration, SerialSettings};

/// Characters a block of `len` user-data bytes takes on the wire at most: every byte a doubled
/// `DLE`, then `DLE ETX` and the BCC ([ET200S SI] §2.7, Fig. 2-12).
pub const fn worst_wire_chars(len: usize) -> u64 {
    (len as u64).saturating_mul(2).saturating_add(3)
}

impl Config {
    /// The longest a send job of a `len`-byte block may take on a line with `settings`, whatever
    /// the line does (see the module docs of [`crate::bound`] for the formula).
    pub fn send_job_bound(&self, settings: &SerialSettings, len: usize) -> Duration {
        self.send_job_bound_with(settings, len, Duration::ZERO)
    }

    /// [`Self::send_job_bound`] with QVZ and ZVZ lengthened by a port's delivery `allowance`.
    pub(crate) fn send_job_bound_with(
        &self,
        settings: &SerialSettings,
        len: usize,
        allowance: Duration,
    ) -> Duration {
        let t_char = settings.char_time();
        let qvz = self.ack_delay + allowance;
        let zvz_gap = settings.gap_limit(self.char_delay + allowance);
        let connection = (t_char + qvz).saturating_mul(self.connection_attempts.into());
        let block = settings.chars_time(worst_wire_chars(len));
        let attempt = connection + block + qvz + zvz_gap + t_char;
        let yielded = settings.chars_time(worst_wire_chars(self.max_block_len.into())) + zvz_gap;
        attempt.saturating_mul(self.transmission_attempts.into()) + yielded
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bound_grows_with_every_parameter() {
        let line = SerialSettings::default();
        let base = Config::default();
        let b = base.send_job_bound(&line, 10);
        for bigger in [
            Config {
                ack_delay: si_core::Duration::from_millis(2010),
                ..base
            },
            Config {
                char_delay: si_core::Duration::from_millis(230),
                ..base
            },
            Config {
                connection_attempts: 7,
                ..base
            },
            Config {
                transmission_attempts: 7,
                ..base
            },
            Config {
                max_block_len: 201,
                ..base
            },
        ] {
            assert!(bigger.send_job_bound(&line, 10) > b, "{bigger:?}");
        }
        assert!(base.send_job_bound(&line, 11) > b);
        assert!(base.send_job_bound_with(&line, 10, Duration::from_millis(1)) > b);
    }
}
