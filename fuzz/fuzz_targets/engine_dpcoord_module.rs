//! The DP window module side fed arbitrary output windows at arbitrary times, with frames
//! arriving on its (loopback) serial side: no panic, the input window keeps its size, the
//! receive buffer stays bounded.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_core::{Duration, Instant};
use si_dp_coord::{LoopbackSerial, Module, ModuleConfig, WindowSize};
use si_fuzz::Input;

fuzz_target!(|data: &[u8]| {
    let mut input = Input(data);
    let window = match input.u8() % 3 {
        0 => WindowSize::Four,
        1 => WindowSize::Eight,
        _ => WindowSize::ThirtyTwo,
    };
    let size = window.bytes();
    let Ok(mut module) = Module::new(ModuleConfig::new(window), LoopbackSerial::new()) else {
        return;
    };
    let mut now = Instant::ZERO;
    while !input.is_empty() {
        let op = input.u8();
        if op & 0x80 != 0 {
            let n = usize::from(input.u8());
            module.serial_mut().inject_frame(input.take(n).to_vec());
            continue;
        }
        now = now + Duration::from_micros(u64::from(input.u16()) * 10);
        let window_out = input.take(size);
        let got = module.cycle(now, window_out);
        assert_eq!(got.len(), size);
        assert!(module.buffered() <= 64 * 1024);
        module.serial_mut().take_sent();
    }
});
