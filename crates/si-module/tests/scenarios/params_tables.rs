//! Module parameters per driver: every limit of the manual's parameter tables at and beyond both
//! ends, defaults, TOML/JSON round trips, and all errors of a file in one run.
//!
//! Tables: [ET200S SI 2005] §2.9.3 (Table 2-9, 3964(R)), Table 2-8 (ASCII),
//! Tables 3-18/3-21 (Modbus), §3.8 / [Modbus/USS] §3.7.6, Table 3-31 (USS).

use si_dp_coord::config::FlowControl as WindowFlow;
use si_dp_coord::frame::WindowSize;
use si_module::params::{DriverParams, ReceiveLine};

/// `(driver, extra lines, key, at low end, at high end, below, above)`.
type Limit = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
);

const LIMITS: &[Limit] = &[
    // ASCII, Table 2-8 / 2-10.
    // At 110 bit/s the default ZVZ of 4 ms is below the Table 2-7 minimum ([derived]).
    (
        "ascii",
        "char_delay_ms = 400",
        "baud",
        "110",
        "115200",
        "50",
        "230400",
    ),
    ("ascii", "", "data_bits", "7", "8", "6", "9"),
    ("ascii", "", "stop_bits", "1", "2", "0", "3"),
    ("ascii", "", "char_delay_ms", "4", "65535", "3", "65536"),
    (
        "ascii",
        "baud = 110",
        "char_delay_ms",
        "364",
        "65535",
        "363",
        "65536",
    ),
    (
        "ascii",
        "end_criterion = \"end-chars\"",
        "end_char_1",
        "1",
        "255",
        "0",
        "256",
    ),
    (
        "ascii",
        "end_criterion = \"end-chars\"\ndata_bits = 7",
        "end_char_1",
        "1",
        "127",
        "0",
        "128",
    ),
    (
        "ascii",
        "end_criterion = \"end-chars\"",
        "end_char_2",
        "0",
        "255",
        "-1",
        "256",
    ),
    (
        "ascii",
        "end_criterion = \"end-chars\"\ndata_bits = 7",
        "end_char_2",
        "0",
        "127",
        "-1",
        "128",
    ),
    (
        "ascii",
        "end_criterion = \"fixed-length\"",
        "frame_length",
        "1",
        "200",
        "0",
        "201",
    ),
    (
        "ascii",
        "",
        "wait_for_xon_ms",
        "20",
        "655350",
        "10",
        "655360",
    ),
    (
        "ascii",
        "",
        "wait_for_cts_ms",
        "20",
        "655350",
        "10",
        "655360",
    ),
    (
        "ascii",
        "",
        "time_rts_off_ms",
        "0",
        "655350",
        "-10",
        "655360",
    ),
    (
        "ascii",
        "",
        "data_wait_time_ms",
        "0",
        "655350",
        "-10",
        "655360",
    ),
    ("ascii", "", "xon", "0", "255", "-1", "256"),
    ("ascii", "", "tx_chunk", "1", "200", "0", "201"),
    // 3964(R), Table 2-9 / 2-11.
    ("3964r", "", "baud", "110", "115200", "50", "230400"),
    ("3964r", "", "data_bits", "7", "8", "6", "9"),
    ("3964r", "", "stop_bits", "1", "2", "0", "3"),
    ("3964r", "", "char_delay_ms", "20", "655350", "19", "655351"),
    ("3964r", "", "ack_delay_ms", "10", "655350", "9", "655351"),
    ("3964r", "", "connection_attempts", "1", "255", "0", "256"),
    ("3964r", "", "transmission_attempts", "1", "255", "0", "256"),
    ("3964r", "", "max_block_len", "1", "1024", "0", "1025"),
    ("3964r", "", "receive_buffer_blocks", "1", "255", "0", "256"),
    // Modbus master, Table 3-18 / 3-17.
    ("modbus-master", "", "baud", "110", "115200", "50", "230400"),
    ("modbus-master", "", "stop_bits", "1", "2", "0", "3"),
    (
        "modbus-master",
        "",
        "response_timeout_ms",
        "50",
        "655000",
        "49",
        "655001",
    ),
    (
        "modbus-master",
        "",
        "char_delay_multiplier",
        "1",
        "10",
        "0",
        "11",
    ),
    // Modbus slave, Table 3-21 / 3-20.
    ("modbus-slave", "", "address", "1", "255", "0", "256"),
    (
        "modbus-slave",
        "",
        "char_delay_multiplier",
        "1",
        "10",
        "0",
        "11",
    ),
    ("modbus-slave", "", "baud", "110", "115200", "50", "230400"),
    // USS master, Table 3-78 and S_USSI.
    ("uss-master", "", "baud", "110", "115200", "50", "187500"),
    ("uss-master", "", "pkw_retries", "0", "32767", "-1", "32768"),
    (
        "uss-master",
        "",
        "response_timeout_ms",
        "1",
        "10000",
        "0",
        "10001",
    ),
    (
        "uss-master",
        "",
        "cycle_pause_ms",
        "0",
        "60000",
        "-1",
        "60001",
    ),
];

fn file(driver: &str, extra: &str, key: &str, value: &str) -> String {
    format!("driver = \"{driver}\"\n{extra}\n{key} = {value}\n")
}

#[test]
fn every_table_limit_at_and_beyond_both_ends() {
    for &(driver, extra, key, low, high, below, above) in LIMITS {
        for ok in [low, high] {
            let text = file(driver, extra, key, ok);
            let p = DriverParams::from_toml_str(&text);
            assert!(p.is_ok(), "{text}: {}", p.unwrap_err());
            // The value is kept: it comes back when written again.
            let back = p.unwrap().to_value();
            assert_eq!(back[key].to_string(), ok, "{text}");
        }
        for bad in [below, above] {
            let text = file(driver, extra, key, bad);
            let e = DriverParams::from_toml_str(&text).expect_err(&text);
            assert_eq!(e.len(), 1, "{text}: {e}");
            let line = e.to_string();
            let shown = bad.trim_start_matches('-');
            let hex = format!("{:02X}H", shown.parse::<u32>().unwrap());
            assert!(
                line.contains(shown) || line.contains(&hex),
                "{text}: {line} does not name the value"
            );
            // The message names the parameter (by key or by the manual's name) and its range.
            assert!(
                line.contains(key)
                    || line.contains("delay")
                    || line.contains("attempts")
                    || line.contains("wait time")
                    || line.contains("time to RTS off")
                    || line.contains("character")
                    || line.contains("length")
                    || line.contains("WDH")
                    || line.contains("timeout")
                    || line.contains("pause")
                    || line.contains("chunk")
                    || line.contains("buffer")
                    || line.contains("multiple")
                    || line.contains("address")
                    || line.contains("response time"),
                "{text}: {line}"
            );
            assert!(
                line.contains('…') || line.contains("one of") || line.contains("range"),
                "{text}: {line} does not give the range"
            );
        }
    }
}

#[test]
fn uss_polling_list_limits() {
    let list = |entries: &str| format!("driver = \"uss-master\"\npolling_list = [{entries}]\n");
    let entry = |a: i64, pzd: i64| format!("{{ address = {a}, pkw = 4, pzd = {pzd} }}");
    for ok in [entry(0, 0), entry(31, 16)] {
        DriverParams::from_toml_str(&list(&ok)).unwrap();
    }
    for (bad, what) in [
        (entry(32, 2), "TNU"),
        (entry(-1, 2), "address"),
        (entry(1, 17), "PZD"),
        (entry(1, -1), "pzd"),
    ] {
        let e = DriverParams::from_toml_str(&list(&bad)).unwrap_err();
        assert_eq!(e.len(), 1, "{e}");
        assert!(e.to_string().contains(what), "{e}");
    }
    let thirty_one: Vec<String> = (0..31).map(|i| entry(i, 2)).collect();
    DriverParams::from_toml_str(&list(&thirty_one.join(", "))).unwrap();
    let thirty_two: Vec<String> = (0..32).map(|i| entry(i % 31, 2)).collect();
    let e = DriverParams::from_toml_str(&list(&thirty_two.join(", "))).unwrap_err();
    assert!(e.to_string().starts_with("SANZ"), "{e}");
    let e = DriverParams::from_toml_str(&list("")).unwrap_err();
    assert!(
        e.to_string().contains("SANZ (polling list entries) = 0"),
        "{e}"
    );
    let e = DriverParams::from_toml_str(&list("{ address = 1, pkw = 5 }")).unwrap_err();
    assert!(
        e.to_string()
            .contains("pkw = 5 is not one of: 0, 3, 4, 127"),
        "{e}"
    );
}

#[test]
fn defaults_are_the_manuals() {
    let p = DriverParams::from_toml_str("driver = \"ascii\"").unwrap();
    let DriverParams::Ascii(a) = &p else { panic!() };
    assert!(!a.diagnostic_interrupt && !a.break_detection);
    assert_eq!(a.config, si_ascii::Config::default());
    assert_eq!(a.config.settings.to_string(), "9600 8E1");

    let p = DriverParams::from_toml_str("driver = \"3964r\"\nblock_check = false").unwrap();
    let DriverParams::R3964(r) = &p else { panic!() };
    assert_eq!(
        r.config.ack_delay.as_millis(),
        550,
        "QVZ default without block check"
    );
    assert_eq!(r.config.char_delay.as_millis(), 220);
    assert!(r.config.clear_at_startup);

    let p = DriverParams::from_toml_str("driver = \"modbus-slave\"").unwrap();
    let DriverParams::ModbusSlave(s) = &p else {
        panic!()
    };
    assert_eq!(s.config.address, 222, "as printed in Table 3-21");
    let p = DriverParams::from_toml_str("driver = \"modbus-master\"").unwrap();
    let DriverParams::ModbusMaster(m) = &p else {
        panic!()
    };
    assert_eq!(m.config.response_timeout.as_millis(), 2_000);
    assert_eq!(m.config.line.char_delay_multiplier, 1);

    let p = DriverParams::from_toml_str("driver = \"uss-master\"").unwrap();
    let DriverParams::UssMaster(u) = &p else {
        panic!()
    };
    assert_eq!(u.interface, si_ascii::config::Interface::Rs485);
    assert_eq!(u.config.settings.to_string(), "9600 8E1");
}

#[test]
fn receive_line_initial_state_depends_on_the_interface() {
    let p = DriverParams::from_toml_str("driver = \"ascii\"\ninterface = \"rs485\"").unwrap();
    let DriverParams::Ascii(a) = &p else { panic!() };
    assert_eq!(a.receive_line, ReceiveLine::Ra0vRb5v);
    let p = DriverParams::from_toml_str("driver = \"3964r\"\ninterface = \"rs422\"").unwrap();
    let DriverParams::R3964(r) = &p else { panic!() };
    assert_eq!(r.receive_line, ReceiveLine::Ra5vRb0v);
    let e = DriverParams::from_toml_str(
        "driver = \"ascii\"\ninterface = \"rs485\"\nreceive_line = \"inverted\"",
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "receive_line = \"inverted\" is not offered on rs485: ra0v-rb5v, none (line 3)"
    );
    let e = DriverParams::from_toml_str("driver = \"3964r\"\ninterface = \"rs485\"").unwrap_err();
    assert_eq!(
        e.to_string(),
        "interface = \"rs485\" is not one of: rs232, rs422 (line 2)"
    );
    let e = DriverParams::from_toml_str(
        "driver = \"modbus-master\"\ninterface = \"rs485\"\nflow_control = \"auto-v24\"",
    )
    .unwrap_err();
    assert!(e.to_string().contains("needs interface = \"rs232\""), "{e}");
    let e =
        DriverParams::from_toml_str("driver = \"modbus-master\"\nparity = \"any\"").unwrap_err();
    assert!(e.to_string().contains("none, odd, even"), "{e}");
}

/// [Modbus/USS] §3.4.3, §3.5.4, §3.6: a mode other than Normal or Interference suppression is
/// 0E22H, "driver not ready".
#[test]
fn an_invalid_modbus_mode_names_0e22h() {
    for driver in ["modbus-master", "modbus-slave"] {
        let e = DriverParams::from_toml_str(&file(driver, "", "mode", "\"fast\"")).unwrap_err();
        assert_eq!(e.len(), 1, "{e}");
        assert_eq!(
            e.to_string(),
            "mode = \"fast\" is not one of: normal, interference-suppression \
             (16#0E22 invalid operating mode; driver not ready) (line 3)"
        );
        let p =
            DriverParams::from_toml_str(&file(driver, "", "mode", "\"interference-suppression\""))
                .unwrap();
        assert_eq!(p.to_value()["mode"], "interference-suppression");
    }
}

#[test]
fn three_wrong_values_and_an_unknown_key_in_one_run() {
    let text =
        "driver = \"ascii\"\nbaud = 9601\ndata_bits = 9\nchar_delay_ms = 70000\ncolour = \"red\"\n";
    let e = DriverParams::from_toml_str(text).unwrap_err();
    let lines: Vec<String> = e.iter().map(|e| e.to_string()).collect();
    assert_eq!(lines.len(), 4, "{lines:?}");
    assert!(lines[0].starts_with("baud = 9601 is not one of: 110, 300"));
    assert_eq!(lines[1], "data_bits = 9 is not one of: 7, 8 (line 3)");
    assert_eq!(
        lines[2],
        "colour is not a parameter of the ascii driver (line 5)"
    );
    assert_eq!(
        lines[3],
        "character delay time = 70000 ms is out of range: 4 … 65535 ms at 9600 bit/s"
    );
    let e = DriverParams::from_toml_str("driver = \"ascii\"\nend_char_1 = 13").unwrap_err();
    assert_eq!(
        e.to_string(),
        "end_char_1 applies only with end_criterion = \"end-chars\" (line 2)"
    );
    let e = DriverParams::from_toml_str("baud = 9600").unwrap_err();
    assert!(e.to_string().starts_with("driver is missing"));
    let e = DriverParams::from_toml_str("driver = \"profibus\"").unwrap_err();
    assert!(e.to_string().contains("ascii, 3964r, modbus-master"));
    let e = DriverParams::from_toml_str("driver = ").unwrap_err();
    assert!(e.to_string().starts_with("not valid TOML"));
    let e = DriverParams::from_toml_str("driver = \"ascii\"\nbaud = \"fast\"").unwrap_err();
    assert!(
        e.to_string()
            .contains("baud = \"fast\" must be a number, one of"),
        "{e}"
    );
    let e = DriverParams::from_toml_str("driver = \"ascii\"\nchar_delay_ms = \"4\"").unwrap_err();
    assert!(e.to_string().contains("must be a whole number"), "{e}");
}

#[test]
fn toml_and_json_round_trip_a_non_default_set() {
    let text = r#"
driver = "ascii"
interface = "rs422"
receive_line = "inverted"
baud = 19200
data_bits = 7
parity = "any"
stop_bits = 2
flow_control = "xon-xoff"
end_criterion = "end-chars"
end_char_1 = 13
end_char_2 = 10
char_delay_ms = 40
dynamic_frames = false
wait_for_xon_ms = 500
"#;
    let p = DriverParams::from_toml_str(text).unwrap();
    let DriverParams::Ascii(a) = &p else { panic!() };
    assert_eq!(a.config.settings.to_string(), "19200 7S2");
    assert_eq!(
        a.config.end,
        si_ascii::config::EndCriterion::EndChars {
            first: 13,
            second: 10
        }
    );
    assert_eq!(DriverParams::from_toml_str(&p.to_toml_string()).unwrap(), p);
    let json = serde_json::to_string(&p).unwrap();
    assert_eq!(DriverParams::from_json_str(&json).unwrap(), p);
    let via_serde: DriverParams = toml::from_str(text).unwrap();
    assert_eq!(via_serde, p);
    let e = toml::from_str::<DriverParams>(
        "driver = \"3964r\"\nconnection_attempts = 0\npriority = \"top\"",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("priority = \"top\" is not one of: low, high"),
        "{e}"
    );
    assert!(
        e.contains("connection attempts = 0 is out of range: 1 … 255"),
        "{e}"
    );
}

#[test]
fn the_same_parameters_configure_the_simulated_module() {
    let p = DriverParams::from_toml_str("driver = \"ascii\"\nflow_control = \"rts-cts\"").unwrap();
    let m = p.module_config(WindowSize::Four);
    assert_eq!(m.window, WindowSize::Four);
    assert_eq!(m.flow_control, WindowFlow::RtsCts);
    assert_eq!(m.max_frame_len, 200, "the ASCII engine's frame limit");
    m.validate().unwrap();
    // The same parameters build the simulated module itself, with its line engine.
    let DriverParams::Ascii(a) = &p else { panic!() };
    let module = a.simulated_module(WindowSize::Four).unwrap();
    assert_eq!(module.config(), &m);
    assert_eq!(module.serial().engine().config(), &a.config);
    let p =
        DriverParams::from_toml_str("driver = \"3964r\"\nmax_block_len = 100\npriority = \"high\"")
            .unwrap();
    let DriverParams::R3964(r) = &p else { panic!() };
    let module = r.simulated_module(WindowSize::Eight).unwrap();
    assert_eq!(module.config().max_frame_len, 100);
    assert_eq!(module.serial().engine().config(), &r.config);
    assert_eq!(p.module_config(WindowSize::Eight), *module.config());
    let p = DriverParams::from_toml_str("driver = \"modbus-slave\"").unwrap();
    let m = p.module_config(WindowSize::ThirtyTwo);
    assert_eq!((m.max_frame_len, m.flow_control), (200, WindowFlow::None));
    assert_eq!(p.settings().to_string(), "9600 8E1");
    assert!(p.clear_at_startup());
}

mod arbitrary_files {
    use proptest::prelude::*;
    use serde_json::{json, Map, Value};
    use si_module::params::DriverParams;

    const KEYS: &[&str] = &[
        "baud",
        "data_bits",
        "stop_bits",
        "parity",
        "interface",
        "receive_line",
        "flow_control",
        "end_criterion",
        "char_delay_ms",
        "end_char_1",
        "end_char_2",
        "frame_length",
        "xon",
        "xoff",
        "wait_for_xon_ms",
        "ack_delay_ms",
        "connection_attempts",
        "block_check",
        "address",
        "response_timeout_ms",
        "char_delay_multiplier",
        "mode",
        "pkw_retries",
        "polling_list",
        "tx_chunk",
    ];

    fn any_value() -> impl Strategy<Value = Value> {
        prop_oneof![
            any::<i64>().prop_map(|n| json!(n)),
            (0u64..70_000).prop_map(|n| json!(n)),
            any::<bool>().prop_map(|b| json!(b)),
            prop::sample::select(vec![
                "none",
                "even",
                "any",
                "rs232",
                "rs422",
                "rs485",
                "xon-xoff",
                "rts-cts",
                "auto-v24",
                "end-chars",
                "fixed-length",
                "inverted",
                "ra0v-rb5v",
                "high",
            ])
            .prop_map(|s| json!(s)),
            Just(json!([{"address": 1, "pkw": 4, "pzd": 2}, {"address": 40}])),
            Just(json!(1.5)),
            Just(json!(null)),
        ]
    }

    proptest! {
        /// Whatever a file says, reading it ends in parameters that pass their own check and
        /// survive a round trip, or in at least one error; it never panics.
        #[test]
        fn any_file_is_read_or_refused(
            driver in prop::sample::select(vec!["ascii", "3964r", "modbus-master", "modbus-slave", "uss-master"]),
            fields in prop::collection::vec((prop::sample::select(KEYS.to_vec()), any_value()), 0..8),
        ) {
            let mut map = Map::new();
            map.insert("driver".into(), json!(driver));
            for (k, v) in fields {
                map.insert(k.into(), v);
            }
            match DriverParams::from_value(&Value::Object(map)) {
                Ok(p) => {
                    prop_assert!(p.check().is_empty());
                    prop_assert_eq!(DriverParams::from_value(&p.to_value()), Ok(p.clone()));
                    prop_assert_eq!(DriverParams::from_toml_str(&p.to_toml_string()), Ok(p));
                }
                Err(e) => prop_assert!(!e.is_empty()),
            }
        }
    }
}

#[test]
fn modbus_auto_v24_carries_its_two_times_to_the_engine_config() {
    let p = DriverParams::from_toml_str(
        "driver = \"modbus-master\"\ninterface = \"rs232\"\nflow_control = \"auto-v24\"\n\
         time_rts_off_ms = 30\ndata_wait_time_ms = 120",
    )
    .unwrap();
    let DriverParams::ModbusMaster(m) = &p else {
        panic!("{p:?}")
    };
    let times = m.config.line.auto_v24.expect("auto V.24 times");
    assert_eq!(
        (
            times.time_rts_off.as_millis(),
            times.data_wait_time.as_millis()
        ),
        (30, 120)
    );
    let p = DriverParams::from_toml_str("driver = \"modbus-master\"").unwrap();
    let DriverParams::ModbusMaster(m) = &p else {
        panic!("{p:?}")
    };
    assert_eq!(m.config.line.auto_v24, None, "no flow control by default");
    let e =
        DriverParams::from_toml_str("driver = \"modbus-slave\"\ntime_rts_off_ms = 30").unwrap_err();
    assert!(e.to_string().contains("time_rts_off_ms"), "{e}");
}

/// A quoted number is a type error naming the key and its line, not a baud rate; an
/// integer beyond 64 bits (which TOML itself refuses) names its line too.
#[test]
fn type_errors_and_oversized_integers_name_their_line() {
    let e = DriverParams::from_toml_str("driver = \"3964r\"\n\nbaud = \"9600\"\n").unwrap_err();
    assert_eq!(e.len(), 1, "{e}");
    assert_eq!(
        e.to_string(),
        "baud = \"9600\" must be a number, one of: 110, 300, 600, 1200, 2400, 4800, 9600, \
         19200, 38400, 57600, 76800, 115200 (line 3)"
    );
    let e = DriverParams::from_toml_str("driver = \"ascii\"\nstop_bits = \"1\"").unwrap_err();
    assert!(
        e.to_string()
            .ends_with("must be a number, one of: 1, 2 (line 2)"),
        "{e}"
    );
    // Named choices still refuse numbers as before.
    let e = DriverParams::from_toml_str("driver = \"ascii\"\nparity = 1").unwrap_err();
    assert!(e.to_string().contains("parity = 1 is not one of"), "{e}");
    let e = DriverParams::from_toml_str(
        "driver = \"ascii\"\nbaud = 9600\nchar_delay_ms = 99999999999999999999\n",
    )
    .unwrap_err();
    let text = e.to_string();
    assert!(text.starts_with("not valid TOML"), "{text}");
    assert!(text.ends_with("(line 3)"), "{text}");
    let e =
        DriverParams::from_toml_str("driver = \"ascii\"\nchar_delay_ms = 18446744073709551616\n")
            .unwrap_err();
    assert!(e.to_string().ends_with("(line 2)"), "{e}");
}
