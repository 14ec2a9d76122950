//! The passive side: a partner's SEND and FETCH jobs served from the SIMATIC memory model
//! ([CP 341] §2.2.3, Fig. 2-18/2-19, Fig. 2-19, §4.8).
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
//!   `[derived]`: 'O' sends to X): `'A'` must name `'D'`, `'O'` must name `'X'`, else 0604.
//!   FETCH reads every type.
//! - **Refusals** are the CP 341's class 06H rows ([`ServeError`], [CP 341 Diag]),
//!   checked in this order: the header's structure (0610, 0611, 0601, 0602, 0604), CPU in STOP
//!   or command not served (060D), command/type pair (0604), CPU number (060A), coordination
//!   flag (0609), length against the job limit (0608), data in the telegram (060B, 060C), the
//!   area (0606 DB missing, 0607 start beyond the area, 0608 end beyond it), flag set (060F).
//!   0611, "actual frame length and header length disagree" ([CP 341 Diag] §8.1), is
//!   raised only for a telegram of more than 128 data bytes `[derived]`: the other
//!   disagreements are 060B and 060C, which name them exactly ([`ServeError::FrameLength`]).
//!   The whole job's range is checked on the first telegram, so a long job is refused before
//!   any byte is written. The reaction carries the error number of
//!   [`ServeError::error_number`] (`[inferred]`, see [`crate::refusal`]).
//! - **CPU number ([CP 341] §2.2.3, Table 2-1, byte 10 high nibble; `[derived]`).** 1 … 4 name a
//!   CPU, 0 "a flag but no CPU number", FH "neither"; 5H … EH are refused with 060A. Every allowed
//!   number is served: a host is one CPU, so it does not tell CPUs of a multi-CPU S5 rack apart.
//! - **Coordination flag ([CP 341] §2.2.3).** A flag is named when byte 9 ≠ FFH; its bit (byte 10
//!   low nibble) must then be 0 … 7 and its byte inside the flag area, else 0609. A job naming a
//!   flag that is set is refused with 060F (32H); the flag is set once the job's *last*
//!   telegram is served, and the CPU program resets it when it has dealt with the data.
//!   **FETCH too:** [CP 341] §2.2.3 explains only the encoding and `[M]` names only "target DB
//!   locked"; the reading chosen is the one public RK 512 partner manual that states it (VIPA CPU
//!   21x manual HB103E, "Coordination flags": "The coordination flag is set in the partner PLC …
//!   when a message is being received. This occurs for input as well as for output commands.
//!   When the coordination flag has been set and a message with this flag is received, then
//!   the respective data is not accepted (or transferred) and a reject message is sent (error
//!   code 32h)"). So a FETCH naming a set flag gets 060F/32H, and a served FETCH sets it: the
//!   CPU program resets it when fresh data are ready to be fetched.
//! - **A first telegram while a continuation is due** (Fig. 2-19 "or a first command frame
//!   received"): the running job is aborted (060E, reported by the station), and the new
//!   telegram is served.
//! - **A continuation without a job** is answered with 060E (36H).

use crate::config::DwUnit;
use crate::frame::{
    Address, Command, CommandHeader, ContinuationHeader, Coordination, DataType, DecodeError,
    ReactionHeader, Telegram, MAX_DATA_PER_TELEGRAM,
};
use crate::refusal::ServeError;
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
    /// Accept SEND jobs (else 060D with error number 0AH).
    pub accept_send: bool,
    /// Accept FETCH jobs (else 060D with error number 0AH).
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
    /// Refused: the reaction carries this refusal's error number; the job (if any) is over.
    Refused(ServeError),
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

    /// A station that does not serve: every command is refused with 060D (error number 0AH).
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

    /// Put the CPU into RUN (`true`) or STOP; in STOP every command is refused with 060D (2AH).
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
            // Byte 3 = 00H is a reaction's; the station never hands one here.
            Ok(Telegram::Reaction(..)) => Err(ServeError::Command),
            Err(e) => Err(match e {
                DecodeError::TooShort { .. } => ServeError::TooShort,
                DecodeError::TooMuchData { .. } => ServeError::FrameLength,
                DecodeError::Unexpected { offset: 2, .. } => ServeError::Command,
                DecodeError::Unexpected { offset: 3, .. } => ServeError::DataType,
                DecodeError::Unexpected { .. } => ServeError::HeaderId,
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
                        error: error.error_number().code(),
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
    ) -> Result<Served, ServeError> {
        if !self.running {
            return Err(ServeError::Stopped);
        }
        let open = if h.command.is_send() {
            self.accept_send
        } else {
            self.accept_fetch
        };
        if !open {
            return Err(ServeError::NotServed);
        }
        let data_type = h.address.data_type();
        let type_ok = match h.command {
            Command::Send => data_type == DataType::Db,
            Command::SendDx => data_type == DataType::Dx,
            Command::Fetch => true,
        };
        if !type_ok {
            return Err(ServeError::DataType);
        }
        if !matches!(h.coordination.cpu, 0..=4 | 0xF) {
            return Err(ServeError::CpuNumber);
        }
        let flag = self.flag(h.coordination)?;
        let total = h.data_len();
        if total == 0 || total > max_job_len {
            return Err(ServeError::Length);
        }
        if h.command.is_send() {
            if data.len() != total.min(MAX_DATA_PER_TELEGRAM) {
                return Err(ServeError::DataAmount);
            }
        } else if !data.is_empty() {
            return Err(ServeError::FetchWithData);
        }
        let place = place(h.address, dw_unit);
        self.check_range(place, total)?;
        if let Some((byte, bit)) = flag {
            if self.memory.bit(Area::Flags, byte.into(), bit) == Ok(true) {
                return Err(ServeError::Locked);
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

    /// The flag bytes 9/10 name ([CP 341] §2.2.3, Table 2-1): none for byte FFH; else bit 0 … 7 of
    /// a flag byte that exists (0609 otherwise).
    fn flag(&self, c: Coordination) -> Result<Option<(u8, u8)>, ServeError> {
        if c.flag_byte == 0xFF {
            return Ok(None);
        }
        if c.flag_bit > 7 || self.memory.bit(Area::Flags, c.flag_byte.into(), 0).is_err() {
            return Err(ServeError::CoordinationFlag);
        }
        Ok(Some((c.flag_byte, c.flag_bit)))
    }

    fn continuation(
        &mut self,
        h: ContinuationHeader,
        data: &[u8],
        reaction: &mut Vec<u8>,
    ) -> Result<Served, ServeError> {
        let Some(mut job) = self.job.take() else {
            return Err(ServeError::Sequence);
        };
        if !self.running {
            return Err(ServeError::Stopped);
        }
        if h.command != job.header.command {
            return Err(ServeError::ContinuationCommand);
        }
        if h.data_type != job.header.address.data_type() {
            return Err(ServeError::ContinuationDataType);
        }
        if h.command.is_send() {
            if data.len() != (job.total - job.done).min(MAX_DATA_PER_TELEGRAM) {
                return Err(ServeError::DataAmount);
            }
        } else if !data.is_empty() {
            return Err(ServeError::FetchWithData);
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
    ) -> Result<(), ServeError> {
        // The range was checked on the first telegram (0606–0608); a failure here would mean
        // the memory shrank under a running job.
        let n = (job.total - job.done).min(MAX_DATA_PER_TELEGRAM);
        let p = job.place;
        let memory = if p.dx { &mut self.dx } else { &mut self.memory };
        let offset = u32::try_from(job.done).map_err(|_| ServeError::Length)?;
        if job.header.command.is_send() {
            memory
                .write(p.area, p.start + offset, data)
                .map_err(|_| ServeError::Length)?;
        } else if matches!(p.area, Area::Timers | Area::Counters) {
            for i in 0..n as u32 / 2 {
                let word = memory
                    .element(p.area, p.start + offset / 2 + i)
                    .map_err(|_| ServeError::Length)?;
                reaction.extend_from_slice(&word.to_be_bytes());
            }
        } else {
            let at = reaction.len();
            reaction.resize(at + n, 0);
            memory
                .read(p.area, p.start + offset, &mut reaction[at..])
                .map_err(|_| ServeError::Length)?;
        }
        job.done += n;
        Ok(())
    }

    fn after(&mut self, job: Job) -> Served {
        if job.done < job.total {
            self.job = Some(job);
            return Served::Partial;
        }
        if let Some((byte, bit)) = job.header.coordination.flag_address() {
            // Checked on the first telegram; the flag is set once the whole job is served
            // ([CP 341] §2.2.3, SEND and FETCH alike: see the module docs).
            let _ = self.memory.set_bit(Area::Flags, byte.into(), bit, true);
        }
        Served::Complete {
            command: job.header.command,
            address: job.header.address,
            len: job.total,
        }
    }

    /// The whole job's area ([CP 341] §2.2.3, Table 2-1 bytes 5–8): 0606 for a DB/DX that does not
    /// exist, 0607 for a start beyond the area, 0608 for an end beyond it.
    fn check_range(&self, p: Place, total: usize) -> Result<(), ServeError> {
        let memory = if p.dx { &self.dx } else { &self.memory };
        match p.area {
            Area::Timers | Area::Counters => {
                if memory.check_elements(p.area, p.start, 1).is_err() {
                    return Err(ServeError::StartAddress);
                }
                let count = u32::try_from(total / 2).map_err(|_| ServeError::Length)?;
                memory
                    .check_elements(p.area, p.start, count)
                    .map_err(|_| ServeError::Length)
            }
            area => {
                let len = memory.bytes(area).map_err(|_| ServeError::DbNumber)?.len();
                let start = p.start as usize;
                if start >= len {
                    Err(ServeError::StartAddress)
                } else if start + total > len {
                    Err(ServeError::Length)
                } else {
                    Ok(())
                }
            }
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
