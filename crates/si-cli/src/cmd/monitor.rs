//! `si monitor`: placeholder until issue 10 lands.

use crate::conn::Connection;
use crate::{CliError, Output};
use clap::Args;

/// `si monitor`.
#[derive(Debug, Args)]
pub struct MonitorArgs {}

impl MonitorArgs {
    /// Run it.
    pub async fn run(&self, _conn: &Connection, _out: &Output) -> Result<(), CliError> {
        Err(CliError::new("not implemented yet"))
    }
}
