//! The loopback check (`si ports --check PORT --loopback`): with TX wired to RX (or a pseudo-terminal whose other
//! end echoes), what the port does with real traffic: a round trip at each baud rate, the
//! packets received bytes arrive in and how long the port holds them, and whether the port
//! hears its own transmission at all, and what the driver's line-error counters
//! (`TIOCGICOUNT`) counted during the loop: parity and framing errors, BREAKs and lost
//! characters. A loop that garbles characters (bad wiring, noise, a partner at another
//! parity or baud rate echoing) shows there, and only there when the port does not mark
//! errors in its stream.
//!
//! What the loop cannot show: that a parity error *would* be detected. That needs a sender and
//! a receiver at different parity at once, which one UART looping back to itself cannot be (it
//! sends with the parity it checks): a second port wired to this one does it
//! ([`crate::port::parity_check`], `--loopback-peer`). A pseudo-terminal has no parity at all:
//! its driver keeps no counters, which the check says instead of a count.
//!
//! Times are measured on this host's clock around blocking-free reads; they are what a user's
//! program sees, not what the wire does.

use crate::port::check::{Finding, Severity};
use crate::port::{self, LineCounters, PortOptions};
use crate::{Parity, SerialSettings};
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// The baud rates tried, slowest first.
const BAUDS: [u32; 5] = [9600, 19200, 38400, 57600, 115200];

/// Bytes sent per round trip: longer than a 16-byte UART FIFO and than a 62-byte FTDI packet
/// payload, so both kinds of packetising show.
const PATTERN_LEN: usize = 100;

/// What one round trip at one baud rate saw.
struct Trip {
    /// Bytes that came back.
    back: usize,
    /// Reads they came in.
    reads: usize,
    /// The largest read.
    largest: usize,
    /// From the write's start to the last byte back.
    round_trip: Duration,
    /// How much later than the wire allows the last byte arrived (0 for a port that hands
    /// bytes over at once).
    hold: Duration,
    /// Whether they are the bytes sent.
    same: bool,
}

/// Run the loopback checks on `path`.
pub async fn loopback(path: &str) -> Vec<Finding> {
    let mut findings = Vec::new();
    let mut echoed = false;
    let before = port::line_counters(path);
    for baud in BAUDS {
        let settings = match SerialSettings::new(baud, 8, Parity::None, 1) {
            Ok(s) => s,
            Err(_) => continue,
        };
        match round_trip(path, settings).await {
            Err(e) => findings.push(Finding::new(
                "loopback",
                Severity::Problem,
                format!("{baud} bit/s: {e}"),
            )),
            Ok(t) if t.back == 0 => findings.push(
                Finding::new(
                    "loopback",
                    Severity::Problem,
                    format!("{baud} bit/s: nothing came back"),
                )
                .remedy(
                    "no echo: wire TX to RX (RS-232 pins 2 and 3), or run the check on a pair \
                     whose other end echoes",
                ),
            ),
            Ok(t) => {
                echoed = true;
                let severity = if t.same && t.back == PATTERN_LEN {
                    Severity::Ok
                } else {
                    Severity::Problem
                };
                let finding = Finding::new(
                    "loopback",
                    severity,
                    format!(
                        "{baud} bit/s: {} of {PATTERN_LEN} bytes back{} in {:.1} ms, in {} read(s) \
                         of at most {} bytes, held {:.1} ms past the wire",
                        t.back,
                        if t.same { "" } else { ", changed" },
                        t.round_trip.as_secs_f64() * 1e3,
                        t.reads,
                        t.largest,
                        t.hold.as_secs_f64() * 1e3,
                    ),
                );
                findings.push(if severity == Severity::Ok {
                    finding
                } else {
                    finding.remedy(
                        "bytes were lost or changed on the way: check the wiring and the \
                         line-error counters",
                    )
                });
            }
        }
    }
    findings.push(if echoed {
        Finding::new(
            "echo",
            Severity::Ok,
            "the port hears its own transmission (loopback or echo present)",
        )
    } else {
        Finding::new(
            "echo",
            Severity::Problem,
            "no echo at any baud rate: the port does not hear its transmission",
        )
        .remedy("wire TX to RX for the loopback check")
    });
    findings.push(line_errors(before, port::line_counters(path)));
    findings
}

/// What the driver's counters say about the loop: the parity and framing errors, BREAKs and
/// lost characters counted from `before` to `after`.
pub fn line_errors(
    before: std::io::Result<LineCounters>,
    after: std::io::Result<LineCounters>,
) -> Finding {
    let (before, after) = match (before, after) {
        (Ok(b), Ok(a)) => (b, a),
        (Err(e), _) | (_, Err(e)) if e.kind() == std::io::ErrorKind::Unsupported => {
            return Finding::new(
                "line errors",
                Severity::Ok,
                "the port's driver keeps no line-error counters (a pseudo-terminal has no \
                 parity): parity and framing errors on the loop cannot be counted",
            )
        }
        (Err(e), _) | (_, Err(e)) => {
            return Finding::new(
                "line errors",
                Severity::Note,
                format!("cannot read the counters: {e}"),
            )
        }
    };
    let d = |a: u32, b: u32| a.wrapping_sub(b);
    let (parity, frame) = (d(after.parity, before.parity), d(after.frame, before.frame));
    let (brk, lost) = (
        d(after.brk, before.brk),
        after.lost().wrapping_sub(before.lost()),
    );
    let text = format!(
        "during the loopback: {parity} parity errors, {frame} framing errors, {brk} BREAKs, \
         {lost} characters lost (the driver's counters)"
    );
    if parity == 0 && frame == 0 && brk == 0 && lost == 0 {
        Finding::new("line errors", Severity::Ok, text)
    } else {
        Finding::new("line errors", Severity::Problem, text).remedy(
            "the loop garbles characters: check the wiring and its ground, and that nothing \
             else (another program, a partner at other settings) is on the line",
        )
    }
}

/// Send the pattern at `settings` and read it back.
async fn round_trip(path: &str, settings: SerialSettings) -> std::io::Result<Trip> {
    let mut port = port::open(path, &settings, &PortOptions::default())?;
    let pattern: Vec<u8> = (0..PATTERN_LEN).map(|i| (i * 7 + 1) as u8).collect();
    let wire = Duration::from_micros(settings.chars_time(PATTERN_LEN as u64).as_micros());
    let started = Instant::now();
    port.write_all(&pattern).await?;
    let mut back = Vec::new();
    let mut reads = 0;
    let mut largest = 0;
    let mut last = started;
    let deadline = started + wire + Duration::from_millis(300);
    let mut buf = [0u8; 256];
    while back.len() < PATTERN_LEN {
        let left = deadline.saturating_duration_since(Instant::now());
        match tokio::time::timeout(left, port.read(&mut buf)).await {
            Ok(Ok(0)) | Err(_) => break,
            Ok(Ok(n)) => {
                last = Instant::now();
                reads += 1;
                largest = largest.max(n);
                back.extend_from_slice(&buf[..n]);
            }
            Ok(Err(e)) => return Err(e),
        }
    }
    let round_trip = last.saturating_duration_since(started);
    Ok(Trip {
        back: back.len(),
        reads,
        largest,
        round_trip,
        hold: round_trip.saturating_sub(wire),
        same: back.iter().zip(&pattern).all(|(a, b)| a == b),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io;

    fn counters(parity: u32, frame: u32) -> io::Result<LineCounters> {
        Ok(LineCounters {
            rx: 500,
            tx: 500,
            parity,
            frame,
            ..LineCounters::default()
        })
    }

    #[test]
    fn parity_errors_counted_during_the_loop_are_a_problem_and_a_pty_says_it_cannot_count() {
        let clean = line_errors(counters(3, 1), counters(3, 1));
        assert_eq!(clean.severity, Severity::Ok, "{}", clean.text);
        let garbled = line_errors(counters(3, 1), counters(7, 1));
        assert_eq!(garbled.severity, Severity::Problem);
        assert!(garbled.text.contains("4 parity errors"), "{}", garbled.text);
        assert!(garbled.remedy.is_some());
        let unsupported = || Err(io::Error::new(io::ErrorKind::Unsupported, "no counters"));
        let pty = line_errors(unsupported(), unsupported());
        assert_eq!(pty.severity, Severity::Ok);
        assert!(pty.text.contains("cannot be counted"), "{}", pty.text);
    }
}
