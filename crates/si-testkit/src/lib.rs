//! # si-testkit
//!
//! What the `si` crates' tests share, written once: a dev-dependency only (`publish = false`).
//!
//! - [`alloc`]: the counting global allocator of the `no_alloc` tests, which prove the si-core
//!   contract "no allocation per frame in steady state" (ARCHITECTURE.md).

pub mod alloc;
