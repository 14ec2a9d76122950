//! The RTU-over-TCP listener routes through the top-level address's router: a `unit_map`
//! applies there (the answer's address is the unit id asked), and a reload's new routes too.

use crate::common::{config, start};
use si_modbus::frame::{crc16, Adu, Request};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// A slave at address 1 (registers from 500) reached as unit 11.
const MAPPED: &str = r#"
listen = "127.0.0.1:0"
rtu_over_tcp_listen = "127.0.0.1:0"
[[line]]
name = "a"
device = "1@500"
unit_map = { 11 = 1 }
pause_ms = 0
"#;

fn fc03(unit: u8, address: u16) -> Vec<u8> {
    let r = Request::ReadHoldingRegisters {
        address,
        quantity: 1,
    };
    Adu::request(unit, &r).unwrap().as_bytes().to_vec()
}

fn with_crc(body: &[u8]) -> Vec<u8> {
    let mut v = body.to_vec();
    v.extend_from_slice(&crc16(body).to_le_bytes());
    v
}

/// Send one raw RTU frame and read the 7-byte answer to a one-register read.
async fn ask(s: &mut tokio::net::TcpStream, frame: &[u8]) -> Vec<u8> {
    s.write_all(frame).await.unwrap();
    let mut answer = [0u8; 7];
    s.read_exact(&mut answer).await.unwrap();
    answer.to_vec()
}

#[tokio::test]
async fn raw_rtu_frames_follow_unit_map_and_a_reloads_routes() {
    let (gateway, _slaves) = start(MAPPED).await;
    let extra = gateway.extra_listeners();
    assert_eq!(extra[0].event, "rtu_over_tcp_listening");
    let mut s = tokio::net::TcpStream::connect(extra[0].addr).await.unwrap();
    assert_eq!(
        ask(&mut s, &fc03(11, 3)).await,
        with_crc(&[11, 0x03, 2, 0x01, 0xF7]),
        "unit 11 reaches address 1, answered as 11"
    );
    let added =
        format!("{MAPPED}[[line]]\nname = \"b\"\ndevice = \"2\"\nunits = \"2\"\npause_ms = 0\n");
    gateway.reload(config(&added)).await.unwrap();
    assert_eq!(
        ask(&mut s, &fc03(2, 1)).await,
        with_crc(&[2, 0x03, 2, 0x00, 0xC9]),
        "the line added by the reload, on the same connection"
    );
}
