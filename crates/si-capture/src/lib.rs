//! Capture file formats for serial line traces: what other tools read, so a line recorded by
//! `si` opens in the engineer's own tools.
//!
//! Each module is one format and does no I/O of its own beyond the `Write` it is given; the
//! waveform writers hold one bounded chunk of samples, never the whole capture.

pub mod sigrok;
pub mod trace_levels;
pub mod uart_levels;
pub mod vcd;
pub mod zip;
