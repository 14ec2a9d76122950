//! # si-uss
//!
//! The USS master of the ET 200S SI Modbus/USS module, for hosts ([Modbus/USS] §3.7,
//! [ET200S SI 2005] Tables 3-80, 3-82, Table 3-84, §3.8, [USS spec]):
//!
//! - [`frame`]: the telegram `STX LGE ADR net-data BCC`, PKW and PZD areas, task and response IDs;
//! - [`param`]: parameter numbers up to 61 999 through the page index in IND's high byte;
//! - [`config`]: polling list, timing and ranges;
//! - [`master`]: the Sans-IO master engine with its polling cycle, PKW handshake, broadcast and
//!   mirror telegrams and diagnostic counters;
//! - [`drive`]: a simulated USS slave (a drive with parameters, a status word that follows the
//!   control word and an actual value that ramps to the setpoint) for tests, examples and `si sim`;
//! - [`status`]: the STATUS codes every job ends with;
//! - [`monitor`]: the passive listener, judging start interval, residual run time and response
//!   delay with [`config`]'s functions, as the master does;
//! - [`fb`]: the net-data DB and the FC equivalents S_USST, S_USSR and S_USSI;
//! - `tokio` (feature `tokio`): an async handle over the si-core driver.
//!
//! ```
//! use si_sim::Simulator;
//! use si_core::Instant;
//! use si_uss::config::{MasterConfig, PollEntry};
//! use si_uss::drive::{Drive, DriveConfig};
//! use si_uss::frame::PkwWords;
//! use si_uss::master::{Event, Master};
//!
//! let settings = si_uss::config::uss_settings(9600).unwrap();
//! let mut config = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
//! config.settings = settings;
//! let mut sim = Simulator::new(1);
//! let m = sim.add_station("master", settings, Master::new(config).unwrap());
//! let d = sim.add_station("drive1", settings, Drive::new(DriveConfig::new(settings, 1)).unwrap());
//! sim.connect(m, d);
//! sim.with(m, |m, now| m.start(now));
//! sim.run_until(Instant::from_micros(200_000));
//! let events = sim.take_events(m);
//! assert!(events.iter().any(|e| matches!(e, Event::Response { address: 1, .. })));
//! ```
//!
//! # Bounds
//!
//! The USS timing ([USS spec] §5.2.1) bounds a poll only on a line that goes quiet: the master
//! waits for a start interval of silence before every request, and a flood never leaves one.
//! So the master adds host bounds derived from its configuration ([`config::MasterConfig`]):
//!
//! - **wait for silence**: a due poll goes out after at most
//!   `max_wait_for_silence = 2 × t_char + t_char + 1.5 × (252 + 3) × t_char + (255 ms + t_char)`,
//!   the start interval plus the longest telegram (STX and its residual run time) plus the
//!   longest USB-adapter hold; any telegram on the line is over by then;
//! - **one poll**: `poll_bound = max_wait_for_silence + 256 × t_char` (the request)
//!   `+ response timeout + (255 ms + t_char)` (the STX may come a port latency late)
//!   `+ max_telegram_duration` (the response's residual run time, + the hold); it ends with a
//!   response, "no answer" (16#1408) or a rejection (residual time, LGE, BCC, …);
//! - **one cycle**: `cycle_bound = entries × poll_bound + cycle pause` (`si uss poll --cycles 1`);
//! - **a parameter job**: `job_bound = (WDH + 2) × cycle_bound` (`si uss read-param`): it goes
//!   out with its slave's next poll and at most 1 + WDH times, once per cycle.
//!
//! Example at 9600 bit/s (t_char = 1.146 ms), one slave, response timeout 20 ms: a poll ends
//! within 697.9 + 293.3 + 20 + 256.1 + 695.6 = **1963 ms**; `uss read-param --retries 0`
//! within 3.93 s, with the default WDH = 20 within 43.2 s. Under noise that never forms a
//! telegram the engine never spins: each wait ends at an instant that moves forward.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod config;
pub mod drive;
pub mod fb;
pub mod frame;
pub mod job_end;
pub mod master;
pub mod monitor;
pub mod param;
mod rx;
pub mod scan;
pub mod status;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod tokio;

pub use config::{MasterConfig, PollEntry};
pub use frame::{Adr, NetData, ParamAddress, Pke, Pkw, PkwWords, Pzd};
pub use master::{Event, JobId, Master, ParamRequest, Width};
