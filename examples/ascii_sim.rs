//! Two ASCII-driver stations on the simulated line, driven the way a PLC program drives the
//! module: S_SEND on one side, S_RCV on the other, called once per 1 ms "cycle"
//! ([ET200S SI] §2.2 quick start, §2.10).
//!
//! `cargo run --example ascii_sim`

use si_serial::ascii::fb::{SRcv, SSend};
use si_serial::ascii::{Config, EndCriterion, Link};
use si_serial::core::{Duration, Parity, SerialSettings};
use si_serial::sim::Simulator;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // 4800 bit/s 8N1, frames end with ETX (03H), as a barcode reader might send them.
    let config = Config {
        settings: SerialSettings::new(4_800, 8, Parity::None, 1)?,
        end: EndCriterion::DEFAULT_END_CHARS,
        char_delay: si_serial::core::Duration::from_millis(10),
        ..Config::default()
    };
    let mut sim = Simulator::new(1);
    let sender = sim.add_station("sender", config.settings, Link::new(config)?);
    let receiver = sim.add_station("receiver", config.settings, Link::new(config)?);
    sim.connect(sender, receiver);

    let messages: [&[u8]; 3] = [b"LOT 4711\x03", b"LOT 4712\x03", b"END\x03"];
    let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
    let mut db = [0u8; 200];
    let (mut next, mut rest) = (0, false);
    for cycle in 0..500 {
        // REQ is edge-triggered: low for one cycle after DONE, then high for the next message.
        let req = !rest && next < messages.len();
        rest = false;
        let data = messages.get(next).copied().unwrap_or_default();
        let sent = sim.with(sender, |l, now| s_send.call(l, now, req, false, data));
        if sent.done || sent.error {
            println!(
                "cycle {cycle:3}: S_SEND DONE={} STATUS={}",
                sent.done, sent.status
            );
            rest = true;
            next += 1;
        }
        let got = sim.with(receiver, |l, now| s_rcv.call(l, now, true, false, &mut db));
        if got.ndr {
            println!(
                "cycle {cycle:3}: S_RCV NDR LEN={} {:?}",
                got.len,
                String::from_utf8_lossy(&db[..got.len])
            );
        }
        if got.error {
            println!("cycle {cycle:3}: S_RCV ERROR STATUS={}", got.status);
        }
        sim.run_for(Duration::from_millis(1));
    }
    Ok(())
}
