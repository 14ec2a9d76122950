//! # si-dp-coord
//!
//! The coordination-byte window protocol through which a non-S7 PROFIBUS-DP master (a PC card,
//! a gateway, a test tool) talks to an ET 200S serial interface module
//! ([ET200S SI 2005] §2.12 "reference data for DP masters other
//! than S7").
//!
//! Each DP cycle the master writes a 4-, 8- or 32-byte output window and reads the input window
//! of the same size. Byte 0 is the coordination byte (bit 7 reserved, bits 6–4 job code, bit 3
//! error, bits 2–0 execution number); the other bytes carry segments of 3, 7 or 31 data bytes.
//!
//! * [`coord`] and [`frame`]: the coordination byte, window images, payload streams, the V.24
//!   signal word, flow-control parameter blocks (pure encode/decode).
//! * [`host`]: the master's engine — one arbiter owning byte 0, jobs send, receive, read/write
//!   V.24, parameters, with segmenting, go-back on the error bit, back-off on foreign job codes and
//!   a job watchdog. Every job ends in exactly one completion.
//! * [`fb`]: the host as a [`si_core::JobPort`], so si-core's S_SEND and S_RCV (and its
//!   [`si_core::fb::Channel`]) run through the window as on a line engine; S_VSTAT, S_VSET,
//!   S_XON, S_RTS, S_V24 with S7 call semantics over the host.
//! * [`module`]: the module's engine, with its serial line behind the [`module::SerialSide`]
//!   trait, for simulations and tests (and gateways that play the module).
//! * [`mod@line`]: [`line::EngineSerial`] makes any Sans-IO line engine the module's serial side, and
//!   the module itself a station of the line simulator.
//! * `engines` (feature `module-sim`): si-3964r's and si-ascii's links as that serial side, so a
//!   simulated module runs 3964(R) or ASCII on its line.
//! * `modbus` (feature `module-sim`): si-modbus's master as that serial side: the module in
//!   Modbus master mode, the S_SEND job layout ([Modbus/USS] §3.4.5–§3.4.16) in, the S_RCV
//!   response layout ([Modbus/USS]
//!   §3.4.5–§3.4.16) or the job's STATUS out.
//! * `sim` (feature `module-sim`): a host and a module joined by a seeded, lagging,
//!   fault-injecting DP exchange.
//!
//! Without `module-sim` (the default) the crate is the host side, the module's engine and the
//! monitor, and builds none of the other protocol crates.
//! * [`monitor`]: reads a recorded trace of DP windows window by window, coordination bytes
//!   and what the data bytes mean for them.
//! * [`timing`]: the manual's processing-time estimate and the PPI token rotation formula.
//! * [`status`]: the STATUS words the window carries.
//!
//! **Not built:** the Modbus/USS module's USS master mode and Modbus slave mode through the
//! window. What the Modbus slave driver hands S_MODB through S_RCV, and takes back through
//! S_SEND, is not documented ([ET200S SI 2005] `[derived]`), and no USS job layout for
//! the window is given either; nothing is invented for them.
//!
//! What describes the module itself rather than the window (its parameter sets per driver, its
//! PROFIBUS slave diagnosis, its identification records I&M0/I&M1 and its LEDs) lives in the
//! `si-module` crate, which builds on this one.
//!
//! # Readings chosen where the manual is unclear
//!
//! [ET200S SI 2005] §2.12 `[derived]` lists the gaps; each reading is documented next to the
//! code that depends on it. In short:
//!
//! | Gap | Reading | Configurable |
//! |---|---|---|
//! | Table 2-23 data shifted | our reconstruction `[derived]` (hold each segment until echoed) | — |
//! | receive request printed 10H | 20H | — |
//! | XON/XOFF 0BH/0DH in Table 2-28 | defaults DC1/DC3 = 11H/13H; any byte may be sent | values |
//! | "LSB" label on the 00H byte | MSB first, as every 16-bit word ([ET200S SI 2005] §2.12.1) | — |
//! | exec number after 7 | 1 (0 would equal the request bytes 10H/20H); [`coord::ExecWrap`] | `exec_wrap` (7 → 1 or 7 → 0) |
//! | 0101H | the answer 20H + 0101H to a receive job with nothing buffered, "not an error" | — |
//! | host error bit in a receive job | module aborts with 20H + 0551H and re-offers the frame | [`config::ReceiveErrorPolicy`] |
//! | write V.24 | data in the request, answer 40H + STATUS, host writes 00H | — |
//! | V.24 bit layout | byte 1 = 00H, byte 2 = `DCD CTS RTS DSR DTR` in bits 4…0 | [`frame::V24Layout`] |
//! | LEN > maximum | 7xH (exec of the segment with the length) + 050EH right after it | `max_frame_len` |
//! | end of receive / read V.24 | the host holds its last echo until the module is idle, then writes 00H | — |
//! | no timeouts | host job watchdog, default 30 s, STATUS 0502H | [`HostConfig`] |
//! | don't-care bytes | written as 00H, ignored when read | — |
//! | 224 vs 200 bytes | 224 (chapter 2); 200 for the Modbus/USS module (`modbus::MAX_FRAME_LEN`) | `max_frame_len` |
//!
//! ```
//! use si_dp_coord::{host::{Host, Job, HostEvent, Outcome}, module::{Module, LoopbackSerial}};
//! use si_dp_coord::config::{HostConfig, ModuleConfig};
//! use si_dp_coord::frame::WindowSize;
//! use si_core::Instant;
//!
//! let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
//! let mut module = Module::new(ModuleConfig::new(WindowSize::Eight), LoopbackSerial::new()).unwrap();
//! let id = host.submit(Job::Send(b"hello"[..].into())).unwrap();
//! let mut input = module.input().to_vec();
//! for cycle in 0..20u64 {
//!     let now = Instant::from_micros(cycle * 1_000);
//!     let output = host.cycle(now, &input).to_vec();
//!     input = module.cycle(now, &output).to_vec();
//! }
//! assert_eq!(
//!     host.poll_event(),
//!     Some(HostEvent::Completed { id, code: si_dp_coord::coord::JobCode::Send, result: Ok(Outcome::Sent) })
//! );
//! assert_eq!(module.serial().sent().next().map(|f| &f[..]), Some(&b"hello"[..]));
//! ```
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod config;
pub mod coord;
#[cfg(feature = "module-sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "module-sim")))]
pub mod engines;
pub mod fb;
pub mod frame;
pub mod host;
pub mod line;
#[cfg(feature = "module-sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "module-sim")))]
pub mod modbus;
pub mod module;
pub mod monitor;
#[cfg(feature = "module-sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "module-sim")))]
pub mod sim;
pub mod status;
pub mod timing;
#[cfg(feature = "module-sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "module-sim")))]
pub mod user_program;

pub use config::{HostConfig, ModuleConfig};
pub use coord::{CoordByte, ExecWrap, JobCode};
pub use frame::{ParamBlock, RxStatus, V24Signals, Window, WindowSize};
pub use host::{Host, HostEvent, Job, JobId, Outcome};
pub use line::{EngineSerial, LineHooks};
pub use module::{LoopbackSerial, Module, SerialEvent, SerialSide};
