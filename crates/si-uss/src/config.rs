//! Master and drive parameters with the manuals' ranges and defaults.
//!
//! - Polling list: 1…31 entries (SANZ, [Modbus/USS] §3.7.6, Table 3-31), each a node number 0…31
//!   (TNU), PKW 0/3/4 words and PZD 0…16 words ([Modbus/USS] §3.7.8); a slave may appear several
//!   times to raise its priority, with the same structure each time.
//! - WDH, permitted PKW repetitions 0…32 767 ([Modbus/USS] §3.7.6, Table 3-31, §3.7.8).
//! - Baud rates: the module offers 110…38 400 ([Modbus/USS] §3.9) or 110…115 200 ([ET200S SI 2005]
//!   [ET200S SI 2005] §3.8.10, Table 3-78); a host also meets drives at 187 500 bit/s ([USS spec]
//!   §5.1.2 start-interval table), so [`USS_BAUD_RATES`] is the twelve manual rates plus 187 500.
//! - Timing ([USS spec] §5.1.2, §5.2.1): start interval 2 character times, response delay ≤ 20 ms,
//!   residual run time 1.5 × (n + 3) character times.

use crate::frame::{PkwWords, MAX_ADDRESS, MAX_NET, MAX_PZD_WORDS};
use serde::{Deserialize, Serialize};
use si_core::{Duration, Parity, RangeError, SerialSettings, SettingsError};

/// Baud rates a USS line may use: the ET 200S table plus 187 500 bit/s.
pub const USS_BAUD_RATES: [u32; 13] = [
    110, 300, 600, 1_200, 2_400, 4_800, 9_600, 19_200, 38_400, 57_600, 76_800, 115_200, 187_500,
];

/// USS character format: 8 data bits, even parity, 1 stop bit ([USS spec] §6.1, 11 bits a
/// character) at `baud`, which must be one of [`USS_BAUD_RATES`].
pub fn uss_settings(baud: u32) -> Result<SerialSettings, SettingsError> {
    SerialSettings::with_rates(baud, 8, Parity::Even, 1, &USS_BAUD_RATES)
}

/// Most entries in the polling list (SANZ 1…31).
pub const MAX_ENTRIES: usize = 31;
/// Longest response delay the USS spec allows a slave ([USS spec] §5.2.1.1).
pub const RESPONSE_DELAY_MAX: Duration = Duration::from_millis(20);

/// One entry of the polling list: whom to poll and with which net-data structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PollEntry {
    /// Node number TNU, 0…31.
    pub address: u8,
    /// PKW words: 0, 3, 4 or variable.
    pub pkw: PkwWords,
    /// PZD words, 0…16.
    pub pzd_words: u8,
}

impl PollEntry {
    /// An entry; checked by [`MasterConfig::validate`].
    pub const fn new(address: u8, pkw: PkwWords, pzd_words: u8) -> Self {
        PollEntry {
            address,
            pkw,
            pzd_words,
        }
    }

    /// Net bytes of a request with a fixed PKW area (variable areas count PKE + IND + one word).
    pub fn net_len(&self) -> usize {
        2 * (self.pkw.fixed().unwrap_or(3) + usize::from(self.pzd_words))
    }
}

/// A parameter outside its range, naming the parameter, the range and the value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// A value outside the manual's range (si-core's one [`RangeError`]).
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// The same node listed twice with different structures.
    #[error("node {address} is listed with two different PKW/PZD structures")]
    ConflictingStructure {
        /// The node.
        address: u8,
    },
}

/// `Ok` if `ok`, else the range error for `name` = `value` outside `range`.
pub(crate) fn check(
    ok: bool,
    name: &'static str,
    value: impl std::fmt::Display,
    range: &'static str,
) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(RangeError::new(name, range, "", value).into())
    }
}

/// What the master sends in a slave's PKW area after a parameter job has ended.
///
/// [Modbus/USS] §3.7.7: with the module's FCs "the last PKW job stays in the transmit
/// interface after it has been processed and is sent to the slave again and again until the user
/// enters a new job". The USS rule of [SINAMICS CU240S] p. 229 is to send AK 0 "no
/// request" when only the PZD matter. Both are offered; the USS rule is the default because a
/// repeated write makes the drive execute it again on every poll (and, with an EEPROM task,
/// wears its EEPROM).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PkwAfterJob {
    /// Send AK 0 "no task" (PKE, IND and PWE all 0) once the job has ended ([SINAMICS CU240S] p.
    /// 229).
    #[default]
    TaskZero,
    /// Send the last job's PKW area again in every poll of that slave until a new job is
    /// entered, as the module's S_USST does ([Modbus/USS] §3.7.7). Responses to the
    /// repetitions end no job. A drive that sends its parameter change reports only in answer
    /// to AK 0 (as this crate's simulated drive does) cannot report while the task repeats.
    RepeatLast,
}

/// How the USS master runs.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct MasterConfig {
    /// Character format and speed (USS: 8E1, see [`uss_settings`]).
    pub settings: SerialSettings,
    /// The polling list, in cycle order.
    pub polling_list: Vec<PollEntry>,
    /// How long to wait for the response's STX after the request's last character: the USS spec's
    /// 20 ms ([USS spec] §5.2.2, "node x does not transmit after 20 ms"). Longer values (up to
    /// 10 s) are for converters and device servers that add latency.
    #[serde(rename = "response_timeout_ms", with = "si_core::time::millis")]
    pub response_timeout: Duration,
    /// WDH, the permitted PKW **repetitions after the first telegram** (0…32 767,
    /// [Modbus/USS] §3.7.6, Table 3-31, §3.7.8): a job goes out at most `1 + retries` times;
    /// when the last of them brings no matching response the job fails, with "node does not
    /// answer" (16#1408) if the node never answered during the job, else with the PKW
    /// interface error (16#1505). WDH = 2 therefore puts at most 3 telegrams of one job to a
    /// silent node on the line.
    ///
    /// **Reading chosen:** the manual says "permitted PKW job retries"; we count retries the
    /// way the word says, as telegrams after the first one.
    pub retries: u16,
    /// What the PKW area carries once a job has ended: AK 0 "no task" (the default) or the last
    /// job again, as the module's FCs do ([`PkwAfterJob`]).
    #[serde(default)]
    pub pkw_after_job: PkwAfterJob,
    /// Extra pause after each complete cycle (0 = poll back to back).
    #[serde(rename = "cycle_pause_ms", with = "si_core::time::millis")]
    pub cycle_pause: Duration,
    /// The transceiver hears our own transmission (an RS-485 bus, the simulator's bus): discard
    /// as many received characters as we sent before looking for the response.
    pub local_echo: bool,
}

impl MasterConfig {
    /// A master polling `polling_list` at 9600 8E1 with the USS defaults (20 ms response timeout,
    /// 20 PKW repetitions, AK 0 after a job, no pause, no echo).
    pub fn new(polling_list: Vec<PollEntry>) -> Self {
        MasterConfig {
            settings: SerialSettings::default(),
            polling_list,
            response_timeout: RESPONSE_DELAY_MAX,
            retries: 20,
            pkw_after_job: PkwAfterJob::TaskZero,
            cycle_pause: Duration::ZERO,
            local_echo: false,
        }
    }

    /// Check every parameter against its range; the first error found.
    pub fn validate(&self) -> Result<(), ConfigError> {
        match self.validate_all().into_iter().next() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// Like [`validate`](Self::validate), but every error, so a parameter file with several
    /// wrong values is reported in one go.
    pub fn validate_all(&self) -> Vec<ConfigError> {
        let mut errors = Vec::new();
        let n = self.polling_list.len();
        errors.extend(
            check(
                (1..=MAX_ENTRIES).contains(&n),
                "SANZ (polling list entries)",
                n,
                "1…31",
            )
            .err(),
        );
        for (i, e) in self.polling_list.iter().enumerate() {
            errors.extend(
                [
                    check(
                        e.address <= MAX_ADDRESS,
                        "TNU (node number)",
                        e.address,
                        "0…31",
                    ),
                    check(
                        usize::from(e.pzd_words) <= MAX_PZD_WORDS,
                        "PZD words",
                        e.pzd_words,
                        "0…16",
                    ),
                    check(
                        e.net_len() <= MAX_NET,
                        "net data bytes",
                        e.net_len(),
                        "0…252",
                    ),
                ]
                .into_iter()
                .filter_map(Result::err),
            );
            if self.polling_list[..i]
                .iter()
                .any(|o| o.address == e.address && (o.pkw, o.pzd_words) != (e.pkw, e.pzd_words))
            {
                errors.push(ConfigError::ConflictingStructure { address: e.address });
            }
        }
        let t = self.response_timeout;
        errors.extend(
            [
                check(
                    t >= Duration::from_millis(1) && t <= Duration::from_secs(10),
                    "response timeout",
                    t,
                    "1 ms … 10 s",
                ),
                check(
                    self.retries <= 32_767,
                    "WDH (PKW repetitions)",
                    self.retries,
                    "0…32767",
                ),
                check(
                    self.cycle_pause <= Duration::from_secs(60),
                    "cycle pause",
                    self.cycle_pause,
                    "0 … 60 s",
                ),
            ]
            .into_iter()
            .filter_map(Result::err),
        );
        errors
    }

    /// Start interval: 2 character times of silence before every STX ([USS spec] §5.1.2).
    pub fn start_interval(&self) -> Duration {
        start_interval(&self.settings)
    }

    /// What a port that hands bytes over in packets may add to any time judged on the host:
    /// the longest latency a USB adapter has plus one character ([`si_core::delivery`]'s
    /// patience and allowance at their largest). The bounds' margin.
    pub fn port_margin(&self) -> Duration {
        si_core::delivery::MAX_LATENCY + self.settings.char_time()
    }

    /// Host bound: the longest a telegram may occupy the line, its STX and the
    /// residual run time of the longest net data, 1 + 1.5 × (252 + 3) character times
    /// ([USS spec] §5.2.1.2, plus [`port_margin`](Self::port_margin).
    pub fn max_telegram_duration(&self) -> Duration {
        self.settings.char_time() + residual_run_time(&self.settings, MAX_NET) + self.port_margin()
    }

    /// Host bound: how long a poll waits for the start interval of silence before
    /// it sends anyway, [`start_interval`](Self::start_interval) +
    /// [`max_telegram_duration`](Self::max_telegram_duration). Any telegram on the line has
    /// ended by then; a line still busy carries noise, which a master would wait out forever.
    pub fn max_wait_for_silence(&self) -> Duration {
        self.start_interval() + self.max_telegram_duration()
    }

    /// Host bound on one poll, from the moment it is due to its response, "no answer" or
    /// rejection, whatever the line does:
    /// [`max_wait_for_silence`](Self::max_wait_for_silence) + the request's wire time
    /// (at most 256 characters) + the response timeout + [`port_margin`](Self::port_margin) (the
    /// STX may reach us a port latency late) + [`max_telegram_duration`](Self::max_telegram_duration)
    /// (the response's rest within its residual run time).
    pub fn poll_bound(&self) -> Duration {
        self.max_wait_for_silence()
            + self.settings.chars_time(crate::frame::MAX_TELEGRAM as u64)
            + self.response_timeout
            + self.port_margin()
            + self.max_telegram_duration()
    }

    /// Host bound on one cycle: every entry's [`poll_bound`](Self::poll_bound) plus the cycle
    /// pause. (A broadcast or mirror telegram slipped in adds one poll bound each.)
    pub fn cycle_bound(&self) -> Duration {
        self.poll_bound()
            .saturating_mul(self.polling_list.len() as u64)
            + self.cycle_pause
    }

    /// Host bound on a parameter job, from [`Master::request_parameter`] to its end:
    /// `(WDH + 2) ×` [`cycle_bound`](Self::cycle_bound). The job goes out with its slave's next
    /// poll (within one cycle) and at most 1 + WDH times, once per cycle ([Modbus/USS] §3.7.8).
    ///
    /// [`Master::request_parameter`]: crate::master::Master::request_parameter
    pub fn job_bound(&self) -> Duration {
        self.cycle_bound()
            .saturating_mul(u64::from(self.retries) + 2)
    }
}

/// Start interval of a line: 2 character times ([USS spec] §5.1.2.
pub fn start_interval(settings: &SerialSettings) -> Duration {
    settings.chars_time(2)
}

/// Residual run time for `n` net bytes: 1.5 × (n + 3) character times, counted from the end of STX
/// ([USS spec] §5.2.1.2, rounded up to a microsecond.
pub fn residual_run_time(settings: &SerialSettings, n: usize) -> Duration {
    let three_halves = settings.chars_time(3 * (n as u64 + 3)).as_micros();
    Duration::from_micros(three_halves.div_ceil(2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_matches_the_uss_spec_table() {
        // [USS spec] §5.1.2: start interval 9600: 2.30 ms; 19200: 1.15 ms; 38400: 0.58 ms; 187500:
        // 0.12 ms.
        let ms = |baud| start_interval(&uss_settings(baud).unwrap()).as_micros();
        assert_eq!(ms(9_600), 2_292);
        assert_eq!(ms(19_200), 1_146);
        assert_eq!(ms(38_400), 573);
        assert_eq!(ms(187_500), 118);
        // 16-byte telegram at 9600: 1.5 × 15 × 1.1458 ms = 25.78 ms.
        let r = residual_run_time(&uss_settings(9_600).unwrap(), 12);
        assert_eq!(r.as_micros(), 25_782);
    }

    #[test]
    fn out_of_range_names_parameter_range_and_value() {
        let mut c = MasterConfig::new(vec![PollEntry::new(32, PkwWords::Four, 2)]);
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "TNU (node number) = 32 is out of range: 0…31"
        );
        c.polling_list = vec![];
        assert!(c.validate().unwrap_err().to_string().starts_with("SANZ"));
        c.polling_list = vec![PollEntry::new(1, PkwWords::Four, 17)];
        assert!(c.validate().unwrap_err().to_string().contains("0…16"));
        c.polling_list = vec![
            PollEntry::new(1, PkwWords::Four, 2),
            PollEntry::new(1, PkwWords::Three, 2),
        ];
        assert_eq!(
            c.validate().unwrap_err(),
            ConfigError::ConflictingStructure { address: 1 }
        );
        assert!(uss_settings(187_500).is_ok());
        assert!(uss_settings(187_000).is_err());
    }

    #[test]
    fn validate_all_reports_every_error() {
        let mut c = MasterConfig::new(vec![
            PollEntry::new(32, PkwWords::Four, 2),
            PollEntry::new(3, PkwWords::Four, 17),
        ]);
        c.retries = 40_000;
        let all: Vec<String> = c.validate_all().iter().map(|e| e.to_string()).collect();
        assert_eq!(all.len(), 3, "{all:?}");
        assert!(all[0].starts_with("TNU"));
        assert!(all[1].starts_with("PZD words"));
        assert!(all[2].starts_with("WDH"));
        assert_eq!(c.validate().unwrap_err().to_string(), all[0]);
        assert!(
            MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)])
                .validate_all()
                .is_empty()
        );
    }
}
