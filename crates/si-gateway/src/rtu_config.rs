//! The keys of a `kind = "modbus-rtu"` line (the default kind): retries, pause, response
//! timeout, queue, broadcasts and the RTU framing; checked into [`RtuLine`].
//!
//! Ranges and defaults: the response timeout is the module's "Response Time", 50–655 000 ms
//! ([Modbus/USS] §3.4.3, Table 3-17, the range `si_modbus::MasterConfig::validate` checks);
//! retries and the pause between requests have no module counterpart (the module has no
//! retries, [Modbus/USS] §3.4.3, Table 3-17) and follow mbusd (`src/conn.h`: `DEFAULT_MAXTRY`
//! 3 tries = 2 retries, `MAX_MAXTRY` 15, `DEFAULT_RQSTPAUSE` 100 ms, `MAX_RQSTPAUSE`
//! 10 000 ms, `DEFAULT_RESPWAIT` 500 ms). mbusd's pause is 1–10 000 ms; we also allow 0.

use crate::demotion::DemotionConfig;
use crate::port_config::{
    check_baud, check_exchange, check_pause, check_queue, line_file, parse_unit_map,
};
use si_core::RangeError;
use std::time::Duration;

line_file! {
    /// One `[[line]]` of kind `modbus-rtu`, as written.
    pub struct RtuFile {
        /// Retries after a timeout or a corrupt answer (0–15, default 2).
        pub retries: Option<u8>,
        /// Pause between the end of one request and the next (ms, 0–10 000, default 100).
        pub pause_ms: Option<u64>,
        /// Response timeout (ms, 50–655 000, default 500).
        pub response_timeout_ms: Option<u32>,
        /// Forward broadcasts (unit 0) to this line.
        #[serde(default)]
        pub broadcast: bool,
        /// Requests waiting for this line at most (1–1024, default 32); one more is refused
        /// with exception 06.
        pub queue: Option<usize>,
        /// The character delay multiplier 1–10, end-of-frame gap = table value × it
        /// ([Modbus/USS] §3.3.5, Table 3-11; default 1).
        pub char_delay_multiplier: Option<u8>,
        /// `gap` (the module's: an answer ends after the end-of-frame gap, the default) or
        /// `length` (host extension: also at the length its header predicts, once its CRC
        /// checks).
        pub frame_end: Option<String>,
        /// The silence that ends a frame and precedes a request: `spec` (the Modbus
        /// specification's t3.5, 1.75 ms at 19200 bit/s and above, [Modbus serial] §2.5.1.1;
        /// the default) or `module` (the module's Table 3-11 gap × `char_delay_multiplier`,
        /// [Modbus/USS] §3.3.5; the default when `char_delay_multiplier` is given).
        pub frame_gap: Option<String>,
        /// After a slave did not answer, the next request waits until the line has been
        /// silent this long, 0–655000 ms (default: the line's response timeout; 0: off), and
        /// what arrives meanwhile is discarded and counted, so a late answer never reaches
        /// another request (si-modbus's quiet guard, bounded by this + the longest response).
        pub quiet_after_timeout_ms: Option<u32>,
        /// TCP unit ids mapped to slave addresses on this line, e.g. `{ 11 = 1, 12 = 2 }`:
        /// unit 11 reaches the slave at address 1, and its answer carries unit id 11 back.
        /// So slaves of the same address on two lines are told apart. The mapped unit ids
        /// are served besides `units` (which may then be left out); a unit id in both is
        /// refused.
        pub unit_map: Option<std::collections::BTreeMap<String, u8>>,
        /// Failed requests in a row that demote a unit, 0–255 (default 3; 0: never demoted;
        /// [`crate::demotion`]).
        pub demote_after: Option<u32>,
        /// How long a demoted unit's requests are answered 0BH at once before one probes
        /// it, 1–3 600 000 ms (default 30 000).
        pub demote_for_ms: Option<u64>,
    }
}

/// How a Modbus RTU line's master recognises the end of an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtuFraming {
    /// fMUL 1–10 ([Modbus/USS] §3.3.5, Table 3-11).
    pub char_delay_multiplier: u8,
    /// At the gap, or also at the predicted length (the default: an answer is handed back
    /// when its last byte is in, and a pause inside it is waited out, as mbusd does; the
    /// module's gap-only framing stays an option).
    pub frame_end: si_modbus::FrameEnd,
    /// The specification's t3.5 (`true`) or the module's gap.
    pub spec_gap: bool,
    /// Silence kept after a timeout before the next request, in ms (`None`: the line's
    /// response timeout).
    pub quiet_after_timeout_ms: Option<u32>,
}

impl Default for RtuFraming {
    fn default() -> Self {
        RtuFraming {
            char_delay_multiplier: 1,
            frame_end: si_modbus::FrameEnd::Length,
            spec_gap: true,
            quiet_after_timeout_ms: None,
        }
    }
}

/// A checked Modbus RTU line's own settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RtuLine {
    /// Retries.
    pub retries: u8,
    /// Pause between requests.
    pub pause: Duration,
    /// Response timeout.
    pub response_timeout: Duration,
    /// Broadcasts forwarded.
    pub broadcast: bool,
    /// Queue length.
    pub queue: usize,
    /// Framing.
    pub framing: RtuFraming,
    /// TCP unit id → slave address, for the unit ids remapped (`unit_map`).
    pub unit_map: Vec<(u8, u8)>,
    /// Auto-demotion of units that stop answering.
    pub demotion: DemotionConfig,
}

impl RtuFile {
    /// Check the line's own keys (the shared ones are checked by the caller).
    pub fn check(&self) -> Result<RtuLine, RangeError> {
        let (retries, response_timeout) =
            check_exchange(self.retries, 2, self.response_timeout_ms, 500)?;
        let pause = check_pause(self.pause_ms, 100)?;
        let queue = check_queue(self.queue)?;
        check_baud(self.baud.unwrap_or(9600), &si_core::BAUD_RATES)?;
        Ok(RtuLine {
            retries,
            pause,
            response_timeout: response_timeout.into(),
            broadcast: self.broadcast,
            queue,
            framing: self.framing()?,
            unit_map: parse_unit_map(self.unit_map.as_ref())?,
            demotion: self.demotion()?,
        })
    }

    /// `demote_after` and `demote_for_ms`, checked. The ranges are ours `[derived]`: up to 255
    /// failures, up to an hour demoted.
    fn demotion(&self) -> Result<DemotionConfig, RangeError> {
        let mut d = DemotionConfig::default();
        if let Some(n) = self.demote_after {
            RangeError::check("demote_after", (0, 255), "", n)?;
            d.demote_after = n;
        }
        if let Some(ms) = self.demote_for_ms {
            RangeError::check("demote_for_ms", (1, 3_600_000), " ms", ms)?;
            d.demote_for = si_core::Duration::from_millis(ms);
        }
        Ok(d)
    }

    /// `char_delay_multiplier`, `frame_end`, `frame_gap` and `quiet_after_timeout_ms`,
    /// checked (the ranges of `si modbus`'s flags).
    fn framing(&self) -> Result<RtuFraming, RangeError> {
        let char_delay_multiplier = self.char_delay_multiplier.unwrap_or(1);
        RangeError::check("char_delay_multiplier", (1, 10), "", char_delay_multiplier)?;
        let frame_end = match self.frame_end.as_deref() {
            Some("gap") => si_modbus::FrameEnd::Gap,
            None | Some("length") => si_modbus::FrameEnd::Length,
            Some(other) => return Err(RangeError::new("frame_end", "gap or length", "", other)),
        };
        let spec_gap = match (self.frame_gap.as_deref(), self.char_delay_multiplier) {
            (None, None) | (Some("spec"), None) => true,
            (None | Some("module"), _) => false,
            (Some("spec"), Some(_)) => {
                return Err(RangeError::new(
                    "frame_gap",
                    "module where char_delay_multiplier is given",
                    "",
                    "spec",
                ))
            }
            (Some(other), _) => {
                return Err(RangeError::new("frame_gap", "spec or module", "", other))
            }
        };
        if let Some(q) = self.quiet_after_timeout_ms {
            RangeError::check("quiet_after_timeout_ms", (0, 655_000), " ms", q)?;
        }
        Ok(RtuFraming {
            char_delay_multiplier,
            frame_end,
            spec_gap,
            quiet_after_timeout_ms: self.quiet_after_timeout_ms,
        })
    }
}
