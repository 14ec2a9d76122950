//! Numbers as users type them, and register addresses in the numbering they think in.
//!
//! Every number `si modbus` takes (addresses, units, register values, the FC08 test value)
//! reads the same way: decimal, `0x` hex (as C and mbpoll write it) or `16#` hex (as STEP 7
//! and the manual write it). Addresses are PDU addresses, 0-based as on the wire, unless
//! `--base 1` asks for Modicon-style numbering where address 1 is PDU address 0 (what mbpoll
//! does by default, and what device manuals listing "register 1" mean).

use crate::error::CliError;
use crate::radix::bounded as parse_number;
use clap::Args;

/// A 16-bit value (a register, the FC08 test value).
pub fn parse_u16(text: &str) -> Result<u16, CliError> {
    parse_number(text, u16::MAX.into())
        .map(|v| v as u16)
        .map_err(CliError::usage)
}

/// A slave address for `--unit` (0 broadcast, 1–255, [Modbus/USS] §3.3.2).
pub fn parse_unit(text: &str) -> Result<u8, String> {
    parse_number(text, u8::MAX.into()).map(|v| v as u8)
}

/// `--addr` as typed: at most 65536 (the last register with `--base 1`).
fn parse_address(text: &str) -> Result<u32, String> {
    parse_number(text, 0x1_0000).map(|v| v as u32)
}

/// Where a read or write starts, in the user's numbering.
#[derive(Debug, Clone, Args)]
pub struct AddressArgs {
    /// First address: decimal, 0x hex or 16# hex; the first address of the base when omitted.
    #[arg(long, value_parser = parse_address)]
    addr: Option<u32>,
    /// Address numbering: 0 = PDU addresses as on the wire (0–65535); 1 = Modicon-style,
    /// address 1 is PDU address 0 (1–65536). Printed addresses use the same numbering.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=1))]
    base: u8,
}

impl AddressArgs {
    /// The numbering the user chose (0 or 1).
    pub fn base(&self) -> u8 {
        self.base
    }

    /// The PDU address of the first of `count` items, or a usage error naming the value when it
    /// does not exist in the chosen base or the range runs past the last address.
    pub fn pdu(&self, count: u16) -> Result<u16, CliError> {
        let base = u32::from(self.base);
        let typed = self.addr.unwrap_or(base);
        let Some(pdu) = typed.checked_sub(base) else {
            return Err(CliError::usage(format!(
                "--addr {typed} does not exist with --base 1: Modicon addresses start at 1 \
                 (PDU address 0)"
            )));
        };
        let top = u32::from(u16::MAX) + base;
        if pdu > u32::from(u16::MAX) {
            return Err(CliError::usage(format!(
                "--addr {typed} is past the last address {top} (with --base {base})"
            )));
        }
        let last = pdu + u32::from(count.max(1)) - 1;
        if last > u32::from(u16::MAX) {
            return Err(CliError::usage(format!(
                "--addr {typed} with {count} items runs to {}, past the last address {top}",
                last + base
            )));
        }
        Ok(pdu as u16)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(addr: Option<u32>, base: u8) -> AddressArgs {
        AddressArgs { addr, base }
    }

    #[test]
    fn numbers_read_as_decimal_0x_or_16_hash() {
        assert_eq!(parse_number("16", 0xFFFF), Ok(16));
        assert_eq!(parse_number("0x10", 0xFFFF), Ok(16));
        assert_eq!(parse_number("0X1f", 0xFFFF), Ok(31));
        assert_eq!(parse_number("16#0E62", 0xFFFF), Ok(0x0E62));
        let e = parse_number("65536", 0xFFFF).unwrap_err();
        assert!(e.contains("65536") && e.contains("65535"), "{e}");
        assert!(parse_number("0x", 0xFFFF).is_err());
        assert!(parse_number("-1", 0xFFFF).is_err());
        assert_eq!(parse_unit("0x11"), Ok(17));
        assert!(parse_unit("256").is_err());
    }

    #[test]
    fn base_1_maps_address_1_to_pdu_0() {
        assert_eq!(at(Some(17), 1).pdu(1).unwrap(), 16);
        assert_eq!(at(Some(16), 0).pdu(1).unwrap(), 16);
        assert_eq!(at(None, 1).pdu(1).unwrap(), 0);
        assert_eq!(at(None, 0).pdu(1).unwrap(), 0);
        assert_eq!(at(Some(65536), 1).pdu(1).unwrap(), 65535);
    }

    #[test]
    fn address_0_with_base_1_is_refused_naming_the_value() {
        let e = at(Some(0), 1).pdu(1).unwrap_err().text().to_owned();
        assert!(e.contains("--addr 0") && e.contains("--base 1"), "{e}");
    }

    #[test]
    fn a_range_past_the_last_address_is_refused() {
        let e = at(Some(65535), 0).pdu(2).unwrap_err().text().to_owned();
        assert!(e.contains("65536") && e.contains("65535"), "{e}");
        assert!(at(Some(65536), 0).pdu(1).is_err());
        assert_eq!(at(Some(65534), 0).pdu(2).unwrap(), 65534);
    }
}
