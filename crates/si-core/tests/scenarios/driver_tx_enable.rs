//! RS-485 direction control through each transmitter enable output
//! (si_core::port::TxEnableOutput, mbusd's `-t`, `-r`, `-y`, `-Y`): the driver's timing is the
//! same for all four, only the output and its level differ. The "port" here is a pipe wired
//! as `si_core::port::SerialPort` wires the real one: the driver's RTS updates go through the
//! output to a probe that notes the level the transceiver would see.
#![cfg(feature = "serial")]

use crate::driver_rs485::{note, steps, talker, Log, Step, Steps};
use bytes::Bytes;
use si_core::driver::{spawn, DriverOptions, PortFacts, RtsToggle, Transport};
use si_core::port::{TxEnable, TxEnableOutput};
use si_core::tap::Tap;
use si_core::{Duration, Output, SerialSettings, SignalUpdate};
use std::io;
use std::path::PathBuf;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, DuplexStream, ReadBuf};

/// The port's own modem lines and wire: notes each write and each RTS level set
/// (`Step::Rts` = the wire level).
type Probe = Tap<DuplexStream, Steps>;

fn probe(pipe: DuplexStream, log: &Log) -> Probe {
    Tap::new(pipe, Steps(log.clone()))
}

/// A pipe behind a transmitter enable output. For the file kinds it notes the file's level
/// after each switch as `Step::Rts` (`1` = high), so every kind reads the same in the log.
struct Wired {
    port: Probe,
    output: TxEnableOutput,
    log: Log,
}

impl Transport for Wired {
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        self.output.set_signals(&mut self.port, update)?;
        if let Some(path) = self.output.how().file() {
            let level = std::fs::read_to_string(path)?;
            note(&self.log, Step::Rts(level == "1"));
        }
        Ok(())
    }
}

impl AsyncRead for Wired {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.port).poll_read(cx, buf)
    }
}

impl AsyncWrite for Wired {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.port).poll_write(cx, buf)
    }
    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.port).poll_flush(cx)
    }
    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.port).poll_shutdown(cx)
    }
}

/// A fresh level file holding `initial`, for the file kinds.
fn level_file(name: &str, initial: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("si-tx-enable-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, initial).unwrap();
    path
}

/// One 4-byte transmission through output `how` on a 9600 8E1 line; the steps in order.
async fn transmit_through(how: TxEnable) -> Vec<Step> {
    let log = Log::default();
    let (ours, mut theirs) = tokio::io::duplex(256);
    let wired = Wired {
        port: probe(ours, &log),
        output: TxEnableOutput::open(how).expect("the output opens"),
        log: log.clone(),
    };
    let options = DriverOptions {
        settings: Some(SerialSettings::default()),
        port: Some(PortFacts {
            rts_toggle: Some(RtsToggle {
                before: Duration::ZERO,
                after: Duration::from_millis(2),
            }),
            ..PortFacts::default()
        }),
        ..DriverOptions::default()
    };
    let (handle, _task) = spawn(talker(&log), wired, options);
    handle
        .call(|t, _| {
            t.out
                .push_back(Output::Transmit(Bytes::from_static(&[1, 2, 3, 4])))
        })
        .await
        .unwrap();
    let mut sent = [0u8; 4];
    theirs.read_exact(&mut sent).await.unwrap();
    steps(&log, 4).await.into_iter().map(|(_, s)| s).collect()
}

/// The sequence of one transmission with the enable output active at `on` (`true`: high).
fn switched(on: bool) -> Vec<Step> {
    vec![
        Step::Rts(on),
        Step::Write(vec![1, 2, 3, 4]),
        Step::TxDone,
        Step::Rts(!on),
    ]
}

#[tokio::test]
async fn rts_active_high_is_on_while_transmitting() {
    assert_eq!(transmit_through(TxEnable::Rts).await, switched(true));
}

#[tokio::test]
async fn rts_inverted_is_off_while_transmitting_and_on_after() {
    assert_eq!(
        transmit_through(TxEnable::RtsInverted).await,
        switched(false)
    );
}

#[tokio::test]
async fn a_sysfs_file_holds_1_while_transmitting_and_0_after() {
    let path = level_file("value", "0");
    assert_eq!(
        transmit_through(TxEnable::File(path.clone())).await,
        switched(true)
    );
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "0");
}

#[tokio::test]
async fn an_inverted_sysfs_file_holds_0_while_transmitting_and_1_after() {
    let path = level_file("value-inverted", "1");
    assert_eq!(
        transmit_through(TxEnable::FileInverted(path.clone())).await,
        switched(false)
    );
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "1");
}

#[test]
fn receive_sets_each_output_to_its_receive_level() {
    let log = Log::default();
    let mut port = probe(tokio::io::duplex(1).0, &log);
    for how in [TxEnable::Rts, TxEnable::RtsInverted] {
        TxEnableOutput::open(how)
            .unwrap()
            .receive(&mut port)
            .unwrap();
    }
    let levels: Vec<Step> = log.lock().unwrap().iter().map(|(_, s)| s.clone()).collect();
    assert_eq!(levels, vec![Step::Rts(false), Step::Rts(true)]);
    let path = level_file("receive", "1");
    TxEnableOutput::open(TxEnable::File(path.clone()))
        .unwrap()
        .receive(&mut port)
        .unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "0");
    TxEnableOutput::open(TxEnable::FileInverted(path.clone()))
        .unwrap()
        .receive(&mut port)
        .unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "1");
    // The file kinds leave the port's RTS alone.
    assert_eq!(log.lock().unwrap().len(), 2);
}

#[test]
fn dtr_passes_through_a_file_output_untouched() {
    let log = Log::default();
    let mut port = probe(tokio::io::duplex(1).0, &log);
    let path = level_file("dtr", "0");
    let mut output = TxEnableOutput::open(TxEnable::File(path.clone())).unwrap();
    output
        .set_signals(
            &mut port,
            SignalUpdate {
                rts: Some(true),
                dtr: Some(true),
            },
        )
        .unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "1");
    assert!(log.lock().unwrap().is_empty(), "RTS was not the output");
}

#[test]
fn a_missing_file_is_an_error_naming_it() {
    let path = std::env::temp_dir().join("si-no-such-dir/gpio17/value");
    let e = TxEnableOutput::open(TxEnable::File(path.clone())).unwrap_err();
    assert_eq!(e.kind(), io::ErrorKind::NotFound);
    assert!(e.to_string().contains(&path.display().to_string()), "{e}");
}

#[cfg(target_os = "linux")]
#[test]
fn a_write_error_is_an_io_error_naming_the_file() {
    // /dev/full refuses every write (ENOSPC).
    let mut output = TxEnableOutput::open(TxEnable::File("/dev/full".into())).unwrap();
    let mut port = probe(tokio::io::duplex(1).0, &Log::default());
    let e = output.receive(&mut port).unwrap_err();
    assert!(
        e.to_string()
            .contains("cannot write the RS-485 direction to /dev/full"),
        "{e}"
    );
}

#[test]
fn release_switches_a_transmitting_output_to_receive_once() {
    let log = Log::default();
    let mut port = probe(tokio::io::duplex(1).0, &log);
    let mut output = TxEnableOutput::open(TxEnable::RtsInverted).unwrap();
    output.release(&mut port).unwrap(); // receiving: nothing to do
    let transmit = SignalUpdate {
        rts: Some(true),
        ..SignalUpdate::default()
    };
    output.set_signals(&mut port, transmit).unwrap();
    output.release(&mut port).unwrap();
    output.release(&mut port).unwrap();
    let levels: Vec<Step> = log.lock().unwrap().iter().map(|(_, s)| s.clone()).collect();
    assert_eq!(levels, vec![Step::Rts(false), Step::Rts(true)]);
}
