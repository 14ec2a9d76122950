//! Each line kind's own keys, read from a whole gateway file: defaults, ranges, and keys of
//! other kinds refused.

/// A key of another kind is unknown to a line's kind: the error names the file, the line the
/// key is written on, and the key.
#[test]
fn a_key_of_another_kind_is_refused_naming_file_line_and_key() {
    let text = "listen = \"127.0.0.1:0\"\n[[line]]\nkind = \"uss\"\ndevice = \"x\"\n\
                units = \"1\"\ncpu = 2\n[[line]]\ndevice = \"y\"\nunits = \"2\"\n";
    let path = std::path::Path::new("plant/gw.toml");
    let e = si_gateway::config::File::parse(path, text)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("plant/gw.toml:6: "), "{e}");
    assert!(e.contains("unknown field `cpu`"), "{e}");
    // The same key on an rk512 line is its own.
    let rk512 = text.replace("\"uss\"", "\"rk512\"");
    let file = si_gateway::config::File::parse(path, &rk512).unwrap();
    assert_eq!(file.check().unwrap().lines.len(), 2);
}

/// A line without `kind` is a Modbus RTU line, and its misspelt key is placed too.
#[test]
fn a_misspelt_key_of_a_modbus_rtu_line_is_placed() {
    let text = "[[line]]\ndevice = \"x\"\nunits = \"1\"\nbuad = 9600\n";
    let e = si_gateway::config::File::parse(std::path::Path::new("gw.toml"), text)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("gw.toml:4: unknown field `buad`"), "{e}");
}

mod uss {
    use si_gateway::config::{File, Kind};
    use si_gateway::uss_config::UssLine;

    fn check(keys: &str) -> Result<UssLine, String> {
        let text = format!("[[line]]\nname = \"d\"\nkind = \"uss\"\ndevice = \"x\"\n{keys}");
        let g = File::from_toml(&text)?.check().map_err(|e| e.to_string())?;
        match g.lines[0].kind.clone() {
            Kind::Uss(u) => Ok(u),
            _ => Err("not a uss line".into()),
        }
    }

    #[test]
    fn drives_are_unit_ids_mapped_to_bus_addresses() {
        let u = check("units = \"5,7\"\n").unwrap();
        assert_eq!(u.drives, [(5, 5), (7, 7)]);
        assert_eq!(u.pzd_words, 2);
        assert_eq!(u.master.response_timeout.as_millis(), 20);
        let u = check("units = \"10-11\"\ndrives = \"0, 31\"\npzd_words = 4\n").unwrap();
        assert_eq!(u.drives, [(10, 0), (11, 31)]);
    }

    #[test]
    fn local_echo_is_dropped_once_by_the_port_not_again_by_the_master() {
        let text = "[[line]]\nkind = \"uss\"\ndevice = \"x\"\nunits = \"1\"\nlocal_echo = true\n";
        let g = File::from_toml(text).unwrap().check().unwrap();
        assert!(
            g.lines[0].port.as_ref().unwrap().local_echo,
            "the port filters the echo"
        );
        let Kind::Uss(u) = &g.lines[0].kind else {
            panic!("not a uss line")
        };
        assert!(!u.master.local_echo, "and the master does not again");
    }

    #[test]
    fn errors_name_the_key_and_the_value() {
        let e = check("units = \"32\"\n").unwrap_err();
        assert!(
            e.contains("line 1 (d): units = 32 (USS bus address) is out of range: 0 … 31"),
            "{e}"
        );
        let e = check("units = \"1\"\ndrives = \"40\"\n").unwrap_err();
        assert!(e.contains("drives = 40"), "{e}");
        let e = check("units = \"1,2\"\ndrives = \"4\"\n").unwrap_err();
        assert!(e.contains("drives = \"4\""), "{e}");
        let e = check("units = \"1\"\npzd_words = 17\n").unwrap_err();
        assert!(e.contains("pzd_words = 17 is out of range: 0 … 16"), "{e}");
        let e = check("units = \"1\"\npkw_words = 2\n").unwrap_err();
        assert!(e.contains("pkw_words = 2"), "{e}");
        let e = check("units = \"1\"\nbaud = 1234\n").unwrap_err();
        assert!(e.contains("baud = 1234 bit/s"), "{e}");
        let e = check("units = \"1\"\nbroadcast = true\n").unwrap_err();
        assert!(e.contains("unknown field `broadcast`"), "{e}");
        let e = check("units = \"1\"\nresponse_timeout_ms = 20000\n").unwrap_err();
        assert!(e.contains("response_timeout_ms = 20000 ms"), "{e}");
        let e = File::from_toml("[[line]]\ndevice = \"x\"\nunits = \"1\"\npzd_words = 2\n")
            .unwrap_err();
        assert!(
            e.contains("unknown field `pzd_words`"),
            "a uss key on a modbus-rtu line: {e}"
        );
    }
}

mod rk512 {
    use si_gateway::config::{File, Kind};
    use si_gateway::rk512_config::{Rk512Line, Role};
    use si_modbus::simatic::ConversionDb;
    use si_rk512::frame::{Address, Coordination};
    use std::time::Duration;

    fn check(keys: &str) -> Result<Rk512Line, String> {
        let text = format!(
            "[[line]]\nname = \"p\"\nkind = \"rk512\"\ndevice = \"x\"\nunits = \"1\"\n{keys}"
        );
        let g = File::from_toml(&text)?.check().map_err(|e| e.to_string())?;
        match g.lines[0].kind.clone() {
            Kind::Rk512(r) => Ok(*r),
            other => Err(format!("not an rk512 line: {other:?}")),
        }
    }

    #[test]
    fn defaults_are_an_on_demand_active_station_with_the_example_conversion() {
        let r = check("").unwrap();
        assert_eq!(r.role, Role::Active);
        assert_eq!(r.config.link.priority, si_3964r::Priority::High);
        assert!(r.config.link.block_check);
        assert_eq!(r.config.response_timeout.as_millis(), 10_000);
        assert_eq!(r.conversion, ConversionDb::EXAMPLE);
        assert_eq!((r.refresh_every, r.refresh.len()), (None, 0));
        assert_eq!(r.coordination, Coordination::NONE);
    }

    #[test]
    fn keys_are_read_into_the_station_and_the_image() {
        let r = check(
            "priority = \"low\"\nblock_check = false\nack_delay_ms = 100\nresponse_timeout_ms = 500\n\
             cpu = 2\nrefresh_ms = 250\nrefresh = [\"DB6:0-99\", \"MB500-531\", \"T40-41\"]\n\
             [line.conversion]\ndb_fc03_06_16 = 10\n",
        )
        .unwrap();
        assert_eq!(r.config.link.priority, si_3964r::Priority::Low);
        assert!(!r.config.link.block_check);
        assert_eq!(r.config.link.ack_delay.as_millis(), 100);
        assert_eq!(r.config.response_timeout.as_millis(), 500);
        assert_eq!(r.coordination, Coordination::cpu_only(2));
        assert_eq!(r.conversion.db_fc03_06_16, 10);
        assert_eq!(r.conversion.db_max, 0, "a given table starts from zeros");
        assert_eq!(r.refresh_every, Some(Duration::from_millis(250)));
        let spans: Vec<_> = r.refresh.iter().map(|s| (s.address, s.len)).collect();
        assert_eq!(
            spans,
            [
                (Address::Db { db: 6, dw: 0 }, 200),
                (Address::Flags(500), 32),
                (Address::Timers(40), 4)
            ]
        );
        let p = check("role = \"passive\"\n[line.memory]\nflags = 16\n[line.memory.dbs]\n9 = 64\n")
            .unwrap();
        assert_eq!(p.role, Role::Passive);
        assert_eq!(p.config.link.priority, si_3964r::Priority::Low);
        assert_eq!((p.memory.flags, p.memory.dbs.get(&9)), (16, Some(&64)));
    }

    #[test]
    fn errors_name_the_key_and_the_value() {
        for (keys, want) in [
            (
                "role = \"both\"\n",
                "role = both is out of range: active or passive",
            ),
            ("priority = \"mid\"\n", "priority = mid"),
            ("ack_delay_ms = 5\n", "(QVZ) = 5 ms"),
            ("response_timeout_ms = 1\n", "(TRES) = 1 ms"),
            ("cpu = 5\n", "cpu = 5 is out of range: 1 … 4"),
            ("dw_unit = \"bits\"\n", "dw_unit = bits"),
            ("refresh_ms = 100\n", "refresh = none"),
            (
                "refresh_ms = 4000000\nrefresh = [\"MB0\"]\n",
                "refresh_ms = 4000000 ms",
            ),
            ("refresh = [\"DB6:300-301\"]\n", "refresh = \"DB6:300-301\""),
            ("refresh = [\"DB0:0-1\"]\n", "refresh = \"DB0:0-1\""),
            ("refresh = [\"DB6:0-512\"]\n", "refresh = \"DB6:0-512\""),
            ("refresh = [\"MB0-2000\"]\n", "refresh = \"MB0-2000\""),
            ("refresh = [\"XB0\"]\n", "refresh = \"XB0\""),
            ("refresh = [\"MB9-1\"]\n", "refresh = \"MB9-1\""),
            ("retries = 2\n", "unknown field `retries`"),
            ("broadcast = true\n", "unknown field `broadcast`"),
            (
                "[line.memory]\nflags = 1\n",
                "memory = set on an active line",
            ),
            (
                "role = \"passive\"\nrefresh = [\"MB0\"]\n",
                "refresh = given is out of range: none on a passive line",
            ),
            (
                "role = \"passive\"\n[line.memory]\nflags = 70000\n",
                "memory.flags = 70000 bytes",
            ),
            (
                "role = \"passive\"\npause_ms = 10\n",
                "pause_ms = set on a passive line",
            ),
            ("[line.conversion]\nbogus = 1\n", "bogus"),
        ] {
            let e = check(keys).unwrap_err();
            assert!(e.contains(want), "{keys}: {e}");
        }
        let many: Vec<String> = (0..33).map(|i| format!("\"MB{i}\"")).collect();
        let e = check(&format!("refresh = [{}]\n", many.join(","))).unwrap_err();
        assert!(
            e.contains("refresh = 33 is out of range: at most 32"),
            "{e}"
        );
        let e = File::from_toml("[[line]]\ndevice = \"x\"\nunits = \"1\"\ncpu = 1\n").unwrap_err();
        assert!(
            e.contains("unknown field `cpu`"),
            "an rk512 key on a modbus-rtu line: {e}"
        );
    }
}

mod r3964 {
    use si_gateway::config::{File, Kind};

    fn check(keys: &str) -> Result<si_3964r::Config, String> {
        let text = format!(
            "[[line]]\nname = \"b\"\nkind = \"3964r\"\ndevice = \"x\"\nunits = \"1\"\n{keys}"
        );
        let g = File::from_toml(&text)?.check().map_err(|e| e.to_string())?;
        match g.lines[0].kind.clone() {
            Kind::R3964(c) => Ok(c),
            other => Err(format!("not a 3964r line: {other:?}")),
        }
    }

    #[test]
    fn the_link_keys_are_read_and_others_refused() {
        let c = check("").unwrap();
        assert_eq!(c.priority, si_3964r::Priority::High);
        assert!(c.block_check);
        let c = check("priority = \"low\"\nblock_check = false\nack_delay_ms = 300\n").unwrap();
        assert_eq!(
            (c.priority, c.block_check, c.ack_delay.as_millis()),
            (si_3964r::Priority::Low, false, 300)
        );
        for (keys, want) in [
            ("ack_delay_ms = 1\n", "(QVZ) = 1 ms"),
            ("cpu = 1\n", "unknown field `cpu`"),
            ("queue = 4\n", "unknown field `queue`"),
            (
                "response_timeout_ms = 100\n",
                "unknown field `response_timeout_ms`",
            ),
        ] {
            let e = check(keys).unwrap_err();
            assert!(e.contains(want), "{keys}: {e}");
        }
        let e = File::from_toml("[[line]]\ndevice = \"x\"\nunits = \"1\"\nack_delay_ms = 100\n")
            .unwrap_err();
        assert!(
            e.contains("unknown field `ack_delay_ms`"),
            "a link key on a modbus-rtu line: {e}"
        );
    }
}
