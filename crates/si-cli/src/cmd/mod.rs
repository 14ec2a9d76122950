//! One module per top-level command.
//!
//! Every protocol module (`r3964`, `rk512`, `ascii`, `modbus`, `uss`) has the same face, so `main`, `frame` and
//! `sim` wire them without knowing their insides:
//!
//! - `Command`: its clap subcommands, run with `Command::run(self, &Connection, &Output)`;
//! - `EncodeArgs` / `DecodeArgs`: `si frame encode|decode <protocol> …`, run with `.run(&Output)`
//!   (not for `ascii`, whose frames are the bytes themselves; `rk512` decodes only);
//! - `SCENARIOS`: the named simulator scenarios `si sim` offers.
//!
//! Imports point one way (tests/import_graph.rs proves it): `frame` and `sim` list the protocol
//! modules, and the protocol modules import only the leaves below all commands: hex parsing
//! (`crate::hex`), the module presets (`crate::preset`), scenarios and trace output (`crate::scenario`), printing (`crate::output`)
//! and errors (`crate::error`).

pub mod ascii;
pub mod completions;
pub mod dpcoord;
pub mod frame;
pub mod gateway;
pub mod modbus;
pub mod module;
pub mod monitor;
pub mod ports;
pub mod r3964;
pub mod rk512;
pub mod sim;
pub mod trace;
pub mod uss;
