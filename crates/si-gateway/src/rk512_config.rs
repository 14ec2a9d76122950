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

use super::rk512_spans::{db_span, Span, DB_BYTES};
use crate::port_config::{check_pause, check_queue, line_file};
use crate::r3964_config::link;
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

line_file! {
    /// One `[[line]]` of kind `rk512`, as written (the module docs list the keys).
    pub struct Rk512File {
        /// `active` (default) or `passive`.
        pub role: Option<String>,
        /// 3964(R) priority, `high` or `low`.
        pub priority: Option<String>,
        /// 3964R with block check (default), or plain 3964.
        pub block_check: Option<bool>,
        /// Acknowledgement delay time QVZ (ms).
        pub ack_delay_ms: Option<u32>,
        /// The partner's answer time TRES (ms; active only).
        pub response_timeout_ms: Option<u32>,
        /// The partner's CPU number 1–4 (header byte 10).
        pub cpu: Option<u8>,
        /// Header byte 6 counts `words` (default) or `bytes`.
        pub dw_unit: Option<String>,
        /// S_MODB's conversion DB (`[line.conversion]`).
        pub conversion: Option<ConversionDb>,
        /// FETCH the `refresh` areas this often (ms; 0: on demand).
        pub refresh_ms: Option<u64>,
        /// The refresh image's areas, e.g. `["DB6:0-99", "MB500-531"]`.
        pub refresh: Option<Vec<String>>,
        /// Passive: the gateway's own memory (`[line.memory]`).
        pub memory: Option<MemorySizes>,
        /// Requests waiting for this line at most (default 32).
        pub queue: Option<usize>,
        /// Pause after each job (ms, active only, default 0).
        pub pause_ms: Option<u64>,
    }
}

impl Rk512File {
    /// Check the line's own keys (the shared keys are checked by the caller): the line, its
    /// queue length and its pause.
    pub fn check(&self) -> Result<(Rk512Line, usize, Duration), RangeError> {
        let role = match self.role.as_deref().unwrap_or("active") {
            "active" => Role::Active,
            "passive" => Role::Passive,
            other => return Err(RangeError::new("role", "active or passive", "", other)),
        };
        let mut config = Config {
            link: link(
                self.priority.as_deref(),
                self.block_check,
                self.ack_delay_ms,
                match role {
                    Role::Active => si_3964r::Priority::High,
                    Role::Passive => si_3964r::Priority::Low,
                },
            )?,
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
            let given = [
                ("response_timeout_ms", self.response_timeout_ms.is_some()),
                ("pause_ms", self.pause_ms.is_some()),
            ];
            if let Some((key, _)) = given.iter().find(|(_, g)| *g) {
                return Err(RangeError::new(
                    key,
                    "a key of active rk512 lines (the passive role starts no jobs)",
                    "",
                    "set on a passive line",
                ));
            }
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
        let queue = check_queue(self.queue)?;
        let pause = check_pause(self.pause_ms, 0)?;
        let line = Rk512Line {
            role,
            config,
            coordination,
            conversion: self.conversion.unwrap_or(ConversionDb::EXAMPLE),
            refresh_every: (refresh_ms > 0).then(|| Duration::from_millis(refresh_ms)),
            refresh,
            memory,
        };
        Ok((line, queue, pause))
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
