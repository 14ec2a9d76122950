//! The window to a simulated module on a pseudo-terminal: the module (window protocol, 3964(R)
//! on its line) runs under the si-core driver on one end of a socat pty pair, a plain 3964(R)
//! link plays the serial partner on the other, and the host exchanges the 8-byte window with
//! the module every 5 ms. A send job through the window reaches the partner; the partner's
//! answer comes back through a receive job.
//!
//! Peer: `apt-get install socat`. Missing, the test is skipped with a message; with `CI` set it
//! fails instead.
#![cfg(target_os = "linux")]

use std::time::Duration;

use si_3964r::{Config, Event, Link, Priority};
use si_core::driver::{spawn, DriverOptions};
use si_core::port::{self, PortOptions};
use si_core::{Instant, SerialSettings};
use si_dp_coord::host::{Host, HostEvent, Job, Outcome};
use si_dp_coord::{engines, HostConfig, WindowSize};
use si_testkit::pty::pty_pair;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_send_and_a_receive_through_the_window_of_a_module_on_a_pty() {
    let Some(pair) = pty_pair() else { return };
    let line = SerialSettings::default();
    let options = DriverOptions {
        settings: Some(line),
        ..DriverOptions::default()
    };
    let module_port = port::open(&pair.a, &line, &PortOptions::default()).unwrap();
    let module = engines::r3964r_module(
        WindowSize::Eight,
        Link::new(Config::default().with_settings(line)).unwrap(),
    )
    .unwrap();
    let (module, _module_task) = spawn(module, module_port, options.clone());
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let partner_port = port::open(&pair.b, &line, &PortOptions::default()).unwrap();
    let (mut partner, _partner_task) = spawn(
        Link::new(high.with_settings(line)).unwrap(),
        partner_port,
        options,
    );

    let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    let mut input = module.call(|m, _| m.input().to_vec()).await.unwrap();
    let started = std::time::Instant::now();
    let now = || Instant::from_micros(started.elapsed().as_micros() as u64);
    let frame = b"through the window to the partner";
    let send = host.submit(Job::Send(frame[..].into())).unwrap();
    let mut receive = None;
    let mut answered = false;
    let mut got = None;
    let mut tick = tokio::time::interval(Duration::from_millis(5));
    while got.is_none() && started.elapsed() < Duration::from_secs(15) {
        tick.tick().await;
        let output = host.cycle(now(), &input).to_vec();
        input = module
            .call(move |m, now| m.cycle(now, &output).to_vec())
            .await
            .unwrap();
        while let Some(event) = host.poll_event() {
            match event {
                HostEvent::Completed { id, result, .. } if id == send => {
                    assert_eq!(result, Ok(Outcome::Sent));
                }
                HostEvent::Completed { id, result, .. } if Some(id) == receive => match result {
                    Ok(Outcome::Received(f)) => got = Some(f),
                    Ok(Outcome::NoMessage) => receive = None,
                    other => panic!("the receive job ended with {other:?}"),
                },
                _ => {}
            }
        }
        while let Some(event) = partner.try_next_event() {
            if let Event::Received { .. } = event {
                let block = partner.call(|l, now| l.take_block(now)).await.unwrap();
                assert_eq!(block.as_deref(), Some(&frame[..]));
                partner
                    .call(|l, now| l.send(now, b"answer".to_vec()))
                    .await
                    .unwrap()
                    .unwrap();
                answered = true;
            }
        }
        if answered && receive.is_none() {
            receive = Some(host.submit(Job::Receive).unwrap());
        }
    }
    assert_eq!(got.as_deref(), Some(&b"answer"[..]));
}
