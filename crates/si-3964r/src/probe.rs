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

use crate::frame::{DLE, NAK, STX};

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
    }
}
