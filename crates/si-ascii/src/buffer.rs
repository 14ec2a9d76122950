//! The receive frame buffer: a 1024-byte ring holding whole frames of different lengths, oldest
//! first ([ET200S SI] §2.8).
//!
//! Received characters go straight into the ring behind the stored frames as a *pending* frame;
//! when the end criterion completes it is *committed*, when it fails it is discarded. Nothing is
//! allocated after construction: the ring and the length queue are sized for the worst case
//! (1024 one-byte frames).

use crate::config::RECEIVE_BUFFER_SIZE;
use std::collections::VecDeque;

// Positions wrap by `% RECEIVE_BUFFER_SIZE`, which is a mask only for a power of two.
const _: () = assert!(RECEIVE_BUFFER_SIZE.is_power_of_two());

/// The ring buffer of received frames.
#[derive(Debug, Clone)]
pub struct FrameBuffer {
    /// A fixed power-of-two size, so positions wrap with a mask rather than a division (every
    /// received character passes through [`FrameBuffer::push`]).
    data: Box<[u8; RECEIVE_BUFFER_SIZE]>,
    /// Index of the first byte of the oldest stored frame.
    head: usize,
    /// Bytes of stored (committed) frames.
    stored: usize,
    /// Bytes of the frame being received, after the stored ones.
    pending: usize,
    /// Length of each stored frame, oldest first.
    lens: VecDeque<u16>,
}

impl Default for FrameBuffer {
    fn default() -> Self {
        FrameBuffer::new()
    }
}

impl FrameBuffer {
    /// An empty 1024-byte buffer.
    pub fn new() -> Self {
        FrameBuffer {
            data: Box::new([0; RECEIVE_BUFFER_SIZE]),
            head: 0,
            stored: 0,
            pending: 0,
            lens: VecDeque::with_capacity(RECEIVE_BUFFER_SIZE),
        }
    }

    /// Total capacity in bytes.
    #[inline]
    pub fn capacity(&self) -> usize {
        RECEIVE_BUFFER_SIZE
    }

    /// Bytes in use: stored frames plus the frame being received.
    #[inline]
    pub fn fill(&self) -> usize {
        self.stored + self.pending
    }

    /// Bytes still free.
    #[inline]
    pub fn free(&self) -> usize {
        self.capacity() - self.fill()
    }

    /// Number of stored (complete) frames.
    #[inline]
    pub fn frames(&self) -> usize {
        self.lens.len()
    }

    /// Bytes of the frame being received.
    pub fn pending_len(&self) -> usize {
        self.pending
    }

    /// Length of the oldest stored frame.
    pub fn oldest_len(&self) -> Option<usize> {
        self.lens.front().map(|&l| usize::from(l))
    }

    /// More than 2/3 of the buffer in use: S_RCV's warning 0B01H ([ET200S SI] §2.8).
    pub fn above_two_thirds(&self) -> bool {
        self.fill() * 3 > self.capacity() * 2
    }

    /// Append one byte to the pending frame; false when the buffer is full.
    #[inline]
    pub fn push(&mut self, byte: u8) -> bool {
        if self.free() == 0 {
            return false;
        }
        let at = (self.head + self.stored + self.pending) % RECEIVE_BUFFER_SIZE;
        self.data[at] = byte;
        self.pending += 1;
        true
    }

    /// The pending frame is complete: store it.
    pub fn commit(&mut self) {
        if self.pending == 0 {
            return;
        }
        // A pending frame never exceeds the maximum frame length, which fits in u16.
        self.lens
            .push_back(u16::try_from(self.pending).unwrap_or(u16::MAX));
        self.stored += self.pending;
        self.pending = 0;
    }

    /// Forget the pending frame.
    pub fn discard_pending(&mut self) {
        self.pending = 0;
    }

    /// Drop the oldest stored frame (overwrite); its length, if there was one.
    pub fn drop_oldest(&mut self) -> Option<usize> {
        let len = usize::from(self.lens.pop_front()?);
        // Move the pending bytes' start along with the head: they follow the stored frames, and
        // the ring is addressed relative to `head`, so nothing needs copying.
        self.head = (self.head + len) % self.capacity();
        self.stored -= len;
        Some(len)
    }

    /// Copy the oldest stored frame into `out` and remove it; its length. `None` if no frame is
    /// stored or `out` is too short (then the frame stays).
    pub fn pop_into(&mut self, out: &mut [u8]) -> Option<usize> {
        let len = self.oldest_len()?;
        let dst = out.get_mut(..len)?;
        let first = len.min(self.capacity() - self.head);
        dst[..first].copy_from_slice(&self.data[self.head..self.head + first]);
        dst[first..].copy_from_slice(&self.data[..len - first]);
        self.drop_oldest();
        Some(len)
    }

    /// Remove everything, pending frame included.
    pub fn clear(&mut self) {
        self.head = 0;
        self.stored = 0;
        self.pending = 0;
        self.lens.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_come_out_oldest_first_across_the_wrap() {
        let mut b = FrameBuffer::new();
        let mut out = [0u8; 300];
        // Fill and empty repeatedly so the frames straddle the end of the ring.
        for round in 0..20u8 {
            for i in 0..150u8 {
                assert!(b.push(i ^ round));
            }
            b.commit();
            assert_eq!(b.pop_into(&mut out), Some(150));
            assert!(out[..150]
                .iter()
                .enumerate()
                .all(|(i, &x)| x == i as u8 ^ round));
        }
        assert_eq!(b.fill(), 0);
    }

    #[test]
    fn full_buffer_refuses_and_warns_above_two_thirds() {
        let mut b = FrameBuffer::new();
        for _ in 0..682 {
            assert!(b.push(1));
        }
        assert!(!b.above_two_thirds()); // 682/1024 < 2/3
        assert!(b.push(1));
        assert!(b.above_two_thirds()); // 683/1024 > 2/3
        while b.push(2) {}
        assert_eq!(b.fill(), 1024);
        b.discard_pending();
        assert_eq!(b.fill(), 0);
    }

    #[test]
    fn dropping_the_oldest_keeps_the_pending_frame() {
        let mut b = FrameBuffer::new();
        b.push(b'a');
        b.commit();
        b.push(b'b');
        b.push(b'c');
        assert_eq!(b.drop_oldest(), Some(1));
        b.commit();
        let mut out = [0u8; 4];
        assert_eq!(b.pop_into(&mut out), Some(2));
        assert_eq!(&out[..2], b"bc");
        assert_eq!(b.pop_into(&mut out), None);
    }

    #[test]
    fn too_short_output_leaves_the_frame() {
        let mut b = FrameBuffer::new();
        b.push(1);
        b.push(2);
        b.commit();
        assert_eq!(b.pop_into(&mut [0u8; 1]), None);
        assert_eq!(b.frames(), 1);
    }
}
