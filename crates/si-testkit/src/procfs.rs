//! What a process costs, read from Linux's `/proc/self`: its threads (all, or by name), its
//! resident memory and its CPU time. For tests that count the driver's helper threads and for
//! the benchmarks' "threads, memory and idle CPU per line" (BENCHMARKS.md). Elsewhere, and
//! where `/proc` cannot be read, every count is `None`.

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

/// The timer slack, in nanoseconds, of each thread of this process with this name
/// (`/proc/<tid>/timerslack_ns`, Linux 4.6 and later): how late the kernel may end the
/// thread's timed waits.
pub fn timer_slack_ns_named(name: &str) -> Option<Vec<u64>> {
    let tasks = std::fs::read_dir("/proc/self/task").ok()?;
    tasks
        .filter_map(Result::ok)
        .filter(|t| comm(&t.path()).is_some_and(|c| c == name))
        .map(|t| {
            let slack = Path::new("/proc").join(t.file_name()).join("timerslack_ns");
            std::fs::read_to_string(slack).ok()?.trim().parse().ok()
        })
        .collect()
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

/// CPU time this process has used so far, user and system (`utime` + `stime` in
/// `/proc/self/stat`, in the kernel's `USER_HZ` ticks of 10 ms: the ABI fixes them at 100 per
/// second). Coarse: measure over seconds.
pub fn cpu_time() -> Option<std::time::Duration> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) may hold spaces; the fields after its ')' are plain.
    let rest = &stat[stat.rfind(')')? + 1..];
    let mut fields = rest.split_whitespace().skip(11); // state is field 3; utime field 14
    let utime: u64 = fields.next()?.parse().ok()?;
    let stime: u64 = fields.next()?.parse().ok()?;
    Some(std::time::Duration::from_millis((utime + stime) * 10))
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

    #[test]
    fn cpu_time_grows_with_work() {
        let before = cpu_time().unwrap();
        let start = std::time::Instant::now();
        let mut x = 0u64;
        while cpu_time().unwrap() < before + std::time::Duration::from_millis(30) {
            x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(7));
            assert!(
                start.elapsed() < std::time::Duration::from_secs(10),
                "no CPU time counted"
            );
        }
    }
}
