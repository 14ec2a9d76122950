//! The receive path a driver puts between a port and an engine, Sans-IO.
//!
//! What a read returns is not always what the line carried: a `PARMRK` port marks line errors
//! in the stream ([`crate::linemark`]), and a port that hears itself returns our own
//! transmission first ([`crate::echo`]). [`RxPath`] undoes both, in that order, and hands the
//! engine data runs and line errors in the order they arrived. The tokio driver uses it; so can
//! any other driver.

use crate::echo::EchoFilter;
use crate::linemark::{MarkDecoder, Marked};
use crate::port_facts::PortFacts;
use crate::sansio::Engine;
use crate::time::Instant;

/// Decodes marks and drops the echo before the engine sees received bytes (module docs).
#[derive(Debug, Clone, Default)]
pub struct RxPath {
    marks: Option<MarkDecoder>,
    echo: Option<EchoFilter>,
}

impl RxPath {
    /// The receive path a port with these facts needs.
    pub fn new(facts: &PortFacts) -> Self {
        RxPath {
            marks: facts.marked_errors.map(MarkDecoder::new),
            echo: facts.local_echo.then(EchoFilter::new),
        }
    }

    /// We transmitted `bytes`; on a port that hears itself, their echo may arrive until
    /// `until`.
    pub fn sent(&mut self, bytes: &[u8], until: Instant) {
        if let Some(echo) = &mut self.echo {
            echo.sent(bytes, until);
        }
    }

    /// Hand what one read returned at `now` to `engine`: data runs to
    /// [`Engine::handle_rx`], marked errors to [`Engine::handle_line_error`], in order.
    /// `seen` gets each decoded piece first, echo included: what the line carried (for a
    /// trace).
    pub fn deliver<E: Engine + ?Sized>(
        &mut self,
        engine: &mut E,
        now: Instant,
        bytes: &[u8],
        mut seen: impl FnMut(Marked<'_>),
    ) {
        let echo = &mut self.echo;
        match &mut self.marks {
            None => {
                seen(Marked::Data(bytes));
                data(echo, engine, now, bytes)
            }
            Some(marks) => marks.feed(bytes, |piece| match piece {
                Marked::Data(run) => {
                    seen(piece);
                    data(echo, engine, now, run)
                }
                Marked::Error(error) => {
                    seen(piece);
                    // Our own echo does not come back garbled: what did is the line's news.
                    if let Some(echo) = echo {
                        echo.stop();
                    }
                    engine.handle_line_error(now, error);
                }
            }),
        }
    }
}

/// One data run, less our echo, to the engine.
fn data<E: Engine + ?Sized>(
    echo: &mut Option<EchoFilter>,
    engine: &mut E,
    now: Instant,
    run: &[u8],
) {
    let run = match echo {
        Some(echo) => echo.filter(now, run),
        None => run,
    };
    if !run.is_empty() {
        engine.handle_rx(now, run);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sansio::{LineError, Output};

    /// Records what reaches the engine.
    #[derive(Default)]
    struct Seen(Vec<Result<u8, LineError>>);
    impl Engine for Seen {
        type Event = ();
        fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
            self.0.extend(bytes.iter().map(|&b| Ok(b)));
        }
        fn handle_timeout(&mut self, _: Instant) {}
        fn handle_line_error(&mut self, _: Instant, error: LineError) {
            self.0.push(Err(error));
        }
        fn poll_output(&mut self) -> Output<()> {
            Output::Wait(None)
        }
    }

    #[test]
    fn marks_are_decoded_before_the_echo_is_dropped() {
        let facts = PortFacts {
            marked_errors: Some(LineError::Parity),
            local_echo: true,
            ..PortFacts::default()
        };
        let mut path = RxPath::new(&facts);
        let mut seen = Seen::default();
        let t = Instant::from_micros(100);
        path.sent(&[0x02, 0xFF], Instant::from_micros(1_000));
        // Our echo (FF doubled by the kernel), then the partner's DLE and a bad character.
        path.deliver(&mut seen, t, &[0x02, 0xFF], |_| {});
        path.deliver(&mut seen, t, &[0xFF, 0x10, 0xFF, 0x00, 0x41], |_| {});
        assert_eq!(seen.0, vec![Ok(0x10), Err(LineError::Parity)]);
    }

    #[test]
    fn a_plain_port_passes_bytes_unchanged() {
        let mut path = RxPath::new(&PortFacts::default());
        let mut seen = Seen::default();
        path.sent(&[1, 2], Instant::from_micros(1_000));
        path.deliver(&mut seen, Instant::from_micros(1), &[1, 2, 0xFF, 0], |_| {});
        assert_eq!(seen.0, vec![Ok(1), Ok(2), Ok(0xFF), Ok(0)]);
    }
}
