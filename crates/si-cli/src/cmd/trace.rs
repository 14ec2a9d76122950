//! `si trace`: work on recorded trace files without watching a line.
//!
//! `si trace export FILE.trace --pcap OUT.pcapng` decodes the trace as `si monitor --trace`
//! does (record by record, in bounded memory) and writes what it delimited for Wireshark;
//! `--sr OUT.sr` and `--vcd OUT.vcd` rebuild the line's UART levels for PulseView and GTKWave
//! ([`waves`]). Any of the three may be given together.
//!
//! `si trace lua-tables` prints the value tables of the Wireshark dissectors
//! (`contrib/wireshark/si.lua`, between its GENERATED markers) from the Rust decoders' own
//! definitions; a test keeps the file equal to it.

use crate::cmd::monitor::{MonitorArgs, Protocol, Sinks};
use crate::conn::Connection;
use crate::error::CliError;
use clap::{Args, Subcommand};
use std::path::PathBuf;

mod waves;

/// `si trace …`.
#[derive(Debug, Subcommand)]
pub enum TraceCommand {
    /// Write a recorded trace in other tools' formats (Wireshark: --pcap, PulseView: --sr,
    /// GTKWave: --vcd).
    Export(ExportArgs),
    /// Print the value tables of contrib/wireshark/si.lua from the Rust decoders.
    LuaTables,
}

impl TraceCommand {
    /// Run it.
    pub fn run(self, conn: &Connection) -> Result<(), CliError> {
        match self {
            TraceCommand::Export(a) => a.run(conn),
            TraceCommand::LuaTables => {
                crate::output::write_stdout(format_args!("{}", lua_tables()));
                Ok(())
            }
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
    #[arg(long, value_name = "OUT")]
    pub pcap: Option<PathBuf>,
    /// Write a sigrok session file for PulseView and `sigrok-cli -i`: one logic channel per
    /// sender (`<station>_TxD`) and per recorded RTS (`<station>_RTS`), 16 samples per bit.
    #[arg(long, value_name = "OUT")]
    pub sr: Option<PathBuf>,
    /// Write the same levels as a VCD (value changes, 1 ns timescale) for GTKWave.
    #[arg(long, value_name = "OUT")]
    pub vcd: Option<PathBuf>,
    /// Protocol to decode the trace as (default: the trace header's).
    #[arg(long, value_enum, default_value_t = Protocol::Auto)]
    pub protocol: Protocol,
}

impl ExportArgs {
    /// Read the trace and write the chosen formats.
    pub fn run(&self, conn: &Connection) -> Result<(), CliError> {
        if self.pcap.is_none() && self.sr.is_none() && self.vcd.is_none() {
            return Err(CliError::new(
                "name a format: --pcap OUT, --sr OUT or --vcd OUT",
            ));
        }
        if let Some(out) = &self.pcap {
            let monitor = MonitorArgs::quiet(self.protocol);
            let mut sinks = Sinks {
                out: None,
                diagram: None,
                pcap: None,
                pcap_path: Some(out.clone()),
                kept: None,
            };
            let analysis = monitor.stream_trace(&self.trace, conn, &mut sinks)?;
            sinks.finish(&analysis, None)?;
        }
        if self.sr.is_some() || self.vcd.is_some() {
            waves::export(&self.trace, self.sr.as_deref(), self.vcd.as_deref(), conn)?;
        }
        Ok(())
    }
}

/// The marker lines around the generated section of `si.lua`.
pub const LUA_BEGIN: &str = "-- BEGIN GENERATED TABLES (si trace lua-tables)\n";
/// See [`LUA_BEGIN`].
pub const LUA_END: &str = "-- END GENERATED TABLES\n";

/// A Lua table `name` of `entries` (key, text), keys in hex when `hex`.
fn lua_table(name: &str, entries: &[(u32, String)], hex: bool) -> String {
    let mut s = format!("local {name} = {{\n");
    for (k, v) in entries {
        if hex {
            s.push_str(&format!("    [0x{k:02X}] = \"{v}\",\n"));
        } else {
            s.push_str(&format!("    [{k}] = \"{v}\",\n"));
        }
    }
    s.push_str("}\n");
    s
}

/// The value tables of the dissectors, from the decoders: RK 512's command and data type
/// letters (`[CP 341]` §2.2.3, Table 2-1), USS's AK 7 error numbers (`[USS]`), the DP window's
/// job codes (`[ET200S SI 2005]` Table 2-22).
pub fn lua_tables() -> String {
    use si_rk512::frame::{Command, DataType};
    let letters = |f: &dyn Fn(u8) -> Option<String>| -> Vec<(u32, String)> {
        (0x20u8..0x7F)
            .filter_map(|b| f(b).map(|name| (u32::from(b), name)))
            .collect()
    };
    let commands = letters(&|b| Command::from_letter(b).map(|c| format!("{c:?}")));
    let types = letters(&|b| DataType::from_letter(b).map(|t| format!("{t:?}")));
    let unknown = si_uss::frame::pkw_error_text(u16::MAX);
    let errors: Vec<(u32, String)> = (0u16..=255)
        .map(|n| (u32::from(n), si_uss::frame::pkw_error_text(n)))
        .filter(|(_, text)| *text != unknown)
        .map(|(n, text)| (n, text.to_owned()))
        .collect();
    let jobs: Vec<(u32, String)> = (0u8..8)
        .map(|b| {
            (
                u32::from(b),
                format!("{:?}", si_dp_coord::JobCode::from_bits(b)),
            )
        })
        .collect();
    let mut s = String::from(LUA_BEGIN);
    s.push_str(&lua_table("rk512_commands", &commands, true));
    s.push_str(&lua_table("rk512_data_types", &types, true));
    s.push_str(&lua_table("uss_pkw_errors", &errors, false));
    s.push_str(&lua_table("dpcoord_jobs", &jobs, false));
    s.push_str(LUA_END);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dissectors' tables are the decoders' tables: regenerate with `si trace lua-tables`.
    #[test]
    fn si_lua_holds_the_generated_tables() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../contrib/wireshark/si.lua"
        );
        let lua = std::fs::read_to_string(path).expect("contrib/wireshark/si.lua");
        let start = lua.find(LUA_BEGIN).expect("the BEGIN marker");
        let end = lua.find(LUA_END).expect("the END marker") + LUA_END.len();
        assert_eq!(
            &lua[start..end],
            lua_tables(),
            "si.lua's tables differ from the decoders: paste `si trace lua-tables` between its markers"
        );
    }
}
