//! The driver's precise timer ("Timing, honestly" in si_core::driver) is one helper thread per
//! process, however many drivers use it: it starts when the first driver waits a short
//! deadline and ends when the last driver using it ends. Alone in its test binary, so no other
//! test's drivers come and go while the threads are counted; the tests here take turns.
#![cfg(all(feature = "tokio", target_os = "linux"))]

use si_core::driver::{precise_timer_drivers, spawn, DriverOptions, Handle};
use si_core::{Duration, Engine, Instant, Output};
use si_testkit::procfs::{threads_named, timer_slack_ns_named};
use std::sync::Mutex;
use tokio::io::DuplexStream;
use tokio::task::JoinHandle;

const THREAD: &str = "si-driver-timer";

/// The tests count threads of the whole process: one at a time.
static TURN: Mutex<()> = Mutex::new(());

/// Arms a deadline on command; reports when it fired.
#[derive(Default)]
struct Timer {
    fired: Option<Instant>,
    deadline: Option<Instant>,
}

impl Engine for Timer {
    type Event = Instant;
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
    fn handle_timeout(&mut self, now: Instant) {
        if self.deadline.is_some_and(|d| now >= d) {
            self.deadline = None;
            self.fired = Some(now);
        }
    }
    fn poll_output(&mut self) -> Output<Instant> {
        match self.fired.take() {
            Some(at) => Output::Event(at),
            None => Output::Wait(self.deadline),
        }
    }
}

fn timer_threads() -> usize {
    threads_named(THREAD).expect("/proc/self/task is readable on Linux")
}

/// The timer threads once the one started has named itself (a thread does so first thing
/// when it runs, which may be a moment after it was started).
fn started_timer_threads() -> usize {
    let start = std::time::Instant::now();
    while timer_threads() == 0 && start.elapsed() < std::time::Duration::from_secs(5) {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    timer_threads()
}

/// Every driver waits deadlines 2 ms ahead (below PRECISE_LEAD, above SPIN_BELOW: the precise
/// timer's range) until `enough` drivers use the timer. A driver that only gets to its
/// deadline once it is due (a loaded machine) fires it at once without the timer; the next
/// round tries again. None fires early.
async fn wait_short_deadlines(handles: &mut [Handle<Timer>], enough: usize) {
    for _round in 0..50 {
        let mut deadlines = Vec::with_capacity(handles.len());
        for handle in handles.iter() {
            let deadline = handle
                .call(|t, now| {
                    let d = now + Duration::from_millis(2);
                    t.deadline = Some(d);
                    d
                })
                .await
                .unwrap();
            deadlines.push(deadline);
        }
        for (handle, deadline) in handles.iter_mut().zip(deadlines) {
            let fired = handle.next_event().await.unwrap();
            assert!(fired >= deadline, "fired early");
        }
        if precise_timer_drivers() >= enough {
            return;
        }
    }
    panic!(
        "only {} of {enough} drivers used the precise timer in 50 rounds",
        precise_timer_drivers()
    );
}

/// Drivers of [`Timer`]s over pipes whose other ends stay open.
struct Fleet {
    handles: Vec<Handle<Timer>>,
    tasks: Vec<JoinHandle<std::io::Result<()>>>,
    _peers: Vec<DuplexStream>,
}

impl Fleet {
    fn new(n: usize) -> Fleet {
        let mut fleet = Fleet {
            handles: Vec::new(),
            tasks: Vec::new(),
            _peers: Vec::new(),
        };
        for _ in 0..n {
            let (ours, theirs) = tokio::io::duplex(64);
            let (handle, task) = spawn(Timer::default(), ours, DriverOptions::default());
            fleet.handles.push(handle);
            fleet.tasks.push(task);
            fleet._peers.push(theirs);
        }
        fleet
    }

    /// End the last `n` drivers (dropping a handle stops its driver) and wait for them.
    async fn end(&mut self, n: usize) {
        let keep = self.handles.len() - n;
        drop(self.handles.split_off(keep));
        for task in self.tasks.split_off(keep) {
            task.await.unwrap().unwrap();
        }
    }
}

/// The timer thread ends soon after the last driver using it (which wakes it on leaving).
fn wait_for_no_timer_thread() {
    assert_eq!(precise_timer_drivers(), 0);
    let start = std::time::Instant::now();
    while timer_threads() > 0 {
        assert!(
            start.elapsed() < std::time::Duration::from_secs(5),
            "the timer thread outlived its drivers"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

#[test]
fn the_helper_thread_starts_on_first_use_and_ends_with_the_driver() {
    let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    assert_eq!(timer_threads(), 0, "no driver yet");
    rt.block_on(async {
        let mut fleet = Fleet::new(1);
        assert_eq!(timer_threads(), 0, "a driver that waited nothing yet");
        wait_short_deadlines(&mut fleet.handles, 1).await;
        assert_eq!(started_timer_threads(), 1);
        fleet.end(1).await;
    });
    wait_for_no_timer_thread();
}

/// The thread's timed waits end when asked: its timer slack (50 µs by default on Linux, the
/// lateness the kernel may add to each wait) is set to 1 µs as the thread starts.
#[test]
fn the_helper_thread_asks_the_kernel_for_exact_waits() {
    let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let mut fleet = Fleet::new(1);
        wait_short_deadlines(&mut fleet.handles, 1).await;
        assert_eq!(started_timer_threads(), 1);
        // The thread sets its slack first thing when it runs, which may be a moment after it
        // named itself.
        let start = std::time::Instant::now();
        let mut slack = timer_slack_ns_named(THREAD).expect("/proc is readable on Linux");
        while slack != [1_000] && start.elapsed() < std::time::Duration::from_secs(5) {
            std::thread::sleep(std::time::Duration::from_millis(1));
            slack = timer_slack_ns_named(THREAD).expect("/proc is readable on Linux");
        }
        assert_eq!(slack, [1_000], "the timer thread's slack in ns");
        fleet.end(1).await;
    });
    wait_for_no_timer_thread();
}

#[test]
fn a_hundred_drivers_share_one_helper_thread_that_ends_with_the_last() {
    let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let mut fleet = Fleet::new(100);
        wait_short_deadlines(&mut fleet.handles, 100).await;
        assert_eq!(precise_timer_drivers(), 100);
        assert_eq!(started_timer_threads(), 1);
        // Half of them end: the thread stays for the others.
        fleet.end(50).await;
        assert_eq!(precise_timer_drivers(), 50);
        assert_eq!(timer_threads(), 1);
        fleet.end(50).await;
    });
    wait_for_no_timer_thread();
}
