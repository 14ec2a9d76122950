//! DP window protocol: window images, parameter blocks and the trace description decode from
//! arbitrary bytes without panicking; parameter blocks re-encode to what they were.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_dp_coord::frame::{describe, Direction, V24Layout};
use si_dp_coord::{ParamBlock, Window};

fuzz_target!(|data: &[u8]| {
    if let Some(w) = Window::from_bytes(data) {
        assert_eq!(w.as_bytes(), data);
        for dir in [Direction::HostToModule, Direction::ModuleToHost] {
            let _ = describe(&w, dir, V24Layout::default());
        }
    }
    if let Ok(block) = ParamBlock::decode(data) {
        let (bytes, n) = block.encode();
        assert_eq!(ParamBlock::decode(&bytes[..n]), Ok(block));
    }
});
