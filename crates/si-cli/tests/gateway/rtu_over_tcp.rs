//! The RTU-over-TCP listener (`rtu_over_tcp_listen`): raw RTU frames with their CRC over TCP,
//! as a serial device server sends them, routed like the Modbus TCP requests to the pymodbus
//! slave and answered as RTU frames; a frame with a wrong CRC gets no answer and is counted.

use super::harness::{wait_for_event, Rig};
use si_modbus::frame::{crc16, Adu, Request};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

fn fc03(unit: u8, address: u16, quantity: u16) -> Vec<u8> {
    let r = Request::ReadHoldingRegisters { address, quantity };
    Adu::request(unit, &r).unwrap().as_bytes().to_vec()
}

fn with_crc(body: &[u8]) -> Vec<u8> {
    let mut v = body.to_vec();
    v.extend_from_slice(&crc16(body).to_le_bytes());
    v
}

fn scrape(addr: &str) -> String {
    let mut s = TcpStream::connect(addr).expect("connect to /metrics");
    s.write_all(b"GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n")
        .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    text
}

#[test]
fn raw_rtu_frames_over_tcp_reach_the_slave_and_bad_crcs_are_dropped() {
    let top = "rtu_over_tcp_listen = \"127.0.0.1:0\"\nmetrics_listen = \"127.0.0.1:0\"";
    let Some(rig) = Rig::start(top, "retries = 0\nresponse_timeout_ms = 200\npause_ms = 0") else {
        return;
    };
    let rtu = wait_for_event(&rig.log, "rtu_over_tcp_listening", Duration::from_secs(10));
    let metrics = wait_for_event(&rig.log, "metrics_listening", Duration::from_secs(10));
    let mut s = TcpStream::connect(rtu["addr"].as_str().unwrap()).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.set_nodelay(true).unwrap();
    // A corrupt frame, then a good one in the same write: only the good one is answered.
    let mut bad = fc03(1, 0, 1);
    bad[6] ^= 0xFF;
    let mut burst = bad;
    burst.extend(fc03(1, 3, 3));
    s.write_all(&burst).unwrap();
    let mut answer = [0u8; 11];
    s.read_exact(&mut answer).unwrap();
    assert_eq!(answer[..], with_crc(&[1, 0x03, 6, 0, 3, 0, 4, 0, 5])[..]);
    // The silent line's unit: 0BH as an RTU exception frame.
    s.write_all(&fc03(2, 0, 1)).unwrap();
    let mut exception = [0u8; 5];
    s.read_exact(&mut exception).unwrap();
    assert_eq!(exception[..], with_crc(&[2, 0x83, 0x0B])[..]);
    let text = scrape(metrics["addr"].as_str().unwrap());
    for want in [
        "si_gateway_rtu_over_tcp_frames_total{outcome=\"crc_error\"} 1\n",
        "si_gateway_rtu_over_tcp_frames_total{outcome=\"ok\"} 2\n",
        "si_gateway_requests_total{line=\"meters\",unit=\"1\",outcome=\"answer\"} 1\n",
    ] {
        assert!(text.contains(want), "{want} not in\n{text}");
    }
    rig.stop();
}
