//! One user program, one instance of each V.24 FB (S_VSTAT, S_VSET, S_XON, S_RTS, S_V24),
//! written once over si-core's `V24Port`: it drives an ASCII link directly and, unchanged, an
//! ASCII driver inside a simulated module through the coordination window, and both see the same
//! results (`[ET200S SI]` §2.10; `[ET200S SI 2005]` §2.12.4–§2.12.6).

use si_core::fb::Done;
use si_core::fb_v24::{SRts, SVset, SVstat, SXon, V24Port, SV24};
use si_core::{Duration, ModemSignals, Status};
use si_dp_coord::engines;
use si_dp_coord::line::EngineSerial;
use si_dp_coord::module::Module;
use si_dp_coord::{Host, HostConfig, WindowSize};
use si_sim::{Simulator, StationId};

const CYCLE: Duration = Duration::from_millis(2);

/// The user program: each FB's REQ is TRUE from the first call; S_VSTAT reads once S_VSET is
/// done. Every call with DONE or ERROR is recorded.
#[derive(Default)]
struct Program {
    xon: SXon,
    rts: SRts,
    v24: SV24,
    set: SVset,
    stat: SVstat,
    set_done: bool,
    results: Vec<(&'static str, Done)>,
    read: Option<ModemSignals>,
}

impl Program {
    /// One PLC cycle over any port.
    fn cycle<P: V24Port>(&mut self, port: &mut P) {
        let ms = Duration::from_millis;
        let xon = self.xon.call(port, true, false, 0x11, 0x13, ms(3_000));
        let rts = self.rts.call(port, true, false, ms(500));
        let v24 = self.v24.call(port, true, false, ms(10), ms(10));
        let set = self.set.call(port, true, false, true, true);
        self.set_done |= set.done;
        let stat = self.stat.call(port, self.set_done, false);
        for (name, d) in [
            ("S_XON", xon),
            ("S_RTS", rts),
            ("S_V24", v24),
            ("S_VSET", set),
            ("S_VSTAT", stat.result),
        ] {
            if d.done || d.error {
                self.results.push((name, d));
            }
        }
        if stat.result.done {
            self.read = Some(stat.signals());
        }
    }

    /// What the program saw, sorted by FB name (the window ends the jobs in its own order).
    fn seen(&self) -> Vec<(&'static str, bool, u16)> {
        let mut seen: Vec<_> = self
            .results
            .iter()
            .map(|&(name, d)| (name, d.done, d.status.code()))
            .collect();
        seen.sort();
        seen
    }
}

fn ascii_config() -> si_ascii::Config {
    si_ascii::Config {
        flow_control: si_ascii::FlowControl::XonXoff,
        ..si_ascii::Config::default()
    }
}

#[test]
fn one_v24_program_drives_an_ascii_link_and_a_window_host_alike() {
    // The ASCII link: every job ends in the call with its edge.
    let mut link = si_ascii::Link::new(ascii_config()).unwrap();
    let mut direct = Program::default();
    for _ in 0..3 {
        direct.cycle(&mut link);
    }

    // The same program through the window of a module running the ASCII driver.
    let window = WindowSize::Four;
    let mut sim = Simulator::new(7);
    let module =
        engines::ascii_module(window, si_ascii::Link::new(ascii_config()).unwrap()).unwrap();
    let settings = ascii_config().settings;
    let mut input = module.input().to_vec();
    let station: StationId<Module<EngineSerial<si_ascii::Link>>> =
        sim.add_station("M", settings, module);
    let mut host = Host::new(HostConfig::new(window)).unwrap();
    let mut windowed = Program::default();
    for _ in 0..400 {
        windowed.cycle(&mut host);
        let out = host.cycle(sim.now(), &input).to_vec();
        input = sim.with(station, |m, now| m.cycle(now, &out).to_vec());
        sim.run_for(CYCLE);
    }

    let expected = vec![
        ("S_RTS", false, 0x0550),
        ("S_V24", false, 0x0550),
        ("S_VSET", true, Status::OK.code()),
        ("S_VSTAT", true, Status::OK.code()),
        ("S_XON", true, Status::OK.code()),
    ];
    assert_eq!(direct.seen(), expected);
    assert_eq!(windowed.seen(), expected);
    // S_VSTAT read the outputs S_VSET set, on both ports.
    for read in [direct.read, windowed.read] {
        let read = read.expect("S_VSTAT done");
        assert!(read.rts && read.dtr, "{read:?}");
    }
    // S_XON's 3 s reached both ASCII drivers as the same parameter.
    let module_link = sim.engine(station).serial().engine();
    for link in [&link, module_link] {
        assert_eq!(
            link.config().xon_xoff.wait_for_xon,
            si_core::Duration::from_millis(3_000)
        );
    }
}
