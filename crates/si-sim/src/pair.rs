//! Two engines back to back on an instant line, for allocation tests and benchmarks where the
//! [`Simulator`](super::Simulator)'s character timing and event queue would be in the way.
//!
//! ```
//! use si_sim::Pair;
//! use si_core::{Engine, Instant, Output};
//! # struct Quiet;
//! # impl Engine for Quiet {
//! #     type Event = ();
//! #     fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
//! #     fn handle_timeout(&mut self, _: Instant) {}
//! #     fn poll_output(&mut self) -> Output<()> { Output::Wait(None) }
//! # }
//! let mut pair = Pair::new(Quiet, Quiet);
//! pair.run_until(Instant::from_micros(1_000));
//! assert_eq!(pair.now, Instant::from_micros(1_000));
//! assert_eq!(pair.events, (0, 0));
//! ```

use si_core::Instant;
use si_core::{Engine, Output};

/// Two engines wired back to back with an instant line: everything one transmits is handed to
/// the other at the same instant, and its tx-done follows at once. Allocates nothing itself.
pub struct Pair<A: Engine, B: Engine> {
    /// The first engine.
    pub a: A,
    /// The second engine.
    pub b: B,
    /// The shared clock.
    pub now: Instant,
    /// Events reported by A and B.
    pub events: (u64, u64),
    /// The last event of A and of B.
    pub last: (Option<A::Event>, Option<B::Event>),
}

impl<A: Engine, B: Engine> Pair<A, B> {
    /// Wire `a` and `b` together at time zero.
    pub fn new(a: A, b: B) -> Self {
        Pair {
            a,
            b,
            now: Instant::ZERO,
            events: (0, 0),
            last: (None, None),
        }
    }

    /// Drain both engines until neither transmits; the earliest deadline of the two.
    ///
    /// # Panics
    ///
    /// If the engines are still talking after 10 000 rounds at one instant (a livelock, which
    /// is what a test wants to hear about).
    pub fn settle(&mut self) -> Option<Instant> {
        for _ in 0..10_000 {
            let (moved_a, da) = drain_into(
                &mut self.a,
                &mut self.b,
                self.now,
                &mut self.events.0,
                &mut self.last.0,
            );
            let (moved_b, db) = drain_into(
                &mut self.b,
                &mut self.a,
                self.now,
                &mut self.events.1,
                &mut self.last.1,
            );
            if !moved_a && !moved_b {
                return Instant::earliest(da, db);
            }
        }
        panic!("the engines keep talking at one instant");
    }

    /// Run timers and traffic up to `until`.
    ///
    /// # Panics
    ///
    /// If timers keep firing 100 000 times before `until` (an engine that never settles).
    pub fn run_until(&mut self, until: Instant) {
        for _ in 0..100_000 {
            match self.settle() {
                Some(t) if t <= until => {
                    self.now = self.now.max(t);
                    self.a.handle_timeout(self.now);
                    self.b.handle_timeout(self.now);
                }
                _ => {
                    self.now = until;
                    self.a.handle_timeout(self.now);
                    self.b.handle_timeout(self.now);
                    self.settle();
                    return;
                }
            }
        }
        panic!("timers keep firing before {until:?}");
    }
}

fn drain_into<F: Engine, T: Engine>(
    from: &mut F,
    to: &mut T,
    now: Instant,
    events: &mut u64,
    last: &mut Option<F::Event>,
) -> (bool, Option<Instant>) {
    let mut moved = false;
    loop {
        match from.poll_output() {
            Output::Transmit(bytes) => {
                to.handle_rx(now, &bytes);
                drop(bytes);
                from.handle_tx_done(now);
                moved = true;
            }
            Output::Event(event) => {
                *events += 1;
                *last = Some(event);
            }
            Output::SetSignals(_) => {}
            Output::Wait(deadline) => return (moved, deadline),
        }
    }
}
