//! `si_core::port::open` on a Linux pseudo-terminal: the line-error marking flags are set in
//! the kernel, and a data byte FFH (which the kernel then doubles) reaches the engine once.

#![cfg(target_os = "linux")]

use si_core::driver::{spawn, DriverOptions};
use si_core::port::{self, PortOptions};
use si_core::{Engine, Instant, LineError, Output, SerialSettings};
use std::time::Duration as StdDuration;
use tokio::io::AsyncWriteExt;
use tokio_serial::{SerialPort, SerialStream};

/// Reports every received run.
#[derive(Default)]
struct Rx(std::collections::VecDeque<Vec<u8>>);
impl Engine for Rx {
    type Event = Vec<u8>;
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        self.0.push_back(bytes.to_vec());
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn poll_output(&mut self) -> Output<Vec<u8>> {
        match self.0.pop_front() {
            Some(run) => Output::Event(run),
            None => Output::Wait(None),
        }
    }
}

/// A pty pair: the master side we drive, and the path of the slave for `port::open`.
fn pty() -> (SerialStream, String) {
    let (master, slave) = SerialStream::pair().expect("open a pseudo-terminal pair");
    let path = slave.name().expect("the slave has a path");
    drop(slave);
    (master, path)
}

#[tokio::test]
async fn an_opened_port_marks_line_errors_in_the_kernel() {
    let (_master, path) = pty();
    let port = port::open(&path, &SerialSettings::default(), &PortOptions::default()).unwrap();
    let mode = port.termios_mode().unwrap();
    assert!(mode.parmrk && mode.inpck, "{mode:?}");
    assert!(
        !mode.ignpar && !mode.brkint && !mode.ignbrk && !mode.istrip,
        "{mode:?}"
    );
    let facts = port.port_facts();
    assert_eq!(facts.marked_errors, Some(LineError::Parity));
    assert_eq!(facts.rx_latency, None, "a pty has no latency timer");
    let info = port.info();
    assert_eq!((info.path.as_str(), &info.usb), (path.as_str(), &None));
}

#[tokio::test]
async fn without_line_errors_the_port_is_left_unmarked() {
    let (_master, path) = pty();
    let options = PortOptions {
        no_line_errors: true,
        ..PortOptions::default()
    };
    let port = port::open(&path, &SerialSettings::default(), &options).unwrap();
    assert!(!port.termios_mode().unwrap().parmrk);
    assert_eq!(port.port_facts().marked_errors, None);
}

#[tokio::test]
async fn a_data_ff_is_doubled_by_the_kernel_and_decoded_once() {
    let (mut master, path) = pty();
    let port = port::open(&path, &SerialSettings::default(), &PortOptions::default()).unwrap();
    let (mut handle, _task) = spawn(Rx::default(), port, DriverOptions::default());
    master.write_all(&[0x41, 0xFF, 0x42, 0xFF]).await.unwrap();
    let mut got = Vec::new();
    while got.len() < 4 {
        let run = tokio::time::timeout(StdDuration::from_secs(10), handle.next_event())
            .await
            .expect("the bytes arrive")
            .expect("the driver runs");
        got.extend(run);
    }
    assert_eq!(got, vec![0x41, 0xFF, 0x42, 0xFF]);
}

#[tokio::test]
async fn a_plain_reader_gets_clean_bytes_from_a_marking_port() {
    use tokio::io::AsyncReadExt;
    let (mut master, path) = pty();
    let mut port = port::open(&path, &SerialSettings::default(), &PortOptions::default()).unwrap();
    master.write_all(&[0xFF, 0x00, 0xFF, 0x7E]).await.unwrap();
    let mut got = [0u8; 4];
    tokio::time::timeout(StdDuration::from_secs(10), port.read_exact(&mut got))
        .await
        .expect("the bytes arrive")
        .unwrap();
    assert_eq!(got, [0xFF, 0x00, 0xFF, 0x7E]);
}

/// Mark and space parity need `CMSPAR`, which a UART driver honours and a pseudo-terminal
/// drops: on a pty the open fails and says why; where it succeeds, the flags are as set.
#[tokio::test]
async fn mark_and_space_parity_are_set_with_cmspar_or_refused_with_the_reason() {
    use si_core::Parity;
    let (_master, path) = pty();
    for parity in [Parity::Mark, Parity::Space] {
        let line = SerialSettings::new(9_600, 8, parity, 1).unwrap();
        match port::open(&path, &line, &PortOptions::default()) {
            Ok(port) => {
                let m = port.termios_mode().unwrap();
                assert!(
                    m.parenb && m.cmspar && m.parodd == (parity == Parity::Mark),
                    "{m:?}"
                );
                // Space is the manuals' "any": not checked on receive.
                assert_eq!(m.inpck, parity == Parity::Mark, "{m:?}");
            }
            Err(e) => assert!(
                e.to_string().contains("does not take") && e.to_string().contains("CMSPAR"),
                "{e}"
            ),
        }
    }
}

/// A port this program holds is reported as busy, naming the holder, not as "not found"; once
/// the driver that held it has closed (`Handle::close` returns after the transport is
/// dropped), it opens again at once.
#[tokio::test]
async fn a_port_still_open_is_busy_and_free_again_once_its_driver_has_closed() {
    let (_master, path) = pty();
    let settings = SerialSettings::default();
    let options = PortOptions::default();
    let first = port::open(&path, &settings, &options).unwrap();
    let (handle, _task) = spawn(Rx::default(), first, DriverOptions::default());
    let e = port::open(&path, &settings, &options).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::ResourceBusy, "{e}");
    assert!(
        e.to_string().contains("port already open by this program"),
        "{e}"
    );
    handle.close().await;
    let again = port::open(&path, &settings, &options);
    assert!(again.is_ok(), "{:?}", again.err());
}
