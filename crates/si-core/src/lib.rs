//! # si-core
//!
//! What every `si` protocol crate shares. The line simulator is its own crate, `si-sim`; the
//! driver and ports stay here behind features, so an engine crate built without features
//! depends on neither tokio nor serde_json.
//!
//! Always:
//!
//! - [`Instant`] and [`Duration`]: time passed into engines, microseconds, no clock reads;
//! - [`SerialSettings`]: the manuals' character formats and the character time derived from them;
//! - [`Status`]: the 16-bit STATUS word of the S7 function blocks, with the manual's text;
//! - [`Engine`] and [`Output`]: the Sans-IO contract (see [`sansio`] for the drain rule);
//! - [`job`]: the job layer: [`JobId`], the [`JobPort`] trait every engine with jobs implements,
//!   and [`fb::Channel`] (one S_SEND and one S_RCV);
//! - [`fb`]: edge detection, one-call pulses, and S_SEND / S_RCV written once over [`JobPort`];
//! - [`fb_v24`]: S_VSTAT, S_VSET, S_XON, S_RTS and S_V24 written once over a [`fb_v24::V24Port`]
//!   (the ASCII link and the coordination window's host);
//! - [`param_block`]: the flow-control parameter blocks 20H–22H and the one conversion between
//!   a TIME and their counts of 10 ms;
//! - [`RangeError`]: a configuration value outside the manual's range, the same for every crate;
//! - [`ModulePreset`]: the module types (ET 200S 1SI, 2005 module, CP 341) and their longest
//!   frame, shared by the ASCII driver and the coordination window;
//! - [`FramePool`]: the pool engines cut the frames they hand out from (no allocation per
//!   frame in steady state);
//! - [`delivery`]: how late the port hands bytes over (USB adapters), and the slack silence
//!   timers need for it;
//! - [`trace`]: the timestamped record of a line ([`trace::Trace`], [`trace::TraceKind`]) that
//!   the simulator, the driver, the monitors and the module's LEDs share;
//! - [`monitor`]: what a passive listener sees and reports, shared by the protocols' monitors;
//!   [`diagram`] draws its analysis as an SVG sequence diagram;
//! - [`tracefile`]: the trace file's header and line format; reading and writing the JSON lines
//!   (`tracefile::read`, `write`, `Recorder`) need feature `tracefile`;
//! - [`linemark`], [`echo`], [`rx_path`], [`port_facts`]: what a real port needs between the
//!   line and an engine (marked line errors, local echo, RS-485 direction), Sans-IO.
//!
//! Behind features:
//!
//! - `tracefile`: the JSON-lines trace file the simulator, the driver and `si monitor` share
//!   (serde_json);
//! - `driver` (feature `tokio`, implies `tracefile`): runs any engine over
//!   `AsyncRead + AsyncWrite`, logging through `tracing`; `frame_log` adds each frame as decoded
//!   text to those logs, through `tap`, a transport that shows a watcher what passes through it;
//! - `port` (feature `serial`): opens a serial port from the engine's [`SerialSettings`], with
//!   line errors, RS-485 and the USB adapter's latency timer.
//!
//! # Citations
//!
//! Doc comments in every `si` crate cite the Siemens manuals by a short tag and the manual's
//! own section, table or figure, e.g. "[Modbus/USS] §3.3.5, Table 3-11"; `[derived]` marks
//! our own inference where a manual is silent or garbled. `SOURCES.md` at the root of the `si`
//! repository (and in the `si-serial` package) lists every tag with the document's title,
//! edition and order number.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod address_list;
#[cfg(feature = "config-file")]
#[cfg_attr(docsrs, doc(cfg(feature = "config-file")))]
pub mod config_file;
pub mod delivery;
pub mod diagram;
pub mod echo;
pub mod fb;
pub mod fb_v24;
pub mod frame_pool;
pub mod hex;
pub mod interface;
pub mod job;
pub mod linemark;
pub mod memory;
pub mod module_preset;
pub mod monitor;
pub mod param_block;
pub mod port_facts;
pub mod range;
pub mod rx_path;
pub mod sansio;
pub mod serial;
pub mod status;
pub mod sweep;
pub mod time;
pub mod trace;
pub mod trace_names;
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
