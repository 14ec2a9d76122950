//! Items held until their turn, handed on in time order: what the line view of a streamed
//! trace (`line_stream`), the decoder's records (`ordered`) and si-capture's
//! streamed waveforms each need, since their inputs come out up to a known horizon late.

use crate::Instant;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// An item and its place: by instant, then a class (which of two items of one instant goes
/// first), then arrival.
struct Slot<T> {
    key: (Instant, u8, u64),
    item: T,
}

impl<T> PartialEq for Slot<T> {
    fn eq(&self, other: &Self) -> bool {
        self.key == other.key
    }
}
impl<T> Eq for Slot<T> {}
impl<T> PartialOrd for Slot<T> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<T> Ord for Slot<T> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.key.cmp(&other.key)
    }
}

/// Items held until their turn: ordered by instant, then class, then arrival (a stable sort's
/// order).
pub struct Reorder<T> {
    held: BinaryHeap<Reverse<Slot<T>>>,
    seq: u64,
}

impl<T> Default for Reorder<T> {
    fn default() -> Self {
        Reorder {
            held: BinaryHeap::new(),
            seq: 0,
        }
    }
}

impl<T> Reorder<T> {
    /// Hold `item` of instant `at`; of items of one instant, a lower `class` goes first.
    pub fn hold(&mut self, at: Instant, class: u8, item: T) {
        self.seq += 1;
        self.held.push(Reverse(Slot {
            key: (at, class, self.seq),
            item,
        }));
    }

    /// The first item held, if its instant is before `before`.
    pub fn pop_before(&mut self, before: Instant) -> Option<T> {
        let Reverse(first) = self.held.peek()?;
        if first.key.0 >= before {
            return None;
        }
        self.pop()
    }

    /// The first item held, whatever its instant (the end of the input).
    pub fn pop(&mut self) -> Option<T> {
        self.held.pop().map(|Reverse(s)| s.item)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_come_out_by_instant_then_class_then_arrival_and_only_before_the_horizon() {
        let at = Instant::from_micros;
        let mut r = Reorder::default();
        r.hold(at(20), 0, "late");
        r.hold(at(10), 1, "rts");
        r.hold(at(10), 0, "char a");
        r.hold(at(10), 0, "char b");
        assert_eq!(r.pop_before(at(10)), None);
        assert_eq!(r.pop_before(at(11)), Some("char a"));
        assert_eq!(r.pop_before(at(11)), Some("char b"));
        assert_eq!(r.pop_before(at(11)), Some("rts"));
        assert_eq!(r.pop_before(at(11)), None);
        assert_eq!(r.pop(), Some("late"));
        assert_eq!(r.pop(), None);
    }
}
