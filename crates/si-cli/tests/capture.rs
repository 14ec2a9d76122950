//! Captures for Wireshark: `si trace export --pcap`, `si monitor --pcap` and `--from-pcap`,
//! read back by `si` itself and by `tshark` (a missing tshark is a skip with a message, a
//! failure with `CI` set, like every peer: common/mod.rs).

mod common;
#[path = "capture/round_trip.rs"]
mod round_trip;
#[path = "capture/tshark.rs"]
mod tshark;
