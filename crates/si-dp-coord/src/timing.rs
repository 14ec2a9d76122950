//! Timing estimates the manuals give for the window exchange and for the bus around it.
//!
//! * The module's processing time per 7 bytes and the transaction total t8 of
//!   [ET200S SI 2005] §3.9.4, Table 3-85 and
//!   [Modbus/USS] §3.8.4.
//! * The PPI token rotation time of [S7-200] §8.4 (Fig. 8-8) and its Tables 8-3/8-4.
//!
//! All results are [`Duration`]s in microseconds, computed in integers and rounded up, so the
//! helpers can size watchdogs and scheduler timeouts without floating point.

use si_core::{Duration, SerialSettings};

/// The module's fixed processing share per window step and per transmission: 10 ms.
pub const MODULE_OVERHEAD: Duration = Duration::from_millis(10);

/// Payload bytes per processing step in the manual's formula ("per 7 bytes", the 8-byte window).
pub const BYTES_PER_STEP: usize = 7;

/// Processing time for one step of 7 bytes ([ET200S SI 2005] §3.9.4, Table 3-85):
/// 1 CPU cycle if the CPU cycle exceeds (I/O cycle + 10 ms), else 2 CPU cycles + 3 I/O cycles +
/// 10 ms.
///
/// The 2005 manual writes "CPU cycle ≫ (I/O cycle + 10 ms)", the Modbus/USS manual ">"
/// ([Modbus/USS] §3.8.4). "≫" is not a computable condition; we use ">", which also
/// keeps the function continuous enough for sizing: at the boundary the two branches differ by
/// at most one CPU cycle plus 3 I/O cycles.
pub fn processing_per_step(cpu_cycle: Duration, io_cycle: Duration) -> Duration {
    if cpu_cycle > io_cycle + MODULE_OVERHEAD {
        cpu_cycle
    } else {
        cpu_cycle.saturating_mul(2) + io_cycle.saturating_mul(3) + MODULE_OVERHEAD
    }
}

/// Processing time to move `bytes` through the window: one step per started group of 7 bytes
/// (at least one step).
pub fn processing_time(bytes: usize, cpu_cycle: Duration, io_cycle: Duration) -> Duration {
    let steps = bytes.div_ceil(BYTES_PER_STEP).max(1) as u64;
    processing_per_step(cpu_cycle, io_cycle).saturating_mul(steps)
}

/// Transmission time of `chars` characters: 10 ms + characters × character time.
///
/// The manual prints "10 ms + baud rate × number of characters", which is dimensionally wrong
/// (`[derived]`); the Russian example's numbers fit characters × 8 bits / baud ([Modbus/USS]
/// [Modbus/USS] §3.8.4 `[derived]`), which ignores start, parity and stop bits. We use the real
/// character time of the configured format ([`SerialSettings::chars_time`]), which is what the line
/// takes.
pub fn transmission_time(chars: u64, settings: &SerialSettings) -> Duration {
    MODULE_OVERHEAD + settings.chars_time(chars)
}

/// The terms of one master/slave transaction through the module ([ET200S SI 2005] §3.9.4, Table
/// 3-85): t8 = t1 + … + t7.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transaction {
    /// t1: master job processing (request bytes through the window).
    pub t1: Duration,
    /// t2: request transmission.
    pub t2: Duration,
    /// t3: slave job processing.
    pub t3: Duration,
    /// t4: one CPU cycle to execute the FC.
    pub t4: Duration,
    /// t5: slave response processing.
    pub t5: Duration,
    /// t6: response transmission.
    pub t6: Duration,
    /// t7: master response processing.
    pub t7: Duration,
}

impl Transaction {
    /// The terms for a request of `request_bytes` window bytes sent as `request_chars`
    /// characters, and a response of `response_bytes` / `response_chars`, with the same CPU and
    /// I/O cycles on both sides.
    pub fn estimate(
        request_bytes: usize,
        request_chars: u64,
        response_bytes: usize,
        response_chars: u64,
        cpu_cycle: Duration,
        io_cycle: Duration,
        settings: &SerialSettings,
    ) -> Transaction {
        let req = processing_time(request_bytes, cpu_cycle, io_cycle);
        let resp = processing_time(response_bytes, cpu_cycle, io_cycle);
        Transaction {
            t1: req,
            t2: transmission_time(request_chars, settings),
            t3: req,
            t4: cpu_cycle,
            t5: resp,
            t6: transmission_time(response_chars, settings),
            t7: resp,
        }
    }

    /// t8, the sum (the manual's printed totals are off by 2 ms, [ET200S SI 2005] §3.9.4, Table
    /// 3-85 / [Modbus/USS] §3.8.4 `[derived]`).
    pub fn total(&self) -> Duration {
        self.t1 + self.t2 + self.t3 + self.t4 + self.t5 + self.t6 + self.t7
    }
}

/// Bits per PPI character in the token formula: start, 8 data, parity, stop.
pub const PPI_BITS_PER_CHAR: u64 = 11;

/// Overhead characters per token hold in the formula (an empirical constant, B-11).
pub const PPI_OVERHEAD_CHARS: u64 = 128;

/// Token hold time of one master sending `data_bytes` per message ([S7-200] §8.4, Fig. 8-8):
/// (128 + n) × 11 bits / baud, rounded up to the microsecond. `baud` 0 gives [`Duration::ZERO`].
pub fn token_hold_time(data_bytes: u64, baud: u32) -> Duration {
    if baud == 0 {
        return Duration::ZERO;
    }
    let bits = PPI_OVERHEAD_CHARS
        .saturating_add(data_bytes)
        .saturating_mul(PPI_BITS_PER_CHAR);
    Duration::from_micros(bits.saturating_mul(1_000_000).div_ceil(u64::from(baud)))
}

/// Token rotation time with `masters` masters each sending `data_bytes` per token hold:
/// T_rot = m × T_hold ([ET200S SI 2005] Tables 3-65 to 3-72). Tables 8-3/8-4 count masters in their
/// "stations" columns (B-3).
pub fn token_rotation_time(masters: u64, data_bytes: u64, baud: u32) -> Duration {
    if baud == 0 {
        return Duration::ZERO;
    }
    let bits = masters
        .saturating_mul(PPI_OVERHEAD_CHARS.saturating_add(data_bytes))
        .saturating_mul(PPI_BITS_PER_CHAR);
    Duration::from_micros(bits.saturating_mul(1_000_000).div_ceil(u64::from(baud)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::Parity;

    const MS: fn(u64) -> Duration = Duration::from_millis;

    #[test]
    fn processing_branches_of_section_9_6() {
        // CPU 40 ms ≫ 2 ms + 10 ms: one CPU cycle per 7 bytes.
        assert_eq!(processing_per_step(MS(40), MS(2)), MS(40));
        // CPU 10 ms < 2 + 10 ms: 2 × 10 + 3 × 2 + 10 = 36 ms.
        assert_eq!(processing_per_step(MS(10), MS(2)), MS(36));
        // The boundary itself (12 ms = 12 ms) is the slow branch.
        assert_eq!(processing_per_step(MS(12), MS(2)), MS(40));
        assert_eq!(processing_time(0, MS(40), MS(2)), MS(40));
        assert_eq!(processing_time(7, MS(40), MS(2)), MS(40));
        assert_eq!(processing_time(8, MS(40), MS(2)), MS(80));
    }

    #[test]
    fn table_3_85_example_read_10_words() {
        // Read 10 words at 9600 bit/s, I/O cycle 2 ms, CPU cycle 40 ms (t4 = 40 ms). Request
        // [addr][FC][start][count] = 6 bytes → 1 step (t1 = t3 = 40 ms); response
        // [addr][FC][count][20 data] = 23 bytes → 4 steps (t5 = t7 = 160 ms): the printed values.
        let s = SerialSettings::new(9600, 8, Parity::Even, 1).unwrap();
        let t = Transaction::estimate(6, 8, 23, 25, MS(40), MS(2), &s);
        assert_eq!(
            (t.t1, t.t3, t.t4, t.t5, t.t7),
            (MS(40), MS(40), MS(40), MS(160), MS(160))
        );
        // Transmission with the real 11-bit character: 10 ms + 8 × 1.1458 ms and 10 ms + 25 ×
        // 1.1458 ms. The manual prints 12/29 ms (2005) or 15/31.7 ms (Russian, 8 bits/char).
        assert_eq!(t.t2.as_millis(), 19);
        assert_eq!(t.t6.as_millis(), 38);
        assert_eq!(t.total(), t.t1 + t.t2 + t.t3 + t.t4 + t.t5 + t.t6 + t.t7);
        assert_eq!(t.total().as_micros(), 497_813);
    }

    #[test]
    fn token_formula_worked_example() {
        // (128 + 4) × 11 / 9600 = 151.25 ms; 6 masters → 907.5 ms ([S7-200] §8.4, Fig. 8-8).
        assert_eq!(token_hold_time(4, 9600), Duration::from_micros(151_250));
        assert_eq!(
            token_rotation_time(6, 4, 9600),
            Duration::from_micros(907_500)
        );
        assert_eq!(token_rotation_time(6, 4, 0), Duration::ZERO);
        assert_eq!(
            token_rotation_time(u64::MAX, u64::MAX, 1).as_micros(),
            u64::MAX
        );
    }
}
