//! The passive side: a partner's SEND and FETCH jobs served from the SIMATIC memory model
//! (cp341-3964r-rk512-ascii.md §4.5, §4.7 Fig. 2-19, §4.8).
//!
//! [`Server`] turns one command telegram into one reaction telegram; the
//! [`Station`](crate::Station) engine carries both over the 3964(R) link and runs TRES while a
//! continuation is due.
//!
//! # Readings
//!
//! - **Memory areas.** D → `Area::Db(n)`, E → inputs, A → outputs, M → flags, T → timers,
//!   Z → counters of [`si_core::memory::Memory`]; X (the S5 extended data blocks, which an S7
//!   memory lacks) → the data blocks of a second `Memory` ([`Server::dx`]).
//! - **SEND only to D and X** (Table 2-1 footnote "when sending, only 'D' is possible" and
//!   'O' sends to X): `'A'` must name `'D'`, `'O'` must name `'X'`, else error 0CH.
//!   FETCH reads every type.
//! - **Checks, in order**: telegram id (0CH), command (16H), CPU in STOP (2AH), data type for
//!   the command (0CH), command not open (0AH), length 0, over the job limit or not matching
//!   the data in the telegram (34H), area missing or too short (14H), coordination flag set
//!   (32H). The whole job's range is checked on the first telegram, so a long job is refused
//!   before any byte is written.
//! - **Coordination flag (§4.8).** For a SEND naming a flag: refused with 32H while the flag
//!   is set; the data are written and the flag is set after the *last* telegram. The partner
//!   program resets it when it has consumed the data. A FETCH is not affected: the sources
//!   describe the flag only as an interlock on new data. The CPU number (byte 10, high nibble)
//!   is not evaluated: a host is one CPU.
//! - **A first telegram while a continuation is due** (Fig. 2-19 "or a first command frame
//!   received"): the running job is aborted (reported), and the new telegram is served.
//! - **A continuation without a job** is answered with 36H (synchronisation error).

use crate::config::DwUnit;
use crate::frame::{
    Address, Command, CommandHeader, ContinuationHeader, DataType, DecodeError, ReactionHeader,
    Telegram, MAX_DATA_PER_TELEGRAM,
};
use crate::status::ErrorNumber;
use serde::{Deserialize, Serialize};
use si_core::memory::{Area, Memory, MemorySizes};
use std::collections::BTreeMap;

/// What the passive side serves: memory sizes and which commands it accepts.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ServerConfig {
    /// Sizes of I, Q, M, T, C and the data blocks.
    pub memory: MemorySizes,
    /// Extended data blocks DX: number → length in bytes.
    pub dx: BTreeMap<u16, u32>,
    /// Accept SEND jobs (else error 0AH).
    pub accept_send: bool,
    /// Accept FETCH jobs (else error 0AH).
    pub accept_fetch: bool,
}

impl Default for ServerConfig {
    /// The default memory sizes, no DX, SEND and FETCH accepted.
    fn default() -> Self {
        ServerConfig {
            memory: MemorySizes::default(),
            dx: BTreeMap::new(),
            accept_send: true,
            accept_fetch: true,
        }
    }
}

/// Where a job's data live.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Place {
    area: Area,
    dx: bool,
    /// Byte offset (byte areas) or element number (timers, counters).
    start: u32,
}

#[derive(Debug, Clone, Copy)]
struct Job {
    header: CommandHeader,
    place: Place,
    total: usize,
    done: usize,
}

/// What serving one telegram did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Served {
    /// A part of a job was served; a continuation telegram is due within TRES.
    Partial,
    /// The job is complete.
    Complete {
        /// SEND, SEND to DX or FETCH.
        command: Command,
        /// Where the data went or came from.
        address: Address,
        /// Bytes of the whole job.
        len: usize,
    },
    /// Answered with this error number; the job (if any) is over.
    Refused(ErrorNumber),
}

/// The passive side's memory and its one running job.
#[derive(Debug, Clone)]
pub struct Server {
    memory: Memory,
    dx: Memory,
    accept_send: bool,
    accept_fetch: bool,
    running: bool,
    job: Option<Job>,
}

impl Server {
    /// A server with zeroed memory of these sizes, CPU in RUN.
    pub fn new(config: &ServerConfig) -> Server {
        let dx_sizes = MemorySizes {
            inputs: 0,
            outputs: 0,
            flags: 0,
            timers: 0,
            counters: 0,
            dbs: config.dx.clone(),
        };
        Server {
            memory: Memory::new(&config.memory),
            dx: Memory::new(&dx_sizes),
            accept_send: config.accept_send,
            accept_fetch: config.accept_fetch,
            running: true,
            job: None,
        }
    }

    /// A station that does not serve: every command is answered with 0AH.
    pub fn refusing() -> Server {
        Server::new(&ServerConfig {
            memory: MemorySizes {
                inputs: 0,
                outputs: 0,
                flags: 0,
                timers: 0,
                counters: 0,
                dbs: BTreeMap::new(),
            },
            accept_send: false,
            accept_fetch: false,
            ..ServerConfig::default()
        })
    }

    /// The memory (DB, I, Q, M, T, C).
    pub fn memory(&self) -> &Memory {
        &self.memory
    }

    /// The memory, to change it as the CPU program would (e.g. reset a coordination flag).
    pub fn memory_mut(&mut self) -> &mut Memory {
        &mut self.memory
    }

    /// The extended data blocks DX, as the data blocks of a second memory.
    pub fn dx(&self) -> &Memory {
        &self.dx
    }

    /// The DX blocks, mutable.
    pub fn dx_mut(&mut self) -> &mut Memory {
        &mut self.dx
    }

    /// Put the CPU into RUN (`true`) or STOP; in STOP every command is answered with 2AH.
    pub fn set_running(&mut self, running: bool) {
        self.running = running;
    }

    /// True while a continuation telegram is due.
    pub fn expects_continuation(&self) -> bool {
        self.job.is_some()
    }

    /// Drop the running job (TRES expired, or a first telegram replaced it).
    pub fn abort(&mut self) -> bool {
        self.job.take().is_some()
    }

    /// Serve one command telegram and write the reaction telegram into `reaction`.
    pub fn serve(
        &mut self,
        telegram: &[u8],
        dw_unit: DwUnit,
        max_job_len: usize,
        reaction: &mut Vec<u8>,
    ) -> Served {
        reaction.clear();
        let continuation = telegram.first() == Some(&crate::frame::CONTINUATION);
        let result = match Telegram::decode(telegram) {
            Ok(Telegram::Command(h, data)) => {
                self.job = None;
                self.first(h, data, dw_unit, max_job_len, reaction)
            }
            Ok(Telegram::Continuation(h, data)) => self.continuation(h, data, reaction),
            Ok(Telegram::Reaction(..)) => Err(ErrorNumber::BadCommand),
            Err(e) => Err(match e {
                DecodeError::TooShort { .. } | DecodeError::TooMuchData { .. } => {
                    ErrorNumber::BadLength
                }
                DecodeError::Unexpected { offset: 2, .. } => ErrorNumber::BadCommand,
                DecodeError::Unexpected { .. } => ErrorNumber::BadHeader,
            }),
        };
        match result {
            Ok(served) => served,
            Err(error) => {
                self.job = None;
                reaction.clear();
                reaction.extend_from_slice(
                    &ReactionHeader {
                        continuation,
                        error: error.code(),
                    }
                    .encode(),
                );
                Served::Refused(error)
            }
        }
    }

    fn first(
        &mut self,
        h: CommandHeader,
        data: &[u8],
        dw_unit: DwUnit,
        max_job_len: usize,
        reaction: &mut Vec<u8>,
    ) -> Result<Served, ErrorNumber> {
        if !self.running {
            return Err(ErrorNumber::NotRunning);
        }
        let data_type = h.address.data_type();
        let type_ok = match h.command {
            Command::Send => data_type == DataType::Db,
            Command::SendDx => data_type == DataType::Dx,
            Command::Fetch => true,
        };
        if !type_ok {
            return Err(ErrorNumber::BadHeader);
        }
        let open = if h.command.is_send() {
            self.accept_send
        } else {
            self.accept_fetch
        };
        if !open {
            return Err(ErrorNumber::AccessDenied);
        }
        let total = h.data_len();
        if total == 0 || total > max_job_len {
            return Err(ErrorNumber::BadLength);
        }
        let expected = if h.command.is_send() {
            total.min(MAX_DATA_PER_TELEGRAM)
        } else {
            0
        };
        if data.len() != expected {
            return Err(ErrorNumber::BadLength);
        }
        let place = place(h.address, dw_unit);
        self.check_range(place, total)?;
        let flag = h.coordination.flag_address();
        if h.command.is_send() {
            if let Some((byte, bit)) = flag {
                match self.memory.bit(Area::Flags, byte.into(), bit) {
                    Ok(true) => return Err(ErrorNumber::Locked),
                    Ok(false) => {}
                    Err(_) => return Err(ErrorNumber::NoSuchArea),
                }
            }
        }
        let mut job = Job {
            header: h,
            place,
            total,
            done: 0,
        };
        reaction.extend_from_slice(
            &ReactionHeader {
                continuation: false,
                error: 0,
            }
            .encode(),
        );
        self.transfer(&mut job, data, reaction)?;
        Ok(self.after(job))
    }

    fn continuation(
        &mut self,
        h: ContinuationHeader,
        data: &[u8],
        reaction: &mut Vec<u8>,
    ) -> Result<Served, ErrorNumber> {
        let Some(mut job) = self.job.take() else {
            return Err(ErrorNumber::Sequence);
        };
        if !self.running {
            return Err(ErrorNumber::NotRunning);
        }
        if h.command != job.header.command {
            return Err(ErrorNumber::BadCommand);
        }
        if h.data_type != job.header.address.data_type() {
            return Err(ErrorNumber::BadHeader);
        }
        let expected = if h.command.is_send() {
            (job.total - job.done).min(MAX_DATA_PER_TELEGRAM)
        } else {
            0
        };
        if data.len() != expected {
            return Err(ErrorNumber::BadLength);
        }
        reaction.extend_from_slice(
            &ReactionHeader {
                continuation: true,
                error: 0,
            }
            .encode(),
        );
        self.transfer(&mut job, data, reaction)?;
        Ok(self.after(job))
    }

    /// Write SEND data, or append FETCH data to the reaction; advance the job.
    fn transfer(
        &mut self,
        job: &mut Job,
        data: &[u8],
        reaction: &mut Vec<u8>,
    ) -> Result<(), ErrorNumber> {
        let n = (job.total - job.done).min(MAX_DATA_PER_TELEGRAM);
        let p = job.place;
        let memory = if p.dx { &mut self.dx } else { &mut self.memory };
        let offset = u32::try_from(job.done).map_err(|_| ErrorNumber::BadLength)?;
        if job.header.command.is_send() {
            memory
                .write(p.area, p.start + offset, data)
                .map_err(|_| ErrorNumber::NoSuchArea)?;
        } else if matches!(p.area, Area::Timers | Area::Counters) {
            for i in 0..n as u32 / 2 {
                let word = memory
                    .element(p.area, p.start + offset / 2 + i)
                    .map_err(|_| ErrorNumber::NoSuchArea)?;
                reaction.extend_from_slice(&word.to_be_bytes());
            }
        } else {
            let at = reaction.len();
            reaction.resize(at + n, 0);
            memory
                .read(p.area, p.start + offset, &mut reaction[at..])
                .map_err(|_| ErrorNumber::NoSuchArea)?;
        }
        job.done += n;
        Ok(())
    }

    fn after(&mut self, job: Job) -> Served {
        if job.done < job.total {
            self.job = Some(job);
            return Served::Partial;
        }
        if job.header.command.is_send() {
            if let Some((byte, bit)) = job.header.coordination.flag_address() {
                // Checked on the first telegram; the flag is set once all data are in (§4.8).
                let _ = self.memory.set_bit(Area::Flags, byte.into(), bit, true);
            }
        }
        Served::Complete {
            command: job.header.command,
            address: job.header.address,
            len: job.total,
        }
    }

    fn check_range(&self, p: Place, total: usize) -> Result<(), ErrorNumber> {
        let memory = if p.dx { &self.dx } else { &self.memory };
        let ok = match p.area {
            Area::Timers | Area::Counters => memory
                .check_elements(p.area, p.start, (total / 2) as u32)
                .is_ok(),
            area => memory
                .bytes(area)
                .is_ok_and(|b| p.start as usize + total <= b.len()),
        };
        if ok {
            Ok(())
        } else {
            Err(ErrorNumber::NoSuchArea)
        }
    }
}

fn place(address: Address, dw_unit: DwUnit) -> Place {
    let (area, dx, start) = match address {
        Address::Db { db, dw } => (Area::Db(db.into()), false, dw_unit.offset(dw)),
        Address::Dx { db, dw } => (Area::Db(db.into()), true, dw_unit.offset(dw)),
        Address::Inputs(a) => (Area::Inputs, false, a.into()),
        Address::Outputs(a) => (Area::Outputs, false, a.into()),
        Address::Flags(a) => (Area::Flags, false, a.into()),
        Address::Timers(a) => (Area::Timers, false, a.into()),
        Address::Counters(a) => (Area::Counters, false, a.into()),
    };
    Place { area, dx, start }
}
