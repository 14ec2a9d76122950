//! ASCII driver: splitting a stream by every end criterion never panics and loses no byte, and
//! parameter blocks decode without panicking and re-encode to what they were.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_ascii::frame::{split, ParamBlock};
use si_ascii::EndCriterion;

fuzz_target!(|data: &[u8]| {
    let Some((&head, bytes)) = data.split_first() else {
        return;
    };
    let end = match head % 3 {
        0 => EndCriterion::CharDelay,
        1 => EndCriterion::EndChars {
            first: bytes.first().copied().unwrap_or(3),
            second: head >> 2,
        },
        _ => EndCriterion::FixedLength {
            len: u16::from(head >> 2) + 1,
        },
    };
    // Every module preset's maximum frame length (200, 224, 1024).
    let max = si_core::ModulePreset::ALL[usize::from(head >> 6) % 3].max_frame_len();
    let _ = split(end, usize::from(max), bytes).count();
    if let Ok(block) = ParamBlock::decode(bytes) {
        let (encoded, len) = block.encode();
        assert_eq!(ParamBlock::decode(&encoded[..len]), Ok(block));
        let _ = block.check();
    }
});
