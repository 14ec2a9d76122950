//! The ASCII driver's parameters with the manual's ranges and defaults
//! ([ET200S SI] §2.9, Table 2-10, §6.5, Table 2-9, §6.10 / §2.12 Table 2-26).
//!
//! [`Config::validate`] rejects a value outside its range with an error naming the parameter,
//! the range and the value. Times are whole milliseconds, as in the manual's tables.
//!
//! Readings chosen where the texts disagree:
//! - **Baud rates** ([ET200S SI] §2.9, Table 2-10 vs [ET200S SI 2005] Table 2-8): all twelve rates
//!   of the 2005 manual (110 … 115 200 bit/s) are accepted; the 2004 module stops at 19 200.
//! - **Minimum character delay time** ([ET200S SI] §2.8, Table 2-9 vs 2005 Table 2-7): for 110 … 19
//!   200 bit/s the ET 200S SI table (364, 134, 68, 34, 18, 9, 4, 4 ms) applies; above 19 200 the
//!   2005 table gives 1 ms, and the parameter range starts at 4 ms (`[derived]`), so 4 ms is the
//!   minimum there.
//! - **Maximum frame length**: a setting, [`Config::max_frame_len`], 1 … 1024 bytes, with the
//!   module presets of [`ModulePreset`]: 200 bytes for the ET 200S 1SI (the default, [ET200S SI]
//!   §2.10, Table 2-13, Table 2-14 Table 2-13/2-14 LEN 1 … 200, [ET200S SI] §2.14), 224 for the
//!   2005 module ([ET200S SI 2005] `[derived]`), 1024 for the CP 341 ([CP 341 Diag] 0517H "> 1
//!   KB"). 1024 is also the receive buffer ([ET200S SI] §2.8), which a frame must fit. The fixed
//!   receive length of [`EndCriterion::FixedLength`] ranges up to it (2005 manual Table 2-8: 1 …
//!   224; [CP 341] §2.3.3, Tables 2-7 to 2-11: 1 … 1024).
//! - **Time steps** (`[derived]`): the flow-control times are counts of 10 ms on the wire, so
//!   values that are not multiples of 10 ms are rejected rather than silently rounded.
//! - **End-of-text characters** (`[derived]`): two characters form a *sequence* (char 1 then char
//!   2, as on the CP 340/341); char 2 = 0 means "unused".

use crate::status;
use serde::{Deserialize, Serialize};
use si_core::param_block::{ten_ms_count, MIN_WAIT};
use si_core::{
    Duration, ModulePreset, RangeError, SerialSettings, SettingsError, Status, BAUD_RATES,
};

/// Longest frame of the ET 200S 1SI, the default of [`Config::max_frame_len`]
/// ([ET200S SI] §2.14: 200 bytes; [`ModulePreset::Et200s1Si`]).
pub const MAX_FRAME_LEN: usize = ModulePreset::Et200s1Si.max_frame_len() as usize;

/// The largest [`Config::max_frame_len`] allowed: 1024 bytes, the CP 341's limit
/// ([`ModulePreset::Cp341`]) and the size of the receive buffer a frame must fit.
pub const MAX_FRAME_LEN_LIMIT: usize = RECEIVE_BUFFER_SIZE;

/// Largest transmit chunk ([`Config::tx_chunk`]): the ET 200S frame, so a chunk never needs
/// more than one frame's worth of the driver's write buffer.
const MAX_TX_CHUNK: usize = MAX_FRAME_LEN;

/// Size of the receive ring buffer ([ET200S SI] §2.8: 1024 bytes).
pub const RECEIVE_BUFFER_SIZE: usize = 1024;

/// XOFF (or RTS = OFF) goes out when this many bytes or fewer are free in the receive buffer
/// ([ET200S SI] §2.8: "50 characters before the receive buffer is full").
pub const XOFF_MARGIN: usize = 50;

/// The physical interface (Table 2-10 "Interface type"), shared with the other drivers.
pub use si_core::Interface;

/// Data flow control (Table 2-10 "Data flow control", [ET200S SI] §2.8).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlowControl {
    /// No flow control (the default, and the only choice on RS-485).
    #[default]
    None,
    /// Software flow control with the XON and XOFF characters (RS-232C and RS-422).
    XonXoff,
    /// Hardware flow control with RTS and CTS (RS-232C only).
    RtsCts,
    /// Automatic operation of the V.24 signals: RTS on before, off after each frame (RS-232C only).
    AutoV24,
}

/// How the receiver recognises the end of a frame ([ET200S SI] §2.8, Table 2-10 "Indicator for end
/// of receive frame").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum EndCriterion {
    /// A gap longer than the character delay time ends the frame (code transparent).
    CharDelay,
    /// The end-of-text character `first`, followed by `second` unless it is 0 (not transparent).
    /// The delivered frame includes the end characters.
    EndChars {
        /// End-of-text character 1: 1 … 7FH (7 data bits) or 1 … FFH (8 data bits); default 03H.
        first: u8,
        /// End-of-text character 2: 0 = unused (the default), else the second of a sequence.
        second: u8,
    },
    /// A fixed number of characters, 1 … [`Config::max_frame_len`] (default 100), ends the frame
    /// (code transparent).
    FixedLength {
        /// Characters per frame.
        len: u16,
    },
}

impl Default for EndCriterion {
    /// "Expiration of character delay time" (Table 2-10 default).
    fn default() -> Self {
        EndCriterion::CharDelay
    }
}

impl EndCriterion {
    /// End-of-text characters with the manual's defaults: ETX (03H) alone.
    pub const DEFAULT_END_CHARS: EndCriterion = EndCriterion::EndChars {
        first: 0x03,
        second: 0,
    };
    /// Fixed length with the manual's default of 100 characters.
    pub const DEFAULT_FIXED: EndCriterion = EndCriterion::FixedLength { len: 100 };
}

/// XON/XOFF parameters (S_XON, Table 2-26 block 20H).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(default)]
pub struct XonXoff {
    /// XON character, default DC1 = 11H (`[derived]`: the 0BH of Table 2-27 is a decimal slip).
    pub xon: u8,
    /// XOFF character, default DC3 = 13H.
    pub xoff: u8,
    /// Wait time for XON after XOFF, 20 … 655 350 ms in 10 ms steps, default 2000 ms. In files
    /// `wait_for_xon_ms`.
    #[serde(rename = "wait_for_xon_ms", with = "si_core::time::millis")]
    pub wait_for_xon: Duration,
}

impl Default for XonXoff {
    fn default() -> Self {
        XonXoff {
            xon: 0x11,
            xoff: 0x13,
            wait_for_xon: Duration::from_millis(2_000),
        }
    }
}

/// RTS/CTS parameters (S_RTS, Table 2-26 block 21H).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(default)]
pub struct RtsCts {
    /// Wait time for CTS = ON, 20 … 655 350 ms in 10 ms steps, default 2000 ms. In files
    /// `wait_for_cts_ms`.
    #[serde(rename = "wait_for_cts_ms", with = "si_core::time::millis")]
    pub wait_for_cts: Duration,
}

impl Default for RtsCts {
    fn default() -> Self {
        RtsCts {
            wait_for_cts: Duration::from_millis(2_000),
        }
    }
}

/// Automatic V.24 parameters (S_V24, Table 2-26 block 22H): the sequence is shared with
/// Modbus and lives in si-core ([`si_core::v24`]).
pub use si_core::v24::AutoV24Times as AutoV24;

/// Every parameter of the ASCII driver (Table 2-10 plus the run-time blocks of Table 2-26).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(default)]
pub struct Config {
    /// Character format; default 9600 8E1.
    pub settings: SerialSettings,
    /// Interface type; default RS-232C.
    pub interface: Interface,
    /// Data flow control; default none.
    pub flow_control: FlowControl,
    /// End-of-frame criterion; default character delay time.
    pub end: EndCriterion,
    /// Character delay time, 4 … 65 535 ms and at least the Table 2-9 minimum for the baud rate;
    /// default 4 ms. Also the monitoring time of the other two criteria and the transmit
    /// inter-frame pause. In files `char_delay_ms`.
    #[serde(rename = "char_delay_ms", with = "si_core::time::millis")]
    pub char_delay: Duration,
    /// Buffer several frames of different lengths (true, the Table 2-10 default) or one.
    pub dynamic_frames: bool,
    /// Do not overwrite stored frames when the buffer is full (default yes).
    pub prevent_overwrite: bool,
    /// Clear the receive buffer at CPU startup (default yes).
    pub clear_at_startup: bool,
    /// Longest frame sent or received, 1 … [`MAX_FRAME_LEN_LIMIT`] bytes; default 200, the
    /// ET 200S 1SI's ([`Config::for_module`] sets it from a [`ModulePreset`]). A longer send job
    /// is refused (1E41H, the FB's LEN check); a longer received frame is discarded with 0850H.
    pub max_frame_len: u16,
    /// XON/XOFF parameters, used with [`FlowControl::XonXoff`].
    pub xon_xoff: XonXoff,
    /// RTS/CTS parameters, used with [`FlowControl::RtsCts`].
    pub rts_cts: RtsCts,
    /// Automatic V.24 parameters, used with [`FlowControl::AutoV24`].
    pub auto_v24: AutoV24,
    /// Host-side, not a module parameter: characters handed to the driver at once while a flow
    /// control is active, 1 … 200 (default 16).
    ///
    /// The module stops after the character on the line when XOFF or CTS = OFF arrives ([ET200S SI]
    /// §2.8). A host cannot: the OS buffers what it writes, and each hand-over costs a timer tick
    /// (about 1 ms under tokio) that shows up as a gap between characters, which a partner
    /// monitoring its character delay time may take for a frame end. 16 characters keep the
    /// overrun well inside the partner's 50-character XOFF margin and the gaps rare. Use 1 in
    /// simulation to model the module exactly.
    pub tx_chunk: u8,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            settings: SerialSettings::default(),
            interface: Interface::Rs232,
            flow_control: FlowControl::None,
            end: EndCriterion::CharDelay,
            char_delay: Duration::from_millis(4),
            dynamic_frames: true,
            prevent_overwrite: true,
            clear_at_startup: true,
            max_frame_len: MAX_FRAME_LEN as u16,
            xon_xoff: XonXoff::default(),
            rts_cts: RtsCts::default(),
            auto_v24: AutoV24::default(),
            tx_chunk: 16,
        }
    }
}

/// A parameter the manual does not allow.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// A value outside its range (si-core's one [`RangeError`]).
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// Two parameters that the manual does not allow together.
    #[error("{parameter} {value} not allowed: {reason}")]
    NotAllowed {
        /// The parameter's name.
        parameter: &'static str,
        /// The rejected value.
        value: String,
        /// Why, citing the manual.
        reason: &'static str,
    },
    /// The character format itself.
    #[error(transparent)]
    Settings(#[from] SettingsError),
}

impl ConfigError {
    /// The STATUS an FB reports for this error: 1E20H "parameter out of range", or 0550H when
    /// the request does not match the configured flow control.
    pub fn status(&self) -> Status {
        match self {
            ConfigError::NotAllowed {
                parameter: "flow control",
                ..
            } => status::FLOW_PARAMETERS_MISMATCH,
            _ => status::PARAMETER_OUT_OF_RANGE,
        }
    }
}

/// The smallest character delay time for `baud` ([ET200S SI] §2.8, Table 2-9;
/// above 19 200 bit/s [ET200S SI 2005] §2.8.3, §2.8.4, Table 2-7 raised to the 4 ms floor).
pub const fn min_char_delay_ms(baud: u32) -> u32 {
    match baud {
        0..=110 => 364,
        111..=300 => 134,
        301..=600 => 68,
        601..=1_200 => 34,
        1_201..=2_400 => 18,
        2_401..=4_800 => 9,
        _ => 4,
    }
}

/// [`min_char_delay_ms`] as a [`Duration`], for [`Config::char_delay`].
pub const fn min_char_delay(baud: u32) -> Duration {
    Duration::from_millis(min_char_delay_ms(baud) as u64)
}

fn out_of_range(
    parameter: &'static str,
    value: impl std::fmt::Display,
    unit: &'static str,
    range: String,
) -> ConfigError {
    RangeError::new(parameter, range, unit, value).into()
}

/// A wait time in whole 10 ms steps within 20 … 655 350 ms (Table 2-26), checked by si-core's
/// one 10 ms conversion.
fn check_step_time(parameter: &'static str, time: Duration) -> Result<(), ConfigError> {
    ten_ms_count(parameter, time, MIN_WAIT)
        .map(drop)
        .map_err(Into::into)
}

impl XonXoff {
    /// Check the characters against the data width and the wait time against its range.
    pub fn validate(&self, settings: &SerialSettings) -> Result<(), ConfigError> {
        first(self.validate_all(settings))
    }

    /// Like [`validate`](Self::validate), but every error.
    pub fn validate_all(&self, settings: &SerialSettings) -> Vec<ConfigError> {
        let mut errors = Vec::new();
        let mask = settings.data_mask();
        for (parameter, c) in [("XON character", self.xon), ("XOFF character", self.xoff)] {
            if c & !mask != 0 {
                errors.push(out_of_range(
                    parameter,
                    format!("{c:02X}H"),
                    "",
                    format!("00H … {mask:02X}H with {} data bits", settings.data_bits()),
                ));
            }
        }
        if self.xon == self.xoff {
            errors.push(ConfigError::NotAllowed {
                parameter: "XOFF character",
                value: format!("{:02X}H", self.xoff),
                reason: "it must differ from the XON character",
            });
        }
        errors.extend(check_step_time("wait time for XON", self.wait_for_xon).err());
        errors
    }
}

impl RtsCts {
    /// Check the wait time against its range (20 … 655 350 ms, 10 ms steps).
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_step_time("wait time for CTS", self.wait_for_cts)
    }
}

/// Both automatic V.24 times against their range (0 … 655 350 ms, 10 ms steps).
fn auto_v24_errors(times: &AutoV24) -> impl Iterator<Item = ConfigError> {
    times
        .validate_all()
        .into_iter()
        .map(ConfigError::OutOfRange)
}

fn first(errors: Vec<ConfigError>) -> Result<(), ConfigError> {
    match errors.into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl Config {
    /// Check every parameter against Table 2-10 / Table 2-26 and the combinations [ET200S SI] §2.8
    /// forbid; the first error found.
    pub fn validate(&self) -> Result<(), ConfigError> {
        first(self.validate_all())
    }

    /// Like [`validate`](Self::validate), but every error, in the order of the parameter
    /// table, so a parameter file with several wrong values is reported in one go.
    pub fn validate_all(&self) -> Vec<ConfigError> {
        let mut errors = Vec::new();
        let s = &self.settings;
        if let Err(e) = SerialSettings::with_rates(
            s.baud(),
            s.data_bits(),
            s.parity(),
            s.stop_bits(),
            &BAUD_RATES,
        ) {
            errors.push(e.into());
        }
        let min = min_char_delay_ms(s.baud());
        let char_delay = self.char_delay.as_millis();
        if char_delay < u64::from(min) || char_delay > 65_535 {
            errors.push(out_of_range(
                "character delay time",
                char_delay,
                " ms",
                format!("{min} … 65535 ms at {} bit/s", s.baud()),
            ));
        }
        let mask = s.data_mask();
        match self.end {
            EndCriterion::CharDelay => {}
            EndCriterion::EndChars { first, second } => {
                if first == 0 || first & !mask != 0 {
                    errors.push(out_of_range(
                        "end-of-text character 1",
                        format!("{first:02X}H"),
                        "",
                        format!("01H … {mask:02X}H with {} data bits", s.data_bits()),
                    ));
                }
                if second & !mask != 0 {
                    errors.push(out_of_range(
                        "end-of-text character 2",
                        format!("{second:02X}H"),
                        "",
                        format!("00H … {mask:02X}H with {} data bits", s.data_bits()),
                    ));
                }
            }
            EndCriterion::FixedLength { len } => {
                if len == 0 || len > self.max_frame_len {
                    errors.push(out_of_range(
                        "length of received frame",
                        len,
                        " bytes",
                        format!("1 … {} bytes", self.max_frame_len),
                    ));
                }
            }
        }
        if self.max_frame_len == 0 || usize::from(self.max_frame_len) > MAX_FRAME_LEN_LIMIT {
            errors.push(out_of_range(
                "maximum frame length",
                self.max_frame_len,
                " bytes",
                format!("1 … {MAX_FRAME_LEN_LIMIT} bytes"),
            ));
        }
        match (self.flow_control, self.interface) {
            (FlowControl::None, _) => {}
            (_, Interface::Rs485) => errors.push(ConfigError::NotAllowed {
                parameter: "flow control",
                value: format!("{:?}", self.flow_control),
                reason: "flow control is not possible on RS-485 ([ET200S SI] §2.8)",
            }),
            (FlowControl::RtsCts | FlowControl::AutoV24, Interface::Rs422) => {
                errors.push(ConfigError::NotAllowed {
                    parameter: "flow control",
                    value: format!("{:?}", self.flow_control),
                    reason: "RTS/CTS and automatic V.24 operation need RS-232C ([ET200S SI] §2.8)",
                })
            }
            _ => {}
        }
        if self.tx_chunk == 0 || usize::from(self.tx_chunk) > MAX_TX_CHUNK {
            errors.push(out_of_range(
                "transmit chunk",
                self.tx_chunk,
                " characters",
                format!("1 … {MAX_TX_CHUNK} characters"),
            ));
        }
        errors.extend(self.xon_xoff.validate_all(s));
        errors.extend(self.rts_cts.validate().err());
        errors.extend(auto_v24_errors(&self.auto_v24));
        if self.flow_control == FlowControl::XonXoff {
            if let EndCriterion::EndChars { first, second } = self.end {
                let flow = [self.xon_xoff.xon, self.xon_xoff.xoff];
                if flow.contains(&first) || (second != 0 && flow.contains(&second)) {
                    errors.push(ConfigError::NotAllowed {
                        parameter: "end-of-text character",
                        value: format!("{first:02X}H/{second:02X}H"),
                        reason:
                            "it must differ from the XON and XOFF characters ([ET200S SI] §2.8)",
                    });
                }
            }
        }
        errors
    }

    /// The defaults with the longest frame of `module` (see the module docs' readings).
    ///
    /// ```
    /// use si_ascii::Config;
    /// use si_core::ModulePreset;
    ///
    /// assert_eq!(Config::for_module(ModulePreset::Si2005).max_frame_len, 224);
    /// assert_eq!(Config::for_module(ModulePreset::Cp341).max_frame_len, 1024);
    /// ```
    pub fn for_module(module: ModulePreset) -> Config {
        Config {
            max_frame_len: module.max_frame_len(),
            ..Config::default()
        }
    }

    /// The longest frame, in bytes.
    pub fn max_frame(&self) -> usize {
        usize::from(self.max_frame_len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::Parity;

    #[test]
    fn defaults_are_table_2_10() {
        let c = Config::default();
        assert_eq!(c.settings.to_string(), "9600 8E1");
        assert_eq!(c.end, EndCriterion::CharDelay);
        assert_eq!(c.char_delay, Duration::from_millis(4));
        assert!(c.dynamic_frames && c.prevent_overwrite && c.clear_at_startup);
        assert_eq!((c.xon_xoff.xon, c.xon_xoff.xoff), (0x11, 0x13));
        assert_eq!(c.xon_xoff.wait_for_xon, Duration::from_millis(2_000));
        assert_eq!(c.rts_cts.wait_for_cts, Duration::from_millis(2_000));
        assert_eq!(
            c.auto_v24,
            AutoV24 {
                time_rts_off: Duration::from_millis(10),
                data_wait_time: Duration::from_millis(10)
            }
        );
        c.validate().unwrap();
    }

    #[test]
    fn table_2_9_minimum_character_delay_per_baud() {
        let want = [
            (110, 364),
            (300, 134),
            (600, 68),
            (1_200, 34),
            (2_400, 18),
            (4_800, 9),
            (9_600, 4),
            (19_200, 4),
            (115_200, 4),
        ];
        for (baud, min) in want {
            assert_eq!(min_char_delay_ms(baud), min, "{baud}");
            let mut c = Config {
                settings: SerialSettings::new(baud, 8, Parity::Even, 1).unwrap(),
                char_delay: Duration::from_millis(min.into()),
                ..Config::default()
            };
            c.validate().unwrap();
            c.char_delay = Duration::from_millis((min - 1).into());
            let e = c.validate().unwrap_err();
            assert_eq!(
                e.to_string(),
                format!(
                    "character delay time = {} ms is out of range: {min} … 65535 ms at {baud} bit/s",
                    min - 1
                )
            );
        }
    }

    #[test]
    fn errors_name_parameter_range_and_value() {
        let c = Config {
            end: EndCriterion::EndChars {
                first: 0,
                second: 0,
            },
            ..Config::default()
        };
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "end-of-text character 1 = 00H is out of range: 01H … FFH with 8 data bits"
        );
        let c = Config {
            settings: SerialSettings::new(9_600, 7, Parity::Even, 1).unwrap(),
            end: EndCriterion::EndChars {
                first: 0x03,
                second: 0x80,
            },
            ..Config::default()
        };
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "end-of-text character 2 = 80H is out of range: 00H … 7FH with 7 data bits"
        );
        let c = Config {
            end: EndCriterion::FixedLength { len: 201 },
            ..Config::default()
        };
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "length of received frame = 201 bytes is out of range: 1 … 200 bytes"
        );
        // The fixed length follows the module's maximum (2005 manual Table 2-8: 1 … 224).
        let c = Config {
            end: EndCriterion::FixedLength { len: 224 },
            ..Config::for_module(ModulePreset::Si2005)
        };
        assert_eq!(c.validate(), Ok(()));
        for (len, value) in [(0u16, "0"), (1025, "1025")] {
            let c = Config {
                max_frame_len: len,
                ..Config::default()
            };
            let e = c.validate().unwrap_err();
            assert_eq!(
                e.to_string(),
                format!("maximum frame length = {value} bytes is out of range: 1 … 1024 bytes")
            );
        }
        let c = Config {
            max_frame_len: 1024,
            end: EndCriterion::FixedLength { len: 1024 },
            ..Config::default()
        };
        assert_eq!(c.validate(), Ok(()));
        let mut c = Config::default();
        c.xon_xoff.wait_for_xon = Duration::from_millis(15);
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "wait time for XON = 15 ms is out of range: 20 … 655350 ms in 10 ms steps"
        );
        c.xon_xoff.wait_for_xon = Duration::from_millis(2_005);
        assert!(c.validate().is_err());
        let mut c = Config::default();
        c.auto_v24.time_rts_off = Duration::from_millis(655_360);
        assert_eq!(
            c.validate().unwrap_err().status(),
            status::PARAMETER_OUT_OF_RANGE
        );
    }

    #[test]
    fn transmit_chunk_is_1_to_200() {
        let c = Config {
            tx_chunk: 0,
            ..Config::default()
        };
        assert_eq!(
            c.validate().unwrap_err().to_string(),
            "transmit chunk = 0 characters is out of range: 1 … 200 characters"
        );
        let c = Config {
            tx_chunk: 201,
            ..Config::default()
        };
        assert!(c.validate().is_err());
    }

    #[test]
    fn flow_control_needs_the_right_interface() {
        let c = Config {
            interface: Interface::Rs485,
            flow_control: FlowControl::XonXoff,
            ..Config::default()
        };
        let e = c.validate().unwrap_err();
        assert!(e.to_string().contains("not possible on RS-485"), "{e}");
        assert_eq!(e.status(), status::FLOW_PARAMETERS_MISMATCH);
        let c = Config {
            interface: Interface::Rs422,
            flow_control: FlowControl::RtsCts,
            ..Config::default()
        };
        assert!(c.validate().is_err());
        let c = Config {
            interface: Interface::Rs422,
            flow_control: FlowControl::XonXoff,
            ..Config::default()
        };
        c.validate().unwrap();
    }

    #[test]
    fn validate_all_reports_every_error() {
        assert!(Config::default().validate_all().is_empty());
        let mut c = Config {
            char_delay: Duration::from_millis(3),
            end: EndCriterion::FixedLength { len: 0 },
            interface: Interface::Rs485,
            flow_control: FlowControl::XonXoff,
            ..Config::default()
        };
        c.auto_v24.data_wait_time = Duration::from_millis(5);
        let all: Vec<String> = c.validate_all().iter().map(|e| e.to_string()).collect();
        assert_eq!(all.len(), 4, "{all:?}");
        assert!(all[0].starts_with("character delay time = 3 ms"), "{all:?}");
        assert!(
            all[1].starts_with("length of received frame = 0"),
            "{all:?}"
        );
        assert!(all[2].contains("not possible on RS-485"), "{all:?}");
        assert!(
            all[3].starts_with("data output wait time = 5 ms"),
            "{all:?}"
        );
        assert_eq!(c.validate().unwrap_err().to_string(), all[0]);
    }

    #[test]
    fn end_chars_must_not_be_flow_characters() {
        let c = Config {
            flow_control: FlowControl::XonXoff,
            end: EndCriterion::EndChars {
                first: 0x13,
                second: 0,
            },
            ..Config::default()
        };
        assert!(c.validate().is_err());
    }

    #[test]
    fn serde_fills_defaults() {
        let c: Config = serde_json_like();
        assert_eq!(c, Config::default());
    }

    /// Deserialize an empty map through serde's value-free path.
    fn serde_json_like() -> Config {
        use serde::de::value::{Error, MapDeserializer};
        let empty: MapDeserializer<'_, std::iter::Empty<(&str, &str)>, Error> =
            MapDeserializer::new(std::iter::empty());
        Config::deserialize(empty).unwrap()
    }
}
