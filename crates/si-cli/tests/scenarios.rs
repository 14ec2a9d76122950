//! The `si` binary offline, one module per command: help and errors, frames, simulations,
//! monitors and their SVG, the module's tables.

#[path = "scenarios/bounds.rs"]
mod bounds;
#[path = "scenarios/cli.rs"]
mod cli;
mod common;
#[path = "scenarios/config_files.rs"]
mod config_files;
#[path = "scenarios/dpcoord.rs"]
mod dpcoord;
#[path = "scenarios/examples.rs"]
mod examples;
#[path = "scenarios/exit_codes.rs"]
mod exit_codes;
#[path = "scenarios/help.rs"]
mod help;
#[path = "scenarios/modbus.rs"]
mod modbus;
#[path = "scenarios/module.rs"]
mod module;
#[path = "scenarios/monitor.rs"]
mod monitor;
#[path = "scenarios/profile.rs"]
mod profile;
#[path = "scenarios/r3964.rs"]
mod r3964;
#[path = "scenarios/rk512.rs"]
mod rk512;
#[path = "scenarios/structured.rs"]
mod structured;
#[path = "scenarios/svg.rs"]
mod svg;
#[path = "scenarios/uss.rs"]
mod uss;
