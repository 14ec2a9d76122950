//! A trace file decoded record by record, for traces of any length: the entries become line
//! characters ([`LineStream`]), the characters go to a decoder whose records come out in start
//! order ([`Ordered`]), and every character, modem line change and record goes to a [`Sink`]
//! as it is decoded. Memory holds a minute of line and the longest trace line, not the file:
//! what `si monitor --trace` and `si trace export` run on.
//!
//! The first [`LOOKAHEAD`] entries are read before anything is decoded: they decide the kind of
//! line (see [`LineStream`]) and, for a recording that names no protocol, let the caller choose
//! the decoder from a [`Probe`] of them (with [`best_fit`](super::best_fit)).

use crate::monitor::line_stream::{LineStream, LOOKAHEAD};
use crate::monitor::ordered::Ordered;
use crate::monitor::{Analysis, Decoder, Kind, LineChar, Record};
use crate::trace::{TraceEntry, TraceKind};
use crate::tracefile::{Header, Item, Stream, TraceFileError};
use crate::{Instant, SerialSettings, SignalUpdate};
use std::io::BufRead;

/// Where a streamed analysis sends what it decoded (the printer, a diagram, a capture).
pub trait Sink {
    /// What a sink's own failure is (a capture that cannot be written).
    type Error;
    /// A character as the decoder is fed it.
    fn char(&mut self, c: &LineChar);
    /// A change of `station`'s modem lines at `at`.
    fn signals(
        &mut self,
        at: Instant,
        update: &SignalUpdate,
        station: &str,
    ) -> Result<(), Self::Error>;
    /// A decoded record, in start order; `stations` are the lanes its indices name.
    fn record(&mut self, r: Record, stations: &[String]) -> Result<(), Self::Error>;
}

/// Why a streamed analysis stopped: its input (`R`, a trace file's error by default, or a
/// capture's) or its sink (`E`).
#[derive(Debug)]
pub enum StreamError<E, R = TraceFileError> {
    /// The input is unreadable.
    Read(R),
    /// The sink failed.
    Sink(E),
}

/// The first entries' line: what the caller chooses a decoder by.
#[derive(Debug, Clone)]
pub struct Probe {
    /// Their characters.
    pub chars: Vec<LineChar>,
    /// The last instant they reach.
    pub end: Instant,
    /// The stations named so far.
    pub stations: Vec<String>,
}

/// A trace file opened for a streamed analysis: its header and first entries read.
#[derive(Debug)]
pub struct TraceStream<R: BufRead> {
    stream: Stream<R>,
    header: Option<Header>,
    prefix: Vec<TraceEntry>,
    more: bool,
}

impl<R: BufRead> TraceStream<R> {
    /// Read the header (if any) and the first [`LOOKAHEAD`] entries of `input`.
    pub fn open(input: R) -> Result<Self, TraceFileError> {
        let mut stream = Stream::new(input);
        let mut header = None;
        let mut prefix = Vec::new();
        let mut more = true;
        while prefix.len() < LOOKAHEAD {
            match stream.next_item()? {
                Some(Item::Header(h)) => header = Some(h),
                Some(Item::Entry(e)) => prefix.push(e),
                None => {
                    more = false;
                    break;
                }
            }
        }
        Ok(TraceStream {
            stream,
            header,
            prefix,
            more,
        })
    }

    /// The trace's header, if it has one.
    pub fn header(&self) -> Option<&Header> {
        self.header.as_ref()
    }

    /// The header, the first entries, and the stream of the rest (`None` when the first
    /// entries were the whole trace): for a reader that feeds the line its own way (si-capture's
    /// waveforms).
    pub fn into_parts(self) -> (Option<Header>, Vec<TraceEntry>, Option<Stream<R>>) {
        (self.header, self.prefix, self.more.then_some(self.stream))
    }

    /// The line of the first entries at `settings` (`windows`: a trace of DP windows).
    pub fn probe(&self, settings: SerialSettings, windows: bool) -> Probe {
        let mut line = LineStream::plan(self.header.as_ref(), &self.prefix, settings, windows);
        let mut chars = Vec::new();
        for e in &self.prefix {
            line.push(e, &mut chars);
        }
        line.finish(&mut chars);
        Probe {
            end: line.end.max(chars.last().map(|c| c.at).unwrap_or_default()),
            stations: line.stations().to_vec(),
            chars,
        }
    }

    /// Decode the whole trace with `decoder` (named `protocol` in the analysis), handing every
    /// character, modem line change and record to `sink`; with `events`, the engines' event
    /// entries become [`Kind::Event`] records. The analysis holds the counters and span, not
    /// the records (the sink had them).
    pub fn run<S: Sink>(
        self,
        (settings, windows): (SerialSettings, bool),
        decoder: Box<dyn Decoder + Send>,
        (protocol, events): (&str, bool),
        sink: &mut S,
    ) -> Result<Analysis, StreamError<S::Error>> {
        let TraceStream {
            mut stream,
            header,
            prefix,
            mut more,
        } = self;
        let mut decoding = Ordered::new(decoder);
        let mut line = LineStream::plan(header.as_ref(), &prefix, settings, windows);
        let mut stations = line.stations().to_vec();
        let mut chars = Vec::new();
        let mut feed = |e: &TraceEntry,
                        line: &mut LineStream,
                        decoding: &mut Ordered,
                        stations: &mut Vec<String>|
         -> Result<(), S::Error> {
            line.push(e, &mut chars);
            if line.stations().len() != stations.len() {
                *stations = line.stations().to_vec();
            }
            if let TraceKind::Signals { update } = &e.kind {
                sink.signals(e.at, update, &e.station)?;
            }
            for c in chars.drain(..) {
                sink.char(&c);
                decoding.push(&c, &mut |r| sink.record(r, stations))?;
            }
            if let (true, TraceKind::Event { text }) = (events, &e.kind) {
                let from = stations.iter().position(|s| s == &e.station);
                let mut r = Record::new(Kind::Event, e.at, e.at, from);
                r.label = text.clone();
                decoding.event(r);
            }
            Ok(())
        };
        for e in &prefix {
            feed(e, &mut line, &mut decoding, &mut stations).map_err(StreamError::Sink)?;
        }
        drop(prefix);
        while more {
            match stream.next_item().map_err(StreamError::Read)? {
                Some(Item::Entry(e)) => {
                    feed(&e, &mut line, &mut decoding, &mut stations).map_err(StreamError::Sink)?
                }
                Some(Item::Header(_)) => {}
                None => more = false,
            }
        }
        let mut rest = Vec::new();
        line.finish(&mut rest);
        stations = line.stations().to_vec();
        for c in &rest {
            sink.char(c);
            decoding
                .push(c, &mut |r| sink.record(r, &stations))
                .map_err(StreamError::Sink)?;
        }
        let end = line.end.max(decoding.last);
        decoding
            .finish(end, &mut |r| sink.record(r, &stations))
            .map_err(StreamError::Sink)?;
        Ok(Analysis {
            protocol: protocol.to_owned(),
            stations,
            records: Vec::new(),
            counters: decoding.decoder.counters().clone(),
            span: (decoding.first.unwrap_or_default(), end),
        })
    }
}
