//! The line errors of a watched port: a marking port (Linux, `PARMRK`, `crate::linemark`)
//! reports parity and framing errors and BREAKs in its stream once a reader attaches, and the
//! kernel counts overruns it cannot mark (`TIOCGICOUNT`). The monitor shows each where a
//! character would have been, so the protocol monitors flag the frame it hit, and the text,
//! JSON and SVG output and the recorded trace (`--record`, through the port's tap) carry it.

use crate::driver::Transport;
use crate::linemark::{MarkDecoder, Marked};
use crate::monitor::LineChar;
use crate::{Instant, LineError, SerialSettings};

/// One watched port's reads turned into line characters, line errors included.
pub struct LineReader {
    /// The decoder of the marked stream; `None` for a port that does not mark (TCP, other
    /// platforms, `--no-line-errors`): its bytes are taken as they come.
    marks: Option<MarkDecoder>,
    /// The direction the port hears (transmitting and receiving station indices).
    dirs: (Option<usize>, Option<usize>),
}

impl LineReader {
    /// Take the port over as a reader that wants the marked stream (`Transport::attach`).
    pub fn attach(port: &mut dyn Transport, dirs: (Option<usize>, Option<usize>)) -> Self {
        LineReader {
            marks: port.attach().marked_errors.map(MarkDecoder::new),
            dirs,
        }
    }

    /// The characters of one read that returned `bytes` at `at`, paced back from `at` one
    /// character time apart (as `crate::monitor::line::pace`), then one overrun if the port
    /// counted characters lost since the previous read (where they were lost the count cannot
    /// say: after the read's characters, `[derived]`). Never before `last`, the time of the
    /// character fed before (from any port of the monitor), which this advances.
    pub fn chars(
        &mut self,
        port: &mut dyn Transport,
        bytes: &[u8],
        at: Instant,
        settings: SerialSettings,
        last: &mut Instant,
    ) -> Vec<LineChar> {
        let mut items: Vec<Result<u8, LineError>> = Vec::with_capacity(bytes.len());
        match &mut self.marks {
            Some(marks) => marks.feed(bytes, |piece| match piece {
                Marked::Data(run) => items.extend(run.iter().map(|&b| Ok(b))),
                Marked::Error(e) => items.push(Err(e)),
            }),
            None => items.extend(bytes.iter().map(|&b| Ok(b))),
        }
        if port.new_overruns() > 0 {
            items.push(Err(LineError::Overrun));
        }
        let n = items.len();
        let (from, to) = self.dirs;
        items
            .into_iter()
            .enumerate()
            .map(|(k, item)| {
                let before = settings.chars_time((n - 1 - k) as u64);
                let t = Instant::from_micros(at.as_micros().saturating_sub(before.as_micros()))
                    .max(*last);
                *last = t;
                LineChar {
                    at: t,
                    from,
                    to,
                    item,
                    exact: k == 0,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::driver::PortFacts;
    use std::pin::Pin;
    use std::task::{Context, Poll};
    use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

    /// A port that marks with parity checked and counted `lost` characters.
    struct Marking {
        lost: u64,
    }
    impl AsyncRead for Marking {
        fn poll_read(
            self: Pin<&mut Self>,
            _: &mut Context<'_>,
            _: &mut ReadBuf<'_>,
        ) -> Poll<std::io::Result<()>> {
            Poll::Pending
        }
    }
    impl AsyncWrite for Marking {
        fn poll_write(
            self: Pin<&mut Self>,
            _: &mut Context<'_>,
            b: &[u8],
        ) -> Poll<std::io::Result<usize>> {
            Poll::Ready(Ok(b.len()))
        }
        fn poll_flush(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<std::io::Result<()>> {
            Poll::Ready(Ok(()))
        }
        fn poll_shutdown(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<std::io::Result<()>> {
            Poll::Ready(Ok(()))
        }
    }
    impl Transport for Marking {
        fn attach(&mut self) -> PortFacts {
            PortFacts {
                marked_errors: Some(LineError::Parity),
                ..PortFacts::default()
            }
        }
        fn new_overruns(&mut self) -> u64 {
            std::mem::take(&mut self.lost)
        }
    }

    #[test]
    fn marks_become_line_errors_in_place_and_a_counted_overrun_follows_the_read() {
        let mut port = Marking { lost: 0 };
        let mut reader = LineReader::attach(&mut port, (Some(0), None));
        let settings = SerialSettings::default();
        let at = Instant::from_micros(100_000);
        let mut last = Instant::ZERO;
        // 41, a bad character, a BREAK, a data FF.
        let read = [0x41, 0xFF, 0x00, 0x37, 0xFF, 0x00, 0x00, 0xFF, 0xFF];
        let items: Vec<_> = reader
            .chars(&mut port, &read, at, settings, &mut last)
            .into_iter()
            .map(|c| c.item)
            .collect();
        assert_eq!(
            items,
            vec![
                Ok(0x41),
                Err(LineError::Parity),
                Err(LineError::Break),
                Ok(0xFF)
            ]
        );
        port.lost = 2;
        let chars = reader.chars(
            &mut port,
            &[0x42],
            at + settings.char_time(),
            settings,
            &mut last,
        );
        let items: Vec<_> = chars.iter().map(|c| c.item).collect();
        assert_eq!(items, vec![Ok(0x42), Err(LineError::Overrun)]);
        assert!(chars[0].at <= chars[1].at);
    }
}
