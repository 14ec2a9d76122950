//! The module's physical interface, a parameter every driver has ("Interface type":
//! [ET200S SI] Table 2-10, [Modbus/USS] §3.2, Tables 3-17 and 3-20).
//!
//! One type for all protocols, because what it changes is the line, not the protocol: RS-232C
//! has secondary signals, RS-422 is four-wire point to point, RS-485 is a two-wire half-duplex
//! bus whose receiver sees turnaround glitches and echoes.

use serde::{Deserialize, Serialize};

/// The physical interface ("Interface type"; RS-232C is every driver's default).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Interface {
    /// RS-232C: the only interface with secondary signals ([ET200S SI] §2.8).
    #[default]
    Rs232,
    /// RS-422, four-wire: one partner, each direction on its own pair.
    Rs422,
    /// RS-485, two-wire half duplex: no flow control ([ET200S SI] §2.8), turnaround after each
    /// frame; a Modbus master recognises a response by a correctly received slave address
    /// ([Modbus/USS] §3.4.1, §3.4.3).
    Rs485,
}
