//! `si rk512`: placeholder until the protocol lands; its face is fixed by `cmd/mod.rs`.

use crate::cmd::sim::Scenario;
use crate::conn::Connection;
use crate::{CliError, Output};
use clap::{Args, Subcommand};

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {}

impl Command {
    /// Run it on the line.
    pub async fn run(self, _conn: &Connection, _out: &Output) -> Result<(), CliError> {
        match self {}
    }
}

/// `si frame decode rk512`.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// Telegram in hex.
    hex: String,
}

impl DecodeArgs {
    /// Run it.
    pub fn run(&self, _out: &Output) -> Result<(), CliError> {
        crate::cmd::frame::parse_hex(&self.hex)?;
        Err(CliError::new("not implemented yet"))
    }
}

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[];
