//! The ASCII driver behind a 16550-type FIFO UART (si-sim's [`FifoUart`], announcing nothing,
//! as a `ttyS` port under the tokio driver): with default configs and each end criterion
//! ([ET200S SI] §2.8: character delay time, end character, fixed length), 100-byte frames
//! arrive whole at every trigger level at 9600 and 19 200 bit/s; and a host too slow to read
//! the FIFO loses characters with an overrun, reported as 080CH ([ET200S SI] §2.13, Table 2-28).

use crate::common;

use common::{errors, settings, Bench};
use si_ascii::{Config, EndCriterion};
use si_core::Duration;
use si_sim::FifoUart;

fn frame(end: EndCriterion) -> Vec<u8> {
    let mut f: Vec<u8> = (0..100).map(|i| b'A' + (i % 26) as u8).collect();
    if let EndCriterion::EndChars { first, .. } = end {
        f[99] = first;
    }
    f
}

fn criteria() -> [EndCriterion; 3] {
    [
        EndCriterion::CharDelay,
        EndCriterion::DEFAULT_END_CHARS,
        EndCriterion::FixedLength { len: 100 },
    ]
}

fn bench(baud: u32, end: EndCriterion, uart: FifoUart) -> Bench {
    let config = Config {
        settings: settings(baud),
        end,
        ..Config::default()
    };
    let mut b = Bench::new(config);
    b.sim.set_uart(b.link, uart).unwrap();
    b
}

#[test]
fn each_end_criterion_gets_whole_frames_through_a_fifo_uart_at_every_trigger_level() {
    for baud in [9_600, 19_200] {
        for trigger in FifoUart::TRIGGERS {
            for end in criteria() {
                let uart = FifoUart::LINUX_16550A.with_trigger(trigger);
                let mut b = bench(baud, end, uart);
                let f = frame(end);
                for _ in 0..3 {
                    b.partner_sends(&f);
                    b.run_for_ms(1_000);
                }
                let events = b.events();
                let what = format!("{baud} bit/s, trigger {trigger}, {end:?}");
                assert!(errors(&events).is_empty(), "{what}: {events:?}");
                assert_eq!(b.frames(), vec![f.clone(), f.clone(), f], "{what}");
            }
        }
    }
}

#[test]
fn a_host_too_slow_for_the_fifo_loses_characters_with_an_overrun_receive_error() {
    // Trigger 14, read 5 ms after the interrupt: at 19 200 bit/s (0.57 ms a character) the
    // two free places fill long before, and the characters after them are lost.
    let uart = FifoUart::LINUX_16550A
        .with_trigger(14)
        .with_service(Duration::from_millis(5));
    let mut b = bench(19_200, EndCriterion::DEFAULT_END_CHARS, uart);
    b.partner_sends(&frame(EndCriterion::DEFAULT_END_CHARS));
    b.run_for_ms(1_000);
    let events = b.events();
    // [ET200S SI] §2.13, Table 2-28: 080CH, transmission error (overrun).
    let codes: Vec<u16> = errors(&events).iter().map(|e| e.0).collect();
    assert!(
        !codes.is_empty() && codes.iter().all(|&c| c == 0x080C),
        "{events:?}"
    );
    assert!(
        b.frames().iter().all(|f| f.len() < 100),
        "nothing arrives whole"
    );
}
