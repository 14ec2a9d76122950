//! Station address lists as users type them (`1-247`, `1,2,10-20`): the Modbus scan's
//! `--units` and the USS scan's `--nodes`, parsed as a gateway line's `units` is
//! ([`si_core::address_list`]).

pub use si_core::address_list::parse;
