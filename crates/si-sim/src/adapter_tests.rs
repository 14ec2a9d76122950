//! The USB adapter model: packet size, latency flush, line errors in order, announcing.

use super::*;

/// Records every hand-over (its time and bytes), every line error and the declared latency.
#[derive(Default)]
struct Host {
    reads: Vec<(Instant, Vec<u8>)>,
    errors: Vec<(Instant, LineError, usize)>,
    latency: Option<Duration>,
}

impl Engine for Host {
    type Event = ();
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.reads.push((now, bytes.to_vec()));
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.errors.push((now, error, self.reads.len()));
    }
    fn set_rx_latency(&mut self, latency: Duration) {
        self.latency = Some(latency);
    }
    fn poll_output(&mut self) -> Output<()> {
        Output::Wait(None)
    }
}

fn rig(adapter: UsbAdapter) -> (Simulator, StationId<Host>, StationId<Host>) {
    let mut sim = Simulator::new(1);
    let s = SerialSettings::default();
    let tx = sim.add_station("tx", s, Host::default());
    let rx = sim.add_station("rx", s, Host::default());
    sim.connect(tx, rx);
    sim.set_adapter(rx, adapter).unwrap();
    (sim, tx, rx)
}

const CT: u64 = 1_146; // 11 bits at 9600 bit/s, rounded up

#[test]
fn a_long_burst_arrives_in_latency_packets_and_a_full_packet_at_once() {
    let (mut sim, tx, rx) = rig(UsbAdapter::FTDI_DEFAULT);
    let data: Vec<u8> = (0..100).collect();
    sim.transmit(tx, &data);
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let host = sim.engine(rx);
    assert_eq!(host.latency, Some(Duration::from_millis(16)));
    let all: Vec<u8> = host.reads.iter().flat_map(|r| r.1.clone()).collect();
    assert_eq!(all, data);
    // First byte at 1 CT: handed over 16 ms later with the 14 that arrived by then.
    assert_eq!(host.reads[0].0, Instant::from_micros(CT + 16_000));
    assert_eq!(host.reads[0].1.len(), 14);
    // Never more than a packet.
    assert!(host.reads.iter().all(|r| r.1.len() <= 62));

    let (mut sim, tx, rx) = rig(UsbAdapter {
        latency: Duration::from_millis(255),
        ..UsbAdapter::FTDI_DEFAULT
    });
    sim.transmit(tx, &data);
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let host = sim.engine(rx);
    // 62 bytes fill a packet before 255 ms: handed over as the 62nd arrives.
    assert_eq!(
        host.reads[0].0,
        Instant::from_micros(62 * 11 * 1_000_000 / 9_600 + 1)
    );
    assert_eq!(host.reads[0].1.len(), 62);
    assert_eq!(host.reads[1].1.len(), 38);
}

#[test]
fn line_errors_reach_the_engine_in_order_with_the_bytes() {
    let (mut sim, tx, rx) = rig(UsbAdapter::FTDI_DEFAULT);
    sim.transmit(tx, &[1, 2, 3]);
    sim.schedule_break(rx, Instant::from_micros(2 * CT + 10));
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let host = sim.engine(rx);
    assert_eq!(host.reads.len(), 2);
    assert_eq!(host.reads[0].1, vec![1, 2]);
    assert_eq!(host.reads[1].1, vec![3]);
    // The BREAK came between the second and third bytes, and is handed over between them.
    assert_eq!(host.errors.len(), 1);
    assert_eq!(host.errors[0].1, LineError::Break);
    assert_eq!(host.errors[0].2, 1);
    assert_eq!(host.errors[0].0, host.reads[1].0);
}

#[test]
fn an_unannounced_adapter_tells_the_engine_nothing() {
    let (mut sim, tx, rx) = rig(UsbAdapter::FTDI_DEFAULT.unannounced());
    sim.transmit(tx, &[7]);
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let host = sim.engine(rx);
    assert_eq!(host.latency, None);
    assert_eq!(
        host.reads,
        vec![(Instant::from_micros(CT + 16_000), vec![7])]
    );
}

#[test]
fn out_of_range_settings_name_the_parameter_range_and_value() {
    let mut sim = Simulator::new(0);
    let st = sim.add_station("x", SerialSettings::default(), Host::default());
    for (bad, parameter, value) in [
        (
            UsbAdapter {
                packet_bytes: 0,
                ..UsbAdapter::FTDI_DEFAULT
            },
            "packet_bytes",
            "0",
        ),
        (
            UsbAdapter {
                packet_bytes: 63,
                ..UsbAdapter::FTDI_DEFAULT
            },
            "packet_bytes",
            "63",
        ),
        (
            UsbAdapter {
                latency: Duration::ZERO,
                ..UsbAdapter::FTDI_DEFAULT
            },
            "latency",
            "0",
        ),
        (
            UsbAdapter {
                latency: Duration::from_millis(256),
                ..UsbAdapter::FTDI_DEFAULT
            },
            "latency",
            "256",
        ),
    ] {
        let e = sim.set_adapter(st, bad).unwrap_err();
        assert_eq!(e.parameter, parameter);
        let text = e.to_string();
        assert!(text.contains(parameter) && text.contains(value), "{text}");
        assert!(text.contains(e.range), "{text}");
    }
    assert!(sim.set_adapter(st, UsbAdapter::FTDI_DEFAULT).is_ok());
}
