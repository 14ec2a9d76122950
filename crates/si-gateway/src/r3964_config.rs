//! The keys of a `kind = "3964r"` line: the 3964(R) link only (`priority`, default `high`;
//! `block_check`, default `true`; `ack_delay_ms`, 10 … 655 350, default 2000 or 550 without
//! block check: [ET200S SI] §2.7, Fig. 2-16, Table 2-11), with the port keys every line has. The
//! link's own bounds (block length 200 bytes, attempts) keep the manual's defaults.

use crate::port_config::line_file;
use si_core::RangeError;

line_file! {
    /// One `[[line]]` of kind `3964r`, as written.
    pub struct R3964File {
        /// 3964(R) priority, `high` (default) or `low`.
        pub priority: Option<String>,
        /// 3964R with block check (default), or plain 3964.
        pub block_check: Option<bool>,
        /// Acknowledgement delay time QVZ (ms).
        pub ack_delay_ms: Option<u32>,
    }
}

impl R3964File {
    /// Check the line's own keys: the link (the shared keys are checked by the caller).
    pub fn check(&self) -> Result<si_3964r::Config, RangeError> {
        let link = link(
            self.priority.as_deref(),
            self.block_check,
            self.ack_delay_ms,
            si_3964r::Priority::High,
        )?;
        link.validate()?;
        Ok(link)
    }
}

/// The 3964(R) link of an `rk512` or `3964r` line from its keys `priority` (default
/// `default`), `block_check` and `ack_delay_ms` (checked with the rest of the configuration).
pub fn link(
    priority: Option<&str>,
    block_check: Option<bool>,
    ack_delay_ms: Option<u32>,
    default: si_3964r::Priority,
) -> Result<si_3964r::Config, RangeError> {
    let mut link = si_3964r::Config::default();
    if block_check == Some(false) {
        link = si_3964r::Config::without_block_check();
    }
    link.priority = match priority {
        None => default,
        Some("low") => si_3964r::Priority::Low,
        Some("high") => si_3964r::Priority::High,
        Some(other) => return Err(RangeError::new("priority", "high or low", "", other)),
    };
    if let Some(q) = ack_delay_ms {
        link.ack_delay = si_core::Duration::from_millis(q.into());
    }
    Ok(link)
}
