//! # Bounds: the longest an RK 512 job may take, whatever the line does
//!
//! An RK 512 job (SEND or FETCH) is a chain of telegrams, each a 3964(R) send job followed by
//! the wait for the partner's reaction ([CP 341] §2.2.3, Fig. 2-18/2-19). Each part is
//! bounded, so the job is:
//!
//! - each telegram ends within the 3964(R) link's bound, [`si_3964r::Config::send_job_bound`]
//!   (see [`si_3964r::bound`]: the attempts and timers of the procedure, an overlong received
//!   block cut off with NAK, and a hard deadline per send job `[derived]`);
//! - our telegram may wait in the station's queue behind one reaction of ours to a partner's
//!   job, which is itself one 3964(R) send job (nesting depth 1, [CP 341] §2.2.3, Fig. 2-17: the
//!   queue holds one command and one reaction);
//! - after the partner's `DLE` for our telegram the reaction must start within TRES (`[derived]`,
//!   [CP 341] §2.2.3, Fig. 2-18/2-19); otherwise the job ends with 0A05H. TRES is judged on every
//!   input, not only on the timer, so a line that never goes quiet cannot hold it off.
//!
//! ```text
//! telegrams = ⌈len / 128⌉ (at least 1)
//! job bound = telegrams × (2 × link bound(138-byte block) + TRES)          [derived]
//! ```
//!
//! At 9600 bit/s with the defaults (3964(R) defaults, TRES 10 s) a job of up to 128 bytes ends
//! within 185.95 s. Most of it is the manual's own budget of 6 × 6 attempts with a 2 s QVZ; with
//! QVZ 200 ms, 2 and 2 attempts and TRES 1 s it is 5.01 s:
//!
//! ```
//! use si_rk512::Config;
//! use si_core::{Duration, SerialSettings};
//!
//! let line = SerialSettings::default();
//! assert_eq!(Config::default().job_bound(&line, 128), Duration::from_micros(185_952_120));
//! assert_eq!(Config::default().job_bound(&line, 129), Duration::from_micros(2 * 185_952_120));
//! let mut short = Config { response_timeout: Duration::from_millis(1_000), ..Config::default() };
//! short.link.ack_delay = Duration::from_millis(200);
//! short.link.connection_attempts = 2;
//! short.link.transmission_attempts = 2;
//! assert_eq!(short.job_bound(&line, 10).as_millis(), 6_942);
//! ```

use crate::config::Config;
use crate::frame::{MAX_DATA_PER_TELEGRAM, MAX_TELEGRAM_LEN};
use si_core::{Duration, SerialSettings};

impl Config {
    /// Telegrams of a job of `len` bytes: 128 data bytes each, at least one ([CP 341] §2.2.3).
    pub fn telegrams(len: usize) -> u64 {
        len.div_ceil(MAX_DATA_PER_TELEGRAM).max(1) as u64
    }

    /// The longest a SEND or FETCH job of `len` bytes may take on a line with `settings`,
    /// whatever the line does (formula and readings in [`crate::bound`]).
    pub fn job_bound(&self, settings: &SerialSettings, len: usize) -> Duration {
        let telegram = self.link.send_job_bound(settings, MAX_TELEGRAM_LEN);
        let per_telegram = telegram.saturating_mul(2) + self.response_timeout;
        per_telegram.saturating_mul(Config::telegrams(len))
    }
}
