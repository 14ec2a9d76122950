//! Watching a live line: a port (and, with a monitor cable's second receive wire, a tap port
//! for the other direction) read without ever transmitting, its bytes and line errors
//! ([`LineReader`]) dated by the host's clock and fed to a decoder, which is also told when
//! the line stays quiet (every 50 ms), until the caller's `stop` or a port closes.
//!
//! Times count from the start of the watch; a character is dated when the OS handed it over,
//! the characters of one read paced back one character time apart.

use crate::driver::Transport;
use crate::monitor::line_errors::LineReader;
use crate::monitor::{Decoder, Record};
use crate::{Instant, SerialSettings};
use std::future::Future;
use tokio::io::AsyncReadExt;

/// How a watch ended.
#[derive(Debug, PartialEq, Eq)]
pub enum Ended<S> {
    /// `stop` ended it with this.
    Stopped(S),
    /// A port reached its end: the tap port if `tap`, else the main one.
    Closed {
        /// Whether it was the tap port.
        tap: bool,
    },
}

/// Why a watch failed.
#[derive(Debug)]
pub enum WatchError<E> {
    /// Reading a port failed.
    Read(std::io::Error),
    /// The caller's record handler failed.
    Records(E),
}

/// Watch `port` (and `tap`, the other direction; the stations are then 0 and 1, else one
/// line, station 0) at `settings` with `decoder`, handing each batch of records to `each`, until
/// `stop` completes or a port ends; the decoder is finished then and its last records handed
/// on. Returns how it ended and the instant it did (from the watch's start).
pub async fn watch<S, E>(
    port: &mut dyn Transport,
    mut tap: Option<&mut dyn Transport>,
    settings: SerialSettings,
    decoder: &mut dyn Decoder,
    stop: impl Future<Output = S>,
    mut each: impl FnMut(Vec<Record>) -> Result<(), E>,
) -> Result<(Ended<S>, Instant), WatchError<E>> {
    let (to_a, to_b) = if tap.is_some() {
        (Some(1), Some(0))
    } else {
        (None, None)
    };
    // Line errors (parity, framing, BREAK, overrun) reach the decoder in place.
    let mut lines_a = LineReader::attach(port, (Some(0), to_a));
    let mut lines_b = tap
        .as_mut()
        .map(|t| LineReader::attach(&mut **t, (Some(1), to_b)));
    let origin = tokio::time::Instant::now();
    let now = || Instant::from_micros(origin.elapsed().as_micros() as u64);
    let mut buf = [0u8; 512];
    let mut buf2 = [0u8; 512];
    let mut last = Instant::ZERO;
    let mut tick = tokio::time::interval(std::time::Duration::from_millis(50));
    tokio::pin!(stop);
    let ended = loop {
        let mut records = Vec::new();
        tokio::select! {
            read = port.read(&mut buf) => {
                let n = read.map_err(WatchError::Read)?;
                if n == 0 {
                    break Ended::Closed { tap: false };
                }
                for c in lines_a.chars(port, &buf[..n], now(), settings, &mut last) {
                    decoder.push(&c, &mut records);
                }
            }
            read = async {
                match tap.as_mut() {
                    Some(t) => t.read(&mut buf2).await,
                    None => std::future::pending().await,
                }
            }, if tap.is_some() => {
                let n = read.map_err(WatchError::Read)?;
                if n == 0 {
                    break Ended::Closed { tap: true };
                }
                let (Some(t), Some(lines)) = (tap.as_mut(), lines_b.as_mut()) else {
                    break Ended::Closed { tap: true };
                };
                for c in lines.chars(&mut **t, &buf2[..n], now(), settings, &mut last) {
                    decoder.push(&c, &mut records);
                }
            }
            _ = tick.tick() => decoder.idle(now(), &mut records),
            s = &mut stop => break Ended::Stopped(s),
        }
        each(records).map_err(WatchError::Records)?;
    };
    let end = now();
    let mut records = Vec::new();
    decoder.finish(end, &mut records);
    each(records).map_err(WatchError::Records)?;
    Ok((ended, end))
}
