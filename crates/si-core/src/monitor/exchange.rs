//! Requests and their answers on a master–slave line (Modbus RTU, USS), as a listener tells
//! them apart without knowing who is master.
//!
//! Reading chosen (the same for every such protocol): a frame is the **answer** when a request
//! waits and the frame comes from another station (or the capture is one-sided, so senders are
//! unknown); otherwise it is a new request, and a request still waiting went unanswered. A
//! request whose answer did not come in time is kept as *late*: a frame from another station
//! that answers it is a late answer, not a new request.

use crate::Instant;

/// A request a listener saw: who sent it, when its last character ended, and what it asked
/// (`T`: the protocol's address and function).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Request<T> {
    /// The sender's station index.
    pub from: Option<usize>,
    /// The end of its last character.
    pub end: Instant,
    /// What it asked.
    pub what: T,
}

/// The request waiting for its answer, and the one whose answer is overdue.
#[derive(Debug, Clone)]
pub struct Exchange<T> {
    waiting: Option<Request<T>>,
    late: Option<Request<T>>,
    one_sided: bool,
}

impl<T: Copy> Exchange<T> {
    /// Nothing waiting; `one_sided` when every frame comes from the same (unknown) sender.
    pub fn new(one_sided: bool) -> Self {
        Exchange {
            waiting: None,
            late: None,
            one_sided,
        }
    }

    /// Whether a frame from `from` is the answer to the waiting request.
    pub fn is_answer(&self, from: Option<usize>) -> bool {
        self.waiting
            .as_ref()
            .is_some_and(|w| self.one_sided || w.from != from)
    }

    /// The waiting request, if `overdue` says its answer is overdue: from now on it is the late
    /// one. Returned for the listener's note.
    pub fn expire(&mut self, overdue: impl FnOnce(&Request<T>) -> bool) -> Option<Request<T>> {
        if self.waiting.as_ref().is_some_and(overdue) {
            self.late = self.waiting.take();
            return self.late;
        }
        None
    }

    /// A frame from `from` that is not the answer: the overdue request it answers late, if
    /// `answers` says it does; otherwise the overdue request is forgotten.
    pub fn late_answer(
        &mut self,
        from: Option<usize>,
        answers: impl FnOnce(&T) -> bool,
    ) -> Option<Request<T>> {
        let late = self.late.take()?;
        ((self.one_sided || late.from != from) && answers(&late.what)).then_some(late)
    }

    /// The waiting request, taken: answered, or gone unanswered.
    pub fn take(&mut self) -> Option<Request<T>> {
        self.waiting.take()
    }

    /// `request` now waits for its answer.
    pub fn wait_for(&mut self, request: Request<T>) {
        self.waiting = Some(request);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(from: usize, end: u64, what: u8) -> Request<u8> {
        Request {
            from: Some(from),
            end: Instant::from_micros(end),
            what,
        }
    }

    #[test]
    fn the_answer_comes_from_the_other_station_and_a_late_one_is_recognised() {
        let mut x = Exchange::new(false);
        assert!(!x.is_answer(Some(1)), "nothing waits");
        x.wait_for(req(0, 100, 7));
        assert!(x.is_answer(Some(1)));
        assert!(!x.is_answer(Some(0)), "the master again: a new request");
        assert_eq!(x.expire(|r| r.end.as_micros() < 50), None);
        assert_eq!(x.expire(|r| r.end.as_micros() < 500), Some(req(0, 100, 7)));
        assert!(!x.is_answer(Some(1)), "nothing waits any more");
        assert_eq!(
            x.late_answer(Some(1), |&what| what == 7),
            Some(req(0, 100, 7))
        );
        assert_eq!(x.late_answer(Some(1), |_| true), None, "answered once");
    }

    #[test]
    fn a_frame_that_does_not_answer_forgets_the_late_request() {
        let mut x = Exchange::new(false);
        x.wait_for(req(0, 100, 7));
        x.expire(|_| true);
        assert_eq!(x.late_answer(Some(1), |&what| what == 8), None);
        assert_eq!(x.late_answer(Some(1), |&what| what == 7), None);
        // One-sided: the sender does not matter.
        let mut x = Exchange::new(true);
        x.wait_for(req(0, 100, 7));
        assert!(x.is_answer(Some(0)));
        assert_eq!(x.take(), Some(req(0, 100, 7)));
        assert_eq!(x.take(), None);
    }
}
