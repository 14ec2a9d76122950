//! What a process costs, read from Linux's `/proc/self`: its threads (all, or by name) and its
//! resident memory. For tests that count the driver's helper threads and for the benchmarks'
//! "threads and memory per line" (BENCHMARKS.md). Elsewhere, and where `/proc` cannot be
//! read, every count is `None`.

use std::path::Path;

/// Threads of this process now.
pub fn threads() -> Option<usize> {
    Some(std::fs::read_dir("/proc/self/task").ok()?.count())
}

/// Threads of this process with this name (`/proc/self/task/*/comm`, which the kernel cuts to
/// 15 bytes).
pub fn threads_named(name: &str) -> Option<usize> {
    let tasks = std::fs::read_dir("/proc/self/task").ok()?;
    Some(
        tasks
            .filter_map(Result::ok)
            .filter(|t| comm(&t.path()).is_some_and(|c| c == name))
            .count(),
    )
}

fn comm(task: &Path) -> Option<String> {
    let text = std::fs::read_to_string(task.join("comm")).ok()?;
    Some(text.trim_end().to_owned())
}

/// Resident memory of this process in bytes (`VmRSS` in `/proc/self/status`).
pub fn rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn a_named_thread_is_counted_while_it_runs() {
        let (stop, wait) = std::sync::mpsc::channel::<()>();
        let (ready, started) = std::sync::mpsc::channel::<()>();
        let before = threads_named("testkit-probe").unwrap();
        // A thread names itself once it runs: counted after it said so.
        let probe = std::thread::Builder::new()
            .name("testkit-probe".into())
            .spawn(move || {
                ready.send(()).unwrap();
                wait.recv()
            })
            .unwrap();
        started.recv().unwrap();
        assert_eq!(threads_named("testkit-probe"), Some(before + 1));
        // At least the test's own thread and the probe.
        assert!(threads().unwrap() >= 2);
        stop.send(()).unwrap();
        probe.join().unwrap().unwrap();
        assert!(rss_bytes().unwrap() > 0);
    }
}
