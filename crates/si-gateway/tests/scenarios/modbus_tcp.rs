//! `kind = "modbus-tcp"` lines: many clients serialised onto the one connection to a Modbus
//! TCP slave (si-modbus's TCP server here), answers with each client's transaction and unit id.

use crate::common::config;
use si_gateway::Gateway;
use si_modbus::frame::Request;
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::{Client, Handler, Peer, Server, ServerConfig};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// A Modbus TCP slave answering FC 03 with `1000 × unit + address` per register, exception
/// 02H from address 100; it counts its connections.
#[derive(Clone, Default)]
struct Slave {
    connections: Arc<AtomicUsize>,
}

impl Handler for Slave {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        let unit = request.unit();
        let pdu = match request.decode_request() {
            Ok((_, Request::ReadHoldingRegisters { address, quantity })) if address < 100 => {
                let mut pdu = vec![unit, 0x03, (2 * quantity) as u8];
                for r in address..address + quantity {
                    pdu.extend((1000 * u16::from(unit) + r).to_be_bytes());
                }
                pdu
            }
            _ => vec![unit, request.function() | 0x80, 0x02],
        };
        // Let other requests reach the gateway meanwhile.
        tokio::task::yield_now().await;
        TcpAdu::from_unit_pdu(request.transaction(), &pdu).ok()
    }

    fn connected(&self, _peer: &Peer) {
        self.connections.fetch_add(1, Ordering::SeqCst);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn eight_clients_share_the_one_connection_to_a_modbus_tcp_slave() {
    let slave = Slave::default();
    let server = Server::with_handler("127.0.0.1:0", ServerConfig::default(), slave.clone())
        .await
        .unwrap();
    let slave_addr = server.local_addr().unwrap();
    tokio::spawn(server.run());
    let text = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nkind = \"modbus-tcp\"\nname = \"plc\"\n\
         address = \"{slave_addr}\"\nunits = \"5\"\nunit_map = {{ 15 = 6 }}\n"
    );
    let gateway = Arc::new(Gateway::start(config(&text)).await.unwrap());
    let addr = gateway.listeners()[0].addr;
    let g = Arc::clone(&gateway);
    tokio::spawn(async move { g.run().await });
    let mut clients = Vec::new();
    for k in 0..8u16 {
        clients.push(tokio::spawn(async move {
            let c = Client::connect(addr).await.unwrap();
            for i in 0..10u16 {
                let (unit, slave_unit) = if (k + i) % 2 == 0 { (5, 5) } else { (15, 6) };
                let address = k * 10 + i;
                let r = Request::ReadHoldingRegisters {
                    address,
                    quantity: 1,
                };
                let a = c.request_adu(unit, &r).await.unwrap();
                let want = (1000 * slave_unit + address).to_be_bytes();
                assert_eq!(
                    a.unit_pdu(),
                    [unit, 0x03, 2, want[0], want[1]],
                    "client {k}"
                );
            }
            // The slave's exception passes unchanged.
            let past = Request::ReadHoldingRegisters {
                address: 100,
                quantity: 1,
            };
            let e = c.request_adu(5, &past).await.unwrap_err();
            assert!(e.to_string().contains("02"), "{e}");
        }));
    }
    for c in clients {
        c.await.unwrap();
    }
    assert_eq!(
        slave.connections.load(Ordering::SeqCst),
        1,
        "one connection for all"
    );
    let s = gateway.stats();
    assert_eq!((s.lines[0].answers, s.lines[0].exceptions), (80, 8));
}

#[test]
fn a_modbus_tcp_line_has_no_serial_keys() {
    let text = "[[line]]\nkind = \"modbus-tcp\"\naddress = \"127.0.0.1:502\"\nunits = \"1\"\nbaud = 9600\n";
    let e = si_gateway::config::File::from_toml(text).unwrap_err();
    assert!(e.contains("unknown field `baud`"), "{e}");
    let none = "[[line]]\nkind = \"modbus-tcp\"\nunits = \"1\"\n";
    let e = si_gateway::config::File::from_toml(none)
        .unwrap()
        .check()
        .unwrap_err()
        .to_string();
    assert!(e.contains("address = none"), "{e}");
}
