//! `si trace export --sr/--vcd`: the recorded line's UART levels (each sender's transmit line,
//! and RTS where the trace has it) rebuilt at 16 samples per bit, with their real timing, for
//! PulseView / `sigrok-cli` (`--sr`) and GTKWave (`--vcd`); see `si_capture::uart_levels`.

use crate::conn::Connection;
use crate::error::CliError;
use si_capture::trace_waves::{self, WavesError};
use si_core::tracefile::{Item, Stream, TRACE_RATES};
use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::Path;

fn create(path: &Path) -> Result<BufWriter<File>, CliError> {
    File::create(path)
        .map(BufWriter::new)
        .map_err(|e| CliError::new(format!("cannot create {}: {e}", path.display())))
}

/// Write the UART levels of the trace at `path` to the sigrok session file `sr` and the VCD
/// `vcd`, whichever are given: read twice, record by record (`si_capture::trace_waves`).
pub fn export(
    path: &Path,
    sr: Option<&Path>,
    vcd: Option<&Path>,
    conn: &Connection,
) -> Result<(), CliError> {
    let open = || File::open(path).map(BufReader::new);
    let cannot_open = |e| CliError::new(format!("cannot open {}: {e}", path.display()));
    let bad = |e| CliError::new(format!("{}: {e}", path.display()));
    // The header, if any, is the first line.
    let header = match Stream::new(open().map_err(cannot_open)?).next_item() {
        Ok(Some(Item::Header(h))) => Some(h),
        Ok(_) => None,
        Err(e) => return Err(bad(e)),
    };
    let settings = header
        .and_then(|h| h.settings)
        .and_then(|f| f.settings())
        .map_or_else(|| conn.settings_for(&TRACE_RATES), Ok)?;
    let sr_file = sr.map(create).transpose()?;
    let vcd_file = vcd.map(create).transpose()?;
    let failed = |what: Option<&Path>, e: std::io::Error| {
        let what = what.map_or_else(String::new, |p| p.display().to_string());
        CliError::new(format!("cannot write {what}: {e}"))
    };
    trace_waves::export(open, settings, sr_file, vcd_file).map_err(|e| match e {
        WavesError::Open(e) => cannot_open(e),
        WavesError::Read(e) => bad(e),
        WavesError::Empty => CliError::new(format!(
            "{}: no characters and no RTS changes to draw",
            path.display()
        )),
        WavesError::Sr(e) => failed(sr, e),
        WavesError::Vcd(e) => failed(vcd, e),
    })
}
