//! A sigrok session file (`.sr`), as PulseView and `sigrok-cli -i` open it: logic channels
//! sampled at a fixed rate.
//!
//! The file is a zip (written STORED, [`crate::zip`]) holding, as libsigrok's srzip output
//! module writes them and its session file reader expects them:
//! - `version`: `2`;
//! - `metadata`: a key file with one section `[device 1]`: `capturefile=logic-1`,
//!   `total probes`, `samplerate` (`153600 Hz`, `3 MHz`), `total analog=0`, `probe1` … `probeN`
//!   (the channel names) and `unitsize` (bytes per sample: one bit per channel, channel 1 in
//!   bit 0 of the first byte);
//! - the samples in chunks `logic-1-1`, `logic-1-2`, … of at most [`CHUNK_SIZE`] bytes each
//!   (libsigrok's own chunk size, 4 MiB), the reader's chunk naming.
//!
//! Samples are filled between level changes ([`SrWriter::edge`]); only the current chunk is
//! held, so a capture of any length is written in 4 MiB of memory plus a few dozen bytes per
//! chunk. A stored zip is as large as its samples: an hour of line at 9600 bit/s (153 600
//! samples/s, one byte each) is about 550 MB.

use crate::uart_levels::Edge;
use crate::zip::ZipWriter;
use std::io::{self, Write};

/// Bytes of samples per `logic-1-N` entry: libsigrok's `CHUNK_SIZE` (4 MiB).
pub const CHUNK_SIZE: usize = 4 * 1024 * 1024;

/// The most channels a file can hold here (the sample is kept in a `u64`).
pub const MAX_CHANNELS: usize = 64;

/// libsigrok's spelling of a sample rate (`sr_samplerate_string`): the largest of GHz, MHz,
/// kHz that divides it, else Hz.
pub fn samplerate_string(rate: u64) -> String {
    for (unit, name) in [(1_000_000_000, "GHz"), (1_000_000, "MHz"), (1_000, "kHz")] {
        if rate >= unit && rate.is_multiple_of(unit) {
            return format!("{} {name}", rate / unit);
        }
    }
    format!("{rate} Hz")
}

/// A session file being written.
pub struct SrWriter<W: Write> {
    zip: ZipWriter<W>,
    unitsize: usize,
    /// The current chunk's samples.
    chunk: Vec<u8>,
    /// Number of the next chunk (`logic-1-N`).
    next_chunk: u32,
    /// Samples written so far (the next sample's index).
    cursor: u64,
    /// The levels from `cursor` on, channel k in bit k.
    levels: u64,
}

impl<W: Write> core::fmt::Debug for SrWriter<W> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SrWriter")
            .field("unitsize", &self.unitsize)
            .field("cursor", &self.cursor)
            .finish_non_exhaustive()
    }
}

impl<W: Write> SrWriter<W> {
    /// Start a file with these channel names (1 … [`MAX_CHANNELS`]), `rate` samples per second
    /// and the channels' levels at sample 0 (`initial[k]`: channel k; missing ones low).
    pub fn new(out: W, channels: &[String], rate: u64, initial: &[bool]) -> io::Result<Self> {
        if channels.is_empty() || channels.len() > MAX_CHANNELS {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "sigrok channels: 1 … {MAX_CHANNELS} allowed, {} given",
                    channels.len()
                ),
            ));
        }
        if rate == 0 {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "sigrok samplerate: 1 Hz or more allowed, 0 given",
            ));
        }
        let unitsize = channels.len().div_ceil(8);
        let mut zip = ZipWriter::new(out);
        zip.add("version", b"2")?;
        let mut meta = String::from("[device 1]\ncapturefile=logic-1\n");
        meta += &format!("total probes={}\n", channels.len());
        meta += &format!("samplerate={}\n", samplerate_string(rate));
        meta += "total analog=0\n";
        for (k, name) in channels.iter().enumerate() {
            // A key file value ends at the line's end: keep a name on its line.
            let name: String = name.chars().filter(|c| !c.is_control()).collect();
            meta += &format!("probe{}={name}\n", k + 1);
        }
        meta += &format!("unitsize={unitsize}\n");
        zip.add("metadata", meta.as_bytes())?;
        Ok(SrWriter {
            zip,
            unitsize,
            chunk: Vec::with_capacity(CHUNK_SIZE - CHUNK_SIZE % unitsize),
            next_chunk: 1,
            cursor: 0,
            levels: initial
                .iter()
                .take(MAX_CHANNELS)
                .enumerate()
                .fold(0, |m, (k, &high)| m | u64::from(high) << k),
        })
    }

    /// A level change. Edges must come in sample order; one before the samples already written
    /// takes effect at the next sample.
    pub fn edge(&mut self, e: Edge) -> io::Result<()> {
        self.fill_to(e.sample)?;
        if e.channel < 64 {
            let bit = 1u64 << e.channel;
            if e.high {
                self.levels |= bit;
            } else {
                self.levels &= !bit;
            }
        }
        Ok(())
    }

    /// Write the samples up to (not including) `end`, the last chunk and the zip's directory.
    pub fn finish(mut self, end: u64) -> io::Result<W> {
        self.fill_to(end)?;
        self.flush_chunk()?;
        self.zip.finish()
    }

    /// Samples written so far.
    pub fn samples(&self) -> u64 {
        self.cursor
    }

    fn fill_to(&mut self, sample: u64) -> io::Result<()> {
        let bytes = self.levels.to_le_bytes();
        let unit = &bytes[..self.unitsize];
        let per_chunk = CHUNK_SIZE / self.unitsize;
        while self.cursor < sample {
            let room = per_chunk - self.chunk.len() / self.unitsize;
            let n = (sample - self.cursor).min(room as u64) as usize;
            if self.unitsize == 1 {
                self.chunk.resize(self.chunk.len() + n, unit[0]);
            } else {
                for _ in 0..n {
                    self.chunk.extend_from_slice(unit);
                }
            }
            self.cursor += n as u64;
            if self.chunk.len() / self.unitsize == per_chunk {
                self.flush_chunk()?;
            }
        }
        Ok(())
    }

    fn flush_chunk(&mut self) -> io::Result<()> {
        if self.chunk.is_empty() {
            return Ok(());
        }
        let name = format!("logic-1-{}", self.next_chunk);
        self.zip.add(&name, &self.chunk)?;
        self.next_chunk += 1;
        self.chunk.clear();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samplerates_are_spelled_as_libsigrok_spells_them() {
        assert_eq!(samplerate_string(153_600), "153600 Hz");
        assert_eq!(samplerate_string(3_000_000), "3 MHz");
        assert_eq!(samplerate_string(307_200), "307200 Hz");
        assert_eq!(samplerate_string(48_000), "48 kHz");
    }

    /// The stored entries of a zip: (name, data), read from the local headers.
    fn entries(b: &[u8]) -> Vec<(String, Vec<u8>)> {
        let mut v = Vec::new();
        let mut i = 0;
        while b[i..i + 4] == [0x50, 0x4b, 3, 4] {
            let size = u32::from_le_bytes(b[i + 18..i + 22].try_into().unwrap()) as usize;
            let name_len = u16::from_le_bytes(b[i + 26..i + 28].try_into().unwrap()) as usize;
            let name = String::from_utf8(b[i + 30..i + 30 + name_len].to_vec()).unwrap();
            let data = b[i + 30 + name_len..i + 30 + name_len + size].to_vec();
            i += 30 + name_len + size;
            v.push((name, data));
        }
        v
    }

    #[test]
    fn metadata_and_samples_are_as_srzip_writes_them() {
        let names = vec!["A TxD".to_owned(), "B TxD".to_owned()];
        let mut w = SrWriter::new(Vec::new(), &names, 153_600, &[true, true]).unwrap();
        let e = |sample, channel, high| Edge {
            sample,
            channel,
            high,
        };
        w.edge(e(2, 0, false)).unwrap();
        w.edge(e(4, 1, false)).unwrap();
        w.edge(e(5, 0, true)).unwrap();
        let b = w.finish(7).unwrap();
        let files = entries(&b);
        assert_eq!(files[0], ("version".to_owned(), b"2".to_vec()));
        let meta = String::from_utf8(files[1].1.clone()).unwrap();
        assert_eq!(
            meta,
            "[device 1]\ncapturefile=logic-1\ntotal probes=2\nsamplerate=153600 Hz\n\
             total analog=0\nprobe1=A TxD\nprobe2=B TxD\nunitsize=1\n"
        );
        assert_eq!(files[2].0, "logic-1-1");
        assert_eq!(files[2].1, vec![3, 3, 2, 2, 0, 1, 1]);
    }

    #[test]
    fn long_captures_are_split_into_chunks_of_libsigroks_size() {
        let names = vec!["x".to_owned()];
        let w = SrWriter::new(Vec::new(), &names, 1000, &[true]).unwrap();
        let b = w.finish(CHUNK_SIZE as u64 * 2 + 10).unwrap();
        let files = entries(&b);
        let chunks: Vec<(&str, usize)> = files[2..]
            .iter()
            .map(|(n, d)| (n.as_str(), d.len()))
            .collect();
        assert_eq!(
            chunks,
            vec![
                ("logic-1-1", CHUNK_SIZE),
                ("logic-1-2", CHUNK_SIZE),
                ("logic-1-3", 10)
            ]
        );
    }

    #[test]
    fn channel_counts_out_of_range_are_refused_by_name() {
        let e = SrWriter::new(Vec::new(), &[], 1000, &[]).unwrap_err();
        assert!(e.to_string().contains("1 … 64 allowed, 0 given"), "{e}");
    }
}
