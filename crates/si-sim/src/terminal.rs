//! A raw terminal station: it transmits what it is told and reports every character and line
//! error it hears, with no protocol. What the simulator's own demonstrations use (`si sim
//! line-timing`, `rs485-collision`): the line's timing and collisions without an engine's
//! reading of them.

use si_core::{Engine, Instant, LineError, Output};
use std::collections::VecDeque;

/// A station that reports what it hears: `Ok(byte)` per character, `Err` per line error.
#[derive(Debug, Default)]
pub struct Terminal {
    events: VecDeque<Result<u8, LineError>>,
}

impl Engine for Terminal {
    type Event = Result<u8, LineError>;
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        self.events.extend(bytes.iter().map(|&b| Ok(b)));
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn handle_line_error(&mut self, _: Instant, error: LineError) {
        self.events.push_back(Err(error));
    }
    fn poll_output(&mut self) -> Output<Self::Event> {
        match self.events.pop_front() {
            Some(e) => Output::Event(e),
            None => Output::Wait(None),
        }
    }
}
