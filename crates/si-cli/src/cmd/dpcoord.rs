//! `si dp-coord`: placeholder until the commands land; its face is fixed by `cmd/mod.rs`.

use crate::cmd::sim::Scenario;
use crate::conn::Connection;
use crate::{CliError, Output};
use clap::Subcommand;

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {}

impl Command {
    /// Run it.
    pub async fn run(self, _conn: &Connection, _out: &Output) -> Result<(), CliError> {
        match self {}
    }
}

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[];
