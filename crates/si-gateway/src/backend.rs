//! What serves a line's units, as the router sees it: the [`Backend`] trait that every line
//! kind implements — Modbus RTU and RK 512 lines through their queue ([`QueuedLine`]), USS
//! drives and 3964(R) partners answering from their images at once — and that a program
//! implements for a line of its own kind.
//!
//! Where a line's bytes go (a serial port, or a serial device server as `tcp:HOST:PORT`) is
//! the line's transport ([`crate::open`]), not its kind: every kind runs over both.

use crate::counters::Outcome;
use crate::line::LineQueue;
use crate::r3964::BlockLine;
use crate::uss::UssDrives;
use si_modbus::mbap::TcpAdu;
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;

/// A future a backend answers with.
pub type BoxFuture<'a, T> = Pin<Box<dyn Future<Output = T> + Send + 'a>>;

/// How a request reaches a line.
pub enum Reach<'a> {
    /// Into the line's queue, served in fair order by the line's own task, which counts what
    /// became of each request ([`crate::line::answered`]); a full queue is answered with 06H.
    Queue(&'a LineQueue),
    /// Answered by this future at once: the answer (its transaction and unit id those of the
    /// request) and how it counts.
    Answer(BoxFuture<'a, (TcpAdu, Outcome)>),
}

/// A line kind as the router reaches it. The request's unit id is already the line's own
/// address of the unit (the TCP unit id mapped); the router gives the answer the client's
/// unit id back.
pub trait Backend: Send + Sync + 'static {
    /// How `request` reaches the line.
    fn reach<'a>(&'a self, request: &'a TcpAdu) -> Reach<'a>;
}

/// A line whose requests wait in a queue for the line's task: Modbus RTU lines and RK 512
/// lines (active or passive).
pub struct QueuedLine(pub Arc<LineQueue>);

impl Backend for QueuedLine {
    fn reach<'a>(&'a self, _request: &'a TcpAdu) -> Reach<'a> {
        Reach::Queue(&self.0)
    }
}

impl Backend for UssDrives {
    fn reach<'a>(&'a self, request: &'a TcpAdu) -> Reach<'a> {
        Reach::Answer(Box::pin(self.answer(request)))
    }
}

impl Backend for BlockLine {
    fn reach<'a>(&'a self, request: &'a TcpAdu) -> Reach<'a> {
        Reach::Answer(Box::pin(self.answer(request)))
    }
}
