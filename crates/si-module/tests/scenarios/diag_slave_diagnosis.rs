//! Slave diagnosis of the SI module (et200s-si-2005-window-protocol.md §6.4, Tables 2-30 and
//! 3-73; et200s-si-3964r-ascii.md §11.4; et200s-si-modbus-uss.md §7.6).

use proptest::prelude::*;
use si_module::diag::{
    ChannelDiagnosis, ChannelType, DiagError, ErrorType, IoType, ModuleDiagnosis, ModuleState,
    ModuleStatus, SlaveDiagnosis, StationStatus, Variant,
};

/// A station whose SI module in slot 3 reports `error` on its channel: standard part (extended
/// diagnosis present), module diagnosis (module 3), module status (module 3: error), one channel.
fn with_channel(error_byte: u8) -> Vec<u8> {
    vec![
        0x08, 0x0C, 0x00, 0x02, 0x80, 0xE0, // standard diagnosis
        0x42, 0x04, // module diagnosis: 2 bytes, module 3
        0x05, 0x82, 0x00, 0x00, 0x10, // module status: 5 bytes, module 3 = 01
        0x83, 0xC0, error_byte, // slot 3, input/output channel 0, byte type + error
    ]
}

#[test]
fn table_2_30_every_channel_error_type_decodes_with_meaning_and_action() {
    let table: [(u8, ErrorType, &str, &str); 6] = [
        (
            0b00110,
            ErrorType::WireBreak,
            "a wire is broken or disconnected",
            "check the terminal wiring and the partner cable",
        ),
        (
            0b00111,
            ErrorType::Overflow,
            "buffer overflow, or message length exceeded",
            "call S_RCV more often",
        ),
        (
            0b01000,
            ErrorType::Underflow,
            "a message of length 0 was sent (3964(R) only)",
            "find out why the partner sends empty frames",
        ),
        (
            0b01001,
            ErrorType::InternalError,
            "internal module error",
            "replace the module",
        ),
        (
            0b10000,
            ErrorType::ParameterAssignment,
            "the module is not parameterized",
            "correct the parameter assignment",
        ),
        (
            0b10110,
            ErrorType::MessageError,
            "frame error or parity error",
            "check the communication settings",
        ),
    ];
    for (code, want, meaning, action) in table {
        let d = SlaveDiagnosis::decode(&with_channel(0x80 | code)).unwrap();
        let c = d.channels[0];
        assert_eq!(c.error, want);
        assert_eq!(c.error.code(), code);
        assert_eq!(
            (c.slot, c.channel, c.io, c.channel_type),
            (3, 0, IoType::InputOutput, ChannelType::Byte)
        );
        assert_eq!(c.error.meaning(Variant::R3964Ascii), meaning);
        assert_eq!(c.error.action(Variant::R3964Ascii), action);
    }
}

#[test]
fn table_3_73_modbus_uss_wording_of_underflow() {
    let t = ErrorType::Underflow;
    assert_eq!(
        t.meaning(Variant::ModbusUss),
        "a message of length 0 was sent"
    );
    assert_eq!(
        t.action(Variant::ModbusUss),
        "check why the partner sends frames without user data"
    );
    for t in ErrorType::ALL {
        assert!(!t.meaning(Variant::ModbusUss).is_empty());
        assert!(!t.action(Variant::ModbusUss).is_empty());
    }
}

#[test]
fn every_other_error_type_is_refused_naming_the_offset() {
    for code in 0..32u8 {
        if ErrorType::from_code(code).is_some() {
            continue;
        }
        let e = SlaveDiagnosis::decode(&with_channel(0x80 | code)).unwrap_err();
        assert!(
            matches!(e, DiagError::Unknown { offset: 15, .. }),
            "{code}: {e}"
        );
        assert!(e.to_string().contains("at offset 15"), "{e}");
    }
}

#[test]
fn standard_module_diagnosis_and_module_status_decode() {
    let d = SlaveDiagnosis::decode(&with_channel(0x86)).unwrap();
    assert_eq!(
        d.station,
        StationStatus {
            status1: 0x08,
            status2: 0x0C,
            status3: 0,
            master_address: 2,
            ident_number: 0x80E0
        }
    );
    assert_eq!(
        d.station.flags().collect::<Vec<_>>(),
        [
            "extended diagnosis present",
            "response monitoring (watchdog) on"
        ]
    );
    assert_eq!(
        d.module_diagnosis
            .as_ref()
            .unwrap()
            .modules()
            .collect::<Vec<_>>(),
        [3]
    );
    let status = d.module_status.as_ref().unwrap();
    assert_eq!(status.state(3), Some(ModuleState::Error));
    assert_eq!(status.state(1), Some(ModuleState::Ok));
    assert_eq!(status.states().count(), 4);
}

#[test]
fn diagnosis_cut_at_every_length_decodes_a_prefix_or_names_the_offset() {
    let full = with_channel(0x86);
    // Block boundaries: after the standard part, the module diagnosis, the module status, the channel.
    let boundaries = [6, 8, 13, 16];
    for len in 0..full.len() {
        let cut = &full[..len];
        match SlaveDiagnosis::decode(cut) {
            Ok(d) => {
                assert!(boundaries.contains(&len), "decoded at {len}");
                assert_eq!(d.encode().unwrap(), cut);
            }
            Err(DiagError::Truncated {
                offset,
                needed,
                available,
                ..
            }) => {
                assert!(!boundaries.contains(&len), "refused at {len}");
                let start = [0, 6, 8, 13].into_iter().rev().find(|&b| b <= len).unwrap();
                assert_eq!(offset, start, "len {len}");
                assert_eq!(available, len - start);
                assert!(needed > available);
            }
            Err(e) => panic!("len {len}: {e}"),
        }
    }
    assert_eq!(
        SlaveDiagnosis::decode(&full[..10]).unwrap_err().to_string(),
        "truncated at offset 8: the module status needs 5 bytes, 2 remain"
    );
    assert_eq!(
        SlaveDiagnosis::decode(&full[..3]).unwrap_err().to_string(),
        "truncated at offset 0: the standard diagnosis needs 6 bytes, 3 remain"
    );
}

#[test]
fn bad_headers_and_order_name_the_offset() {
    let mut d = with_channel(0x86);
    d[9] = 0x81;
    assert_eq!(
        SlaveDiagnosis::decode(&d).unwrap_err().to_string(),
        "unknown status type (the SI module sends 82H, module status) at offset 9: byte 81H"
    );
    let mut d = with_channel(0x86);
    d[6] = 0xC2;
    assert!(matches!(
        SlaveDiagnosis::decode(&d),
        Err(DiagError::Unknown { offset: 6, .. })
    ));
    let mut d = with_channel(0x86);
    d[8] = 0x03;
    assert!(matches!(
        SlaveDiagnosis::decode(&d),
        Err(DiagError::BadLength {
            offset: 8,
            length: 3,
            ..
        })
    ));
    let mut d = with_channel(0x86);
    d[14] = 0x00; // I/O type 00 is reserved
    assert!(matches!(
        SlaveDiagnosis::decode(&d),
        Err(DiagError::Unknown { offset: 14, .. })
    ));
    let d = with_channel(0xE6); // channel type 111 is reserved
    assert!(matches!(
        SlaveDiagnosis::decode(&d),
        Err(DiagError::Unknown { offset: 15, .. })
    ));
    // Module status after a channel entry.
    let mut d = vec![0x08, 0x0C, 0x00, 0x02, 0x80, 0xE0, 0x83, 0xC0, 0x86];
    d.extend_from_slice(&[0x04, 0x82, 0x00, 0x00]);
    assert!(matches!(
        SlaveDiagnosis::decode(&d),
        Err(DiagError::OutOfOrder { offset: 9, .. })
    ));
    assert!(matches!(
        SlaveDiagnosis::decode(&[0; 245]),
        Err(DiagError::TooLong { len: 245 })
    ));
}

#[test]
fn simulated_module_entry_encodes() {
    let d = SlaveDiagnosis {
        station: StationStatus {
            status1: 0x08,
            status2: 0x0C,
            status3: 0,
            master_address: 2,
            ident_number: 0x80E0,
        },
        module_diagnosis: Some(ModuleDiagnosis { bits: vec![0x04] }),
        module_status: Some({
            let mut s = ModuleStatus::default();
            s.set(3, ModuleState::Error);
            s
        }),
        channels: vec![ChannelDiagnosis::si(3, ErrorType::WireBreak)],
    };
    assert_eq!(d.encode().unwrap(), with_channel(0x86));
    let too_far = SlaveDiagnosis {
        channels: vec![ChannelDiagnosis::si(64, ErrorType::WireBreak)],
        ..SlaveDiagnosis::default()
    };
    assert!(matches!(
        too_far.encode(),
        Err(DiagError::TooLarge { field: "slot", .. })
    ));
}

fn any_channel() -> impl Strategy<Value = ChannelDiagnosis> {
    (
        0..64u8,
        0..64u8,
        prop::sample::select(vec![IoType::Input, IoType::Output, IoType::InputOutput]),
        prop::sample::select(vec![
            ChannelType::Bit,
            ChannelType::TwoBits,
            ChannelType::FourBits,
            ChannelType::Byte,
            ChannelType::Word,
            ChannelType::TwoWords,
        ]),
        prop::sample::select(ErrorType::ALL.to_vec()),
    )
        .prop_map(
            |(slot, channel, io, channel_type, error)| ChannelDiagnosis {
                slot,
                channel,
                io,
                channel_type,
                error,
            },
        )
}

proptest! {
    #[test]
    fn decode_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let _ = SlaveDiagnosis::decode(&bytes);
    }

    #[test]
    fn encode_decode_round_trip(
        std in any::<[u8; 6]>(),
        diag in prop::option::of(prop::collection::vec(any::<u8>(), 0..20)),
        status in prop::option::of(prop::collection::vec(any::<u8>(), 0..20)),
        channels in prop::collection::vec(any_channel(), 0..20),
    ) {
        let d = SlaveDiagnosis {
            station: StationStatus {
                status1: std[0], status2: std[1], status3: std[2], master_address: std[3],
                ident_number: u16::from_be_bytes([std[4], std[5]]),
            },
            module_diagnosis: diag.map(|bits| ModuleDiagnosis { bits }),
            module_status: status.map(|bits| ModuleStatus { bits }),
            channels,
        };
        let bytes = d.encode().unwrap();
        prop_assert_eq!(SlaveDiagnosis::decode(&bytes).unwrap(), d);
    }
}
