//! A write-only zip archive of STORED (uncompressed) entries, written front to back to any
//! `Write`: the container of a sigrok session file.
//!
//! Each entry is given whole (its CRC-32 and size go into its local header, so no data
//! descriptor and no seeking are needed); only the central directory's records (name, CRC,
//! sizes, offset: a few dozen bytes per entry) stay in memory until [`ZipWriter::finish`].
//! No Zip64: an archive is refused once it would pass 4 GiB or 65 535 entries, the limits of
//! the classic format (PKWARE APPNOTE 6.3, §4.3.7, §4.3.12, §4.3.16).

use std::io::{self, Write};

/// CRC-32 as zip uses it (polynomial 04C11DB7, reflected: the catalog's ISO-HDLC).
const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Local file header signature `PK\3\4`.
const LOCAL_HEADER: u32 = 0x0403_4b50;
/// Central directory file header signature `PK\1\2`.
const CENTRAL_HEADER: u32 = 0x0201_4b50;
/// End of central directory signature `PK\5\6`.
const END_OF_DIRECTORY: u32 = 0x0605_4b50;
/// "Version needed to extract" 1.0: stored entries, no Zip64.
const VERSION_NEEDED: u16 = 10;
/// MS-DOS date 1980-01-01, the earliest a zip can say: the archive's entries carry no real
/// modification time, so two exports of one trace are byte for byte the same.
const DOS_DATE: u16 = (1 << 5) | 1;

/// What the central directory keeps of one entry.
struct Entry {
    name: String,
    crc: u32,
    size: u32,
    offset: u32,
}

/// A zip archive being written.
pub struct ZipWriter<W: Write> {
    out: W,
    /// Bytes written so far: the next local header's offset.
    offset: u64,
    entries: Vec<Entry>,
}

impl<W: Write> core::fmt::Debug for ZipWriter<W> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ZipWriter")
            .field("offset", &self.offset)
            .field("entries", &self.entries.len())
            .finish_non_exhaustive()
    }
}

fn too_big(what: &str) -> io::Error {
    io::Error::other(format!(
        "zip archive: {what} exceeds the classic zip limit (4 GiB, 65535 entries; no Zip64)"
    ))
}

impl<W: Write> ZipWriter<W> {
    /// An empty archive writing to `out`.
    pub fn new(out: W) -> Self {
        ZipWriter {
            out,
            offset: 0,
            entries: Vec::new(),
        }
    }

    /// Append one stored entry `name` holding `data`.
    pub fn add(&mut self, name: &str, data: &[u8]) -> io::Result<()> {
        let size = u32::try_from(data.len()).map_err(|_| too_big("an entry"))?;
        let offset = u32::try_from(self.offset).map_err(|_| too_big("the archive"))?;
        if self.entries.len() >= usize::from(u16::MAX) {
            return Err(too_big("the number of entries"));
        }
        let name_len = u16::try_from(name.len()).map_err(|_| too_big("an entry name"))?;
        let crc = CRC32.checksum(data);
        let mut h = Vec::with_capacity(30 + name.len());
        put32(&mut h, LOCAL_HEADER);
        put16(&mut h, VERSION_NEEDED);
        put16(&mut h, 0); // flags
        put16(&mut h, 0); // method: stored
        put16(&mut h, 0); // time
        put16(&mut h, DOS_DATE);
        put32(&mut h, crc);
        put32(&mut h, size); // compressed size
        put32(&mut h, size); // uncompressed size
        put16(&mut h, name_len);
        put16(&mut h, 0); // extra field length
        h.extend_from_slice(name.as_bytes());
        self.out.write_all(&h)?;
        self.out.write_all(data)?;
        self.offset += h.len() as u64 + data.len() as u64;
        self.entries.push(Entry {
            name: name.to_owned(),
            crc,
            size,
            offset,
        });
        Ok(())
    }

    /// Write the central directory and its end record; returns the writer, flushed.
    pub fn finish(mut self) -> io::Result<W> {
        let start = u32::try_from(self.offset).map_err(|_| too_big("the archive"))?;
        let mut d = Vec::new();
        for e in &self.entries {
            put32(&mut d, CENTRAL_HEADER);
            put16(&mut d, VERSION_NEEDED); // version made by: MS-DOS, 1.0
            put16(&mut d, VERSION_NEEDED);
            put16(&mut d, 0); // flags
            put16(&mut d, 0); // method: stored
            put16(&mut d, 0); // time
            put16(&mut d, DOS_DATE);
            put32(&mut d, e.crc);
            put32(&mut d, e.size);
            put32(&mut d, e.size);
            put16(&mut d, e.name.len() as u16); // checked in add
            put16(&mut d, 0); // extra field length
            put16(&mut d, 0); // comment length
            put16(&mut d, 0); // disk number
            put16(&mut d, 0); // internal attributes
            put32(&mut d, 0); // external attributes
            put32(&mut d, e.offset);
            d.extend_from_slice(e.name.as_bytes());
        }
        let size = u32::try_from(d.len()).map_err(|_| too_big("the central directory"))?;
        start
            .checked_add(size)
            .ok_or_else(|| too_big("the archive"))?;
        let count = self.entries.len() as u16; // checked in add
        put32(&mut d, END_OF_DIRECTORY);
        put16(&mut d, 0); // this disk
        put16(&mut d, 0); // disk of the central directory
        put16(&mut d, count);
        put16(&mut d, count);
        put32(&mut d, size);
        put32(&mut d, start);
        put16(&mut d, 0); // comment length
        self.out.write_all(&d)?;
        self.out.flush()?;
        Ok(self.out)
    }
}

fn put16(v: &mut Vec<u8>, x: u16) {
    v.extend_from_slice(&x.to_le_bytes());
}

fn put32(v: &mut Vec<u8>, x: u32) {
    v.extend_from_slice(&x.to_le_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u16_at(b: &[u8], i: usize) -> u16 {
        u16::from_le_bytes([b[i], b[i + 1]])
    }

    fn u32_at(b: &[u8], i: usize) -> u32 {
        u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
    }

    #[test]
    fn crc32_is_zips_check_value() {
        // The catalog check value of CRC-32/ISO-HDLC, the CRC zip stores.
        assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn entries_are_stored_and_the_directory_points_at_them() {
        let mut z = ZipWriter::new(Vec::new());
        z.add("version", b"2").unwrap();
        z.add("logic-1-1", &[0xFF, 0x00, 0x55]).unwrap();
        let b = z.finish().unwrap();
        // Local header of "version": stored, size 1, the name, then the data.
        assert_eq!(u32_at(&b, 0), LOCAL_HEADER);
        assert_eq!(u16_at(&b, 8), 0);
        assert_eq!(u32_at(&b, 14), CRC32.checksum(b"2"));
        assert_eq!(u32_at(&b, 18), 1);
        assert_eq!(&b[30..37], b"version");
        assert_eq!(b[37], b'2');
        // Second entry follows at once.
        assert_eq!(u32_at(&b, 38), LOCAL_HEADER);
        assert_eq!(&b[38 + 30..38 + 39], b"logic-1-1");
        // End record: two entries, directory right after the data.
        let end = b.len() - 22;
        assert_eq!(u32_at(&b, end), END_OF_DIRECTORY);
        assert_eq!(u16_at(&b, end + 10), 2);
        let dir = u32_at(&b, end + 16) as usize;
        assert_eq!(dir, 38 + 30 + 9 + 3);
        assert_eq!(u32_at(&b, dir), CENTRAL_HEADER);
        assert_eq!(u32_at(&b, dir + 42), 0, "first entry's local header offset");
        assert_eq!(u32_at(&b, end + 12) as usize, end - dir);
    }
}
