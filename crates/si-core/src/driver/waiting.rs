//! Bytes already waiting when a deadline expires ("A late host" in the driver's docs).
//!
//! The silence timers of the protocols end a frame when the *line* has been silent: Modbus
//! RTU's end-of-frame gap ([Modbus/USS] §3.3.5, Table 3-11; the 3.5-character t3.5 of
//! [Modbus serial] §2.5.1.1), the ASCII driver's character delay time ([ET200S SI] §2.8), the
//! USS residual run time. A host cannot watch the line; it sees when its reads return. When its
//! process was off the CPU for longer than such a timer while a frame was arriving, it wakes with
//! the deadline expired **and** the rest of the frame waiting in the port's buffer. Firing the
//! deadline first would end the frame at a silence the line never had (a cut Modbus answer:
//! 0E52H/0E57H). So before the driver fires an expired deadline it takes what the transport
//! holds without waiting ([`read_waiting`]) and hands it to the engine stamped just before the
//! deadline ([`stamp_waiting`]); only a deadline with nothing waiting, a silence that really
//! happened, fires. The engines' contract is unchanged: they are told of bytes at an instant,
//! as always, and judge the gap themselves.

use crate::time::{Duration, Instant};
use std::future::poll_fn;
use std::io;
use std::pin::Pin;
use std::task::Poll;
use tokio::io::{AsyncRead, ReadBuf};

/// How far before an expired deadline the bytes found waiting are stamped: the engines'
/// deadlines mean "at this instant the timer has run" (a frame ends when `now ≥ last + gap`),
/// so a byte stamped one microsecond (the engines' time resolution) earlier fell inside it.
pub const BEFORE_DEADLINE: Duration = Duration::from_micros(1);

/// Read what `io` can give now, without waiting: `None` if a read would wait (nothing is
/// waiting), else the read's result (`Ok(0)`: end of file).
///
/// Polled outside tokio's cooperative budget: a transport whose task used up its budget
/// answers "not ready" even with bytes waiting, and that would be taken for silence.
pub async fn read_waiting<R: AsyncRead + Unpin>(
    io: &mut R,
    buf: &mut [u8],
) -> Option<io::Result<usize>> {
    let mut buf = ReadBuf::new(buf);
    let once = poll_fn(|cx| match Pin::new(&mut *io).poll_read(cx, &mut buf) {
        Poll::Ready(result) => Poll::Ready(Some(result)),
        Poll::Pending => Poll::Ready(None),
    });
    let read = tokio::task::unconstrained(once).await?;
    Some(read.map(|()| buf.filled().len()))
}

/// The instant bytes found waiting when the deadline `expired` is fired late at `now` are
/// handed to the engine at: just before the deadline ([`BEFORE_DEADLINE`]), not later than
/// `now`, and not earlier than `floor`, the latest instant the engine was already told
/// (its time never runs backwards).
///
/// Why before the deadline (`[derived]` from the silence rule of [Modbus/USS] §3.3.5,
/// Table 3-11 and [Modbus serial] §2.5.1.1): the bytes were in the port's buffer when the
/// driver got to run; the only silence the host measured is its own absence. A receiver with
/// its own UART (the module) times the gap between characters on the wire and would have seen
/// them arrive. Had the host run at the deadline, bytes that came before it would have reached
/// the engine before it too; bytes that came after it would have found the frame ended. The
/// host cannot tell these apart once it is late, and reads them as the first: a frame the line
/// never cut is not cut. The reading costs something only where the line really was silent
/// for the gap and then carried a new frame within the host's lateness (another station's
/// frame right after the first on a shared bus): the two then reach the engine as one, which
/// fails its check (CRC) and is counted, where firing first would have kept them apart. The
/// other reading cuts every frame whose rest was waiting, on every line, which is the common
/// case: a master waiting for its answer, a slave receiving a request.
pub fn stamp_waiting(expired: Instant, now: Instant, floor: Instant) -> Instant {
    let just_before = Instant::from_micros(
        expired
            .as_micros()
            .saturating_sub(BEFORE_DEADLINE.as_micros()),
    );
    just_before.min(now).max(floor)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(us: u64) -> Instant {
        Instant::from_micros(us)
    }

    #[test]
    fn waiting_bytes_are_stamped_just_before_the_expired_deadline() {
        assert_eq!(stamp_waiting(at(5_000), at(9_000), at(1_000)), at(4_999));
    }

    #[test]
    fn the_stamp_is_never_later_than_now_nor_earlier_than_what_the_engine_was_told() {
        assert_eq!(stamp_waiting(at(5_000), at(3_000), at(1_000)), at(3_000));
        // A deadline already due when the engine named it: the engine's time stands.
        assert_eq!(stamp_waiting(at(5_000), at(9_000), at(6_000)), at(6_000));
        assert_eq!(stamp_waiting(at(0), at(9_000), at(0)), at(0));
    }

    #[tokio::test]
    async fn read_waiting_takes_what_is_there_and_does_not_wait_for_more() {
        use tokio::io::AsyncWriteExt;
        let (mut ours, mut theirs) = tokio::io::duplex(64);
        let mut buf = [0u8; 16];
        assert!(read_waiting(&mut ours, &mut buf).await.is_none());
        theirs.write_all(&[1, 2, 3]).await.unwrap();
        let n = read_waiting(&mut ours, &mut buf).await.unwrap().unwrap();
        assert_eq!(&buf[..n], &[1, 2, 3]);
        assert!(read_waiting(&mut ours, &mut buf).await.is_none());
        drop(theirs);
        assert_eq!(read_waiting(&mut ours, &mut buf).await.unwrap().unwrap(), 0);
    }
}
