//! `--from-pcap FILE`: the characters of a capture, for the monitor, packet by packet.
//!
//! Three kinds of capture are read:
//! - **ours** (`--pcap`, `si trace export`): exported PDUs and RTAC line events, with the
//!   trace header in the section comment (protocol, settings, stations, start);
//! - **an RTAC serial capture** from another sniffer: each TX/RX event's payload is
//!   characters, TX from a station `tx`, RX from a station `rx`; line errors as they are;
//! - **a USER0 (147) capture** of Modbus RTU: each packet is one frame of unknown direction
//!   (the monitor sees a one-sided line, station `line`).
//!
//! A packet holds a frame, not its characters' times: the first character ends at the
//! packet's time and the others follow at the line's character time, so the monitor judges
//! the gaps between frames (the timers) but not inside them.

use crate::pcapng::{Block, ReadError, Reader};
use crate::{rtac, upper_pdu};
use si_core::monitor::ordered::Ordered;
use si_core::monitor::streamed::{Sink, StreamError};
use si_core::monitor::{Analysis, Decoder, LineChar};
use si_core::tracefile::Header;
use si_core::{Duration, Instant, LineError, SerialSettings};
use std::io::BufReader;

/// Link type of USER0 (DLT_USER0), what many serial sniffers use for raw frames.
pub const LINKTYPE_USER0: u16 = 147;

/// One packet: (interface, time in µs, bytes, comment).
pub type Packet = (u32, u64, Vec<u8>, Option<String>);

/// A capture opened for the monitor.
pub struct PcapIn {
    reader: Reader<BufReader<std::fs::File>>,
    /// The trace header from the section comment, if the capture is ours.
    pub header: Option<Header>,
    /// Link type of each interface of the section.
    linktypes: Vec<u16>,
    /// Station names; the characters' `from`/`to` index into it.
    pub stations: Vec<String>,
    /// The dissector named by the first exported PDU, if any.
    pub dissector: Option<String>,
    origin: Option<u64>,
    settings: SerialSettings,
    last: Instant,
    /// DP windows: a window's bytes are written at once, a microsecond apart.
    pub windows: bool,
    /// The end of the recording, if the capture marks it.
    pub end: Option<Instant>,
}

fn read_error(path: &std::path::Path, e: ReadError) -> String {
    format!("{}: {e}", path.display())
}

impl PcapIn {
    /// Open `path` and read up to its first packet (the header, the interfaces); that packet
    /// is handed back to be fed once the decoder is chosen.
    pub fn open(path: &std::path::Path) -> Result<(Self, Option<Packet>), String> {
        let file = std::fs::File::open(path)
            .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        let reader = Reader::new(BufReader::new(file)).map_err(|e| read_error(path, e))?;
        let mut me = PcapIn {
            reader,
            header: None,
            linktypes: Vec::new(),
            stations: Vec::new(),
            dissector: None,
            origin: None,
            settings: SerialSettings::default(),
            last: Instant::ZERO,
            windows: false,
            end: None,
        };
        // The first packet, kept for the caller to feed after it chose the decoder.
        loop {
            match me.reader.next_block().map_err(|e| read_error(path, e))? {
                None => return Ok((me, None)),
                Some(Block::Section { comment }) => {
                    me.linktypes.clear();
                    me.header = comment.and_then(|c| Header::from_line(&c));
                    if let Some(h) = &me.header {
                        me.stations = h.stations.clone();
                        me.origin = h
                            .start
                            .as_deref()
                            .and_then(crate::pcap_out::epoch_micros)
                            .or(Some(0));
                    }
                }
                Some(Block::Interface { linktype, .. }) => me.linktypes.push(linktype),
                Some(Block::Packet {
                    interface,
                    at_us,
                    data,
                    comment,
                }) => {
                    let data = data.to_vec();
                    if me.linktypes.get(interface as usize) == Some(&upper_pdu::LINKTYPE) {
                        if let Ok(p) = upper_pdu::decode(&data) {
                            me.dissector = p.dissector.map(str::to_owned);
                        }
                    }
                    return Ok((me, Some((interface, at_us, data, comment))));
                }
            }
        }
    }

    /// The line's character format (for the character time between a frame's characters).
    pub fn set_settings(&mut self, settings: SerialSettings) {
        self.settings = settings;
    }

    /// The link type of the first interface (what kind of capture it is).
    pub fn first_linktype(&self) -> Option<u16> {
        self.linktypes.first().copied()
    }

    /// Sender and receiver from a packet comment `from → to` (`?` unknown, `*` everyone).
    #[allow(clippy::type_complexity)]
    fn route(&mut self, comment: Option<&str>) -> Option<(Option<usize>, Option<usize>)> {
        let (from, to) = comment?.split_once(" → ")?;
        let mut index = |name: &str| (name != "?" && name != "*").then(|| self.station(name));
        Some((index(from), index(to)))
    }

    fn station(&mut self, name: &str) -> usize {
        match self.stations.iter().position(|s| s == name) {
            Some(i) => i,
            None => {
                self.stations.push(name.to_owned());
                self.stations.len() - 1
            }
        }
    }

    /// The characters of one packet.
    pub fn chars(
        &mut self,
        interface: u32,
        at_us: u64,
        data: &[u8],
        comment: Option<&str>,
        out: &mut Vec<LineChar>,
    ) {
        let origin = *self.origin.get_or_insert(at_us);
        let at = Instant::from_micros(at_us.saturating_sub(origin));
        let linktype = self.linktypes.get(interface as usize).copied();
        let mut to = None;
        let (from, payload): (Option<usize>, &[u8]) = match linktype {
            Some(upper_pdu::LINKTYPE) => {
                let Ok(p) = upper_pdu::decode(data) else {
                    return;
                };
                let from = match self.route(comment) {
                    Some((from, receiver)) => {
                        to = Some(receiver);
                        from
                    }
                    _ => Some({
                        let name = match p.direction {
                            Some(upper_pdu::Direction::Received) => "B",
                            _ => "A",
                        };
                        let k = usize::from(p.direction == Some(upper_pdu::Direction::Received));
                        if k < self.stations.len() {
                            k
                        } else {
                            self.station(name)
                        }
                    }),
                };
                (from, p.payload)
            }
            Some(rtac::LINKTYPE) => {
                let Some((h, payload)) = rtac::Header::parse(data) else {
                    return;
                };
                if comment == Some(crate::pcap_out::END_COMMENT) {
                    self.end = Some(at);
                    return;
                }
                let error = match h.event {
                    rtac::Event::Framing => Some(LineError::Framing),
                    rtac::Event::Parity => Some(LineError::Parity),
                    rtac::Event::Break => Some(LineError::Break),
                    rtac::Event::Overflow => Some(LineError::Overrun),
                    _ => None,
                };
                let (from, receiver) = match (self.route(comment), h.event) {
                    (Some(route), _) => route,
                    (_, rtac::Event::TxStart | rtac::Event::TxEnd) => {
                        (Some(self.station("tx")), None)
                    }
                    (_, rtac::Event::RxStart | rtac::Event::RxEnd) => {
                        (Some(self.station("rx")), None)
                    }
                    _ => (None, None),
                };
                if let Some(e) = error {
                    self.emit(at, from, Some(receiver), Err(e), true, out);
                    return;
                }
                (from, payload)
            }
            Some(LINKTYPE_USER0) => (Some(self.station("line")), data),
            _ => return,
        };
        for (k, &b) in payload.iter().enumerate() {
            // Counted from the frame's start as a transmitter paces it (`chars_time` of k + 1
            // characters less the first's), not k rounded character times: 15 rounded times
            // can shorten the silence after a frame by the microseconds a start interval is
            // judged by.
            let t = if self.windows {
                at + Duration::from_micros(k as u64)
            } else {
                let since_start = self.settings.chars_time(k as u64 + 1);
                at + Duration::from_micros(
                    since_start.as_micros() - self.settings.chars_time(1).as_micros(),
                )
            };
            let exact = !self.windows || k == 0;
            self.emit(t, from, to, Ok(b), exact, out);
        }
    }

    fn emit(
        &mut self,
        at: Instant,
        from: Option<usize>,
        to: Option<Option<usize>>,
        item: Result<u8, LineError>,
        exact: bool,
        out: &mut Vec<LineChar>,
    ) {
        let at = at.max(self.last);
        self.last = at;
        // The packet comment names the receiver; without it, point to point is assumed.
        let to = to.unwrap_or(match (from, self.stations.len()) {
            (Some(f), 2) if f < 2 => Some(1 - f),
            _ => None,
        });
        out.push(LineChar {
            at,
            from,
            to,
            item,
            exact,
        });
    }

    /// The next packet: (interface, time, bytes, comment); `None` at the end.
    pub fn next_packet(&mut self) -> Result<Option<Packet>, String> {
        loop {
            match self.reader.next_block().map_err(|e| e.to_string())? {
                None => return Ok(None),
                Some(Block::Section { .. }) => self.linktypes.clear(),
                Some(Block::Interface { linktype, .. }) => self.linktypes.push(linktype),
                Some(Block::Packet {
                    interface,
                    at_us,
                    data,
                    comment,
                }) => return Ok(Some((interface, at_us, data.to_vec(), comment))),
            }
        }
    }
}

impl PcapIn {
    /// Decode the capture from `first` (what [`open`](Self::open) handed back) on with
    /// `decoder` (named `protocol` in the analysis), packet by packet, handing every character
    /// and record to `sink`. The analysis holds the counters and span, not the records.
    pub fn run<S: Sink>(
        mut self,
        first: Option<Packet>,
        decoder: Box<dyn Decoder + Send>,
        protocol: &str,
        sink: &mut S,
    ) -> Result<Analysis, StreamError<S::Error, String>> {
        let mut decoding = Ordered::new(decoder);
        let mut chars = Vec::new();
        let mut packet = first;
        let mut end = Instant::ZERO;
        while let Some((iface, at, data, comment)) = packet {
            self.chars(iface, at, &data, comment.as_deref(), &mut chars);
            for c in chars.drain(..) {
                end = end.max(c.at);
                sink.char(&c);
                decoding
                    .push(&c, &mut |r| sink.record(r, &self.stations))
                    .map_err(StreamError::Sink)?;
            }
            packet = self.next_packet().map_err(StreamError::Read)?;
        }
        let end = self.end.unwrap_or(end).max(end);
        decoding
            .finish(end, &mut |r| sink.record(r, &self.stations))
            .map_err(StreamError::Sink)?;
        Ok(Analysis {
            protocol: protocol.to_owned(),
            stations: self.stations,
            records: Vec::new(),
            counters: decoding.decoder.counters().clone(),
            span: (decoding.first.unwrap_or_default(), end),
        })
    }
}
