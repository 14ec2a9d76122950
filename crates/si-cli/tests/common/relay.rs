//! A relay between two pseudo-terminals that behaves like a USB-serial adapter in front of a
//! real line: bytes cross a virtual wire paced at the character time, and the adapter hands
//! them on in packets of up to 62 bytes, when full or 16 ms after the first byte it holds (the
//! model of `si_sim::UsbAdapter`, here in real time). A pseudo-terminal alone delivers
//! every write at once; through this relay a long frame arrives as bursts with 16 ms holes,
//! as it does on a laptop with an FTDI adapter.

use std::collections::VecDeque;
use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
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

/// Relays between the pseudo-terminals `a` and `b` (the far ends of two socat pairs made with
/// `ignoreeof`), both directions shaped by `adapter`. Runs until the pairs are closed (the
/// threads end when their reads fail).
pub fn usb_relay(a: &str, b: &str, adapter: Adapter) {
    relay(a, b, adapter, adapter);
}

/// Relays between the host's pseudo-terminal `host` and a device's `device` with the adapter
/// on the host's side only, in front of a device with a plain UART (a drive): what the device
/// sends is held as `adapter` holds it; what the host writes is only paced by the wire, as an
/// adapter's transmit side hands each USB packet to its UART at once `[derived]`.
#[allow(dead_code)] // Not every test binary that includes this module uses it.
pub fn usb_relay_host_side(host: &str, device: &str, adapter: Adapter) {
    let wire_only = Adapter {
        packet: 1,
        latency: Duration::ZERO,
        ..adapter
    };
    relay(host, device, wire_only, adapter);
}

/// Relays `a` → `b` shaped by `to_b` and `b` → `a` by `to_a`.
fn relay(a: &str, b: &str, to_b: Adapter, to_a: Adapter) {
    let open = |p: &str| {
        OpenOptions::new()
            .read(true)
            .write(true)
            .open(p)
            .unwrap_or_else(|e| panic!("relay cannot open {p}: {e}"))
    };
    let (fa, fb) = (open(a), open(b));
    let (fa2, fb2) = (fa.try_clone().unwrap(), fb.try_clone().unwrap());
    for (from, to, adapter) in [(fa2, fb2, to_b), (fb, fa, to_a)] {
        let (tx, rx) = channel();
        std::thread::spawn(move || read_into(from, tx));
        std::thread::spawn(move || shape(rx, to, adapter));
    }
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
fn shape(rx: Receiver<Vec<u8>>, mut to: File, adapter: Adapter) {
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
                hand_over(&mut to, &mut held, &mut first_at);
            }
        }
        if first_at.is_some_and(|f| f + adapter.latency <= now) {
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

fn hand_over(to: &mut File, held: &mut Vec<u8>, first_at: &mut Option<Instant>) {
    // A closed far end ends the test's line; the reader side notices and stops the relay.
    let _ = to.write_all(held).and_then(|()| to.flush());
    held.clear();
    *first_at = None;
}
