//! RS-485 direction control: [`Rs485`], what [`PortOptions`](super::PortOptions) takes, and
//! [`Rs485Mode`], its kinds by name (`kernel`, `rts`, `rts-inverted`, `sysfs`,
//! `sysfs-inverted`), the names a command line, a profile or a gateway file gives.
//! [`Rs485Mode::control`] adds the file and the delays and makes the [`Rs485`].

use super::tx_enable::TxEnable;
use crate::driver::RtsToggle;
use crate::time::Duration;
use core::fmt;
use core::str::FromStr;
use std::path::PathBuf;

/// Who switches an RS-485 transceiver between sending and receiving; [`Rs485Mode`] names the
/// kinds and builds one from its name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Rs485 {
    /// The kernel's RS-485 mode (Linux `TIOCSRS485`): the UART driver raises RTS for each
    /// transmission, with these delays in whole milliseconds (the kernel's unit).
    Kernel {
        /// RTS on this long before the first bit.
        delay_before: Duration,
        /// RTS kept on this long after the last bit.
        delay_after: Duration,
    },
    /// The driver switches the transceiver itself around each write ([`RtsToggle`]): for
    /// adapters and kernels without RS-485 mode. Less exact (user-space timing, "Timing,
    /// honestly" in the driver docs).
    Driver {
        /// The waits before the first byte and after tx-done.
        toggle: RtsToggle,
        /// The output that enables the transmitter: RTS either polarity or a file such as
        /// a GPIO's sysfs `value` (mbusd's `-t`, `-r`, `-y`, `-Y`).
        output: TxEnable,
    },
}

/// Who switches the transceiver, without the file and the delays: the kernel, or the driver
/// through RTS (either polarity) or a file (either polarity), as mbusd's `-t`, `-r`, `-y`, `-Y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rs485Mode {
    /// The kernel's RS-485 mode (Linux `TIOCSRS485`, where the port's driver has it).
    Kernel,
    /// The driver raises RTS before each transmission and drops it after (mbusd `-t`).
    Rts,
    /// The driver drops RTS to transmit and raises it after (mbusd `-r`).
    RtsInverted,
    /// The driver writes `1` to a file to transmit and `0` after (mbusd `-y`).
    Sysfs,
    /// The driver writes `0` to a file to transmit and `1` after (mbusd `-Y`).
    SysfsInverted,
}

impl Rs485Mode {
    /// Every mode, in the order [`Rs485Mode::NAMES`] lists them.
    pub const ALL: [Rs485Mode; 5] = [
        Rs485Mode::Kernel,
        Rs485Mode::Rts,
        Rs485Mode::RtsInverted,
        Rs485Mode::Sysfs,
        Rs485Mode::SysfsInverted,
    ];

    /// Every name, for an error or a help text that lists them.
    pub const NAMES: &'static str = "kernel, rts, rts-inverted, sysfs, sysfs-inverted";

    /// The name as typed (`rts-inverted`).
    pub const fn name(self) -> &'static str {
        match self {
            Rs485Mode::Kernel => "kernel",
            Rs485Mode::Rts => "rts",
            Rs485Mode::RtsInverted => "rts-inverted",
            Rs485Mode::Sysfs => "sysfs",
            Rs485Mode::SysfsInverted => "sysfs-inverted",
        }
    }

    /// Whether this mode writes a file (the file kinds of [`TxEnable`]).
    pub const fn needs_file(self) -> bool {
        matches!(self, Rs485Mode::Sysfs | Rs485Mode::SysfsInverted)
    }

    /// The direction control for this mode: the transmitter on `before` the first bit and
    /// kept on `after` the last (whole milliseconds for the kernel), written to `file` for
    /// the file modes. A file mode without a file is refused; a file given to another mode is
    /// ignored (a caller that wants to refuse it checks [`Rs485Mode::needs_file`]).
    pub fn control(
        self,
        file: Option<PathBuf>,
        before: Duration,
        after: Duration,
    ) -> Result<Rs485, Rs485ModeError> {
        let output = match (self, file) {
            (Rs485Mode::Kernel, _) => {
                return Ok(Rs485::Kernel {
                    delay_before: before,
                    delay_after: after,
                })
            }
            (Rs485Mode::Rts, _) => TxEnable::Rts,
            (Rs485Mode::RtsInverted, _) => TxEnable::RtsInverted,
            (Rs485Mode::Sysfs, Some(file)) => TxEnable::File(file),
            (Rs485Mode::SysfsInverted, Some(file)) => TxEnable::FileInverted(file),
            (mode, None) => return Err(Rs485ModeError::MissingFile(mode)),
        };
        Ok(Rs485::Driver {
            toggle: RtsToggle { before, after },
            output,
        })
    }
}

impl fmt::Display for Rs485Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is no mode, or a file mode without its file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Rs485ModeError {
    /// Not one of [`Rs485Mode::NAMES`]; the value as given.
    #[error("RS-485 mode {0:?} unknown; expected one of {names}", names = Rs485Mode::NAMES)]
    Unknown(String),
    /// [`Rs485Mode::Sysfs`] or [`Rs485Mode::SysfsInverted`] without the file to write.
    #[error("RS-485 mode {0} needs a file to write '1'/'0' to")]
    MissingFile(Rs485Mode),
}

/// The mode by its name, exactly as [`Rs485Mode::name`] spells it.
impl FromStr for Rs485Mode {
    type Err = Rs485ModeError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Rs485Mode::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| Rs485ModeError::Unknown(s.to_owned()))
    }
}

/// From its name in a file (`rs485 = "rts-inverted"`); the error lists the names.
impl<'de> serde::Deserialize<'de> for Rs485Mode {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = <std::borrow::Cow<'de, str>>::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

/// As its name.
impl serde::Serialize for Rs485Mode {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_mode_parses_from_its_name_and_names_list_them_all() {
        for mode in Rs485Mode::ALL {
            assert_eq!(mode.name().parse::<Rs485Mode>(), Ok(mode));
            assert_eq!(mode.to_string(), mode.name());
        }
        let listed: Vec<&str> = Rs485Mode::ALL.iter().map(|m| m.name()).collect();
        assert_eq!(listed.join(", "), Rs485Mode::NAMES);
    }

    #[test]
    fn an_unknown_name_is_named_with_the_accepted_ones() {
        let e = "RTS".parse::<Rs485Mode>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "RS-485 mode \"RTS\" unknown; expected one of kernel, rts, rts-inverted, sysfs, \
             sysfs-inverted"
        );
    }

    #[test]
    fn control_builds_each_kind_and_a_file_mode_needs_its_file() {
        let (b, a) = (Duration::from_millis(1), Duration::from_millis(2));
        assert_eq!(
            Rs485Mode::Kernel.control(None, b, a),
            Ok(Rs485::Kernel {
                delay_before: b,
                delay_after: a
            })
        );
        let toggle = RtsToggle {
            before: b,
            after: a,
        };
        assert_eq!(
            Rs485Mode::RtsInverted.control(None, b, a),
            Ok(Rs485::Driver {
                toggle,
                output: TxEnable::RtsInverted
            })
        );
        let file = PathBuf::from("/sys/class/gpio/gpio17/value");
        assert_eq!(
            Rs485Mode::SysfsInverted.control(Some(file.clone()), b, a),
            Ok(Rs485::Driver {
                toggle,
                output: TxEnable::FileInverted(file)
            })
        );
        let e = Rs485Mode::Sysfs.control(None, b, a).unwrap_err();
        assert_eq!(e, Rs485ModeError::MissingFile(Rs485Mode::Sysfs));
        assert_eq!(
            e.to_string(),
            "RS-485 mode sysfs needs a file to write '1'/'0' to"
        );
    }
}
