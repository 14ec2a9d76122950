//! # si-serial
//!
//! Host-side implementations of the serial protocols of the SIMATIC ET 200S serial interface
//! modules, so a PC, gateway or test tool can talk to what those modules talk to — or stand in
//! for the module itself.
//!
//! This facade re-exports the crates of the family, one feature per protocol:
//!
//! | feature | crate | what |
//! |---|---|---|
//! | (always) | [`core`] (`si-core`) | time, serial settings, STATUS codes, the Sans-IO contract, line traces, tokio driver |
//! | `sim` (default) | [`sim`] (`si-sim`) | the deterministic line simulator with seeded faults |
//! | `3964r` (default) | [`r3964`] (`si-3964r`) | the 3964 / 3964(R) procedure and its FBs |
//! | `rk512` (default) | [`rk512`] (`si-rk512`) | RK 512 SEND/FETCH over 3964(R) |
//! | `ascii` (default) | [`ascii`] (`si-ascii`) | the ASCII driver and its FBs |
//! | `modbus` (default) | [`modbus`] (`si-modbus`) | Modbus RTU master and slave, S_MODB |
//! | `uss` (default) | [`uss`] (`si-uss`) | the USS master and its FC equivalents |
//! | `dp-coord` (default) | [`dp_coord`] (`si-dp-coord`) | the coordination-byte DP window protocol, host and module |
//! | `module` (default) | [`module`] (`si-module`) | the ET 200S SI module itself: parameters per driver, diagnosis, I&M, LEDs |
//! | `tracefile` | | reading and writing trace files (JSON lines), without the driver |
//! | `tokio` | | the async driver and handles (implies `tracefile`) |
//! | `serial` | | serial ports: `core::port::open` from the engine's `SerialSettings` (implies `tokio`) |
//!
//! Every engine is Sans-IO: it is fed bytes and time and says what to transmit and when to wake
//! it, so the same code runs under tokio, in the deterministic simulator, and in tests.
//!
//! The modules are the crates themselves, inlined (`#[doc(inline)]`): each has its own pages
//! here. With feature `tokio`, each protocol's `tokio` module has the same handle: `spawn(config,
//! transport)`, `open(config, path)` (feature `serial`, the port opened with the config's own
//! line settings), the protocol's jobs on `&self`, `recv()`, `next_event()`, `close().await`
//! (returns once the port is released) and `closed()`, and one `Error` with the variants
//! `Refused`, `Failed { status, .. }`, `Config`, `Stopped` and `Io`.
#![cfg_attr(docsrs, feature(doc_cfg))]

#[doc(inline)]
pub use si_core as core;

#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
#[doc(inline)]
pub use si_sim as sim;

#[cfg(feature = "3964r")]
#[cfg_attr(docsrs, doc(cfg(feature = "3964r")))]
#[doc(inline)]
pub use si_3964r as r3964;

#[cfg(feature = "rk512")]
#[cfg_attr(docsrs, doc(cfg(feature = "rk512")))]
#[doc(inline)]
pub use si_rk512 as rk512;

#[cfg(feature = "ascii")]
#[cfg_attr(docsrs, doc(cfg(feature = "ascii")))]
#[doc(inline)]
pub use si_ascii as ascii;

#[cfg(feature = "modbus")]
#[cfg_attr(docsrs, doc(cfg(feature = "modbus")))]
#[doc(inline)]
pub use si_modbus as modbus;

#[cfg(feature = "uss")]
#[cfg_attr(docsrs, doc(cfg(feature = "uss")))]
#[doc(inline)]
pub use si_uss as uss;

#[cfg(feature = "dp-coord")]
#[cfg_attr(docsrs, doc(cfg(feature = "dp-coord")))]
#[doc(inline)]
pub use si_dp_coord as dp_coord;

#[cfg(feature = "module")]
#[cfg_attr(docsrs, doc(cfg(feature = "module")))]
#[doc(inline)]
pub use si_module as module;
/// The README, compiled as doc-tests: a snippet there that stops compiling fails
/// `cargo test --doc`. Its Rust blocks use the simulator, 3964(R), Modbus and a serial port,
/// so they are tested with those features (`--all-features` in CI); shell blocks are tagged
/// `sh`.
#[cfg(all(
    doctest,
    feature = "sim",
    feature = "serial",
    feature = "3964r",
    feature = "modbus"
))]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
