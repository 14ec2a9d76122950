//! # si-modbus
//!
//! Modbus RTU as the ET 200S SI Modbus/USS module does it (et200s-si-modbus-uss.md §3–§5):
//!
//! - [`frame`]: ADU encode/decode with CRC-16, request and response PDUs of FC 01–08, 11, 12,
//!   15, 16 with the manual's limits, exceptions; zero-copy views, no allocation;
//! - [`rx`]: frame detection by silence with the manual's gap table and operating modes;
//! - [`master`]: the Sans-IO master engine, every outcome a STATUS of the manual;
//! - [`slave`]: the Sans-IO slave engine served by a [`slave::Store`]: plain tables, or the
//!   SIMATIC memory model reached through S_MODB's conversion DB ([`simatic`]);
//! - [`fb`]: S_SEND/S_RCV master jobs and S_MODB as the PLC programmer sees them;
//! - `tokio` (feature `tokio`): an async master handle and a slave server task.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod config;
pub mod fb;
pub mod frame;
pub mod master;
pub mod rx;
pub mod simatic;
pub mod slave;
pub mod status;

#[cfg(feature = "tokio")]
pub mod tokio;

pub use config::{MasterConfig, Mode, SlaveConfig};
pub use frame::{Adu, Bits, ExceptionCode, Registers, Request, Response};
pub use master::{Master, MasterEvent};
pub use simatic::{ConversionDb, SimaticStore};
pub use slave::{Slave, SlaveEvent, Store, StoreError, Tables};
