//! One error for a configuration value outside the manual's range, shared by every crate's
//! configuration (ARCHITECTURE.md, "Time and timers": an out-of-range value is rejected with an
//! error that names the parameter, the range and the value).
//!
//! Each crate's `ConfigError` carries a [`RangeError`] for its range checks (and its own
//! variants for what is not a range: two parameters not allowed together, a STATUS the module
//! reports), so a user reads every range error the same way:
//!
//! ```
//! use si_core::RangeError;
//!
//! let e = RangeError::between("character delay time (ZVZ)", 20, 655_350, " ms", 5);
//! assert_eq!(e.to_string(), "character delay time (ZVZ) = 5 ms is out of range: 20 … 655350 ms");
//! assert_eq!((e.parameter, e.unit, e.value.as_str()), ("character delay time (ZVZ)", " ms", "5"));
//! ```

use std::borrow::Cow;
use std::fmt::Display;

/// A parameter outside its range: the manual's name of the parameter, the allowed values as
/// the manual writes them, the unit, and the value given.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{parameter} = {value}{unit} is out of range: {range}")]
pub struct RangeError {
    /// The parameter's name as the manual gives it.
    pub parameter: &'static str,
    /// The allowed values, with their unit and any condition (`20 … 655350 ms`,
    /// `34 … 65535 ms at 1200 bit/s`, `0, 3, 4 or 127`).
    pub range: Cow<'static, str>,
    /// The unit of the value, with its leading space (empty for counts and codes).
    pub unit: &'static str,
    /// The value given, without its unit.
    pub value: String,
}

impl RangeError {
    /// `parameter` = `value` (in `unit`) is not one of `range`.
    pub fn new(
        parameter: &'static str,
        range: impl Into<Cow<'static, str>>,
        unit: &'static str,
        value: impl Display,
    ) -> RangeError {
        RangeError {
            parameter,
            range: range.into(),
            unit,
            value: value.to_string(),
        }
    }

    /// `parameter` = `value` is outside `min … max` (both in `unit`).
    pub fn between(
        parameter: &'static str,
        min: impl Display,
        max: impl Display,
        unit: &'static str,
        value: impl Display,
    ) -> RangeError {
        RangeError::new(parameter, format!("{min} … {max}{unit}"), unit, value)
    }

    /// `Err` naming `parameter` unless `min <= value <= max`.
    pub fn check<T: PartialOrd + Display>(
        parameter: &'static str,
        (min, max): (T, T),
        unit: &'static str,
        value: T,
    ) -> Result<(), RangeError> {
        if min <= value && value <= max {
            Ok(())
        } else {
            Err(RangeError::between(parameter, min, max, unit, value))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_accepts_the_bounds_and_names_what_is_outside() {
        assert!(RangeError::check("attempts", (1u32, 255), "", 1).is_ok());
        assert!(RangeError::check("attempts", (1u32, 255), "", 255).is_ok());
        let e = RangeError::check("attempts", (1u32, 255), "", 0).unwrap_err();
        assert_eq!(e.to_string(), "attempts = 0 is out of range: 1 … 255");
        let e = RangeError::new("PKW words", "0, 3, 4 or 127", "", 5);
        assert_eq!(
            e.to_string(),
            "PKW words = 5 is out of range: 0, 3, 4 or 127"
        );
    }
}
