//! The noise peer of the pty noise tests ("a noise test per role"): a thread writing
//! a pattern to the far end of a socat pty pair.
//!
//! Writes are non-blocking: a write blocked on a full pty holds its write lock, and socat,
//! restoring the termios as it exits after `si` closed the other end, would wait for it for
//! ever. And one noise test runs at a time ([`one_at_a_time`]): two floods through two socat
//! pairs at once starve each other on a 2-core machine, which says nothing about `si`.

use std::io::{Read, Write};
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::{exit_within, pty_pair, si_command, Kill};

/// What the noise peer writes.
#[derive(Debug, Clone, Copy)]
pub enum Noise {
    /// Nothing.
    Silent,
    /// One pseudo-random byte every 2 ms.
    RandomEvery2Ms,
    /// 01H every 2 ms.
    OneEvery2Ms,
    /// 01H as fast as the pty takes it.
    Flood,
    /// Pseudo-random bytes every 2 ms for 1 s, then silence.
    RandomForOneSecond,
    /// STX, then 64 × 'A' every 5 ms: a 3964(R) block that never ends.
    EndlessFrame,
}

static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Hold while a noise peer writes.
pub fn one_at_a_time() -> MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Writes `noise` to `port` until `stop` is set, the pattern ends, or the pty goes away.
pub fn noise_peer(port: &str, noise: Noise, stop: Arc<AtomicBool>) {
    use std::os::unix::fs::OpenOptionsExt;
    let mut tty = std::fs::OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(port)
        .expect("open the noise end of the pty pair");
    std::thread::spawn(move || {
        let started = Instant::now();
        // xorshift64: reproducible noise without a dependency.
        let mut rng: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut random = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 24) as u8
        };
        let mut first = true;
        while !stop.load(Ordering::Relaxed) {
            let (chunk, pause_ms): (Vec<u8>, u64) = match noise {
                Noise::Silent => return,
                Noise::RandomEvery2Ms => (vec![random()], 2),
                Noise::OneEvery2Ms => (vec![0x01], 2),
                Noise::Flood => (vec![0x01; 4096], 0),
                Noise::RandomForOneSecond if started.elapsed() > Duration::from_secs(1) => return,
                Noise::RandomForOneSecond => (vec![random()], 2),
                Noise::EndlessFrame => {
                    let mut c = vec![b'A'; 64];
                    if first {
                        c[0] = 0x02;
                    }
                    (c, 5)
                }
            };
            match tty.write(&chunk) {
                // The pty is full (nobody reads the far end now): wait a little.
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(1));
                    continue;
                }
                Err(_) => return, // the pair is gone
                Ok(_) => first = false,
            }
            if pause_ms > 0 {
                std::thread::sleep(Duration::from_millis(pause_ms));
            }
        }
    });
}

/// Runs `si --port <pty> ARGS` against each of `patterns` (one at a time, a fresh pty pair
/// each): it must end with exit code 1 (a protocol failure, not a usage error's 2 nor a
/// panic's 101) in under twice `bound`, its stderr holding `expected` (a STATUS, `16#…`).
/// Twice the bound is a bound, not a timing claim: it leaves room for the process start and a
/// loaded machine. Returns early (a skip) without socat.
pub fn each_pattern_within(patterns: &[Noise], bound: Duration, args: &[&str], expected: &str) {
    let _one = one_at_a_time();
    let limit = bound * 2;
    for &noise in patterns {
        let Some(pair) = pty_pair() else { return };
        let stop = Arc::new(AtomicBool::new(false));
        noise_peer(&pair.b, noise, stop.clone());
        // The line is already noisy when the job starts.
        std::thread::sleep(Duration::from_millis(100));
        let started = Instant::now();
        let mut si = Kill(
            si_command()
                .args(["--port", &pair.a])
                .args(args)
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .expect("start si"),
        );
        // Drained by a thread, so a chatty stderr never blocks `si` while we poll its exit.
        let mut pipe = si.0.stderr.take().expect("si stderr");
        let stderr = std::thread::spawn(move || {
            let mut text = String::new();
            let _ = pipe.read_to_string(&mut text);
            text
        });
        let what = format!("si {args:?} against {noise:?} (bound {bound:?})");
        let status = exit_within(&mut si, started, limit, &what);
        stop.store(true, Ordering::Relaxed);
        let err = stderr.join().expect("stderr reader");
        assert_eq!(
            status.code(),
            Some(1),
            "si {args:?} against {noise:?}: {err}"
        );
        assert!(
            err.contains(expected),
            "si {args:?} against {noise:?}: {expected} in {err}"
        );
    }
}
