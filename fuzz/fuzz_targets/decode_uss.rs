//! USS telegram codec: decoding never panics; a decoded telegram re-encodes to the same bytes;
//! net data parses under every PKW/PZD layout without panicking.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_uss::frame::{decode, encode, PkwWords, MAX_TELEGRAM};
use si_uss::NetData;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = decode(data) {
        let mut out = [0u8; MAX_TELEGRAM];
        let n = encode(t.adr, t.net, &mut out).expect("a decoded telegram encodes");
        assert_eq!(&out[..n], data);
    }
    let Some((&head, net)) = data.split_first() else {
        return;
    };
    let pkw = match head % 4 {
        0 => PkwWords::None,
        1 => PkwWords::Three,
        2 => PkwWords::Four,
        _ => PkwWords::Variable,
    };
    if let Ok(parsed) = NetData::parse(net, pkw, usize::from(head >> 4)) {
        let mut out = [0u8; MAX_TELEGRAM];
        let _ = parsed.write(&mut out);
    }
});
