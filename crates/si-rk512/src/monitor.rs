//! Passive RK 512 decoding: the 3964(R) monitor ([`si_3964r::monitor`]) with every block's user
//! data read as an RK 512 telegram ([CP 341] §2.2.3, §2.3.2: command, continuation and
//! reaction telegrams), decoded by this crate's own [`crate::frame::Telegram::decode`].
//!
//! The timers are those of the 3964(R) link under the station ([`Config::link`]).
//!
//! ```
//! use si_rk512::monitor;
//! use si_core::monitor::Decoder;
//!
//! let m = monitor::new(&si_rk512::Config::default(), si_core::SerialSettings::default());
//! assert_eq!(m.counters().0["RK 512 telegrams"], 0);
//! ```

use crate::frame::Telegram;
use crate::Config;
use si_3964r::monitor::{Described, Monitor, Params, Payload};
use si_core::SerialSettings;

/// The 3964(R) monitor's reading of RK 512 telegrams.
pub const PAYLOAD: Payload = Payload {
    ok_counter: "RK 512 telegrams",
    error_counter: "RK 512 errors",
    describe,
};

/// The monitor for a line with `line`'s character format that a station with `config` runs
/// on.
pub fn new(config: &Config, line: SerialSettings) -> Monitor {
    Monitor::new(params(&config.link, line))
}

/// The 3964(R) monitor's parameters for `link` on `line` with RK 512 telegrams in its blocks.
pub fn params(link: &si_3964r::Config, line: SerialSettings) -> Params {
    Params {
        payload: Some(PAYLOAD),
        ..Params::from_config(link, line)
    }
}

fn describe(payload: &[u8]) -> Described {
    match Telegram::decode(payload) {
        Ok(t) => Ok((short_rk512(&t), format!("RK 512 {}", describe_rk512(&t)))),
        Err(e) => Err(format!("RK 512: {e}")),
    }
}

/// A diagram label for an RK 512 telegram: `SEND DB10 DW0`, `reaction 00H`.
fn short_rk512(t: &Telegram<'_>) -> String {
    match t {
        Telegram::Command(h, data) => format!("{:?} {} ({} B)", h.command, h.address, data.len()),
        Telegram::Continuation(h, data) => format!("cont. {:?} ({} B)", h.command, data.len()),
        Telegram::Reaction(h, data) => format!("reaction {:02X}H ({} B)", h.error, data.len()),
    }
}

fn describe_rk512(t: &Telegram<'_>) -> String {
    match t {
        Telegram::Command(h, data) => format!("{h:?}, {} B data", data.len()),
        Telegram::Continuation(h, data) => format!("continuation {h:?}, {} B data", data.len()),
        Telegram::Reaction(h, data) => format!("reaction {h:?}, {} B data", data.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_send_command_reads_as_rk512_and_garbage_is_counted_as_an_error() {
        let (label, text) =
            describe(&[0, 0, b'A', b'D', 10, 0, 0, 1, 0xFF, 0xFF, 0x12, 0x34]).unwrap();
        assert!(text.starts_with("RK 512 "), "{text}");
        assert!(label.ends_with("(2 B)"), "{label}");
        assert!(describe(&[0x55]).unwrap_err().starts_with("RK 512: "));
    }
}
