//! Property tests: nothing panics on any input, and every job ends in exactly one completion,
//! also with the real line engines on a faulty line.

mod common;
#[path = "proptests/engines_chaos.rs"]
mod engines_chaos;
#[path = "proptests/never_panics.rs"]
mod never_panics;
