//! Every crate reports a parameter outside its range as si-core's one `RangeError`:
//! a user reads the parameter, the range, the unit and the value the same way for 3964(R),
//! RK 512, ASCII, Modbus, USS and the DP window.

use si_serial::core::RangeError;
use si_serial::{ascii, dp_coord, modbus, r3964, rk512, uss};

/// The same shape for every crate: `parameter = value unit is out of range: range`.
fn reads_alike(e: &RangeError, parameter: &str, value: &str) {
    assert_eq!(e.parameter, parameter);
    assert_eq!(e.value, value);
    assert_eq!(
        e.to_string(),
        format!(
            "{parameter} = {value}{} is out of range: {}",
            e.unit, e.range
        )
    );
}

#[test]
fn every_config_names_parameter_range_unit_and_value_the_same_way() {
    let e = r3964::Config {
        char_delay: si_core::Duration::from_millis(5),
        ..r3964::Config::default()
    }
    .validate()
    .unwrap_err();
    reads_alike(&e, "character delay time (ZVZ)", "5");
    assert_eq!((&*e.range, e.unit), ("20 … 655350 ms", " ms"));

    let mut rk = rk512::Config::default();
    rk.link.max_block_len = 100;
    let e = rk.validate().unwrap_err();
    assert_eq!(e.value, "100");
    assert_eq!(e.unit, " bytes");

    let e = ascii::Config {
        tx_chunk: 0,
        ..ascii::Config::default()
    }
    .validate()
    .unwrap_err();
    let ascii::config::ConfigError::OutOfRange(e) = e else {
        panic!("a range error: {e:?}");
    };
    reads_alike(&e, "transmit chunk", "0");

    let e = modbus::config::MasterConfig {
        response_timeout: si_serial::core::Duration::from_millis(49),
        ..Default::default()
    }
    .validate()
    .unwrap_err();
    reads_alike(&e.range, "response time", "49");
    assert_eq!(e.status.code(), 0x0E23, "and the module's STATUS beside it");

    let e = uss::config::MasterConfig::new(vec![uss::config::PollEntry::new(
        32,
        uss::frame::PkwWords::Four,
        2,
    )])
    .validate()
    .unwrap_err();
    let uss::config::ConfigError::OutOfRange(e) = e else {
        panic!("a range error: {e:?}");
    };
    reads_alike(&e, "TNU (node number)", "32");

    let mut host = dp_coord::HostConfig::new(dp_coord::WindowSize::Eight);
    host.max_frame_len = 0;
    reads_alike(&host.validate().unwrap_err(), "max_frame_len", "0");
}
