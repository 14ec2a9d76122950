//! # si-testkit
//!
//! What the `si` crates' tests share, written once: a dev-dependency only (`publish = false`).
//!
//! - [`alloc`]: the counting global allocator of the `no_alloc` tests, which prove the si-core
//!   contract "no allocation per frame in steady state" (ARCHITECTURE.md).
//! - [`noise`]: noise peers, a noise driver and [`noise::facing`], the set-up of every engine
//!   crate's noise test, for the "bound on every job" tests.
//! - [`job_run`]: step the line simulator while a job runs, failing past its bound.
//! - [`peers`]: external test peers (socat, pymodbus, mbpoll): skip without one, fail under
//!   `CI`; a child process killed when the test ends.
//! - [`pty`]: pseudo-terminal pairs (socat) for the pty tests of a library handle.
//! - [`relay`]: a relay between two pseudo-terminals that paces bytes at the wire's character
//!   time and can hold them like a USB adapter (the USB tests, the `si-pace` binary).
//! - [`procfs`]: threads and resident memory of the process (Linux), for the driver's
//!   thread-count test and the lines-per-process benchmark.

pub mod alloc;
pub mod job_run;
pub mod noise;
pub mod peers;
pub mod procfs;
pub mod pty;
pub mod relay;
