//! The async master (feature `tokio`) against a simulated drive over an in-memory duplex pipe,
//! both run by the si-core tokio driver in real time.
#![cfg(feature = "tokio")]

use si_core::driver::{spawn, DriverOptions};
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::PkwWords;
use si_uss::master::{Event, ParamRequest, Width};
use si_uss::status;
use si_uss::tokio::{Error, Handle};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn parameters_and_pzd_over_a_duplex_pipe() {
    let settings = uss_settings(19_200).unwrap();
    let (a, b) = tokio::io::duplex(1024);
    let options = DriverOptions {
        settings: Some(settings),
        ..DriverOptions::default()
    };
    let (_drive, _drive_task) = spawn(
        Drive::new(DriveConfig::new(settings, 4)).unwrap(),
        b,
        options.clone(),
    );
    let mut config = MasterConfig::new(vec![PollEntry::new(4, PkwWords::Four, 2)]);
    config.settings = settings;
    // Real time on a loaded CI machine: generous, unlike the 20 ms of the USS spec.
    config.response_timeout = si_core::Duration::from_millis(500);
    let mut m = Handle::spawn(config, a).unwrap();

    assert_eq!(m.read_parameter(4, 700, 0).await.unwrap(), 5);
    assert_eq!(
        m.write_parameter(4, 1082, 0, 77, Width::Word)
            .await
            .unwrap(),
        77
    );
    let e = m
        .parameter(4, ParamRequest::write(964, 0, 1, Width::Word))
        .await
        .unwrap_err();
    assert_eq!(
        e,
        Error::Failed {
            status: status::PKW_ERROR,
            error_number: Some(1),
            address: 4,
            number: 964
        }
    );
    assert!(e.to_string().contains("error number 1"), "{e}");
    assert!(matches!(
        m.parameter(9, ParamRequest::read(700, 0)).await,
        Err(Error::Refused(_))
    ));

    m.set_control(4, vec![0x047F, 100]).await.unwrap();
    let mut saw_running = false;
    for _ in 0..200 {
        if let Some(Event::Response { net, .. }) = m.next_event().await {
            if net.pzd.first().unwrap() & 0x0004 != 0 {
                saw_running = true;
                break;
            }
        }
    }
    assert!(saw_running);
}
