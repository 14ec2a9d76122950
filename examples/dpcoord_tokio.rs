//! A simulated ET 200S SI module in real time: the module (window protocol on one side, 3964(R)
//! on its line) runs under the tokio driver on one end of an in-memory pipe, a plain 3964(R)
//! link plays the serial partner on the other end, and a DP master task exchanges the 8-byte
//! window every 5 ms. The user program calls S_SEND and S_RCV through the window
//! ([ET200S SI 2005] §2.12, §2.10). Replace the pipe with a serial port or a TCP
//! device server (any `si_core::driver::Transport`) and the module talks to real equipment; the
//! `si dp-coord module` command does exactly that.
//!
//! `cargo run --example dpcoord_tokio --features tokio`

use si_serial::core::driver::{spawn, DriverOptions};
use si_serial::core::SerialSettings;
use si_serial::dp_coord::fb::{SRcv, SSend};
use si_serial::dp_coord::{engines, Host, HostConfig, WindowSize};
use si_serial::r3964::{config::Priority, Config, Event, Link};
use std::time::Duration;

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let line = SerialSettings::default();
    let options = DriverOptions {
        settings: Some(line),
        ..DriverOptions::default()
    };
    let (module_end, partner_end) = tokio::io::duplex(1024);

    // The module: window protocol + 3964(R) (low priority) on the line.
    let module = engines::r3964r_module(
        WindowSize::Eight,
        Link::new(Config::default().with_settings(line))?,
    )?;
    let (module, _module_task) = spawn(module, module_end, options.clone());

    // The serial partner: 3964(R), high priority.
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let (mut partner, _partner_task) =
        spawn(Link::new(high.with_settings(line))?, partner_end, options);

    // The DP master and the user program: one cycle every 5 ms.
    let mut host = Host::new(HostConfig::new(WindowSize::Eight))?;
    let mut input = module.call(|m, _| m.input().to_vec()).await?;
    let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
    let mut db = [0u8; 224];
    let mut tick = tokio::time::interval(Duration::from_millis(5));
    let (mut sent, mut replied, mut got_reply) = (false, false, false);
    let start = std::time::Instant::now();
    while !got_reply && start.elapsed() < Duration::from_secs(10) {
        tick.tick().await;
        // User program.
        if !sent {
            let d = s_send.call(
                &mut host,
                now(start),
                true,
                false,
                b"hello from the PLC side",
            );
            if d.done || d.error {
                println!("S_SEND done={} STATUS={}", d.done, d.status);
                sent = true;
            }
        }
        let r = s_rcv.call(&mut host, now(start), true, false, &mut db);
        if r.ndr {
            println!("S_RCV NDR {:?}", String::from_utf8_lossy(&db[..r.len]));
            got_reply = true;
        } else if r.error {
            println!("S_RCV ERROR STATUS={}", r.status);
        }
        // DP exchange.
        let output = host.cycle(now(start), &input).to_vec();
        input = module
            .call(move |m, now| m.cycle(now, &output).to_vec())
            .await?;
        // The partner: print what arrives, answer once.
        while let Ok(Some(event)) =
            tokio::time::timeout(Duration::from_millis(0), partner.next_event()).await
        {
            if let Event::Received { .. } = event {
                let block = partner.call(|l, now| l.take_block(now)).await?;
                println!(
                    "partner received {:?}",
                    block.map(|b| String::from_utf8_lossy(&b).into_owned())
                );
                if !replied {
                    partner
                        .call(|l, now| l.send(now, &b"hello from the partner"[..]))
                        .await??;
                    replied = true;
                }
            }
        }
    }
    Ok(())
}

/// The host's clock: microseconds since the start.
fn now(start: std::time::Instant) -> si_serial::core::Instant {
    si_serial::core::Instant::from_micros(
        u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX),
    )
}
