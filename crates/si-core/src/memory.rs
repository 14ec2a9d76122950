//! The SIMATIC memory model: data blocks (DB), bit memory (M), inputs (I), outputs (Q),
//! timers (T) and counters (C) of an S7 CPU, for the protocols that read and write PLC memory
//! by area and address (the Modbus slave through S_MODB, [Modbus/USS] §3.5.3–§3.5.17, Table 3-19;
//! the RK 512 passive side).
//!
//! Byte areas (I, Q, M, DB) are byte-addressed; a WORD is two bytes, high byte first (S7
//! order). Timers and counters are 16-bit words addressed by number. Every access is checked
//! against the configured sizes and reports which limit it crossed, so callers can map it to
//! their manual's error (S_MODB ERROR_NR 14–17, 20, 21).

use crate::range::RangeError;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A memory area.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Area {
    /// Process-image inputs, `I` (German `E`).
    Inputs,
    /// Process-image outputs, `Q` (German `A`).
    Outputs,
    /// Bit memory, `M` (flags, `F` in some translations).
    Flags,
    /// Timers, one word each.
    Timers,
    /// Counters, one word each.
    Counters,
    /// A data block by number.
    Db(u16),
}

impl core::fmt::Display for Area {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Area::Inputs => f.write_str("I"),
            Area::Outputs => f.write_str("Q"),
            Area::Flags => f.write_str("M"),
            Area::Timers => f.write_str("T"),
            Area::Counters => f.write_str("C"),
            Area::Db(n) => write!(f, "DB{n}"),
        }
    }
}

/// Sizes of a simulated CPU's areas.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MemorySizes {
    /// Input bytes (IB0 … IB n−1).
    pub inputs: u32,
    /// Output bytes.
    pub outputs: u32,
    /// Bit-memory bytes.
    pub flags: u32,
    /// Number of timers.
    pub timers: u32,
    /// Number of counters.
    pub counters: u32,
    /// Data blocks: number → length in bytes.
    pub dbs: BTreeMap<u16, u32>,
}

impl Default for MemorySizes {
    /// A mid-range CPU: IB0–IB127, QB0–QB127, MB0–MB2047, T0–T255, C0–C255, no DBs.
    fn default() -> Self {
        MemorySizes {
            inputs: 128,
            outputs: 128,
            flags: 2048,
            timers: 256,
            counters: 256,
            dbs: BTreeMap::new(),
        }
    }
}

/// Largest I, Q or M area, in bytes: the conversion DB addresses bytes by WORD (uuuuu, ooooo,
/// vvvvv, sssss are 0…65535, [Modbus/USS] §3.5.3, Table 3-19 "Value ranges"), so bytes 0…65535
/// are all a module can reach. Area sizes otherwise "depend on the CPU type"
/// ([ET200S SI 2005] §3.6.17, §3.6.20); more than the module addresses would only be
/// memory no request reaches.
pub const MAX_AREA_BYTES: u32 = 65_536;

/// Most timers or counters: their numbers (ttttt, zzzzz) are WORDs 0…65535 as well ([Modbus/USS]
/// §3.5.3, Table 3-19).
pub const MAX_ELEMENTS: u32 = 65_536;

/// Largest data block, in bytes. Our reading (the manuals give no DB size): an S7 byte offset
/// is a WORD, DBB0…DBB65535; the S_MODB conversion itself reaches only DBW0…DBW1022 of each
/// DB ([Modbus/USS] §3.5.5–§3.5.19, `(R & 1FFH) × 2`).
pub const MAX_DB_BYTES: u32 = 65_536;

/// Most memory in all areas together, in bytes (timers and counters count two bytes each): a
/// host limit, not the manual's, so a configuration of many large DBs cannot exhaust the host.
/// 16 MiB holds 256 full-size DBs, or every DB S_MODB can address from one base DB at 1 KiB.
pub const MAX_TOTAL_BYTES: u64 = 16 * 1024 * 1024;

impl MemorySizes {
    /// Check every size against [`MAX_AREA_BYTES`], [`MAX_ELEMENTS`], [`MAX_DB_BYTES`] and
    /// [`MAX_TOTAL_BYTES`] without allocating anything: the first size out of range.
    pub fn check(&self) -> Result<(), RangeError> {
        for (parameter, value) in [
            ("memory.inputs", self.inputs),
            ("memory.outputs", self.outputs),
            ("memory.flags", self.flags),
        ] {
            RangeError::check(parameter, (0, MAX_AREA_BYTES), " bytes", value)?;
        }
        RangeError::check("memory.timers", (0, MAX_ELEMENTS), "", self.timers)?;
        RangeError::check("memory.counters", (0, MAX_ELEMENTS), "", self.counters)?;
        for (&n, &len) in &self.dbs {
            if len > MAX_DB_BYTES {
                let range = format!("0 … {MAX_DB_BYTES} bytes (DB{n})");
                return Err(RangeError::new("DB length", range, " bytes", len));
            }
        }
        let total = self.total_bytes();
        RangeError::check("memory in all areas", (0, MAX_TOTAL_BYTES), " bytes", total)
    }

    /// Bytes these sizes take (timers and counters two each).
    pub fn total_bytes(&self) -> u64 {
        let bytes = u64::from(self.inputs) + u64::from(self.outputs) + u64::from(self.flags);
        let words = 2 * (u64::from(self.timers) + u64::from(self.counters));
        let dbs: u64 = self.dbs.values().map(|&l| u64::from(l)).sum();
        bytes + words + dbs
    }
}

/// An access the CPU would refuse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MemoryError {
    /// Beyond the end of an area: `end` is the first element past the access, `size` the
    /// area's size (bytes, or timers/counters).
    #[error("{area}: access up to {end} beyond the area size {size}")]
    OutOfRange {
        /// The area.
        area: Area,
        /// One past the last element accessed.
        end: u64,
        /// The area's size.
        size: u32,
    },
    /// The data block does not exist.
    #[error("DB{0} does not exist")]
    NoSuchDb(u16),
}

/// The memory of a simulated CPU.
#[derive(Debug, PartialEq, Eq)]
pub struct Memory {
    inputs: Vec<u8>,
    outputs: Vec<u8>,
    flags: Vec<u8>,
    timers: Vec<u16>,
    counters: Vec<u16>,
    dbs: BTreeMap<u16, Vec<u8>>,
}

impl Clone for Memory {
    fn clone(&self) -> Self {
        Memory {
            inputs: self.inputs.clone(),
            outputs: self.outputs.clone(),
            flags: self.flags.clone(),
            timers: self.timers.clone(),
            counters: self.counters.clone(),
            dbs: self.dbs.clone(),
        }
    }

    /// Copy `source` into this memory, reusing its buffers: no allocation when the two have
    /// the same areas and data blocks (a memory kept as a copy of another, updated after each
    /// change).
    fn clone_from(&mut self, source: &Self) {
        self.inputs.clone_from(&source.inputs);
        self.outputs.clone_from(&source.outputs);
        self.flags.clone_from(&source.flags);
        self.timers.clone_from(&source.timers);
        self.counters.clone_from(&source.counters);
        if self.dbs.keys().eq(source.dbs.keys()) {
            for (mine, theirs) in self.dbs.values_mut().zip(source.dbs.values()) {
                mine.clone_from(theirs);
            }
        } else {
            self.dbs.clone_from(&source.dbs);
        }
    }
}

impl Memory {
    /// Zeroed memory of these sizes, after [`MemorySizes::check`]: a size beyond its maximum
    /// is refused before anything is allocated.
    pub fn checked(sizes: &MemorySizes) -> Result<Self, RangeError> {
        sizes.check()?;
        Ok(Memory::new(sizes))
    }

    /// Zeroed memory of these sizes, unchecked: for sizes the program chose. Sizes from a user
    /// go through [`Memory::checked`].
    pub fn new(sizes: &MemorySizes) -> Self {
        Memory {
            inputs: vec![0; sizes.inputs as usize],
            outputs: vec![0; sizes.outputs as usize],
            flags: vec![0; sizes.flags as usize],
            timers: vec![0; sizes.timers as usize],
            counters: vec![0; sizes.counters as usize],
            dbs: sizes
                .dbs
                .iter()
                .map(|(&n, &len)| (n, vec![0; len as usize]))
                .collect(),
        }
    }

    /// Create (or resize) data block `n` with `len` zero bytes.
    pub fn add_db(&mut self, n: u16, len: u32) {
        self.dbs.insert(n, vec![0; len as usize]);
    }

    /// The bytes of a byte area (I, Q, M, DB).
    pub fn bytes(&self, area: Area) -> Result<&[u8], MemoryError> {
        match area {
            Area::Inputs => Ok(&self.inputs),
            Area::Outputs => Ok(&self.outputs),
            Area::Flags => Ok(&self.flags),
            Area::Db(n) => self
                .dbs
                .get(&n)
                .map(Vec::as_slice)
                .ok_or(MemoryError::NoSuchDb(n)),
            Area::Timers | Area::Counters => Err(MemoryError::OutOfRange {
                area,
                end: 0,
                size: 0,
            }),
        }
    }

    fn bytes_mut(&mut self, area: Area) -> Result<&mut [u8], MemoryError> {
        match area {
            Area::Inputs => Ok(&mut self.inputs),
            Area::Outputs => Ok(&mut self.outputs),
            Area::Flags => Ok(&mut self.flags),
            Area::Db(n) => self
                .dbs
                .get_mut(&n)
                .map(Vec::as_mut_slice)
                .ok_or(MemoryError::NoSuchDb(n)),
            Area::Timers | Area::Counters => Err(MemoryError::OutOfRange {
                area,
                end: 0,
                size: 0,
            }),
        }
    }

    fn words(&self, area: Area) -> Option<&[u16]> {
        match area {
            Area::Timers => Some(&self.timers),
            Area::Counters => Some(&self.counters),
            _ => None,
        }
    }

    fn words_mut(&mut self, area: Area) -> Option<&mut [u16]> {
        match area {
            Area::Timers => Some(&mut self.timers),
            Area::Counters => Some(&mut self.counters),
            _ => None,
        }
    }

    fn range(
        area: Area,
        start: u32,
        len: usize,
        size: usize,
    ) -> Result<core::ops::Range<usize>, MemoryError> {
        let end = start as u64 + len as u64;
        if end > size as u64 {
            return Err(MemoryError::OutOfRange {
                area,
                end,
                size: size as u32,
            });
        }
        Ok(start as usize..end as usize)
    }

    /// Copy bytes from `start` of a byte area into `out`.
    pub fn read(&self, area: Area, start: u32, out: &mut [u8]) -> Result<(), MemoryError> {
        let bytes = self.bytes(area)?;
        let r = Self::range(area, start, out.len(), bytes.len())?;
        out.copy_from_slice(&bytes[r]);
        Ok(())
    }

    /// Write `data` at `start` of a byte area.
    pub fn write(&mut self, area: Area, start: u32, data: &[u8]) -> Result<(), MemoryError> {
        let bytes = self.bytes_mut(area)?;
        let r = Self::range(area, start, data.len(), bytes.len())?;
        bytes[r].copy_from_slice(data);
        Ok(())
    }

    /// Bit `bit` (0–7) of byte `byte`, e.g. M1004.1.
    pub fn bit(&self, area: Area, byte: u32, bit: u8) -> Result<bool, MemoryError> {
        let mut b = [0];
        self.read(area, byte, &mut b)?;
        Ok(b[0] & (1 << (bit & 7)) != 0)
    }

    /// Set or clear one bit.
    pub fn set_bit(
        &mut self,
        area: Area,
        byte: u32,
        bit: u8,
        value: bool,
    ) -> Result<(), MemoryError> {
        let bytes = self.bytes_mut(area)?;
        let r = Self::range(area, byte, 1, bytes.len())?;
        let b = &mut bytes[r.start];
        if value {
            *b |= 1 << (bit & 7);
        } else {
            *b &= !(1 << (bit & 7));
        }
        Ok(())
    }

    /// The WORD at byte `start` of a byte area (high byte first), e.g. DB6.DBW4.
    pub fn word(&self, area: Area, start: u32) -> Result<u16, MemoryError> {
        let mut w = [0; 2];
        self.read(area, start, &mut w)?;
        Ok(u16::from_be_bytes(w))
    }

    /// Write the WORD at byte `start`.
    pub fn set_word(&mut self, area: Area, start: u32, value: u16) -> Result<(), MemoryError> {
        self.write(area, start, &value.to_be_bytes())
    }

    /// Timer or counter `n`'s word.
    pub fn element(&self, area: Area, n: u32) -> Result<u16, MemoryError> {
        let words = self.words(area).ok_or(MemoryError::OutOfRange {
            area,
            end: 0,
            size: 0,
        })?;
        let r = Self::range(area, n, 1, words.len())?;
        Ok(words[r.start])
    }

    /// Set timer or counter `n`'s word.
    pub fn set_element(&mut self, area: Area, n: u32, value: u16) -> Result<(), MemoryError> {
        let words = self.words_mut(area).ok_or(MemoryError::OutOfRange {
            area,
            end: 0,
            size: 0,
        })?;
        let r = Self::range(area, n, 1, words.len())?;
        words[r.start] = value;
        Ok(())
    }

    /// Check that `count` timers or counters from `n` exist.
    pub fn check_elements(&self, area: Area, n: u32, count: u32) -> Result<(), MemoryError> {
        let size = self.words(area).map_or(0, <[u16]>::len);
        Self::range(area, n, count as usize, size).map(|_| ())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clone_from_copies_into_the_same_buffers() {
        let mut sizes = MemorySizes {
            flags: 16,
            ..MemorySizes::default()
        };
        sizes.dbs.insert(1, 8);
        let mut source = Memory::new(&sizes);
        let mut kept = source.clone();
        let (db, flags) = (
            kept.bytes(Area::Db(1)).unwrap().as_ptr(),
            kept.bytes(Area::Flags).unwrap().as_ptr(),
        );
        source.set_word(Area::Db(1), 2, 0xBEEF).unwrap();
        source.write(Area::Flags, 0, &[7]).unwrap();
        kept.clone_from(&source);
        assert_eq!(kept, source);
        assert_eq!(
            kept.bytes(Area::Db(1)).unwrap().as_ptr(),
            db,
            "no new DB buffer"
        );
        assert_eq!(kept.bytes(Area::Flags).unwrap().as_ptr(), flags);
        // Other data blocks: a plain copy.
        source.add_db(9, 4);
        kept.clone_from(&source);
        assert_eq!(kept, source);
    }

    #[test]
    fn bits_words_and_limits() {
        let mut sizes = MemorySizes::default();
        sizes.dbs.insert(6, 1024);
        let mut m = Memory::new(&sizes);
        m.set_bit(Area::Flags, 1004, 1, true).unwrap();
        assert_eq!(m.word(Area::Flags, 1004).unwrap(), 0x0200);
        m.set_word(Area::Db(6), 100, 0xCD09).unwrap();
        assert_eq!(m.bytes(Area::Db(6)).unwrap()[100..102], [0xCD, 0x09]);
        assert_eq!(m.word(Area::Db(7), 0), Err(MemoryError::NoSuchDb(7)));
        assert_eq!(
            m.read(Area::Outputs, 127, &mut [0; 2]),
            Err(MemoryError::OutOfRange {
                area: Area::Outputs,
                end: 129,
                size: 128
            })
        );
        m.set_element(Area::Timers, 255, 0x1234).unwrap();
        assert_eq!(m.element(Area::Timers, 255).unwrap(), 0x1234);
        assert!(m.element(Area::Counters, 256).is_err());
        assert_eq!(Area::Db(6).to_string(), "DB6");
    }

    #[test]
    fn sizes_beyond_their_maximum_are_refused_with_the_parameter_and_range() {
        let mut sizes = MemorySizes::default();
        assert!(Memory::checked(&sizes).is_ok());
        sizes.flags = u32::MAX;
        let e = Memory::checked(&sizes).unwrap_err();
        assert_eq!(
            e.to_string(),
            "memory.flags = 4294967295 bytes is out of range: 0 … 65536 bytes"
        );
        sizes.flags = MAX_AREA_BYTES;
        sizes.timers = MAX_ELEMENTS + 1;
        assert_eq!(sizes.check().unwrap_err().parameter, "memory.timers");
        sizes.timers = 0;
        sizes.dbs.insert(1, MAX_DB_BYTES + 1);
        assert_eq!(
            sizes.check().unwrap_err().to_string(),
            "DB length = 65537 bytes is out of range: 0 … 65536 bytes (DB1)"
        );
        // Every DB at its maximum is fine alone, not 300 of them together.
        sizes.dbs = (1..=300).map(|n| (n, MAX_DB_BYTES)).collect();
        let e = sizes.check().unwrap_err();
        assert_eq!(e.parameter, "memory in all areas");
        assert_eq!(e.range, "0 … 16777216 bytes");
    }
}
