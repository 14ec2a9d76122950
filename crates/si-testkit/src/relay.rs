//! A relay between two pseudo-terminals that behaves like a USB-serial adapter in front of a
//! real line: bytes cross a virtual wire paced at the character time, and the adapter hands
//! them on in packets of up to 62 bytes, when full or 16 ms after the first byte it holds (the
//! model of `si_sim::UsbAdapter`, here in real time). A pseudo-terminal alone delivers
//! every write at once; through this relay a long frame arrives as bursts with 16 ms holes,
//! as it does on a laptop with an FTDI adapter. With packets of one byte and no latency
//! ([`Adapter::wire`]) it is a plain virtual wire: every byte arrives when its last bit would
//! have, as on a real line (the `si-pace` binary, which `benches/gateway/vs_mbusd.sh` puts
//! between a gateway and its slave).

use std::collections::VecDeque;
use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The adapter's shape: character time of the line, packet size, latency timer.
#[derive(Debug, Clone, Copy)]
pub struct Adapter {
    /// One character on the wire.
    pub char_time: Duration,
    /// Data bytes per packet (FTDI: 62).
    pub packet: usize,
    /// The latency timer (FTDI default: 16 ms).
    pub latency: Duration,
}

impl Adapter {
    /// No adapter, only the wire: each byte handed on alone, the moment its character time on
    /// a line of `bits_per_char` bits at `baud` bit/s has passed.
    pub fn wire(baud: u32, bits_per_char: u32) -> Self {
        Adapter {
            packet: 1,
            latency: Duration::ZERO,
            ..Adapter::ftdi_default(baud, bits_per_char)
        }
    }

    /// An FTDI adapter with its default latency timer, on a line of `bits_per_char` bits at
    /// `baud` bit/s.
    pub fn ftdi_default(baud: u32, bits_per_char: u32) -> Self {
        Adapter {
            char_time: Duration::from_micros(
                (u64::from(bits_per_char) * 1_000_000).div_ceil(u64::from(baud)),
            ),
            packet: 62,
            latency: Duration::from_millis(16),
        }
    }
}

/// A running relay: its threads, and how late it handed bytes on.
pub struct Relay {
    threads: Vec<JoinHandle<()>>,
    late: Arc<AtomicU64>,
}

impl Relay {
    /// The most any hand-over came after its due time so far (in either direction): the
    /// relay's own scheduling delay. A loaded machine can stall the relay's threads, and
    /// then the line it models has holes no real adapter would make; a test that judges
    /// silence can tell such a run from a failure of the code under test.
    pub fn max_late(&self) -> Duration {
        Duration::from_micros(self.late.load(Ordering::Relaxed))
    }

    /// [`max_late`](Self::max_late) since the last call (or the start), starting afresh: for a
    /// relay that carries several runs.
    pub fn take_max_late(&self) -> Duration {
        Duration::from_micros(self.late.swap(0, Ordering::Relaxed))
    }

    /// Wait until the relay ends (a pseudo-terminal closed).
    pub fn join(self) {
        for thread in self.threads {
            let _ = thread.join();
        }
    }
}

/// How late a relay may hand bytes on and still model its adapter: a hole that much longer
/// than the adapter's own is within a character or two at 9600 bit/s, which the engines'
/// allowances cover; a longer one is a hole no adapter makes.
pub const LATE_TOLERANCE: Duration = Duration::from_millis(2);

/// Run `attempt` up to `tries` times until it succeeds. `attempt` returns its outcome and how
/// late its relay was ([`Relay::max_late`]). A failed attempt whose relay was later than
/// [`LATE_TOLERANCE`] is tried again (the machine stalled the relay and made a hole no
/// adapter makes: the run judged the test's machine, not the code); a failure on a relay
/// that kept time, or `tries` late ones, fails the test with the attempt's message.
pub fn retry_if_late(tries: usize, mut attempt: impl FnMut() -> (Result<(), String>, Duration)) {
    for n in 1..=tries {
        let (outcome, late) = attempt();
        match outcome {
            Ok(()) => return,
            Err(e) if late > LATE_TOLERANCE && n < tries => {
                eprintln!("attempt {n}: the relay was {late:?} late, trying again ({e})");
            }
            Err(e) => panic!("attempt {n} (relay late by {late:?}): {e}"),
        }
    }
}

/// Relays between the pseudo-terminals `a` and `b` (the far ends of two socat pairs made with
/// `ignoreeof`), both directions shaped by `adapter`. Runs until the pairs are closed (the
/// threads end when their reads fail).
pub fn usb_relay(a: &str, b: &str, adapter: Adapter) -> Relay {
    relay(a, b, adapter, adapter)
}

/// Relays between the host's pseudo-terminal `host` and a device's `device` with the adapter
/// on the host's side only, in front of a device with a plain UART (a drive): what the device
/// sends is held as `adapter` holds it; what the host writes is only paced by the wire, as an
/// adapter's transmit side hands each USB packet to its UART at once `[derived]`.
pub fn usb_relay_host_side(host: &str, device: &str, adapter: Adapter) -> Relay {
    let wire_only = Adapter {
        packet: 1,
        latency: Duration::ZERO,
        ..adapter
    };
    relay(host, device, wire_only, adapter)
}

/// Relays `a` → `b` shaped by `to_b` and `b` → `a` by `to_a`.
fn relay(a: &str, b: &str, to_b: Adapter, to_a: Adapter) -> Relay {
    let open = |p: &str| {
        OpenOptions::new()
            .read(true)
            .write(true)
            .open(p)
            .unwrap_or_else(|e| panic!("relay cannot open {p}: {e}"))
    };
    let (fa, fb) = (open(a), open(b));
    let (fa2, fb2) = (fa.try_clone().unwrap(), fb.try_clone().unwrap());
    let late = Arc::new(AtomicU64::new(0));
    let mut threads = Vec::new();
    for (from, to, adapter) in [(fa2, fb2, to_b), (fb, fa, to_a)] {
        let (tx, rx) = channel();
        let late = Arc::clone(&late);
        threads.push(std::thread::spawn(move || read_into(from, tx)));
        threads.push(std::thread::spawn(move || shape(rx, to, adapter, &late)));
    }
    Relay { threads, late }
}

fn read_into(mut from: File, tx: std::sync::mpsc::Sender<Vec<u8>>) {
    let mut buf = [0u8; 512];
    while let Ok(n) = from.read(&mut buf) {
        if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
            return;
        }
    }
}

/// Paces what arrives on `rx` at the character time (each byte completes one character time
/// after the previous one, or after it arrived), collects it like the adapter and writes the
/// packets to `to`.
fn shape(rx: Receiver<Vec<u8>>, mut to: File, adapter: Adapter, late: &AtomicU64) {
    let mut wire: VecDeque<(Instant, u8)> = VecDeque::new();
    let mut wire_free = Instant::now();
    let mut held: Vec<u8> = Vec::with_capacity(adapter.packet);
    let mut first_at: Option<Instant> = None;
    loop {
        let now = Instant::now();
        while let Some(&(at, byte)) = wire.front() {
            if at > now {
                break;
            }
            wire.pop_front();
            if held.is_empty() {
                first_at = Some(at);
            }
            held.push(byte);
            if held.len() == adapter.packet {
                note_late(late, now, at);
                hand_over(&mut to, &mut held, &mut first_at);
            }
        }
        if let Some(due) = first_at.map(|f| f + adapter.latency).filter(|&d| d <= now) {
            note_late(late, now, due);
            hand_over(&mut to, &mut held, &mut first_at);
        }
        let next = [
            wire.front().map(|w| w.0),
            first_at.map(|f| f + adapter.latency),
        ]
        .into_iter()
        .flatten()
        .min();
        let got = match next {
            Some(t) => rx.recv_timeout(t.saturating_duration_since(now)),
            None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
        };
        match got {
            Ok(bytes) => {
                let now = Instant::now();
                for byte in bytes {
                    wire_free = wire_free.max(now) + adapter.char_time;
                    wire.push_back((wire_free, byte));
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}

/// Keep the largest delay of a hand-over due at `due` and made at `now`.
fn note_late(late: &AtomicU64, now: Instant, due: Instant) {
    let us = u64::try_from(now.saturating_duration_since(due).as_micros()).unwrap_or(u64::MAX);
    late.fetch_max(us, Ordering::Relaxed);
}

fn hand_over(to: &mut File, held: &mut Vec<u8>, first_at: &mut Option<Instant>) {
    // A closed far end ends the test's line; the reader side notices and stops the relay.
    let _ = to.write_all(held).and_then(|()| to.flush());
    held.clear();
    *first_at = None;
}
