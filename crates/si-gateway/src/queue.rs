//! One line's bounded request queue with fair order: round-robin between clients.
//!
//! The Modbus TCP server answers one request per connection at a time, so today a client has
//! at most one request waiting and plain FIFO order would already alternate; the rotation
//! keeps the order fair if a client could ever queue several (pipelining), so that one busy
//! client cannot starve the others.

use std::collections::VecDeque;

/// Requests waiting for a line, at most `capacity` of them.
#[derive(Debug)]
pub struct FairQueue<T> {
    entries: VecDeque<(u64, T)>,
    capacity: usize,
    /// The client served last: the next pop prefers the next client id after it.
    last: Option<u64>,
}

impl<T> FairQueue<T> {
    /// An empty queue holding at most `capacity` requests. Room is taken as requests wait,
    /// not up front: a gateway line's job is ~300 bytes, so the default 32 slots reserved per
    /// line were 9.5 KiB of each idle line's memory (BENCHMARKS.md "Lines per
    /// process"); `push` keeps the bound.
    pub fn new(capacity: usize) -> Self {
        FairQueue {
            entries: VecDeque::new(),
            capacity,
            last: None,
        }
    }

    /// Queue `item` for `client`; a full queue gives it back (the caller answers 06H).
    pub fn push(&mut self, client: u64, item: T) -> Result<(), T> {
        if self.entries.len() >= self.capacity {
            return Err(item);
        }
        self.entries.push_back((client, item));
        Ok(())
    }

    /// The oldest request of the next client in rotation (ascending client ids, wrapping).
    pub fn pop(&mut self) -> Option<(u64, T)> {
        let after = self.last;
        let next = self
            .entries
            .iter()
            .map(|(c, _)| *c)
            .filter(|&c| after.is_none_or(|l| c > l))
            .min()
            .or_else(|| self.entries.iter().map(|(c, _)| *c).min())?;
        let at = self.entries.iter().position(|(c, _)| *c == next)?;
        self.last = Some(next);
        self.entries.remove(at)
    }

    /// Requests waiting.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// No request waiting.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clients_take_turns_and_each_keeps_its_own_order() {
        let mut q = FairQueue::new(8);
        for (c, v) in [
            (1, "a1"),
            (1, "a2"),
            (1, "a3"),
            (2, "b1"),
            (3, "c1"),
            (2, "b2"),
        ] {
            q.push(c, v).unwrap();
        }
        let order: Vec<_> = std::iter::from_fn(|| q.pop().map(|(_, v)| v)).collect();
        assert_eq!(order, ["a1", "b1", "c1", "a2", "b2", "a3"]);
    }

    #[test]
    fn an_idle_queue_reserves_no_room() {
        let mut q = FairQueue::new(1024);
        assert_eq!(q.entries.capacity(), 0);
        q.push(1, [0u8; 300]).unwrap();
        assert!(q.entries.capacity() < 1024);
    }

    #[test]
    fn a_full_queue_gives_the_request_back() {
        let mut q = FairQueue::new(2);
        q.push(1, 1).unwrap();
        q.push(2, 2).unwrap();
        assert_eq!(q.push(3, 3), Err(3));
        assert_eq!(q.len(), 2);
        q.pop();
        assert!(q.push(3, 3).is_ok());
    }
}
