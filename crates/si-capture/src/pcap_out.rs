//! `--pcap FILE`: the monitor's frames as a pcapng capture for Wireshark.
//!
//! - **Interface 0, exported PDUs** (`LINKTYPE_WIRESHARK_UPPER_PDU`, 252): every record with
//!   bytes (a frame, block, telegram or control character, flagged or not: its raw bytes
//!   exactly) is one packet at its first character's time, naming the dissector
//!   ([`dissector`]: Wireshark's own `mbrtu` for Modbus RTU, `contrib/wireshark/si.lua` for
//!   ours) and its direction: sent for the first station, received for the second. The packet
//!   comment names the sending and the receiving station (`master → drive1`, `*` for everyone
//!   on a bus), so a bus of more stations reads back.
//! - **Interface 1, RTAC serial** (`LINKTYPE_RTAC_SERIAL`, 250): what is not a frame: a line
//!   error (framing, parity, BREAK, overrun) as its event with no payload, and a change of the
//!   modem lines as event 00 with the new DTR/RTS levels in the control-lines byte. We chose
//!   records over comments so a display filter (`rtacser.event_type`) finds them, and they keep
//!   their own time in the packet list.
//! - **The end of the recording** is an RTAC record with event 00 and the comment
//!   [`END_COMMENT`]: a trace ends when its recorder stopped, not at its last character, and
//!   the monitor judges the timers still running then (a slave that never answered).
//! - **The section comment** is the trace's header line (`si-trace` JSON: protocol, line
//!   settings, stations, wall-clock start), so `si monitor --from-pcap` decodes the capture as
//!   the trace was decoded.
//!
//! Times are the recording's wall-clock start plus the record's time; a trace without a
//! start (the simulator's virtual time) counts from 1970-01-01.

use crate::pcapng::Writer;
use crate::rtac;
use crate::upper_pdu::{self, Direction};
use si_core::monitor::{LineChar, Record};
use si_core::tracefile::Header;
use si_core::{Instant, LineError};
use std::collections::VecDeque;
use std::io::BufWriter;

/// The Wireshark dissector for a monitor protocol name (`si monitor --protocol`).
pub fn dissector(protocol: &str) -> &'static str {
    match protocol {
        "modbus" => "mbrtu",
        "3964r" | "3964" => "si_3964r",
        "rk512" => "si_rk512",
        "uss" => "si_uss",
        "dp-coord" => "si_dpcoord",
        // The ASCII driver's frames are the user's own bytes.
        _ => "data",
    }
}

/// The monitor protocol a dissector name stands for (the inverse of [`dissector`]).
pub fn protocol_of(dissector: &str) -> Option<&'static str> {
    Some(match dissector {
        "mbrtu" => "modbus",
        "si_3964r" => "3964r",
        "si_rk512" => "rk512",
        "si_uss" => "uss",
        "si_dpcoord" => "dp-coord",
        "data" => "ascii",
        _ => return None,
    })
}

/// A line error's RTAC event.
pub fn event_of(e: LineError) -> rtac::Event {
    match e {
        LineError::Framing => rtac::Event::Framing,
        LineError::Parity => rtac::Event::Parity,
        LineError::Break => rtac::Event::Break,
        LineError::Overrun => rtac::Event::Overflow,
    }
}

/// Microseconds since the Unix epoch of an RFC 3339 UTC time as trace headers write it
/// (`2026-11-25T16:18:25.123456Z`); `None` if it is not that shape.
pub fn epoch_micros(text: &str) -> Option<u64> {
    let num = |s: &str| s.parse::<u64>().ok();
    let (date, time) = text.strip_suffix('Z')?.split_once('T')?;
    let mut d = date.splitn(3, '-');
    let (y, m, day) = (num(d.next()?)?, num(d.next()?)?, num(d.next()?)?);
    let (hms, frac) = time.split_once('.').unwrap_or((time, "0"));
    let mut t = hms.splitn(3, ':');
    let (h, min, s) = (num(t.next()?)?, num(t.next()?)?, num(t.next()?)?);
    let digits = frac.len().min(6);
    let micros = num(&frac[..digits])? * 10u64.pow((6 - digits) as u32);
    // Howard Hinnant's days_from_civil, for dates from 1970 on.
    let (y, m) = if m <= 2 {
        (y.checked_sub(1)?, m + 9)
    } else {
        (y, m - 3)
    };
    let era = y / 400;
    let yoe = y - era * 400;
    let doy = (153 * m + 2) / 5 + day.checked_sub(1)?;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = (era * 146_097 + doe).checked_sub(719_468)?;
    Some(((days * 86_400 + h * 3600 + min * 60 + s) * 1_000_000) + micros)
}

/// The comment of the packet that marks the end of the recording.
pub const END_COMMENT: &str = "end of recording";

/// A packet's comment `from → to`: station names, `?` for an unknown sender, `*` for
/// everyone on a bus.
fn route(from: Option<usize>, to: Option<usize>, stations: &[String]) -> String {
    let name =
        |i: Option<usize>, none| i.and_then(|i| stations.get(i)).map_or(none, String::as_str);
    format!("{} → {}", name(from, "?"), name(to, "*"))
}

/// The capture being written.
pub struct PcapOut {
    w: Writer<BufWriter<std::fs::File>>,
    dissector: &'static str,
    origin: u64,
    /// Line errors not yet written: they go in before the first record that starts after
    /// them, so the capture stays in time order.
    errors: VecDeque<(Instant, Option<usize>, Option<usize>, LineError)>,
    scratch: Vec<u8>,
    path: std::path::PathBuf,
}

impl PcapOut {
    /// Create `path` for a line decoded as `protocol`, described by `header`.
    pub fn create(
        path: &std::path::Path,
        protocol: &str,
        header: &Header,
    ) -> std::io::Result<Self> {
        let file = std::fs::File::create(path)?;
        let comment = header.to_line();
        let mut w = Writer::new(
            BufWriter::new(file),
            concat!("si ", env!("CARGO_PKG_VERSION")),
            Some(&comment),
        )?;
        w.interface(upper_pdu::LINKTYPE, "line")?;
        w.interface(rtac::LINKTYPE, "line events")?;
        Ok(PcapOut {
            w,
            dissector: dissector(protocol),
            origin: header.start.as_deref().and_then(epoch_micros).unwrap_or(0),
            errors: VecDeque::new(),
            scratch: Vec::new(),
            path: path.to_owned(),
        })
    }

    /// The file being written (for error messages).
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }

    /// A character the monitor was fed: a line error becomes an RTAC record.
    pub fn char(&mut self, c: &LineChar) {
        if let Err(e) = c.item {
            self.errors.push_back((c.at, c.from, c.to, e));
        }
    }

    fn flush_errors(&mut self, until: Option<Instant>, stations: &[String]) -> std::io::Result<()> {
        while let Some(&(at, from, to, e)) = self.errors.front() {
            if until.is_some_and(|u| at > u) {
                break;
            }
            self.errors.pop_front();
            let header = rtac::Header {
                at_us: self.origin + at.as_micros(),
                event: event_of(e),
                lines: 0,
                footer: 0,
            };
            let comment = route(from, to, stations);
            self.w
                .packet(1, header.at_us, &header.bytes(), Some(&comment))?;
        }
        Ok(())
    }

    /// A record, in start order: a packet if it has bytes.
    pub fn record(&mut self, r: &Record, stations: &[String]) -> std::io::Result<()> {
        self.flush_errors(Some(r.start), stations)?;
        if r.bytes.is_empty() {
            return Ok(());
        }
        let direction = if r.from == Some(1) {
            Direction::Received
        } else {
            Direction::Sent
        };
        self.scratch.clear();
        upper_pdu::encode_into(&mut self.scratch, self.dissector, direction, &r.bytes);
        let comment = route(r.from, r.to, stations);
        self.w.packet(
            0,
            self.origin + r.start.as_micros(),
            &self.scratch,
            Some(&comment),
        )
    }

    /// A change of a station's modem lines (`lines`: [`rtac::lines`] bits).
    pub fn signals(
        &mut self,
        at: Instant,
        update: &si_core::SignalUpdate,
        station: &str,
    ) -> std::io::Result<()> {
        // The outputs a trace records, as RTAC's control-line bits: on when set, else off.
        let on = |set: Option<bool>, bit: u8| if set == Some(true) { bit } else { 0 };
        let lines = on(update.dtr, rtac::lines::DTR) | on(update.rts, rtac::lines::RTS);
        let header = rtac::Header {
            at_us: self.origin + at.as_micros(),
            event: rtac::Event::Other(0),
            lines,
            footer: 0,
        };
        self.w
            .packet(1, header.at_us, &header.bytes(), Some(station))
    }

    /// Write what is held, mark the recording's `end`, and close the file.
    pub fn finish(mut self, stations: &[String], end: Instant) -> std::io::Result<()> {
        self.flush_errors(None, stations)?;
        let header = rtac::Header {
            at_us: self.origin + end.as_micros(),
            event: rtac::Event::Other(0),
            lines: 0,
            footer: 0,
        };
        self.w
            .packet(1, header.at_us, &header.bytes(), Some(END_COMMENT))?;
        self.w.finish().map(drop)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_times_read_as_epoch_micros() {
        assert_eq!(epoch_micros("1970-01-01T00:00:00.000000Z"), Some(0));
        assert_eq!(
            epoch_micros("2026-11-25T16:18:25.123456Z"),
            Some(1_795_623_505_123_456)
        );
        assert_eq!(
            epoch_micros("2000-02-29T12:34:56.007Z"),
            Some(951_827_696_007_000)
        );
        assert_eq!(epoch_micros("yesterday"), None);
    }

    #[test]
    fn dissector_names_map_back() {
        for p in ["modbus", "3964r", "rk512", "uss", "dp-coord", "ascii"] {
            assert_eq!(protocol_of(dissector(p)), Some(p));
        }
    }
}
