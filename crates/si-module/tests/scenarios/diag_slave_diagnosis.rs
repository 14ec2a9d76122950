//! Slave diagnosis of the SI module ([ET200S SI 2005] Tables 2-30, 3-73, Tables 2-30 and
//! 3-73; [ET200S SI] §2.13, Table 2-29; [Modbus/USS] §3.6.3, Table 3-28).

use proptest::prelude::*;
use si_module::diag::{
    ChannelDiagnosis, ChannelType, DiagError, ErrorType, IoType, ModuleDiagnosis, ModuleState,
    ModuleStatus, SlaveDiagnosis, StationStatus, UnknownKind, UnknownPart, Variant,
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

/// The modules the module diagnosis says report something.
fn reporting_modules(d: &SlaveDiagnosis) -> Vec<usize> {
    d.module_diagnosis.as_ref().unwrap().modules().collect()
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
fn every_other_error_type_is_kept_raw_and_the_rest_decoded() {
    for code in 0..32u8 {
        if ErrorType::from_code(code).is_some() {
            continue;
        }
        let bytes = with_channel(0x80 | code);
        let d = SlaveDiagnosis::decode(&bytes).unwrap();
        assert!(d.channels.is_empty(), "{code}");
        assert_eq!(
            d.unknown,
            [UnknownPart {
                offset: 13,
                kind: UnknownKind::Channel {
                    slot: 3,
                    channel: 0,
                    io: Some(IoType::InputOutput),
                    channel_type: Some(ChannelType::Byte),
                    error_type: code,
                },
                bytes: vec![0x83, 0xC0, 0x80 | code],
            }],
            "{code}"
        );
        assert_eq!(
            d.module_status.as_ref().unwrap().state(3),
            Some(ModuleState::Error)
        );
        assert_eq!(d.encode().unwrap(), bytes);
    }
}

/// A whole station, as the IM sends it: the SI module in slot 3 with a message error, a
/// digital input module in slot 4 with an error type of its own (1, not in the SI tables), an
/// entry with a reserved I/O type and channel type in slot 5, and a DP-V1 diagnostic interrupt
/// block (status type 01H) after the channel entries.
#[test]
fn a_full_station_keeps_unknown_parts_raw_and_decodes_the_rest() {
    let bytes = [
        0x08, 0x0C, 0x00, 0x02, 0x80, 0xE0, // standard diagnosis
        0x42, 0x1C, // module diagnosis: modules 3, 4, 5
        0x06, 0x82, 0x00, 0x00, 0x50, 0x02, // module status: 3, 4 error; 5 wrong module
        0x83, 0xC0, 0x96, // slot 3 channel 0, input/output, byte: message error (22)
        0x84, 0x41, 0x21, // slot 4 channel 1, input, bit: error type 1
        0x85, 0x02, 0xE6, // slot 5 channel 2: I/O type 00, channel type 111
        0x08, 0x01, 0x04, 0x01, 0x00, 0x11, 0x22, 0x33, // interrupt block, 8 bytes
    ];
    let d = SlaveDiagnosis::decode(&bytes).unwrap();
    assert_eq!(d.station.ident_number, 0x80E0);
    assert_eq!(reporting_modules(&d), [3, 4, 5]);
    let status = d.module_status.as_ref().unwrap();
    assert_eq!(
        [status.state(3), status.state(4), status.state(5)],
        [
            Some(ModuleState::Error),
            Some(ModuleState::Error),
            Some(ModuleState::WrongModule)
        ]
    );
    assert_eq!(
        d.channels,
        [ChannelDiagnosis::si(3, ErrorType::MessageError)]
    );
    assert_eq!(
        d.unknown,
        [
            UnknownPart {
                offset: 17,
                kind: UnknownKind::Channel {
                    slot: 4,
                    channel: 1,
                    io: Some(IoType::Input),
                    channel_type: Some(ChannelType::Bit),
                    error_type: 1,
                },
                bytes: vec![0x84, 0x41, 0x21],
            },
            UnknownPart {
                offset: 20,
                kind: UnknownKind::Channel {
                    slot: 5,
                    channel: 2,
                    io: None,
                    channel_type: None,
                    error_type: 6,
                },
                bytes: vec![0x85, 0x02, 0xE6],
            },
            UnknownPart {
                offset: 23,
                kind: UnknownKind::StatusBlock {
                    status_type: Some(0x01)
                },
                bytes: bytes[23..].to_vec(),
            },
        ]
    );
    assert_eq!(
        d.unknown[0].kind.to_string(),
        "channel entry: slot 4 channel 1 (input, bit): error type 00001 (1), not in the SI \
         module's tables (see the reporting module's manual)"
    );
    assert_eq!(
        d.unknown[1].kind.to_string(),
        "channel entry: slot 5 channel 2 (I/O type 00 reserved, channel type reserved): error \
         type 00110 (6)"
    );
    // Unknown parts that came last: the same bytes again.
    assert_eq!(d.encode().unwrap(), bytes);
}

#[test]
fn blocks_out_of_the_usual_order_a_second_status_and_header_11_are_kept() {
    // Module status after a channel entry is still the module status; a second one is kept.
    let mut d = vec![0x08, 0x0C, 0x00, 0x02, 0x80, 0xE0, 0x83, 0xC0, 0x86];
    d.extend_from_slice(&[0x05, 0x82, 0x00, 0x00, 0x10]);
    d.extend_from_slice(&[0x05, 0x82, 0x00, 0x00, 0x04]);
    let x = SlaveDiagnosis::decode(&d).unwrap();
    assert_eq!(x.channels, [ChannelDiagnosis::si(3, ErrorType::WireBreak)]);
    assert_eq!(x.module_status.unwrap().state(3), Some(ModuleState::Error));
    assert_eq!(x.unknown.len(), 1);
    assert_eq!(
        (x.unknown[0].offset, x.unknown[0].kind),
        (14, UnknownKind::Repeated)
    );
    // A module status block with another status type or nonzero bytes 2–3 is a status block;
    // a short device-related block (DP-V0, manufacturer-specific) as well.
    for (block, status_type) in [
        (&[0x05, 0x81, 0x00, 0x00, 0x10][..], Some(0x81)),
        (&[0x05, 0x82, 0x03, 0x01, 0x10][..], Some(0x82)),
        (&[0x02, 0x7F][..], Some(0x7F)),
        (&[0x01][..], None),
    ] {
        let mut d = vec![0x08, 0x0C, 0x00, 0x02, 0x80, 0xE0];
        d.extend_from_slice(block);
        d.extend_from_slice(&[0x83, 0xC0, 0x86]);
        let x = SlaveDiagnosis::decode(&d).unwrap();
        assert_eq!(x.module_status, None, "{block:02X?}");
        assert_eq!(x.channels.len(), 1, "{block:02X?}");
        assert_eq!(
            x.unknown,
            [UnknownPart {
                offset: 6,
                kind: UnknownKind::StatusBlock { status_type },
                bytes: block.to_vec(),
            }]
        );
    }
    // Header 11: no known length, so the rest is one part; what came before is decoded.
    let d = [
        0x08, 0x0C, 0x00, 0x02, 0x80, 0xE0, 0x83, 0xC0, 0x86, 0xC2, 0x01, 0x83, 0xC0, 0x96,
    ];
    let x = SlaveDiagnosis::decode(&d).unwrap();
    assert_eq!(x.channels, [ChannelDiagnosis::si(3, ErrorType::WireBreak)]);
    assert_eq!(
        x.unknown,
        [UnknownPart {
            offset: 9,
            kind: UnknownKind::Header { header: 0xC2 },
            bytes: d[9..].to_vec(),
        }]
    );
}

#[test]
fn only_wrong_lengths_fail_naming_the_offset() {
    let mut d = with_channel(0x86);
    d[8] = 0x00; // module status header of length 0
    assert_eq!(
        SlaveDiagnosis::decode(&d).unwrap_err().to_string(),
        "invalid length 0 in the module status header at offset 8 (at least 1)"
    );
    let mut d = with_channel(0x86);
    d[6] = 0x40;
    assert!(matches!(
        SlaveDiagnosis::decode(&d),
        Err(DiagError::BadLength {
            offset: 6,
            length: 0,
            ..
        })
    ));
    let mut d = with_channel(0x86);
    d[8] = 0x3F; // a device-related block longer than what follows
    assert!(matches!(
        SlaveDiagnosis::decode(&d),
        Err(DiagError::Truncated {
            offset: 8,
            needed: 63,
            available: 8,
            ..
        })
    ));
    assert!(matches!(
        SlaveDiagnosis::decode(&[0; 245]),
        Err(DiagError::TooLong { len: 245 })
    ));
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
    assert_eq!(reporting_modules(&d), [3]);
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
        unknown: Vec::new(),
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

/// A diagnosis whose every length field is right: the standard part, then blocks with headers
/// 00 and 01 of lengths 1 … 63 and channel entries with any content, optionally a header-11
/// tail, at most 244 bytes.
fn well_framed() -> impl Strategy<Value = Vec<u8>> {
    let block = prop_oneof![
        (0u8..2, 1usize..64).prop_flat_map(|(kind, len)| {
            prop::collection::vec(any::<u8>(), len - 1).prop_map(move |body| {
                let mut b = vec![kind << 6 | len as u8];
                b.extend(body);
                b
            })
        }),
        any::<[u8; 3]>().prop_map(|[a, b, c]| vec![0x80 | a & 0x3F, b, c]),
    ];
    (
        any::<[u8; 6]>(),
        prop::collection::vec(block, 0..12),
        prop::option::of(prop::collection::vec(any::<u8>(), 0..8)),
    )
        .prop_map(|(std, blocks, tail)| {
            let mut out = std.to_vec();
            for b in blocks {
                if out.len() + b.len() <= 236 {
                    out.extend(b);
                }
            }
            if let Some(t) = tail {
                out.push(0xC0 | t.len() as u8);
                out.extend(t);
            }
            out
        })
}

proptest! {
    /// Any bytes: no panic, and an error only for a wrong length.
    #[test]
    fn decode_never_panics_and_fails_only_on_lengths(
        bytes in prop::collection::vec(any::<u8>(), 0..300),
    ) {
        match SlaveDiagnosis::decode(&bytes) {
            Ok(d) => prop_assert_eq!(d.encode().unwrap().len(), bytes.len()),
            Err(DiagError::TooLong { .. }) => prop_assert!(bytes.len() > 244),
            Err(DiagError::Truncated { .. } | DiagError::BadLength { .. }) => {}
            Err(e) => prop_assert!(false, "{}", e),
        }
    }

    /// Every well-framed diagnosis decodes, whatever its codes, and each unknown part carries
    /// the bytes it was found at.
    #[test]
    fn a_well_framed_diagnosis_always_decodes(bytes in well_framed()) {
        let d = SlaveDiagnosis::decode(&bytes).unwrap();
        prop_assert_eq!(d.encode().unwrap().len(), bytes.len());
        for u in &d.unknown {
            prop_assert_eq!(&bytes[u.offset..u.offset + u.bytes.len()], &u.bytes[..]);
        }
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
            unknown: Vec::new(),
        };
        let bytes = d.encode().unwrap();
        prop_assert_eq!(SlaveDiagnosis::decode(&bytes).unwrap(), d);
    }
}
