//! `si diag`, `si im`, `si params`: placeholders until issue 11 lands.

use crate::{CliError, Output};
use clap::Subcommand;

/// `si diag`.
#[derive(Debug, Subcommand)]
pub enum DiagCommand {}

impl DiagCommand {
    /// Run it.
    pub fn run(self, _out: &Output) -> Result<(), CliError> {
        match self {}
    }
}

/// `si im`.
#[derive(Debug, Subcommand)]
pub enum ImCommand {}

impl ImCommand {
    /// Run it.
    pub fn run(self, _out: &Output) -> Result<(), CliError> {
        match self {}
    }
}

/// `si params`.
#[derive(Debug, Subcommand)]
pub enum ParamsCommand {}

impl ParamsCommand {
    /// Run it.
    pub fn run(self, _out: &Output) -> Result<(), CliError> {
        match self {}
    }
}
