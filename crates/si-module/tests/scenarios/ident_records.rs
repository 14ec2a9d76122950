//! Identification data DS 231 (I&M0) and DS 232 (I&M1), [ET200S SI 2005] §2.9.4, Tables 2-10/2-11
//! (Tables 2-10 and 2-11).

use proptest::prelude::*;
use si_module::diag::Variant;
use si_module::ident::{
    Im0, Im1, ImError, Index, Record, SoftwareRevision, DATA_LEN, HID_LEN, LOCATION_LEN, RECORD_LEN,
};

#[test]
fn table_2_10_field_sizes_add_up_to_54_data_bytes_per_index() {
    assert_eq!(2 + 20 + 16 + 2 + 4 + 2 + 2 + 2 + 2 + 2, DATA_LEN);
    assert_eq!(HID_LEN + LOCATION_LEN, DATA_LEN);
    assert_eq!(10 + DATA_LEN, RECORD_LEN);
    assert_eq!((Index::Im0.record(), Index::Im1.record()), (231, 232));
}

#[test]
fn ds_231_golden_bytes() {
    let im0 = Im0::for_variant(Variant::R3964Ascii, "S C-X4U12345");
    let r = im0.encode().unwrap();
    assert_eq!(r.len(), 64);
    // Header: SZL ID F111H, index 1, length 0038H, one block, index 1.
    assert_eq!(r[..10], [0xF1, 0x11, 0, 1, 0, 0x38, 0, 1, 0, 1]);
    assert_eq!(r[10..12], [0x00, 0x2A]); // manufacturer: Siemens AG
    assert_eq!(&r[12..32], b"6ES7 138-4DF01-0AB0 "); // device name, 20 bytes, blank padded
    assert_eq!(&r[32..48], b"S C-X4U12345    "); // serial number, 16 bytes
    assert_eq!(r[48..50], [0, 1]); // hardware revision
    assert_eq!(&r[50..54], b"V\x01\x00\x00"); // software revision V1.0.0
    assert_eq!(r[54..56], [0, 0]); // revision counter: not supported
    assert_eq!(r[56..58], [0xF6, 0x00]); // PROFILE_ID
    assert_eq!(r[58..60], [0x00, 0x04]); // profile-specific type: communication module
    assert_eq!(r[60..62], [0x00, 0x00]); // I&M version
    assert_eq!(r[62..64], [0x00, 0x01]); // I&M0 and I&M1 supported
    assert_eq!(Im0::decode(&r).unwrap(), im0);
    assert_eq!(Record::decode(&r).unwrap(), Record::Im0(im0));
    let modbus = Im0::for_variant(Variant::ModbusUss, "1");
    assert_eq!(modbus.order_number, "6ES7 138-4DF11-0AB0");
    assert_eq!(SoftwareRevision::default().to_string(), "V1.0.0");
}

#[test]
fn ds_232_golden_bytes_and_length_limits() {
    let im1 = Im1::new("PLANT-A/LINE-3", "HALL 2 ROW 5").unwrap();
    let r = im1.encode().unwrap();
    assert_eq!(r[..10], [0xF1, 0x11, 0, 2, 0, 0x38, 0, 1, 0, 2]);
    assert_eq!(&r[10..42], b"PLANT-A/LINE-3                  ");
    assert_eq!(&r[42..64], b"HALL 2 ROW 5          ");
    assert_eq!(Im1::decode(&r).unwrap(), im1);
    assert_eq!(Record::decode(&r).unwrap(), Record::Im1(im1));

    // At the limits: 32 and 22 characters.
    let hid = "H".repeat(32);
    let loc = "L".repeat(22);
    let full = Im1::new(&hid, &loc).unwrap();
    assert_eq!(Im1::decode(&full.encode().unwrap()).unwrap(), full);
    // One beyond.
    assert_eq!(
        Im1::new(&"H".repeat(33), "").unwrap_err().to_string(),
        "plant designation (HID) is 33 characters long, at most 32 allowed"
    );
    assert_eq!(
        Im1::new("", &"L".repeat(23)).unwrap_err(),
        ImError::TooLong {
            field: "location designation (OKZ)",
            len: 23,
            max: 22
        }
    );
    assert!(matches!(
        Im1::new("Straße", ""),
        Err(ImError::Character { position: 5, .. })
    ));
    assert!(matches!(
        Im1::new("a\tb", ""),
        Err(ImError::Character { position: 2, .. })
    ));
}

#[test]
fn wrong_records_are_refused_naming_the_field() {
    let good = Im1::default().encode().unwrap();
    assert_eq!(
        Im1::decode(&good[..63]).unwrap_err(),
        ImError::Length { len: 63 }
    );
    let mut r = good;
    r[5] = 0x36;
    assert_eq!(
        Im1::decode(&r).unwrap_err().to_string(),
        "header length of the ID data at offset 4 must be 0038H, got 0036H"
    );
    let mut r = good;
    r[0] = 0xF0;
    assert!(matches!(
        Im1::decode(&r),
        Err(ImError::Header {
            field: "SZL ID",
            ..
        })
    ));
    // An I&M1 record is not an I&M0 record.
    assert!(matches!(
        Im0::decode(&good),
        Err(ImError::Header {
            field: "index",
            offset: 2,
            ..
        })
    ));
    let mut r = good;
    r[12] = 0x80;
    assert!(matches!(
        Im1::decode(&r),
        Err(ImError::Character { position: 12, .. })
    ));
    // 00H padding is accepted and stripped.
    let mut r = Im1::new("AB", "").unwrap().encode().unwrap();
    r[12..42].fill(0);
    assert_eq!(Im1::decode(&r).unwrap().hid, "AB");
}

proptest! {
    #[test]
    fn im1_round_trip(hid in "[ -~]{0,32}", loc in "[ -~]{0,22}") {
        let im1 = Im1::new(&hid, &loc).unwrap();
        let back = Im1::decode(&im1.encode().unwrap()).unwrap();
        // Trailing blanks are padding.
        prop_assert_eq!(back.hid, hid.trim_end_matches(' '));
        prop_assert_eq!(back.location, loc.trim_end_matches(' '));
    }

    #[test]
    fn im0_round_trip(order in "[!-~]([ -~]{0,18}[!-~])?", serial in "[!-~]{0,16}", hw: u16,
                      sw: [u8; 4], words: [u16; 4], ver: [u8; 2]) {
        let im0 = Im0 {
            manufacturer: words[0],
            order_number: order,
            serial_number: serial,
            hardware_revision: hw,
            software_revision: SoftwareRevision { prefix: sw[0], functional: sw[1], bug_fix: sw[2], internal: sw[3] },
            revision_counter: words[1],
            profile_id: words[2],
            profile_specific_type: words[3],
            im_version: ver,
            im_supported: 1,
        };
        prop_assert_eq!(Im0::decode(&im0.encode().unwrap()).unwrap(), im0);
    }

    #[test]
    fn decode_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..80)) {
        let _ = Record::decode(&bytes);
    }
}
