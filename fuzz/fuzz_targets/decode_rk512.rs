//! RK 512 telegram headers and telegrams: decoding arbitrary bytes never panics, and a decoded
//! command header encodes back to the bytes it came from.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_rk512::frame::{CommandHeader, ContinuationHeader, ReactionHeader, Telegram};

fuzz_target!(|data: &[u8]| {
    if let Ok(h) = CommandHeader::decode(data) {
        let again = h.encode();
        assert_eq!(CommandHeader::decode(&again), Ok(h));
        let _ = h.data_len();
    }
    if let Ok(h) = ContinuationHeader::decode(data) {
        assert_eq!(ContinuationHeader::decode(&h.encode()), Ok(h));
    }
    if let Ok(h) = ReactionHeader::decode(data) {
        assert_eq!(ReactionHeader::decode(&h.encode()), Ok(h));
    }
    let _ = Telegram::decode(data);
});
