//! Gateways whose lines are in-memory pipes to si-modbus slaves.

use si_gateway::config::{Config, File};
use si_gateway::open::{Connect, Opening};
use si_gateway::{Gateway, Options};
use si_modbus::frame::Request;
use si_modbus::mbap::TcpAdu;
use si_modbus::slave::Tables;
use si_modbus::tokio::Slave;
use si_modbus::SlaveConfig;
use std::sync::{Arc, Mutex};

/// The checked configuration of TOML `text`.
pub fn config(text: &str) -> Config {
    File::from_toml(text).unwrap().check().unwrap()
}

/// The slaves behind the pipes, kept running while the test holds them.
pub type Slaves = Arc<Mutex<Vec<Slave<Tables>>>>;

/// A connector giving each line a pipe to a new slave: the line's `device` names the slave's
/// address (`"7"`), whose holding register `r` holds `100 × address + r`, or the address and
/// that base (`"1@500"`: address 1, register `r` holds `500 + r`).
pub fn slaves() -> (Connect, Slaves) {
    let slaves: Slaves = Arc::default();
    let keep = Arc::clone(&slaves);
    let connect: Connect = Arc::new(move |line, _settings| {
        let keep = Arc::clone(&keep);
        let device = match &line.port.as_ref().expect("a port").device {
            si_gateway::config::Device::Port(p) | si_gateway::config::Device::Tcp(p) => p.clone(),
        };
        Box::pin(async move {
            let (address, base) = match device.split_once('@') {
                Some((a, b)) => (a.parse().unwrap(), b.parse().unwrap()),
                None => {
                    let a: u8 = device.parse().expect("a slave address as the device");
                    (a, 100 * u16::from(a))
                }
            };
            let (a, b) = tokio::io::duplex(1024);
            let mut tables = Tables::new(0, 0, 64, 0);
            for (r, v) in tables.holding_registers.iter_mut().enumerate() {
                *v = base + r as u16;
            }
            let config = SlaveConfig {
                address,
                ..SlaveConfig::default()
            };
            let slave = Slave::spawn(config, tables, b).expect("a slave");
            keep.lock().unwrap().push(slave);
            Ok(Box::new(a) as Box<dyn si_core::driver::Transport>)
        })
    });
    (connect, slaves)
}

/// Start `text`'s gateway with its lines on pipes to slaves.
pub async fn start(text: &str) -> (Gateway, Slaves) {
    let (connect, slaves) = slaves();
    let options = Options {
        opening: Opening {
            connect: Some(connect),
            ..Opening::default()
        },
        ..Options::default()
    };
    let gateway = Gateway::start_with(config(text), options).await.unwrap();
    (gateway, slaves)
}

/// FC 03, one register at `address`, of `unit`.
pub fn read(transaction: u16, unit: u8, address: u16) -> TcpAdu {
    let r = Request::ReadHoldingRegisters {
        address,
        quantity: 1,
    };
    TcpAdu::request(transaction, unit, &r).unwrap()
}
