//! The library's async USS master on a pseudo-terminal: a simulated drive (si_uss::drive, run
//! by the si-core driver) on the other end of a socat pty pair, 19200 bit/s. Parameters are
//! read and written, and the drive's state words come back in the cyclic telegrams.
//!
//! Peer: `apt-get install socat`. Missing, the test is skipped with a message; with `CI` set it
//! fails instead.
#![cfg(all(feature = "tokio", target_os = "linux"))]

use si_core::driver::{spawn, DriverOptions};
use si_core::port::{self, PortOptions};
use si_testkit::pty::pty_pair;
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::PkwWords;
use si_uss::tokio::Handle;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_master_reads_and_writes_parameters_of_a_simulated_drive_on_a_pty() {
    let Some(pair) = pty_pair() else { return };
    let settings = uss_settings(19_200).unwrap();
    let drive_port = port::open(&pair.b, &settings, &PortOptions::default()).unwrap();
    let options = DriverOptions {
        settings: Some(settings),
        ..DriverOptions::default()
    };
    let (_drive, _task) = spawn(
        Drive::new(DriveConfig::new(settings, 4)).unwrap(),
        drive_port,
        options,
    );
    let mut config = MasterConfig::new(vec![PollEntry::new(4, PkwWords::Four, 2)]);
    config.settings = settings;
    // Real time through a pty on a loaded machine: generous, unlike the 20 ms of the USS spec.
    config.response_timeout = si_core::Duration::from_millis(500);
    let line = port::open(&pair.a, &settings, &PortOptions::default()).unwrap();
    let master = Handle::spawn(config, line).unwrap();
    assert_eq!(master.read_parameter(4, 700, 0).await.unwrap(), 5);
    assert_eq!(
        master
            .write_parameter(4, 1082, 0, 77, si_uss::Width::Word)
            .await
            .unwrap(),
        77
    );
    assert_eq!(master.read_parameter(4, 1082, 0).await.unwrap(), 77);
}
