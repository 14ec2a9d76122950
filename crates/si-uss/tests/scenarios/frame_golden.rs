//! Golden telegrams built by hand from the USS rules ([USS spec], [Modbus/USS]
//! [Modbus/USS] §3.7.1), with their BCC worked out byte by byte, and anti-tests for the usual
//! mistakes.

use si_uss::frame::{
    self, bcc, decode, decode_from, encode, Adr, DecodeError, NetData, ParamAddress, Pke, Pkw,
    PkwWords, Pzd, MAX_TELEGRAM,
};

fn build(adr: Adr, net: &[u8]) -> Vec<u8> {
    let mut buf = [0u8; MAX_TELEGRAM];
    let n = encode(adr, net, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// [SINAMICS CU240S] p. 178, "common fixed length": PKW 4 + PZD 2 words → LGE 0EH, 16 bytes. Slave
/// 0, read P700 (AK 1, PKE 12BCH), STW 047EH, HSW 0.
/// BCC: 02^0E = 0C; ^00 = 0C; ^12 = 1E; ^BC = A2; ^(zeros) = A2; ^04 = A6; ^7E = D8.
const READ_P700: [u8; 16] = [
    0x02, 0x0E, 0x00, 0x12, 0xBC, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04, 0x7E, 0x00, 0x00, 0xD8,
];

#[test]
fn section_3_fixed_length_telegram_pkw4_pzd2_is_16_bytes_with_lge_0e() {
    let net = NetData {
        pkw: Some(Pkw::new(Pke::new(1, false, 700), 0, &[0, 0])),
        pzd: Pzd::new(&[0x047E, 0]),
    };
    let mut buf = [0u8; 12];
    assert_eq!(net.write(&mut buf).unwrap(), 12);
    assert_eq!(build(Adr::slave(0).unwrap(), &buf), READ_P700);
    let t = decode(&READ_P700).unwrap();
    assert_eq!(t.adr, Adr(0));
    assert_eq!(NetData::parse(t.net, PkwWords::Four, 2).unwrap(), net);
}

#[test]
fn shortest_telegram_has_lge_2_and_bcc_over_stx_lge_adr() {
    // 02 ^ 02 ^ 05 = 05.
    assert_eq!(build(Adr(5), &[]), vec![0x02, 0x02, 0x05, 0x05]);
    // PZD only: slave 3, STW 047FH, HSW 4000H: LGE 06; BCC 02^06^03^04^7F^40^00 = 3C.
    let t = build(Adr(3), &[0x04, 0x7F, 0x40, 0x00]);
    assert_eq!(t, vec![0x02, 0x06, 0x03, 0x04, 0x7F, 0x40, 0x00, 0x3C]);
}

#[test]
fn bcc_includes_stx_and_the_whole_telegram_xors_to_zero() {
    assert_eq!(bcc(&READ_P700[..15]), 0xD8);
    assert_eq!(bcc(&READ_P700), 0);
}

#[test]
fn anti_bcc_computed_without_stx_is_rejected() {
    let mut t = READ_P700;
    t[15] = bcc(&t[1..15]); // the 3964R habit: XOR after STX
    assert_eq!(t[15], 0xDA);
    assert_eq!(
        decode(&t),
        Err(DecodeError::Bcc {
            offset: 15,
            expected: 0xD8,
            found: 0xDA
        })
    );
}

#[test]
fn decode_names_wrong_lge_stx_size_and_address_with_offsets() {
    let mut t = READ_P700;
    t[1] = 0x0C;
    assert_eq!(
        decode(&t),
        Err(DecodeError::WrongLength {
            lge: 0x0C,
            expected: 14,
            found: 16
        })
    );
    assert_eq!(
        decode(&[0x02, 0x01, 0x00, 0x03]),
        Err(DecodeError::LgeOutOfRange { lge: 1 })
    );
    assert_eq!(
        decode(&[0x03, 0x02, 0x00, 0x01]),
        Err(DecodeError::NoStx { found: 0x03 })
    );
    assert_eq!(decode(&[0x02, 0x02]), Err(DecodeError::TooShort { len: 2 }));
    assert_eq!(decode(&[0u8; 257]), Err(DecodeError::Oversize { len: 257 }));
    assert_eq!(
        decode_from(&READ_P700, Adr(1)),
        Err(DecodeError::UnexpectedAddress {
            expected: 1,
            found: 0
        })
    );
    let e = decode(&{
        let mut t = READ_P700;
        t[15] ^= 1;
        t
    })
    .unwrap_err();
    assert_eq!(e.to_string(), "BCC at byte 15 is D9H, expected D8H");
}

#[test]
fn largest_telegram_is_256_bytes_and_253_net_bytes_are_refused() {
    let net = [0xA5u8; 252];
    let t = build(Adr(31), &net);
    assert_eq!(t.len(), 256);
    assert_eq!(t[1], 254);
    assert!(decode(&t).is_ok());
    let mut buf = [0u8; 300];
    assert_eq!(
        encode(Adr(1), &[0; 253], &mut buf),
        Err(frame::EncodeError::NetTooLong(253))
    );
}

#[test]
fn adr_type_bits_broadcast_mirror_special() {
    assert_eq!(build(Adr::broadcast(), &[])[2], 0x20);
    assert_eq!(build(Adr::mirror(7).unwrap(), &[])[2], 0x47);
    let bytes = build(Adr(0x85), &[]);
    let t = decode(&bytes).unwrap();
    assert!(t.adr.is_special() && t.adr.address() == 5);
}

#[test]
fn words_are_high_byte_first_and_double_words_high_word_first() {
    // Write P2000 (page 1 → IND 8000H, PKE PNU 0) with 0001_86A0H = 100 000, AK 3.
    let (pnu, ind) = ParamAddress {
        number: 2000,
        index: 0,
    }
    .split()
    .unwrap();
    let pkw = Pkw::new(Pke::new(3, false, pnu), ind, &[0x0001, 0x86A0]);
    assert_eq!(pkw.value(), 100_000);
    let mut buf = [0u8; 8];
    NetData {
        pkw: Some(pkw),
        pzd: Pzd::default(),
    }
    .write(&mut buf)
    .unwrap();
    assert_eq!(buf, [0x30, 0x00, 0x80, 0x00, 0x00, 0x01, 0x86, 0xA0]);
}

#[test]
fn variable_pkw_takes_what_precedes_the_pzd() {
    let net = [
        0x10, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x02, 0x00, 0x03, 0xAB, 0xCD,
    ];
    let d = NetData::parse(&net, PkwWords::Variable, 1).unwrap();
    assert_eq!(d.pkw.unwrap().pwe(), &[1, 2, 3]);
    assert_eq!(d.pzd.words(), &[0xABCD]);
    assert!(matches!(
        NetData::parse(&net, PkwWords::Three, 2),
        Err(DecodeError::WrongStructure {
            expected: 10,
            found: 12
        })
    ));
}
