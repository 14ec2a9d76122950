//! Keyword arguments to si's configs: float seconds to [`Duration`], names to enums, Python
//! ints narrowed with the parameter named. The ranges themselves are the configs' own
//! (`validate`), checked when the handle is built.

use crate::errors::{argument_error, range_error};
use pyo3::prelude::*;
use si_core::port::PortOptions;
use si_core::{Duration, Parity, SerialSettings, SettingsError};

/// The character format from its keyword arguments (any of the module's twelve baud rates).
pub fn settings(
    baud: i64,
    data_bits: i64,
    parity: &str,
    stop_bits: i64,
) -> PyResult<SerialSettings> {
    let baud = narrow::<u32>("baud", baud)?;
    let data_bits = narrow::<u8>("data_bits", data_bits)?;
    let stop_bits = narrow::<u8>("stop_bits", stop_bits)?;
    let parity: Parity = parity.parse().map_err(|e| settings_error(&e))?;
    SerialSettings::new(baud, data_bits, parity, stop_bits).map_err(|e| settings_error(&e))
}

pub fn settings_error(e: &SettingsError) -> PyErr {
    let range = si_core::RangeError::new(
        match e {
            SettingsError::Baud { .. } => "baud",
            SettingsError::DataBits(_) => "data_bits",
            SettingsError::StopBits(_) => "stop_bits",
            SettingsError::Parity(_) => "parity",
        },
        match e {
            SettingsError::Baud { allowed, .. } => format!("{allowed:?} bit/s"),
            SettingsError::DataBits(_) => "7 or 8".to_owned(),
            SettingsError::StopBits(_) => "1 or 2".to_owned(),
            SettingsError::Parity(_) => "none, even, odd, mark, space (or any)".to_owned(),
        },
        "",
        match e {
            SettingsError::Baud { value, .. } => value.to_string(),
            SettingsError::DataBits(v) | SettingsError::StopBits(v) => v.to_string(),
            SettingsError::Parity(p) => format!("{p:?}"),
        },
    );
    range_error(&range, None)
}

/// `value` as the Rust integer type of `parameter`; outside that type's range a ConfigError.
pub fn narrow<T>(parameter: &str, value: i64) -> PyResult<T>
where
    T: TryFrom<i64> + num_bounds::Bounds,
{
    T::try_from(value)
        .map_err(|_| argument_error(parameter, &format!("{} … {}", T::MIN, T::MAX), value))
}

/// Float seconds as a [`Duration`] (microsecond resolution); negative, NaN or infinite is a
/// ConfigError naming `parameter`.
pub fn seconds(parameter: &str, value: f64) -> PyResult<Duration> {
    if (0.0..1.0e9).contains(&value) {
        Ok(Duration::from_micros((value * 1e6).round() as u64))
    } else {
        Err(argument_error(parameter, "0 … 1e9 s", value))
    }
}

/// The port options: `rx_latency` in float seconds declares how late the port hands bytes over
/// (0 for a pseudo-terminal or a port that delivers byte by byte; None: read from sysfs or
/// assume a USB adapter).
pub fn port_options(rx_latency: Option<f64>) -> PyResult<PortOptions> {
    Ok(PortOptions {
        rx_latency: rx_latency.map(|s| seconds("rx_latency", s)).transpose()?,
        ..PortOptions::default()
    })
}

/// The smallest and largest values of the integer types keyword arguments are narrowed to.
pub mod num_bounds {
    /// An integer type's bounds, printed in a ConfigError.
    pub trait Bounds {
        /// The smallest value.
        const MIN: i128;
        /// The largest value.
        const MAX: i128;
    }
    macro_rules! bounds {
        ($($t:ty),*) => {$(
            impl Bounds for $t {
                const MIN: i128 = <$t>::MIN as i128;
                const MAX: i128 = <$t>::MAX as i128;
            }
        )*};
    }
    bounds!(u8, u16, u32);
}
