//! # si-3964r
//!
//! The 3964 and 3964(R) procedure of the SIMATIC ET 200S serial interface module (and the
//! CP 341), for hosts: a PC, a gateway or a test tool talks to a module, a CP or any 3964(R)
//! partner, or stands in for one ([ET200S SI] §2.7, [CP 341] §2.2.2, §2.3.1).
//!
//! - [`frame`]: the block on the wire (DLE doubling, `DLE ETX`, BCC) and a byte-by-byte decoder
//!   that says exactly what is wrong;
//! - [`config`]: the parameters of Table 2-11 with the manual's defaults and ranges (serde);
//! - [`link`]: one Sans-IO engine that is sender and receiver, with both timers, both attempt
//!   counters, the initialization conflict, the 4 s block wait and the 400 ms buffer wait;
//! - [`status`]: the STATUS codes of classes 07H and 08H with the manual's texts;
//! - [`monitor`]: the passive listener of a 3964(R) line, judging ZVZ and QVZ with the link's
//!   own timers (and reading a layer's user data, RK 512 in `si_rk512::monitor`);
//! - [`fb`]: S_SEND and S_RCV with the S7 call semantics;
//! - [`bound`]: the longest a send job may take whatever the line does, with the
//!   formula and an example at 9600 bit/s: 88.83 s for a 200-byte block with the defaults;
//! - `tokio` (feature `tokio`): an async handle, `send(bytes).await` and `recv().await`.
//!
//! Two stations exchange blocks on the deterministic line simulator:
//!
//! ```
//! use si_3964r::config::Priority;
//! use si_3964r::{Config, Event, Link};
//! use si_sim::Simulator;
//! use si_core::{Instant, SerialSettings};
//!
//! let line = SerialSettings::default(); // 9600 8E1
//! let mut sim = Simulator::new(7);
//! let plc = sim.add_station("PLC", line, Link::new(Config::default().with_settings(line)).unwrap());
//! let host_config = Config { priority: Priority::High, ..Config::default() };
//! let host = sim.add_station("host", line, Link::new(host_config.with_settings(line)).unwrap());
//! sim.connect(plc, host);
//!
//! // Both send at the same instant: an initialization conflict, the low-priority PLC yields.
//! let from_plc = sim.with(plc, |l, now| l.send(now, &b"status"[..])).unwrap();
//! let from_host = sim.with(host, |l, now| l.send(now, &b"setpoint"[..])).unwrap();
//! sim.run_until_quiet(Instant::from_micros(30_000_000));
//!
//! assert_eq!(sim.take_events(host), vec![Event::Sent { job: from_host }, Event::Received { len: 6 }]);
//! assert_eq!(sim.take_events(plc), vec![Event::Received { len: 8 }, Event::Sent { job: from_plc }]);
//! assert_eq!(sim.with(plc, |l, now| l.take_block(now)).unwrap(), &b"setpoint"[..]);
//! assert_eq!(sim.with(host, |l, now| l.take_block(now)).unwrap(), &b"status"[..]);
//! ```
//!
//! # Bounds
//!
//! Every send job ends with [`Event::Sent`] or [`Event::SendFailed`] within
//! [`Config::send_job_bound`] whatever the line does: a silent partner, noise, a flood, a frame
//! that never ends (cut off with NAK at the maximum block length). The formula, the readings
//! and an example: [`bound`]. At 9600 bit/s with the defaults a 200-byte block ends within
//! 88.83 s; a silent partner ends it after 6 × 2.001 s with 0703H.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod bound;
pub mod config;
pub mod fb;
pub mod frame;
pub mod link;
pub mod monitor;
pub mod probe;
pub mod status;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod tokio;

pub use config::{Config, ConfigError, Priority};
pub use frame::{FrameError, Mode};
pub use link::{Counters, Event, JobId, Link, SendError};
