//! `si trace export --sr/--vcd`: the recorded line's UART levels (each sender's transmit line,
//! and RTS where the trace has it) rebuilt at 16 samples per bit, with their real timing, for
//! PulseView / `sigrok-cli` (`--sr`) and GTKWave (`--vcd`); see `si_capture::uart_levels`.

use crate::conn::Connection;
use crate::error::CliError;
use si_capture::sigrok::SrWriter;
use si_capture::uart_levels::{self, Edge, Levels};
use si_capture::vcd::VcdWriter;
use si_core::tracefile;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

/// Where the edges go: each format asked for.
struct Waves {
    sr: Option<SrWriter<BufWriter<File>>>,
    vcd: Option<VcdWriter<BufWriter<File>>>,
}

impl Waves {
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

/// Write the UART levels of the trace at `path` to the sigrok session file `sr` and the VCD
/// `vcd`, whichever are given.
pub fn export(
    path: &Path,
    sr: Option<&Path>,
    vcd: Option<&Path>,
    conn: &Connection,
) -> Result<(), CliError> {
    let file = File::open(path)
        .map_err(|e| CliError::new(format!("cannot open {}: {e}", path.display())))?;
    let file = tracefile::read(io::BufReader::new(file))
        .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
    let settings = file
        .header
        .as_ref()
        .and_then(|h| h.settings)
        .and_then(|f| f.settings())
        .map_or_else(|| conn.settings_for(&si_core::tracefile::TRACE_RATES), Ok)?;
    let wave = si_capture::trace_levels::waveform(&file, settings);
    drop(file);
    if wave.channels.is_empty() {
        return Err(CliError::new(format!(
            "{}: no characters and no RTS changes to draw",
            path.display()
        )));
    }
    let rate = uart_levels::sample_rate(&settings);
    let failed =
        |what: &Path, e: io::Error| CliError::new(format!("cannot write {}: {e}", what.display()));
    let mut sinks = Waves {
        sr: match sr {
            Some(p) => Some(
                SrWriter::new(create(p)?, &wave.channels, rate, &wave.initial)
                    .map_err(|e| failed(p, e))?,
            ),
            None => None,
        },
        vcd: match vcd {
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
    if let (Some(w), Some(p)) = (sinks.sr, sr) {
        w.finish(end).map_err(|e| failed(p, e))?;
    }
    if let (Some(w), Some(p)) = (sinks.vcd, vcd) {
        w.finish(end).map_err(|e| failed(p, e))?;
    }
    Ok(())
}
