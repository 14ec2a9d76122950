//! `si diag`, `si im`, `si params`: the SI module's own data, offline.
//!
//! - `si diag decode HEX`: a PROFIBUS slave diagnosis with the channel errors' meaning and action
//!   ([ET200S SI 2005] Tables 2-30, 3-73, [`si_module::diag`]); parts the SI module's
//!   tables do not describe (other modules' channel errors, interrupts) are shown raw;
//! - `si im decode HEX` / `si im encode --hid TEXT --location TEXT`: the 64-byte identification
//!   records DS 231 / DS 232 ([ET200S SI 2005] §2.9.4, Tables 2-10/2-11, [`si_module::ident`]);
//! - `si params check FILE`: a TOML or JSON parameter file against the manual's tables; prints
//!   the checked set, or every wrong value at once ([`si_module::params`]); `si params default
//!   DRIVER` prints a file with the manual's defaults to start from.

use crate::error::CliError;
use crate::hex::parse_hex_args;
use crate::output::Output;
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;
use si_core::hex;
use si_module::diag::{SlaveDiagnosis, Variant};
use si_module::ident::{Im1, Record};
use si_module::params::DriverParams;
use std::path::PathBuf;

/// `si diag`.
#[derive(Debug, Subcommand)]
pub enum DiagCommand {
    /// Decode a slave diagnosis (from station status 1 on): station status, module diagnosis,
    /// module status and the channel errors with the manual's meaning and action; what the SI
    /// module's tables do not describe is shown with its raw bytes.
    Decode(DiagDecodeArgs),
}

/// Which module's wording to use for the channel errors.
#[derive(Debug, Clone, Copy, Default, ValueEnum)]
pub enum VariantArg {
    /// ET 200S 1SI 3964(R)/ASCII (Table 2-30).
    #[default]
    #[value(name = "3964r-ascii")]
    R3964Ascii,
    /// ET 200S 1SI Modbus/USS (Table 3-73).
    ModbusUss,
}

/// `si diag decode`.
#[derive(Debug, Args)]
pub struct DiagDecodeArgs {
    /// The diagnosis bytes in hex, as one argument or several words.
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
    /// The module variant, for the wording of the channel errors.
    #[arg(long, value_enum, default_value_t)]
    variant: VariantArg,
}

impl DiagCommand {
    /// Run it.
    pub fn run(self, out: &Output) -> Result<(), CliError> {
        match self {
            DiagCommand::Decode(a) => a.run(out),
        }
    }
}

impl DiagDecodeArgs {
    fn run(&self, out: &Output) -> Result<(), CliError> {
        let bytes = parse_hex_args(&self.hex)?;
        let d = SlaveDiagnosis::decode(&bytes).map_err(|e| CliError::new(e.to_string()))?;
        let variant = match self.variant {
            VariantArg::R3964Ascii => Variant::R3964Ascii,
            VariantArg::ModbusUss => Variant::ModbusUss,
        };
        let s = d.station;
        let flags: Vec<&str> = s.flags().collect();
        out.line(
            &format!(
                "station: status {:02X} {:02X} {:02X}, master {}, ident {:04X}H{}",
                s.status1,
                s.status2,
                s.status3,
                s.master_address,
                s.ident_number,
                if flags.is_empty() {
                    String::new()
                } else {
                    format!(": {}", flags.join(", "))
                }
            ),
            json!({"part": "station", "station": s, "flags": flags}),
        );
        if let Some(m) = &d.module_diagnosis {
            let modules: Vec<usize> = m.modules().collect();
            let list: Vec<String> = modules.iter().map(|n| n.to_string()).collect();
            out.line(
                &format!(
                    "module diagnosis: {}",
                    if list.is_empty() {
                        "no module reports".to_string()
                    } else {
                        format!("module {} reports", list.join(", "))
                    }
                ),
                json!({"part": "module-diagnosis", "modules": modules}),
            );
        }
        if let Some(m) = &d.module_status {
            let states: Vec<_> = m.states().collect();
            let faulty: Vec<String> = states
                .iter()
                .filter(|(_, st)| *st != si_module::diag::ModuleState::Ok)
                .map(|(n, st)| format!("module {n}: {}", st.text()))
                .collect();
            out.line(
                &format!(
                    "module status: {}",
                    if faulty.is_empty() {
                        format!("{} modules OK", states.len())
                    } else {
                        faulty.join("; ")
                    }
                ),
                json!({"part": "module-status", "states": states.iter()
                    .map(|(n, st)| json!({"module": n, "state": st})).collect::<Vec<_>>()}),
            );
        }
        for c in &d.channels {
            let e = c.error;
            out.line(
                &format!(
                    "channel: slot {} channel {} ({}, {}): error type {:05b} ({}) {}: {}. Action: {}",
                    c.slot,
                    c.channel,
                    c.io.text(),
                    c.channel_type.text(),
                    e.code(),
                    e.code(),
                    e.name(),
                    e.meaning(variant),
                    e.action(variant)
                ),
                json!({"part": "channel", "channel": c, "code": e.code(), "name": e.name(),
                       "meaning": e.meaning(variant), "action": e.action(variant)}),
            );
        }
        // What the SI module's tables do not describe: other modules' entries, interrupts,
        // blocks of unknown layout, shown with their raw bytes.
        for u in &d.unknown {
            let raw = hex::format(&u.bytes);
            out.line(
                &format!("not decoded at offset {}: {}; raw {raw}", u.offset, u.kind),
                json!({"part": "unknown", "offset": u.offset, "kind": u.kind,
                       "text": u.kind.to_string(), "bytes": raw}),
            );
        }
        Ok(())
    }
}

/// `si im`.
#[derive(Debug, Subcommand)]
pub enum ImCommand {
    /// Decode a 64-byte DS 231 (I&M0) or DS 232 (I&M1) record, header included.
    Decode(ImDecodeArgs),
    /// Build the 64-byte DS 232 (I&M1) record to write to the module.
    Encode(ImEncodeArgs),
}

/// `si im decode`.
#[derive(Debug, Args)]
pub struct ImDecodeArgs {
    /// The record in hex, as one argument or several words.
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

/// `si im encode`.
#[derive(Debug, Args)]
pub struct ImEncodeArgs {
    /// Plant designation (HID), at most 32 characters.
    #[arg(long, default_value = "")]
    hid: String,
    /// Location designation (OKZ), at most 22 characters.
    #[arg(long, default_value = "")]
    location: String,
}

impl ImCommand {
    /// Run it.
    pub fn run(self, out: &Output) -> Result<(), CliError> {
        match self {
            ImCommand::Decode(a) => {
                let bytes = parse_hex_args(&a.hex)?;
                match Record::decode(&bytes).map_err(|e| CliError::new(e.to_string()))? {
                    Record::Im0(r) => out.line(
                        &format!(
                            "I&M0 (DS 231): manufacturer {:04X}H, order number {:?}, serial number {:?}, \
                             hardware revision {}, software revision {}, revision counter {}, \
                             profile {:04X}H type {:04X}H, I&M version {:02X} {:02X}, I&M supported {:04X}H",
                            r.manufacturer,
                            r.order_number,
                            r.serial_number,
                            r.hardware_revision,
                            r.software_revision,
                            r.revision_counter,
                            r.profile_id,
                            r.profile_specific_type,
                            r.im_version[0],
                            r.im_version[1],
                            r.im_supported
                        ),
                        json!({"record": 231, "im0": r}),
                    ),
                    Record::Im1(r) => out.line(
                        &format!(
                            "I&M1 (DS 232): plant designation {:?}, location {:?}",
                            r.hid, r.location
                        ),
                        json!({"record": 232, "im1": r}),
                    ),
                }
                Ok(())
            }
            ImCommand::Encode(a) => {
                let im1 =
                    Im1::new(&a.hid, &a.location).map_err(|e| CliError::new(e.to_string()))?;
                let bytes = im1.encode().map_err(|e| CliError::new(e.to_string()))?;
                let text = hex::format(&bytes);
                out.line(&text, json!({"record": 232, "hex": text}));
                Ok(())
            }
        }
    }
}

/// `si params`.
#[derive(Debug, Subcommand)]
pub enum ParamsCommand {
    /// Check a parameter file (TOML, or JSON if it ends in .json) against the manual's tables;
    /// print the checked set with every default filled in, or every wrong value at once.
    Check(ParamsCheckArgs),
    /// Print a driver's parameter file with every key at the manual's default, to start from.
    Default(ParamsDefaultArgs),
}

/// The drivers of the two modules.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DriverArg {
    /// ASCII driver (3964(R)/ASCII module).
    Ascii,
    /// 3964(R) driver (3964(R)/ASCII module).
    #[value(name = "3964r")]
    R3964,
    /// Modbus master (Modbus/USS module).
    ModbusMaster,
    /// Modbus slave (Modbus/USS module).
    ModbusSlave,
    /// USS master (Modbus/USS module).
    UssMaster,
}

/// `si params default`.
#[derive(Debug, Args)]
pub struct ParamsDefaultArgs {
    /// The driver.
    #[arg(value_enum)]
    driver: DriverArg,
}

/// `si params check`.
#[derive(Debug, Args)]
pub struct ParamsCheckArgs {
    /// The parameter file.
    file: PathBuf,
}

impl ParamsCommand {
    /// Run it.
    pub fn run(self, out: &Output) -> Result<(), CliError> {
        match self {
            ParamsCommand::Check(a) => a.run(out),
            ParamsCommand::Default(a) => {
                use si_module::params::{
                    AsciiParams, ModbusMasterParams, ModbusSlaveParams, R3964Params,
                    UssMasterParams,
                };
                let p: DriverParams = match a.driver {
                    DriverArg::Ascii => AsciiParams::default().into(),
                    DriverArg::R3964 => R3964Params::default().into(),
                    DriverArg::ModbusMaster => ModbusMasterParams::default().into(),
                    DriverArg::ModbusSlave => ModbusSlaveParams::default().into(),
                    DriverArg::UssMaster => UssMasterParams::default().into(),
                };
                out.line(
                    p.to_toml_string().trim_end(),
                    json!({"params": p.to_value()}),
                );
                Ok(())
            }
        }
    }
}

impl ParamsCheckArgs {
    fn run(&self, out: &Output) -> Result<(), CliError> {
        let name = self.file.display();
        let text = crate::config_file::read(&self.file)?;
        let json_file = self
            .file
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let parsed = if json_file {
            DriverParams::from_json_str(&text)
        } else {
            DriverParams::from_toml_str(&text)
        };
        match parsed {
            Ok(p) => {
                let value = p.to_value();
                out.line(
                    &format!(
                        "# {name}: valid {} parameters\n{}",
                        p.driver(),
                        p.to_toml_string().trim_end()
                    ),
                    json!({"file": name.to_string(), "valid": true, "params": value}),
                );
                Ok(())
            }
            Err(errors) => {
                for e in errors.iter() {
                    out.line(
                        &format!("{name}: {e}"),
                        json!({"file": name.to_string(), "parameter": e.parameter, "error": e.text}),
                    );
                }
                Err(CliError::new(format!(
                    "{name}: {} wrong parameter{}",
                    errors.len(),
                    if errors.len() == 1 { "" } else { "s" }
                )))
            }
        }
    }
}
