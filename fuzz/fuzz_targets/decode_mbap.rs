//! Modbus TCP (MBAP) framing: the streaming decoder never panics on any bytes in any chunking,
//! hands out the same ADUs whether fed whole or one byte at a time, and every ADU it hands out
//! is the bytes it was given.
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_modbus::mbap::Decoder;

/// Every ADU `data` decodes to, fed `chunk` bytes at a time; stops at a header error.
fn adus(data: &[u8], chunk: usize) -> (Vec<Vec<u8>>, bool) {
    let mut decoder = Decoder::new();
    let mut out = Vec::new();
    for mut piece in data.chunks(chunk.max(1)) {
        while !piece.is_empty() {
            match decoder.decode(&mut piece) {
                Ok(Some(adu)) => {
                    let _ = adu.decode_request();
                    let _ = adu.decode_response();
                    out.push(adu.as_bytes().to_vec());
                }
                Ok(None) => {}
                Err(_) => return (out, true),
            }
        }
    }
    (out, false)
}

fuzz_target!(|data: &[u8]| {
    let whole = adus(data, data.len());
    let bytewise = adus(data, 1);
    assert_eq!(whole, bytewise);
    // The ADUs are the input's bytes, back to back, from its start.
    let joined: Vec<u8> = whole.0.concat();
    assert_eq!(&data[..joined.len()], &joined[..]);
});
