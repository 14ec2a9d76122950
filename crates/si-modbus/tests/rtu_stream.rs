//! RTU over TCP ([`si_modbus::rtu_stream`]): any bytes in any chunking never panic and never
//! hold more than one ADU; valid frames come out whole however TCP cuts them; a corrupted frame
//! costs only itself once the peer goes quiet.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use si_modbus::frame::{Adu, Request, MAX_ADU};
use si_modbus::rtu_stream::{Cut, RtuStream};
use si_modbus::rx::Expect;

/// A request of a kind with a predicted length: FC03 or FC16.
fn request() -> impl Strategy<Value = Adu> {
    prop_oneof![
        (0u8..=247, any::<u16>(), 1u16..=125).prop_map(|(unit, address, quantity)| {
            Adu::request(unit, &Request::ReadHoldingRegisters { address, quantity }).unwrap()
        }),
        (
            0u8..=247,
            any::<u16>(),
            prop::collection::vec(any::<u16>(), 1..=60)
        )
            .prop_map(|(unit, address, values)| {
                Adu::request(
                    unit,
                    &Request::WriteMultipleRegisters {
                        address,
                        values: si_modbus::frame::Registers::Words(&values),
                    },
                )
                .unwrap()
            }),
    ]
}

/// Feed `bytes` cut into chunks of the given sizes (cycled), collecting every cut.
fn feed(stream: &mut RtuStream, bytes: &[u8], chunks: &[usize]) -> Vec<Cut> {
    let mut cuts = Vec::new();
    let mut rest = bytes;
    let mut sizes = chunks.iter().cycle();
    while !rest.is_empty() {
        let n = (*sizes.next().unwrap()).clamp(1, rest.len());
        let (mut chunk, tail) = rest.split_at(n);
        rest = tail;
        while let Some(cut) = stream.push(&mut chunk) {
            cuts.push(cut);
        }
        assert!(chunk.is_empty());
        assert!(stream.pending() <= MAX_ADU);
    }
    cuts
}

fn frames(cuts: &[Cut]) -> Vec<Vec<u8>> {
    cuts.iter()
        .filter_map(|c| match c {
            Cut::Frame(adu) => Some(adu.as_bytes().to_vec()),
            _ => None,
        })
        .collect()
}

proptest! {
    // A fixed seed: the hunt after a bad CRC may, with odds of 1 in 65536 per offset, take a
    // misaligned span for a frame; a random seed would make that a rare flaky failure.
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: RngSeed::Fixed(27), ..ProptestConfig::default() })]

    #[test]
    fn any_bytes_any_chunking_no_panic_and_bounded(
        bytes in prop::collection::vec(any::<u8>(), 0..2000),
        chunks in prop::collection::vec(1usize..300, 1..8),
        expect in prop_oneof![Just(Expect::Request), Just(Expect::Nothing), any::<u8>().prop_map(Expect::ResponseTo)],
        gap_at_end in any::<bool>(),
    ) {
        let mut s = RtuStream::new(expect);
        let cuts = feed(&mut s, &bytes, &chunks);
        for cut in &cuts {
            if let Cut::Frame(adu) = cut {
                prop_assert!(si_modbus::frame::crc_ok(adu.as_bytes()));
            }
        }
        if gap_at_end {
            while s.gap().is_some() {}
            prop_assert_eq!(s.pending(), 0);
        }
    }

    #[test]
    fn valid_frames_come_out_whole_in_any_chunking(
        adus in prop::collection::vec(request(), 1..10),
        chunks in prop::collection::vec(1usize..300, 1..8),
    ) {
        let bytes: Vec<u8> = adus.iter().flat_map(|a| a.as_bytes().to_vec()).collect();
        let mut s = RtuStream::new(Expect::Request);
        let cuts = feed(&mut s, &bytes, &chunks);
        let want: Vec<Vec<u8>> = adus.iter().map(|a| a.as_bytes().to_vec()).collect();
        prop_assert_eq!(frames(&cuts), want);
        prop_assert_eq!(cuts.len(), adus.len());
        prop_assert_eq!(s.pending(), 0);
    }

    #[test]
    fn a_corrupted_frame_costs_only_itself(
        before in prop::collection::vec(request(), 0..4),
        hit in request(),
        after in prop::collection::vec(request(), 1..5),
        flip_at in any::<prop::sample::Index>(),
        flip in 1u8..=255,
        chunks in prop::collection::vec(1usize..300, 1..8),
    ) {
        let mut bad = hit.as_bytes().to_vec();
        let at = flip_at.index(bad.len());
        bad[at] ^= flip;
        let mut bytes: Vec<u8> = before.iter().flat_map(|a| a.as_bytes().to_vec()).collect();
        bytes.extend_from_slice(&bad);
        for a in &after {
            bytes.extend_from_slice(a.as_bytes());
        }
        let mut s = RtuStream::new(Expect::Request);
        let mut cuts = feed(&mut s, &bytes, &chunks);
        // The peer goes quiet: a corrupted length may still hold the frames after it.
        while let Some(cut) = s.gap() {
            cuts.push(cut);
        }
        prop_assert_eq!(s.pending(), 0);
        let got = frames(&cuts);
        let want_before: Vec<Vec<u8>> = before.iter().map(|a| a.as_bytes().to_vec()).collect();
        let want_after: Vec<Vec<u8>> = after.iter().map(|a| a.as_bytes().to_vec()).collect();
        prop_assert!(got.len() >= want_before.len() + want_after.len(), "{:?}", cuts);
        prop_assert_eq!(&got[..want_before.len()], &want_before[..]);
        prop_assert_eq!(&got[got.len() - want_after.len()..], &want_after[..]);
        prop_assert!(s.counters().crc_errors <= 1, "{:?}", s.counters());
    }
}
