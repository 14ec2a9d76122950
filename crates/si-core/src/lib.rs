//! # si-core
//!
//! What every `si` protocol crate shares:
//!
//! - [`Instant`] and [`Duration`]: time passed into engines, microseconds, no clock reads;
//! - [`SerialSettings`]: the manuals' character formats and the character time derived from them;
//! - [`Status`]: the 16-bit STATUS word of the S7 function blocks, with the manual's text;
//! - [`Engine`] and [`Output`]: the Sans-IO contract (see [`sansio`] for the drain rule);
//! - [`delivery`]: how late the port hands bytes over (USB adapters), and the slack silence
//!   timers need for it;
//! - [`fb`]: edge detection and one-call pulses for the FB equivalents;
//! - [`sim`]: a deterministic discrete-event line simulator with seeded faults;
//! - [`tracefile`]: the JSON-lines trace file the simulator, the driver and `si monitor` share;
//! - `driver` (feature `tokio`): runs any engine over `AsyncRead + AsyncWrite`.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod delivery;
pub mod fb;
pub mod hex;
pub mod interface;
pub mod memory;
pub mod sansio;
pub mod serial;
pub mod sim;
pub mod status;
pub mod time;
pub mod tracefile;

#[cfg(feature = "tokio")]
pub mod driver;

pub use interface::Interface;
pub use sansio::{Engine, LineError, ModemSignals, Output, SignalUpdate};
pub use serial::{Parity, SerialSettings, SettingsError, BAUD_RATES};
pub use status::{Status, StatusInfo};
pub use time::{Duration, Instant};
