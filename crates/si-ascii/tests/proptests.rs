//! Properties: any byte stream cut by the fixed-length or the character-delay criterion
//! reassembles to the original ([ET200S SI] §2.8), and no input at any timing
//! makes the engine panic, grow without bound, or break the 1024-byte buffer ([ET200S SI] §2.8).

use proptest::prelude::*;
use si_ascii::config::min_char_delay_ms;
use si_ascii::{Config, EndCriterion, Event, FlowControl, Interface, Link};
use si_core::{
    Duration, Engine, Instant, LineError, ModemSignals, ModulePreset, Output, Parity,
    SerialSettings, SignalUpdate,
};

/// Feeds an engine with time, firing its timer whenever the clock passes the deadline, and
/// reads every frame as soon as it is reported.
struct Driver {
    link: Link,
    now: Instant,
    deadline: Option<Instant>,
    frames: Vec<Vec<u8>>,
    errors: Vec<u16>,
    completions: usize,
}

impl Driver {
    fn new(mut link: Link) -> Self {
        link.set_rx_latency(si_core::Duration::ZERO); // a byte-by-byte port: manual timing
        let mut d = Driver {
            link,
            now: Instant::ZERO,
            deadline: None,
            frames: Vec::new(),
            errors: Vec::new(),
            completions: 0,
        };
        d.drain();
        d
    }

    fn drain(&mut self) {
        for _ in 0..10_000 {
            match self.link.poll_output() {
                Output::Wait(d) => {
                    self.deadline = d;
                    return;
                }
                Output::Event(Event::Received { .. }) => {
                    if let Some(f) = self.link.read_frame_vec(self.now) {
                        self.frames.push(f);
                    }
                }
                Output::Event(Event::ReceiveError { status, .. }) => {
                    self.errors.push(status.code())
                }
                Output::Event(Event::Sent { .. } | Event::SendFailed { .. }) => {
                    self.completions += 1
                }
                Output::Transmit(b) => {
                    assert!(!b.is_empty() && b.len() <= self.link.config().max_frame())
                }
                Output::SetSignals(_) => {}
            }
        }
        panic!("the engine never said Wait");
    }

    /// Advance the clock to `to`, firing due timers on the way.
    fn advance(&mut self, to: Instant) {
        while let Some(d) = self.deadline.filter(|&d| d <= to) {
            self.now = self.now.max(d);
            self.link.handle_timeout(self.now);
            self.drain();
            if self.deadline == Some(d) {
                panic!("deadline {d} did not move after it fired");
            }
        }
        self.now = self.now.max(to);
    }

    fn rx(&mut self, at: Instant, byte: u8) {
        self.advance(at);
        self.link.handle_rx(self.now, &[byte]);
        self.drain();
    }
}

fn baud() -> impl Strategy<Value = u32> {
    prop::sample::select(vec![300u32, 1_200, 9_600, 19_200, 115_200])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn char_delay_frames_reassemble_to_the_stream(
        baud in baud(),
        chunks in prop::collection::vec(
            prop::collection::vec((any::<u8>(), 0u64..=1_000), 1..=200), 1..6),
        pauses in prop::collection::vec(1u64..50_000, 6),
    ) {
        let settings = SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
        let cdt_ms = min_char_delay_ms(baud);
        let cdt = Duration::from_millis(u64::from(cdt_ms));
        let config = Config { settings, char_delay: si_core::Duration::from_millis(cdt_ms.into()), ..Config::default() };
        let mut d = Driver::new(Link::new(config).unwrap());
        let ct = settings.char_time();
        let mut t = Instant::from_micros(1_000);
        for (chunk, pause) in chunks.iter().zip(&pauses) {
            for (i, &(byte, permille)) in chunk.iter().enumerate() {
                // Inside a frame the gap before a character is at most the CDT.
                if i > 0 {
                    t += ct + Duration::from_micros(cdt.as_micros() * permille / 1_000);
                }
                d.rx(t, byte);
            }
            // Between frames the gap is longer than the CDT.
            t += ct + cdt + Duration::from_micros(*pause);
        }
        d.advance(t + Duration::from_secs(10));
        let want: Vec<Vec<u8>> = chunks.iter().map(|c| c.iter().map(|x| x.0).collect()).collect();
        prop_assert_eq!(&d.frames, &want);
        prop_assert!(d.errors.is_empty());
    }

    #[test]
    fn fixed_length_frames_reassemble_to_the_stream(
        baud in baud(),
        len in 1u16..=200,
        stream in prop::collection::vec((any::<u8>(), 0u64..=1_000), 0..1_000),
    ) {
        let settings = SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
        let cdt_ms = min_char_delay_ms(baud);
        let cdt = Duration::from_millis(u64::from(cdt_ms));
        let config = Config {
            settings,
            char_delay: si_core::Duration::from_millis(cdt_ms.into()),
            end: EndCriterion::FixedLength { len },
            ..Config::default()
        };
        let mut d = Driver::new(Link::new(config).unwrap());
        let ct = settings.char_time();
        let mut t = Instant::from_micros(1_000);
        for &(byte, permille) in &stream {
            t += ct + Duration::from_micros(cdt.as_micros() * permille / 1_000);
            d.rx(t, byte);
        }
        d.advance(t + Duration::from_secs(10));
        let n = usize::from(len);
        let whole = stream.len() / n * n;
        let joined: Vec<u8> = d.frames.concat();
        let bytes: Vec<u8> = stream.iter().map(|x| x.0).collect();
        prop_assert_eq!(&joined[..], &bytes[..whole]);
        prop_assert!(d.frames.iter().all(|f| f.len() == n));
        // A short tail is the 0806H error, nothing else.
        let want_errors = if whole < bytes.len() { vec![0x0806] } else { vec![] };
        prop_assert_eq!(d.errors, want_errors);
    }
}

#[derive(Debug, Clone)]
enum Op {
    Rx(Vec<u8>),
    Timeout,
    TxDone,
    LineError(u8),
    Signals(u8),
    Send(Vec<u8>),
    Read,
    Restart,
    SetSignals(u8),
}

fn op() -> impl Strategy<Value = (u64, Op)> {
    let op = prop_oneof![
        4 => prop::collection::vec(any::<u8>(), 0..64).prop_map(Op::Rx),
        2 => Just(Op::Timeout),
        2 => Just(Op::TxDone),
        1 => any::<u8>().prop_map(Op::LineError),
        1 => any::<u8>().prop_map(Op::Signals),
        2 => prop::collection::vec(any::<u8>(), 0..210).prop_map(Op::Send),
        // Around the 2005 module's and the CP 341's maximum frame.
        1 => prop::collection::vec(any::<u8>(), 220..1030).prop_map(Op::Send),
        2 => Just(Op::Read),
        1 => Just(Op::Restart),
        1 => any::<u8>().prop_map(Op::SetSignals),
    ];
    (prop_oneof![0u64..100, 0u64..100_000, 0u64..5_000_000], op)
}

fn config() -> impl Strategy<Value = Config> {
    (
        0usize..4,
        0usize..3,
        0usize..3,
        any::<(bool, bool, bool)>(),
        baud(),
        any::<(u8, u8, u16)>(),
        prop::sample::select(ModulePreset::ALL.to_vec()),
    )
        .prop_map(
            |(flow, iface, end, (dynamic, prevent, clear), baud, (a, b, n), module)| {
                let flow_control = [
                    FlowControl::None,
                    FlowControl::XonXoff,
                    FlowControl::RtsCts,
                    FlowControl::AutoV24,
                ][flow];
                let interface = [Interface::Rs232, Interface::Rs422, Interface::Rs485][iface];
                let end = [
                    EndCriterion::CharDelay,
                    EndCriterion::EndChars {
                        first: a.max(1),
                        second: b,
                    },
                    EndCriterion::FixedLength { len: n % 200 + 1 },
                ][end];
                Config {
                    settings: SerialSettings::new(baud, 8, Parity::Even, 1).unwrap(),
                    char_delay: si_core::Duration::from_millis(min_char_delay_ms(baud).into()),
                    flow_control,
                    interface,
                    end,
                    dynamic_frames: dynamic,
                    prevent_overwrite: prevent,
                    clear_at_startup: clear,
                    ..Config::for_module(module)
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn no_input_at_any_timing_panics(config in config(), ops in prop::collection::vec(op(), 0..120)) {
        let Ok(link) = Link::new(config) else { return Ok(()) };
        let mut d = Driver::new(link);
        let mut sends = 0usize;
        for (dt, op) in ops {
            let now = d.now + Duration::from_micros(dt);
            d.advance(now);
            match op {
                Op::Rx(bytes) => d.link.handle_rx(now, &bytes),
                Op::Timeout => d.link.handle_timeout(now),
                Op::TxDone => d.link.handle_tx_done(now),
                Op::LineError(k) => d.link.handle_line_error(now, [
                    LineError::Parity, LineError::Framing, LineError::Overrun, LineError::Break,
                ][usize::from(k % 4)]),
                Op::Signals(s) => d.link.handle_signals(now, ModemSignals {
                    dsr: s & 1 != 0, cts: s & 2 != 0, dcd: s & 4 != 0, ..ModemSignals::default()
                }),
                Op::Send(frame) => {
                    if d.link.send(now, frame.into()).is_ok() {
                        sends += 1;
                    }
                }
                Op::Read => { d.link.read_frame_vec(now); }
                Op::Restart => d.link.restart(now),
                Op::SetSignals(s) => {
                    let _ = d.link.set_signals(SignalUpdate {
                        rts: (s & 1 != 0).then_some(s & 2 != 0),
                        dtr: (s & 4 != 0).then_some(s & 8 != 0),
                    });
                }
            }
            d.drain();
            let completions = d.completions;
            let buffer = d.link.buffer();
            prop_assert!(buffer.fill() <= buffer.capacity());
            prop_assert!(buffer.pending_len() <= d.link.config().max_frame());
            // Every accepted job ends at most once; at most one is open.
            prop_assert!(completions <= sends && sends - completions <= 1);
        }
    }
}
