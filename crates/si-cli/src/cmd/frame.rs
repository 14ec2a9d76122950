//! `si frame encode|decode <protocol> HEX`: frames offline, no line needed.

use crate::cmd::{modbus, r3964, rk512, uss};
use crate::error::CliError;
use crate::output::Output;
use clap::Subcommand;

/// Encode or decode one frame of a protocol.
#[derive(Debug, Subcommand)]
pub enum FrameCommand {
    /// Build the bytes that go on the line from a payload.
    #[command(subcommand)]
    Encode(Encode),
    /// Check and take apart bytes seen on the line; exits non-zero naming the error.
    #[command(subcommand)]
    Decode(Decode),
}

/// `si frame encode <protocol>`.
#[derive(Debug, Subcommand)]
pub enum Encode {
    /// 3964(R): the block that follows the partner's DLE (stuffed data, DLE ETX, BCC).
    #[command(name = "3964r")]
    R3964(r3964::EncodeArgs),
    /// Modbus RTU: address + PDU in, ADU with CRC out.
    Modbus(modbus::EncodeArgs),
    /// USS: ADR + net data in, the whole telegram (STX LGE ADR … BCC) out.
    Uss(uss::EncodeArgs),
}

/// `si frame decode <protocol>`.
#[derive(Debug, Subcommand)]
pub enum Decode {
    /// 3964(R): the block after DLE, up to and including DLE ETX (and BCC).
    #[command(name = "3964r")]
    R3964(r3964::DecodeArgs),
    /// RK 512: a command, continuation or reaction telegram, with or without its data.
    Rk512(rk512::DecodeArgs),
    /// Modbus RTU: an ADU with CRC, read as request or response.
    Modbus(modbus::DecodeArgs),
    /// USS: a telegram from STX to BCC.
    Uss(uss::DecodeArgs),
}

impl FrameCommand {
    /// Run it.
    pub fn run(self, out: &Output) -> Result<(), CliError> {
        match self {
            FrameCommand::Encode(Encode::R3964(a)) => a.run(out),
            FrameCommand::Encode(Encode::Modbus(a)) => a.run(out),
            FrameCommand::Encode(Encode::Uss(a)) => a.run(out),
            FrameCommand::Decode(Decode::R3964(a)) => a.run(out),
            FrameCommand::Decode(Decode::Rk512(a)) => a.run(out),
            FrameCommand::Decode(Decode::Modbus(a)) => a.run(out),
            FrameCommand::Decode(Decode::Uss(a)) => a.run(out),
        }
    }
}
