//! Zero heap allocations per job and per frame in steady state (the si-core contract,
//! ARCHITECTURE.md), under the shared counting global allocator (si-testkit): the window
//! protocol alone ([`window`]), the line engines bridged through it ([`engines`]) and the module
//! in Modbus master mode ([`modbus`]).
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

#[path = "no_alloc/engines.rs"]
mod engines;
#[path = "no_alloc/modbus.rs"]
mod modbus;
#[path = "no_alloc/window.rs"]
mod window;

fn main() {
    window::run();
    engines::run();
    modbus::run();
}
