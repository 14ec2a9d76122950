//! The library's API: start, the mountable handler, stats, events, run and shutdown.

use crate::common::{read, start};
use si_modbus::frame::Request;

const ONE_LINE: &str = r#"
listen = "127.0.0.1:0"
[[line]]
name = "meters"
device = "7"
units = "7"
pause_ms = 0
response_timeout_ms = 100
retries = 0
"#;

#[tokio::test]
async fn the_handler_routes_answers_and_counts() {
    let (gateway, _slaves) = start(ONE_LINE).await;
    let h = gateway.handler();
    let answer = h.call(read(1, 7, 2)).await.unwrap();
    assert_eq!(answer.transaction(), 1);
    assert_eq!(answer.unit_pdu(), [7, 0x03, 2, 0x02, 0xBE]);
    // No line serves unit 9: 0AH.
    let answer = h.call(read(2, 9, 0)).await.unwrap();
    assert_eq!(answer.unit_pdu(), [9, 0x83, 0x0A]);
    let stats = gateway.stats();
    assert_eq!((stats.lines[0].requests, stats.lines[0].answers), (1, 1));
    assert_eq!(stats.down, [None]);
    assert_ne!(gateway.listeners()[0].addr.port(), 0);
}

#[tokio::test]
async fn a_tcp_client_is_served_until_shutdown() {
    let (gateway, _slaves) = start(ONE_LINE).await;
    let addr = gateway.listeners()[0].addr;
    let stop = gateway.shutdown_handle();
    let client = async move {
        let c = si_modbus::tokio::tcp::Client::connect(addr).await.unwrap();
        let r = Request::ReadHoldingRegisters {
            address: 5,
            quantity: 1,
        };
        let answer = c.request_adu(7, &r).await.unwrap();
        stop.shutdown();
        answer
    };
    let (ran, answer) = tokio::join!(gateway.run(), client);
    assert_eq!(ran, Ok(()), "shut down, not failed");
    assert_eq!(answer.unit_pdu(), [7, 0x03, 2, 0x02, 0xC1]);
    // A second run returns at once.
    assert_eq!(gateway.run().await, Ok(()));
}

/// In virtual time: a line whose device is away at start starts down (0AH), and the events
/// say so, then that it came up once its device is there.
#[tokio::test(start_paused = true)]
async fn events_tell_a_line_down_at_start_and_up() {
    use si_gateway::open::{Connect, Opening};
    use si_gateway::{Error, Event, Gateway, Options};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let (pipes, _slaves) = crate::common::slaves();
    let there = Arc::new(AtomicBool::new(false));
    let seen = Arc::clone(&there);
    let connect: Connect = Arc::new(move |line, settings| {
        if seen.load(Ordering::SeqCst) {
            pipes(line, settings)
        } else {
            Box::pin(async { Err(Error::Port("away".into())) })
        }
    });
    let options = Options {
        opening: Opening {
            connect: Some(connect),
            ..Opening::default()
        },
        ..Options::default()
    };
    let text = format!("allow_down_at_start = true\n{ONE_LINE}");
    let gateway = Gateway::start_with(crate::common::config(&text), options)
        .await
        .unwrap();
    let mut events = gateway.events();
    let answer = gateway.handler().call(read(1, 7, 0)).await.unwrap();
    assert_eq!(answer.unit_pdu(), [7, 0x83, 0x0A], "down: 0AH");
    assert_eq!(
        events.recv().await.unwrap(),
        Event::LineDown {
            line: 0,
            name: "meters".into(),
            reason: "away".into(),
            at_start: true
        }
    );
    there.store(true, Ordering::SeqCst);
    let up = events.recv().await.unwrap();
    assert!(
        matches!(
            up,
            Event::LineUp {
                line: 0,
                reopened: false,
                ..
            }
        ),
        "{up:?}"
    );
    let answer = gateway.handler().call(read(2, 7, 0)).await.unwrap();
    assert_eq!(answer.unit_pdu(), [7, 0x03, 2, 0x02, 0xBC]);
}

/// The gateway's handler mounted in a program's own si-modbus TCP server: the same routes.
#[tokio::test]
async fn the_handler_mounts_in_a_programs_own_tcp_server() {
    use si_modbus::tokio::tcp::{Client, Server, ServerConfig};
    let (gateway, _slaves) = start(ONE_LINE).await;
    let own = Server::with_handler("127.0.0.1:0", ServerConfig::default(), gateway.handler())
        .await
        .unwrap();
    let addr = own.local_addr().unwrap();
    tokio::spawn(own.run());
    let c = Client::connect(addr).await.unwrap();
    let r = Request::ReadHoldingRegisters {
        address: 4,
        quantity: 1,
    };
    let answer = c.request_adu(7, &r).await.unwrap();
    assert_eq!(answer.unit_pdu(), [7, 0x03, 2, 0x02, 0xC0]);
    assert_eq!(gateway.stats().lines[0].answers, 1);
}
