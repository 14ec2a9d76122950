//! The keys of a `kind = "rk512"` line: the RK 512 / 3964(R) link, the S_MODB conversion DB
//! that maps registers and bits to the partner's S7 memory, the refresh image, and the
//! passive role's memory; checked into [`Rk512Line`].
//!
//! | key | range | default | source |
//! |---|---|---|---|
//! | `role` | `active`, `passive` | `active` | si's own |
//! | `priority` | `high`, `low` | `high` active, `low` passive (the partners must differ) | [ET200S SI] §2.7, Fig. 2-16 |
//! | `block_check` | bool | `true` (3964R; `false`: plain 3964, QVZ default 550 ms) | [ET200S SI] §2.7, Table 2-11 |
//! | `ack_delay_ms` | 10 … 655 350 | 2000 (550 without block check) | Table 2-11 |
//! | `response_timeout_ms` | 10 … 655 350 | 10 000: TRES | [CP 341] `[derived]` |
//! | `cpu` | 1 … 4 | none (byte 10 high nibble FH) | [CP 341] §2.2.3, Table 2-1, `[derived]` |
//! | `dw_unit` | `words`, `bytes` | `words` | [Public RK 512] |
//! | `[line.conversion]` | `ConversionDb` fields | Table 3-20's example | [Modbus/USS] §3.5.3, Table 3-19 |
//! | `refresh_ms` | 0 … 3 600 000 | 0 (FETCH on demand) | si's own |
//! | `refresh` | up to 32 areas | none | si's own |
//! | `[line.memory]` | `MemorySizes` (passive only) | DB1–DB6 of 1024 bytes, MB0–1255 | `SimaticStore::example` |
//! | `queue`, `pause_ms` | as for Modbus RTU lines | 32, 0 | |
//!
//! `refresh` areas are written `DB6:0-99` (data words 0–99 of DB6, DB 1–255, DW 0–511, the
//! first DW ≤ 255), `MB500-531`, `IB0-3`, `QB0-7` (bytes 0–65 535), `T40-47`, `C40-47`
//! (cells 0–65 535); one number for one word, byte or cell. Each is at most the job limit
//! (1024 bytes, `si_rk512::Config::max_job_len`).

use super::config::{refuse_keys, Device, Kind, Line, LineFile, DEFAULT_QUEUE, MAX_QUEUE};
use super::rk512_spans::{db_span, Span, DB_BYTES};
use si_core::memory::{Area, MemorySizes};
use si_core::RangeError;
use si_modbus::simatic::ConversionDb;
use si_rk512::config::DwUnit;
use si_rk512::frame::{Address, Coordination};
use si_rk512::Config;
use std::time::Duration;

/// Most refresh areas of one line.
pub const MAX_REFRESH_AREAS: usize = 32;
/// Longest refresh period (ms): one hour.
pub const MAX_REFRESH_MS: u64 = 3_600_000;

/// Which side of RK 512 the gateway's station is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The gateway SENDs and FETCHes: the partner's memory is served.
    Active,
    /// The partner SENDs and FETCHes: the gateway's own memory is served.
    Passive,
}

/// A checked RK 512 line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rk512Line {
    /// Active or passive.
    pub role: Role,
    /// The RK 512 and 3964(R) parameters.
    pub config: Config,
    /// Header bytes 9 and 10 of our jobs: no flag, the CPU number if given.
    pub coordination: Coordination,
    /// Registers and bits to S7 memory.
    pub conversion: ConversionDb,
    /// FETCH `refresh` every this long; `None`: FETCH on demand.
    pub refresh_every: Option<Duration>,
    /// The areas of the refresh image.
    pub refresh: Vec<Span>,
    /// The passive role's memory.
    pub memory: MemorySizes,
}

/// The passive role's memory without `[line.memory]`: what `si modbus serve` simulates.
fn default_memory() -> MemorySizes {
    let mut sizes = MemorySizes {
        flags: 1256,
        ..MemorySizes::default()
    };
    for db in 1..=6 {
        sizes.dbs.insert(db, DB_BYTES);
    }
    sizes
}

impl LineFile {
    /// The RK 512 keys given on a line of another kind: refused by name. A `3964r` line has
    /// the link's keys (priority, block check, QVZ), not RK 512's.
    pub(super) fn refuse_rk512_keys(&self, kind: &str) -> Result<(), RangeError> {
        let value = format!("set on a {kind} line");
        refuse_keys(
            &[
                ("role", self.role.is_some()),
                ("cpu", self.cpu.is_some()),
                ("dw_unit", self.dw_unit.is_some()),
                ("conversion", self.conversion.is_some()),
                ("refresh_ms", self.refresh_ms.is_some()),
                ("refresh", self.refresh.is_some()),
                ("memory", self.memory.is_some()),
            ],
            "a key of rk512 lines",
            value.clone(),
        )?;
        if kind == "3964r" {
            return Ok(());
        }
        refuse_keys(
            &[
                ("priority", self.priority.is_some()),
                ("block_check", self.block_check.is_some()),
                ("ack_delay_ms", self.ack_delay_ms.is_some()),
            ],
            "a key of rk512 and 3964r lines",
            value,
        )
    }

    /// The keys neither `rk512` nor `3964r` lines have, each with whether it is given:
    /// broadcasts, Modbus retries, USS drives.
    pub(super) fn not_on_3964r_links(&self) -> Vec<(&'static str, bool)> {
        vec![
            ("broadcast", self.broadcast),
            ("retries", self.retries.is_some()),
            ("drives", self.drives.is_some()),
            ("pzd_words", self.pzd_words.is_some()),
            ("pkw_words", self.pkw_words.is_some()),
        ]
    }

    /// The 3964(R) link of an `rk512` or `3964r` line: `priority` (default `default`),
    /// `block_check`, `ack_delay_ms` (checked with the rest of the configuration).
    pub(super) fn link(&self, default: si_3964r::Priority) -> Result<si_3964r::Config, RangeError> {
        let mut link = si_3964r::Config::default();
        if self.block_check == Some(false) {
            link = si_3964r::Config::without_block_check();
        }
        link.priority = match self.priority.as_deref() {
            None => default,
            Some("low") => si_3964r::Priority::Low,
            Some("high") => si_3964r::Priority::High,
            Some(other) => return Err(RangeError::new("priority", "high or low", "", other)),
        };
        if let Some(q) = self.ack_delay_ms {
            link.ack_delay = si_core::Duration::from_millis(q.into());
        }
        Ok(link)
    }

    /// Check an `rk512` line whose device and unit ids are already read.
    pub(super) fn check_rk512(
        &self,
        name: String,
        device: Device,
        units: Vec<u8>,
    ) -> Result<Line, RangeError> {
        refuse_keys(
            &self.not_on_3964r_links(),
            "not a key of rk512 lines",
            "given".to_string(),
        )?;
        let role = match self.role.as_deref().unwrap_or("active") {
            "active" => Role::Active,
            "passive" => Role::Passive,
            other => return Err(RangeError::new("role", "active or passive", "", other)),
        };
        let mut config = Config {
            link: self.link(match role {
                Role::Active => si_3964r::Priority::High,
                Role::Passive => si_3964r::Priority::Low,
            })?,
            ..Config::default()
        };
        if let Some(t) = self.response_timeout_ms {
            config.response_timeout = si_core::Duration::from_millis(t.into());
        }
        config.dw_unit = match self.dw_unit.as_deref() {
            None | Some("words") => DwUnit::Words,
            Some("bytes") => DwUnit::Bytes,
            Some(other) => return Err(RangeError::new("dw_unit", "words or bytes", "", other)),
        };
        config.validate()?;
        let coordination = match self.cpu {
            Some(cpu) => {
                RangeError::check("cpu", (1, 4), "", cpu)?;
                Coordination::cpu_only(cpu)
            }
            None => Coordination::NONE,
        };
        let refresh_ms = self.refresh_ms.unwrap_or(0);
        RangeError::check("refresh_ms", (0, MAX_REFRESH_MS), " ms", refresh_ms)?;
        let areas = self.refresh.as_deref().unwrap_or_default();
        if areas.len() > MAX_REFRESH_AREAS {
            let range = format!("at most {MAX_REFRESH_AREAS} areas");
            return Err(RangeError::new("refresh", range, "", areas.len()));
        }
        let refresh = areas
            .iter()
            .map(|a| parse_area(a, config.dw_unit, config.max_job_len as usize))
            .collect::<Result<Vec<_>, _>>()?;
        if refresh_ms > 0 && refresh.is_empty() {
            return Err(RangeError::new(
                "refresh",
                "at least one area when refresh_ms > 0",
                "",
                "none",
            ));
        }
        if role == Role::Passive && (refresh_ms > 0 || !refresh.is_empty()) {
            return Err(RangeError::new(
                "refresh",
                "none on a passive line (its memory is the gateway's own)",
                "",
                "given",
            ));
        }
        if role == Role::Passive {
            // Both belong to jobs the gateway starts; a passive line starts none.
            refuse_keys(
                &[
                    ("response_timeout_ms", self.response_timeout_ms.is_some()),
                    ("pause_ms", self.pause_ms.is_some()),
                ],
                "a key of active rk512 lines (the passive role starts no jobs)",
                "set on a passive line".to_owned(),
            )?;
        }
        let memory = match (&self.memory, role) {
            (Some(_), Role::Active) => {
                return Err(RangeError::new(
                    "memory",
                    "a key of passive rk512 lines",
                    "",
                    "set on an active line",
                ))
            }
            (Some(m), Role::Passive) => m.clone(),
            (None, _) => default_memory(),
        };
        memory.check()?;
        let queue = self.queue.unwrap_or(DEFAULT_QUEUE);
        RangeError::check("queue", (1, MAX_QUEUE), "", queue)?;
        let pause_ms = self.pause_ms.unwrap_or(0);
        RangeError::check("pause_ms", (0, 10_000), " ms", pause_ms)?;
        self.check_rs485()?;
        let kind = Kind::Rk512(Box::new(Rk512Line {
            role,
            config,
            coordination,
            conversion: self.conversion.unwrap_or(ConversionDb::EXAMPLE),
            refresh_every: (refresh_ms > 0).then(|| Duration::from_millis(refresh_ms)),
            refresh,
            memory,
        }));
        Ok(Line {
            response_timeout_ms: u32::try_from(config.response_timeout.as_millis())
                .unwrap_or(u32::MAX),
            queue,
            pause: Duration::from_millis(pause_ms),
            ..self.port_line(name, device, units, kind)
        })
    }
}

/// One `refresh` area (module docs), e.g. `DB6:0-99` or `MB500-531`.
fn parse_area(text: &str, dw_unit: DwUnit, max_len: usize) -> Result<Span, RangeError> {
    let bad = || {
        RangeError::new(
            "refresh",
            "DBn:a-b (data words), MBa-b, IBa-b, QBa-b (bytes), Ta-b, Ca-b (cells), \
             within the job limit",
            "",
            format!("{text:?}"),
        )
    };
    let t = text.trim();
    let range = |r: &str, max: u32| -> Result<(u32, u32), RangeError> {
        let (a, b) = r.split_once('-').unwrap_or((r, r));
        let a: u32 = a.trim().parse().map_err(|_| bad())?;
        let b: u32 = b.trim().parse().map_err(|_| bad())?;
        if a > b || b > max {
            return Err(bad());
        }
        Ok((a, b))
    };
    let span = if let Some(rest) = t.strip_prefix("DB") {
        let (db, words) = rest.split_once(':').ok_or_else(bad)?;
        let db: u16 = db.trim().parse().map_err(|_| bad())?;
        if !(1..=255).contains(&db) {
            return Err(bad());
        }
        let (a, b) = range(words, DB_BYTES / 2 - 1)?;
        db_span(db, 2 * a, 2 * (b - a + 1) as usize, dw_unit).map_err(|_| bad())?
    } else {
        let (area, unit, rest) = if let Some(r) = t.strip_prefix("MB") {
            (Area::Flags, 1, r)
        } else if let Some(r) = t.strip_prefix("IB") {
            (Area::Inputs, 1, r)
        } else if let Some(r) = t.strip_prefix("QB") {
            (Area::Outputs, 1, r)
        } else if let Some(r) = t.strip_prefix('T') {
            (Area::Timers, 2, r)
        } else if let Some(r) = t.strip_prefix('C') {
            (Area::Counters, 2, r)
        } else {
            return Err(bad());
        };
        let (a, b) = range(rest, u32::from(u16::MAX))?;
        let at = a as u16;
        let address = match area {
            Area::Flags => Address::Flags(at),
            Area::Inputs => Address::Inputs(at),
            Area::Outputs => Address::Outputs(at),
            Area::Timers => Address::Timers(at),
            _ => Address::Counters(at),
        };
        Span {
            address,
            area,
            start: a,
            len: unit * (b - a + 1) as usize,
        }
    };
    if span.len > max_len {
        return Err(bad());
    }
    Ok(span)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::File;

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
            ("retries = 2\n", "retries = given"),
            ("broadcast = true\n", "broadcast = given"),
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
        let e = File::from_toml("[[line]]\ndevice = \"x\"\nunits = \"1\"\ncpu = 1\n")
            .unwrap()
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("cpu = set on a modbus-rtu line"), "{e}");
    }
}
