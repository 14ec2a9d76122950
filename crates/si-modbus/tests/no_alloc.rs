//! Zero heap allocations per frame in steady state (the si-core contract, ARCHITECTURE.md):
//! a master polls a slave under a counting global allocator. Requests and responses are cut
//! from transmit buffers the engines keep (`split().freeze()`), and `reserve` reclaims the same
//! allocation once the driver drops the previous frame.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use si_core::Duration;
use si_modbus::frame::{Registers, Request};
use si_modbus::mbap::{Decoder, TcpAdu};
use si_modbus::serve::{execute, Outcome, ResponseData};
use si_modbus::Tables;
use si_modbus::{FrameEnd, Master, MasterConfig, MasterEvent, SimaticStore, Slave, SlaveConfig};
use si_sim::Pair;
use si_testkit::alloc::assert_no_alloc;

fn main() {
    for frame_end in [FrameEnd::Gap, FrameEnd::Length] {
        steady_state_polling_does_not_allocate(frame_end);
        println!("no_alloc: 1000 request/response cycles with {frame_end:?} allocate nothing: ok");
    }
    modbus_tcp_codec_does_not_allocate();
    println!("no_alloc: 1000 Modbus TCP request/response codec cycles allocate nothing: ok");
}

/// The Modbus TCP path of a server and a client without the sockets: encode a request, decode
/// it from a stream in two chunks, execute it on a store (the RTU slave's code), encode the
/// response and decode it again.
fn modbus_tcp_codec_does_not_allocate() {
    let mut store = Tables::new(0, 0, 64, 0);
    let mut server = Decoder::new();
    let mut client = Decoder::new();
    let words = [0x1234u16; 10];
    let requests = [
        Request::WriteMultipleRegisters {
            address: 3,
            values: Registers::Words(&words),
        },
        Request::ReadHoldingRegisters {
            address: 0,
            quantity: 20,
        },
    ];
    let mut answered = 0u32;
    assert_no_alloc("1000 Modbus TCP cycles", || {
        for transaction in 0..1_000u16 {
            let request = &requests[transaction as usize % 2];
            let adu = TcpAdu::request(transaction, 1, request).unwrap();
            let (head, tail) = adu.as_bytes().split_at(5);
            let mut input = head;
            assert!(server.decode(&mut input).unwrap().is_none());
            let mut input = tail;
            let got = server.decode(&mut input).unwrap().unwrap();
            let (unit, decoded) = got.decode_request().unwrap();
            let mut data: ResponseData = [0; 256];
            let Outcome::Answer { response, .. } = execute(&mut store, &decoded, &mut data) else {
                panic!("refused");
            };
            let reply = TcpAdu::response(got.transaction(), unit, &response).unwrap();
            let mut input = reply.as_bytes();
            let back = client.decode(&mut input).unwrap().unwrap();
            assert_eq!(back.transaction(), transaction);
            assert_eq!(back.decode_response().unwrap().1, response);
            answered += 1;
        }
    });
    assert_eq!(answered, 1_000);
}

fn steady_state_polling_does_not_allocate(frame_end: FrameEnd) {
    let master = Master::new(MasterConfig::default())
        .unwrap()
        .with_frame_end(frame_end);
    let config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    let slave = Slave::new(config, SimaticStore::example())
        .unwrap()
        .with_frame_end(frame_end);
    let mut pair = Pair::new(master, slave);
    let read = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 10,
    };
    let words = [0x1234u16; 10];
    let write = Request::WriteMultipleRegisters {
        address: 0,
        values: Registers::Words(&words),
    };
    let cycle = |pair: &mut Pair<Master, Slave<SimaticStore>>| {
        for request in [&read, &write] {
            let now = pair.now;
            pair.a.request(now, 1, request).unwrap();
            pair.run_until(now + Duration::from_millis(100));
            assert!(!pair.a.is_busy());
            assert!(
                matches!(pair.last.0, Some(MasterEvent::Completed(_))),
                "{:?}",
                pair.last.0
            );
        }
    };
    for _ in 0..20 {
        cycle(&mut pair); // warm up: queues reach their working size
    }
    let events = pair.events;
    assert_no_alloc("1000 cycles", || {
        for _ in 0..1_000 {
            cycle(&mut pair);
        }
    });
    // Every request ended in a master event (done), so the frames really went both ways.
    assert!(pair.events.0 - events.0 >= 2_000, "{:?}", pair.events);
}
