//! The tokio driver: runs any [`Engine`] over a byte stream.
//!
//! [`spawn`] moves an engine and a [`Transport`] (a serial port from `si_core::port::open` or a
//! `tokio-serial` stream with feature `serial`, a TCP stream to a serial device server, a
//! `tokio::io::duplex` pipe) into a task and gives back a [`Handle`]: commands go in with
//! [`Caller::call`] (a [`Handle`] is a [`Caller`]), events come out of
//! [`Handle::next_event`], and a job is run to its end with [`Caller::run_job`] (see "Job
//! routing"). [`Handle::close`] stops the driver and returns once the transport is dropped (the
//! port released); [`Handle::closed`] waits for the driver to end on its own.
//!
//! # Job routing
//!
//! Every protocol handle waits for its jobs the same way, written once here:
//! [`Caller::run_job`] starts a job inside the driver with the engine's
//! [`JobEnd::begin_job`] and routes to it the event its [`JobEnd::job_end`] recognises as the
//! job's end, keyed by the engine's [`JobId`]. (An engine without [`JobEnd`] can still register
//! its own start and matcher with [`Caller::job`].) The driver offers each event to the waiting jobs before the application's event
//! queue, so a job's outcome reaches exactly the caller that started it, even when an earlier
//! caller has stopped waiting (its outcome is then dropped, not handed to the next). A start
//! the engine refuses as busy ([`Start::Busy`]) waits in the driver, in call order, and is
//! offered again whenever the engine reports an event: one-job protocols queue there, not in
//! each handle.
//!
//! # Timing, honestly
//!
//! The driver feeds the engine `Instant`s from tokio's monotonic clock (microseconds since the
//! driver started) and re-checks every deadline whenever it wakes, for whatever reason, so a
//! timer is never missed and never fires early.
//!
//! Tokio's timer wheel has **1 ms granularity**: alone, it fires a deadline between 0 and about
//! 2 ms late, which turns Modbus's 1 ms end-of-frame gap at 57 600–115 200 bit/s into 2–3 ms.
//! So the driver uses tokio's timer only to get within [`PRECISE_LEAD`] (3 ms) of a deadline;
//! the last stretch is waited by one helper thread for all the process's drivers
//! (`si-driver-timer`, started on first use, ended when the last driver using it ends; see
//! [`precise_timer_drivers`]) that blocks on a condition variable with a timeout until the
//! earliest armed deadline (the kernel's high-resolution timers; on Linux the thread asks for
//! 1 µs of timer slack instead of the default 50 µs, so its waits end within some tens of µs
//! on an idle machine) and wakes that driver's task [`SPIN_BELOW`]
//! (50 µs) early; the driver yields to the runtime for the rest. The thread sleeps in the
//! kernel, so it burns no CPU; tokio's timer stays armed as a backstop. A
//! deadline already due when the engine names it (tx-done right after a write on a transport
//! without wire time) is handled at once, and whatever fell due while the driver slept reaches
//! the engine before the bytes or the command that woke it, except an engine deadline with
//! bytes waiting behind it: those go first (see "A late host").
//!
//! What remains is the operating system: scheduling latency under load (milliseconds on a
//! busy machine), and the port itself. A pseudo-terminal or a pipe delivers bytes at once; a
//! USB adapter delivers them in packets, when 62 bytes are waiting or its latency timer runs
//! out (16 ms by default on FTDI chips, 1–255 ms). A port opened with
//! `port::open` (feature `serial`) reads that timer on Linux
//! (`/sys/bus/usb-serial/devices/<tty>/latency_timer`) and the driver passes it to the engine
//! with [`Engine::set_rx_latency`] before the first byte, so engines can tell a hole between
//! two packets from silence; [`DriverOptions::port`] gives it for other transports (a serial
//! device server's packing delay). `si --latency-timer 1` (or
//! `PortOptions::latency_timer`) sets the timer to
//! 1 ms where the user may write it. A 3.5-character gap below a millisecond (Modbus above
//! 19 200 bit/s) still cannot be *enforced* from user space: the driver reports the gap the
//! kernel let it see. Use a converter with hardware framing where that matters, or let the
//! engine end frames by length where the protocol allows it (si-modbus's `FrameEnd::Length`).
//!
//! # A late host
//!
//! A host whose process was off the CPU for longer than an engine's silence timer (Modbus's
//! end-of-frame gap, [Modbus/USS] §3.3.5, Table 3-11, t3.5 of [Modbus serial] §2.5.1.1: a few
//! milliseconds) while a frame arrived wakes with the deadline expired and the rest of
//! the frame already in the port's buffer. Before the driver fires an expired deadline it
//! therefore takes what the transport holds without waiting and hands it to the engine first,
//! stamped just before the deadline; only a deadline with nothing waiting, a silence that
//! really happened, fires (the reading and its cost: the driver's `waiting` module). Each
//! deadline gets this once: one the bytes do not move (a response timeout) fires after them,
//! and a line that never pauses cannot hold it off.
//!
//! "Transmission done" ([`Engine::handle_tx_done`]) is reported when the write has completed
//! *and*, if [`DriverOptions::settings`] is given, the bytes' character time has passed since the
//! write began: a serial driver's write returns while the UART still shifts bytes out.
//!
//! # Line errors
//!
//! A port from `port::open` (feature `serial`) on Linux marks parity and framing errors and
//! BREAKs in the received stream (`PARMRK`); when the driver takes the port over
//! ([`Transport::attach`]) it decodes the marks ([`crate::linemark`]) and hands the engine data
//! runs and [`LineError`]s in the order they arrived
//! ([`crate::rx_path`]), so the manuals' 080C/0810/0811/080D codes are reachable on real
//! hardware. A marked bad character is reported as a parity error on a line with a checked
//! parity bit and as a framing error on one without (the kernel cannot tell them apart);
//! overruns are counted by the kernel, not marked. On other platforms, and with
//! `PortOptions::no_line_errors`, a bad character arrives as a plain byte and no line error
//! reaches the engine. Traces record the decoded bytes and the errors (`rx_chunk`,
//! `rx_error`).
//!
//! # RS-485
//!
//! For adapters that do not switch their transceiver themselves, the driver raises RTS before a
//! transmission and drops it [`RtsToggle::after`] past tx-done ([`PortFacts::rts_toggle`]); the
//! kernel's own RS-485 mode (`port::Rs485::Kernel`, Linux) is more exact where the port's
//! driver has it. On a port that hears its own transmission ([`PortFacts::local_echo`]), the
//! received bytes that repeat what was sent, within the transmit window plus the port's
//! latency, are dropped before the engine sees them ([`crate::echo`]).
//!
//! # Logs
//!
//! The driver reports what it does through `tracing` (target `si_core::driver`), so a program
//! sees it with any subscriber, and `si -v`/`-vv`/`-vvv` prints it on stderr:
//!
//! | level | what | from |
//! |---|---|---|
//! | INFO | each frame sent and received, decoded as text (`sent FC03 req: …`) | [`crate::frame_log::FrameLog`], the transport wrapper that knows the protocol |
//! | DEBUG | the raw bytes of every write and read in hex, line errors, modem-signal changes, and each event the engine reports (its `Debug` form) | this driver |
//! | TRACE | timers: the engine's deadline when it changes, each timeout and tx-done as it fires | this driver |
//!
//! WARN is kept for trouble the line survives (a trace file that cannot be written, no precise
//! timer thread). Frames are INFO only through a [`FrameLog`](crate::frame_log::FrameLog)
//! around the transport: the driver moves bytes for any engine and cannot name a frame.

use crate::job::{JobEnd, JobId, NotStarted};
use crate::linemark::Marked;
pub use crate::port_facts::{PortFacts, RtsToggle};
use crate::rx_path::RxPath;
use crate::sansio::{Engine, LineError, ModemSignals, Output, SignalUpdate};
use crate::serial::SerialSettings;
use crate::time::{Duration, Instant};
use crate::trace::TraceKind;
use crate::tracefile::Recorder;
use precise_timer::PreciseTimer;
pub use precise_timer::{precise_timer_drivers, PRECISE_LEAD, SPIN_BELOW};
use std::io;
use std::ops::ControlFlow;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::sync::{mpsc, oneshot};
use tokio::task::JoinHandle;

mod events;
mod precise_timer;
mod waiting;

/// A byte stream the driver can run an engine over, with optional modem-signal access.
///
/// The default methods say "no modem signals": right for TCP and in-memory pipes.
pub trait Transport: AsyncRead + AsyncWrite + Unpin + Send + 'static {
    /// Set RTS/DTR. Transports without them ignore the request.
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        let _ = update;
        Ok(())
    }

    /// Read CTS/DSR/DCD (and the current RTS/DTR); `None` if the transport has no signals.
    fn read_signals(&mut self) -> io::Result<Option<ModemSignals>> {
        Ok(None)
    }

    /// A driver takes this transport over: what must it know about the port behind it
    /// ([`PortFacts`]): its delivery latency, RS-485 direction control, local echo, and whether
    /// reads from now on return a `PARMRK`-marked stream for the driver to decode (a port that
    /// marks line errors hands plain readers clean bytes and switches to the marked stream
    /// here). Called once, before the first read. The default is a plain byte stream.
    fn attach(&mut self) -> PortFacts {
        PortFacts::default()
    }

    /// Characters the port lost since the last call that the stream cannot show: the kernel
    /// counts UART and buffer overruns (Linux `TIOCGICOUNT`) but does not mark them. The
    /// driver asks after each read and reports a rise as one [`LineError::Overrun`] after
    /// that read's bytes. The default: a transport that loses nothing it could count.
    fn new_overruns(&mut self) -> u64 {
        0
    }
}

impl Transport for tokio::net::TcpStream {}
impl Transport for tokio::io::DuplexStream {}

#[cfg(feature = "serial")]
#[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
impl Transport for tokio_serial::SerialStream {
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        use tokio_serial::SerialPort;
        if let Some(rts) = update.rts {
            self.write_request_to_send(rts)?;
        }
        if let Some(dtr) = update.dtr {
            self.write_data_terminal_ready(dtr)?;
        }
        Ok(())
    }

    fn read_signals(&mut self) -> io::Result<Option<ModemSignals>> {
        use tokio_serial::SerialPort;
        // Pseudo-terminals have no modem lines; report "none" rather than failing.
        let (Ok(cts), Ok(dsr), Ok(dcd)) = (
            self.read_clear_to_send(),
            self.read_data_set_ready(),
            self.read_carrier_detect(),
        ) else {
            return Ok(None);
        };
        Ok(Some(ModemSignals {
            cts,
            dsr,
            dcd,
            ..ModemSignals::default()
        }))
    }
}

/// How the driver runs.
#[derive(Debug, Clone)]
pub struct DriverOptions {
    /// The line's character format, used to report tx-done only after the bytes' character
    /// time. `None` reports it when the write completes.
    pub settings: Option<SerialSettings>,
    /// How often modem inputs are polled on transports that have them.
    pub signal_poll: std::time::Duration,
    /// Events buffered for the application before the driver stops reading the line (nothing
    /// is dropped: the OS buffers the line meanwhile), or drops them
    /// ([`drop_unread_events`](Self::drop_unread_events)).
    pub event_capacity: usize,
    /// When `event_capacity` events wait unread, drop further ones instead of pausing the
    /// line. For handles whose users need not read events (job outcomes are routed to their
    /// callers, received data stays in the engine until asked for): a program that only sends
    /// must not stall the line it sends on.
    pub drop_unread_events: bool,
    /// Record what the driver sees into a trace file ([`crate::tracefile`]): every write as
    /// `tx`, every read as `rx_chunk`, signal changes and the engine's events (their `Debug`
    /// form), under the recorder's station name. `si monitor --trace` reads it back.
    pub recorder: Option<Recorder>,
    /// What the port needs from the driver beyond what the transport says
    /// ([`Transport::attach`], right for ports from `si_core::port::open`): a latency, RTS
    /// toggling or a marked stream given here is used where the transport gives none, local
    /// echo where either asks for it.
    pub port: Option<PortFacts>,
}

impl Default for DriverOptions {
    fn default() -> Self {
        DriverOptions {
            settings: None,
            signal_poll: std::time::Duration::from_millis(10),
            event_capacity: 1024,
            drop_unread_events: false,
            recorder: None,
            port: None,
        }
    }
}

/// What a job's start did ([`Caller::job`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Start<K, R> {
    /// The job runs; the event that ends it is recognised with this key (a `JobId`, or `()`
    /// for an engine that runs one job at a time).
    Running(K),
    /// The job has its outcome at once (a refusal, or nothing to wait for).
    Ended(R),
    /// The engine runs another job: the start is offered again after the engine's next event.
    Busy,
}

/// A job waiting in the driver for the event that ends it: takes an event and gives it back
/// if it is not its own.
type Waiter<Ev> = Box<dyn FnMut(Ev) -> Option<Ev> + Send>;

/// One attempt to start a job: `None` if the engine was busy, else the waiter (if the job runs).
type Attempt<E> =
    Box<dyn FnMut(&mut E, Instant) -> Option<Option<Waiter<<E as Engine>::Event>>> + Send>;

/// A closure run on the engine ([`Caller::send`]).
type Run<E> = Box<dyn FnOnce(&mut E, Instant) + Send>;

enum Command<E: Engine> {
    /// Run a closure on the engine.
    Run(Run<E>),
    /// Start a job and route its outcome ([`Caller::job`]).
    Job(Attempt<E>),
    /// End the driver: it drops the transport (releasing the port) and every job waiting
    /// ends with [`DriverStopped`] ([`Handle::close`]).
    Stop,
}

/// The jobs the driver routes: those waiting for their end, those waiting to start.
struct Jobs<E: Engine> {
    waiting: Vec<Waiter<E::Event>>,
    deferred: std::collections::VecDeque<Attempt<E>>,
}

impl<E: Engine> Jobs<E> {
    fn new() -> Self {
        Jobs {
            waiting: Vec::new(),
            deferred: std::collections::VecDeque::new(),
        }
    }

    /// A new job: started now unless earlier ones wait to start (call order is kept).
    fn start(&mut self, engine: &mut E, now: Instant, attempt: Attempt<E>) {
        self.deferred.push_back(attempt);
        self.retry(engine, now);
    }

    /// Start the jobs waiting to start, in order, until the engine is busy.
    fn retry(&mut self, engine: &mut E, now: Instant) {
        while let Some(attempt) = self.deferred.front_mut() {
            match attempt(engine, now) {
                None => return,
                Some(waiter) => {
                    self.deferred.pop_front();
                    self.waiting.extend(waiter);
                }
            }
        }
    }

    /// Hand `event` to the job it ends, if any; otherwise give it back for the application.
    fn route(&mut self, mut event: E::Event) -> Option<E::Event> {
        for i in 0..self.waiting.len() {
            match (self.waiting[i])(event) {
                None => {
                    drop(self.waiting.remove(i));
                    return None;
                }
                Some(other) => event = other,
            }
        }
        Some(event)
    }
}

/// The commanding side of a running driver: clonable, so several tasks can run jobs while one
/// takes the events from the [`Handle`].
pub struct Caller<E: Engine> {
    commands: mpsc::UnboundedSender<Command<E>>,
}

impl<E: Engine> Clone for Caller<E> {
    fn clone(&self) -> Self {
        Caller {
            commands: self.commands.clone(),
        }
    }
}

/// The application's side of a running driver: a [`Caller`] (which it dereferences to) and the
/// engine's events.
pub struct Handle<E: Engine> {
    caller: Caller<E>,
    events: events::Receiver<E::Event>,
    /// Set once the driver task has ended and dropped its transport.
    released: tokio::sync::watch::Receiver<bool>,
}

impl<E: Engine> std::ops::Deref for Handle<E> {
    type Target = Caller<E>;
    fn deref(&self) -> &Caller<E> {
        &self.caller
    }
}

/// The driver task has ended (the transport closed or failed); its `JoinHandle` says why.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the driver has stopped: the port was closed or failed")]
pub struct DriverStopped;

/// An I/O error (opening a port) that the handles' error enums can clone and compare: equal
/// when kind and message are.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{0}")]
pub struct IoError(pub std::sync::Arc<io::Error>);

impl IoError {
    /// The error's kind: `ResourceBusy` for a port another handle or program holds, `NotFound`
    /// for a path that does not exist.
    pub fn kind(&self) -> io::ErrorKind {
        self.0.kind()
    }
}

impl PartialEq for IoError {
    fn eq(&self, other: &Self) -> bool {
        self.kind() == other.kind() && self.0.to_string() == other.0.to_string()
    }
}

impl Eq for IoError {}

impl From<io::Error> for IoError {
    fn from(e: io::Error) -> Self {
        IoError(std::sync::Arc::new(e))
    }
}

/// Why [`Caller::run_job`] gave no output: the engine refused the job (`R`, its
/// [`JobEnd::Refusal`]), the job ended badly (`F`, its [`JobEnd::Failure`]), or the driver
/// stopped. Each protocol's handle turns it into its own error's `Refused`, `Failed` and
/// `Stopped`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum JobError<R, F> {
    /// The engine refused to start the job.
    Refused(R),
    /// The job ran and ended with this failure.
    Failed(F),
    /// The driver has stopped.
    Stopped,
}

impl<R, F> From<DriverStopped> for JobError<R, F> {
    fn from(_: DriverStopped) -> Self {
        JobError::Stopped
    }
}

impl<E: Engine> Caller<E> {
    /// Run `f` on the engine inside the driver at the current time (a command such as `send`),
    /// drain the outputs it causes, and return its result.
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut E, Instant) -> R + Send + 'static,
    ) -> Result<R, DriverStopped> {
        let (tx, rx) = oneshot::channel();
        self.send(move |engine, now| {
            let _ = tx.send(f(engine, now));
        })?;
        rx.await.map_err(|_| DriverStopped)
    }

    /// Run `f` on the engine inside the driver and drain the outputs it causes, without
    /// waiting for it: one channel send, no reply.
    pub fn send(
        &self,
        f: impl FnOnce(&mut E, Instant) + Send + 'static,
    ) -> Result<(), DriverStopped> {
        self.commands
            .send(Command::Run(Box::new(f)))
            .map_err(|_| DriverStopped)
    }

    /// Start a job inside the driver and wait for its outcome ("Job routing" in the module
    /// docs). `start` runs on the engine (again, later, for as long as it says
    /// [`Start::Busy`]); for a running job, `done` is offered the engine's events, keyed by
    /// what `start` returned, and returns `Break(outcome)` for the event that ends the job or
    /// `Continue(event)` to pass the event on. Events no job takes reach
    /// [`Handle::next_event`].
    ///
    /// Dropping the future does not cancel the job: the engine runs it to its end and the
    /// driver drops the outcome.
    pub async fn job<K, R>(
        &self,
        mut start: impl FnMut(&mut E, Instant) -> Start<K, R> + Send + 'static,
        done: impl FnMut(&K, E::Event) -> ControlFlow<R, E::Event> + Send + 'static,
    ) -> Result<R, DriverStopped>
    where
        K: Send + 'static,
        R: Send + 'static,
        E::Event: 'static,
    {
        let (tx, rx) = oneshot::channel();
        let mut reply = Some(tx);
        let mut done = Some(done);
        let attempt: Attempt<E> = Box::new(move |engine, now| match start(engine, now) {
            Start::Busy => None,
            Start::Ended(outcome) => {
                if let Some(reply) = reply.take() {
                    let _ = reply.send(outcome);
                }
                Some(None)
            }
            Start::Running(key) => {
                let mut reply = reply.take();
                let mut done = done.take()?;
                let waiter: Waiter<E::Event> = Box::new(move |event| match done(&key, event) {
                    ControlFlow::Break(outcome) => {
                        if let Some(reply) = reply.take() {
                            let _ = reply.send(outcome);
                        }
                        None
                    }
                    ControlFlow::Continue(other) => Some(other),
                });
                Some(Some(waiter))
            }
        });
        self.commands
            .send(Command::Job(attempt))
            .map_err(|_| DriverStopped)?;
        rx.await.map_err(|_| DriverStopped)
    }
}

impl<E: JobEnd> Caller<E>
where
    E::Job: Send + 'static,
    E::Output: Send + 'static,
    E::Refusal: Send + 'static,
    E::Failure: Send + 'static,
    E::Event: 'static,
{
    /// Run `job` to its end: started with [`JobEnd::begin_job`] inside the driver (queued
    /// there, in call order, while the engine is busy) and ended by the event
    /// [`JobEnd::job_end`] recognises as its own. Every protocol handle runs its jobs
    /// through this one method.
    ///
    /// Dropping the future does not cancel the job: the engine runs it to its end and the
    /// driver drops the outcome.
    pub async fn run_job(
        &self,
        job: E::Job,
    ) -> Result<E::Output, JobError<E::Refusal, E::Failure>> {
        let start = move |engine: &mut E, now| match engine.begin_job(now, job.clone()) {
            Ok(id) => Start::Running(id),
            Err(NotStarted::Busy) => Start::Busy,
            Err(NotStarted::Refused(why)) => Start::Ended(Err(JobError::Refused(why))),
        };
        let done = |id: &JobId, event: E::Event| match E::job_end(&event) {
            Some((ended, outcome)) if ended == *id => {
                ControlFlow::Break(outcome.map_err(JobError::Failed))
            }
            _ => ControlFlow::Continue(event),
        };
        self.job(start, done).await?
    }
}

impl<E: Engine> Handle<E> {
    /// Stop the driver without waiting: it drops the transport as soon as its task runs, and
    /// every caller's job ends with [`DriverStopped`]. For a handle's `Drop`.
    pub fn stop(&self) {
        let _ = self.caller.commands.send(Command::Stop);
    }

    /// Stop the driver and return once it has dropped the transport: the port is released
    /// and may be opened again at once.
    pub async fn close(&self) {
        self.stop();
        self.closed().await;
    }

    /// Wait until the driver has stopped (the port closed or failed, or [`close`](Self::close)
    /// was called) and released the transport.
    pub async fn closed(&self) {
        let mut released = self.released.clone();
        let _ = released.wait_for(|done| *done).await;
    }

    /// A clonable commanding side.
    pub fn caller(&self) -> Caller<E> {
        self.caller.clone()
    }

    /// The next event the engine reported that no job took; `None` once the driver has
    /// stopped and every event has been taken.
    pub async fn next_event(&mut self) -> Option<E::Event> {
        self.events.recv().await
    }

    /// An event already waiting, without waiting for one.
    pub fn try_next_event(&mut self) -> Option<E::Event> {
        self.events.try_recv()
    }
}

/// Start a driver task for `engine` over `transport`. Dropping the [`Handle`] stops the task;
/// the `JoinHandle` returns the I/O error that ended it, if any.
pub fn spawn<E, T>(
    engine: E,
    transport: T,
    options: DriverOptions,
) -> (Handle<E>, JoinHandle<io::Result<()>>)
where
    E: Engine + Send + 'static,
    E::Event: Send + 'static,
    T: Transport,
{
    let (command_tx, command_rx) = mpsc::unbounded_channel();
    let (event_tx, event_rx) = events::channel(options.event_capacity);
    let (released_tx, released) = tokio::sync::watch::channel(false);
    let task = tokio::spawn(async move {
        // `run` owns the transport: once it returns, the port is closed.
        let ended = run(engine, transport, options, command_rx, event_tx).await;
        released_tx.send_replace(true);
        // The application sees only that the driver stopped (DriverStopped): say why here,
        // e.g. an adapter unplugged, or a port that cannot set RTS (a pseudo-terminal).
        match &ended {
            // A hang-up (pty closed, USB adapter pulled: EIO/ENODEV/ENXIO, a peer's reset) is
            // what the application reports itself as a lost line: said once, there.
            Err(e) if hung_up(e) => tracing::debug!("the line closed: {e}"),
            Err(e) => tracing::error!("the line failed: {e}"),
            Ok(()) => {}
        }
        ended
    });
    (
        Handle {
            caller: Caller {
                commands: command_tx,
            },
            events: event_rx,
            released,
        },
        task,
    )
}

/// Is `e` the port going away rather than something the application could not know?
fn hung_up(e: &io::Error) -> bool {
    // EIO, ENXIO and ENODEV (Linux and the BSDs agree on these numbers).
    const HANG_UPS: [i32; 3] = [5, 6, 19];
    matches!(
        e.kind(),
        io::ErrorKind::BrokenPipe
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::UnexpectedEof
    ) || e.raw_os_error().is_some_and(|n| HANG_UPS.contains(&n))
}

/// The clock the driver passes its engine's time on: [`Instant`]s in microseconds since the
/// clock started, read from tokio's clock (so paused test time applies). Anything beside an
/// engine that keeps time of its own in [`Instant`]s (a gateway's unit demotion, say) uses
/// one too, so there is one way to turn the process's time into an engine's.
#[derive(Debug, Clone, Copy)]
pub struct Clock(tokio::time::Instant);

impl Clock {
    /// A clock starting now (its [`now`](Self::now) is 0 at first).
    pub fn start() -> Clock {
        Clock(tokio::time::Instant::now())
    }

    /// The time since the clock started.
    pub fn now(&self) -> Instant {
        Instant::from_micros(self.0.elapsed().as_micros() as u64)
    }

    /// The tokio instant of `at` on this clock (to sleep until it).
    pub fn to_tokio(&self, at: Instant) -> tokio::time::Instant {
        self.0 + std::time::Duration::from_micros(at.as_micros())
    }
}

/// Yields in a row for one deadline before the driver leaves it to the wheel: never reached
/// in real time (a yield costs a system call), only when the clock stands still (tokio's
/// paused test clock).
const MAX_SPINS: u32 = 1_000;

async fn run<E, T>(
    mut engine: E,
    mut io: T,
    options: DriverOptions,
    mut commands: mpsc::UnboundedReceiver<Command<E>>,
    events: events::Sender<E::Event>,
) -> io::Result<()>
where
    E: Engine,
    T: Transport,
{
    let clock = Clock::start();
    let record = |kind: TraceKind| {
        if let Some(r) = &options.recorder {
            if let Err(e) = r.record(kind) {
                tracing::warn!("trace recording failed: {e}");
            }
        }
    };
    let facts = options.port.unwrap_or_default().or(io.attach());
    if let Some(latency) = facts.rx_latency {
        engine.set_rx_latency(latency);
    }
    let mut rx = Receive {
        path: RxPath::new(&facts),
        buf: [0u8; 512],
        recording: options.recorder.is_some(),
        record: &record,
        floor: Instant::from_micros(0),
        rescued: None,
    };
    let mut direction = Direction::new(facts.rts_toggle);
    // How long after tx-done our own echo may still arrive: the port's delivery latency, or
    // a USB adapter's default latency timer when the port did not say.
    let echo_grace = facts.rx_latency.unwrap_or(ECHO_GRACE);
    let mut tx_done_at: Option<Instant> = None;
    let mut signals = io.read_signals()?;
    let mut poll = tokio::time::interval(options.signal_poll);
    poll.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut precise = PreciseTimer::default();
    // One wheel timer for the driver's life, moved only when its target changes (a new
    // `sleep_until` per wake-up would register and deregister a wheel entry every time).
    let wheel = tokio::time::sleep_until(clock.0);
    tokio::pin!(wheel);
    let mut wheel_set: Option<Instant> = None;
    let mut spins = 0u32;
    let mut jobs = Jobs::<E>::new();
    // The engine's deadline last logged (TRACE, "Logs").
    let mut timer: Option<Instant> = None;

    loop {
        // Drain until Wait, acting on every output.
        let mut deadline = loop {
            match engine.poll_output() {
                Output::Transmit(bytes) => {
                    tracing::debug!("tx {}", crate::hex::format(&bytes));
                    if options.recorder.is_some() {
                        record(TraceKind::Tx {
                            bytes: bytes.to_vec(),
                        });
                    }
                    if let Some(update) = direction.before_write(&mut io)? {
                        record(TraceKind::Signals { update });
                        if direction.lead() > Duration::ZERO {
                            tokio::time::sleep(direction.lead().into()).await;
                        }
                    }
                    let started = clock.now();
                    io.write_all(&bytes).await?;
                    io.flush().await?;
                    let ends = |settings: Option<SerialSettings>| {
                        let on_wire = settings
                            .map_or(started, |s| started + s.chars_time(bytes.len() as u64));
                        on_wire.max(clock.now())
                    };
                    let at = ends(options.settings);
                    let done = tx_done_at.map_or(at, |t| t.max(at));
                    tx_done_at = Some(done);
                    // RTS off and the echo window follow the wire, whatever the engine is told.
                    let on_wire = done.max(ends(options.settings.or(facts.wire)));
                    direction.written(on_wire);
                    rx.path.sent(&bytes, on_wire + echo_grace);
                }
                Output::SetSignals(update) => {
                    tracing::debug!("signals {update:?}");
                    record(TraceKind::Signals { update });
                    io.set_signals(update).map_err(|e| {
                        io::Error::new(e.kind(), format!("cannot set the RTS/DTR outputs: {e}"))
                    })?
                }
                Output::Event(event) => {
                    tracing::debug!("event {event:?}");
                    if options.recorder.is_some() {
                        record(TraceKind::Event {
                            text: format!("{event:?}"),
                        });
                    }
                    let Some(event) = jobs.route(event) else {
                        continue;
                    };
                    if options.drop_unread_events {
                        if let Err(events::TrySendError::Closed) = events.try_send(event) {
                            return Ok(()); // the application is gone
                        }
                    } else if events.send(event).await.is_err() {
                        return Ok(()); // the application is gone
                    }
                }
                Output::Wait(deadline) => break deadline,
            }
        };
        if deadline != timer {
            timer = deadline;
            match deadline {
                Some(at) => tracing::trace!("timer set for {at} (now {})", clock.now()),
                None => tracing::trace!("timer stopped"),
            }
        }
        // A start the engine refused as busy may go now; it may cause outputs.
        if !jobs.deferred.is_empty() {
            let before = jobs.deferred.len();
            rx.floor = clock.now();
            jobs.retry(&mut engine, rx.floor);
            if jobs.deferred.len() != before {
                continue;
            }
        }

        // A deadline already due (tx-done right after a write to a port without wire time) is
        // handled at once: tokio's wheel would round it up to its next millisecond tick. The
        // budget makes an engine that keeps asking for a past deadline yield to other tasks.
        let next = Instant::earliest(deadline, Instant::earliest(tx_done_at, direction.off_at));
        if next.is_some_and(|at| at <= clock.now()) {
            precise.disarm();
            tokio::task::consume_budget().await;
            let now = clock.now();
            rx.catch_up(&mut engine, &mut io, &mut tx_done_at, deadline, now)
                .await?;
            direction.due(now, &mut io, &record)?;
            continue;
        }

        // Tokio's wheel until PRECISE_LEAD before the next deadline, then the precise thread
        // until SPIN_BELOW before it, then yielding to the runtime until it has passed (with
        // the wheel at the deadline itself as a backstop).
        let mut wheel_at = next;
        let mut spin = false;
        match next.map(|at| (at, at - clock.now())) {
            Some((at, remaining)) if remaining > PRECISE_LEAD => {
                precise.disarm();
                wheel_at = Some(Instant::from_micros(
                    at.as_micros() - PRECISE_LEAD.as_micros(),
                ));
            }
            Some((at, remaining)) if remaining > SPIN_BELOW => {
                precise.arm(at, remaining.saturating_sub(SPIN_BELOW))
            }
            Some(_) => {
                precise.disarm();
                // Bounded: under tokio's paused test clock time only moves when the runtime
                // idles, which yielding prevents; then the wheel (backstop) takes over.
                spin = spins < MAX_SPINS;
                spins += 1;
            }
            None => precise.disarm(),
        }
        if !spin {
            spins = 0;
        }
        if let Some(at) = wheel_at.filter(|&at| wheel_set != Some(at)) {
            wheel.as_mut().reset(clock.to_tokio(at));
            wheel_set = Some(at);
        }

        tokio::select! {
            command = commands.recv() => match command {
                Some(command) => {
                    // What fell due while we slept goes first (bytes that waited in the port
                    // before an expired deadline, "A late host"): the command sees the state
                    // the line has reached.
                    let now = clock.now();
                    rx.catch_up(&mut engine, &mut io, &mut tx_done_at, deadline.take(), now)
                        .await?;
                    direction.due(now, &mut io, &record)?;
                    rx.floor = now;
                    match command {
                        Command::Run(f) => f(&mut engine, now),
                        Command::Job(attempt) => jobs.start(&mut engine, now, attempt),
                        Command::Stop => return Ok(()),
                    }
                }
                None => return Ok(()),
            },
            read = io.read(&mut rx.buf) => {
                let n = read?;
                if n == 0 {
                    return Ok(());
                }
                let now = clock.now();
                let expired = deadline.take();
                match rx.rescuable(expired, now) {
                    // The deadline expired while these bytes waited ("A late host"): they
                    // go first, and the engine names its deadline again.
                    Some(expired) => rx.deliver_late(&mut engine, &mut io, &mut tx_done_at, expired, n, now),
                    None => {
                        // A tx-done or timeout that fell due before these bytes came goes
                        // first (a slave must know its answer has left before it judges the
                        // next request).
                        fire_due(&mut engine, &mut tx_done_at, expired, now);
                        rx.deliver(&mut engine, &mut io, n, now);
                        rx.floor = now;
                    }
                }
                direction.due(now, &mut io, &record)?;
            }
            _ = &mut wheel, if wheel_at.is_some() => wheel_set = None,
            _ = precise.fired(), if precise.is_armed() => precise.fired_seen(),
            _ = tokio::task::yield_now(), if spin => {}
            _ = poll.tick(), if signals.is_some() => {
                let now_signals = io.read_signals()?;
                if now_signals != signals {
                    signals = now_signals;
                    if let Some(s) = signals {
                        let now = clock.now();
                        engine.handle_signals(now, s);
                        rx.floor = now;
                    }
                }
            }
        }

        // Whatever woke us, look at the clock: timers are checked, not trusted; an expired
        // deadline fires only if no bytes waited behind it ("A late host").
        let now = clock.now();
        rx.catch_up(&mut engine, &mut io, &mut tx_done_at, deadline, now)
            .await?;
        direction.due(now, &mut io, &record)?;
    }
}

/// The driver's receiving side: the port's receive path, the read buffer, and how bytes found
/// waiting behind an expired deadline reach the engine ([`waiting`], "A late host").
struct Receive<'r, F: Fn(TraceKind)> {
    path: RxPath,
    buf: [u8; 512],
    /// A trace is recorded (the bytes are copied for it only then).
    recording: bool,
    record: &'r F,
    /// The latest instant the engine has been told (the driver sets it wherever it tells the
    /// engine anything): bytes stamped back to an expired deadline never go before it (the
    /// engine's time never runs backwards).
    floor: Instant,
    /// The expired deadline bytes were last handed over before. Once is all a deadline gets:
    /// what a read finds then waited while the driver was late; if the engine names the same
    /// deadline again (one that bytes do not move, a response timeout), more bytes can only
    /// have come since, and a line that never pauses (a flood) must not hold it off.
    rescued: Option<Instant>,
}

impl<F: Fn(TraceKind)> Receive<'_, F> {
    /// Hand the first `n` bytes of the buffer (one read) to the engine at `at` through the
    /// receive path, recording what the line carried; then a rise in the port's overrun count.
    fn deliver<E: Engine, T: Transport>(
        &mut self,
        engine: &mut E,
        io: &mut T,
        n: usize,
        at: Instant,
    ) {
        let (recording, record) = (self.recording, self.record);
        self.path
            .deliver(engine, at, &self.buf[..n], |piece| match piece {
                Marked::Data(bytes) => {
                    tracing::debug!("rx {}", crate::hex::format(bytes));
                    if recording {
                        record(TraceKind::RxChunk {
                            bytes: bytes.to_vec(),
                        })
                    }
                }
                Marked::Error(error) => {
                    tracing::debug!("rx line error: {error:?}");
                    record(TraceKind::RxError { error })
                }
            });
        // An overrun lost characters somewhere around this read; where exactly the counter
        // cannot say, so it is reported after the read's bytes (`[derived]`): the frame they
        // belong to, or the one they end, is judged corrupt.
        let lost = io.new_overruns();
        if lost > 0 {
            let error = LineError::Overrun;
            tracing::debug!("rx line error: {error:?} ({lost} characters lost)");
            record(TraceKind::RxError { error });
            engine.handle_line_error(at, error);
        }
    }

    /// The engine's `deadline` if it has expired by `now` and bytes waiting behind it may still
    /// go first (not already done once for it, [`rescued`](Self::rescued)).
    fn rescuable(&self, deadline: Option<Instant>, now: Instant) -> Option<Instant> {
        deadline.filter(|&d| now >= d && self.rescued != Some(d))
    }

    /// The first `n` bytes of the buffer were read at `now`, after the engine's deadline
    /// `expired`: they waited in the port while the driver was late, so they reach the engine
    /// stamped just before that deadline ([`waiting::stamp_waiting`]), and the deadline is not
    /// fired (the engine names its deadline again). A tx-done due by `now` still goes first,
    /// at the same instant, and the bytes are never stamped before it was due.
    fn deliver_late<E: Engine, T: Transport>(
        &mut self,
        engine: &mut E,
        io: &mut T,
        tx_done_at: &mut Option<Instant>,
        expired: Instant,
        n: usize,
        now: Instant,
    ) {
        let tx_done = tx_done_at.filter(|&t| now >= t);
        let floor = tx_done.map_or(self.floor, |t| t.max(self.floor));
        let at = waiting::stamp_waiting(expired, now, floor);
        tracing::trace!("deadline {expired} expired with bytes waiting (now {now}): rx at {at}");
        if let Some(due) = tx_done {
            *tx_done_at = None;
            tracing::trace!("tx done (due {due}, now {now}, told {at})");
            engine.handle_tx_done(at);
        }
        self.deliver(engine, io, n, at);
        self.floor = at;
        self.rescued = Some(expired);
    }

    /// What fell due by `now` reaches the engine: bytes waiting behind an expired `deadline`
    /// first ([`waiting_first`](Self::waiting_first)); without them, a tx-done and the deadline
    /// that are due ([`fire_due`]).
    async fn catch_up<E: Engine, T: Transport>(
        &mut self,
        engine: &mut E,
        io: &mut T,
        tx_done_at: &mut Option<Instant>,
        deadline: Option<Instant>,
        now: Instant,
    ) -> io::Result<()> {
        if !self
            .waiting_first(engine, io, tx_done_at, deadline, now)
            .await?
            && fire_due(engine, tx_done_at, deadline, now)
        {
            // Only what the engine was told raises the floor: raised by a look at the clock
            // that fired nothing (the one after a late read), it would stamp the next bytes
            // found waiting at `now`, past a deadline they were in the port before.
            self.floor = now;
        }
        Ok(())
    }

    /// Before the engine's `deadline` fires at `now`: if it has expired and the transport holds
    /// bytes already, take them without waiting and hand them over first
    /// ([`deliver_late`](Self::deliver_late)). True if bytes were waiting (the deadline is then
    /// not fired: the engine names it again); false if the deadline is not due or nothing was
    /// waiting (a silence that really happened: fire it). An end of file is left to the next
    /// read.
    async fn waiting_first<E: Engine, T: Transport>(
        &mut self,
        engine: &mut E,
        io: &mut T,
        tx_done_at: &mut Option<Instant>,
        deadline: Option<Instant>,
        now: Instant,
    ) -> io::Result<bool> {
        let Some(expired) = self.rescuable(deadline, now) else {
            return Ok(false);
        };
        match waiting::read_waiting(io, &mut self.buf).await {
            None | Some(Ok(0)) => Ok(false),
            Some(Ok(n)) => {
                self.deliver_late(engine, io, tx_done_at, expired, n, now);
                Ok(true)
            }
            Some(Err(e)) => Err(e),
        }
    }
}

/// How long our echo may still arrive after tx-done on a port that did not give its latency:
/// a little more than the 16 ms default latency timer of FTDI-type USB adapters.
pub const ECHO_GRACE: Duration = Duration::from_millis(20);

/// RS-485 direction control by the driver ([`RtsToggle`]): RTS on before the first byte of a
/// transmission, off `after` past its tx-done. Transmissions that follow each other before RTS
/// went off keep it on.
struct Direction {
    toggle: Option<RtsToggle>,
    /// When RTS goes off; `Some` while it is on.
    off_at: Option<Instant>,
}

impl Direction {
    fn new(toggle: Option<RtsToggle>) -> Self {
        Direction {
            toggle,
            off_at: None,
        }
    }

    /// Raise RTS if it is not up; the update made, if any (the caller then waits
    /// [`lead`](Self::lead)).
    fn before_write<T: Transport>(&mut self, io: &mut T) -> io::Result<Option<SignalUpdate>> {
        if self.toggle.is_none() || self.off_at.is_some() {
            return Ok(None);
        }
        let update = SignalUpdate {
            rts: Some(true),
            ..SignalUpdate::default()
        };
        io.set_signals(update)?;
        Ok(Some(update))
    }

    /// The transceiver's enable time to wait after raising RTS.
    fn lead(&self) -> Duration {
        self.toggle.map_or(Duration::ZERO, |t| t.before)
    }

    /// The write is out; its last byte leaves the transmitter at `tx_done`.
    fn written(&mut self, tx_done: Instant) {
        if let Some(t) = self.toggle {
            self.off_at = Some(tx_done + t.after);
        }
    }

    /// Drop RTS if its time has come.
    fn due<T: Transport>(
        &mut self,
        now: Instant,
        io: &mut T,
        record: &impl Fn(TraceKind),
    ) -> io::Result<()> {
        if self.off_at.is_some_and(|at| now >= at) {
            self.off_at = None;
            let update = SignalUpdate {
                rts: Some(false),
                ..SignalUpdate::default()
            };
            record(TraceKind::Signals { update });
            io.set_signals(update)?;
        }
        Ok(())
    }
}

/// Tell the engine that its transmission is done and its deadline has passed, if they have;
/// true if it told the engine anything.
fn fire_due<E: Engine>(
    engine: &mut E,
    tx_done_at: &mut Option<Instant>,
    deadline: Option<Instant>,
    now: Instant,
) -> bool {
    let mut told = false;
    if let Some(at) = tx_done_at.filter(|&t| now >= t) {
        *tx_done_at = None;
        tracing::trace!("tx done (due {at}, now {now})");
        engine.handle_tx_done(now);
        told = true;
    }
    if let Some(at) = deadline.filter(|&d| now >= d) {
        tracing::trace!("timeout (due {at}, now {now})");
        engine.handle_timeout(now);
        told = true;
    }
    told
}

/// A transport with facts added to what it says itself ([`PortFacts::or`]): local echo on a
/// TCP stream to a serial device server on a two-wire bus, a latency the program knows.
#[derive(Debug)]
pub struct WithFacts<T> {
    /// The transport.
    pub inner: T,
    /// Facts used where the transport gives none.
    pub facts: PortFacts,
}

impl<T: Transport> AsyncRead for WithFacts<T> {
    fn poll_read(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        buf: &mut tokio::io::ReadBuf<'_>,
    ) -> std::task::Poll<io::Result<()>> {
        std::pin::Pin::new(&mut self.inner).poll_read(cx, buf)
    }
}

impl<T: Transport> AsyncWrite for WithFacts<T> {
    fn poll_write(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        buf: &[u8],
    ) -> std::task::Poll<io::Result<usize>> {
        std::pin::Pin::new(&mut self.inner).poll_write(cx, buf)
    }
    fn poll_flush(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<io::Result<()>> {
        std::pin::Pin::new(&mut self.inner).poll_flush(cx)
    }
    fn poll_shutdown(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<io::Result<()>> {
        std::pin::Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

impl<T: Transport> Transport for WithFacts<T> {
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        self.inner.set_signals(update)
    }
    fn read_signals(&mut self) -> io::Result<Option<ModemSignals>> {
        self.inner.read_signals()
    }
    fn attach(&mut self) -> PortFacts {
        self.inner.attach().or(self.facts)
    }
    fn new_overruns(&mut self) -> u64 {
        self.inner.new_overruns()
    }
}

/// A boxed transport, so a program can choose serial or TCP at run time.
impl Transport for Box<dyn Transport> {
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        (**self).set_signals(update)
    }
    fn read_signals(&mut self) -> io::Result<Option<ModemSignals>> {
        (**self).read_signals()
    }
    fn attach(&mut self) -> PortFacts {
        (**self).attach()
    }
    fn new_overruns(&mut self) -> u64 {
        (**self).new_overruns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hang_up_is_told_from_a_failure() {
        assert!(hung_up(&io::Error::from_raw_os_error(5)), "EIO: pty closed");
        assert!(
            hung_up(&io::Error::from_raw_os_error(19)),
            "ENODEV: adapter pulled"
        );
        assert!(hung_up(&io::ErrorKind::BrokenPipe.into()));
        assert!(
            !hung_up(&io::Error::from_raw_os_error(25)),
            "ENOTTY: cannot set RTS"
        );
        assert!(!hung_up(&io::ErrorKind::PermissionDenied.into()));
    }
    use crate::tracefile::{self, Header};
    use std::io::Write;
    use std::sync::{Arc, Mutex};
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// Echoes every received chunk back and reports its length.
    #[derive(Default)]
    struct Echo {
        tx: Vec<u8>,
        events: Vec<usize>,
    }
    impl Engine for Echo {
        type Event = usize;
        fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
            self.tx.extend_from_slice(bytes);
            self.events.push(bytes.len());
        }
        fn handle_timeout(&mut self, _: Instant) {}
        fn poll_output(&mut self) -> Output<usize> {
            if !self.tx.is_empty() {
                return Output::Transmit(std::mem::take(&mut self.tx).into());
            }
            match self.events.pop() {
                Some(n) => Output::Event(n),
                None => Output::Wait(None),
            }
        }
    }

    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);
    impl Write for Shared {
        fn write(&mut self, b: &[u8]) -> io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn the_recorder_sees_reads_writes_and_events() {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let file = Shared::default();
        rt.block_on(async {
            let recorder = tracefile::Recorder::new(Box::new(file.clone()), &Header::new("driver"))
                .unwrap()
                .for_station("host");
            let (ours, mut theirs) = tokio::io::duplex(64);
            let options = DriverOptions {
                recorder: Some(recorder),
                ..DriverOptions::default()
            };
            let (mut handle, _task) = spawn(Echo::default(), ours, options);
            theirs.write_all(&[0x02, 0x10]).await.unwrap();
            let mut back = [0u8; 2];
            theirs.read_exact(&mut back).await.unwrap();
            assert_eq!(back, [0x02, 0x10]);
            assert_eq!(handle.next_event().await, Some(2));
        });
        let bytes = file.0.lock().unwrap().clone();
        let f = tracefile::read(&bytes[..]).unwrap();
        let kinds: Vec<_> = f.trace.entries.iter().map(|e| e.kind.clone()).collect();
        assert_eq!(
            kinds,
            vec![
                TraceKind::RxChunk {
                    bytes: vec![0x02, 0x10]
                },
                TraceKind::Tx {
                    bytes: vec![0x02, 0x10]
                },
                TraceKind::Event { text: "2".into() },
            ]
        );
        assert!(f.trace.entries.iter().all(|e| e.station == "host"));
    }

    /// Runs one job at a time: a received byte ends the running job with that byte as its
    /// outcome, and is an event for the application when no job runs.
    #[derive(Default)]
    struct OneJob {
        running: Option<u64>,
        started: u64,
        events: std::collections::VecDeque<(Option<u64>, u8)>,
    }
    impl Engine for OneJob {
        type Event = (Option<u64>, u8);
        fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
            for &b in bytes {
                self.events.push_back((self.running.take(), b));
            }
        }
        fn handle_timeout(&mut self, _: Instant) {}
        fn poll_output(&mut self) -> Output<Self::Event> {
            self.events
                .pop_front()
                .map_or(Output::Wait(None), Output::Event)
        }
    }

    async fn one_job(caller: Caller<OneJob>) -> Result<u8, DriverStopped> {
        let start = |e: &mut OneJob, _| {
            if e.running.is_some() {
                return Start::Busy;
            }
            e.started += 1;
            e.running = Some(e.started);
            Start::Running(e.started)
        };
        let done = |job: &u64, event: (Option<u64>, u8)| match event {
            (Some(j), byte) if j == *job => ControlFlow::Break(byte),
            other => ControlFlow::Continue(other),
        };
        caller.job(start, done).await
    }

    #[tokio::test]
    async fn jobs_get_their_own_outcomes_in_call_order_and_other_events_reach_the_application() {
        let (ours, mut theirs) = tokio::io::duplex(64);
        let (mut handle, _task) = spawn(OneJob::default(), ours, DriverOptions::default());
        // The second start finds the engine busy and waits in the driver.
        let first = tokio::spawn(one_job(handle.caller()));
        let second = tokio::spawn(one_job(handle.caller()));
        tokio::task::yield_now().await;
        theirs.write_all(&[7]).await.unwrap();
        assert_eq!(first.await.unwrap(), Ok(7));
        theirs.write_all(&[8]).await.unwrap();
        assert_eq!(second.await.unwrap(), Ok(8));
        // No job runs: the byte is the application's event.
        theirs.write_all(&[9]).await.unwrap();
        assert_eq!(handle.next_event().await, Some((None, 9)));
        assert_eq!(handle.call(|e, _| e.started).await, Ok(2));
        drop(theirs);
        assert_eq!(one_job(handle.caller()).await, Err(DriverStopped));
    }

    /// Jobs written once through [`JobEnd`]: a job sends its byte and ends when the partner
    /// echoes it back (a zero byte back fails it with that byte as the failure); one job runs
    /// at a time; a 0xFF job is refused.
    #[derive(Default)]
    struct Echoed {
        next: u64,
        running: Option<(JobId, u8)>,
        tx: Option<u8>,
        events: std::collections::VecDeque<(JobId, Result<u8, u8>)>,
    }
    impl Engine for Echoed {
        type Event = (JobId, Result<u8, u8>);
        fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
            for &b in bytes {
                if let Some((id, _)) = self.running.take() {
                    self.events
                        .push_back((id, if b == 0 { Err(b) } else { Ok(b) }));
                }
            }
        }
        fn handle_timeout(&mut self, _: Instant) {}
        fn poll_output(&mut self) -> Output<Self::Event> {
            if let Some(b) = self.tx.take() {
                return Output::Transmit(vec![b].into());
            }
            self.events
                .pop_front()
                .map_or(Output::Wait(None), Output::Event)
        }
    }
    impl JobEnd for Echoed {
        type Job = u8;
        type Output = u8;
        type Refusal = &'static str;
        type Failure = u8;
        fn begin_job(&mut self, _: Instant, byte: u8) -> Result<JobId, NotStarted<&'static str>> {
            if byte == 0xFF {
                return Err(NotStarted::Refused("0xFF is not sent"));
            }
            if self.running.is_some() {
                return Err(NotStarted::Busy);
            }
            self.next += 1;
            let id = JobId(self.next);
            self.running = Some((id, byte));
            self.tx = Some(byte);
            Ok(id)
        }
        fn job_end(event: &Self::Event) -> Option<(JobId, Result<u8, u8>)> {
            Some(*event)
        }
    }

    #[tokio::test]
    async fn run_job_queues_busy_starts_and_routes_each_end_to_its_caller() {
        let (ours, mut theirs) = tokio::io::duplex(64);
        let (handle, _task) = spawn(Echoed::default(), ours, DriverOptions::default());
        let (a, b) = (handle.caller(), handle.caller());
        let first = tokio::spawn(async move { a.run_job(7).await });
        let second = tokio::spawn(async move { b.run_job(8).await });
        let mut sent = [0u8; 1];
        theirs.read_exact(&mut sent).await.unwrap();
        theirs.write_all(&sent).await.unwrap();
        let mut next = [0u8; 1];
        theirs.read_exact(&mut next).await.unwrap();
        theirs.write_all(&[0]).await.unwrap();
        let (first, second) = (first.await.unwrap(), second.await.unwrap());
        // Whichever started first got the echo; the other, queued while busy, the failure.
        let mut outcomes = [first, second];
        outcomes.sort_by_key(|o| o.is_err());
        assert_eq!(outcomes[0], Ok(sent[0]));
        assert_eq!(outcomes[1], Err(JobError::Failed(0)));
        assert_eq!(
            handle.run_job(0xFF).await,
            Err(JobError::Refused("0xFF is not sent"))
        );
        handle.close().await;
        assert_eq!(handle.run_job(1).await, Err(JobError::Stopped));
        // The transport was dropped: the partner reads end of file.
        let mut rest = Vec::new();
        theirs.read_to_end(&mut rest).await.unwrap();
    }

    /// Reports what reaches it: data runs and line errors, in order.
    #[derive(Default)]
    struct Lines(std::collections::VecDeque<Result<Vec<u8>, crate::LineError>>);
    impl Engine for Lines {
        type Event = Result<Vec<u8>, crate::LineError>;
        fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
            self.0.push_back(Ok(bytes.to_vec()));
        }
        fn handle_line_error(&mut self, _: Instant, error: crate::LineError) {
            self.0.push_back(Err(error));
        }
        fn handle_timeout(&mut self, _: Instant) {}
        fn poll_output(&mut self) -> Output<Self::Event> {
            self.0.pop_front().map_or(Output::Wait(None), Output::Event)
        }
    }

    #[test]
    fn a_marked_stream_reaches_the_engine_and_the_trace_as_data_and_line_errors_in_order() {
        use crate::LineError::{Break, Parity};
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let file = Shared::default();
        let seen = rt.block_on(async {
            let recorder = tracefile::Recorder::new(Box::new(file.clone()), &Header::new("driver"))
                .unwrap()
                .for_station("host");
            let (ours, mut theirs) = tokio::io::duplex(64);
            let options = DriverOptions {
                recorder: Some(recorder),
                port: Some(PortFacts {
                    marked_errors: Some(Parity),
                    ..PortFacts::default()
                }),
                ..DriverOptions::default()
            };
            let (mut handle, _task) = spawn(Lines::default(), ours, options);
            // 41, a bad character (37), a data FF, a BREAK.
            let marked = [0x41, 0xFF, 0x00, 0x37, 0xFF, 0xFF, 0xFF, 0x00, 0x00];
            theirs.write_all(&marked).await.unwrap();
            let mut seen = Vec::new();
            while seen.len() < 4 {
                seen.push(handle.next_event().await.unwrap());
            }
            seen
        });
        assert_eq!(
            seen,
            vec![Ok(vec![0x41]), Err(Parity), Ok(vec![0xFF]), Err(Break)]
        );
        let bytes = file.0.lock().unwrap().clone();
        let f = tracefile::read(&bytes[..]).unwrap();
        let line: Vec<_> = f
            .trace
            .entries
            .iter()
            .map(|e| e.kind.clone())
            .filter(|k| !matches!(k, TraceKind::Event { .. }))
            .collect();
        assert_eq!(
            line,
            vec![
                TraceKind::RxChunk { bytes: vec![0x41] },
                TraceKind::RxError { error: Parity },
                TraceKind::RxChunk { bytes: vec![0xFF] },
                TraceKind::RxError { error: Break },
            ]
        );
    }

    /// A duplex stream whose "kernel" counted lost characters (what `TIOCGICOUNT` tells).
    struct Lossy {
        inner: tokio::io::DuplexStream,
        lost: std::sync::Arc<std::sync::atomic::AtomicU64>,
    }
    impl AsyncRead for Lossy {
        fn poll_read(
            mut self: std::pin::Pin<&mut Self>,
            cx: &mut std::task::Context<'_>,
            buf: &mut tokio::io::ReadBuf<'_>,
        ) -> std::task::Poll<io::Result<()>> {
            std::pin::Pin::new(&mut self.inner).poll_read(cx, buf)
        }
    }
    impl AsyncWrite for Lossy {
        fn poll_write(
            mut self: std::pin::Pin<&mut Self>,
            cx: &mut std::task::Context<'_>,
            buf: &[u8],
        ) -> std::task::Poll<io::Result<usize>> {
            std::pin::Pin::new(&mut self.inner).poll_write(cx, buf)
        }
        fn poll_flush(
            mut self: std::pin::Pin<&mut Self>,
            cx: &mut std::task::Context<'_>,
        ) -> std::task::Poll<io::Result<()>> {
            std::pin::Pin::new(&mut self.inner).poll_flush(cx)
        }
        fn poll_shutdown(
            mut self: std::pin::Pin<&mut Self>,
            cx: &mut std::task::Context<'_>,
        ) -> std::task::Poll<io::Result<()>> {
            std::pin::Pin::new(&mut self.inner).poll_shutdown(cx)
        }
    }
    impl Transport for Lossy {
        fn new_overruns(&mut self) -> u64 {
            self.lost.swap(0, std::sync::atomic::Ordering::SeqCst)
        }
    }

    #[test]
    fn an_overrun_the_port_counted_reaches_the_engine_once_after_the_bytes_of_that_read() {
        use crate::LineError::Overrun;
        use std::sync::atomic::Ordering::SeqCst;
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let seen = rt.block_on(async {
            let (ours, mut theirs) = tokio::io::duplex(64);
            let lost = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
            let port = Lossy {
                inner: ours,
                lost: lost.clone(),
            };
            let (mut handle, _task) = spawn(Lines::default(), port, DriverOptions::default());
            theirs.write_all(&[1]).await.unwrap();
            let mut seen = vec![handle.next_event().await.unwrap()];
            // Three characters lost before the next read.
            lost.store(3, SeqCst);
            theirs.write_all(&[2]).await.unwrap();
            seen.push(handle.next_event().await.unwrap());
            seen.push(handle.next_event().await.unwrap());
            theirs.write_all(&[3]).await.unwrap();
            seen.push(handle.next_event().await.unwrap());
            seen
        });
        assert_eq!(
            seen,
            vec![Ok(vec![1]), Ok(vec![2]), Err(Overrun), Ok(vec![3])]
        );
    }
}
