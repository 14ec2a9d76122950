//! # si-ascii
//!
//! The ASCII driver of the SIMATIC ET 200S serial interface module ([ET200S SI] §2.8,
//! [ET200S SI 2005] §2.8, [CP 341] §2.2.4, §2.3.3) for hosts: a Sans-IO
//! [`Link`] that cuts received bytes into frames by the manual's three end criteria (character
//! delay time, one or two end-of-text characters, fixed length), keeps them in the module's
//! 1024-byte ring buffer, sends frames with the inter-frame pause, and speaks XON/XOFF, RTS/CTS
//! and the automatic V.24 signal sequence.
//!
//! - [`config`]: parameters with the manual's ranges and defaults;
//! - [`frame`]: the pure end-of-text / fixed-length cutter;
//! - [`buffer`]: the receive ring buffer;
//! - [`link`]: the engine;
//! - [`status`]: the STATUS codes;
//! - [`monitor`]: the passive listener, cutting frames by the link's own criterion and delay;
//! - [`fb`]: S_SEND, S_RCV, S_VSTAT, S_VSET, S_XON, S_RTS, S_V24;
//! - `tokio` (feature `tokio`): an async handle.
//!
//! ```
//! use si_ascii::{Config, EndCriterion, Event, Link};
//! use si_sim::Simulator;
//! use si_core::{Instant, SerialSettings};
//!
//! let config = Config { end: EndCriterion::EndChars { first: b'\r', second: b'\n' }, ..Config::default() };
//! let mut sim = Simulator::new(1);
//! let a = sim.add_station("A", config.settings, Link::new(config).unwrap());
//! let b = sim.add_station("B", config.settings, Link::new(config).unwrap());
//! sim.connect(a, b);
//! sim.with(a, |link, now| link.send(now, "hello\r\n".into())).unwrap();
//! sim.run_until_quiet(Instant::from_micros(1_000_000));
//! assert!(matches!(sim.take_events(b)[..], [Event::Received { len: 7, .. }]));
//! assert_eq!(sim.with(b, |link, now| link.read_frame_vec(now)).unwrap(), b"hello\r\n");
//! ```
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod buffer;
pub mod config;
pub mod fb;
pub mod frame;
pub mod job_end;
pub mod link;
pub mod monitor;
pub mod status;

#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod tokio;

pub use config::{
    AutoV24, Config, ConfigError, EndCriterion, FlowControl, Interface, RtsCts, XonXoff,
    MAX_FRAME_LEN, RECEIVE_BUFFER_SIZE,
};
pub use link::{Event, JobId, Link, Refused, SendError};
