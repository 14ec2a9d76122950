//! [`InlineMaster`]: the RTU master engine driven in the caller's own future.

use super::client::{unexpected, Client};
use super::error::{Error, Job};
use super::master::Diagnostics;
use crate::config::MasterConfig;
use crate::frame::{Request, Response};
use crate::master::{self, Attempts, Completion, MasterEvent, Queued};
use si_core::driver::Transport;
use si_core::{Engine, Instant, Output, Status};
use std::future::Future;
use std::pin::Pin;
use std::task::Poll;
use tokio::io::AsyncWriteExt;
use tokio::sync::Mutex;

/// Bytes read from the port at once: more than the longest ADU (264 bytes).
const RX_CHUNK: usize = 512;

/// The RTU master engine driven in the caller's own future, for a
/// request/response client that owns its port. No task, no channel: a job writes the request,
/// reads the response and fires the engine's timers inside the `await` that asked for it.
///
/// What it leaves out, compared with the driver-backed [`Master`](super::Master): the driver's
/// precise timer (deadlines wait on tokio's timer, which fires up to about 2 ms late, so with
/// the module's [`FrameEnd::Gap`](crate::FrameEnd) a response is recognised that much later;
/// [`FrameEnd::Length`](crate::FrameEnd) ends it at once), RS-485 direction control by RTS,
/// local-echo suppression and decoding of `PARMRK` line-error marks (it never calls
/// [`Transport::attach`]), and events between jobs (nothing reads the port while no job runs:
/// what arrived meanwhile is read, and reported as 0E50H, at the next job). Use it on pipes, TCP
/// device servers and ports that switch their transceiver themselves; use the driver-backed
/// master where the line needs the rest.
///
/// Methods take `&self`; one job at a time ([Modbus/USS] §4.2): concurrent calls wait for the
/// port's lock. A job whose future is dropped before it ended is run to its end (its outcome
/// dropped) by the next call, before that call's own request goes out.
pub struct InlineMaster<T: Transport> {
    inner: Mutex<Inner<T>>,
}

struct Inner<T> {
    engine: master::Master,
    port: T,
    /// The engine's time zero.
    origin: tokio::time::Instant,
    rx: [u8; RX_CHUNK],
    /// When to report tx-done: the write has completed and the bytes' character time has
    /// passed since it began (a UART still shifts bytes out when `write` returns).
    tx_done: Option<Instant>,
    diagnostics: Diagnostics,
    /// The port failed or closed: every later job fails with [`Error::Stopped`].
    stopped: bool,
}

impl<T: Transport> InlineMaster<T> {
    /// A master on `transport`.
    pub fn new(config: MasterConfig, transport: T) -> Result<Self, Error> {
        Ok(Self::from_engine(master::Master::new(config)?, transport))
    }

    /// A master with an engine built by the caller (for options beyond [`MasterConfig`], such
    /// as [`master::Master::with_frame_end`]).
    pub fn from_engine(mut engine: master::Master, transport: T) -> Self {
        engine.transmit_in_place();
        InlineMaster {
            inner: Mutex::new(Inner {
                engine,
                port: transport,
                origin: tokio::time::Instant::now(),
                rx: [0; RX_CHUNK],
                tx_done: None,
                diagnostics: Diagnostics::default(),
                stopped: false,
            }),
        }
    }

    /// Send any request and wait for its completion (a broadcast completes after the
    /// turnaround delay with no response).
    pub async fn request(&self, unit: u8, request: &Request<'_>) -> Result<Completion, Error> {
        self.inner.lock().await.run(unit, request, |c| *c).await
    }

    /// [`request`](Self::request), and what the job's attempts met ([`Attempts`]).
    pub async fn request_with_attempts(
        &self,
        unit: u8,
        request: &Request<'_>,
    ) -> (Result<Completion, Error>, Attempts) {
        let mut inner = self.inner.lock().await;
        let result = inner.run(unit, request, |c| *c).await;
        let attempts = match result {
            Err(Error::Refused { .. } | Error::Stopped) => Attempts::default(),
            _ => inner.engine.attempts(),
        };
        (result, attempts)
    }

    /// Line diagnostics met during jobs outside their responses (0E50H, line errors), oldest
    /// first; taking them empties the list.
    pub async fn take_diagnostics(&self) -> Vec<Status> {
        self.inner.lock().await.diagnostics.take()
    }

    /// Run `f` on the engine between jobs (counters, state), as the driver-backed
    /// [`Master::call`](super::Master::call) does.
    pub async fn call<R>(&self, f: impl FnOnce(&mut master::Master, Instant) -> R) -> R {
        let mut inner = self.inner.lock().await;
        let now = inner.now();
        f(&mut inner.engine, now)
    }

    /// Shut the port down and give it up; the port is released when this returns.
    pub async fn close(self) -> Result<(), Error> {
        let mut inner = self.inner.into_inner();
        inner.port.shutdown().await?;
        Ok(())
    }
}

#[cfg(feature = "serial")]
#[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
impl InlineMaster<si_core::port::SerialPort> {
    /// Open the serial port at `path` with the config's own line settings (feature `serial`).
    pub fn open(config: MasterConfig, path: &str) -> Result<Self, Error> {
        let engine = master::Master::new(config)?;
        let port = si_core::port::open(
            path,
            &config.line.settings,
            &si_core::port::PortOptions::default(),
        )?;
        Ok(Self::from_engine(engine, port))
    }
}

impl<T: Transport> Inner<T> {
    fn now(&self) -> Instant {
        let elapsed = self.origin.elapsed();
        Instant::from_micros(u64::try_from(elapsed.as_micros()).unwrap_or(u64::MAX))
    }

    /// Run one job: `pick` reads what the caller wants out of its completion where the engine
    /// reports it (a completion carries both ADUs inline, so not moving it up through the
    /// futures saves copying it at each level).
    async fn run<R>(
        &mut self,
        unit: u8,
        request: &Request<'_>,
        pick: impl FnOnce(&Completion) -> R,
    ) -> Result<R, Error> {
        let job = Job::of(unit, request);
        if self.stopped {
            return Err(Error::Stopped);
        }
        // A job abandoned by a dropped future runs to its end first (its outcome is nobody's).
        while self.engine.is_busy() {
            let abandoned = self.drive(None, |_| (), None).await;
            let _abandoned = self.note_stop(abandoned)?;
        }
        let now = self.now();
        let id = self
            .engine
            .request(now, unit, request)
            .map_err(|reason| Error::Refused { job, reason })?;
        let outcome = self.drive(Some(id), pick, Some(now)).await;
        match self.note_stop(outcome)? {
            Ok(r) => Ok(r),
            Err(status) => Err(Error::failed(job, status)),
        }
    }

    /// What [`drive`](Self::drive) returned, noting a port that failed or closed: every later
    /// job fails with [`Error::Stopped`]. A plain function after the `await`, not a wrapping
    /// future: each nested future is one more state machine to enter at every poll.
    fn note_stop<R>(&mut self, result: Result<R, Error>) -> Result<R, Error> {
        if matches!(result, Err(Error::Stopped | Error::Io(_))) {
            self.stopped = true;
        }
        result
    }

    /// Run the engine until the running job ends: its outcome, `pick`ed from the completion
    /// (`Ok(Err(status))` for a failed job); `Err` if the port failed (the caller passes it
    /// through [`note_stop`](Self::note_stop)). `now`: a clock reading just taken (the job's
    /// start), reused for the first turn.
    async fn drive<R>(
        &mut self,
        id: Option<si_core::job::JobId>,
        pick: impl FnOnce(&Completion) -> R,
        now: Option<Instant>,
    ) -> Result<Result<R, Status>, Error> {
        // The engine's next deadline, armed only when a wait is not over after one yield: on
        // a pipe or a busy runtime the answer is usually there by then, and a timer armed and
        // disarmed per request would cost more than the exchange itself. (A timer kept armed
        // across jobs was tried too: every park of the runtime then also runs tokio's timer
        // wheel, and the round trip got slower than with the yield.)
        // Pinned here, not boxed: a job that waits for its answer (every one on a real line)
        // costs no allocation for its timer.
        let mut sleep = std::pin::pin!(None::<tokio::time::Sleep>);
        let mut armed: Option<Instant> = None;
        let mut yielded = false;
        // Just wrote a request: the first wait skips the read and only yields. The answer
        // cannot be there before the partner has run, and a read polled now would register
        // its waker, so the partner's write would wake this task once and the yield's
        // own wake a second time, two wake-ups (an eventfd write each on tokio's
        // current-thread runtime) where one is enough.
        let mut skip_read = false;
        // A clock reading taken just before (a read's arrival, a deadline handled) that the
        // next turn reuses.
        let mut fresh: Option<Instant> = now;
        // `fresh` is a reading from before a yield: the deadlines were checked against it.
        let mut stale = false;
        loop {
            // One clock read per turn: the engine's outputs, the write and the deadline checks
            // below take microseconds at most.
            let now = fresh.take().unwrap_or_else(|| self.now());
            let stale_now = std::mem::take(&mut stale);
            // A turn on the reading from before a yield (`stale_now`) has nothing to drain or
            // check: the engine has not run since the turn before the yield emptied its outputs
            // and checked its deadlines against this same reading. It only polls the read (the
            // timer is not armed on a stale reading), so its deadline is not computed again.
            let next = if stale_now {
                None
            } else {
                let wait = loop {
                    // Read the output where the engine's queue keeps it: an output is as large as a
                    // completion (two ADUs inline), and one handed out by value, or kept across the
                    // write's `await`, would be copied whole; only the frame's handle crosses.
                    let ours_ended = self.engine.running_job().is_none_or(|r| Some(r) != id);
                    let (out, kept) = match self.engine.next_output_mut() {
                        Ok(next) => next,
                        Err(deadline) => break deadline,
                    };
                    let bytes = match out {
                        Output::Transmit(bytes) => std::mem::take(bytes),
                        Output::SetSignals(update) => {
                            let update = *update;
                            self.engine.consume_output();
                            self.port.set_signals(update)?;
                            continue;
                        }
                        Output::Event(Queued::Event(MasterEvent::Diagnostic(s))) => {
                            self.diagnostics.keep(*s);
                            self.engine.consume_output();
                            continue;
                        }
                        // The job's end: one job at a time, so once it is no longer the running
                        // one, this event ended it ([`master::Master::outcome`] has it by id).
                        Output::Event(Queued::Completed) if ours_ended => {
                            let picked = pick(kept);
                            self.engine.consume_output();
                            return Ok(Ok(picked));
                        }
                        Output::Event(Queued::Event(MasterEvent::Completed(c))) if ours_ended => {
                            let picked = pick(c);
                            self.engine.consume_output();
                            return Ok(Ok(picked));
                        }
                        Output::Event(Queued::Event(MasterEvent::Failed { status, .. }))
                            if ours_ended =>
                        {
                            let status = *status;
                            self.engine.consume_output();
                            return Ok(Err(status));
                        }
                        Output::Event(_) => {
                            self.engine.consume_output();
                            continue;
                        }
                        Output::Wait(deadline) => {
                            let deadline = *deadline;
                            self.engine.consume_output();
                            break deadline;
                        }
                    };
                    self.engine.consume_output();
                    let start = now;
                    // An empty frame is the job's request, written from where the engine keeps
                    // it ([`master::Master::transmit_in_place`]): no frame cut per request.
                    let frame: &[u8] = if bytes.is_empty() {
                        self.engine.request_bytes()
                    } else {
                        &bytes
                    };
                    let len = frame.len() as u64;
                    self.port.write_all(frame).await?;
                    skip_read = true;
                    yielded = false;
                    let settings = self.engine.config().line.settings;
                    self.tx_done = Some(start + settings.chars_time(len));
                };
                if self.tx_done.is_some_and(|t| t <= now) {
                    self.tx_done = None;
                    self.engine.handle_tx_done(now);
                    fresh = Some(now);
                    continue;
                }
                if wait.is_some_and(|d| d <= now) {
                    self.engine.handle_timeout(now);
                    fresh = Some(now);
                    continue;
                }
                Instant::earliest(wait, self.tx_done)
            };
            let origin = self.origin;
            // Armed when first polled: only once the read (polled first) is pending, so a
            // response already there costs no timer (no wheel entry).
            // The read, the yield and the timer, polled in that order by hand: `select!`
            // would build and poll the same three futures with more bookkeeping per turn.
            // The yield by hand too: the task wakes itself and is pending once. tokio's
            // `yield_now` defers the wake to the runtime's list of deferred wakers, which a
            // `block_on` per request (a caller's plain `block_on(master.read(..))`) builds anew
            // each time: an allocation and its release per request. Woken at once, the task
            // still runs only after the tasks already queued (the partner that answers); on
            // the multi-threaded runtime's `block_on` tokio's yield wakes at once anyway.
            let mut wake_sent = false;
            let (port, rx) = (&mut self.port, &mut self.rx);
            let woke = std::future::poll_fn(|cx| {
                if !skip_read {
                    let mut buf = tokio::io::ReadBuf::new(&mut rx[..]);
                    if let Poll::Ready(read) = Pin::new(&mut *port).poll_read(cx, &mut buf) {
                        return Poll::Ready(Woke::Read(read.map(|()| buf.filled().len())));
                    }
                }
                if !yielded {
                    if wake_sent {
                        return Poll::Ready(Woke::Yielded);
                    }
                    wake_sent = true;
                    cx.waker().wake_by_ref();
                    return Poll::Pending;
                }
                if stale_now {
                    return Poll::Ready(Woke::Timer);
                }
                if next != armed {
                    if let Some(next) = next {
                        let at = origin + std::time::Duration::from_micros(next.as_micros());
                        match sleep.as_mut().as_pin_mut() {
                            Some(s) => s.reset(at),
                            None => sleep.set(Some(tokio::time::sleep_until(at))),
                        }
                    }
                    armed = next;
                }
                match (armed, sleep.as_mut().as_pin_mut()) {
                    (Some(_), Some(s)) => s.poll(cx).map(|()| Woke::Timer),
                    _ => Poll::Pending,
                }
            })
            .await;
            match woke {
                Woke::Read(read) => {
                    yielded = false;
                    let n = read?;
                    if n == 0 {
                        return Err(Error::Stopped);
                    }
                    let now = self.now();
                    // The request's end first, if it is due (the turn after a yield did
                    // not read the clock to see it): the engine hears of its events in order,
                    // both in one call that checks the engine's timers once where a second
                    // check at the same instant has nothing to do.
                    if self.tx_done.is_some_and(|t| t <= now) {
                        self.tx_done = None;
                        self.engine.handle_tx_done_and_rx(now, &self.rx[..n]);
                    } else {
                        self.engine.handle_rx(now, &self.rx[..n]);
                    }
                    fresh = Some(now);
                }
                Woke::Yielded => {
                    yielded = true;
                    skip_read = false;
                    // The turn after a yield reuses this turn's clock reading: it only polls
                    // the read, which reads the clock itself if bytes came. If none came, the
                    // timer ends that turn at once instead of arming on a stale reading, and
                    // the turn after reads the clock.
                    fresh = Some(now);
                    stale = true;
                }
                // What is due is handled at the top of the loop.
                Woke::Timer => armed = None,
            }
        }
    }
}

/// What ended a wait of [`Inner::drive`].
enum Woke {
    /// The port's read returned.
    Read(std::io::Result<usize>),
    /// The yield after a write is over.
    Yielded,
    /// The timer fired (or a turn on a stale clock reading ended).
    Timer,
}

impl<T: Transport> Client for InlineMaster<T> {
    async fn exchange<R: Send>(
        &self,
        unit: u8,
        request: &Request<'_>,
        pick: impl FnOnce(Option<Response<'_>>) -> Option<R> + Send,
    ) -> Result<R, Error> {
        self.inner
            .lock()
            .await
            .run(unit, request, |c| pick(c.response()))
            .await?
            .ok_or_else(|| unexpected(unit, request))
    }
}
