//! The FB equivalents ([Modbus/USS] §3.4.2, §3.4.5–§3.4.16, §3.5.1–§3.5.2, §3.6.4, §3.6.5;
//! [ET200S SI 2005] Tables 3-74 to 3-77, §3.5.5–§3.5.16): master jobs through S_SEND/S_RCV with the
//! manual's job and response layouts, and S_MODB for the slave with its ERROR_NR table.
//!
//! The FBs are plain structs called once per PLC cycle with S7 semantics: REQ is
//! edge-triggered, R resets, EN_R is a level, DONE / NDR / ERROR / STATUS / LEN are valid for
//! exactly one call. They drive the engines directly (a host with its own port). S_SEND and
//! S_RCV are si-core's, over the [`Master`] as a [`JobPort`]; S_MODB is this crate's own, and
//! the application hands the slave's events to [`SModb::on_event`].
//!
//! # Readings chosen ([Modbus/USS] §3.4.2, §3.4.5–§3.4.16, §3.3.3, Table 3-10 `[derived]`)
//!
//! - A failed job (timeout, exception, response error) is reported by **both** blocks: S_SEND
//!   ERROR and S_RCV ERROR with the same STATUS (Figure 3-7 labels both ERROR lines). S_SEND
//!   DONE comes when the job completed, that is after the response (or after the broadcast
//!   turnaround), and S_RCV NDR at the same time with the data.
//! - FC15 source data are sent in S7 memory order (DBB6, DBB7, …), as the Modbus/USS manual
//!   §3.4.15 says; the 2005 manual's example comment suggests the opposite byte order in each
//!   word ([ET200S SI 2005] §3.5.5–§3.5.16), which we do not follow.
//! - FC01/02 responses are stored word by word with the first received byte in the **low**
//!   byte of `data[1]` (S7 offset +1), as [Modbus/USS] §3.4.5–§3.4.16 says literally and its
//!   examples show (W#16#1701 for 01, 17). So reading coils and writing the same DB back with FC15
//!   swaps byte pairs; that asymmetry is the manual's.
//! - FC07 writes only the high byte of `data[1]` (offset +0), LEN = 1.
//! - FC12 always stores 70 bytes; a shorter event log is padded with 00H.
//! - LEN is checked against 1…200 (1E41H) as the FBs' transfer limit; the Modbus limits
//!   (2040 bits, 127 registers) are checked as well, so the practical maxima of [Modbus/USS]
//!   §3.4.5–§3.4.16 apply.
//! - A read job whose result would not fit S_RCV's 200 bytes (FC01/02 over 1600 bits, FC03/04
//!   over 100 registers: [Modbus/USS] §3.4.5–§3.4.16's practical maxima) ends with **050EH**
//!   "illegal frame length: more than 200 bytes" ([Modbus/USS] §3.6), the manual's code for a frame
//!   beyond the 200-byte limit between module and CPU. The manual does not say when the module
//!   finds out ([Modbus/USS] §3.4.5–§3.4.16 `[derived]`); we check before sending, like the other
//!   job checks of [Modbus/USS] §3.4.5–§3.4.16, so no request goes on the line and no slave is read
//!   for a result that could not be delivered. The range checks of [Modbus/USS] §3.4.5–§3.4.16 come
//!   first: 2041 bits is still 0E44H, 128 registers 0E45H. S_RCV LEN is never above 200. (The 2005
//!   manual's chapter 3 gives LEN 1…256 and 050EH above 256 bytes instead, [ET200S SI 2005] Tables
//!   3-65 to 3-72, `[derived]`; like [`MAX_LEN`] we follow the Modbus/USS module's own manual,
//!   [Modbus/USS] §3.4.2 and §3.6.)

use crate::frame::{fc, Bits, Registers, Request, Response};
use crate::master::{Completion, Master, RequestError};
use crate::simatic::{ConversionDb, SimaticStore};
use crate::slave::{Slave, SlaveEvent};
use crate::status;
use bytes::Bytes;
use si_core::fb::{Pulse, RisingEdge};
use si_core::job::{JobId, JobPort, NotStarted, Reception};
use si_core::memory::Area;
use si_core::status::common;
use si_core::{Instant, Status};

pub use si_core::fb::{Done, Received, SRcv, SSend};

/// The most bytes S_SEND and S_RCV move (LEN 1…200, [Modbus/USS] §3.4.2).
pub const MAX_LEN: usize = 200;

/// Read a master job from the S_SEND source area ([Modbus/USS] §3.4.5–§3.4.16): `(unit, request)`,
/// or the STATUS the module reports (0E40H–0E4AH, 1E41H; 050EH for a read whose result exceeds
/// [`MAX_LEN`], [Modbus/USS] §3.4.5–§3.4.16).
pub fn parse_job(source: &[u8]) -> Result<(u8, Request<'_>), Status> {
    let len = source.len();
    if len > MAX_LEN {
        return Err(common::INVALID_LEN);
    }
    if len < 2 {
        return Err(status::LEN_TOO_SMALL);
    }
    let unit = source[0];
    let f = source[1];
    if !fc::is_supported(f) {
        return Err(status::INVALID_FUNCTION);
    }
    if unit == 0 && !fc::broadcast_allowed(f) {
        return Err(status::BROADCAST_NOT_ALLOWED_FOR_FC);
    }
    let plain = matches!(
        f,
        fc::READ_EXCEPTION_STATUS | fc::GET_COMM_EVENT_COUNTER | fc::GET_COMM_EVENT_LOG
    );
    if plain {
        if len > 2 {
            return Err(status::LEN_TOO_LARGE);
        }
        let r = match f {
            fc::READ_EXCEPTION_STATUS => Request::ReadExceptionStatus,
            fc::GET_COMM_EVENT_COUNTER => Request::GetCommEventCounter,
            _ => Request::GetCommEventLog,
        };
        return Ok((unit, r));
    }
    if len < 6 {
        return Err(status::LEN_TOO_SMALL_FOR_FC);
    }
    let w2 = u16::from_be_bytes([source[2], source[3]]);
    let w4 = u16::from_be_bytes([source[4], source[5]]);
    let fixed = |r: Request<'static>| {
        if len > 6 {
            Err(status::LEN_TOO_LARGE)
        } else {
            Ok((unit, r))
        }
    };
    // [Modbus/USS] §3.4.5–§3.4.16: the result of a read goes to S_RCV, which takes at most MAX_LEN
    // bytes.
    let fits_s_rcv = |result_len: usize| {
        if result_len > MAX_LEN {
            Err(status::FRAME_TOO_LONG)
        } else {
            Ok(())
        }
    };
    match f {
        fc::READ_COILS | fc::READ_DISCRETE_INPUTS => {
            if w4 == 0 || w4 > crate::frame::MAX_BITS {
                return Err(status::BIT_COUNT);
            }
            fits_s_rcv(bits_result_len(usize::from(w4).div_ceil(8)))?;
            if f == fc::READ_COILS {
                fixed(Request::ReadCoils {
                    address: w2,
                    quantity: w4,
                })
            } else {
                fixed(Request::ReadDiscreteInputs {
                    address: w2,
                    quantity: w4,
                })
            }
        }
        fc::READ_HOLDING_REGISTERS | fc::READ_INPUT_REGISTERS => {
            if w4 == 0 || w4 > crate::frame::MAX_REGISTERS {
                return Err(status::REGISTER_COUNT);
            }
            fits_s_rcv(2 * usize::from(w4))?;
            if f == fc::READ_HOLDING_REGISTERS {
                fixed(Request::ReadHoldingRegisters {
                    address: w2,
                    quantity: w4,
                })
            } else {
                fixed(Request::ReadInputRegisters {
                    address: w2,
                    quantity: w4,
                })
            }
        }
        fc::WRITE_SINGLE_COIL => match w4 {
            crate::frame::COIL_ON | crate::frame::COIL_OFF => fixed(Request::WriteSingleCoil {
                address: w2,
                value: w4 == crate::frame::COIL_ON,
            }),
            _ => Err(status::COIL_VALUE),
        },
        fc::WRITE_SINGLE_REGISTER => fixed(Request::WriteSingleRegister {
            address: w2,
            value: w4,
        }),
        fc::DIAGNOSTICS => {
            if w2 != 0 {
                return Err(status::DIAGNOSTIC_CODE);
            }
            fixed(Request::Diagnostics { data: w4 })
        }
        _ => {
            // FC15 / FC16.
            let coils = f == fc::WRITE_MULTIPLE_COILS;
            let max = if coils {
                crate::frame::MAX_BITS
            } else {
                crate::frame::MAX_REGISTERS
            };
            if w4 == 0 || w4 > max {
                return Err(status::WRITE_COUNT);
            }
            let need = if coils {
                (w4 as usize).div_ceil(8)
            } else {
                2 * w4 as usize
            };
            if len < 6 + need {
                return Err(status::LEN_DOES_NOT_MATCH_COUNT);
            }
            if len > 6 + need + 1 {
                // One pad byte is allowed: the source is "word by word".
                return Err(status::LEN_TOO_LARGE);
            }
            let data = &source[6..6 + need];
            Ok((
                unit,
                if coils {
                    Request::WriteMultipleCoils {
                        address: w2,
                        values: Bits::packed(data, w4),
                    }
                } else {
                    Request::WriteMultipleRegisters {
                        address: w2,
                        values: Registers::Wire(data),
                    }
                },
            ))
        }
    }
}

/// S_RCV LEN of FC01/02 data of `bytes` bytes: stored word by word, so an odd count gets the
/// high byte of its last word as well ([Modbus/USS] §3.4.5–§3.4.16).
const fn bits_result_len(bytes: usize) -> usize {
    bytes + bytes % 2
}

/// Write a completed job's response into the S_RCV destination area ([Modbus/USS] §3.4.5–§3.4.16);
/// returns LEN. `dest` must hold at least [`MAX_LEN`] bytes … or as many as the response needs. The
/// response of a job [`parse_job`] accepted never needs more than [`MAX_LEN`].
pub fn store_response(completion: &Completion, dest: &mut [u8]) -> usize {
    let Some(response) = completion.response() else {
        return 0;
    };
    let unit = completion.unit();
    let mut put = |at: usize, b: u8| {
        if let Some(slot) = dest.get_mut(at) {
            *slot = b;
        }
    };
    let echo = |put: &mut dyn FnMut(usize, u8), f: u8, w2: u16, w4: u16| {
        put(0, unit);
        put(1, f);
        let [a, b] = w2.to_be_bytes();
        put(2, a);
        put(3, b);
        let [a, b] = w4.to_be_bytes();
        put(4, a);
        put(5, b);
        6
    };
    match response {
        Response::ReadCoils(bits) | Response::ReadDiscreteInputs(bits) => {
            let n = bits.byte_len();
            for k in 0..n {
                // 1st byte → low byte of data[1] (offset +1), 2nd → high byte (offset +0).
                put(k ^ 1, bits.byte(k));
            }
            if n % 2 == 1 {
                put(n - 1, 0); // high byte of the last word
            }
            bits_result_len(n)
        }
        Response::ReadHoldingRegisters(regs) | Response::ReadInputRegisters(regs) => {
            for (i, r) in regs.iter().enumerate() {
                let [a, b] = r.to_be_bytes();
                put(2 * i, a);
                put(2 * i + 1, b);
            }
            2 * regs.len()
        }
        Response::WriteSingleCoil { address, value } => echo(
            &mut put,
            fc::WRITE_SINGLE_COIL,
            address,
            if value { 0xFF00 } else { 0 },
        ),
        Response::WriteSingleRegister { address, value } => {
            echo(&mut put, fc::WRITE_SINGLE_REGISTER, address, value)
        }
        Response::Diagnostics { data } => echo(&mut put, fc::DIAGNOSTICS, 0, data),
        Response::WriteMultipleCoils { address, quantity } => {
            echo(&mut put, fc::WRITE_MULTIPLE_COILS, address, quantity)
        }
        Response::WriteMultipleRegisters { address, quantity } => {
            echo(&mut put, fc::WRITE_MULTIPLE_REGISTERS, address, quantity)
        }
        Response::ReadExceptionStatus(s) => {
            put(0, s); // high byte of data[1]; the low byte is left unchanged
            1
        }
        Response::GetCommEventCounter {
            status,
            event_count,
        } => {
            for (i, b) in [status, event_count]
                .iter()
                .flat_map(|w| w.to_be_bytes())
                .enumerate()
            {
                put(i, b);
            }
            4
        }
        Response::GetCommEventLog {
            status,
            event_count,
            message_count,
            events,
        } => {
            for (i, b) in [status, event_count, message_count]
                .iter()
                .flat_map(|w| w.to_be_bytes())
                .enumerate()
            {
                put(i, b);
            }
            for k in 0..64 {
                put(6 + k, events.get(k).copied().unwrap_or(0));
            }
            70
        }
        Response::Exception { .. } => 0,
    }
}

/// The FBs' bookkeeping on the master: once the job S_SEND started has ended, its outcome
/// becomes S_RCV's reception (the response, or the failure; a broadcast has no response, so
/// S_RCV shows nothing for it). Only jobs started through [`JobPort::start_job`] are tracked;
/// jobs the application starts with [`Master::request`] never reach the FBs.
///
/// The master keeps the last job's outcome by its [`JobId`] ([`Master::outcome`]) until the
/// next job ends, and the FBs are called every cycle, so the outcome is collected here on
/// their next call. **Reading chosen** [derived]: a program that also starts its own jobs on
/// the engine between two FB calls may replace the outcome before S_RCV sees it; the module
/// has no such second job source.
fn collect(master: &mut Master) {
    let Some(id) = master.fb_job else {
        return;
    };
    let Some(outcome) = master.outcome(id) else {
        return;
    };
    master.fb_job = None;
    let reception = match outcome {
        Ok(c) => c.response().is_some().then_some(Ok(c)),
        Err(status) => Some(Err(status)),
    };
    if reception.is_some() {
        master.fb_reception = reception;
    }
}

/// FB3 S_SEND and FB2 S_RCV for Modbus master jobs ([Modbus/USS] §3.4.2, Figure 3-7) are si-core's,
/// over the [`Master`] as a [`JobPort`]: the job is the S_SEND source area ([Modbus/USS]
/// §3.4.5–§3.4.16), the "received frame" the response of the job in the S_RCV destination layout
/// ([Modbus/USS] §3.4.5–§3.4.16).
impl JobPort for Master {
    type Job = Bytes;
    type Output = ();

    /// Parses the source area ([`parse_job`], 0E40H–0E4AH, 1E41H) and starts the job (0502H
    /// while one runs).
    fn start_job(&mut self, now: Instant, source: Bytes) -> Result<JobId, NotStarted> {
        let (unit, request) = parse_job(&source)?;
        if self.is_busy() {
            return Err(RequestError::Busy.status().into());
        }
        collect(self);
        // Ended within `request` already (the automatic V.24 gate)? Then its outcome is the
        // master's last one, and `collect` finds it by this id.
        let id = self.request(now, unit, &request).map_err(|e| e.status())?;
        self.fb_job = Some(id);
        Ok(id)
    }

    fn job_outcome(&mut self, id: JobId) -> Option<Result<(), Status>> {
        collect(self);
        self.outcome(id).map(|r| r.map(|_| ()))
    }

    /// R on S_SEND: the request already on the line runs to its end, but neither S_SEND nor
    /// S_RCV reports it.
    fn cancel_job(&mut self, id: JobId) {
        if self.fb_job == Some(id) {
            self.fb_job = None;
        }
    }

    /// The response of the last job, stored as [Modbus/USS] §3.4.5–§3.4.16 lays it out, or its
    /// failure: a failed job is reported by both blocks with the same STATUS (Figure 3-7).
    fn take_received(&mut self, _now: Instant, dest: &mut [u8]) -> Option<Reception> {
        collect(self);
        Some(match self.fb_reception.take()? {
            Ok(c) => Reception::Frame {
                len: store_response(&c, dest),
                status: Status::OK,
            },
            Err(status) => Reception::Error(status),
        })
    }

    /// R on S_RCV drops a response not yet taken; EN_R = 0 keeps it.
    fn stop_receiving(&mut self, reset: bool) -> bool {
        collect(self);
        if reset {
            self.fb_reception = None;
        }
        false
    }
}

/// S_MODB's ERROR_NR table ([Modbus/USS] §3.6.4, §3.6.5; [ET200S SI 2005] Tables 3-74 to 3-77):
/// number, meaning, remedy.
pub const ERROR_NR: &[(u16, &str, &str)] = &[
    (0, "no error", "-"),
    (
        1,
        "error reading the SZL with SFC51 (ERROR_INFO = RET_VAL)",
        "analyse RET_VAL",
    ),
    (
        2,
        "timeout or error during module initialisation (ERROR_INFO = S_SEND/S_RCV STATUS)",
        "check that the interface is parameterised for Modbus slave",
    ),
    (
        11,
        "driver passed an invalid start address (ERROR_INFO = start address)",
        "check the master's Modbus address",
    ),
    (12, "register count = 0", "check the master"),
    (13, "register count > 128", "check the master"),
    (
        14,
        "access beyond the CPU's M area (ERROR_INFO = end address)",
        "reduce the address or length",
    ),
    (
        15,
        "access beyond the CPU's Q or I area",
        "reduce the address or length",
    ),
    (
        16,
        "access beyond the timer area",
        "reduce the address or length",
    ),
    (
        17,
        "access beyond the counter area",
        "reduce the address or length",
    ),
    (
        18,
        "driver passed an invalid SIMATIC area",
        "power-cycle the module",
    ),
    (
        19,
        "I/O access error",
        "check that the I/O exists and is error-free",
    ),
    (
        20,
        "DB does not exist (ERROR_INFO = DB number)",
        "create the DB",
    ),
    (
        21,
        "DB too short (ERROR_INFO = DB number)",
        "lengthen the DB",
    ),
    (22, "DB number below DB_Min", "change the limit"),
    (23, "DB number above DB_Max", "change the limit"),
    (24, "M byte below M_Min", "change the limit"),
    (25, "M byte above M_Max", "change the limit"),
    (26, "Q byte below Q_Min", "change the limit"),
    (27, "Q byte above Q_Max", "change the limit"),
    (
        90,
        "error sending the acknowledgement to the driver (ERROR_INFO = S_SEND STATUS)",
        "analyse STATUS",
    ),
    (
        94,
        "error reading SYSTAT (ERROR_INFO = S_RCV STATUS)",
        "analyse STATUS",
    ),
];

/// The text of an S_MODB error number.
pub fn error_text(nr: u16) -> Option<(&'static str, &'static str)> {
    ERROR_NR
        .iter()
        .find(|e| e.0 == nr)
        .map(|&(_, meaning, remedy)| (meaning, remedy))
}

/// Outputs of one S_MODB call.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SModbOutputs {
    /// A write request from the master was executed (one call).
    pub ndr: bool,
    /// Initialisation succeeded (level).
    pub start_ok: bool,
    /// Initialisation failed (level).
    pub start_error: bool,
    /// Error number ([Modbus/USS] §3.6.4, §3.6.5), held until the next START edge.
    pub error_nr: u16,
    /// Additional information.
    pub error_info: u16,
}

/// FB81 S_MODB over a [`Slave`] with a [`SimaticStore`] ([Modbus/USS] §3.5.1, §3.5.2).
///
/// A rising edge on START reads the conversion DB `DB_NO` from the CPU memory into the store,
/// clears ERROR_NR/ERROR_INFO and sets START_OK; until then every request gets exception 04.
/// A missing or short conversion DB sets START_ERROR with ERROR_NR 20/21 (the manual's init
/// errors 1–9 cover only SFC51 and module start-up; 20/21 name the cause).
#[derive(Debug, Default)]
pub struct SModb {
    start: RisingEdge,
    out: SModbOutputs,
    ndr: Pulse<()>,
}

impl SModb {
    /// A fresh S_MODB instance.
    pub fn new() -> Self {
        SModb::default()
    }

    /// One cycle: `start` is the START input, `db_no` the conversion DB.
    pub fn call(
        &mut self,
        slave: &mut Slave<SimaticStore>,
        start: bool,
        db_no: u16,
    ) -> SModbOutputs {
        if self.start.update(start) {
            self.out = SModbOutputs::default();
            let store = slave.store_mut();
            let mut bytes = [0u8; 52];
            match store.memory.read(Area::Db(db_no), 0, &mut bytes) {
                Ok(()) => {
                    store.conversion = ConversionDb::from_bytes(&bytes).unwrap_or_default();
                    store.started = true;
                    self.out.start_ok = true;
                }
                Err(e) => {
                    store.started = false;
                    self.out.start_error = true;
                    self.out.error_nr = match e {
                        si_core::memory::MemoryError::NoSuchDb(_) => 20,
                        _ => 21,
                    };
                    self.out.error_info = db_no;
                }
            }
        }
        SModbOutputs {
            ndr: self.ndr.take().is_some(),
            ..self.out
        }
    }

    /// Hand the slave's events to the FB: S_MODB errors land in ERROR_NR/ERROR_INFO, executed
    /// writes pulse NDR.
    pub fn on_event(&mut self, event: &SlaveEvent) {
        match *event {
            SlaveEvent::Served { function, .. } | SlaveEvent::Broadcast { function, .. }
                if matches!(function, 5 | 6 | 15 | 16) =>
            {
                self.ndr.fire(())
            }
            SlaveEvent::Exception { error: Some(e), .. } if e.error_nr != 0 => {
                self.out.error_nr = e.error_nr;
                self.out.error_info = e.info;
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Adu, ExceptionCode};
    use crate::{MasterConfig, SlaveConfig};
    use si_core::{Engine, Output};

    fn hex(s: &str) -> Vec<u8> {
        si_core::hex::parse(s).unwrap()
    }

    /// [Modbus/USS] §3.4.5–§3.4.16 job examples of the 2005 manual ([ET200S SI 2005]
    /// §3.5.5–§3.5.16) and every refusal code.
    #[test]
    fn send_area_jobs_and_their_refusals() {
        let j1 = hex("05 01 00 40 00 10");
        let (u, r) = parse_job(&j1).unwrap();
        assert_eq!(
            (u, r),
            (
                5,
                Request::ReadCoils {
                    address: 0x40,
                    quantity: 16
                }
            )
        );
        let j2 = hex("05 05 00 19 FF 00");
        let (_, r) = parse_job(&j2).unwrap();
        assert_eq!(
            r,
            Request::WriteSingleCoil {
                address: 0x19,
                value: true
            }
        );
        let j3 = hex("05 08 00 00 A5 C3");
        let (_, r) = parse_job(&j3).unwrap();
        assert_eq!(r, Request::Diagnostics { data: 0xA5C3 });
        assert_eq!(
            parse_job(&hex("05 07")).unwrap().1,
            Request::ReadExceptionStatus
        );
        // FC15: 10 bits from 0058H, data word EFCDH sent in memory order EF, CD (§3.4.15).
        let job = hex("05 0F 00 58 00 0A EF CD");
        let (_, r) = parse_job(&job).unwrap();
        let adu = Adu::request(5, &r).unwrap();
        // Bits past the 10th are padded with zeros, as Modbus asks: CD → 01.
        assert_eq!(&adu.as_bytes()[..9], &hex("05 0F 00 58 00 0A 02 EF 01")[..]);
        // FC16: 3 registers 41A1 42A2 43A3 from 0060H.
        let j4 = hex("05 10 00 60 00 03 41 A1 42 A2 43 A3");
        let (_, r) = parse_job(&j4).unwrap();
        assert_eq!(
            r,
            Request::WriteMultipleRegisters {
                address: 0x60,
                values: Registers::Words(&[0x41A1, 0x42A2, 0x43A3])
            }
        );
        for (job, code) in [
            ("05", 0x0E40),
            ("05 03 00", 0x0E41),
            ("05 09 00 00 00 01", 0x0E42),
            ("00 03 00 00 00 01", 0x0E43),
            ("05 01 00 00 07 F9", 0x0E44),
            ("05 03 00 00 00 80", 0x0E45),
            ("05 10 00 00 00 00", 0x0E46),
            ("05 10 00 00 00 02 00 01", 0x0E47),
            ("05 05 00 00 12 34", 0x0E48),
            ("05 08 00 01 00 00", 0x0E49),
            ("05 03 00 00 00 01 00", 0x0E4A),
            // [Modbus/USS] §3.4.5–§3.4.16: results beyond S_RCV's 200 bytes.
            ("05 01 00 00 06 41", 0x050E),
            ("05 02 00 00 07 F8", 0x050E),
            ("05 03 00 00 00 65", 0x050E),
            ("05 04 00 00 00 7F", 0x050E),
        ] {
            assert_eq!(parse_job(&hex(job)).unwrap_err().code(), code, "{job}");
        }
        assert_eq!(parse_job(&[0; 201]).unwrap_err(), common::INVALID_LEN);
    }

    fn completion(request: &str, response: &str) -> Completion {
        // Run a master against the scripted response to get a real Completion.
        let mut m = Master::new(MasterConfig::default()).unwrap();
        m.set_rx_latency(si_core::Duration::ZERO);
        let req = hex(request);
        let (unit, r) = parse_job(&req).unwrap();
        m.request(Instant::ZERO, unit, &r).unwrap();
        while !matches!(m.poll_output(), Output::Wait(_)) {}
        m.handle_tx_done(Instant::from_micros(10_000));
        let mut resp = hex(response);
        let c = crate::frame::crc16(&resp).to_le_bytes();
        resp.extend_from_slice(&c);
        m.handle_rx(Instant::from_micros(20_000), &resp);
        m.handle_timeout(Instant::from_micros(30_000));
        loop {
            match m.poll_output() {
                Output::Event(crate::MasterEvent::Completed(c)) => return c,
                Output::Wait(_) => panic!("no completion"),
                _ => {}
            }
        }
    }

    /// [Modbus/USS] §3.4.5–§3.4.16's examples: FC01 16 bits 01, 17 → W#16#1701; FC02 24 bits 04,
    /// 26, 48 → W#16#2604, W#16#0048; FC03 2123, 2527; FC07 3Exx; FC11 FEDC, 0108.
    #[test]
    fn rcv_area_layouts_of_section_4_4() {
        let mut dest = [0xAAu8; 80];
        let c = completion("05 01 00 40 00 10", "05 01 02 01 17");
        assert_eq!(store_response(&c, &mut dest), 2);
        assert_eq!(dest[..2], [0x17, 0x01]);
        let c = completion("05 02 01 20 00 18", "05 02 03 04 26 48");
        assert_eq!(store_response(&c, &mut dest), 4);
        assert_eq!(dest[..4], [0x26, 0x04, 0x00, 0x48]);
        let c = completion("05 03 00 40 00 02", "05 03 04 21 23 25 27");
        assert_eq!(store_response(&c, &mut dest), 4);
        assert_eq!(dest[..4], [0x21, 0x23, 0x25, 0x27]);
        let mut dest = [0xAAu8; 80];
        let c = completion("05 07", "05 07 3E");
        assert_eq!(store_response(&c, &mut dest), 1);
        assert_eq!(dest[..2], [0x3E, 0xAA]);
        let c = completion("05 0B", "05 0B FE DC 01 08");
        assert_eq!(store_response(&c, &mut dest), 4);
        assert_eq!(dest[..4], [0xFE, 0xDC, 0x01, 0x08]);
        let c = completion("05 0C", "05 0C 08 87 65 01 08 02 20 11 22");
        assert_eq!(store_response(&c, &mut dest), 70);
        assert_eq!(
            dest[..9],
            [0x87, 0x65, 0x01, 0x08, 0x02, 0x20, 0x11, 0x22, 0x00]
        );
        let c = completion("05 06 01 80 3E 7F", "05 06 01 80 3E 7F");
        assert_eq!(store_response(&c, &mut dest), 6);
        assert_eq!(dest[..6], hex("05 06 01 80 3E 7F")[..]);
    }

    /// Drain the master's outputs (the application's job; the FBs do not need its events).
    fn drain(m: &mut Master) {
        while !matches!(m.poll_output(), Output::Wait(_)) {}
    }

    /// The request leaves the line, then the 2 s response time runs out (no slave answers).
    fn time_out(m: &mut Master) {
        m.handle_timeout(Instant::from_micros(10_000));
        drain(m);
        m.handle_timeout(Instant::from_micros(2_010_000));
        drain(m);
    }

    /// A master, S_SEND and S_RCV, with S_SEND's first call (REQ edge) for `job` made.
    fn started(job: &[u8]) -> (Master, SSend, SRcv) {
        let mut m = Master::new(MasterConfig::default()).unwrap();
        m.set_rx_latency(si_core::Duration::ZERO);
        let (mut s_send, s_rcv) = (SSend::default(), SRcv::default());
        let d = s_send.call(&mut m, Instant::ZERO, true, false, job);
        assert_eq!(d, Done::default());
        drain(&mut m);
        (m, s_send, s_rcv)
    }

    #[test]
    fn s_send_and_s_rcv_pulse_once_per_job() {
        let job = hex("01 03 00 00 00 01");
        let (mut m, mut s_send, mut s_rcv) = started(&job);
        time_out(&mut m);
        let out = s_send.call(&mut m, Instant::ZERO, true, false, &job);
        assert!(out.error && !out.done);
        assert_eq!(out.status, status::RESPONSE_TIMEOUT);
        assert_eq!(
            s_send.call(&mut m, Instant::ZERO, true, false, &job),
            Done::default()
        );
        let mut dest = [0u8; 10];
        let r = s_rcv.call(&mut m, Instant::ZERO, true, false, &mut dest);
        assert!(r.error && r.status == status::RESPONSE_TIMEOUT);
        assert_eq!(
            s_rcv.call(&mut m, Instant::ZERO, true, false, &mut dest),
            Received::default()
        );
        // A bad job is refused at once on the edge.
        s_send.call(&mut m, Instant::ZERO, false, false, &job);
        let out = s_send.call(
            &mut m,
            Instant::ZERO,
            true,
            false,
            &hex("00 03 00 00 00 01"),
        );
        assert_eq!(out.status.code(), 0x0E43);
    }

    #[test]
    fn s_rcv_gets_the_response_in_the_4_4_layout_with_done() {
        let job = hex("05 03 00 40 00 02");
        let (mut m, mut s_send, mut s_rcv) = started(&job);
        m.handle_tx_done(Instant::from_micros(10_000));
        drain(&mut m);
        let mut resp = hex("05 03 04 21 23 25 27");
        let crc = crate::frame::crc16(&resp).to_le_bytes();
        resp.extend_from_slice(&crc);
        m.handle_rx(Instant::from_micros(20_000), &resp);
        m.handle_timeout(Instant::from_micros(30_000));
        drain(&mut m);
        let mut dest = [0u8; 8];
        // EN_R = 0 keeps the response for later.
        let r = s_rcv.call(&mut m, Instant::ZERO, false, false, &mut dest);
        assert!(!r.ndr && !r.error);
        let d = s_send.call(&mut m, Instant::ZERO, true, false, &job);
        assert!(d.done && !d.error);
        let r = s_rcv.call(&mut m, Instant::ZERO, true, false, &mut dest);
        assert_eq!(
            (r.ndr, r.error, r.len, r.status),
            (true, false, 4, Status::OK)
        );
        assert_eq!(dest[..4], [0x21, 0x23, 0x25, 0x27]);
        assert!(
            !s_rcv
                .call(&mut m, Instant::ZERO, true, false, &mut dest)
                .ndr
        );
    }

    #[test]
    fn r_on_s_send_reports_1e0d_and_the_response_is_nobodys() {
        let mut m = Master::new(MasterConfig::default()).unwrap();
        m.set_rx_latency(si_core::Duration::ZERO);
        let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
        let job = hex("01 03 00 00 00 01");
        s_send.call(&mut m, Instant::ZERO, true, false, &job);
        // R before the outputs were drained: the request is already queued on the line.
        let d = s_send.call(&mut m, Instant::ZERO, true, true, &job);
        assert_eq!((d.error, d.status), (true, common::ABORTED_BY_RESET));
        drain(&mut m);
        time_out(&mut m);
        let mut dest = [0u8; 10];
        assert_eq!(
            s_rcv.call(&mut m, Instant::ZERO, true, false, &mut dest),
            Received::default()
        );
        assert!(!m.is_busy());
    }

    #[test]
    fn s_modb_reads_the_conversion_db_and_reports_errors() {
        let mut store = SimaticStore::example();
        store.started = false;
        store.memory.add_db(10, 52);
        store
            .memory
            .write(Area::Db(10), 0, &ConversionDb::EXAMPLE.to_bytes())
            .unwrap();
        store.conversion = ConversionDb::default();
        let config = SlaveConfig {
            address: 1,
            ..SlaveConfig::default()
        };
        let mut slave = Slave::new(config, store).unwrap();
        slave.set_rx_latency(si_core::Duration::ZERO);
        let mut fb = SModb::new();
        let out = fb.call(&mut slave, true, 10);
        assert!(out.start_ok && !out.start_error);
        assert_eq!(slave.store().conversion, ConversionDb::EXAMPLE);
        fb.on_event(&SlaveEvent::Exception {
            function: 6,
            code: ExceptionCode::IllegalDataAddress,
            status: None,
            error: Some(crate::slave::StoreError::new(
                ExceptionCode::IllegalDataAddress,
                23,
                7,
            )),
        });
        let out = fb.call(&mut slave, true, 10);
        assert_eq!((out.error_nr, out.error_info), (23, 7));
        assert_eq!(error_text(23).unwrap().0, "DB number above DB_Max");
        fb.on_event(&SlaveEvent::Served {
            function: 16,
            address: 0,
            quantity: 1,
        });
        assert!(fb.call(&mut slave, true, 10).ndr);
        // A new START edge clears the error; a missing DB is START_ERROR 20.
        fb.call(&mut slave, false, 99);
        let out = fb.call(&mut slave, true, 99);
        assert!(out.start_error && !out.start_ok);
        assert_eq!((out.error_nr, out.error_info), (20, 99));
        assert!(!slave.store().started);
    }
}
