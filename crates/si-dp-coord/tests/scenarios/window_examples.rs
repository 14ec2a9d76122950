//! The manual's example tables ([ET200S SI 2005] §2.12.2–§2.12.6)
//! as golden cycle-by-cycle tests, in our corrected readings `[derived]`:
//!
//! * Table 2-23 (send 22 characters, 8-byte window): the reconstruction of [ET200S SI 2005]
//!   §2.12.2, Table 2-23 (`[derived]`);
//! * Table 2-24 (receive 6 bytes): the request is 20H, not the printed 10H (`[derived]`);
//! * Table 2-28 (XON/XOFF parameters, 4-byte window): XON/XOFF 11H/13H (`[derived]`), byte 3 = MSB
//!   (`[derived]`).
//!
//! Each table is played twice: the host against the table's IN column (checking its OUT column),
//! and the module against the table's OUT column (checking its IN column). `xx`/`nn` are bytes the
//! table leaves open.

use crate::common;

use bytes::Bytes;
use common::{assert_window, bytes, ms};
use si_dp_coord::coord::JobCode;
use si_dp_coord::host::{Host, HostEvent, Job, Outcome};
use si_dp_coord::module::{LoopbackSerial, Module};
use si_dp_coord::{HostConfig, ModuleConfig, ParamBlock, V24Signals, WindowSize};

/// Plays `rows` of (IN, expected OUT) against a host; returns the events.
fn play_host(host: &mut Host, rows: &[(&str, &str)]) -> Vec<HostEvent> {
    let mut events = Vec::new();
    for (cycle, (input, expected)) in rows.iter().enumerate() {
        let out = host.cycle(ms(cycle as u64), &bytes(input)).to_vec();
        assert_window(&format!("host cycle {}", cycle + 1), &out, expected);
        events.extend(std::iter::from_fn(|| host.poll_event()));
    }
    events
}

/// Plays `rows` of (OUT, expected IN) against a module.
fn play_module(module: &mut Module<LoopbackSerial>, rows: &[(&str, &str)]) {
    for (cycle, (output, expected)) in rows.iter().enumerate() {
        let input = module.cycle(ms(cycle as u64), &bytes(output)).to_vec();
        assert_window(&format!("module cycle {}", cycle + 1), &input, expected);
    }
}

fn completed(events: &[HostEvent]) -> Vec<(JobCode, Result<Outcome, si_core::Status>)> {
    events
        .iter()
        .filter_map(|e| match e {
            HostEvent::Completed { code, result, .. } => Some((*code, result.clone())),
            _ => None,
        })
        .collect()
}

const ALPHABET: &[u8] = b"abcdefghijklmnopqrstuv";

/// [ET200S SI 2005] §2.12.2, Table 2-23 reconstructed: DP cycle ≈ CPU cycle, so the echo lags one
/// cycle and the host holds each segment until it is echoed.
#[test]
fn table_2_23_send_22_characters_host() {
    let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    host.submit(Job::Send(Bytes::from_static(ALPHABET)))
        .unwrap();
    let events = play_host(
        &mut host,
        &[
            ("00 00 00 xx xx xx xx xx", "10 xx xx xx xx xx xx xx"),
            ("00 00 00 xx xx xx xx xx", "10 xx xx xx xx xx xx xx"),
            ("10 00 00 xx xx xx xx xx", "11 00 16 'a' 'b' 'c' 'd' 'e'"),
            ("10 xx xx xx xx xx xx xx", "11 00 16 'a' 'b' 'c' 'd' 'e'"),
            ("11 xx xx xx xx xx xx xx", "12 'f' 'g' 'h' 'i' 'j' 'k' 'l'"),
            ("12 xx xx xx xx xx xx xx", "13 'm' 'n' 'o' 'p' 'q' 'r' 's'"),
            ("13 xx xx xx xx xx xx xx", "14 't' 'u' 'v' xx xx xx xx"),
            ("13 xx xx xx xx xx xx xx", "14 't' 'u' 'v' xx xx xx xx"),
            ("14 xx xx xx xx xx xx xx", "14 't' 'u' 'v' xx xx xx xx"),
            ("14 xx xx xx xx xx xx xx", "14 't' 'u' 'v' xx xx xx xx"),
            ("74 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
            ("74 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
            ("00 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
        ],
    );
    assert_eq!(completed(&events), [(JobCode::Send, Ok(Outcome::Sent))]);
    assert!(!host.is_busy());
}

#[test]
fn table_2_23_send_22_characters_module() {
    let mut serial = LoopbackSerial::new();
    serial.loopback = false;
    let mut module = Module::new(ModuleConfig::new(WindowSize::Eight), serial).unwrap();
    play_module(
        &mut module,
        &[
            ("00 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
            ("10 xx xx xx xx xx xx xx", "10 nn nn xx xx xx xx xx"),
            ("10 xx xx xx xx xx xx xx", "10 nn nn xx xx xx xx xx"),
            ("11 00 16 'a' 'b' 'c' 'd' 'e'", "11 xx xx xx xx xx xx xx"),
            ("11 00 16 'a' 'b' 'c' 'd' 'e'", "11 xx xx xx xx xx xx xx"),
            ("12 'f' 'g' 'h' 'i' 'j' 'k' 'l'", "12 xx xx xx xx xx xx xx"),
            ("13 'm' 'n' 'o' 'p' 'q' 'r' 's'", "13 xx xx xx xx xx xx xx"),
            // The last segment is echoed; the frame then goes to the line.
            ("14 't' 'u' 'v' xx xx xx xx", "14 xx xx xx xx xx xx xx"),
            // Transmitted: end-of-job acknowledgement, exec 4, STATUS 0000H.
            ("14 't' 'u' 'v' xx xx xx xx", "74 00 00 xx xx xx xx xx"),
            ("14 't' 'u' 'v' xx xx xx xx", "74 00 00 xx xx xx xx xx"),
            ("00 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
        ],
    );
    let sent: Vec<_> = module.serial().sent().cloned().collect();
    assert_eq!(sent, [Bytes::from_static(ALPHABET)]);
}

/// [ET200S SI 2005] §2.12.2–§2.12.6, Table 2-24: the host polls idle until 0001H, requests with 20H
/// (`[derived]`), echoes 21H and 22H, and the module returns to idle.
#[test]
fn table_2_24_receive_6_bytes_host() {
    let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    // Nothing waiting: the host sees 0000H.
    host.cycle(ms(0), &bytes("00 00 00 xx xx xx xx xx"));
    assert_eq!(host.receive_status(), Some(si_dp_coord::RxStatus::Empty));
    host.submit(Job::Receive).unwrap();
    let events = play_host(
        &mut host,
        &[
            ("00 00 01 xx xx xx xx xx", "20 xx xx xx xx xx xx xx"),
            ("21 00 06 'a' 'b' 'c' 'd' 'e'", "21 xx xx xx xx xx xx xx"),
            ("22 'f' xx xx xx xx xx xx", "22 xx xx xx xx xx xx xx"),
            ("00 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
        ],
    );
    assert_eq!(
        completed(&events),
        [(
            JobCode::Receive,
            Ok(Outcome::Received(Bytes::from_static(b"abcdef")))
        )]
    );
}

#[test]
fn table_2_24_receive_6_bytes_module() {
    let mut module =
        Module::new(ModuleConfig::new(WindowSize::Eight), LoopbackSerial::new()).unwrap();
    play_module(
        &mut module,
        &[("00 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx")],
    );
    module.serial_mut().inject_frame(&b"abcdef"[..]);
    play_module(
        &mut module,
        &[
            ("00 xx xx xx xx xx xx xx", "00 00 01 xx xx xx xx xx"),
            ("20 xx xx xx xx xx xx xx", "21 00 06 'a' 'b' 'c' 'd' 'e'"),
            ("20 xx xx xx xx xx xx xx", "21 00 06 'a' 'b' 'c' 'd' 'e'"),
            ("21 xx xx xx xx xx xx xx", "22 'f' xx xx xx xx xx xx"),
            ("22 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
            // The held echo 22H is not a request: the module stays idle.
            ("22 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
            ("00 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
        ],
    );
    assert_eq!(module.stats().frames_delivered, 1);
}

/// [ET200S SI 2005] §2.12.2–§2.12.6, Table 2-25: read V.24 answers 31H, 00H, signal bits (DCD 4,
/// CTS 3, RTS 2, DSR 1, DTR 0); the host echoes 31H; the module goes idle.
#[test]
fn table_2_25_read_v24_host() {
    let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    host.submit(Job::ReadV24).unwrap();
    let events = play_host(
        &mut host,
        &[
            ("00 00 00 xx xx xx xx xx", "30 xx xx xx xx xx xx xx"),
            ("31 00 1B xx xx xx xx xx", "31 xx xx xx xx xx xx xx"),
            ("31 00 1B xx xx xx xx xx", "31 xx xx xx xx xx xx xx"),
            ("00 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
        ],
    );
    let expected = V24Signals {
        dcd: true,
        cts: true,
        rts: false,
        dsr: true,
        dtr: true,
    };
    assert_eq!(
        completed(&events),
        [(JobCode::ReadV24, Ok(Outcome::Signals(expected)))]
    );
}

#[test]
fn table_2_25_read_v24_module() {
    let mut serial = LoopbackSerial::new();
    serial.inputs = V24Signals {
        dcd: true,
        cts: true,
        dsr: true,
        ..V24Signals::default()
    };
    let mut module = Module::new(ModuleConfig::new(WindowSize::Eight), serial).unwrap();
    play_module(
        &mut module,
        &[
            // DTR set first through write V.24, so the answer shows outputs too.
            ("40 00 01 xx xx xx xx xx", "40 00 00 xx xx xx xx xx"),
            ("00 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
            ("30 xx xx xx xx xx xx xx", "31 00 1B xx xx xx xx xx"),
            ("30 xx xx xx xx xx xx xx", "31 00 1B xx xx xx xx xx"),
            ("31 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
            ("00 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
        ],
    );
}

/// [ET200S SI 2005] §2.12.2–§2.12.6, Table 2-26: write V.24 carries 40H, 00H, signal bits (RTS bit
/// 2, DTR bit 0) in the request; the module answers 40H + STATUS; the host writes idle.
#[test]
fn table_2_26_write_v24_host() {
    let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    host.submit(Job::WriteV24 {
        rts: true,
        dtr: true,
    })
    .unwrap();
    let events = play_host(
        &mut host,
        &[
            ("00 00 00 xx xx xx xx xx", "40 00 05 xx xx xx xx xx"),
            ("00 00 00 xx xx xx xx xx", "40 00 05 xx xx xx xx xx"),
            ("40 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
            ("00 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
        ],
    );
    assert_eq!(
        completed(&events),
        [(JobCode::WriteV24, Ok(Outcome::SignalsWritten))]
    );
}

#[test]
fn table_2_26_write_v24_module() {
    let mut module =
        Module::new(ModuleConfig::new(WindowSize::Eight), LoopbackSerial::new()).unwrap();
    play_module(
        &mut module,
        &[
            ("40 00 04 xx xx xx xx xx", "40 00 00 xx xx xx xx xx"),
            ("40 00 04 xx xx xx xx xx", "40 00 00 xx xx xx xx xx"),
            ("00 xx xx xx xx xx xx xx", "00 00 00 xx xx xx xx xx"),
        ],
    );
    let s = si_dp_coord::SerialSide::signals(module.serial());
    assert!(s.rts && !s.dtr);
}

/// [ET200S SI 2005] §2.12.2–§2.12.6, Table 2-28, 4-byte window: block 20H, length 0004H, XON, XOFF,
/// wait time 00C8H in three segments; the end-of-job acknowledgement 73H carries the last exec
/// number.
#[test]
fn table_2_28_xon_xoff_parameters_host() {
    let mut host = Host::new(HostConfig::new(WindowSize::Four)).unwrap();
    host.submit(Job::Parameters(ParamBlock::XON_XOFF_DEFAULT))
        .unwrap();
    let events = play_host(
        &mut host,
        &[
            ("00 00 00 xx", "50 xx xx xx"),
            ("50 xx xx xx", "51 20 00 04"),
            ("51 xx xx xx", "52 11 13 00"),
            ("52 xx xx xx", "53 C8 xx xx"),
            ("53 xx xx xx", "53 C8 xx xx"),
            ("73 00 00 xx", "00 xx xx xx"),
            ("00 00 00 xx", "00 xx xx xx"),
        ],
    );
    assert_eq!(
        completed(&events),
        [(JobCode::Parameters, Ok(Outcome::ParametersSet))]
    );
}

/// The bytes exactly as printed (0BH/0DH, `[derived]`) are still a well-formed block: the
/// characters are free values, only their meaning as DC1/DC3 is wrong.
#[test]
fn table_2_28_as_printed_bytes() {
    let mut host = Host::new(HostConfig::new(WindowSize::Four)).unwrap();
    host.submit(Job::Parameters(ParamBlock::XonXoff {
        xon: 0x0B,
        xoff: 0x0D,
        xon_wait: 200,
    }))
    .unwrap();
    play_host(
        &mut host,
        &[
            ("00 00 00 xx", "50 xx xx xx"),
            ("50 xx xx xx", "51 20 00 04"),
            ("51 xx xx xx", "52 0B 0D 00"),
            ("52 xx xx xx", "53 C8 xx xx"),
        ],
    );
}

#[test]
fn table_2_28_xon_xoff_parameters_module() {
    let mut module =
        Module::new(ModuleConfig::new(WindowSize::Four), LoopbackSerial::new()).unwrap();
    play_module(
        &mut module,
        &[
            ("00 xx xx xx", "00 00 00 xx"),
            ("50 xx xx xx", "50 xx xx xx"),
            ("51 20 00 04", "51 xx xx xx"),
            ("52 11 13 00", "52 xx xx xx"),
            ("53 C8 xx xx", "53 xx xx xx"),
            ("53 C8 xx xx", "73 00 00 xx"),
            ("00 xx xx xx", "00 00 00 xx"),
        ],
    );
    assert_eq!(
        module.serial().flow_control,
        Some(ParamBlock::XON_XOFF_DEFAULT)
    );
}

/// The three blocks of Table 2-27 in the 8-byte window fit one segment each ([ET200S SI 2005]
/// §2.12.2–§2.12.6 `[derived]`).
#[test]
fn table_2_27_blocks_in_one_8_byte_segment() {
    for (block, seg) in [
        (ParamBlock::XON_XOFF_DEFAULT, "51 20 00 04 11 13 00 C8"),
        (ParamBlock::RTS_CTS_DEFAULT, "51 21 00 02 00 C8 xx xx"),
        (ParamBlock::AUTO_V24_DEFAULT, "51 22 00 04 00 01 00 01"),
    ] {
        let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
        host.submit(Job::Parameters(block)).unwrap();
        play_host(
            &mut host,
            &[
                ("00 00 00 xx xx xx xx xx", "50 xx xx xx xx xx xx xx"),
                ("50 00 00 xx xx xx xx xx", seg),
                ("71 00 00 xx xx xx xx xx", "00 xx xx xx xx xx xx xx"),
            ],
        );
    }
}

/// Idle shows 0B01H when more than 2/3 of the receive buffer is used ([ET200S SI 2005] §2.12.1).
#[test]
fn section_2_5_idle_status_two_thirds_full() {
    let cfg = ModuleConfig {
        rx_buffer_bytes: 30,
        ..ModuleConfig::new(WindowSize::Eight)
    };
    let mut module = Module::new(cfg, LoopbackSerial::new()).unwrap();
    module.serial_mut().inject_frame(&[1u8; 20][..]);
    play_module(
        &mut module,
        &[("00 xx xx xx xx xx xx xx", "00 00 01 xx xx xx xx xx")],
    );
    module.serial_mut().inject_frame(&[2u8; 1][..]);
    play_module(
        &mut module,
        &[("00 xx xx xx xx xx xx xx", "00 0B 01 xx xx xx xx xx")],
    );
}
