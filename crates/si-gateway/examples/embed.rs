//! A gateway embedded in a program, with a line of the program's own kind (every holding
//! register reads 42), served on a TCP port and asked in-process.
use si_gateway::backend::{Backend, Reach};
use si_gateway::config::{Config, Line};
use si_gateway::{counters::Outcome, Gateway};
use si_modbus::mbap::TcpAdu;
use std::sync::Arc;

struct FortyTwo;
impl Backend for FortyTwo {
    fn reach<'a>(&'a self, request: &'a TcpAdu) -> Reach<'a> {
        let pdu = [request.unit(), 3, 2, 0, 42];
        let answer = TcpAdu::from_unit_pdu(request.transaction(), &pdu).unwrap_or(*request);
        Reach::Answer(Box::pin(async move { (answer, Outcome::Answer) }))
    }
}

/// Start the gateway and ask its line (run by the crate's tests/examples.rs).
#[tokio::main(flavor = "current_thread")]
pub async fn main() -> Result<(), si_gateway::Error> {
    let mut config = Config::listening("127.0.0.1:0");
    let line = Line::custom("mine", vec![1], Arc::new(FortyTwo));
    config.lines.push(line);
    let gateway = Gateway::start(config).await?;
    println!("listening on {}", gateway.listeners()[0].addr);
    let read = TcpAdu::from_unit_pdu(7, &[1, 3, 0, 0, 0, 1]).expect("a request");
    let answer = gateway.handler().call(read).await.expect("an answer");
    assert_eq!(answer.unit_pdu(), [1, 3, 2, 0, 42], "our own line answered");
    Ok(())
}
