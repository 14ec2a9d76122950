//! Modbus RTU codec: request and response decoding never panic; whatever decodes re-encodes to
//! the same ADU (CRC included).
#![no_main]
use libfuzzer_sys::fuzz_target;
use si_modbus::frame::{crc_ok, decode_request, decode_response, MAX_ADU};
use si_modbus::Adu;

fuzz_target!(|data: &[u8]| {
    let _ = crc_ok(data);
    let mut buf = [0u8; MAX_ADU];
    if let Ok((unit, request)) = decode_request(data) {
        let n = request
            .encode(unit, &mut buf)
            .expect("a decoded request encodes");
        assert_eq!(&buf[..n], data);
    }
    if let Ok((unit, response)) = decode_response(data) {
        let n = response
            .encode(unit, &mut buf)
            .expect("a decoded response encodes");
        assert_eq!(&buf[..n], data);
    }
    if let Some(adu) = Adu::from_slice(data) {
        assert_eq!(adu.as_bytes(), data);
        let _ = adu.decode_request();
        let _ = adu.decode_response();
    }
});
