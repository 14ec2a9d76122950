//! A [`Transport`] that shows a [`Watch`] everything passing through it, written once for every
//! observer of a live line: the decoded-frame log ([`crate::frame_log`]), a trace recorder
//! (`si --record`).
//!
//! The tap forwards every call to the transport it wraps and tells its watcher what was
//! written, what was read and which modem signals were set. On a port that marks line errors
//! (`PortFacts::marked_errors`, learnt when a driver attaches) the reads are decoded
//! ([`crate::linemark`]) so the watcher gets data runs and line errors, not marks.

use crate::driver::{PortFacts, Transport};
use crate::linemark::{MarkDecoder, Marked};
use crate::sansio::{ModemSignals, SignalUpdate};
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// What watches a line through a [`Tap`].
pub trait Watch {
    /// These bytes were written (the write has completed).
    fn written(&mut self, bytes: &[u8]);
    /// A read returned this piece: a data run or a line error in a character's place.
    fn read(&mut self, piece: Marked<'_>);
    /// The modem outputs were set.
    fn signals(&mut self, update: SignalUpdate) {
        let _ = update;
    }
    /// The transport was polled for reading (after any data it returned): the watcher may
    /// register a wake-up with `cx`, to act on silence.
    fn poll_idle(&mut self, cx: &mut Context<'_>) {
        let _ = cx;
    }
}

/// A transport with a watcher (module docs).
#[derive(Debug)]
pub struct Tap<T, W> {
    inner: T,
    watch: W,
    /// Once a driver attached to a port that marks line errors: reads are marked.
    marks: Option<MarkDecoder>,
}

impl<T, W> Tap<T, W> {
    /// Show `watch` what passes through `inner`.
    pub fn new(inner: T, watch: W) -> Self {
        Tap {
            inner,
            watch,
            marks: None,
        }
    }

    /// The watcher.
    pub fn watch(&self) -> &W {
        &self.watch
    }
}

impl<T: Transport, W: Watch + Unpin> AsyncRead for Tap<T, W> {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = &mut *self;
        let before = buf.filled().len();
        let poll = Pin::new(&mut this.inner).poll_read(cx, buf);
        if let Poll::Ready(Ok(())) = &poll {
            let new = &buf.filled()[before..];
            let watch = &mut this.watch;
            match &mut this.marks {
                Some(marks) => marks.feed(new, |piece| watch.read(piece)),
                None if !new.is_empty() => watch.read(Marked::Data(new)),
                None => {}
            }
        }
        this.watch.poll_idle(cx);
        poll
    }
}

impl<T: Transport, W: Watch + Unpin> AsyncWrite for Tap<T, W> {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let poll = Pin::new(&mut self.inner).poll_write(cx, buf);
        if let Poll::Ready(Ok(n)) = &poll {
            if *n > 0 {
                self.watch.written(&buf[..*n]);
            }
        }
        poll
    }
    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_flush(cx)
    }
    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

impl<T: Transport, W: Watch + Unpin + Send + 'static> Transport for Tap<T, W> {
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        self.watch.signals(update);
        self.inner.set_signals(update)
    }
    fn read_signals(&mut self) -> io::Result<Option<ModemSignals>> {
        self.inner.read_signals()
    }
    fn attach(&mut self) -> PortFacts {
        let facts = self.inner.attach();
        self.marks = facts.marked_errors.map(MarkDecoder::new);
        facts
    }
    /// The watcher sees an overrun the kernel counted as the driver does: one
    /// [`LineError::Overrun`](crate::LineError) after the read that found it.
    fn new_overruns(&mut self) -> u64 {
        let lost = self.inner.new_overruns();
        if lost > 0 {
            self.watch
                .read(Marked::Error(crate::sansio::LineError::Overrun));
        }
        lost
    }
}
