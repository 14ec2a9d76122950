//! The SF, TX and RX LEDs ([ET200S SI 2005] §2.1, §2.9.5, Table 2-12, §9.3).

use proptest::prelude::*;
use si_core::Instant;
use si_module::led::{leds, Firmware, Leds, Light, ModuleState, OperatingMode};

fn at(ms: u64) -> Instant {
    Instant::from_micros(ms * 1_000)
}

#[test]
fn table_2_12_firmware_update_patterns() {
    let of = |firmware| {
        leds(&ModuleState {
            firmware,
            // Whatever else is going on, the firmware state decides.
            transmitting: true,
            wire_break: true,
            ..ModuleState::default()
        })
    };
    let on = Light::On;
    let off = Light::Off;
    let flash = Light::Flashing;
    assert_eq!(
        of(Firmware::Updating),
        Leds {
            sf: on,
            tx: on,
            rx: on
        }
    );
    assert_eq!(
        of(Firmware::UpdateFinished),
        Leds {
            sf: on,
            tx: off,
            rx: off
        }
    );
    assert_eq!(
        of(Firmware::Missing),
        Leds {
            sf: flash,
            tx: off,
            rx: off
        }
    );
    assert_eq!(
        of(Firmware::HardwareFault),
        Leds {
            sf: flash,
            tx: flash,
            rx: flash
        }
    );
    // 2 Hz: lit for 250 ms, dark for 250 ms, all three in phase.
    let fault = of(Firmware::HardwareFault);
    assert_eq!(fault.lit(at(0)), (true, true, true));
    assert_eq!(fault.lit(at(249)), (true, true, true));
    assert_eq!(fault.lit(at(250)), (false, false, false));
    assert_eq!(fault.lit(at(500)), (true, true, true));
    assert_eq!(of(Firmware::Missing).lit(at(750)), (false, false, false));
}

#[test]
fn section_1_6_sf_sources() {
    let quiet = ModuleState::default();
    assert_eq!(leds(&quiet), Leds::default());
    for state in [
        ModuleState {
            hardware_fault: true,
            ..quiet
        },
        ModuleState {
            parameter_error: true,
            ..quiet
        },
        ModuleState {
            wire_break: true,
            ..quiet
        },
        ModuleState {
            communication_error: true,
            ..quiet
        },
        ModuleState {
            mode: OperatingMode::Parameterizing,
            ..quiet
        },
    ] {
        assert_eq!(leds(&state).sf, Light::On, "{state:?}");
    }
    // STOP alone does not light SF; its cause does.
    let stop = ModuleState {
        mode: OperatingMode::Stop,
        ..quiet
    };
    assert_eq!(leds(&stop).sf, Light::Off);
}

#[test]
fn tx_and_rx_follow_the_line_in_run_only() {
    let both = ModuleState {
        transmitting: true,
        receiving: true,
        ..ModuleState::default()
    };
    assert_eq!(leds(&both).lit(at(123)), (false, true, true));
    let only_rx = ModuleState {
        receiving: true,
        ..ModuleState::default()
    };
    assert_eq!(leds(&only_rx).lit(at(0)), (false, false, true));
    for mode in [OperatingMode::Stop, OperatingMode::Parameterizing] {
        let l = leds(&ModuleState { mode, ..both });
        assert_eq!((l.tx, l.rx), (Light::Off, Light::Off), "{mode:?}");
    }
}

proptest! {
    #[test]
    fn steady_lights_do_not_depend_on_time(bits: [bool; 6], t1: u64, t2: u64) {
        let state = ModuleState {
            hardware_fault: bits[0],
            parameter_error: bits[1],
            wire_break: bits[2],
            communication_error: bits[3],
            transmitting: bits[4],
            receiving: bits[5],
            ..ModuleState::default()
        };
        let l = leds(&state);
        prop_assert_eq!(l.lit(Instant::from_micros(t1)), l.lit(Instant::from_micros(t2)));
        prop_assert_eq!(l.sf == Light::On, bits[..4].iter().any(|b| *b));
    }
}

#[test]
fn tx_and_rx_follow_a_simulated_line_in_virtual_time() {
    use si_core::Duration;
    use si_sim::Simulator;
    let config = si_ascii::Config::default();
    let settings = config.settings;
    let mut sim = Simulator::new(1);
    let a = sim.add_station("A", settings, si_ascii::Link::new(config).unwrap());
    let b = sim.add_station("B", settings, si_ascii::Link::new(config).unwrap());
    sim.connect(a, b);
    let start = sim.now();
    sim.with(a, |l, now| l.send(now, "hello".into())).unwrap();
    sim.run_until_quiet(start + Duration::from_secs(1));
    let trace = sim.trace();
    let led = |station: &str, at: Instant| {
        leds(&ModuleState::default().with_line(trace, station, &settings, at)).lit(at)
    };
    // 5 characters of 11 bits at 9600 bit/s: 5.73 ms on the line.
    let mid = Instant::from_micros(start.as_micros() + 3_000);
    assert_eq!(led("A", mid), (false, true, false), "sender: TX");
    assert_eq!(led("B", mid), (false, false, true), "receiver: RX");
    let after = Instant::from_micros(start.as_micros() + 7_000);
    assert_eq!(led("A", after), (false, false, false));
    assert_eq!(led("B", after), (false, false, false));
    // Both light with the first bit (the simulated line has no propagation delay).
    assert_eq!(
        led("A", start),
        (false, true, false),
        "TX lights with the first bit"
    );
    assert_eq!(led("B", start), (false, false, true));
}
