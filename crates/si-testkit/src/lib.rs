//! # si-testkit
//!
//! What the `si` crates' tests share, written once: a dev-dependency only (`publish = false`).
//!
//! - [`alloc`]: the counting global allocator of the `no_alloc` tests, which prove the si-core
//!   contract "no allocation per frame in steady state" (ARCHITECTURE.md).
//! - [`noise`]: a noise peer for the line simulator (silent, random, endless frame, flood,
//!   noise then silence), for the "bound on every job" tests of issue 21.

pub mod alloc;
pub mod noise;
