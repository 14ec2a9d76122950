//! `si trace`: work on recorded trace files without watching a line.
//!
//! `si trace export FILE.trace --sr OUT.sr --vcd OUT.vcd` rebuilds the UART levels of the
//! recorded line (each sender's transmit line, and RTS where the trace has it) at 16 samples
//! per bit, with their real timing, for PulseView / `sigrok-cli` (`--sr`) and GTKWave (`--vcd`);
//! see `si_capture::uart_levels`. One match arm per format in [`ExportArgs::run`].

use crate::cmd::monitor::TRACE_RATES;
use crate::conn::Connection;
use crate::error::CliError;
use clap::{Args, Subcommand};
use si_capture::sigrok::SrWriter;
use si_capture::uart_levels::{self, Edge, Levels};
use si_capture::vcd::VcdWriter;
use si_core::tracefile;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// `si trace …`.
#[derive(Debug, Subcommand)]
pub enum TraceCommand {
    /// Write a recorded trace in another tool's format (PulseView: --sr, GTKWave: --vcd).
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
    /// Write a sigrok session file for PulseView and `sigrok-cli -i`: one logic channel per
    /// sender (`<station>_TxD`) and per recorded RTS (`<station>_RTS`), 16 samples per bit.
    #[arg(long, value_name = "OUT")]
    pub sr: Option<PathBuf>,
    /// Write the same levels as a VCD (value changes, 1 ns timescale) for GTKWave.
    #[arg(long, value_name = "OUT")]
    pub vcd: Option<PathBuf>,
}

/// Where the edges go: each format asked for.
struct Sinks {
    sr: Option<SrWriter<BufWriter<File>>>,
    vcd: Option<VcdWriter<BufWriter<File>>>,
}

impl Sinks {
    fn edge(&mut self, e: Edge) -> io::Result<()> {
        if let Some(sr) = &mut self.sr {
            sr.edge(e)?;
        }
        if let Some(vcd) = &mut self.vcd {
            vcd.edge(e)?;
        }
        Ok(())
    }
}

fn create(path: &Path) -> Result<BufWriter<File>, CliError> {
    File::create(path)
        .map(BufWriter::new)
        .map_err(|e| CliError::new(format!("cannot create {}: {e}", path.display())))
}

impl ExportArgs {
    /// Read the trace and write the chosen formats.
    pub fn run(&self, conn: &Connection) -> Result<(), CliError> {
        if self.sr.is_none() && self.vcd.is_none() {
            return Err(CliError::new("name a format: --sr OUT or --vcd OUT"));
        }
        let path = &self.trace;
        let file = File::open(path)
            .map_err(|e| CliError::new(format!("cannot open {}: {e}", path.display())))?;
        let file = tracefile::read(io::BufReader::new(file))
            .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
        let settings = file
            .header
            .as_ref()
            .and_then(|h| h.settings)
            .and_then(|f| f.settings())
            .map_or_else(|| conn.settings_for(&TRACE_RATES), Ok)?;
        let wave = si_capture::trace_levels::waveform(&file, settings);
        drop(file);
        if wave.channels.is_empty() {
            return Err(CliError::new(format!(
                "{}: no characters and no RTS changes to draw",
                path.display()
            )));
        }
        let rate = uart_levels::sample_rate(&settings);
        let failed = |what: &Path, e: io::Error| {
            CliError::new(format!("cannot write {}: {e}", what.display()))
        };
        let mut sinks = Sinks {
            sr: match &self.sr {
                Some(p) => Some(
                    SrWriter::new(create(p)?, &wave.channels, rate, &wave.initial)
                        .map_err(|e| failed(p, e))?,
                ),
                None => None,
            },
            vcd: match &self.vcd {
                Some(p) => Some(
                    VcdWriter::new(create(p)?, "si", &wave.channels, rate, &wave.initial)
                        .map_err(|e| failed(p, e))?,
                ),
                None => None,
            },
        };
        let mut levels = Levels::new(settings, wave.initial);
        let mut result = Ok(());
        let mut sink = |e: Edge| {
            if result.is_ok() {
                result = sinks.edge(e);
            }
        };
        for item in wave.items {
            levels.push(item, &mut sink);
        }
        // Two character times of idle line after the last edge, so a decoder sees the end.
        let end = levels.finish(&mut sink) + 2 * u64::from(settings.bits_per_char()) * 16;
        let write_error = |e: io::Error| CliError::new(format!("cannot write the export: {e}"));
        result.map_err(write_error)?;
        if let (Some(sr), Some(p)) = (sinks.sr, &self.sr) {
            sr.finish(end).map_err(|e| failed(p, e))?;
        }
        if let (Some(vcd), Some(p)) = (sinks.vcd, &self.vcd) {
            vcd.finish(end).map_err(|e| failed(p, e))?;
        }
        Ok(())
    }
}
