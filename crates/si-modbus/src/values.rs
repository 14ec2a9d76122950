//! Register values as a user reads them: 16-bit registers on the wire, high byte first
//! ([Modbus/USS] §3.4.5–§3.4.16; S7 WORDs are big-endian), shown one by one or joined in pairs
//! into 32-bit numbers and floats, or as characters. What two registers mean together is left
//! to the devices: the common convention (Modicon, and mbpoll's default) puts the high word
//! first ([`WordOrder::Big`]); many devices send the low word first ([`WordOrder::Swapped`]).

use std::str::FromStr;

/// How each register (or pair of registers) is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ValueFormat {
    /// Each register as 4 hex digits (`0x4049`).
    Hex,
    /// Each register as an unsigned decimal number (the default).
    #[default]
    U16,
    /// Each register as a signed (two's complement) decimal number.
    I16,
    /// Two registers as one unsigned 32-bit number (see [`WordOrder`]).
    U32,
    /// Two registers as one signed 32-bit number (see [`WordOrder`]).
    I32,
    /// Two registers as one IEEE 754 single-precision float (see [`WordOrder`]).
    F32,
    /// Two characters per register, high byte first, as one quoted string; bytes outside
    /// printable ASCII are written as `\xNN`.
    Ascii,
}

/// Which register of a pair holds the high 16 bits (32-bit formats only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WordOrder {
    /// High word first, at the lower address (Modicon convention, the default).
    #[default]
    Big,
    /// Low word first, at the lower address ("word swapped").
    Swapped,
}

impl ValueFormat {
    /// Every format, in the order [`NAMES`](Self::NAMES) names them.
    pub const ALL: [ValueFormat; 7] = [
        ValueFormat::Hex,
        ValueFormat::U16,
        ValueFormat::I16,
        ValueFormat::U32,
        ValueFormat::I32,
        ValueFormat::F32,
        ValueFormat::Ascii,
    ];

    /// The formats' names.
    pub const NAMES: [&'static str; 7] = ["hex", "u16", "i16", "u32", "i32", "f32", "ascii"];

    /// How many registers one value takes.
    pub fn registers_per_value(self) -> u16 {
        match self {
            ValueFormat::U32 | ValueFormat::I32 | ValueFormat::F32 => 2,
            _ => 1,
        }
    }

    /// The format's name (`f32`).
    pub fn name(self) -> &'static str {
        let i = Self::ALL.iter().position(|f| *f == self).unwrap_or(0);
        Self::NAMES[i]
    }
}

impl FromStr for ValueFormat {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let i = Self::NAMES
            .iter()
            .position(|n| *n == text)
            .ok_or_else(|| format!("format {text:?}: one of {}", Self::NAMES.join(", ")))?;
        Ok(Self::ALL[i])
    }
}

impl WordOrder {
    /// The orders' names.
    pub const NAMES: [&'static str; 2] = ["big", "swapped"];

    /// The order's name (`big`, `swapped`).
    pub fn name(self) -> &'static str {
        match self {
            WordOrder::Big => "big",
            WordOrder::Swapped => "swapped",
        }
    }
}

impl FromStr for WordOrder {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "big" => Ok(WordOrder::Big),
            "swapped" => Ok(WordOrder::Swapped),
            _ => Err(format!("word order {text:?}: big or swapped")),
        }
    }
}

/// One shown value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A register in hex.
    Hex(u16),
    /// An unsigned number (u16, u32).
    Unsigned(u32),
    /// A signed number (i16, i32).
    Signed(i32),
    /// A float (f32).
    Float(f32),
    /// Characters (ascii), already escaped.
    Text(String),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Hex(v) => write!(f, "0x{v:04X}"),
            Value::Unsigned(v) => write!(f, "{v}"),
            Value::Signed(v) => write!(f, "{v}"),
            // Rust prints the shortest text that reads back as the same f32: 3.1415927.
            Value::Float(v) => write!(f, "{v}"),
            Value::Text(t) => write!(f, "\"{t}\""),
        }
    }
}

/// Two registers as they came, lower address first, joined into 32 bits in `order`.
pub fn join(first: u16, second: u16, order: WordOrder) -> u32 {
    let (high, low) = match order {
        WordOrder::Big => (first, second),
        WordOrder::Swapped => (second, first),
    };
    (u32::from(high) << 16) | u32::from(low)
}

/// The registers shown in `format`. A 32-bit format takes them in pairs (a last odd register
/// is left out: a caller refuses an odd count before the read); `ascii`
/// gives one value for all of them.
pub fn show(regs: &[u16], format: ValueFormat, order: WordOrder) -> Vec<Value> {
    let pairs = || regs.chunks_exact(2).map(|p| join(p[0], p[1], order));
    match format {
        ValueFormat::Hex => regs.iter().map(|&r| Value::Hex(r)).collect(),
        ValueFormat::U16 => regs.iter().map(|&r| Value::Unsigned(r.into())).collect(),
        ValueFormat::I16 => regs
            .iter()
            .map(|&r| Value::Signed(i16::from_be_bytes(r.to_be_bytes()).into()))
            .collect(),
        ValueFormat::U32 => pairs().map(Value::Unsigned).collect(),
        ValueFormat::I32 => pairs()
            .map(|v| Value::Signed(i32::from_be_bytes(v.to_be_bytes())))
            .collect(),
        ValueFormat::F32 => pairs().map(|v| Value::Float(f32::from_bits(v))).collect(),
        ValueFormat::Ascii => vec![Value::Text(ascii(regs))],
    }
}

/// Two characters per register, high byte first; `"` and `\` escaped, bytes outside printable
/// ASCII as `\xNN`, so the text is unambiguous and shows every byte.
fn ascii(regs: &[u16]) -> String {
    let mut text = String::with_capacity(regs.len() * 2);
    for byte in regs.iter().flat_map(|r| r.to_be_bytes()) {
        match byte {
            b'"' => text.push_str("\\\""),
            b'\\' => text.push_str("\\\\"),
            0x20..=0x7E => text.push(char::from(byte)),
            _ => text.push_str(&format!("\\x{byte:02X}")),
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shown(regs: &[u16], format: ValueFormat, order: WordOrder) -> Vec<String> {
        show(regs, format, order)
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    #[test]
    fn pi_reads_the_same_from_either_word_order() {
        // 0x40490FDB is the f32 nearest to π.
        let big = shown(&[0x4049, 0x0FDB], ValueFormat::F32, WordOrder::Big);
        let swapped = shown(&[0x0FDB, 0x4049], ValueFormat::F32, WordOrder::Swapped);
        assert_eq!(big, ["3.1415927"]);
        assert_eq!(swapped, big);
        // The other order reads other bits.
        let wrong = shown(&[0x0FDB, 0x4049], ValueFormat::F32, WordOrder::Big);
        assert_ne!(wrong, big);
    }

    #[test]
    fn sixteen_bit_formats_show_each_register() {
        let regs = [0x0000, 0x7FFF, 0x8000, 0xFFFF];
        assert_eq!(
            shown(&regs, ValueFormat::U16, WordOrder::Big),
            ["0", "32767", "32768", "65535"]
        );
        assert_eq!(
            shown(&regs, ValueFormat::I16, WordOrder::Big),
            ["0", "32767", "-32768", "-1"]
        );
        assert_eq!(
            shown(&regs, ValueFormat::Hex, WordOrder::Swapped),
            ["0x0000", "0x7FFF", "0x8000", "0xFFFF"]
        );
    }

    #[test]
    fn thirty_two_bit_formats_join_pairs_in_the_word_order() {
        let regs = [0x0001, 0x0002, 0xFFFF, 0xFFFE];
        assert_eq!(
            shown(&regs, ValueFormat::U32, WordOrder::Big),
            ["65538", "4294967294"]
        );
        assert_eq!(
            shown(&regs, ValueFormat::U32, WordOrder::Swapped),
            ["131073", "4294901759"]
        );
        assert_eq!(
            shown(&regs, ValueFormat::I32, WordOrder::Big),
            ["65538", "-2"]
        );
        assert_eq!(
            shown(&regs, ValueFormat::I32, WordOrder::Swapped),
            ["131073", "-65537"]
        );
    }

    #[test]
    fn ascii_is_high_byte_first_with_escapes() {
        // "Hi", "!\0", then a quote and a backslash.
        let regs = [0x4869, 0x2100, 0x225C];
        assert_eq!(
            shown(&regs, ValueFormat::Ascii, WordOrder::Big),
            [r#""Hi!\x00\"\\""#]
        );
    }
}
