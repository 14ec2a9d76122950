//! # si-module
//!
//! What describes the ET 200S serial interface module itself, as opposed to the coordination-byte
//! window protocol (`si-dp-coord`) through which a DP master talks to it:
//!
//! * [`params`]: the module's parameter set per driver (ASCII, 3964(R), Modbus master and slave,
//!   USS master) with the manual's ranges and defaults, read from and written to TOML or JSON,
//!   and the simulated module a parameter set configures;
//! * [`diag`]: the PROFIBUS slave diagnosis of a station with an SI module, decode and encode;
//!   what the SI module's tables do not describe (other modules' entries, interrupts) is kept raw;
//! * [`ident`]: the identification records I&M0 (DS 231) and I&M1 (DS 232);
//! * [`led`]: the module's SF, TX and RX LEDs as a function of its state and the time.
//!
//! The parameter sets are the protocol crates' own configuration types, so this crate reads every
//! protocol crate's config (ARCHITECTURE.md allows it) and builds on `si-dp-coord` for the
//! simulated module; the window protocol itself depends on none of this.
//!
//! ```
//! use si_module::params::DriverParams;
//! use si_module::diag::Variant;
//!
//! let params = DriverParams::from_toml_str("driver = \"ascii\"\nbaud = 19200\n").unwrap();
//! assert_eq!(params.variant(), Variant::R3964Ascii);
//! ```
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod diag;
pub mod ident;
pub mod led;
pub mod params;
