//! The driver's RS-485 help (si_core::driver, si_core::port_facts): RTS toggled around a
//! transmission in the order RTS on → write → tx-done → (delay) → RTS off, and the echo of our
//! own transmission dropped on a port that hears itself.
#![cfg(feature = "tokio")]

use bytes::Bytes;
use si_core::driver::{spawn, DriverOptions, PortFacts, RtsToggle};
use si_core::linemark::Marked;
use si_core::tap::{Tap, Watch};
use si_core::{Duration, Engine, Instant, Output, SerialSettings, SignalUpdate};
use std::collections::VecDeque;
use std::io;
use std::sync::{Arc, Mutex};
use std::time::Duration as StdDuration;
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};

/// What happened, in order, with the wall-clock time it happened.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Step {
    Rts(bool),
    Write(Vec<u8>),
    TxDone,
}

pub(crate) type Log = Arc<Mutex<Vec<(std::time::Instant, Step)>>>;

pub(crate) fn note(log: &Log, step: Step) {
    log.lock().unwrap().push((std::time::Instant::now(), step));
}

/// Notes the writes and RTS changes of a tapped duplex pipe.
pub(crate) struct Steps(pub(crate) Log);

impl Watch for Steps {
    fn written(&mut self, bytes: &[u8]) {
        note(&self.0, Step::Write(bytes.to_vec()));
    }
    fn read(&mut self, _: Marked<'_>) {}
    fn signals(&mut self, update: SignalUpdate) {
        if let Some(rts) = update.rts {
            note(&self.0, Step::Rts(rts));
        }
    }
}

/// Transmits on command, notes tx-done, reports what it receives.
pub(crate) struct Talker {
    /// What it transmits next.
    pub(crate) out: VecDeque<Output<Vec<u8>>>,
    log: Log,
}

impl Engine for Talker {
    type Event = Vec<u8>;
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        self.out.push_back(Output::Event(bytes.to_vec()));
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn handle_tx_done(&mut self, _: Instant) {
        note(&self.log, Step::TxDone);
    }
    fn poll_output(&mut self) -> Output<Vec<u8>> {
        self.out.pop_front().unwrap_or(Output::Wait(None))
    }
}

pub(crate) fn talker(log: &Log) -> Talker {
    Talker {
        out: VecDeque::new(),
        log: log.clone(),
    }
}

/// Wait (bounded) until the log has `n` steps.
pub(crate) async fn steps(log: &Log, n: usize) -> Vec<(std::time::Instant, Step)> {
    for _ in 0..1_000 {
        if log.lock().unwrap().len() >= n {
            break;
        }
        tokio::time::sleep(StdDuration::from_millis(5)).await;
    }
    log.lock().unwrap().clone()
}

/// A [`Talker`] on a 9600 8E1 line over a recording pipe, the driver toggling RTS.
fn start_toggling(
    toggle: RtsToggle,
    pipe: DuplexStream,
    log: &Log,
) -> (
    si_core::driver::Handle<Talker>,
    tokio::task::JoinHandle<io::Result<()>>,
) {
    start_toggling_with(toggle, pipe, log, Some(SerialSettings::default()), None)
}

/// [`start_toggling`] with the engine's tx-done timing (`settings`, `None`: when the write
/// returns) and the port's own line format (`wire`, as `si_core::port::open` reports it).
fn start_toggling_with(
    toggle: RtsToggle,
    pipe: DuplexStream,
    log: &Log,
    settings: Option<SerialSettings>,
    wire: Option<SerialSettings>,
) -> (
    si_core::driver::Handle<Talker>,
    tokio::task::JoinHandle<io::Result<()>>,
) {
    let options = DriverOptions {
        settings,
        port: Some(PortFacts {
            rts_toggle: Some(toggle),
            wire,
            ..PortFacts::default()
        }),
        ..DriverOptions::default()
    };
    let transport = Tap::new(pipe, Steps(log.clone()));
    spawn(talker(log), transport, options)
}

#[tokio::test]
async fn rts_goes_on_before_the_write_and_off_after_tx_done_plus_the_delay() {
    let log = Log::default();
    let (ours, mut theirs) = tokio::io::duplex(256);
    let line = SerialSettings::default(); // 9600 8E1: 10 bytes take 11.46 ms on the wire
    let after = Duration::from_millis(5);
    let toggle = RtsToggle {
        before: Duration::ZERO,
        after,
    };
    let (handle, _task) = start_toggling(toggle, ours, &log);
    let frame = [0x5Au8; 10];
    handle
        .call(move |t, _| {
            t.out
                .push_back(Output::Transmit(Bytes::copy_from_slice(&frame)))
        })
        .await
        .unwrap();
    let mut sent = [0u8; 10];
    theirs.read_exact(&mut sent).await.unwrap();

    let got = steps(&log, 4).await;
    let order: Vec<Step> = got.iter().map(|(_, s)| s.clone()).collect();
    assert_eq!(
        order,
        vec![
            Step::Rts(true),
            Step::Write(frame.to_vec()),
            Step::TxDone,
            Step::Rts(false)
        ]
    );
    // Never early: RTS stays on for the bytes' wire time plus the delay after the write. The
    // log stamps the write when the mock transport sees it, a few microseconds after the
    // driver read the clock the deadline counts from: that much is the log's, not the driver's.
    let on_for = got[3].0 - got[1].0 + StdDuration::from_micros(20);
    let least = StdDuration::from(line.chars_time(10) + after);
    assert!(
        on_for >= least,
        "RTS off {on_for:?} after the write, before {least:?}"
    );
}

/// An engine told "done" when the write returns (the 3964(R) handle, whose link judges a DLE
/// arriving before tx-done itself) still keeps RTS on until the bytes have left the wire: the
/// port's line format, not the engine's tx-done, times the direction switch.
#[tokio::test]
async fn rts_follows_the_wire_even_when_the_engine_hears_done_at_the_write() {
    let log = Log::default();
    let (ours, mut theirs) = tokio::io::duplex(256);
    let line = SerialSettings::default();
    let toggle = RtsToggle::default();
    let (handle, _task) = start_toggling_with(toggle, ours, &log, None, Some(line));
    let frame = [0xA5u8; 20];
    handle
        .call(move |t, _| {
            t.out
                .push_back(Output::Transmit(Bytes::copy_from_slice(&frame)))
        })
        .await
        .unwrap();
    let mut sent = [0u8; 20];
    theirs.read_exact(&mut sent).await.unwrap();
    let got = steps(&log, 4).await;
    let order: Vec<Step> = got.iter().map(|(_, s)| s.clone()).collect();
    assert_eq!(
        order,
        vec![
            Step::Rts(true),
            Step::Write(frame.to_vec()),
            Step::TxDone,
            Step::Rts(false)
        ]
    );
    // As above: the log stamps the write a few microseconds after the driver read the clock
    // the deadline counts from (with the precise timer's 1 µs slack the switch comes that
    // close to its deadline).
    let on_for = got[3].0 - got[1].0 + StdDuration::from_micros(20);
    let least = StdDuration::from(line.chars_time(20));
    assert!(
        on_for >= least,
        "RTS off {on_for:?} after the write, before the 20 bytes' {least:?} on the wire"
    );
}

#[tokio::test]
async fn back_to_back_transmissions_keep_rts_on() {
    let log = Log::default();
    let (ours, mut theirs) = tokio::io::duplex(256);
    let (handle, _task) = start_toggling(RtsToggle::default(), ours, &log);
    handle
        .call(|t, _| {
            t.out
                .push_back(Output::Transmit(Bytes::from_static(&[1, 2])));
            t.out
                .push_back(Output::Transmit(Bytes::from_static(&[3, 4])));
        })
        .await
        .unwrap();
    let mut sent = [0u8; 4];
    theirs.read_exact(&mut sent).await.unwrap();
    let order: Vec<Step> = steps(&log, 5).await.into_iter().map(|(_, s)| s).collect();
    assert_eq!(
        order,
        vec![
            Step::Rts(true),
            Step::Write(vec![1, 2]),
            Step::Write(vec![3, 4]),
            Step::TxDone,
            Step::Rts(false)
        ]
    );
}

/// Sends `ours`, lets the far end answer with `heard`, and returns what the engine received.
async fn echo_run(sent: &'static [u8], heard: &'static [u8], answer_len: usize) -> Vec<u8> {
    let log = Log::default();
    let (ours, mut theirs) = tokio::io::duplex(256);
    let options = DriverOptions {
        port: Some(PortFacts {
            local_echo: true,
            ..PortFacts::default()
        }),
        ..DriverOptions::default()
    };
    let (mut handle, _task) = spawn(talker(&log), ours, options);
    handle
        .call(move |t, _| t.out.push_back(Output::Transmit(Bytes::from_static(sent))))
        .await
        .unwrap();
    let mut wire = vec![0u8; sent.len()];
    theirs.read_exact(&mut wire).await.unwrap();
    theirs.write_all(heard).await.unwrap();
    let mut got = Vec::new();
    while got.len() < answer_len {
        let run = tokio::time::timeout(StdDuration::from_secs(10), handle.next_event())
            .await
            .expect("the answer arrives")
            .expect("the driver runs");
        got.extend(run);
    }
    got
}

#[tokio::test]
async fn our_echo_is_dropped_and_the_answer_passed_on_over_a_duplex_pipe() {
    // The port hears our request, then the partner's answer.
    let got = echo_run(&[1, 3, 0, 0], &[1, 3, 0, 0, 1, 3, 2], 3).await;
    assert_eq!(got, vec![1, 3, 2]);
}

#[tokio::test]
async fn an_echo_that_does_not_match_ends_suppression() {
    // The second byte came back different (a collision): it and the rest reach the engine.
    let got = echo_run(&[1, 3, 0, 0], &[1, 7, 0, 0], 3).await;
    assert_eq!(got, vec![7, 0, 0]);
}
