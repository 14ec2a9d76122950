//! One frame pool for every engine: frames handed out as [`Bytes`] without an allocation per
//! frame in steady state. Mostly transmit frames handed to the driver (the transmit-buffer
//! pool); the 3964(R) and ASCII links cut the received frames they hand to the
//! application from one the same way.
//!
//! An engine writes a frame into the pool, which cuts it off as [`Bytes`]
//! (`split().freeze()`). The frame shares the pool's allocation; once the driver has dropped
//! it (and every earlier frame), the next [`FramePool::cut`] that runs out of room gets the same
//! allocation back through `BytesMut::reserve`, so a line where each frame is gone before the
//! next is cut allocates nothing after the first frame. Only while an earlier frame is still
//! held (a slow driver, a test keeping frames) does the pool move to a new allocation of
//! [`FramePool::chunk`] bytes.

use bytes::{Bytes, BytesMut};

/// A kept [`BytesMut`] that frames are cut from (module docs).
#[derive(Debug, Clone)]
pub struct FramePool {
    buf: BytesMut,
    /// Bytes allocated at a time: the engine's choice, a few of its longest frames, so a frame
    /// still held while the next is cut rarely makes the pool move.
    chunk: usize,
}

impl FramePool {
    /// A pool that allocates `chunk` bytes at its first [`cut`](Self::cut) (nothing before):
    /// for engines that may never transmit.
    pub fn new(chunk: usize) -> Self {
        FramePool {
            buf: BytesMut::new(),
            chunk,
        }
    }

    /// A pool that allocates its `chunk` bytes now, so the first frame does not allocate
    /// either.
    pub fn preallocated(chunk: usize) -> Self {
        FramePool {
            buf: BytesMut::with_capacity(chunk),
            chunk,
        }
    }

    /// Bytes the pool allocates at a time.
    pub fn chunk(&self) -> usize {
        self.chunk
    }

    /// `frame` as [`Bytes`] cut from the pool. When the pool has run out of room it reserves
    /// a chunk, which reclaims its allocation if every frame cut from it has been dropped. A
    /// frame longer than the chunk grows the chunk to twice that frame (room for it and the
    /// next), so the pool stays bounded by twice the engine's longest frame or its chunk.
    pub fn cut(&mut self, frame: &[u8]) -> Bytes {
        self.make_room(frame.len());
        self.buf.extend_from_slice(frame);
        self.buf.split().freeze()
    }

    /// A frame of `len` bytes written in place by `fill` (for a source that copies into a
    /// slice, like a ring buffer), cut as [`cut`](Self::cut) does. `fill` returning `false`
    /// leaves nothing cut and gives `None`.
    pub fn cut_filled(
        &mut self,
        len: usize,
        fill: impl FnOnce(&mut [u8]) -> bool,
    ) -> Option<Bytes> {
        self.make_room(len);
        self.buf.resize(len, 0);
        if !fill(&mut self.buf) {
            self.buf.clear();
            return None;
        }
        Some(self.buf.split().freeze())
    }

    /// Room for `len` more bytes: a chunk reserved when the pool has run out (reclaiming the
    /// allocation once its frames are dropped), the chunk grown for a frame longer than it.
    fn make_room(&mut self, len: usize) {
        if len > self.chunk {
            self.chunk = 2 * len;
        }
        if self.buf.capacity() < len {
            self.buf.reserve(self.chunk);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_come_out_as_written() {
        let mut pool = FramePool::new(8);
        assert_eq!(pool.cut(&[1, 2, 3]), Bytes::from_static(&[1, 2, 3]));
        assert_eq!(pool.cut(&[4]), Bytes::from_static(&[4]));
        assert_eq!(pool.cut(&[]), Bytes::new());
    }

    #[test]
    fn dropped_frames_give_their_allocation_back() {
        let mut pool = FramePool::preallocated(8);
        let first = pool.cut(&[1; 6]);
        let at = first.as_ptr();
        drop(first);
        // Only 2 bytes left: the pool must reserve and reclaims the same allocation.
        let second = pool.cut(&[2; 6]);
        assert_eq!(second.as_ptr(), at);
    }

    #[test]
    fn a_held_frame_keeps_its_bytes() {
        let mut pool = FramePool::preallocated(8);
        let first = pool.cut(&[1; 6]);
        let second = pool.cut(&[2; 6]);
        assert_ne!(second.as_ptr(), first.as_ptr());
        assert_eq!(&first[..], &[1; 6]);
        assert_eq!(&second[..], &[2; 6]);
    }

    #[test]
    fn a_filled_frame_is_cut_or_nothing_is() {
        let mut pool = FramePool::new(8);
        assert_eq!(
            pool.cut_filled(2, |b| {
                b.copy_from_slice(&[5, 6]);
                true
            }),
            Some(Bytes::from_static(&[5, 6]))
        );
        assert_eq!(pool.cut_filled(3, |_| false), None);
        assert_eq!(pool.cut(&[7]), Bytes::from_static(&[7]));
    }

    #[test]
    fn a_long_frame_grows_the_chunk_to_twice_its_length() {
        let mut pool = FramePool::new(4);
        assert_eq!(pool.cut(&[9; 10]).len(), 10);
        assert_eq!(pool.chunk(), 20);
    }
}
