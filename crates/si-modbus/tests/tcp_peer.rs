//! A [`Handler`] learns which connection asks ([`Peer`]) and when connections come and go:
//! what a gateway needs for per-client counters and fair queueing.
#![cfg(feature = "tokio")]

use std::sync::{Arc, Mutex};
use std::time::Duration;

use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::{Client, Handler, Peer, Server, ServerConfig};
use si_modbus::tokio::Client as _;

/// Answers every request with its connection number in a register, and logs the connections.
#[derive(Default)]
struct Numbered {
    log: Arc<Mutex<Vec<String>>>,
}

impl Handler for Numbered {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        panic!("answer_from is called instead: {request:?}")
    }

    async fn answer_from(&self, peer: &Peer, request: TcpAdu) -> Option<TcpAdu> {
        let [hi, lo] = (peer.id as u16).to_be_bytes();
        let pdu = [request.unit(), 0x03, 2, hi, lo];
        TcpAdu::from_unit_pdu(request.transaction(), &pdu).ok()
    }

    fn connected(&self, peer: &Peer) {
        self.log.lock().unwrap().push(format!("+{}", peer.id));
    }

    fn disconnected(&self, peer: &Peer) {
        self.log.lock().unwrap().push(format!("-{}", peer.id));
    }
}

#[tokio::test]
async fn each_connection_has_its_own_number_and_is_announced() {
    let handler = Numbered::default();
    let log = Arc::clone(&handler.log);
    let server = Server::with_handler("127.0.0.1:0", ServerConfig::default(), handler)
        .await
        .unwrap();
    let addr = server.local_addr().unwrap();
    tokio::spawn(server.run());
    let a = Client::connect(addr).await.unwrap();
    let b = Client::connect(addr).await.unwrap();
    assert_eq!(a.read_holding_registers(1, 0, 1).await.unwrap(), [1]);
    assert_eq!(b.read_holding_registers(1, 0, 1).await.unwrap(), [2]);
    assert_eq!(a.read_holding_registers(1, 0, 1).await.unwrap(), [1]);
    drop(a);
    // The server notices the close on its next read; wait for it, bounded.
    for _ in 0..100 {
        if log.lock().unwrap().len() == 3 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert_eq!(*log.lock().unwrap(), ["+1", "+2", "-1"]);
    drop(b);
}
