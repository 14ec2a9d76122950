//! One user program, two transports: S_SEND and S_RCV (si-core's `fb::Channel`) over any
//! `JobPort`, run first directly on two 3964(R) links (a host with its own
//! serial port), then through the DP windows of two simulated ET 200S SI modules that run
//! 3964(R) on their line ([ET200S SI 2005] §2.12, §2.10).
//!
//! `cargo run --example dpcoord_sim`

use si_serial::core::fb::Channel;
use si_serial::core::job::FramePort;
use si_serial::core::{Duration, Instant, SerialSettings};
use si_serial::dp_coord::line::EngineSerial;
use si_serial::dp_coord::module::Module;
use si_serial::dp_coord::{engines, Host, HostConfig, WindowSize};
use si_serial::r3964::{config::Priority, Config, Link};
use si_serial::sim::{Simulator, StationId};

/// The user program: sends its message once, prints what arrives. Unchanged for both transports.
struct Program {
    name: &'static str,
    channel: Channel,
    message: &'static [u8],
    sent: bool,
    db: [u8; 200],
}

impl Program {
    fn new(name: &'static str, message: &'static [u8]) -> Self {
        Program {
            name,
            channel: Channel::default(),
            message,
            sent: false,
            db: [0; 200],
        }
    }

    fn cycle<P: FramePort>(&mut self, port: &mut P, now: Instant) {
        if !self.sent {
            let d = self
                .channel
                .s_send
                .call(port, now, true, false, self.message);
            if d.done || d.error {
                self.sent = true;
                println!(
                    "{now} {}: S_SEND done={} STATUS={}",
                    self.name, d.done, d.status
                );
            }
        }
        let r = self
            .channel
            .s_rcv
            .call(port, now, true, false, &mut self.db);
        if r.ndr {
            let text = String::from_utf8_lossy(&self.db[..r.len]);
            println!("{now} {}: S_RCV NDR LEN={} {text:?}", self.name, r.len);
        } else if r.error {
            println!("{now} {}: S_RCV ERROR STATUS={}", self.name, r.status);
        }
    }
}

const CYCLE: Duration = Duration::from_millis(2);

fn link(priority: Priority, line: SerialSettings) -> Link {
    Link::new(
        (Config {
            priority,
            ..Config::default()
        })
        .with_settings(line),
    )
    .expect("valid 3964(R) parameters")
}

fn main() {
    let line = SerialSettings::default();

    println!("-- directly on the 3964(R) links");
    let mut sim = Simulator::new(1);
    let a = sim.add_station("A", line, link(Priority::High, line));
    let b = sim.add_station("B", line, link(Priority::Low, line));
    sim.connect(a, b);
    let mut pa = Program::new("A", b"ping");
    let mut pb = Program::new("B", b"pong");
    for _ in 0..500 {
        sim.with(a, |l, now| pa.cycle(l, now));
        sim.with(b, |l, now| pb.cycle(l, now));
        sim.run_for(CYCLE);
    }

    println!("-- through the DP windows of two modules running 3964(R)");
    let mut sim = Simulator::new(1);
    let window = WindowSize::Eight;
    let ma = engines::r3964r_module(window, link(Priority::High, line)).expect("valid module");
    let mb = engines::r3964r_module(window, link(Priority::Low, line)).expect("valid module");
    let mut a = Dp::new(&mut sim, "A", line, ma);
    let mut b = Dp::new(&mut sim, "B", line, mb);
    sim.connect(a.station, b.station);
    let mut pa = Program::new("A", b"ping");
    let mut pb = Program::new("B", b"pong");
    for _ in 0..500 {
        pa.cycle(&mut a.host, sim.now());
        pb.cycle(&mut b.host, sim.now());
        a.exchange(&mut sim);
        b.exchange(&mut sim);
        sim.run_for(CYCLE);
    }
}

/// A DP master's view of one module: its host engine and the last input window.
struct Dp {
    station: StationId<Module<EngineSerial<Link>>>,
    host: Host,
    input: Vec<u8>,
}

impl Dp {
    fn new(
        sim: &mut Simulator,
        name: &str,
        line: SerialSettings,
        module: Module<EngineSerial<Link>>,
    ) -> Dp {
        let input = module.input().to_vec();
        let host = Host::new(HostConfig::new(module.config().window)).expect("valid host");
        Dp {
            station: sim.add_station(name, line, module),
            host,
            input,
        }
    }

    /// One DP cycle: the host's output window to the module, its input window back.
    fn exchange(&mut self, sim: &mut Simulator) {
        let output = self.host.cycle(sim.now(), &self.input).to_vec();
        self.input = sim.with(self.station, |m, now| m.cycle(now, &output).to_vec());
    }
}
