//! 3964(R) block codec: `decode` and the streaming decoder never panic, never hold more than the
//! maximum, agree with each other, and decoding an encoded payload gives it back.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_3964r::frame::{decode, encode, Decoder, Mode};

fuzz_target!(|data: &[u8]| {
    let Some((&head, bytes)) = data.split_first() else {
        return;
    };
    let mode = if head & 1 == 0 {
        Mode::BlockCheck
    } else {
        Mode::NoBlockCheck
    };
    let max = usize::from(head >> 1) * 2;
    let whole = decode(bytes, mode, max);
    let mut d = Decoder::new(mode, max);
    let mut end = None;
    for (i, &b) in bytes.iter().enumerate() {
        assert!(d.payload().len() <= max);
        if let Some(r) = d.push(b) {
            end = Some((i + 1, r));
            break;
        }
    }
    let mut fast = Decoder::new(mode, max);
    match (fast.push_slice(bytes), end) {
        ((used, Some(r)), Some((at, slow))) => {
            assert_eq!((used, r), (at, slow));
            assert_eq!(fast.payload(), d.payload());
            if used == bytes.len() && r.is_ok() {
                assert_eq!(whole.as_deref(), Ok(d.payload()));
            } else {
                assert!(whole.is_err());
            }
        }
        ((_, None), None) => assert!(whole.is_err()),
        (fast, slow) => panic!("push_slice {fast:?} but push {slow:?}"),
    }
    if bytes.len() <= max {
        assert_eq!(
            decode(&encode(bytes, mode), mode, max).as_deref(),
            Ok(bytes)
        );
    }
});
