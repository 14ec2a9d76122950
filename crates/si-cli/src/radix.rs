//! Numbers as the user types and reads them: one radix convention for every command that takes
//! it ("one radix convention on input and output").
//!
//! - **Input:** decimal by default; hex after `0x` (`0x047F`) or in the manuals' notation
//!   `16#047F`; a leading `-` where a value may be negative (`-5`, `-0x10`).
//! - **Output:** decimal by default; [`show`] writes `16#…` (at least four digits) when the user
//!   asked for hex (`--hex`).
//!
//! A leaf module: it imports nothing of the crate, so every command may use it. Errors are plain
//! strings, as clap's value parsers want them.

/// `text` as an unsigned number: decimal, or hex after `0x`, `0X` or `16#`.
pub fn unsigned(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let hex = t
        .strip_prefix("0x")
        .or_else(|| t.strip_prefix("0X"))
        .or_else(|| t.strip_prefix("16#"));
    let parsed = match hex {
        Some(h) => u64::from_str_radix(h, 16),
        None => t.parse(),
    };
    parsed.map_err(|_| format!("{text:?} is not a number (decimal, or hex with 0x or 16#)"))
}

/// `text` as a number with an optional leading `-`, within `min …= max`.
pub fn signed(text: &str, min: i64, max: i64) -> Result<i64, String> {
    let t = text.trim();
    let (negative, magnitude) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t),
    };
    let m = unsigned(magnitude).map_err(|_| {
        format!("{text:?} is not a number (decimal, or hex with 0x or 16#, optionally with -)")
    })?;
    let value = i64::try_from(m)
        .ok()
        .map(|m| if negative { -m } else { m })
        .filter(|v| (min..=max).contains(v));
    value.ok_or_else(|| format!("{text} is out of range: {min} … {max}"))
}

/// `text` as an unsigned number within `0 …= max`.
pub fn bounded(text: &str, max: u64) -> Result<u64, String> {
    let v = unsigned(text)?;
    if v <= max {
        Ok(v)
    } else {
        Err(format!("{text} is out of range: 0 … {max}"))
    }
}

/// A clap value parser for a byte (node numbers).
pub fn u8_arg(text: &str) -> Result<u8, String> {
    bounded(text, u8::MAX.into()).map(|v| v as u8)
}

/// A clap value parser for a word (control words, setpoints as bit patterns).
pub fn u16_arg(text: &str) -> Result<u16, String> {
    bounded(text, u16::MAX.into()).map(|v| v as u16)
}

/// A clap value parser for a word that may also be given as a negative number: its 16-bit
/// two's complement (−32 768 … 65 535).
pub fn word_arg(text: &str) -> Result<u16, String> {
    signed(text, i16::MIN.into(), u16::MAX.into()).map(|v| v as u16)
}

/// `value` for the user: decimal, or with `hex` as `16#` and at least four hex digits.
pub fn show(value: impl Into<i64>, hex: bool) -> String {
    let v: i64 = value.into();
    match (hex, v < 0) {
        (false, _) => v.to_string(),
        (true, false) => format!("16#{v:04X}"),
        (true, true) => format!("-16#{:04X}", v.unsigned_abs()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_by_default_hex_with_0x_or_16_hash() {
        assert_eq!(unsigned("1151"), Ok(1151));
        assert_eq!(unsigned("0x047F"), Ok(0x047F));
        assert_eq!(unsigned("16#047F"), Ok(0x047F));
        assert_eq!(unsigned("0X7f"), Ok(0x7F));
        assert!(unsigned("047F").is_err(), "bare hex is not decimal");
        assert!(unsigned("-1").is_err());
    }

    #[test]
    fn signed_values_and_their_ranges() {
        assert_eq!(signed("-5", -10, 10), Ok(-5));
        assert_eq!(signed("-0x10", -100, 100), Ok(-16));
        assert_eq!(
            signed("-11", -10, 10),
            Err("-11 is out of range: -10 … 10".to_owned())
        );
        assert_eq!(word_arg("-5"), Ok(0xFFFB));
        assert_eq!(word_arg("65535"), Ok(0xFFFF));
        assert!(word_arg("-32769").is_err());
        assert!(u16_arg("65536").unwrap_err().contains("0 … 65535"));
        assert_eq!(u8_arg("16#1F"), Ok(31));
    }

    #[test]
    fn output_is_decimal_unless_hex_is_asked_for() {
        assert_eq!(show(1151u16, false), "1151");
        assert_eq!(show(1151u16, true), "16#047F");
        assert_eq!(show(-5i32, false), "-5");
        assert_eq!(show(-5i32, true), "-16#0005");
        assert_eq!(show(0x12345u32, true), "16#12345");
    }
}
