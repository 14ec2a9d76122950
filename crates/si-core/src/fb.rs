//! Helpers that give the FB equivalents the S7 call semantics (et200s-si-3964r-ascii.md §8.1,
//! §8.9): REQ is edge-triggered, R resets, EN_R is a level, and DONE / NDR / ERROR / STATUS are
//! valid for exactly one call.
//!
//! ```
//! use si_core::fb::{Pulse, RisingEdge};
//!
//! let mut req = RisingEdge::default();
//! assert!(req.update(true));   // FALSE → TRUE: start a job
//! assert!(!req.update(true));  // still TRUE: nothing new
//! assert!(!req.update(false));
//! assert!(req.update(true));   // a new edge
//!
//! let mut done = Pulse::default();
//! done.fire(0x0000u16);
//! assert_eq!(done.take(), Some(0x0000)); // the call that sees it
//! assert_eq!(done.take(), None);         // the next call does not
//! ```

/// R_TRIG: true on the call where the input goes from FALSE to TRUE.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RisingEdge {
    last: bool,
}

impl RisingEdge {
    /// Feed this call's input level; true on a rising edge.
    pub fn update(&mut self, input: bool) -> bool {
        let edge = input && !self.last;
        self.last = input;
        edge
    }

    /// Forget the last level (after R): the next TRUE counts as an edge.
    pub fn reset(&mut self) {
        self.last = false;
    }
}

/// An output that is set by one event and visible to exactly one FB call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pulse<T> {
    pending: Option<T>,
}

impl<T> Default for Pulse<T> {
    fn default() -> Self {
        Pulse { pending: None }
    }
}

impl<T> Pulse<T> {
    /// Arm the pulse for the next call. A second `fire` before that call replaces the first,
    /// as a PLC output would be overwritten.
    pub fn fire(&mut self, value: T) {
        self.pending = Some(value);
    }

    /// The value for this call, if any; afterwards the pulse is clear.
    pub fn take(&mut self) -> Option<T> {
        self.pending.take()
    }

    /// True if the next `take` returns a value.
    pub fn is_armed(&self) -> bool {
        self.pending.is_some()
    }
}

/// DONE / ERROR / STATUS of an FB without data outputs (S_VSET, S_XON, S_RTS, S_V24, and
/// S_SEND through the window), valid for the one call that returns it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Done {
    /// The job completed without error (this call only).
    pub done: bool,
    /// The job completed with an error (this call only).
    pub error: bool,
    /// 0000H, or the error.
    pub status: crate::Status,
}

impl Default for Done {
    /// Nothing completed in this call: DONE and ERROR false, STATUS 0000H.
    fn default() -> Self {
        Done {
            done: false,
            error: false,
            status: crate::Status::OK,
        }
    }
}

impl Done {
    /// DONE for this call.
    pub fn ok() -> Self {
        Done {
            done: true,
            ..Done::default()
        }
    }

    /// ERROR with `status` for this call.
    pub fn failed(status: crate::Status) -> Self {
        Done {
            error: true,
            status,
            ..Done::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reset_makes_a_held_req_count_again() {
        let mut e = RisingEdge::default();
        assert!(e.update(true));
        e.reset();
        assert!(e.update(true));
    }

    #[test]
    fn pulse_is_overwritten_not_queued() {
        let mut p = Pulse::default();
        p.fire(1);
        p.fire(2);
        assert!(p.is_armed());
        assert_eq!(p.take(), Some(2));
        assert!(!p.is_armed());
    }
}
