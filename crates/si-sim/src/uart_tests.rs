//! The FIFO UART model: trigger level, character timeout, host service latency, overrun,
//! declaring; and the simulator's declaration of direct stations.

use super::*;

/// Records every read (its time and bytes), every line error and what was declared.
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

const CT: u64 = 1_146; // 11 bits at 9600 bit/s, rounded up

fn rig(uart: Option<FifoUart>) -> (Simulator, StationId<Host>, StationId<Host>) {
    let mut sim = Simulator::new(1);
    let s = SerialSettings::default();
    let tx = sim.add_station("tx", s, Host::default());
    let rx = sim.add_station("rx", s, Host::default());
    sim.connect(tx, rx);
    if let Some(uart) = uart {
        sim.set_uart(rx, uart).unwrap();
    }
    (sim, tx, rx)
}

fn reads(sim: &mut Simulator, uart: FifoUart, n: usize) -> Vec<(Instant, Vec<u8>)> {
    let (mut s, tx, rx) = rig(Some(uart));
    let bytes: Vec<u8> = (0..n as u8).collect();
    s.transmit(tx, &bytes);
    s.run_until_quiet(Instant::from_micros(1_000_000));
    *sim = s;
    sim.engine(rx).reads.clone()
}

#[test]
fn the_fifo_interrupts_at_its_trigger_level_and_the_tail_after_four_character_times() {
    let uart = FifoUart::LINUX_16550A
        .with_trigger(8)
        .with_service(Duration::ZERO);
    let mut sim = Simulator::new(0);
    let got = reads(&mut sim, uart, 20);
    let sizes: Vec<usize> = got.iter().map(|r| r.1.len()).collect();
    assert_eq!(sizes, vec![8, 8, 4]);
    assert_eq!(got[0].0.as_micros(), 8 * CT - 1); // the 8th character's end (exact: 88/9600 s)
                                                  // The tail: 4 character times after its last character (the 20th).
    let last = SerialSettings::default().chars_time(20).as_micros();
    assert_eq!(
        got[2].0.as_micros(),
        last + 4 * SerialSettings::default().char_time().as_micros()
    );
}

#[test]
fn trigger_one_hands_every_character_over_at_wire_pace() {
    let uart = FifoUart::LINUX_16550A.with_trigger(1);
    let mut sim = Simulator::new(0);
    let got = reads(&mut sim, uart, 10);
    assert!(got.iter().all(|r| r.1.len() == 1));
    let service = uart.service.as_micros();
    for (k, r) in got.iter().enumerate() {
        let end = SerialSettings::default()
            .chars_time(k as u64 + 1)
            .as_micros();
        assert_eq!(r.0.as_micros(), end + service);
    }
}

#[test]
fn characters_arriving_while_the_host_reads_come_with_the_read() {
    // Read 3 character times after the interrupt: 3 more characters have arrived by then.
    let uart = FifoUart::LINUX_16550A
        .with_trigger(4)
        .with_service(Duration::from_micros(3 * CT));
    let mut sim = Simulator::new(0);
    let got = reads(&mut sim, uart, 7);
    assert_eq!(got[0].1, vec![0, 1, 2, 3, 4, 5, 6]);
}

#[test]
fn a_slow_host_loses_characters_past_sixteen_with_one_overrun_after_them() {
    let uart = FifoUart::LINUX_16550A
        .with_trigger(14)
        .with_service(Duration::from_millis(10));
    let (mut sim, tx, rx) = rig(Some(uart));
    sim.transmit(tx, &(0..30u8).collect::<Vec<_>>());
    sim.run_until_quiet(Instant::from_micros(1_000_000));
    let host = sim.engine(rx);
    assert_eq!(host.reads[0].1, (0..16u8).collect::<Vec<_>>());
    assert_eq!(host.errors.len(), 1);
    assert_eq!(
        (host.errors[0].1, host.errors[0].2),
        (LineError::Overrun, 1)
    );
}

#[test]
fn direct_stations_are_declared_byte_by_byte_and_fifo_uarts_only_when_announced() {
    let (mut sim, tx, rx) = rig(Some(FifoUart::LINUX_16550A));
    sim.run_for(Duration::from_millis(1));
    assert_eq!(sim.engine(tx).latency, Some(Duration::ZERO));
    assert_eq!(
        sim.engine(rx).latency,
        None,
        "an unannounced UART declares nothing"
    );
    let (mut sim, _, rx) = rig(Some(FifoUart::LINUX_16550A.with_trigger(14).announced()));
    sim.run_for(Duration::from_millis(1));
    let hold =
        SerialSettings::default().char_time().saturating_mul(16) + FifoUart::LINUX_16550A.service;
    assert_eq!(sim.engine(rx).latency, Some(hold));
}

#[test]
fn a_trigger_level_outside_the_16550s_is_refused_by_name() {
    let (mut sim, _, rx) = rig(None);
    let e = sim
        .set_uart(rx, FifoUart::LINUX_16550A.with_trigger(2))
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "FIFO UART trigger = 2 is out of range 1, 4, 8 or 14"
    );
}
