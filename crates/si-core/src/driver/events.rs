//! The driver's event queue: the engine's events no job took, from the driver task to the
//! [`Handle`](super::Handle). Bounded like the tokio channel it replaces
//! ([`DriverOptions::event_capacity`](super::DriverOptions::event_capacity)), with the same
//! two ways to send (wait for room, or drop when full) and the same end conditions.
//!
//! Why not `tokio::sync::mpsc`: its channel allocates a block of 32 slots when it is created,
//! and a Modbus master's event (a completion holding its request and response ADUs) is about
//! 540 bytes, so every driver held 17 KiB for events that, on a gateway line, never come (job
//! outcomes go to their jobs): two thirds of an idle line's memory with 1,000 lines in one
//! process (BENCHMARKS.md "Lines per process"). This queue takes room as events
//! wait. Once it has grown it keeps its room, so a steady flow of events allocates nothing per
//! event; it never holds more than the capacity.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use tokio::sync::Notify;

/// A bounded queue of `capacity` events; the driver task sends, the handle receives.
pub(super) fn channel<T>(capacity: usize) -> (Sender<T>, Receiver<T>) {
    let shared = Arc::new(Shared {
        state: Mutex::new(State {
            items: VecDeque::new(),
            capacity: capacity.max(1),
            sender: true,
            receiver: true,
        }),
        readable: Notify::new(),
        writable: Notify::new(),
    });
    (Sender(Arc::clone(&shared)), Receiver(shared))
}

struct Shared<T> {
    state: Mutex<State<T>>,
    /// An event was queued, or the sender is gone.
    readable: Notify,
    /// Room was made, or the receiver is gone.
    writable: Notify,
}

struct State<T> {
    items: VecDeque<T>,
    capacity: usize,
    /// The sending side still exists.
    sender: bool,
    /// The receiving side still exists.
    receiver: bool,
}

impl<T> Shared<T> {
    /// Lock, taking over a lock poisoned by a panicking holder (the queue stays consistent:
    /// every change is a single push or pop).
    fn lock(&self) -> MutexGuard<'_, State<T>> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Why [`Sender::try_send`] did not queue the event.
#[derive(Debug, PartialEq, Eq)]
pub(super) enum TrySendError {
    /// `capacity` events wait unread.
    Full,
    /// The receiver is gone.
    Closed,
}

/// The driver task's side.
pub(super) struct Sender<T>(Arc<Shared<T>>);

impl<T> Sender<T> {
    /// Queue `event` if there is room.
    pub(super) fn try_send(&self, event: T) -> Result<(), TrySendError> {
        let mut s = self.0.lock();
        if !s.receiver {
            return Err(TrySendError::Closed);
        }
        if s.items.len() >= s.capacity {
            return Err(TrySendError::Full);
        }
        s.items.push_back(event);
        drop(s);
        self.0.readable.notify_one();
        Ok(())
    }

    /// Queue `event`, waiting for room; `Err` (with the event) once the receiver is gone.
    pub(super) async fn send(&self, event: T) -> Result<(), T> {
        let mut event = Some(event);
        loop {
            {
                let mut s = self.0.lock();
                if let Some(e) = event.take() {
                    if !s.receiver {
                        return Err(e);
                    }
                    if s.items.len() < s.capacity {
                        s.items.push_back(e);
                        drop(s);
                        self.0.readable.notify_one();
                        return Ok(());
                    }
                    event = Some(e);
                }
            }
            // Room made between the check and here leaves a permit: nothing is missed.
            self.0.writable.notified().await;
        }
    }
}

impl<T> Drop for Sender<T> {
    fn drop(&mut self) {
        self.0.lock().sender = false;
        self.0.readable.notify_one();
    }
}

/// The handle's side.
pub(super) struct Receiver<T>(Arc<Shared<T>>);

impl<T> Receiver<T> {
    /// The next event, waiting for one; `None` once the sender is gone and all are taken.
    pub(super) async fn recv(&mut self) -> Option<T> {
        loop {
            {
                let mut s = self.0.lock();
                if let Some(event) = s.items.pop_front() {
                    drop(s);
                    self.0.writable.notify_one();
                    return Some(event);
                }
                if !s.sender {
                    return None;
                }
            }
            // An event queued between the check and here leaves a permit.
            self.0.readable.notified().await;
        }
    }

    /// An event already waiting.
    pub(super) fn try_recv(&mut self) -> Option<T> {
        let event = self.0.lock().items.pop_front()?;
        self.0.writable.notify_one();
        Some(event)
    }
}

impl<T> Drop for Receiver<T> {
    fn drop(&mut self) {
        let dropped = {
            let mut s = self.0.lock();
            s.receiver = false;
            std::mem::take(&mut s.items)
        };
        drop(dropped); // outside the lock
        self.0.writable.notify_one();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_idle_queue_holds_no_room() {
        let (tx, rx) = channel::<[u8; 540]>(1024);
        assert_eq!(rx.0.lock().items.capacity(), 0);
        tx.try_send([0; 540]).unwrap();
        assert!(rx.0.lock().items.capacity() < 1024);
    }

    #[tokio::test]
    async fn events_come_out_in_order_and_a_full_queue_refuses_or_waits() {
        let (tx, mut rx) = channel(2);
        tx.try_send(1).unwrap();
        tx.send(2).await.unwrap();
        assert_eq!(tx.try_send(3), Err(TrySendError::Full));
        // A waiting send completes once the receiver takes one.
        let sender = tokio::spawn(async move {
            tx.send(3).await.unwrap();
            tx
        });
        tokio::task::yield_now().await;
        assert!(!sender.is_finished());
        assert_eq!(rx.recv().await, Some(1));
        let tx = sender.await.unwrap();
        assert_eq!(rx.try_recv(), Some(2));
        assert_eq!(rx.recv().await, Some(3));
        assert_eq!(rx.try_recv(), None);
        drop(tx);
        assert_eq!(rx.recv().await, None);
    }

    #[tokio::test]
    async fn a_waiting_receiver_wakes_for_an_event_and_for_the_end() {
        let (tx, mut rx) = channel(4);
        let receiver = tokio::spawn(async move {
            let first = rx.recv().await;
            let end = rx.recv().await;
            (first, end)
        });
        tokio::task::yield_now().await;
        tx.try_send(7).unwrap();
        tokio::task::yield_now().await;
        drop(tx);
        assert_eq!(receiver.await.unwrap(), (Some(7), None));
    }

    #[tokio::test]
    async fn sending_ends_when_the_receiver_is_gone() {
        let (tx, rx) = channel(1);
        tx.try_send(1).unwrap();
        let sender = tokio::spawn(async move { tx.send(2).await });
        tokio::task::yield_now().await;
        drop(rx);
        assert_eq!(sender.await.unwrap(), Err(2));
        let (tx, rx) = channel::<u8>(1);
        drop(rx);
        assert_eq!(tx.try_send(1), Err(TrySendError::Closed));
    }
}
