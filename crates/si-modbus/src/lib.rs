//! # si-modbus
//!
//! Modbus RTU as the ET 200S SI Modbus/USS module does it ([Modbus/USS] §3.3–§3.5):
//!
//! - [`frame`]: ADU encode/decode with CRC-16, request and response PDUs of FC 01–08, 11, 12,
//!   15, 16 with the manual's limits, exceptions; zero-copy views, no allocation;
//! - [`rx`]: frame detection by silence with the manual's gap table and operating modes, and
//!   (host extension [`config::FrameEnd::Length`]) by the length the header predicts;
//! - [`master`]: the Sans-IO master engine, every outcome a STATUS of the manual;
//! - [`slave`]: the Sans-IO slave engine served by a [`slave::Store`]: plain tables, or the
//!   SIMATIC memory model reached through S_MODB's conversion DB ([`simatic`]);
//! - [`monitor`]: the passive listener of an RTU line, with the master's gap and response
//!   timeout;
//! - [`fb`]: S_SEND/S_RCV master jobs and S_MODB as the PLC programmer sees them;
//! - [`serve`]: one decoded request executed on a [`slave::Store`], shared by the RTU slave and
//!   the Modbus TCP server so both answer alike; [`serve_map`] says what a slave over a
//!   conversion DB serves and why it refused a request;
//! - [`rtu_stream`]: RTU ADUs cut out of a TCP byte stream (RTU over TCP), Sans-IO;
//! - [`mbap`]: Modbus TCP framing (MBAP header, streaming decoder), Sans-IO, over the same PDU
//!   codec as RTU;
//! - `tokio` (feature `tokio`): the `Client` trait, one method per function code, implemented
//!   by the RTU master handle (engine in a driver task), the inline master (engine in the
//!   caller's future) and `tokio::tcp`'s Modbus TCP client; a slave handle and a Modbus TCP
//!   server; one `Error` for all of them.
//!
//! ```
//! use si_modbus::frame::{Adu, Request};
//! // [Modbus/USS] §3.3.1, Table 3-9, §3.3.5: address, PDU, CRC low byte first.
//! let adu = Adu::request(1, &Request::ReadHoldingRegisters { address: 0, quantity: 10 }).unwrap();
//! assert_eq!(adu.as_bytes(), [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD]);
//! ```
//!
//! # Readings chosen where the manuals are silent or disagree
//!
//! Each is documented where it is implemented; in short:
//!
//! - quantity limits are the manual's 2040 bits / 127 registers, not the Modbus
//!   specification's, so an ADU can reach 264 bytes ([`frame`]; [Modbus/USS] §3.4.5–§3.4.16
//!   `[derived]`);
//! - the end-of-frame gap follows the Modbus/USS manual's Table 3-11 (4 ms floor at
//!   9600–38 400 bit/s), 364 ms at 110 bit/s and 1 ms above 38 400 from the 2005 manual
//!   ([`config::gap_table`]; [Modbus/USS] §3.3.5, Table 3-11 `[derived]`); it is measured between
//!   received characters ([`rx`]);
//! - ending a frame at its predicted length once its CRC checks is a host extension, off by
//!   default; the master still leaves the gap's silence before its next request
//!   ([`config::FrameEnd`]; [Modbus/USS] §3.3.5, Table 3-11);
//! - behind a port that hands bytes over in packets (a USB adapter: declared with
//!   `Engine::set_rx_latency`, or shown by a read of two or more bytes) frames also end by
//!   their length, the gap gets the port's allowance, and a framing failure's remedy names the
//!   adapter's latency timer; on a byte-by-byte port the manual's timing holds exactly
//!   ([`rx`], [`si_core::delivery`]);
//! - on RS-485 the master recognises a response by a correctly received slave address in
//!   Normal mode too, skipping a turnaround glitch ([`master::Master::with_interface`];
//!   [Modbus/USS] §3.4.1, §3.4.3);
//! - a response that fails both a length check and the CRC reports the length (0E52H/0E53H),
//!   one that fails only the CRC 0E57H ([`master::check_response`]);
//! - retries (default 0) and the broadcast turnaround (default 100 ms) are extensions
//!   ([`config::MasterConfig`]; [Modbus/USS] §3.4.3, Table 3-17, §3.4 `[derived]`);
//! - slave addresses 1–255, default 222 as printed ([`config::SlaveConfig`]; [Modbus/USS] §3.5.4,
//!   Table 3-20 `[derived]`);
//! - the whole span of a bit access must lie in one conversion range; register spans continue
//!   into the next DB; write-limit violations answer exception 02, CPU area and DB errors 04,
//!   FC05/15 on T/C 02, T/C misalignment 03 with 0832H ([`simatic`]; [Modbus/USS] §3.5.3,
//!   §3.5.5–§3.5.19 `[derived]`);
//! - the swapped FC05/FC15 formulas are read the consistent way ([`simatic`]; [Modbus/USS]
//!   §3.5.5–§3.5.19 `[derived]`);
//! - a failed master job is reported by S_SEND and S_RCV alike; FC15 sources are sent in S7
//!   memory order; FC01/02 results go first byte → low byte as printed ([`fb`]; [Modbus/USS]
//!   §3.4.2, §3.4.5–§3.4.16 `[derived]`);
//! - an S_SEND read whose result would exceed S_RCV's 200 bytes (over 100 registers or 1600
//!   bits) ends with 050EH before any request is sent ([`fb`]; [Modbus/USS] §3.4.5–§3.4.16
//!   `[derived]`);
//! - 0806H "character delay time exceeded" is never raised: in RTU the character delay time
//!   is the end-of-frame gap, and a frame it cuts short fails the checks the manual names
//!   (0E52H–0E57H, 0836H) ([`status`]; [Modbus/USS] §3.3.5, Table 3-11 `[derived]`).
//!
//! # Bounds
//!
//! The manual's "Response Time" ([Modbus/USS] §3.4.3, Table 3-17, 0830H) runs only to the **start**
//! of a response. On a line that never goes quiet (noise, a flood, a partner that sends an endless
//! frame) that alone ends no job, so the master adds host bounds derived from its configuration
//! ([`config::MasterConfig`]), and every master job — [`master::Master::request`],
//! S_SEND/S_RCV ([`fb`]), `si modbus read/write/diag` — ends with a STATUS within
//! [`config::MasterConfig::job_bound`]:
//!
//! - **one response**, once started, must be whole within
//!   `max_response_duration = 264 × t_char + tZVZ + (255 ms + t_char)`: the longest frame's
//!   wire time, the end-of-frame gap ([Modbus/USS] §3.3.5, Table 3-11) and the longest USB-adapter
//!   hold; later bytes are noise and the attempt ends with 0830H (a retry follows if configured);
//! - **one attempt**: `attempt_bound = max_response_duration` (the longest hold for silence
//!   before the request, `FrameEnd::Length` only) `+ 264 × t_char` (the request; + the V.24
//!   data output wait if configured) `+ Response Time + (255 ms + t_char)` (the response's
//!   first byte may come a port latency late; or the broadcast turnaround if longer)
//!   `+ max_response_duration`;
//! - **the job**: `job_bound = (retries + 1) × attempt_bound`; whatever is still running then
//!   fails with 0830H.
//!
//! Example: `si modbus read --response-timeout-ms 500` at 9600 bit/s 8E1 (t_char = 1.146 ms, tZVZ = 4 ms,
//! no retries): max_response_duration = 302.5 + 4 + 256.1 = 562.6 ms, and the job ends within
//! 562.6 + 302.5 + 756.1 + 562.6 = **2184 ms**, under the 2.5 s a host may wait. Against a
//! silent partner it still ends at the Response Time (0830H, 509 ms here), and a frame that
//! does end is judged by [Modbus/USS] §3.4.5–§3.4.16 as before (0831H, 0E57H, …).
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod config;
pub mod fb;
pub mod frame;
mod job_end;
pub mod master;
pub mod mbap;
pub mod monitor;
pub mod poll_counters;
pub mod quiet_guard;
pub mod rtu_stream;
pub mod rx;
pub mod scan;
pub mod serve;
pub mod serve_map;
pub mod simatic;
pub mod slave;
pub mod status;
pub mod store;
mod transmitter;
pub mod values;

#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod tokio;

pub use config::{FrameEnd, MasterConfig, Mode, SlaveConfig};
pub use frame::{Adu, Bits, ExceptionCode, Registers, Request, Response};
pub use master::{Master, MasterEvent};
pub use simatic::{ConversionDb, SimaticStore};
pub use slave::{Slave, SlaveEvent, Store, StoreError, Tables};

/// The one trait of Modbus clients, RTU and TCP ([`tokio::Client`]).
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub use crate::tokio::Client;
