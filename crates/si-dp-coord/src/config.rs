//! Parameters of the host and module engines, with the manual's values as defaults and the
//! readings we chose where the manual is silent ([ET200S SI 2005] §2.12 `[derived]`).

use crate::coord::ExecWrap;
use crate::frame::{V24Layout, WindowSize};
use crate::status::NOT_POSSIBLE_IN_MODE;
use serde::{Deserialize, Serialize};
use si_core::{Duration, ModulePreset, RangeError, Status};

/// The largest frame of chapter 2 (S_SEND/S_RCV LEN, 050EH, 0850H): 224 bytes, the 2005
/// module's ([`ModulePreset::Si2005`]). The 1E41H text says 1…200 and the Modbus/USS module uses
/// 200 (`[derived]`); [`HostConfig::for_module`] picks the limit by module type.
pub const MAX_FRAME_LEN: usize = ModulePreset::Si2005.max_frame_len() as usize;

/// The upper bound any configuration may choose: the 16-bit length word could say 65 535, but a
/// bounded engine needs a bounded buffer.
pub const MAX_FRAME_LEN_LIMIT: usize = 4096;

/// Default host job watchdog: 30 s.
///
/// The manual defines no timeout for any window step (`[derived]`). A send job legitimately waits
/// for the whole serial transmission before the end-of-job acknowledgement ([ET200S SI 2005]
/// §2.12.1–§2.12.7 `[derived]`), including 3964(R) retries: 224 bytes at 1200 bit/s take 2.05 s per
/// attempt, plus QVZ 2 s, times 6 attempts ≈ 25 s. 30 s covers that; slower lines or longer retry
/// chains need a longer watchdog.
pub const DEFAULT_JOB_TIMEOUT: Duration = Duration::from_secs(30);

/// A configuration value outside its range: every window parameter error is a range error,
/// si-core's one [`RangeError`].
pub type ConfigError = RangeError;

fn check(name: &'static str, value: usize, min: usize, max: usize) -> Result<(), ConfigError> {
    RangeError::check(name, (min, max), "", value)
}

/// Host (DP master) engine parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HostConfig {
    /// The window size of the configured module variant (the host cannot learn it from the
    /// module, `[derived]`).
    pub window: WindowSize,
    /// Largest frame the host sends or accepts, 1 … [`MAX_FRAME_LEN_LIMIT`]; default 224, the
    /// 2005 module's; [`HostConfig::for_module`] takes it from the module type.
    /// Longer send jobs are refused with 1E41H before they touch the window (the FB's own
    /// LEN check, [ET200S SI 2005] `[derived]`).
    pub max_frame_len: usize,
    /// Watchdog per job, from the moment the job owns byte 0 until its completion; `None`
    /// disables it. Default [`DEFAULT_JOB_TIMEOUT`]. In files `job_timeout_ms`.
    #[serde(rename = "job_timeout_ms", with = "si_core::time::millis_opt")]
    pub job_timeout: Option<Duration>,
    /// The STATUS a job ends with when its watchdog expires. The manual has no such code; the
    /// default 0502H ("job not possible in the module's current mode") names the likely cause: a
    /// module that is not in RUN or not parameterized does not process jobs
    /// ([Modbus/USS] §3.8.2).
    pub watchdog_status: Status,
    /// Jobs waiting for the arbiter, 1 … 1024; default 16. Further submissions are refused.
    pub queue_capacity: usize,
    /// Start a receive job on its own whenever the idle status shows a waiting frame (what S_RCV
    /// does with EN_R = 1). Default off: receive jobs are submitted explicitly.
    pub auto_receive: bool,
    /// Where the V.24 bit field sits in the signal word (`[derived]`); default byte 2.
    pub v24_layout: V24Layout,
    /// What follows execution number 7 (`[derived]`): 7 → 1 by default, or 7 → 0. Host and module
    /// must use the same; see [`ExecWrap`] for what a disagreement looks like.
    #[serde(default)]
    pub exec_wrap: ExecWrap,
}

impl Default for HostConfig {
    fn default() -> Self {
        HostConfig {
            window: WindowSize::Eight,
            max_frame_len: MAX_FRAME_LEN,
            job_timeout: Some(DEFAULT_JOB_TIMEOUT),
            watchdog_status: NOT_POSSIBLE_IN_MODE,
            queue_capacity: 16,
            auto_receive: false,
            v24_layout: V24Layout::LowByte,
            exec_wrap: ExecWrap::ToOne,
        }
    }
}

impl HostConfig {
    /// The defaults for a window size.
    pub fn new(window: WindowSize) -> Self {
        HostConfig {
            window,
            ..HostConfig::default()
        }
    }

    /// The defaults for a window size and the module type behind the window, whose longest
    /// frame becomes [`max_frame_len`](Self::max_frame_len): 200 bytes for the ET 200S 1SI
    /// ([ET200S SI] §2.12: "send job longer than 200 bytes"), 224 for the 2005
    /// module ([ET200S SI 2005] `[derived]`).
    ///
    /// The coordination window is an ET 200S protocol: the CP 341 sits in the S7-300 rack and
    /// has no DP window, so [`ModulePreset::Cp341`] is refused with an error naming the module
    /// types that have one.
    ///
    /// ```
    /// use si_core::ModulePreset;
    /// use si_dp_coord::{HostConfig, WindowSize};
    ///
    /// let host = HostConfig::for_module(WindowSize::Eight, ModulePreset::Et200s1Si).unwrap();
    /// assert_eq!(host.max_frame_len, 200);
    /// assert!(HostConfig::for_module(WindowSize::Eight, ModulePreset::Cp341).is_err());
    /// ```
    pub fn for_module(window: WindowSize, module: ModulePreset) -> Result<Self, ConfigError> {
        if !module.has_dp_window() {
            return Err(RangeError::new(
                "module type behind the coordination window",
                "ET 200S 1SI (et200s) or 2005 module (2005)",
                "",
                module.name(),
            ));
        }
        Ok(HostConfig {
            max_frame_len: usize::from(module.max_frame_len()),
            ..HostConfig::new(window)
        })
    }

    /// Checks every range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check("max_frame_len", self.max_frame_len, 1, MAX_FRAME_LEN_LIMIT)?;
        check("queue_capacity", self.queue_capacity, 1, 1024)
    }
}

/// What the module does when the host sets the error bit in a receive job (`[derived]`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ReceiveErrorPolicy {
    /// Table 2-21: abort the delivery, answer 20H with STATUS 0551H, wait for the host's idle
    /// code and offer the same frame again from segment 1. The default.
    #[default]
    AbortAndReoffer,
    /// The general sender rule of §2.12.7: resend from the segment after the last valid one.
    GoBack,
}

/// The flow control configured for the module (GSD/HW config). A parameter job must carry the
/// matching block, else the module answers 0550H ([ET200S SI 2005] §2.12.2–§2.12.6 `[derived]`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum FlowControl {
    /// No flow control: every parameter block is refused with 0550H.
    None,
    /// XON/XOFF (block 20H). The default, so the manual's Table 2-28 example works as printed.
    #[default]
    XonXoff,
    /// RTS/CTS (block 21H).
    RtsCts,
    /// Automatic V.24 control (block 22H).
    AutoV24,
}

impl FlowControl {
    /// The block number this flow control accepts.
    pub const fn block(self) -> Option<u8> {
        match self {
            FlowControl::None => None,
            FlowControl::XonXoff => Some(0x20),
            FlowControl::RtsCts => Some(0x21),
            FlowControl::AutoV24 => Some(0x22),
        }
    }
}

/// Module (DP slave) engine parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModuleConfig {
    /// The window size of the module variant.
    pub window: WindowSize,
    /// Largest frame, 1 … [`MAX_FRAME_LEN_LIMIT`]; default 224. A longer send is refused with
    /// the end-of-job acknowledgement and 050EH right after the segment carrying the length word
    /// ([ET200S SI 2005] §2.12.7 case 1; `[derived]`: the exec number of that 7xH is the one of
    /// that segment).
    pub max_frame_len: usize,
    /// Receive buffer in bytes, 1 … 65 536; default 1024 (the ASCII driver's buffer,
    /// [ET200S SI 2005] §2.8.3, Table 2-8). 0B01H is published above 2/3 of it.
    pub rx_buffer_bytes: usize,
    /// Most frames (and receive errors) buffered, 1 … 1024; default 250. The manual bounds the
    /// buffer by bytes only; the count keeps a flood of 1-byte frames bounded too. When either
    /// limit is reached the newest frame is discarded ("prevent overwriting", the default of
    /// [ET200S SI 2005] §2.8.3, Table 2-8) and the next receive job reports 080AH.
    pub rx_buffer_frames: usize,
    /// Reaction to the host's error bit in a receive job (`[derived]`).
    pub receive_error_policy: ReceiveErrorPolicy,
    /// The configured flow control, which decides the valid parameter block.
    pub flow_control: FlowControl,
    /// Where the V.24 bit field sits in the signal word (`[derived]`); default byte 2.
    pub v24_layout: V24Layout,
    /// What follows execution number 7 (`[derived]`): 7 → 1 by default, or 7 → 0. Host and module
    /// must use the same; see [`ExecWrap`] for what a disagreement looks like.
    #[serde(default)]
    pub exec_wrap: ExecWrap,
}

impl Default for ModuleConfig {
    fn default() -> Self {
        ModuleConfig {
            window: WindowSize::Eight,
            max_frame_len: MAX_FRAME_LEN,
            rx_buffer_bytes: 1024,
            rx_buffer_frames: 250,
            receive_error_policy: ReceiveErrorPolicy::AbortAndReoffer,
            flow_control: FlowControl::XonXoff,
            v24_layout: V24Layout::LowByte,
            exec_wrap: ExecWrap::ToOne,
        }
    }
}

impl ModuleConfig {
    /// The defaults for a window size.
    pub fn new(window: WindowSize) -> Self {
        ModuleConfig {
            window,
            ..ModuleConfig::default()
        }
    }

    /// Checks every range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check("max_frame_len", self.max_frame_len, 1, MAX_FRAME_LEN_LIMIT)?;
        check("rx_buffer_bytes", self.rx_buffer_bytes, 1, 65_536)?;
        check("rx_buffer_frames", self.rx_buffer_frames, 1, 1024)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_max_frame_follows_the_module_type() {
        assert_eq!(HostConfig::default().max_frame_len, 224);
        let len = |m| {
            HostConfig::for_module(WindowSize::Four, m)
                .map(|c| (c.window, c.max_frame_len))
                .map_err(|e| e.to_string())
        };
        assert_eq!(len(ModulePreset::Et200s1Si), Ok((WindowSize::Four, 200)));
        assert_eq!(len(ModulePreset::Si2005), Ok((WindowSize::Four, 224)));
        assert_eq!(
            len(ModulePreset::Cp341),
            Err(
                "module type behind the coordination window = cp341 is out of range: \
                 ET 200S 1SI (et200s) or 2005 module (2005)"
                    .into()
            )
        );
    }

    #[test]
    fn defaults_are_valid_and_ranges_are_named() {
        HostConfig::default().validate().unwrap();
        ModuleConfig::default().validate().unwrap();
        let bad = HostConfig {
            max_frame_len: 0,
            ..HostConfig::default()
        };
        assert_eq!(
            bad.validate().unwrap_err().to_string(),
            "max_frame_len = 0 is out of range: 1 … 4096"
        );
        let bad = ModuleConfig {
            rx_buffer_frames: 0,
            ..ModuleConfig::default()
        };
        assert!(bad.validate().is_err());
    }
}
