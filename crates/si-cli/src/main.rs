//! `si`: speak the ET 200S serial-module protocols from a PC.
//!
//! `si <protocol> <action>` over `--port` or `--tcp`, `si frame encode|decode` offline,
//! `si sim` for two simulated peers. Human output by default, `--json` lines for scripts,
//! `-v`/`-vv`/`-vvv` for `tracing` logs on stderr ([`logs`]). Errors print one line and exit non-zero (1 a
//! protocol or I/O failure, 2 usage, 130 interrupted: [`error::EXIT_CODES`]); a protocol failure
//! prints its STATUS.

mod address_list;
mod cmd;
mod config_file;
mod conn;
mod error;
mod help;
mod hex;
mod line_names;
mod lines;
mod logs;
mod output;
mod preset;
mod profile;
mod radix;
mod scenario;
mod setting_sweep;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use error::CliError;
use output::Output;
use std::process::ExitCode;

/// Speak the SIMATIC ET 200S serial interface module protocols: 3964(R), RK 512, ASCII, Modbus RTU, USS.
#[derive(Debug, Parser)]
#[command(name = "si", version, about, propagate_version = true, after_help = error::EXIT_CODES)]
struct Cli {
    #[command(flatten)]
    connection: conn::Connection,
    /// Print JSON lines instead of text.
    #[arg(long, global = true)]
    json: bool,
    /// Log on stderr: -v each frame sent and received, decoded, with its wall-clock time; -vv
    /// also the raw bytes in hex and the protocol engine's events; -vvv also the timers.
    ///
    /// Only si's own logs are raised (dependencies stay at warnings); RUST_LOG (e.g.
    /// `si_core=debug`) replaces the filter when set. Colour only on a terminal, and never with
    /// NO_COLOR set.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// List the serial ports of this machine, or check one (`--check PORT`): what keeps it
    /// from working, with remedies.
    Ports(cmd::ports::PortsArgs),
    /// Encode or decode frames offline, from hex.
    #[command(subcommand)]
    Frame(cmd::frame::FrameCommand),
    /// Watch a line (receive only) or a recorded trace and decode the frames with their timing.
    Monitor(cmd::monitor::MonitorArgs),
    /// Work on recorded trace files: export them for Wireshark, PulseView and GTKWave.
    #[command(subcommand)]
    Trace(cmd::trace::TraceCommand),
    /// Decode a module's PROFIBUS slave diagnosis.
    #[command(subcommand)]
    Diag(cmd::module::DiagCommand),
    /// Identification data I&M0 / I&M1 (DS 231 / DS 232): decode and encode.
    #[command(subcommand)]
    Im(cmd::module::ImCommand),
    /// Module parameters per driver: check a TOML/JSON file against the manual's tables.
    #[command(subcommand)]
    Params(cmd::module::ParamsCommand),
    /// Run a scenario between simulated stations and print the line trace.
    Sim(cmd::sim::SimArgs),
    /// 3964 / 3964(R) procedure: send and receive blocks.
    #[command(name = "3964r", subcommand)]
    R3964(cmd::r3964::Command),
    /// RK 512 over 3964(R): SEND and FETCH jobs, or serve them from a simulated CPU memory.
    #[command(subcommand)]
    Rk512(cmd::rk512::Command),
    /// ASCII driver: send and receive frames with the manual's end criteria and flow control.
    #[command(subcommand)]
    Ascii(cmd::ascii::Command),
    /// Modbus RTU master (read, write, diagnostics) and slave (serve).
    #[command(subcommand)]
    Modbus(cmd::modbus::Command),
    /// The coordination-byte DP window protocol: be the host (DP master side) or the module.
    #[command(name = "dp-coord", subcommand)]
    DpCoord(cmd::dpcoord::Command),
    /// USS master: poll drives, read and write parameters; a simulated drive.
    #[command(subcommand)]
    Uss(cmd::uss::Command),
    /// Modbus TCP gateway to Modbus RTU, USS, RK 512 and 3964(R) lines: routes by unit id,
    /// queues, retries, counters.
    Gateway(cmd::gateway::GatewayArgs),
    /// Print the completion script for a shell (bash, zsh, fish, elvish, powershell).
    Completions(cmd::completions::CompletionsArgs),
}

fn main() -> ExitCode {
    let matches = help::arrange(Cli::command()).get_matches();
    let mut cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    cli.connection.protocol = match &cli.command {
        Command::R3964(_) => Some("3964r"),
        Command::Rk512(_) => Some("rk512"),
        Command::Ascii(_) => Some("ascii"),
        Command::Modbus(_) => Some("modbus"),
        Command::Uss(_) => Some("uss"),
        // `dp-coord module` names its line's procedure itself (from `--protocol`).
        _ => None,
    };
    logs::init(cli.verbose);
    // Frames are logged only when INFO is on for si_core::frame_log (-v, or RUST_LOG).
    cli.connection.frame_log = Some(cmd::monitor::line_decoder);
    let out = Output { json: cli.json };
    let result = cli
        .connection
        .settle_line(&matches)
        .and_then(|()| profile::apply(&mut cli.connection, &matches))
        .and_then(|()| match cli.command {
            Command::Ports(a) => a.run(&cli.connection, &out),
            Command::Frame(c) => c.run(&out),
            Command::Monitor(a) => {
                runtime().and_then(|rt| rt.block_on(a.run(&cli.connection, &out)))
            }
            Command::Trace(c) => c.run(&cli.connection),
            Command::Diag(c) => c.run(&out),
            Command::Im(c) => c.run(&out),
            Command::Params(c) => c.run(&out),
            Command::Sim(a) => cli
                .connection
                .settings()
                .and_then(|s| a.run(s, cli.connection.record.as_deref(), &out)),
            Command::R3964(c) => runtime().and_then(|rt| rt.block_on(c.run(&cli.connection, &out))),
            Command::Rk512(c) => runtime().and_then(|rt| rt.block_on(c.run(&cli.connection, &out))),
            Command::Ascii(c) => runtime().and_then(|rt| rt.block_on(c.run(&cli.connection, &out))),
            Command::Modbus(c) => {
                runtime().and_then(|rt| rt.block_on(c.run(&cli.connection, &out)))
            }
            Command::DpCoord(c) => {
                runtime().and_then(|rt| rt.block_on(c.run(&cli.connection, &out)))
            }
            Command::Uss(c) => runtime().and_then(|rt| rt.block_on(c.run(&cli.connection, &out))),
            Command::Gateway(a) => {
                runtime().and_then(|rt| rt.block_on(a.run(&cli.connection, &out)))
            }
            Command::Completions(a) => a.run(help::arrange(Cli::command())),
        });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("si: error: {}", e.text());
            ExitCode::from(e.code())
        }
    }
}

fn runtime() -> Result<Runtime, CliError> {
    Ok(Runtime(
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?,
    ))
}

/// The runtime of the commands that talk to a line, with the one SIGINT rule: Ctrl-C ends
/// every command with exit 130 ([`CliError::interrupted`]). A command that watches Ctrl-C
/// itself (a poll's or a monitor's counters, `modbus serve`) is polled first and ends with its
/// own output; any other is dropped at once.
struct Runtime(tokio::runtime::Runtime);

impl Runtime {
    fn block_on(
        &self,
        command: impl std::future::Future<Output = Result<(), CliError>>,
    ) -> Result<(), CliError> {
        self.0.block_on(async {
            tokio::select! {
                biased;
                result = command => result,
                _ = tokio::signal::ctrl_c() => Err(CliError::interrupted()),
            }
        })
    }
}
