//! Hex byte strings as people type them: `02 0E 00`, `020E00`, `0x02,0x0E`, `02:0e`.
//!
//! ```
//! assert_eq!(si_core::hex::parse("0x02, 0x0E 10").unwrap(), vec![0x02, 0x0E, 0x10]);
//! let err = si_core::hex::parse("02 0G").unwrap_err();
//! assert_eq!(err.to_string(), "invalid hex digit 'G' at position 5 (1-based)");
//! assert_eq!(si_core::hex::format(&[0x02, 0x10]), "02 10");
//! ```

use core::fmt::Write;

/// Why a hex string could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HexError {
    /// A character that is neither a hex digit nor a separator.
    #[error("invalid hex digit {found:?} at position {position} (1-based)")]
    InvalidDigit {
        /// The offending character.
        found: char,
        /// Its position in the input, counting characters from 1.
        position: usize,
    },
    /// A byte with one digit only, where a separator splits digits unevenly.
    #[error("odd number of hex digits in the group ending at position {position} (1-based)")]
    OddDigits {
        /// Position of the group's last character.
        position: usize,
    },
}

/// Parse bytes from hex. Whitespace, `,`, `:` and `-` separate groups; a group may carry a `0x`
/// prefix or the manuals' `16#` (the SIMATIC notation, `16#0A`); each group needs an even
/// number of digits (`020E` is two bytes). Error positions count in the text as given.
pub fn parse(text: &str) -> Result<Vec<u8>, HexError> {
    let mut out = Vec::with_capacity(text.len() / 2);
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_whitespace() || matches!(c, ',' | ':' | '-') {
            i += 1;
            continue;
        }
        // One group: optional 0x, then hex digits up to a separator.
        if c == '0' && matches!(chars.get(i + 1), Some('x' | 'X')) {
            i += 2;
        } else if chars[i..].starts_with(&['1', '6', '#']) {
            i += 3;
        }
        let mut high: Option<u8> = None;
        while i < chars.len() && !(chars[i].is_whitespace() || matches!(chars[i], ',' | ':' | '-'))
        {
            let d = chars[i].to_digit(16).ok_or(HexError::InvalidDigit {
                found: chars[i],
                position: i + 1,
            })? as u8;
            match high.take() {
                Some(h) => out.push(h << 4 | d),
                None => high = Some(d),
            }
            i += 1;
        }
        if high.is_some() {
            return Err(HexError::OddDigits { position: i });
        }
    }
    Ok(out)
}

/// Bytes as upper-case hex pairs separated by spaces.
pub fn format(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{b:02X}");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn accepts_the_three_spellings() {
        let want = vec![0x02, 0x0E, 0x00];
        assert_eq!(parse("02 0E 00").unwrap(), want);
        assert_eq!(parse("020E00").unwrap(), want);
        assert_eq!(parse("0x02,0x0E,0x00").unwrap(), want);
        assert_eq!(parse("").unwrap(), Vec::<u8>::new());
    }

    #[test]
    fn errors_name_the_position() {
        assert_eq!(
            parse("020").unwrap_err(),
            HexError::OddDigits { position: 3 }
        );
        assert_eq!(
            parse("0x02,0xZZ").unwrap_err(),
            HexError::InvalidDigit {
                found: 'Z',
                position: 8
            }
        );
    }

    proptest! {
        #[test]
        fn format_then_parse_round_trips(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            prop_assert_eq!(parse(&format(&bytes)).unwrap(), bytes);
        }

        #[test]
        fn parse_never_panics(text in ".{0,40}") {
            let _ = parse(&text);
        }
    }

    #[test]
    fn a_group_may_lead_with_16_hash_as_the_manuals_write_it() {
        assert_eq!(parse("16#01 16#0210,03").unwrap(), [0x01, 0x02, 0x10, 0x03]);
        let e = parse("16#0G").unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid hex digit 'G' at position 5 (1-based)"
        );
        // Inside a group `16#` is no prefix.
        assert!(parse("0116#02").is_err());
    }
}
