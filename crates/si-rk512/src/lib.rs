//! # si-rk512
//!
//! The RK 512 computer link on top of 3964(R), as the CP 341 and the S5/S7 partners speak it
//! ([CP 341] §2.2.3, §2.3.2, [Public RK 512]): SEND and FETCH jobs of any length,
//! split into telegrams of 128 data bytes and reassembled, each answered by a reaction
//! telegram that says whether the partner took the data or had them.
//!
//! - [`frame`]: the 10-byte command header, the 4-byte continuation and reaction headers;
//!   decode errors name the offset, what was expected and what was found;
//! - [`area`]: the partner's memory areas by name (`DB10`, `E`/`I`, …), parsed for the
//!   front ends that take them as text;
//! - [`config`]: TRES, the job length limit, the DW-number convention, and the 3964(R)
//!   parameters underneath;
//! - [`station`]: one Sans-IO engine wrapping a [`si_3964r::Link`]: our jobs (active side) and
//!   the partner's jobs (passive side) over one line;
//! - [`passive`]: the partner's jobs served from the SIMATIC memory model
//!   ([`si_core::memory`]), with coordination flags and the CPU number;
//! - [`refusal`]: why the passive side refused a partner's telegram (class 06H) and the error
//!   number its reaction carries;
//! - [`status`]: the STATUS codes as the CP 341 reports them ([CP 341 Diag]), by the
//!   side that raises them:
//!   - **05H** (requester, our job): 0515/0516 for our own flag bit and CPU number, refused
//!     at once; 051A when our command telegram could not be sent, after the 3964(R) 07xx;
//!   - **06H** (responder, the partner's job): the partner's telegram is faulty or cannot be
//!     served (0601 … 0611), or our reaction could not be sent (0612, after the 07xx);
//!   - **07H/08H** (either side): the 3964(R) link's procedure errors, [`si_3964r::status`];
//!   - **09H** (requester): the partner's reaction carries an error number (byte 4 → 09xx,
//!     `[inferred]`, unknown bytes 090E);
//!   - **0AH** (requester): the partner's reaction is faulty (0A01 … 0A04) or missing (0A05).
//! - [`monitor`]: the passive listener, the 3964(R) monitor reading RK 512 telegrams;
//! - [`fb`]: send and fetch FB equivalents with REQ / DONE / ERROR / STATUS;
//! - [`bound`]: the longest a job may take whatever the line does: per telegram two
//!   3964(R) send jobs and TRES; 185.95 s for up to 128 bytes at 9600 bit/s with the defaults;
//! - `tokio` (feature `tokio`): an async handle, `send(..).await` and `fetch(..).await`.
//!
//! A SEND of 300 bytes (three telegrams) and a FETCH of them back, on the line simulator:
//!
//! ```
//! use si_rk512::frame::{Address, Coordination};
//! use si_rk512::passive::ServerConfig;
//! use si_rk512::{Config, Event, Station};
//! use si_sim::Simulator;
//! use si_core::{Instant, SerialSettings};
//!
//! let line = SerialSettings::default();
//! let mut host_config = Config::default();
//! host_config.link.priority = si_3964r::Priority::High;
//! let mut memory = ServerConfig::default();
//! memory.memory.dbs.insert(10, 1024);
//! let mut sim = Simulator::new(3);
//! let host = sim.add_station("host", line, Station::new(host_config.with_settings(line)).unwrap());
//! let plc = sim.add_station("PLC", line, Station::serving(Config::default().with_settings(line), &memory).unwrap());
//! sim.connect(host, plc);
//!
//! let data: Vec<u8> = (0..300u16).map(|i| i as u8).collect();
//! let to = Address::Db { db: 10, dw: 0 };
//! sim.with(host, |s, now| s.send(now, to, Coordination::NONE, data.clone())).unwrap();
//! sim.run_until_quiet(Instant::from_micros(60_000_000));
//! let job = sim.with(host, |s, now| s.fetch(now, to, Coordination::NONE, 300)).unwrap();
//! sim.run_until_quiet(Instant::from_micros(120_000_000));
//! let events = sim.take_events(host);
//! assert_eq!(events.last(), Some(&Event::Done { job, data: data.into() }));
//! ```
//!
//! # Bounds
//!
//! Every SEND and FETCH ends with [`Event::Done`] or [`Event::Failed`] within
//! [`Config::job_bound`] whatever the line does: per telegram two 3964(R) send jobs (a reaction
//! of ours may go first) and TRES, each bounded ([`si_3964r::bound`]). The formula, the readings
//! and an example: [`bound`]. At 9600 bit/s with the defaults a job of up to 128 bytes ends
//! within 185.95 s, one of up to 256 bytes within twice that.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod area;
pub mod bound;
pub mod config;
pub mod fb;
pub mod frame;
pub mod monitor;
pub mod passive;
pub mod refusal;
pub mod station;
pub mod status;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod tokio;

pub use config::{Config, CounterLetter, DwUnit};
pub use frame::{Address, Command, Coordination, DataType};
pub use station::{Event, JobId, RequestError, Station};
