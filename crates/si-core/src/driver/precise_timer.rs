//! The precise timer service: one helper thread per process waits the last stretch before
//! every driver's deadline ("Timing, honestly" in [`super`]).
//!
//! Tokio's timer wheel brings a driver to within [`PRECISE_LEAD`] of its next deadline; from
//! there the driver arms this service, whose thread blocks on a condition variable with a
//! timeout (the kernel's high-resolution timers) until the earliest deadline armed by any
//! driver, and wakes that driver's task through its own [`Notify`]. A driver's wait therefore
//! costs a slot in a table, not a thread: 1,000 lines in a gateway share one thread
//! (BENCHMARKS.md, "Many lines in one process"), where there used to be one per driver.
//!
//! - **Life:** the thread starts when the first driver arms it and ends when the last driver
//!   using it is dropped (drivers that never wait a short deadline never start it); the next
//!   driver starts a new one. A process that runs no driver has no such thread.
//! - **Cost:** arming, moving and disarming a deadline are O(log n) in the drivers armed (an
//!   indexed binary heap, [`DeadlineHeap`]); slots are reused, so nothing is allocated per arm
//!   once the tables have grown to the number of drivers. One mutex guards the tables; the
//!   thread wakes drivers after releasing it.
//! - **Exactness:** as before, one condition-variable wait per deadline; drivers whose
//!   deadlines fall due together are woken one after the other, microseconds apart.
//! - **No thread:** if it cannot be started, the driver warns and uses tokio's timer alone
//!   (deadlines up to about 2 ms late).

use crate::time::{Duration, Instant};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use tokio::sync::Notify;

/// How close to a deadline the driver hands over from tokio's 1 ms timer wheel to the precise
/// helper thread ("Timing, honestly" in the driver's docs): more than the wheel's worst
/// lateness on an idle machine, so the wheel wakes the driver before the deadline.
pub const PRECISE_LEAD: Duration = Duration::from_millis(3);

/// How close to a deadline the driver stops sleeping and yields to the runtime until the
/// deadline has passed: about the kernel's timer slack, below which a sleeping thread cannot
/// be woken more precisely, and far cheaper than a thread's wake-up for the microsecond waits
/// of a fast line (tx-done of a short frame at a high baud rate). At most this long per
/// deadline the driver task polls instead of sleeping; other tasks run in between.
pub const SPIN_BELOW: Duration = Duration::from_micros(50);

/// The name of the helper thread (seen in `top -H`, `/proc/<pid>/task/*/comm`).
const THREAD_NAME: &str = "si-driver-timer";

/// The process's service while any driver uses it (a closed one is replaced on next use).
static SERVICE: Mutex<Option<Arc<Service>>> = Mutex::new(None);

/// Drivers using the process's precise timer thread now: each driver that has waited a
/// deadline closer than [`PRECISE_LEAD`] counts until it ends. For status lines and
/// benchmarks; `0` means no such thread runs.
pub fn precise_timer_drivers() -> usize {
    lock(&SERVICE)
        .as_ref()
        .map_or(0, |service| service.state().drivers())
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// What the drivers and the thread share.
struct Service {
    state: Mutex<State>,
    /// Tells the thread that the earliest deadline changed or the last driver has gone.
    changed: Condvar,
}

struct State {
    deadlines: DeadlineHeap<std::time::Instant>,
    /// Per slot: how to wake the driver seated there; `None` for a free slot.
    drivers: Vec<Option<Arc<Notify>>>,
    /// Free slots, reused before the table grows.
    free: Vec<usize>,
    /// The last driver has gone: the thread ends, and new drivers start a new service.
    closed: bool,
}

impl State {
    fn drivers(&self) -> usize {
        self.drivers.len() - self.free.len()
    }

    fn seat(&mut self, fired: Arc<Notify>) -> usize {
        match self.free.pop() {
            Some(slot) => {
                self.drivers[slot] = Some(fired);
                slot
            }
            None => {
                self.drivers.push(Some(fired));
                self.drivers.len() - 1
            }
        }
    }
}

impl Service {
    fn state(&self) -> MutexGuard<'_, State> {
        lock(&self.state)
    }

    /// The thread: fire what is due, then sleep until the earliest deadline or a change.
    fn run(&self) {
        exact_waits();
        // Drivers to wake, collected under the lock and woken after it (kept: no allocation
        // once it has grown to the most deadlines due at once).
        let mut due: Vec<Arc<Notify>> = Vec::new();
        let mut state = self.state();
        loop {
            if state.closed {
                return;
            }
            let now = std::time::Instant::now();
            while let Some((slot, _)) = state.deadlines.earliest().filter(|&(_, at)| at <= now) {
                state.deadlines.remove(slot);
                due.extend(state.drivers.get(slot).cloned().flatten());
            }
            if !due.is_empty() {
                drop(state);
                for fired in due.drain(..) {
                    fired.notify_one();
                }
                state = self.state();
                continue;
            }
            state = match state.deadlines.earliest() {
                None => self
                    .changed
                    .wait(state)
                    .unwrap_or_else(PoisonError::into_inner),
                Some((_, at)) => {
                    self.changed
                        .wait_timeout(state, at - now)
                        .unwrap_or_else(PoisonError::into_inner)
                        .0
                }
            };
        }
    }

    /// A seat in the process's service, starting its thread if none runs.
    fn join(fired: &Arc<Notify>) -> std::io::Result<(Arc<Service>, usize)> {
        let mut global = lock(&SERVICE);
        if let Some(service) = global.as_ref() {
            let mut state = service.state();
            if !state.closed {
                let slot = state.seat(Arc::clone(fired));
                drop(state);
                return Ok((Arc::clone(service), slot));
            }
        }
        let service = Arc::new(Service {
            state: Mutex::new(State {
                deadlines: DeadlineHeap::default(),
                drivers: Vec::new(),
                free: Vec::new(),
                closed: false,
            }),
            changed: Condvar::new(),
        });
        let theirs = Arc::clone(&service);
        std::thread::Builder::new()
            .name(THREAD_NAME.into())
            .spawn(move || theirs.run())?;
        let slot = service.state().seat(Arc::clone(fired));
        *global = Some(Arc::clone(&service));
        Ok((service, slot))
    }
}

/// Make this thread's timed waits end when asked. Linux lets a thread's timed wait end up to
/// its *timer slack* late (50 µs by default) so that wake-ups can be merged; for the one
/// thread whose job is to wake drivers on time that is the whole error left (measured: a
/// Modbus master's request after the 1 ms gap at 115 200 bit/s went out about 45 µs sooner
/// with 1 µs of slack). Best effort: a kernel that refuses leaves the default.
fn exact_waits() {
    #[cfg(target_os = "linux")]
    {
        /// The slack asked for, in nanoseconds (0 would mean "the default" to the kernel).
        const SLACK_NS: std::ffi::c_ulong = 1_000;
        let _ = nix::sys::prctl::set_timerslack(SLACK_NS);
    }
}

/// A driver's place in the service.
struct Seat {
    service: Arc<Service>,
    slot: usize,
    fired: Arc<Notify>,
}

/// A driver's handle on the precise timer service: fires deadlines less than [`PRECISE_LEAD`]
/// ahead with the kernel's high-resolution timers instead of tokio's 1 ms wheel.
#[derive(Default)]
pub(super) struct PreciseTimer {
    seat: Option<Seat>,
    /// The engine deadline the service is armed for (to skip re-arming for the same one).
    armed: Option<Instant>,
    /// The thread could not be started: tokio's timer alone, as before.
    unavailable: bool,
}

impl PreciseTimer {
    /// Wake the driver `remaining` from now for the engine deadline `at`.
    pub(super) fn arm(&mut self, at: Instant, remaining: Duration) {
        if self.armed == Some(at) || self.unavailable {
            return;
        }
        let Some(seat) = self.seat() else {
            return;
        };
        let when = std::time::Instant::now() + std::time::Duration::from(remaining);
        let earliest = seat.service.state().deadlines.set(seat.slot, when);
        if earliest {
            seat.service.changed.notify_one();
        }
        self.armed = Some(at);
    }

    pub(super) fn disarm(&mut self) {
        if self.armed.take().is_some() {
            if let Some(seat) = &self.seat {
                seat.service.state().deadlines.remove(seat.slot);
            }
        }
    }

    pub(super) fn is_armed(&self) -> bool {
        self.armed.is_some()
    }

    /// The service has fired (it disarmed the slot): arm it again for the next deadline, even
    /// if that is the same one (a wake-up before it, such as a stale notification).
    pub(super) fn fired_seen(&mut self) {
        self.armed = None;
    }

    /// Resolves when the armed deadline has passed (or spuriously: the driver checks the
    /// clock, never the timer); never without a seat.
    pub(super) async fn fired(&self) {
        match &self.seat {
            Some(seat) => seat.fired.notified().await,
            None => std::future::pending().await,
        }
    }

    /// The seat in the service, taken on first use.
    fn seat(&mut self) -> Option<&Seat> {
        if self.seat.is_none() {
            let fired = Arc::new(Notify::new());
            match Service::join(&fired) {
                Ok((service, slot)) => {
                    self.seat = Some(Seat {
                        service,
                        slot,
                        fired,
                    })
                }
                Err(e) => {
                    tracing::warn!("no precise timer thread ({e}): deadlines may fire 1–2 ms late");
                    self.unavailable = true;
                }
            }
        }
        self.seat.as_ref()
    }
}

impl Drop for PreciseTimer {
    /// Leave the service; the last driver to leave ends its thread.
    fn drop(&mut self) {
        let Some(seat) = self.seat.take() else {
            return;
        };
        let mut state = seat.service.state();
        state.deadlines.remove(seat.slot);
        if let Some(driver) = state.drivers.get_mut(seat.slot) {
            *driver = None;
            state.free.push(seat.slot);
        }
        if state.drivers() == 0 {
            state.closed = true;
            drop(state);
            seat.service.changed.notify_one();
        }
    }
}

/// Deadlines by slot, earliest first: a binary min-heap that knows where each slot's entry
/// sits, so setting, moving and removing a slot's deadline are O(log n), and nothing is
/// allocated once the vectors have grown to the number of slots.
#[derive(Debug)]
struct DeadlineHeap<T> {
    /// `(deadline, slot)` in heap order: each entry is no later than its children.
    heap: Vec<(T, usize)>,
    /// Per slot: the index of its entry in `heap`, `None` when it has no deadline.
    index: Vec<Option<usize>>,
}

impl<T> Default for DeadlineHeap<T> {
    fn default() -> Self {
        DeadlineHeap {
            heap: Vec::new(),
            index: Vec::new(),
        }
    }
}

impl<T: Ord + Copy> DeadlineHeap<T> {
    /// The earliest deadline and its slot.
    fn earliest(&self) -> Option<(usize, T)> {
        self.heap.first().map(|&(at, slot)| (slot, at))
    }

    /// Set (or move) `slot`'s deadline; true if it is now the earliest.
    fn set(&mut self, slot: usize, at: T) -> bool {
        if self.index.len() <= slot {
            self.index.resize(slot + 1, None);
        }
        let i = match self.index[slot] {
            Some(i) => {
                self.heap[i].0 = at;
                i
            }
            None => {
                self.heap.push((at, slot));
                self.index[slot] = Some(self.heap.len() - 1);
                self.heap.len() - 1
            }
        };
        let i = self.up(i);
        self.down(i) == 0
    }

    /// Remove `slot`'s deadline, if it has one.
    fn remove(&mut self, slot: usize) {
        let Some(i) = self.index.get_mut(slot).and_then(Option::take) else {
            return;
        };
        let last = self.heap.len() - 1;
        if i != last {
            self.heap.swap(i, last);
            self.index[self.heap[i].1] = Some(i);
        }
        self.heap.pop();
        if i < self.heap.len() {
            let i = self.up(i);
            self.down(i);
        }
    }

    fn swap(&mut self, a: usize, b: usize) {
        self.heap.swap(a, b);
        self.index[self.heap[a].1] = Some(a);
        self.index[self.heap[b].1] = Some(b);
    }

    /// Move the entry at `i` towards the root while it is earlier than its parent.
    fn up(&mut self, mut i: usize) -> usize {
        while i > 0 {
            let parent = (i - 1) / 2;
            if self.heap[i].0 >= self.heap[parent].0 {
                break;
            }
            self.swap(i, parent);
            i = parent;
        }
        i
    }

    /// Move the entry at `i` towards the leaves while a child is earlier.
    fn down(&mut self, mut i: usize) -> usize {
        loop {
            let mut first = i;
            for child in [2 * i + 1, 2 * i + 2] {
                if child < self.heap.len() && self.heap[child].0 < self.heap[first].0 {
                    first = child;
                }
            }
            if first == i {
                return i;
            }
            self.swap(i, first);
            i = first;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[derive(Debug, Clone)]
    enum Op {
        Set(usize, u32),
        Remove(usize),
        Pop,
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            (0..12usize, 0..50u32).prop_map(|(s, at)| Op::Set(s, at)),
            (0..12usize).prop_map(Op::Remove),
            Just(Op::Pop),
        ]
    }

    proptest! {
        /// Against a plain table: the earliest deadline is always the least one set and not
        /// removed, and "now the earliest" is reported exactly when it is.
        #[test]
        fn the_heap_always_yields_the_earliest_deadline(ops in prop::collection::vec(op(), 0..200)) {
            let mut heap = DeadlineHeap::default();
            let mut model: Vec<Option<u32>> = vec![None; 12];
            for op in ops {
                match op {
                    Op::Set(slot, at) => {
                        let earliest = heap.set(slot, at);
                        model[slot] = Some(at);
                        let least = model.iter().flatten().min().copied();
                        prop_assert_eq!(earliest, least == Some(at) && heap.earliest() == Some((slot, at)));
                    }
                    Op::Remove(slot) => {
                        heap.remove(slot);
                        model[slot] = None;
                    }
                    Op::Pop => {
                        if let Some((slot, at)) = heap.earliest() {
                            prop_assert_eq!(model[slot], Some(at));
                            heap.remove(slot);
                            model[slot] = None;
                        }
                    }
                }
                let least = model.iter().flatten().min().copied();
                prop_assert_eq!(heap.earliest().map(|(_, at)| at), least);
                prop_assert_eq!(heap.heap.len(), model.iter().flatten().count());
            }
        }
    }

    #[test]
    fn re_arming_grown_slots_allocates_nothing() {
        let mut heap = DeadlineHeap::default();
        for slot in 0..1000 {
            heap.set(slot, slot as u64);
        }
        let capacity = (heap.heap.capacity(), heap.index.capacity());
        for round in 0..10u64 {
            for slot in 0..1000 {
                heap.remove(slot);
                heap.set(slot, (slot as u64 * 7919 + round) % 1000);
            }
        }
        assert_eq!((heap.heap.capacity(), heap.index.capacity()), capacity);
        let mut last = 0;
        while let Some((slot, at)) = heap.earliest() {
            assert!(at >= last, "out of order");
            last = at;
            heap.remove(slot);
        }
    }
}
