//! # si-core
//!
//! What every `si` protocol crate shares:
//!
//! - [`Instant`] and [`Duration`]: time passed into engines, microseconds, no clock reads;
//! - [`SerialSettings`]: the manuals' character formats and the character time derived from them;
//! - [`Status`]: the 16-bit STATUS word of the S7 function blocks, with the manual's text;
//! - [`Engine`] and [`Output`]: the Sans-IO contract (see [`sansio`] for the drain rule);
//! - [`job`]: the job layer: [`JobId`], the [`JobPort`] trait every engine with jobs implements,
//!   and [`job::Channel`] (one S_SEND and one S_RCV);
//! - [`fb`]: edge detection, one-call pulses, and S_SEND / S_RCV written once over [`JobPort`];
//! - [`RangeError`]: a configuration value outside the manual's range, the same for every crate;
//! - [`ModulePreset`]: the module types (ET 200S 1SI, 2005 module, CP 341) and their longest
//!   frame, shared by the ASCII driver and the coordination window;
//! - [`FramePool`]: the pool engines cut the frames they hand out from (no allocation per
//!   frame in steady state);
//! - [`delivery`]: how late the port hands bytes over (USB adapters), and the slack silence
//!   timers need for it;
//! - [`sim`]: a deterministic discrete-event line simulator with seeded faults;
//! - [`monitor`]: what a passive listener sees and reports, shared by the protocols' monitors;
//!   [`diagram`] draws its analysis as an SVG sequence diagram;
//! - [`tracefile`]: the JSON-lines trace file the simulator, the driver and `si monitor` share;
//! - [`linemark`], [`echo`], [`rx_path`], [`port_facts`]: what a real port needs between the
//!   line and an engine (marked line errors, local echo, RS-485 direction), Sans-IO;
//! - `driver` (feature `tokio`): runs any engine over `AsyncRead + AsyncWrite`, logging through
//!   `tracing`; `frame_log` adds each frame as decoded text to those logs, through `tap`, a
//!   transport that shows a watcher what passes through it;
//! - `port` (feature `serial`): opens a serial port from the engine's [`SerialSettings`], with
//!   line errors, RS-485 and the USB adapter's latency timer.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod delivery;
pub mod diagram;
pub mod echo;
pub mod fb;
pub mod frame_pool;
pub mod hex;
pub mod interface;
pub mod job;
pub mod linemark;
pub mod memory;
pub mod module_preset;
pub mod monitor;
pub mod port_facts;
pub mod range;
pub mod rx_path;
pub mod sansio;
pub mod serial;
pub mod sim;
pub mod status;
pub mod time;
pub mod tracefile;
pub mod v24;

#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod driver;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod frame_log;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod tap;

pub use interface::Interface;
pub use job::{JobId, JobPort};
pub use module_preset::ModulePreset;
pub use range::RangeError;
#[cfg(feature = "serial")]
#[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
pub mod port;

pub use frame_pool::FramePool;
pub use sansio::{Engine, LineError, ModemSignals, Output, SignalUpdate};
pub use serial::{Parity, SerialSettings, SettingsError, BAUD_RATES};
pub use status::{Status, StatusInfo};
pub use time::{Duration, Instant};
