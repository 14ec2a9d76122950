//! The flow-control parameter blocks 20H, 21H and 22H, written once for every side that speaks
//! them: the FBs S_XON, S_RTS and S_V24 build them, a non-S7 DP master sends them with job code
//! 5 through the coordination window, the window's module and the ASCII link apply them
//! (`[ET200S SI]` §2.12, Tables 2-26 and 2-27; `[ET200S SI 2005]` §2.12.6, Table 2-28).
//!
//! A block is `[number][length hi][length lo][parameters …]`; the length counts the bytes after
//! the length field. Times cross the wire as big-endian **counts of 10 ms** (C8H = 200 → 2 s,
//! 1 → 10 ms): [`ten_ms_count`] and [`ten_ms_time`] are the one conversion between a TIME and a
//! count.
//!
//! ```
//! use si_core::param_block::ParamBlock;
//!
//! let (bytes, len) = ParamBlock::XON_XOFF_DEFAULT.encode();
//! assert_eq!(bytes[..len], [0x20, 0x00, 0x04, 0x11, 0x13, 0x00, 0xC8]);
//! assert_eq!(ParamBlock::decode(&bytes[..len]), Ok(ParamBlock::XON_XOFF_DEFAULT));
//! ```

use crate::range::RangeError;
use crate::time::Duration;
use serde::{Deserialize, Serialize};

/// One step of the blocks' times: 10 ms.
pub const TEN_MS: Duration = Duration::from_millis(10);

/// The longest time a block carries: 65 535 × 10 ms = 655 350 ms, the "10 min 55 s 350 ms" of
/// the FBs' TIME inputs (`[ET200S SI]` §2.10, Tables 2-15 to 2-17).
pub const MAX_TIME: Duration = Duration::from_millis(655_350);

/// The shortest wait for XON after XOFF and for CTS = ON: 20 ms, a count of 2
/// (`[ET200S SI]` §2.10, Tables 2-15 and 2-16; Table 2-26).
pub const MIN_WAIT: Duration = Duration::from_millis(20);

/// A TIME as a count of 10 ms, checked against `min ..= 655 350 ms` and the 10 ms grid
/// (`[ET200S SI]` §2.12, Table 2-26: "20 … 655 350 ms in 10 ms steps"; §2.10, Tables 2-15 to
/// 2-17 for the FB inputs).
///
/// A time off the 10 ms grid is refused rather than rounded `[derived]`: the manual gives the
/// ranges "in 10 ms steps" and leaves open whether other values are rounded or rejected;
/// refusing keeps the time the module uses equal to the time the user wrote, and matches the
/// ASCII driver's own parameter check. The error names `parameter`, the range and the value.
///
/// ```
/// use si_core::param_block::{ten_ms_count, MIN_WAIT};
/// use si_core::Duration;
///
/// assert_eq!(ten_ms_count("WAIT_FOR_XON", Duration::from_secs(2), MIN_WAIT), Ok(200));
/// assert!(ten_ms_count("WAIT_FOR_XON", Duration::from_millis(10), MIN_WAIT).is_err());
/// assert!(ten_ms_count("TIME_RTS_OFF", Duration::from_millis(5), Duration::ZERO).is_err());
/// ```
pub fn ten_ms_count(
    parameter: &'static str,
    time: Duration,
    min: Duration,
) -> Result<u16, RangeError> {
    let us = time.as_micros();
    let step = TEN_MS.as_micros();
    let count = u16::try_from(us / step).ok();
    match count {
        Some(count) if time >= min && time <= MAX_TIME && us.is_multiple_of(step) => Ok(count),
        // A whole number of milliseconds is named as one with its unit, as every other range
        // error names its value; a finer time prints as the duration it is.
        _ if us.is_multiple_of(1_000) => Err(RangeError::new(
            parameter,
            ten_ms_range(min),
            " ms",
            time.as_millis(),
        )),
        _ => Err(RangeError::new(parameter, ten_ms_range(min), "", time)),
    }
}

fn ten_ms_range(min: Duration) -> String {
    format!(
        "{} … {} ms in 10 ms steps",
        min.as_millis(),
        MAX_TIME.as_millis()
    )
}

/// The TIME a count of 10 ms stands for (`[ET200S SI]` §2.12, Table 2-26).
pub const fn ten_ms_time(count: u16) -> Duration {
    Duration::from_millis(count as u64 * 10)
}

/// A flow-control parameter block (`[ET200S SI]` §2.12, Table 2-26). Times are raw counts of
/// 10 ms, exactly as they cross the wire: 200 = 2 s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ParamBlock {
    /// Block 20H, XON/XOFF (S_XON): XON and XOFF characters, wait time for XON after XOFF.
    XonXoff {
        /// XON character, default DC1 = 11H.
        xon: u8,
        /// XOFF character, default DC3 = 13H.
        xoff: u8,
        /// Wait for XON after XOFF, 10 ms units, 2 … 65535 (default 200 = 2 s).
        xon_wait: u16,
    },
    /// Block 21H, RTS/CTS (S_RTS): wait time for CTS = ON.
    RtsCts {
        /// Wait for CTS = ON, 10 ms units, 2 … 65535 (default 200 = 2 s).
        cts_wait: u16,
    },
    /// Block 22H, automatic V.24 control (S_V24).
    AutoV24 {
        /// Time until RTS = OFF after the transmission, 10 ms units, 0 … 65535 (default 1).
        rts_off_delay: u16,
        /// Wait for CTS = ON after RTS = ON (the data output wait time), 10 ms units,
        /// 0 … 65535 (default 1).
        cts_wait: u16,
    },
}

/// Why a parameter stream is not a valid block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ParamError {
    /// The stream ends before the block does.
    #[error("parameter block truncated: {0} bytes")]
    Truncated(usize),
    /// Not 20H, 21H or 22H.
    #[error("unknown parameter block {0:02X}H (expected 20H, 21H or 22H)")]
    UnknownBlock(u8),
    /// The length word does not match the block's fixed length.
    #[error("parameter block {block:02X}H has length {len}, expected {expected}")]
    Length {
        /// Block number.
        block: u8,
        /// Length word received.
        len: u16,
        /// The block's fixed length.
        expected: u16,
    },
    /// A time below its minimum (XON and CTS waits: 2 × 10 ms).
    #[error("parameter block {block:02X}H: time {value} × 10 ms below the minimum 2 (20 ms)")]
    OutOfRange {
        /// Block number.
        block: u8,
        /// The raw value.
        value: u16,
    },
}

impl ParamBlock {
    /// The XON/XOFF defaults of Table 2-26: DC1 = 11H, DC3 = 13H, 2 s. The example (Table 2-27
    /// of `[ET200S SI]`, Table 2-28 of `[ET200S SI 2005]`) transmits 0BH/0DH (decimal 11/13) as
    /// "DC1/DC3"; ASCII says 11H/13H, which we use `[derived]`.
    pub const XON_XOFF_DEFAULT: ParamBlock = ParamBlock::XonXoff {
        xon: 0x11,
        xoff: 0x13,
        xon_wait: 200,
    };
    /// The RTS/CTS default: wait for CTS 2 s.
    pub const RTS_CTS_DEFAULT: ParamBlock = ParamBlock::RtsCts { cts_wait: 200 };
    /// The automatic V.24 default: 10 ms and 10 ms.
    pub const AUTO_V24_DEFAULT: ParamBlock = ParamBlock::AutoV24 {
        rts_off_delay: 1,
        cts_wait: 1,
    };

    /// Block number 20H/21H/22H.
    pub const fn number(&self) -> u8 {
        match self {
            ParamBlock::XonXoff { .. } => 0x20,
            ParamBlock::RtsCts { .. } => 0x21,
            ParamBlock::AutoV24 { .. } => 0x22,
        }
    }

    /// The fixed length word of a block number (bytes after the length field).
    pub const fn length_of(block: u8) -> Option<u16> {
        match block {
            0x20 | 0x22 => Some(4),
            0x21 => Some(2),
            _ => None,
        }
    }

    /// Bytes of the encoded block: 7 for 20H and 22H, 5 for 21H.
    pub const fn len(&self) -> usize {
        match self {
            ParamBlock::RtsCts { .. } => 5,
            _ => 7,
        }
    }

    /// Never empty; here for clippy's `len` convention.
    pub const fn is_empty(&self) -> bool {
        false
    }

    /// The parameter stream `[block][LEN_hi][LEN_lo][params …]` and its length (5 or 7 bytes;
    /// unused bytes are zero).
    pub fn encode(&self) -> ([u8; 7], usize) {
        let bytes = match *self {
            ParamBlock::XonXoff {
                xon,
                xoff,
                xon_wait,
            } => {
                let [hi, lo] = xon_wait.to_be_bytes();
                [0x20, 0, 4, xon, xoff, hi, lo]
            }
            ParamBlock::RtsCts { cts_wait } => {
                let [hi, lo] = cts_wait.to_be_bytes();
                [0x21, 0, 2, hi, lo, 0, 0]
            }
            ParamBlock::AutoV24 {
                rts_off_delay,
                cts_wait,
            } => {
                let [a, b] = rts_off_delay.to_be_bytes();
                let [c, d] = cts_wait.to_be_bytes();
                [0x22, 0, 4, a, b, c, d]
            }
        };
        (bytes, self.len())
    }

    /// Reads a block from the start of `stream` (trailing bytes, such as segment padding, are
    /// ignored) and checks its form: number, length word, enough bytes. The times' ranges are
    /// checked by [`check`](Self::check), or where the block is applied.
    pub fn decode(stream: &[u8]) -> Result<ParamBlock, ParamError> {
        let [block, lh, ll, rest @ ..] = stream else {
            return Err(ParamError::Truncated(stream.len()));
        };
        let expected = ParamBlock::length_of(*block).ok_or(ParamError::UnknownBlock(*block))?;
        let len = u16::from_be_bytes([*lh, *ll]);
        if len != expected {
            return Err(ParamError::Length {
                block: *block,
                len,
                expected,
            });
        }
        Ok(match (*block, rest) {
            (0x20, &[xon, xoff, h, l, ..]) => ParamBlock::XonXoff {
                xon,
                xoff,
                xon_wait: u16::from_be_bytes([h, l]),
            },
            (0x21, &[h, l, ..]) => ParamBlock::RtsCts {
                cts_wait: u16::from_be_bytes([h, l]),
            },
            (0x22, &[a, b, c, d, ..]) => ParamBlock::AutoV24 {
                rts_off_delay: u16::from_be_bytes([a, b]),
                cts_wait: u16::from_be_bytes([c, d]),
            },
            _ => return Err(ParamError::Truncated(stream.len())),
        })
    }

    /// The ranges of Table 2-26: the XON and CTS waits are at least 2 (20 ms); every other
    /// count of 0 … 65535 is valid.
    pub fn check(&self) -> Result<(), ParamError> {
        let value = match *self {
            ParamBlock::XonXoff { xon_wait, .. } => xon_wait,
            ParamBlock::RtsCts { cts_wait } => cts_wait,
            ParamBlock::AutoV24 { .. } => return Ok(()),
        };
        if value < 2 {
            return Err(ParamError::OutOfRange {
                block: self.number(),
                value,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Moved from si-ascii's frame module with the codec.
    #[test]
    fn table_2_27_xon_xoff_job_stream_decodes() {
        // The three 3-byte segments of Table 2-27: 20 00 04 | 0B 0D 00 | C8. The example prints
        // DC1/DC3 as 0BH/0DH (decimal 11/13); the block carries whatever bytes it holds.
        let stream = [0x20, 0x00, 0x04, 0x0B, 0x0D, 0x00, 0xC8, 0xEE, 0xEE];
        assert_eq!(
            ParamBlock::decode(&stream),
            Ok(ParamBlock::XonXoff {
                xon: 0x0B,
                xoff: 0x0D,
                xon_wait: 200
            })
        );
        assert_eq!(ten_ms_time(200), Duration::from_millis(2_000));
    }

    /// Moved from si-ascii's frame module with the codec.
    #[test]
    fn table_2_26_blocks_round_trip_with_defaults() {
        for block in [
            ParamBlock::XON_XOFF_DEFAULT,
            ParamBlock::RTS_CTS_DEFAULT,
            ParamBlock::AUTO_V24_DEFAULT,
        ] {
            let (bytes, len) = block.encode();
            assert_eq!(len, block.len());
            assert_eq!(ParamBlock::decode(&bytes[..len]), Ok(block));
        }
        assert_eq!(
            ParamBlock::RTS_CTS_DEFAULT.encode().0[..5],
            [0x21, 0x00, 0x02, 0x00, 0xC8]
        );
        assert_eq!(
            ParamBlock::AUTO_V24_DEFAULT.encode().0,
            [0x22, 0x00, 0x04, 0x00, 0x01, 0x00, 0x01]
        );
        assert_eq!(
            ParamBlock::decode(&[0x23, 0, 4]),
            Err(ParamError::UnknownBlock(0x23))
        );
        assert_eq!(
            ParamBlock::decode(&[0x21, 0, 4, 0, 0, 0, 0]),
            Err(ParamError::Length {
                block: 0x21,
                len: 4,
                expected: 2
            })
        );
        assert_eq!(
            ParamBlock::decode(&[0x20, 0, 4, 1]),
            Err(ParamError::Truncated(4))
        );
    }

    /// Moved from si-dp-coord's frame module with the codec; the range check is `check` now.
    #[test]
    fn parameter_blocks_of_table_2_27() {
        let (b, n) = ParamBlock::XON_XOFF_DEFAULT.encode();
        assert_eq!(&b[..n], [0x20, 0x00, 0x04, 0x11, 0x13, 0x00, 0xC8]);
        let (b, n) = ParamBlock::RTS_CTS_DEFAULT.encode();
        assert_eq!(&b[..n], [0x21, 0x00, 0x02, 0x00, 0xC8]);
        let (b, n) = ParamBlock::AUTO_V24_DEFAULT.encode();
        assert_eq!(&b[..n], [0x22, 0x00, 0x04, 0x00, 0x01, 0x00, 0x01]);
        assert!(matches!(
            ParamBlock::decode(&[0x21, 0, 4, 0, 0xC8, 0, 0]),
            Err(ParamError::Length { .. })
        ));
        // 1 × 10 ms reads as a block, but is below the 20 ms minimum.
        let short = ParamBlock::decode(&[0x21, 0, 2, 0, 1]).unwrap();
        assert_eq!(
            short.check(),
            Err(ParamError::OutOfRange {
                block: 0x21,
                value: 1
            })
        );
        assert_eq!(ParamBlock::AUTO_V24_DEFAULT.check(), Ok(()));
        assert_eq!(
            ParamBlock::AutoV24 {
                rts_off_delay: 0,
                cts_wait: 0
            }
            .check(),
            Ok(())
        );
        assert_eq!(
            ParamBlock::decode(&[0x20, 0]),
            Err(ParamError::Truncated(2))
        );
    }

    #[test]
    fn ten_ms_counts_within_the_manual_ranges() {
        let ms = Duration::from_millis;
        assert_eq!(ten_ms_count("T", ms(20), MIN_WAIT), Ok(2));
        assert_eq!(ten_ms_count("T", ms(655_350), MIN_WAIT), Ok(65_535));
        assert_eq!(ten_ms_count("T", Duration::ZERO, Duration::ZERO), Ok(0));
        let e = ten_ms_count("WAIT_FOR_CTS", ms(10), MIN_WAIT).unwrap_err();
        assert_eq!(e.parameter, "WAIT_FOR_CTS");
        assert_eq!(e.range, "20 … 655350 ms in 10 ms steps");
        assert!(ten_ms_count("T", ms(655_360), MIN_WAIT).is_err());
        assert!(ten_ms_count("T", Duration::from_secs(700), Duration::ZERO).is_err());
        // Off the 10 ms grid: refused, not rounded.
        assert!(ten_ms_count("T", ms(2_005), MIN_WAIT).is_err());
        assert!(ten_ms_count("T", Duration::from_micros(20_001), MIN_WAIT).is_err());
        for count in [0, 1, 2, 200, u16::MAX] {
            assert_eq!(
                ten_ms_count("T", ten_ms_time(count), Duration::ZERO),
                Ok(count)
            );
        }
    }

    proptest! {
        /// Moved from si-ascii's frame module with the codec.
        #[test]
        fn param_block_decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..12)) {
            if let Ok(block) = ParamBlock::decode(&bytes) {
                let (b, n) = block.encode();
                prop_assert_eq!(ParamBlock::decode(&b[..n]), Ok(block));
            }
        }
    }
}
