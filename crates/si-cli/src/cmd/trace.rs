//! `si trace`: work on recorded trace files without watching a line.
//!
//! `si trace export FILE.trace --pcap OUT.pcapng` decodes the trace as `si monitor --trace`
//! does (record by record, in bounded memory) and writes what it delimited in another tool's
//! format: one match arm per format in [`ExportArgs::run`].

use crate::cmd::monitor::{MonitorArgs, Protocol, Sinks};
use crate::conn::Connection;
use crate::error::CliError;
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// `si trace …`.
#[derive(Debug, Subcommand)]
pub enum TraceCommand {
    /// Write a recorded trace in another tool's format (Wireshark: --pcap).
    Export(ExportArgs),
}

impl TraceCommand {
    /// Run it.
    pub fn run(self, conn: &Connection) -> Result<(), CliError> {
        match self {
            TraceCommand::Export(a) => a.run(conn),
        }
    }
}

/// `si trace export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The trace file (`si --record`, `si sim --record`, `si monitor` on a port with --record).
    #[arg(value_name = "FILE")]
    pub trace: PathBuf,
    /// Write a pcapng capture for Wireshark: each frame the monitor delimits as an exported PDU
    /// naming its dissector (mbrtu, si_3964r, si_rk512, si_uss, si_dpcoord), line errors and
    /// modem lines as RTAC serial records.
    #[arg(long, value_name = "OUT", required = true)]
    pub pcap: Option<PathBuf>,
    /// Protocol to decode the trace as (default: the trace header's).
    #[arg(long, value_enum, default_value_t = Protocol::Auto)]
    pub protocol: Protocol,
}

impl ExportArgs {
    /// Decode the trace and write the chosen format.
    pub fn run(&self, conn: &Connection) -> Result<(), CliError> {
        let monitor = MonitorArgs::quiet(self.protocol);
        match &self.pcap {
            Some(out) => {
                let mut sinks = Sinks {
                    out: None,
                    diagram: None,
                    pcap: None,
                    pcap_path: Some(out.clone()),
                    kept: None,
                };
                let analysis = monitor.stream_trace(&self.trace, conn, &mut sinks)?;
                sinks.finish(&analysis, None)
            }
            None => Err(CliError::new("name a format: --pcap OUT")),
        }
    }
}
