//! A deterministic discrete-event line simulator.
//!
//! Engines are attached as *stations* and wired either point to point (RS-232/RS-422: full
//! duplex, A's transmitter drives B's receiver and vice versa, RTS→CTS and DTR→DSR/DCD crossed
//! as in a null-modem cable) or to a shared RS-485 bus (half duplex: every member hears every
//! character, its own included, and characters that overlap in time garble each other, so every
//! receiver gets a framing error for them).
//!
//! Characters take exactly their character time: the k-th character of a back-to-back burst ends
//! at `burst start + ceil(k × bits × 10⁶ / baud)` µs ([`SerialSettings::chars_time`]), so there is
//! no drift however long the burst. Time is virtual: an hour of traffic runs in well under a
//! second of real time.
//!
//! Happenings are processed in (time, seq) order, seq being the order they were scheduled in,
//! so same-instant ties resolve the same way on every run. The queue stays small however busy
//! the line: a transmission is one record walked character by character (`sim/burst.rs`: one
//! queue entry per burst and receive latency, not per character and receiver), and a station's
//! timer is one entry however often the engine re-arms it (each re-arm still takes its own seq;
//! only a deadline earlier than the queued entry is queued at once, a later one when the old
//! entry comes up). A timer cancelled after it was queued leaves that entry to pass as a no-op
//! step, which keeps [`Simulator::is_quiet`] false until then.
//!
//! Faults are drawn from a seeded generator, so a failing run is reproduced by its seed:
//! bit flips, dropped and inserted characters and extra latency per wire ([`Faults`]), BREAK at a
//! given instant ([`Simulator::schedule_break`]) and a partner that stops transmitting
//! ([`Simulator::silence`]).
//!
//! Any station can sit behind a USB-serial adapter ([`Simulator::set_adapter`], [`UsbAdapter`]):
//! its received characters then reach its engine in packets of up to 62 bytes, handed over when
//! full or when the adapter's latency timer (1–255 ms) runs out, as most hosts meet a real line.
//! Such a station's trace records each hand-over as one [`TraceKind::RxChunk`] (what its engine
//! saw), not one `Rx` per character. Stations without an adapter are unchanged.
//!
//! Or behind a 16550-type UART with a receive FIFO ([`Simulator::set_uart`], [`FifoUart`]): its
//! characters reach its engine when the FIFO (16 places) reaches its trigger level (1, 4, 8 or
//! 14) or its character timeout (4 character times) runs out, a host service latency later;
//! characters arriving at a full FIFO are lost with an overrun. Recorded as `RxChunk`s too.
//!
//! **What each station's engine is told about its port** ([`Engine::set_rx_latency`]): a
//! station without adapter or UART is declared byte by byte (`Duration::ZERO`) before the
//! simulation first moves, so the manuals' exact timing holds from the first byte; an adapter
//! or UART declares its hold when it announces, and nothing otherwise (an unknown port, which
//! si-core's `delivery` takes for a default USB adapter until the reads show otherwise).
//!
//! ```
//! use si_sim::Simulator;
//! use si_core::{Engine, Instant, Output, SerialSettings};
//!
//! /// An engine that reports every character it receives.
//! #[derive(Default)]
//! struct Listener(Vec<u8>);
//! impl Engine for Listener {
//!     type Event = u8;
//!     fn handle_rx(&mut self, _: Instant, bytes: &[u8]) { self.0.extend_from_slice(bytes) }
//!     fn handle_timeout(&mut self, _: Instant) {}
//!     fn poll_output(&mut self) -> Output<u8> {
//!         if self.0.is_empty() { Output::Wait(None) } else { Output::Event(self.0.remove(0)) }
//!     }
//! }
//!
//! let mut sim = Simulator::new(42);
//! let settings = SerialSettings::default(); // 9600 8E1: 11 bits a character
//! let a = sim.add_station("A", settings, Listener::default());
//! let b = sim.add_station("B", settings, Listener::default());
//! sim.connect(a, b);
//! sim.transmit(a, &[0x55]);
//! sim.run_until_quiet(Instant::from_micros(1_000_000));
//! assert_eq!(sim.take_events(b), vec![0x55]);
//! assert_eq!(sim.trace().received("B")[0].0, Instant::from_micros(1_146)); // 11 / 9600 s
//! ```

mod adapter;
mod burst;
mod pair;
mod rng;
mod terminal;
mod uart;

pub use adapter::{AdapterError, UsbAdapter};
pub use pair::Pair;
pub use rng::SplitMix64;
pub use si_core::trace::{Trace, TraceEntry, TraceKind};
pub use terminal::Terminal;
pub use uart::{FifoUart, UartError};

use adapter::Held;
use burst::{Burst, Key, Mod};
use core::any::Any;
use core::marker::PhantomData;
use si_core::SerialSettings;
use si_core::{Duration, Instant};
use si_core::{Engine, LineError, ModemSignals, Output, SignalUpdate};
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};
use uart::{Fifo, FifoWake};

/// Seeded faults on the characters a station receives from others (its own bus echo is clean).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Faults {
    /// Probability that a character arrives with one random bit inverted.
    pub bit_flip: f64,
    /// Probability that a character is lost.
    pub drop: f64,
    /// Probability that a random extra character arrives right after a real one.
    pub insert: f64,
    /// Delay added to every character (a slow converter, a device server).
    pub extra_latency: Duration,
}

/// A typed handle to a station; `E` is its engine type, so events and the engine come back typed.
#[derive(Debug)]
pub struct StationId<E> {
    index: usize,
    _engine: PhantomData<fn() -> E>,
}

impl<E> Clone for StationId<E> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<E> Copy for StationId<E> {}

impl<E> StationId<E> {
    /// Position in the order stations were added.
    pub fn index(self) -> usize {
        self.index
    }
}

/// The object-safe face of an [`Engine`], so stations of different engine types share one line.
/// `Any` as a supertrait: the engine is reached again by upcasting, without a virtual call.
trait Station: Any {
    fn rx(&mut self, now: Instant, bytes: &[u8]);
    fn timeout(&mut self, now: Instant);
    fn tx_done(&mut self, now: Instant);
    fn line_error(&mut self, now: Instant, e: LineError);
    fn signals(&mut self, now: Instant, s: ModemSignals);
    fn rx_latency(&mut self, latency: Duration);
    fn poll(&mut self) -> Output<Box<dyn Any>>;
    fn describe(&self, event: &dyn Any) -> String;
}

impl<E> Station for E
where
    E: Engine + 'static,
    E::Event: 'static,
{
    fn rx(&mut self, now: Instant, bytes: &[u8]) {
        self.handle_rx(now, bytes)
    }
    fn timeout(&mut self, now: Instant) {
        self.handle_timeout(now)
    }
    fn tx_done(&mut self, now: Instant) {
        self.handle_tx_done(now)
    }
    fn line_error(&mut self, now: Instant, e: LineError) {
        self.handle_line_error(now, e)
    }
    fn signals(&mut self, now: Instant, s: ModemSignals) {
        self.handle_signals(now, s)
    }
    fn rx_latency(&mut self, latency: Duration) {
        self.set_rx_latency(latency)
    }
    fn poll(&mut self) -> Output<Box<dyn Any>> {
        match self.poll_output() {
            Output::Transmit(b) => Output::Transmit(b),
            Output::SetSignals(s) => Output::SetSignals(s),
            Output::Event(e) => Output::Event(Box::new(e)),
            Output::Wait(d) => Output::Wait(d),
        }
    }
    fn describe(&self, event: &dyn Any) -> String {
        event
            .downcast_ref::<E::Event>()
            .map(|e| format!("{e:?}"))
            .unwrap_or_default()
    }
}

/// Which wire a station is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wiring {
    Unconnected,
    /// Full duplex to the station with this index.
    PointToPoint(usize),
    /// Member of the bus with this index.
    Bus(usize),
}

struct Slot {
    name: String,
    settings: SerialSettings,
    engine: Box<dyn Station>,
    events: VecDeque<Box<dyn Any>>,
    wiring: Wiring,
    faults: Faults,
    /// Transmitter: when the current burst started, how many characters it holds, and when the
    /// last of them ends.
    burst_start: Instant,
    burst_chars: u64,
    tx_free_at: Instant,
    tx_generation: u64,
    /// The deadline the engine last asked for.
    deadline: Option<Instant>,
    /// That deadline as a queue key: when it fires and its place among happenings at the same
    /// instant (a fresh seq at every re-arm, as if each re-arm were queued).
    timer: Option<Key>,
    /// The key of the one queue entry standing for this station's timer: never later than
    /// `timer`. Re-arming later queues nothing; when this entry pops before `timer` it is
    /// queued again at `timer` (lazy timers: one entry per station however often it re-arms).
    timer_queued: Option<Key>,
    silent_from: Option<Instant>,
    /// A scripted corruption: the character with this index (counting from 0 at the time of
    /// the call) among those received from others gets its bits XORed with the mask.
    corrupt: Option<(u64, u8)>,
    signals: ModemSignals,
    /// A USB-serial adapter between the receiver and the engine ([`Simulator::set_adapter`]).
    adapter: Option<Held>,
    /// A 16550-type UART with a receive FIFO before the engine ([`Simulator::set_uart`]).
    uart: Option<Fifo>,
    /// The engine was told how its port delivers ([`Engine::set_rx_latency`]), or must not be
    /// (an unannounced adapter or UART).
    declared: bool,
}

#[derive(Debug, Clone, Copy)]
enum What {
    /// The next character of a burst for the receivers of one latency (see [`burst`]).
    Char {
        burst: u32,
        lane: u32,
    },
    /// A BREAK at a station's receiver.
    Break {
        to: usize,
    },
    TxDone {
        station: usize,
        generation: u64,
    },
    /// A station's timer: live only if its key is the station's `timer_queued`.
    Timeout {
        station: usize,
    },
    /// A station's USB adapter's latency timer ran out: live only if no hand-over came first.
    AdapterFlush {
        station: usize,
        generation: u64,
    },
    /// A station's FIFO UART interrupts or is read (live only for its current generation).
    Uart {
        station: usize,
        wake: FifoWake,
    },
}

struct Scheduled {
    at: Instant,
    seq: u64,
    what: What,
}

impl PartialEq for Scheduled {
    fn eq(&self, o: &Self) -> bool {
        (self.at, self.seq) == (o.at, o.seq)
    }
}
impl Eq for Scheduled {}
impl PartialOrd for Scheduled {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Scheduled {
    /// Reversed, so the `BinaryHeap` pops the earliest; ties go in scheduling order.
    fn cmp(&self, o: &Self) -> Ordering {
        (o.at, o.seq).cmp(&(self.at, self.seq))
    }
}

/// The simulator: stations, wires, a clock and an event queue.
pub struct Simulator {
    now: Instant,
    seq: u64,
    queue: BinaryHeap<Scheduled>,
    /// The lane delivering characters right now, out of the queue (see [`step`](Self::step)).
    hot: Option<Scheduled>,
    slots: Vec<Slot>,
    buses: Vec<Vec<usize>>,
    /// Per bus, the bursts still in flight on it (ids in `bursts`), for collisions.
    bus_live: Vec<Vec<u32>>,
    /// Bursts in flight and spare ones, whose buffers are reused.
    bursts: Vec<Burst>,
    /// Ids of the spare bursts.
    free_bursts: Vec<u32>,
    rng: SplitMix64,
    trace: Option<Trace>,
    /// Some station has not been told yet how its port delivers ([`Simulator::declare`]).
    undeclared: bool,
}

impl Simulator {
    /// An empty simulation at virtual time zero whose faults are drawn from `seed`. The trace is
    /// recorded; switch it off with [`without_trace`](Self::without_trace) for long runs.
    pub fn new(seed: u64) -> Self {
        Simulator {
            now: Instant::ZERO,
            seq: 0,
            queue: BinaryHeap::new(),
            hot: None,
            slots: Vec::new(),
            buses: Vec::new(),
            bus_live: Vec::new(),
            bursts: Vec::new(),
            free_bursts: Vec::new(),
            rng: SplitMix64::new(seed),
            trace: Some(Trace::default()),
            undeclared: false,
        }
    }

    /// Do not record a trace (hours of virtual traffic would fill memory).
    pub fn without_trace(mut self) -> Self {
        self.trace = None;
        self
    }

    /// Attach an engine as a station with the given character format.
    pub fn add_station<E>(
        &mut self,
        name: &str,
        settings: SerialSettings,
        engine: E,
    ) -> StationId<E>
    where
        E: Engine + 'static,
        E::Event: 'static,
    {
        self.slots.push(Slot {
            name: name.to_owned(),
            settings,
            engine: Box::new(engine),
            events: VecDeque::new(),
            wiring: Wiring::Unconnected,
            faults: Faults::default(),
            burst_start: Instant::ZERO,
            burst_chars: 0,
            tx_free_at: Instant::ZERO,
            tx_generation: 0,
            deadline: None,
            timer: None,
            timer_queued: None,
            silent_from: None,
            corrupt: None,
            signals: ModemSignals::default(),
            adapter: None,
            uart: None,
            declared: false,
        });
        self.undeclared = true;
        let index = self.slots.len() - 1;
        self.drain(index);
        StationId {
            index,
            _engine: PhantomData,
        }
    }

    /// Wire two stations point to point, full duplex, with a null-modem cable.
    pub fn connect<A, B>(&mut self, a: StationId<A>, b: StationId<B>) {
        self.slots[a.index].wiring = Wiring::PointToPoint(b.index);
        self.slots[b.index].wiring = Wiring::PointToPoint(a.index);
    }

    /// Put stations on one shared half-duplex RS-485 bus.
    pub fn bus(&mut self, members: &[usize]) {
        let bus = self.buses.len();
        for &m in members {
            self.slots[m].wiring = Wiring::Bus(bus);
        }
        self.buses.push(members.to_vec());
        self.bus_live.push(Vec::new());
    }

    /// Faults on what `station` receives from others.
    pub fn set_faults<E>(&mut self, station: StationId<E>, faults: Faults) {
        self.slots[station.index].faults = faults;
    }

    /// From `from` on, whatever `station` transmits never reaches the line (a partner that
    /// stops answering, a broken transmit wire).
    pub fn silence<E>(&mut self, station: StationId<E>, from: Instant) {
        self.slots[station.index].silent_from = Some(from);
    }

    /// The `nth` character (0 = the next) that `station` receives from others arrives with its
    /// bits XORed with `mask`: a deterministic single fault for scenario tests (a BCC error, a
    /// wrong address), where seeded random faults would be too blunt.
    pub fn corrupt_received<E>(&mut self, station: StationId<E>, nth: u64, mask: u8) {
        self.slots[station.index].corrupt = Some((nth, mask));
    }

    /// Put a USB-serial adapter in front of `station`'s receiver (see [`UsbAdapter`] for the
    /// model): from now on what it receives reaches its engine in packets of up to
    /// `packet_bytes`, handed over when full or `latency` after the first pending byte. With
    /// `announce_latency` the engine is told the latency ([`Engine::set_rx_latency`]) at once.
    /// The station's transmitter and its modem signals are unchanged.
    pub fn set_adapter<E>(
        &mut self,
        station: StationId<E>,
        adapter: UsbAdapter,
    ) -> Result<(), AdapterError> {
        adapter.validate()?;
        let slot = &mut self.slots[station.index];
        slot.adapter = Some(Held::new(adapter));
        slot.declared = true;
        if adapter.announce_latency {
            slot.engine.rx_latency(adapter.latency);
            self.drain(station.index);
        }
        Ok(())
    }

    /// Put a 16550-type UART with a receive FIFO in front of `station`'s receiver (see
    /// [`FifoUart`] for the model): from now on what it receives reaches its engine when the
    /// FIFO reaches its trigger level or its character timeout runs out, `service` later, and
    /// characters arriving at a full FIFO are lost with an overrun. With `announce` the engine
    /// is told the longest hold ([`FifoUart::hold`]) at once; without, it learns from the
    /// reads. Replaces a USB adapter set before.
    pub fn set_uart<E>(&mut self, station: StationId<E>, uart: FifoUart) -> Result<(), UartError> {
        uart.validate()?;
        let slot = &mut self.slots[station.index];
        slot.adapter = None;
        slot.uart = Some(Fifo::new(uart, &slot.settings));
        slot.declared = true;
        if uart.announce {
            slot.engine.rx_latency(uart.hold(&slot.settings));
            self.drain(station.index);
        }
        Ok(())
    }

    /// Tell every station not yet told how its port delivers: a station without an adapter or
    /// UART hears its characters the moment they end, so its engine is declared byte by byte
    /// (`set_rx_latency(Duration::ZERO)`) and keeps the manuals' timing exactly from the first
    /// byte. Runs by itself before the simulation first moves (a step, a command, a
    /// transmission), after the stations were set up; adapters and UARTs declare their own
    /// (or, unannounced, nothing: the engine starts from an unknown port).
    fn declare(&mut self) {
        if !self.undeclared {
            return;
        }
        self.undeclared = false;
        for index in 0..self.slots.len() {
            if !self.slots[index].declared {
                self.slots[index].declared = true;
                self.slots[index].engine.rx_latency(Duration::ZERO);
                self.drain(index);
            }
        }
    }

    /// A BREAK reaches `station`'s receiver at `at`.
    pub fn schedule_break<E>(&mut self, station: StationId<E>, at: Instant) {
        self.schedule(at.max(self.now), What::Break { to: station.index });
    }

    /// Current virtual time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// The recorded trace (empty when recording is off).
    pub fn trace(&self) -> &Trace {
        static EMPTY: Trace = Trace {
            entries: Vec::new(),
        };
        self.trace.as_ref().unwrap_or(&EMPTY)
    }

    /// The station's engine, to inspect.
    pub fn engine<E: 'static>(&self, station: StationId<E>) -> &E {
        let engine: &dyn Any = &*self.slots[station.index].engine;
        engine
            .downcast_ref()
            .expect("StationId type matches the engine added")
    }

    /// Call the station's engine (a command such as `send`) at the current time, then drain its
    /// outputs into the simulation. Returns what the closure returns.
    pub fn with<E: 'static, R>(
        &mut self,
        station: StationId<E>,
        f: impl FnOnce(&mut E, Instant) -> R,
    ) -> R {
        self.declare();
        let now = self.now;
        let engine: &mut dyn Any = &mut *self.slots[station.index].engine;
        let engine = engine
            .downcast_mut()
            .expect("StationId type matches the engine added");
        let r = f(engine, now);
        self.drain(station.index);
        r
    }

    /// Put raw bytes on the line from `station` as if its engine had sent them (a scripted or
    /// misbehaving partner).
    pub fn transmit<E>(&mut self, station: StationId<E>, bytes: &[u8]) {
        self.declare();
        self.start_transmit(station.index, bytes);
    }

    /// Events the station's engine reported since the last call, oldest first.
    pub fn take_events<E>(&mut self, station: StationId<E>) -> Vec<E::Event>
    where
        E: Engine + 'static,
        E::Event: 'static,
    {
        self.slots[station.index]
            .events
            .drain(..)
            .filter_map(|e| e.downcast::<E::Event>().ok().map(|b| *b))
            .collect()
    }

    /// True when nothing is scheduled: no character in flight, no timer running (nor the
    /// queue entry of a timer cancelled before its deadline, which passes as a no-op step).
    pub fn is_quiet(&self) -> bool {
        self.queue.is_empty() && self.hot.is_none()
    }

    /// When the next happening is due, if any.
    fn next_at(&self) -> Option<Instant> {
        match (&self.hot, self.queue.peek()) {
            (Some(hot), Some(top)) => Some(hot.at.min(top.at)),
            (Some(hot), None) => Some(hot.at),
            (None, top) => top.map(|t| t.at),
        }
    }

    /// Process the next scheduled happening; false if there is none.
    pub fn step(&mut self) -> bool {
        self.declare();
        // The lane delivering characters is kept out of the queue (`hot`) while it stays ahead
        // of everything queued: an undisturbed burst costs no queue work at all.
        let from_queue = match (&self.hot, self.queue.peek()) {
            (None, None) => return false,
            (Some(hot), Some(top)) => (top.at, top.seq) < (hot.at, hot.seq),
            (hot, _) => hot.is_none(),
        };
        if from_queue {
            let next = self.queue.pop().expect("peeked");
            if let What::Char { .. } = next.what {
                if let Some(previous) = self.hot.replace(next) {
                    self.queue.push(previous);
                }
            } else {
                self.now = self.now.max(next.at);
                self.dispatch(next.what, (next.at, next.seq));
                return true;
            }
        }
        let hot = self.hot.as_mut().expect("a hot lane");
        let (at, what) = (hot.at, hot.what);
        let What::Char { burst, lane } = what else {
            unreachable!("only lanes are hot")
        };
        let (to, item, next) = self.bursts[burst as usize].advance(lane as usize);
        match next {
            Some((at, seq)) => {
                hot.at = at;
                hot.seq = seq;
            }
            None => {
                self.hot = None;
                self.lane_done(burst);
            }
        }
        self.now = self.now.max(at);
        self.receive(to, item);
        true
    }

    /// Process everything scheduled up to and including `until`, then set the clock to `until`.
    pub fn run_until(&mut self, until: Instant) {
        self.declare();
        while self.next_at().is_some_and(|at| at <= until) {
            self.step();
        }
        self.now = self.now.max(until);
    }

    /// [`run_until`](Self::run_until) `now + span`.
    pub fn run_for(&mut self, span: Duration) {
        self.run_until(self.now + span);
    }

    /// Run until nothing is scheduled or the clock would pass `limit`; true if quiet.
    pub fn run_until_quiet(&mut self, limit: Instant) -> bool {
        self.declare();
        while self.next_at().is_some_and(|at| at <= limit) {
            self.step();
        }
        self.is_quiet()
    }

    fn schedule(&mut self, at: Instant, what: What) {
        self.seq += 1;
        self.queue.push(Scheduled {
            at,
            seq: self.seq,
            what,
        });
    }

    fn schedule_key(&mut self, (at, seq): Key, what: What) {
        self.queue.push(Scheduled { at, seq, what });
    }

    #[inline]
    fn record(&mut self, station: usize, kind: TraceKind) {
        if self.trace.is_some() {
            self.record_entry(station, kind);
        }
    }

    #[cold]
    fn record_entry(&mut self, station: usize, kind: TraceKind) {
        if let Some(trace) = &mut self.trace {
            trace.entries.push(TraceEntry {
                at: self.now,
                station: self.slots[station].name.clone(),
                kind,
            });
        }
    }

    /// A character (or a line error) arrives at `to` now: at its engine, or at its adapter.
    fn receive(&mut self, to: usize, item: Result<u8, LineError>) {
        if let Some(fifo) = &mut self.slots[to].uart {
            if let Some((at, wake)) = fifo.arrive(self.now, item) {
                self.schedule(at, What::Uart { station: to, wake });
            }
            return;
        }
        if let Some(held) = &mut self.slots[to].adapter {
            held.pending.push(item);
            let (n, full) = (held.pending.len(), held.config.packet_bytes);
            let (latency, generation) = (held.config.latency, held.generation);
            if n >= full {
                self.hand_over(to);
            } else if n == 1 {
                let at = self.now + latency;
                self.schedule(
                    at,
                    What::AdapterFlush {
                        station: to,
                        generation,
                    },
                );
            }
            return;
        }
        let now = self.now;
        match item {
            Ok(byte) => {
                self.record(to, TraceKind::Rx { byte });
                self.slots[to].engine.rx(now, &[byte]);
            }
            Err(error) => {
                self.record(to, TraceKind::RxError { error });
                self.slots[to].engine.line_error(now, error);
            }
        }
        self.drain(to);
    }

    /// The adapter in front of `to` hands what it holds to the engine: each run of bytes in one
    /// `handle_rx` (recorded as one chunk), each line error on its own, in order, draining after
    /// each as the contract asks.
    fn hand_over(&mut self, to: usize) {
        let Some(held) = &mut self.slots[to].adapter else {
            return;
        };
        held.generation += 1;
        let mut packet = core::mem::take(&mut held.pending);
        let mut scratch = core::mem::take(&mut held.scratch);
        self.deliver(to, &packet, &mut scratch);
        packet.clear();
        if let Some(held) = &mut self.slots[to].adapter {
            held.pending = packet;
            held.scratch = scratch;
        }
    }

    /// The host reads the FIFO of the UART in front of `to` (see [`hand_over`](Self::hand_over)).
    fn uart_read(&mut self, to: usize) {
        let Some(fifo) = &mut self.slots[to].uart else {
            return;
        };
        let mut packet = core::mem::take(&mut fifo.pending);
        let mut scratch = core::mem::take(&mut fifo.scratch);
        self.deliver(to, &packet, &mut scratch);
        packet.clear();
        if let Some(fifo) = &mut self.slots[to].uart {
            fifo.pending = packet;
            fifo.scratch = scratch;
            fifo.emptied();
        }
    }

    /// Hands what a port held to `to`'s engine: each run of bytes in one `handle_rx`
    /// (recorded as one chunk), each line error on its own, in order, draining after each.
    fn deliver(&mut self, to: usize, packet: &[Result<u8, LineError>], scratch: &mut Vec<u8>) {
        adapter::runs(
            packet,
            |item| {
                let now = self.now;
                match item {
                    Ok(bytes) => {
                        if self.trace.is_some() {
                            let bytes = bytes.to_vec();
                            self.record(to, TraceKind::RxChunk { bytes });
                        }
                        self.slots[to].engine.rx(now, bytes);
                    }
                    Err(error) => {
                        self.record(to, TraceKind::RxError { error });
                        self.slots[to].engine.line_error(now, error);
                    }
                }
                self.drain(to);
            },
            scratch,
        );
    }

    /// Everything but a burst's characters (those are [`step`](Self::step)'s).
    #[inline(never)]
    fn dispatch(&mut self, what: What, key: Key) {
        let now = self.now;
        match what {
            What::Char { .. } => {}
            What::Break { to } => self.receive(to, Err(LineError::Break)),
            What::TxDone {
                station,
                generation,
            } => {
                if self.slots[station].tx_generation == generation {
                    self.slots[station].engine.tx_done(now);
                    self.drain(station);
                }
            }
            What::Timeout { station } => {
                let slot = &mut self.slots[station];
                if slot.timer_queued != Some(key) {
                    return; // superseded by an earlier deadline
                }
                slot.timer_queued = None;
                match slot.timer {
                    Some(armed) if armed == key => {
                        slot.timer = None;
                        slot.deadline = None;
                        slot.engine.timeout(now);
                        self.drain(station);
                    }
                    Some(later) => {
                        slot.timer_queued = Some(later);
                        self.schedule_key(later, What::Timeout { station });
                    }
                    None => {} // cancelled
                }
            }
            What::AdapterFlush {
                station,
                generation,
            } => {
                let live = self.slots[station]
                    .adapter
                    .as_ref()
                    .is_some_and(|h| h.generation == generation && !h.pending.is_empty());
                if live {
                    self.hand_over(station);
                }
            }
            What::Uart { station, wake } => {
                let Some(fifo) = &mut self.slots[station].uart else {
                    return;
                };
                match wake {
                    FifoWake::Timeout(generation) => {
                        if let Some((at, wake)) = fifo.timeout(now, generation) {
                            self.schedule(at, What::Uart { station, wake });
                        }
                    }
                    FifoWake::Read(generation) => {
                        if fifo.read(generation) {
                            self.uart_read(station);
                        }
                    }
                }
            }
        }
    }

    /// Drain a station's outputs until it waits (the contract's rule), acting on each.
    fn drain(&mut self, station: usize) {
        // Runs for every delivered character: the station itself needs no allocation, only
        // partners woken by a modem-signal change go on the (then allocated) list.
        let mut pending = Vec::new();
        self.drain_one(station, &mut pending);
        while let Some(s) = pending.pop() {
            self.drain_one(s, &mut pending);
        }
    }

    /// Drain one station until it waits; partners whose modem inputs it changed go on
    /// `pending`.
    fn drain_one(&mut self, s: usize, pending: &mut Vec<usize>) {
        loop {
            // The common case, a wait, stays here; the others are out of line.
            match self.slots[s].engine.poll() {
                Output::Wait(deadline) => {
                    self.set_timer(s, deadline);
                    break;
                }
                Output::Transmit(bytes) => self.on_transmit(s, bytes),
                Output::SetSignals(update) => self.on_signals(s, update, pending),
                Output::Event(event) => self.on_event(s, event),
            }
        }
    }

    #[inline(never)]
    fn on_transmit(&mut self, s: usize, bytes: bytes::Bytes) {
        if self.trace.is_some() {
            let bytes = bytes.to_vec();
            self.record(s, TraceKind::Tx { bytes });
        }
        self.start_transmit(s, &bytes);
    }

    #[inline(never)]
    fn on_signals(&mut self, s: usize, update: SignalUpdate, pending: &mut Vec<usize>) {
        self.record(s, TraceKind::Signals { update });
        if let Some(partner) = self.apply_signals(s, update) {
            pending.push(partner);
        }
    }

    #[inline(never)]
    fn on_event(&mut self, s: usize, event: Box<dyn Any>) {
        if self.trace.is_some() {
            let text = self.slots[s].engine.describe(event.as_ref());
            self.record(s, TraceKind::Event { text });
        }
        self.slots[s].events.push_back(event);
    }

    /// Arm (or cancel) a station's timer. Each change takes a fresh seq, so the timer keeps
    /// the place among same-instant happenings it would have if it were queued at once; only a
    /// deadline earlier than the queued entry is queued now.
    fn set_timer(&mut self, s: usize, deadline: Option<Instant>) {
        let slot = &mut self.slots[s];
        if slot.deadline == deadline {
            return;
        }
        slot.deadline = deadline;
        slot.timer = deadline.map(|at| {
            self.seq += 1;
            (at.max(self.now), self.seq)
        });
        if let Some(key) = slot.timer {
            if slot.timer_queued.is_none_or(|queued| key < queued) {
                slot.timer_queued = Some(key);
                self.schedule_key(key, What::Timeout { station: s });
            }
        }
    }

    /// Null-modem crossing: our RTS is the partner's CTS, our DTR its DSR and DCD.
    fn apply_signals(&mut self, s: usize, update: SignalUpdate) -> Option<usize> {
        let own = &mut self.slots[s].signals;
        own.rts = update.rts.unwrap_or(own.rts);
        own.dtr = update.dtr.unwrap_or(own.dtr);
        let own = *own;
        let Wiring::PointToPoint(p) = self.slots[s].wiring else {
            return None;
        };
        let partner = &mut self.slots[p].signals;
        let before = *partner;
        partner.cts = own.rts;
        partner.dsr = own.dtr;
        partner.dcd = own.dtr;
        let after = *partner;
        if before == after {
            return None;
        }
        self.slots[p].engine.signals(self.now, after);
        Some(p)
    }

    fn start_transmit(&mut self, s: usize, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        let now = self.now;
        let silenced = self.slots[s].silent_from.is_some_and(|t| now >= t);
        let slot = &mut self.slots[s];
        if slot.tx_free_at <= now {
            slot.burst_start = now;
            slot.burst_chars = 0;
        }
        let (t0, first) = (slot.burst_start, slot.burst_chars);
        slot.burst_chars += bytes.len() as u64;
        if !silenced {
            self.put_on_wire(s, bytes, t0, first);
        }
        let slot = &mut self.slots[s];
        slot.tx_free_at = slot.burst_start + slot.settings.chars_time(slot.burst_chars);
        slot.tx_generation += 1;
        let (at, generation) = (slot.tx_free_at, slot.tx_generation);
        self.schedule(
            at,
            What::TxDone {
                station: s,
                generation,
            },
        );
    }

    /// Put a burst on the sender's wire: one cursor per receiver, one lane per latency queued
    /// at its first delivery (see [`burst`]). Reserves the seqs the characters would have
    /// taken one by one, draws the
    /// receivers' faults in the order they always were drawn (character by character,
    /// receiver by receiver), and on a bus marks the characters colliding with other senders'.
    fn put_on_wire(&mut self, s: usize, bytes: &[u8], t0: Instant, first: u64) {
        let (bus, receivers) = match self.slots[s].wiring {
            Wiring::Unconnected => return,
            Wiring::PointToPoint(_) => (None, 1),
            Wiring::Bus(bus) => (Some(bus), self.buses[bus].len()),
        };
        if receivers == 0 {
            return;
        }
        let id = match self.free_bursts.pop() {
            Some(id) => id,
            None => {
                self.bursts.push(Burst::default());
                (self.bursts.len() - 1) as u32
            }
        };
        let seq_base = self.seq + 1;
        self.seq += 2 * receivers as u64 * bytes.len() as u64;
        let settings = self.slots[s].settings;
        let b = &mut self.bursts[id as usize];
        b.begin(s, bus, t0, first, settings, bytes, seq_base, receivers);
        let mut faulty = false;
        for i in 0..receivers {
            let to = match (self.slots[s].wiring, bus) {
                (Wiring::PointToPoint(p), _) => p,
                (_, Some(bus)) => self.buses[bus][i],
                _ => unreachable!("wired"),
            };
            let rx = &self.slots[to];
            let mismatch = rx.settings != settings;
            let latency = if to == s {
                Duration::ZERO
            } else {
                let f = rx.faults;
                faulty |= rx.corrupt.is_some() || [f.drop, f.bit_flip, f.insert].iter().any(draws);
                rx.faults.extra_latency
            };
            b.add_receiver(to, latency, mismatch);
        }
        if faulty {
            self.draw_faults(id);
        }
        if let Some(bus) = bus {
            self.collide(bus, id);
        }
        let b = &mut self.bursts[id as usize];
        b.start_lanes();
        for lane in 0..b.lanes() {
            if let Some((at, seq)) = b.key_if_live(lane) {
                self.queue.push(Scheduled {
                    at,
                    seq,
                    what: What::Char {
                        burst: id,
                        lane: lane as u32,
                    },
                });
            }
        }
        match (b.live, bus) {
            (0, _) => self.free_bursts.push(id),
            (_, Some(bus)) => self.bus_live[bus].push(id),
            (_, None) => {}
        }
    }

    /// Draw the seeded faults of a new burst's receivers (not the sender's own echo), exactly
    /// as they were drawn when every character was scheduled on its own: per character, per
    /// receiver: drop; else bit flip (and which bit), the scripted corruption, insertion (and
    /// the noise). Characters sent with another format still take their draws.
    fn draw_faults(&mut self, id: u32) {
        let b = &mut self.bursts[id as usize];
        let (len, receivers, sender) = (b.len(), b.receivers, b.sender);
        for k in 0..len {
            for c in &mut b.cursors[..receivers] {
                if c.to == sender {
                    continue;
                }
                let rx = &mut self.slots[c.to];
                let f = rx.faults;
                if self.rng.chance(f.drop) {
                    c.mods.push(Mod {
                        k,
                        drop: true,
                        xor: 0,
                        noise: None,
                    });
                    continue;
                }
                let mut xor = 0;
                if self.rng.chance(f.bit_flip) {
                    let bit = self.rng.below(u64::from(rx.settings.data_bits()));
                    xor ^= 1 << bit;
                }
                if let Some((nth, mask)) = rx.corrupt {
                    rx.corrupt = nth.checked_sub(1).map(|n| (n, mask));
                    if nth == 0 {
                        xor ^= mask;
                    }
                }
                let noise = self
                    .rng
                    .chance(f.insert)
                    .then(|| self.rng.next_u64() as u8 & rx.settings.data_mask());
                if xor != 0 || noise.is_some() {
                    c.mods.push(Mod {
                        k,
                        drop: false,
                        xor,
                        noise,
                    });
                }
            }
        }
    }

    /// RS-485: characters of a new burst that overlap in time with characters of another
    /// sender's burst still in flight on the bus garble each other, for every receiver.
    /// (Bursts that have left the line entirely cannot overlap: a new one starts no earlier
    /// than now, and a burst leaves at its last delivery, no earlier than its end.)
    fn collide(&mut self, bus: usize, id: u32) {
        let (start, end) = self.bursts[id as usize].span();
        for j in 0..self.bus_live[bus].len() {
            let other_id = self.bus_live[bus][j] as usize;
            let (new, other) = (&self.bursts[id as usize], &self.bursts[other_id]);
            let (o_start, o_end) = other.span();
            if other.sender == new.sender || !(o_start < end && start < o_end) {
                continue;
            }
            let theirs = other.overlapping(start, end);
            let ours = new.overlapping(o_start, o_end);
            self.bursts[other_id].garbled.push(theirs);
            self.bursts[id as usize].garbled.push(ours);
        }
    }

    /// A lane of `burst` has delivered its last character; the burst leaves the line (and
    /// goes back to the pool) with its last lane.
    #[inline(never)]
    fn lane_done(&mut self, id: u32) {
        let b = &mut self.bursts[id as usize];
        b.live -= 1;
        if b.live > 0 {
            return;
        }
        if let Some(bus) = b.bus {
            let live = &mut self.bus_live[bus];
            if let Some(pos) = live.iter().position(|&x| x == id) {
                live.swap_remove(pos);
            }
        }
        self.free_bursts.push(id);
    }
}

/// Whether [`SplitMix64::chance`] draws a number for this probability (it skips `p <= 0`
/// only, so a NaN draws too).
fn draws(p: &f64) -> bool {
    !matches!(p.partial_cmp(&0.0), Some(Ordering::Less | Ordering::Equal))
}

#[cfg(test)]
mod adapter_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod uart_tests;
