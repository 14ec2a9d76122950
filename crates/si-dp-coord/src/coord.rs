//! The coordination byte (byte 0 of both windows), its job codes and execution numbers.
//!
//! et200s-si-2005-window-protocol.md §2.2 (Table 2-21) and §2.3 (Table 2-22):
//!
//! ```text
//!  bit:   7        6   5   4        3         2   1   0
//!       | res |  job code   | error | exec number |
//! ```
//!
//! The layout is the same in both directions. The Russian extraction proves the field order
//! from the example bytes 51H/52H/53H/73H (et200s-si-3964r-ascii.md §9.2).

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
/// Decoding ignores bit 7 (reserved, §2.2); encoding always writes it as 0.
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

    /// `job` with the error bit set and `last_valid` as the execution number (§2.8).
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
    /// code (§2.4 rule 1).
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

/// The execution number after `exec`: 1, 2, …, 7, then 1 again.
///
/// The manual gives the range "1 to 7" and uses 0 only in the job request and acceptance
/// (10H, 20H, 50H); it does not say what follows 7 (H-5, et200s-si-2005-window-protocol.md
/// §2.2). Wrap-around is unavoidable (a 224-byte send takes 76 segments in the 4-byte window).
/// We read 7 → 1: wrapping to 0 would make the 8th segment of a send or the 8th echo of a
/// receive identical to the request bytes 10H/20H, which a module in idle would take for a new
/// job. Verify on hardware.
pub const fn next_exec(exec: u8) -> u8 {
    if exec >= 7 {
        1
    } else {
        exec + 1
    }
}

/// The execution number of segment `k` (1-based): 1…7, 1…7, …; segment 0 is the request (0).
pub const fn exec_of_segment(k: usize) -> u8 {
    if k == 0 {
        0
    } else {
        ((k - 1) % 7) as u8 + 1
    }
}

/// The most recent segment at or before `k` whose execution number is `exec` (0 ⇒ segment 0,
/// the acceptance): how a sender maps "last valid exec" back to a segment for go-back (§2.8).
/// Looks back at most 6 segments, the largest ambiguity-free distance with 7 numbers.
pub const fn segment_with_exec(k: usize, exec: u8) -> Option<usize> {
    if exec == 0 {
        return Some(0);
    }
    let mut back = 0;
    while back < 7 && back <= k {
        let j = k - back;
        if j > 0 && exec_of_segment(j) == exec & 7 {
            return Some(j);
        }
        back += 1;
    }
    None
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
    fn exec_numbers_wrap_7_to_1() {
        let seq: Vec<u8> = (1..=16).map(exec_of_segment).collect();
        assert_eq!(seq, [1, 2, 3, 4, 5, 6, 7, 1, 2, 3, 4, 5, 6, 7, 1, 2]);
        assert_eq!(next_exec(0), 1);
        assert_eq!(next_exec(7), 1);
        for k in 1..40 {
            assert_eq!(next_exec(exec_of_segment(k)), exec_of_segment(k + 1));
        }
    }

    #[test]
    fn go_back_finds_the_latest_segment() {
        assert_eq!(segment_with_exec(9, 1), Some(8));
        assert_eq!(segment_with_exec(9, 2), Some(9));
        assert_eq!(segment_with_exec(9, 3), Some(3));
        assert_eq!(segment_with_exec(2, 0), Some(0));
        assert_eq!(segment_with_exec(2, 5), None);
    }
}
