//! The maximum frame length as a setting with module presets: ET 200S 1SI 200 bytes
//! ([ET200S SI] Table 2-13/2-14), 2005 module 224 bytes ([ET200S SI 2005] `[derived]`),
//! CP 341 1024 bytes ([CP 341 Diag] 0517H). Received frames longer than the setting are
//! discarded with 0850H; send jobs longer than it are refused with 050EH by the link and with
//! 1E41H by S_SEND's LEN check.

use crate::common;

use common::{errors, settings, Bench};
use si_ascii::fb::SSend;
use si_ascii::{status, Config, EndCriterion, SendError};
use si_core::{ModulePreset, Status};

/// The preset's configuration at 115 200 bit/s (a 1 KB frame takes under 100 ms).
fn config(module: ModulePreset, end: EndCriterion) -> Config {
    Config {
        settings: settings(115_200),
        end,
        ..Config::for_module(module)
    }
}

#[test]
fn each_preset_receives_its_longest_frame_and_rejects_one_byte_more_with_0850() {
    for module in ModulePreset::ALL {
        let max = usize::from(module.max_frame_len());
        for end in [EndCriterion::CharDelay, EndCriterion::DEFAULT_END_CHARS] {
            let body = |n: usize| {
                let mut f = vec![0x41; n];
                if end != EndCriterion::CharDelay {
                    f[n - 1] = 0x03;
                }
                f
            };
            let mut b = Bench::new(config(module, end));
            b.partner_sends(&body(max));
            b.run_for_ms(300);
            assert!(errors(&b.events()).is_empty(), "{module:?} {end:?}");
            assert_eq!(
                b.frames(),
                vec![body(max)],
                "{module:?} {end:?}: exactly max"
            );

            b.partner_sends(&body(max + 1));
            b.run_for_ms(300);
            b.partner_sends(&body(4));
            b.run_for_ms(100);
            assert_eq!(
                errors(&b.events()).iter().map(|e| e.0).collect::<Vec<_>>(),
                vec![status::FRAME_TOO_LONG.code()],
                "{module:?} {end:?}: max + 1"
            );
            assert_eq!(b.frames(), vec![body(4)], "{module:?} {end:?}: next frame");
        }
    }
}

#[test]
fn fixed_length_up_to_the_preset_maximum() {
    let c = config(ModulePreset::Si2005, EndCriterion::FixedLength { len: 224 });
    let mut b = Bench::new(c);
    b.partner_sends(&[7; 448]);
    b.run_for_ms(300);
    assert_eq!(b.frames(), vec![vec![7; 224], vec![7; 224]]);
    // The ET 200S 1SI stops at 200 (Table 2-10).
    let e = Config {
        end: EndCriterion::FixedLength { len: 224 },
        ..Config::default()
    }
    .validate()
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "length of received frame = 224 bytes is out of range: 1 … 200 bytes"
    );
}

#[test]
fn a_send_longer_than_the_maximum_is_refused_with_050e_and_nothing_goes_out() {
    for module in ModulePreset::ALL {
        let max = usize::from(module.max_frame_len());
        let mut b = Bench::new(config(module, EndCriterion::CharDelay));
        let refused = b
            .sim
            .with(b.link, |l, now| l.send(now, vec![0x55; max + 1].into()));
        assert_eq!(refused, Err(SendError::TooLong { len: max + 1, max }));
        assert_eq!(
            refused.unwrap_err().status(),
            status::INVALID_FRAME_LENGTH,
            "{module:?}"
        );
        b.run_for_ms(300);
        assert!(b.sim.engine(b.partner).bytes().is_empty(), "{module:?}");
        // The longest frame goes out whole.
        b.sim
            .with(b.link, |l, now| l.send(now, vec![0x55; max].into()))
            .unwrap();
        b.run_for_ms(300);
        assert_eq!(b.sim.engine(b.partner).bytes(), vec![0x55; max]);
    }
    // An empty frame is the FB's LEN error, not a frame length error.
    let mut b = Bench::new(Config::default());
    let empty = b.sim.with(b.link, |l, now| l.send(now, Vec::new().into()));
    assert_eq!(empty.unwrap_err().status(), status::INVALID_LEN);
}

#[test]
fn s_send_checks_len_against_the_maximum_with_1e41() {
    for (module, len, expect) in [
        (ModulePreset::Et200s1Si, 201, Some(status::INVALID_LEN)),
        (ModulePreset::Si2005, 224, None),
        (ModulePreset::Si2005, 225, Some(status::INVALID_LEN)),
    ] {
        let mut b = Bench::new(config(module, EndCriterion::CharDelay));
        let mut s_send = SSend::default();
        let data = vec![0x31; len];
        let mut result = None;
        for _ in 0..100 {
            let out = b
                .sim
                .with(b.link, |l, now| s_send.call(l, now, true, false, &data));
            if out.done || out.error {
                result = Some(out.status);
                break;
            }
            b.run_for_ms(1);
        }
        assert_eq!(
            result,
            Some(expect.unwrap_or(Status::OK)),
            "{module:?} LEN {len}"
        );
    }
}
