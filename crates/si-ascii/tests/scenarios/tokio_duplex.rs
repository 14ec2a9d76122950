//! The async handle (feature `tokio`) over an in-memory duplex pipe: two links exchange lines
//! cut by CR LF, and a refused frame comes back as a typed error.
#![cfg(feature = "tokio")]

use si_ascii::tokio::{Error, Handle, Incoming, Refusal};
use si_ascii::{Config, EndCriterion, SendError};

fn config() -> Config {
    Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        ..Config::default()
    }
}

#[tokio::test]
async fn two_handles_exchange_lines_over_a_duplex_pipe() {
    let (left, right) = tokio::io::duplex(1024);
    let mut a = Handle::spawn(config(), left).unwrap();
    let mut b = Handle::spawn(config(), right).unwrap();
    a.send(&b"first\r\n"[..]).await.unwrap();
    a.send(&b"second\r\n"[..]).await.unwrap();
    assert_eq!(b.recv().await.unwrap(), &b"first\r\n"[..]);
    match b.recv_timed().await.unwrap() {
        Incoming::Frame { data, .. } => assert_eq!(data, &b"second\r\n"[..]),
        other => panic!("{other:?}"),
    }
    // And back.
    b.send(&b"ack\r\n"[..]).await.unwrap();
    assert_eq!(a.recv().await.unwrap(), &b"ack\r\n"[..]);
    // A frame over 200 bytes is refused before anything is sent.
    assert_eq!(
        a.send(vec![0u8; 201]).await,
        Err(Error::Refused(Refusal::Send(SendError::TooLong {
            len: 201,
            max: 200
        })))
    );
}

#[tokio::test(start_paused = true)]
async fn restart_drops_waiting_frames_only_when_clearing_is_set() {
    for clear in [true, false] {
        let (left, right) = tokio::io::duplex(1024);
        let a = Handle::spawn(config(), left).unwrap();
        let receiver = Config {
            clear_at_startup: clear,
            ..config()
        };
        let mut b = Handle::spawn(receiver, right).unwrap();
        a.send(&b"before\r\n"[..]).await.unwrap();
        // Wait (in virtual time) until the frame is cut and stored in B's buffer.
        let mut stored = 0;
        for _ in 0..100 {
            stored = b.call(|l, _| l.buffer().frames()).await.unwrap();
            if stored > 0 {
                break;
            }
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
        }
        assert_eq!(stored, 1);
        b.restart().await.unwrap();
        a.send(&b"after\r\n"[..]).await.unwrap();
        let expected: &[u8] = if clear { b"after\r\n" } else { b"before\r\n" };
        assert_eq!(
            b.recv().await.unwrap(),
            expected,
            "clear_at_startup = {clear}"
        );
    }
}
