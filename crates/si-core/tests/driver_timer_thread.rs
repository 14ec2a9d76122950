//! The driver's precise-timer helper thread ("Timing, honestly" in si_core::driver) starts on
//! first use and ends with its driver. Alone in its test binary, so no other test's driver
//! threads come and go while the threads are counted.
#![cfg(all(feature = "tokio", target_os = "linux"))]

use si_core::driver::{spawn, DriverOptions};
use si_core::{Duration, Engine, Instant, Output};

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

/// Threads of this process with this name (Linux: /proc/self/task/*/comm).
fn threads_named(name: &str) -> usize {
    std::fs::read_dir("/proc/self/task")
        .map(|dir| {
            dir.filter_map(Result::ok)
                .filter(|t| {
                    std::fs::read_to_string(t.path().join("comm"))
                        .is_ok_and(|c| c.trim_end() == name)
                })
                .count()
        })
        .unwrap_or(0)
}

#[test]
fn the_helper_thread_starts_on_first_use_and_ends_with_the_driver() {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let before = threads_named("si-driver-timer");
    assert_eq!(before, 0, "no driver yet");
    rt.block_on(async {
        let (ours, _theirs) = tokio::io::duplex(64);
        let (mut handle, task) = spawn(Timer::default(), ours, DriverOptions::default());
        // A deadline 2 ms ahead goes to the helper thread (below PRECISE_LEAD, above
        // SPIN_BELOW) unless the driver only gets to it once it is already due (a loaded
        // machine): then it fires at once, and the next attempt tries again.
        for _attempt in 0..50 {
            let deadline = handle
                .call(|t, now| {
                    let d = now + Duration::from_millis(2);
                    t.deadline = Some(d);
                    d
                })
                .await
                .unwrap();
            let fired = handle.next_event().await.unwrap();
            assert!(fired >= deadline, "fired early");
            if threads_named("si-driver-timer") > before {
                break;
            }
        }
        assert_eq!(threads_named("si-driver-timer"), before + 1);
        drop(handle);
        task.await.unwrap().unwrap();
    });
    // The thread notices within a moment that its driver has gone.
    let start = std::time::Instant::now();
    while threads_named("si-driver-timer") > before {
        assert!(
            start.elapsed() < std::time::Duration::from_secs(5),
            "the helper thread outlived its driver"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}
