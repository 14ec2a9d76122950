//! Capture file formats for serial line traces: what Wireshark, PulseView and GTKWave (and other
//! sniffers' files) read and write, so a line recorded by `si` opens in the engineer's own tools.
//!
//! Each format module is one format and does no I/O of its own beyond the `Read`/`Write` it is
//! given; every reader is bounded by the largest record it accepts, never by the file, and the
//! waveform writers hold one bounded chunk of samples, never the whole capture.
//!
//! Three modules join the formats to si-core's monitor (`si_core::monitor`, which this crate
//! builds on and which knows no capture format): [`pcap_out`] writes what the monitor delimits
//! as a Wireshark capture, [`pcap_in`] feeds a capture back to a decoder, and [`trace_waves`]
//! rebuilds a recorded trace's UART levels record by record. They open the files they are named.

pub mod pcap_in;
pub mod pcap_out;
pub mod pcapng;
pub mod rtac;
pub mod sigrok;
pub mod trace_levels;
pub mod trace_waves;
pub mod uart_levels;
pub mod upper_pdu;
pub mod vcd;
pub mod zip;
