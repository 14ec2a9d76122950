//! How register values are shown on the command line (`si modbus read --format …
//! --word-order …`): the values are si-modbus's (`si_modbus::values`); this checks the count
//! against the format and writes a value in JSON.

use serde_json::Value as Json;
use si_modbus::values::{Value, ValueFormat};

/// A usage error when `count` registers do not split into whole values (an odd count with
/// a 32-bit format).
pub fn check_count(format: ValueFormat, count: u16) -> Result<(), String> {
    let per = format.registers_per_value();
    if count.is_multiple_of(per) {
        Ok(())
    } else {
        Err(format!(
            "--format {} takes {per} registers per value, and --count {count} is odd: \
             read an even number of registers",
            format.name()
        ))
    }
}

/// The value in JSON: numbers as numbers (a float with the digits the text shows, NaN and
/// infinities as null), hex and text as strings.
pub fn json(value: &Value) -> Json {
    match value {
        Value::Hex(_) => Json::String(value.to_string()),
        Value::Unsigned(v) => Json::from(*v),
        Value::Signed(v) => Json::from(*v),
        Value::Float(v) => v
            .to_string()
            .parse::<f64>()
            .ok()
            .and_then(serde_json::Number::from_f64)
            .map_or(Json::Null, Json::Number),
        Value::Text(t) => Json::String(t.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_modbus::values::{show, WordOrder};

    #[test]
    fn an_odd_count_with_a_32_bit_format_is_refused_naming_the_count() {
        let e = check_count(ValueFormat::F32, 3).unwrap_err();
        assert!(e.contains("--count 3") && e.contains("f32"), "{e}");
        assert!(check_count(ValueFormat::U32, 4).is_ok());
        assert!(check_count(ValueFormat::I16, 3).is_ok());
    }

    #[test]
    fn json_keeps_numbers_as_numbers_with_the_shown_digits() {
        let pi = show(&[0x4049, 0x0FDB], ValueFormat::F32, WordOrder::Big);
        assert_eq!(json(&pi[0]).to_string(), "3.1415927");
        let nan = show(&[0x7FC0, 0x0000], ValueFormat::F32, WordOrder::Big);
        assert_eq!(json(&nan[0]), Json::Null);
        assert_eq!(json(&Value::Hex(0x10)), Json::from("0x0010"));
        assert_eq!(json(&Value::Signed(-2)), Json::from(-2));
    }
}
