//! The coordination byte (byte 0 of both windows), its job codes and execution numbers.
//!
//! [ET200S SI 2005] §2.12.1 (Table 2-21) and §2.12.1 (Table 2-22):
//!
//! ```text
//!  bit:   7        6   5   4        3         2   1   0
//!       | res |  job code   | error | exec number |
//! ```
//!
//! The layout is the same in both directions. The Russian manual's examples prove the field order
//! from the example bytes 51H/52H/53H/73H ([ET200S SI] §2.12, Table 2-20).

use core::fmt;
use serde::{Deserialize, Serialize};

/// Bits 6–4 of the coordination byte (Table 2-22).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum JobCode {
    /// 0H: idle; the module publishes its receive status in bytes 1–2.
    Idle,
    /// 1H: send a frame (host → module → serial line).
    Send,
    /// 2H: receive a frame (serial line → module → host).
    Receive,
    /// 3H: read the V.24 signal states.
    ReadV24,
    /// 4H: write the V.24 signals (RTS, DTR).
    WriteV24,
    /// 5H: transfer parameters not covered by the GSD file (flow-control blocks).
    Parameters,
    /// 6H: reserved by the manual; never written by this crate, ignored when read.
    Reserved,
    /// 7H: end-of-job acknowledgement (module → host, end of send and parameter jobs).
    EndOfJob,
}

impl JobCode {
    /// The 3-bit code.
    pub const fn bits(self) -> u8 {
        match self {
            JobCode::Idle => 0,
            JobCode::Send => 1,
            JobCode::Receive => 2,
            JobCode::ReadV24 => 3,
            JobCode::WriteV24 => 4,
            JobCode::Parameters => 5,
            JobCode::Reserved => 6,
            JobCode::EndOfJob => 7,
        }
    }

    /// The code from the low three bits of `bits` (every value is a code, so this cannot fail).
    pub const fn from_bits(bits: u8) -> JobCode {
        match bits & 7 {
            0 => JobCode::Idle,
            1 => JobCode::Send,
            2 => JobCode::Receive,
            3 => JobCode::ReadV24,
            4 => JobCode::WriteV24,
            5 => JobCode::Parameters,
            6 => JobCode::Reserved,
            _ => JobCode::EndOfJob,
        }
    }

    /// The coordination byte that requests this job: code, no error, exec number 0
    /// (10H, 20H, …; Table 2-22's last column).
    pub const fn request(self) -> u8 {
        self.bits() << 4
    }
}

impl fmt::Display for JobCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            JobCode::Idle => "idle",
            JobCode::Send => "send",
            JobCode::Receive => "receive",
            JobCode::ReadV24 => "read V.24",
            JobCode::WriteV24 => "write V.24",
            JobCode::Parameters => "parameters",
            JobCode::Reserved => "reserved",
            JobCode::EndOfJob => "end of job",
        })
    }
}

/// A decoded coordination byte.
///
/// Decoding ignores bit 7 (reserved, [ET200S SI 2005] §2.12.1, Table 2-21); encoding always writes
/// it as 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct CoordByte {
    /// Bits 6–4.
    pub job: JobCode,
    /// Bit 3: the writer saw a segment out of order; `exec` then holds the last valid number.
    pub error: bool,
    /// Bits 2–0: the execution number (1…7 during a transfer, 0 in request and acceptance).
    pub exec: u8,
}

impl CoordByte {
    /// The idle byte 00H.
    pub const IDLE: CoordByte = CoordByte::new(JobCode::Idle, 0);

    /// `job` with execution number `exec` (masked to 3 bits) and no error.
    pub const fn new(job: JobCode, exec: u8) -> CoordByte {
        CoordByte {
            job,
            error: false,
            exec: exec & 7,
        }
    }

    /// `job` with the error bit set and `last_valid` as the execution number ([ET200S SI 2005]
    /// §2.12.7).
    pub const fn error(job: JobCode, last_valid: u8) -> CoordByte {
        CoordByte {
            job,
            error: true,
            exec: last_valid & 7,
        }
    }

    /// Decodes any byte (bit 7 is ignored).
    pub const fn decode(byte: u8) -> CoordByte {
        CoordByte {
            job: JobCode::from_bits(byte >> 4),
            error: byte & 0x08 != 0,
            exec: byte & 7,
        }
    }

    /// The wire byte, bit 7 = 0.
    pub const fn encode(self) -> u8 {
        (self.job.bits() << 4) | ((self.error as u8) << 3) | (self.exec & 7)
    }

    /// Idle code without the error bit: the only byte after which the host may write a job
    /// code ([ET200S SI 2005] §2.12.1 rule 1).
    pub const fn is_idle(self) -> bool {
        matches!(self.job, JobCode::Idle) && !self.error
    }
}

impl fmt::Display for CoordByte {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02X}H ({}", self.encode(), self.job)?;
        if self.error {
            write!(f, ", error, last valid {}", self.exec)
        } else {
            write!(f, ", exec {}", self.exec)
        }?;
        f.write_str(")")
    }
}

/// What follows execution number 7 (`[derived]`, [ET200S SI 2005] §2.12.1, Table 2-21): a setting
/// of both the host ([`HostConfig::exec_wrap`](crate::config::HostConfig::exec_wrap)) and the
/// module ([`ModuleConfig::exec_wrap`](crate::config::ModuleConfig::exec_wrap)), which must agree.
///
/// The manual gives the range "1 to 7" and uses 0 only in the job request and acceptance
/// (10H, 20H, 50H); it does not say what follows 7. Wrap-around is unavoidable (a 224-byte send
/// takes 76 segments in the 4-byte window, 33 in the 8-byte one). The default reads 7 → 1:
/// wrapping to 0 makes the 8th segment of a send or the 8th echo of a receive identical to the
/// request bytes 10H/20H, which a module back in idle takes for a new job. 7 → 0 is offered for
/// a module that turns out to count 0…7 on hardware.
///
/// When host and module disagree, the first segment after 7 is out of order for the receiver
/// ([ET200S SI 2005] §2.12.7): a module sets its error bit with the last valid number 7 and the
/// host sends the same segment again, forever, so a send job ends only by the host's watchdog
/// ([`HostConfig::job_timeout`](crate::config::HostConfig::job_timeout), STATUS 0502H by
/// default); in a receive job the host sets its error bit and the module aborts with 0551H
/// (Table 2-21), or the host takes a 20H segment for the module's 20H + STATUS answer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ExecWrap {
    /// 1, 2, …, 7, 1, 2, …: 0 stays the request's and acceptance's number. The default.
    #[default]
    ToOne,
    /// 1, 2, …, 7, 0, 1, …: all eight values of the 3-bit field.
    ToZero,
}

impl ExecWrap {
    /// How many execution numbers the cycle has: 7 or 8.
    const fn period(self) -> usize {
        match self {
            ExecWrap::ToOne => 7,
            ExecWrap::ToZero => 8,
        }
    }

    /// The execution number after `exec`.
    pub const fn next(self, exec: u8) -> u8 {
        match self {
            ExecWrap::ToOne if exec >= 7 => 1,
            ExecWrap::ToZero if exec >= 7 => 0,
            _ => exec + 1,
        }
    }

    /// The execution number of segment `k` (1-based); segment 0 is the request (0).
    pub const fn of_segment(self, k: usize) -> u8 {
        match self {
            _ if k == 0 => 0,
            ExecWrap::ToOne => ((k - 1) % 7) as u8 + 1,
            ExecWrap::ToZero => (k % 8) as u8,
        }
    }

    /// The most recent segment at or before `k` whose execution number is `exec` (segment 0 is
    /// the acceptance, number 0): how a sender maps "last valid exec" back to a segment for
    /// go-back ([ET200S SI 2005] §2.12.7). Looks back at most one cycle less one segment (6 or 7),
    /// the largest ambiguity-free distance. With 7 → 1, number 0 can only be the acceptance's.
    pub const fn segment_with(self, k: usize, exec: u8) -> Option<usize> {
        if matches!(self, ExecWrap::ToOne) && exec & 7 == 0 {
            return Some(0);
        }
        let mut back = 0;
        while back < self.period() && back <= k {
            let j = k - back;
            if self.of_segment(j) == exec & 7 {
                return Some(j);
            }
            back += 1;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_2_22_request_bytes() {
        let codes = [
            (JobCode::Idle, 0x00),
            (JobCode::Send, 0x10),
            (JobCode::Receive, 0x20),
            (JobCode::ReadV24, 0x30),
            (JobCode::WriteV24, 0x40),
            (JobCode::Parameters, 0x50),
            (JobCode::Reserved, 0x60),
            (JobCode::EndOfJob, 0x70),
        ];
        for (code, byte) in codes {
            assert_eq!(code.request(), byte);
            assert_eq!(CoordByte::decode(byte).job, code);
        }
    }

    #[test]
    fn table_2_21_field_layout_from_the_examples() {
        // 51H = parameters, exec 1; 73H = end of job, exec 3; 74H = end of job, exec 4.
        assert_eq!(
            CoordByte::decode(0x51),
            CoordByte::new(JobCode::Parameters, 1)
        );
        assert_eq!(
            CoordByte::decode(0x73),
            CoordByte::new(JobCode::EndOfJob, 3)
        );
        assert_eq!(CoordByte::new(JobCode::EndOfJob, 4).encode(), 0x74);
        // Error bit 3 with the last valid number.
        assert_eq!(CoordByte::error(JobCode::Send, 2).encode(), 0x1A);
        assert!(CoordByte::decode(0x1A).error);
        // Bit 7 is reserved and ignored.
        assert_eq!(CoordByte::decode(0x80), CoordByte::IDLE);
        assert!(CoordByte::decode(0x80).is_idle());
        assert!(!CoordByte::decode(0x08).is_idle());
    }

    #[test]
    fn every_byte_round_trips_without_bit_7() {
        for b in 0..=255u8 {
            assert_eq!(CoordByte::decode(b).encode(), b & 0x7F);
        }
    }

    #[test]
    fn exec_numbers_wrap_7_to_1_by_default() {
        let w = ExecWrap::default();
        assert_eq!(w, ExecWrap::ToOne);
        let seq: Vec<u8> = (1..=16).map(|k| w.of_segment(k)).collect();
        assert_eq!(seq, [1, 2, 3, 4, 5, 6, 7, 1, 2, 3, 4, 5, 6, 7, 1, 2]);
        assert_eq!(w.next(0), 1);
        assert_eq!(w.next(7), 1);
        for k in 0..40 {
            assert_eq!(w.next(w.of_segment(k)), w.of_segment(k + 1));
        }
    }

    #[test]
    fn exec_numbers_wrap_7_to_0_when_set() {
        let w = ExecWrap::ToZero;
        let seq: Vec<u8> = (0..=17).map(|k| w.of_segment(k)).collect();
        assert_eq!(seq, [0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1]);
        assert_eq!(w.next(7), 0);
        for k in 0..40 {
            assert_eq!(w.next(w.of_segment(k)), w.of_segment(k + 1));
        }
    }

    #[test]
    fn go_back_finds_the_latest_segment() {
        let w = ExecWrap::ToOne;
        assert_eq!(w.segment_with(9, 1), Some(8));
        assert_eq!(w.segment_with(9, 2), Some(9));
        assert_eq!(w.segment_with(9, 3), Some(3));
        assert_eq!(w.segment_with(2, 0), Some(0));
        assert_eq!(w.segment_with(2, 5), None);
        assert_eq!(
            w.segment_with(9, 0),
            Some(0),
            "0 is only the acceptance's number"
        );
        let w = ExecWrap::ToZero;
        assert_eq!(w.segment_with(9, 0), Some(8));
        assert_eq!(w.segment_with(9, 1), Some(9));
        assert_eq!(w.segment_with(9, 2), Some(2));
        assert_eq!(w.segment_with(3, 0), Some(0));
    }
}
