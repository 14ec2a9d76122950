//! A Value Change Dump (IEEE 1364 §18, the VCD four-state format) of scalar signals, as
//! GTKWave opens it: the same levels as the sigrok file, written as value changes only.
//!
//! The timescale is 1 ns; a sample index is converted to the nearest nanosecond, so a bit at
//! 9600 bit/s lasts 104 166 or 104 167 ns and the edges keep their real timing.

use crate::uart_levels::Edge;
use std::io::{self, Write};

/// A VCD being written.
pub struct VcdWriter<W: Write> {
    out: W,
    rate: u64,
    /// Time (ns) of the last `#` line written.
    time: Option<u64>,
    codes: Vec<String>,
}

impl<W: Write> core::fmt::Debug for VcdWriter<W> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("VcdWriter")
            .field("rate", &self.rate)
            .field("time", &self.time)
            .finish_non_exhaustive()
    }
}

/// The identifier code of signal `k`: printable ASCII from `!` on, base 94, as VCD allows.
fn code(mut k: usize) -> String {
    let mut s = String::new();
    loop {
        s.push(char::from(b'!' + (k % 94) as u8));
        k /= 94;
        if k == 0 {
            return s;
        }
        k -= 1;
    }
}

/// A VCD reference name: no white space (it would end the name).
fn reference(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect()
}

impl<W: Write> VcdWriter<W> {
    /// Start a dump of these signals, sampled at `rate` per second, with their levels at time 0
    /// (`initial[k]`: signal k; missing ones low). `module` names the scope.
    pub fn new(
        mut out: W,
        module: &str,
        signals: &[String],
        rate: u64,
        initial: &[bool],
    ) -> io::Result<Self> {
        if rate == 0 {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "vcd sample rate: 1 Hz or more allowed, 0 given",
            ));
        }
        let codes: Vec<String> = (0..signals.len()).map(code).collect();
        writeln!(out, "$comment si trace export $end")?;
        writeln!(out, "$timescale 1 ns $end")?;
        writeln!(out, "$scope module {} $end", reference(module))?;
        for (name, code) in signals.iter().zip(&codes) {
            writeln!(out, "$var wire 1 {code} {} $end", reference(name))?;
        }
        writeln!(out, "$upscope $end")?;
        writeln!(out, "$enddefinitions $end")?;
        writeln!(out, "#0")?;
        writeln!(out, "$dumpvars")?;
        for (k, code) in codes.iter().enumerate() {
            let high = initial.get(k).copied().unwrap_or(false);
            writeln!(out, "{}{code}", u8::from(high))?;
        }
        writeln!(out, "$end")?;
        Ok(VcdWriter {
            out,
            rate,
            time: Some(0),
            codes,
        })
    }

    /// The time in ns of sample `sample`, rounded to the nearest.
    pub fn nanos(&self, sample: u64) -> u64 {
        let ns = (u128::from(sample) * 1_000_000_000 + u128::from(self.rate / 2))
            / u128::from(self.rate);
        u64::try_from(ns).unwrap_or(u64::MAX)
    }

    /// A level change; edges come in sample order. An unknown channel is ignored.
    pub fn edge(&mut self, e: Edge) -> io::Result<()> {
        let Some(code) = self.codes.get(e.channel) else {
            return Ok(());
        };
        let t = self.nanos(e.sample);
        if self.time.is_none_or(|last| t > last) {
            writeln!(self.out, "#{t}")?;
            self.time = Some(t);
        }
        writeln!(self.out, "{}{code}", u8::from(e.high))
    }

    /// End the dump at sample `end` (a final time stamp, so viewers show the quiet line after
    /// the last edge); returns the writer, flushed.
    pub fn finish(mut self, end: u64) -> io::Result<W> {
        let t = self.nanos(end);
        if self.time.is_none_or(|last| t > last) {
            writeln!(self.out, "#{t}")?;
        }
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_distinct_printable_identifiers() {
        assert_eq!(code(0), "!");
        assert_eq!(code(93), "~");
        assert_eq!(code(94), "!!");
        let all: std::collections::HashSet<String> = (0..10_000).map(code).collect();
        assert_eq!(all.len(), 10_000);
    }

    #[test]
    fn value_changes_are_written_at_their_nanosecond() {
        let names = vec!["A TxD".to_owned(), "B RTS".to_owned()];
        let mut w = VcdWriter::new(Vec::new(), "line", &names, 153_600, &[true, false]).unwrap();
        w.edge(Edge {
            sample: 16,
            channel: 0,
            high: false,
        })
        .unwrap();
        w.edge(Edge {
            sample: 16,
            channel: 1,
            high: true,
        })
        .unwrap();
        let text = String::from_utf8(w.finish(32).unwrap()).unwrap();
        assert!(text.contains("$var wire 1 ! A_TxD $end"), "{text}");
        assert!(text.contains("$dumpvars\n1!\n0\"\n$end\n"), "{text}");
        // 16 samples at 153 600 Hz: 104 166.67 ns, rounded to 104 167.
        assert!(text.ends_with("#104167\n0!\n1\"\n#208333\n"), "{text}");
    }
}
