//! The record file format: a fixed little-endian header, then 8-byte-aligned flat arrays
//! ("sections") of plain `#[repr(C)]` structs that are read in place, without copying,
//! through [`bytemuck`].
//!
//! Layout (byte offsets; integers little-endian; N = number of sections):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `b"DAYSTEP\0"` |
//! | 8 | 4 | [`FORMAT_VERSION`] (u32) |
//! | 12 | 4 | header length H = 144 + 24·N (u32) |
//! | 16 | 48 | [`RecordKey::to_bytes`]: scene hash 32, direction u64, resolution u32, kind u8, 3 zero bytes |
//! | 64 | 1 | byte order of the sections: 1 = little-endian, 2 = big-endian |
//! | 65 | 3 | zero |
//! | 68 | 4 | N (u32, at most [`MAX_SECTIONS`]) |
//! | 72 | 8 | payload length P (u64); the file is exactly H + P bytes |
//! | 80 | 32 | blake3 of the payload (bytes H .. H + P) |
//! | 112 | 24·N | section table, per section: tag u32, element size u32 (bytes), count u64, offset u64 (from the start of the file, a multiple of 8, ≥ H) |
//! | 112 + 24·N | 32 | blake3 of bytes 0 .. 112 + 24·N (the header checksum) |
//! | H | P | the sections in table order, each padded with zeros to a multiple of 8 |
//!
//! Sections hold host-endian plain data (all supported targets are little-endian in
//! practice); a record written with the other byte order is rejected, never misread.

use super::key::{RecordKey, RECORD_KEY_BYTES};
use super::FORMAT_VERSION;
use bytemuck::Pod;

// The direction-record codec lived here; its items keep this path.
pub use super::direction_codec::{
    decode_direction, encode_direction, LeafRec, StatsRec, FIRST_USER_TAG, TAG_LEAVES, TAG_STATS,
};

/// The first 8 bytes of every record.
pub const MAGIC: [u8; 8] = *b"DAYSTEP\0";
/// Most sections a record may have (bounds the work of validating a corrupt header).
pub const MAX_SECTIONS: u32 = 1024;
/// Header bytes before the section table.
pub const FIXED_HEADER_BYTES: usize = 112;
/// Bytes per section-table entry.
pub const SECTION_ENTRY_BYTES: usize = 24;
/// Bytes of each blake3 checksum.
pub const CHECKSUM_BYTES: usize = 32;

const BYTE_ORDER_LITTLE: u8 = 1;
const BYTE_ORDER_BIG: u8 = 2;
const HOST_BYTE_ORDER: u8 = if cfg!(target_endian = "little") {
    BYTE_ORDER_LITTLE
} else {
    BYTE_ORDER_BIG
};

/// Header length for `n` sections: 144 + 24·n bytes (a multiple of 8).
pub fn header_len(n: usize) -> usize {
    FIXED_HEADER_BYTES + SECTION_ENTRY_BYTES * n + CHECKSUM_BYTES
}

/// Why a byte string is not a usable record. Every check of [`Record::validate`] has its
/// own variant, so a warning can say what was wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Invalid {
    /// Shorter than its header or its stated length says.
    #[error("truncated: {len} bytes, at least {needed} needed")]
    Truncated {
        /// Actual length, bytes.
        len: u64,
        /// Length the header implies, bytes.
        needed: u64,
    },
    /// Longer than its header says (bytes appended).
    #[error("{len} bytes where the header says {expected}")]
    LengthMismatch {
        /// Actual length, bytes.
        len: u64,
        /// Length the header implies, bytes.
        expected: u64,
    },
    /// Does not start with [`MAGIC`]: not a daystep record.
    #[error("not a daystep record (bad magic)")]
    BadMagic,
    /// Written by another format version.
    #[error("format version {found}, this build reads {}", FORMAT_VERSION)]
    Version {
        /// The version in the file.
        found: u32,
    },
    /// A header field that cannot be right (section count, header length, key padding).
    #[error("corrupt header: {0}")]
    HeaderCorrupt(&'static str),
    /// The header checksum does not match the header.
    #[error("header checksum mismatch")]
    HeaderChecksum,
    /// Sections written with the other byte order.
    #[error("written on a machine of the other byte order")]
    ByteOrder,
    /// A valid record, but of another key than the one asked for (or than its file name).
    #[error("record of another key")]
    OtherKey,
    /// The payload checksum does not match the payload.
    #[error("payload checksum mismatch")]
    PayloadChecksum,
    /// A section reaching outside the file, or into the header.
    #[error("section {index} out of bounds")]
    SectionOutOfBounds {
        /// Position in the section table.
        index: usize,
    },
    /// A section whose offset is not a multiple of 8 (or whose bytes are not aligned in
    /// memory for the element type).
    #[error("section {index} misaligned")]
    SectionMisaligned {
        /// Position in the section table.
        index: usize,
    },
    /// A section the reader needs is not in the record.
    #[error("no section with tag {tag}")]
    MissingSection {
        /// The tag asked for.
        tag: u32,
    },
    /// A section whose element size differs from the type asked for.
    #[error("section with tag {tag} has {found}-byte elements, expected {expected}")]
    ElementSize {
        /// The tag asked for.
        tag: u32,
        /// Size of the requested type, bytes.
        expected: u32,
        /// Size in the file, bytes.
        found: u32,
    },
    /// A section with a structurally impossible content (e.g. two stats entries).
    #[error("section with tag {tag}: {what}")]
    BadSection {
        /// The tag.
        tag: u32,
        /// What is wrong.
        what: &'static str,
    },
    /// The file could not be read or mapped.
    #[error("unreadable: {0}")]
    Unreadable(String),
}

/// One section to write: a tag the reader looks it up by, the element size and the raw
/// bytes of the elements.
#[derive(Clone, Copy, Debug)]
pub struct Section<'a> {
    /// Identifies the section; unique within a record. Tags below [`FIRST_USER_TAG`] are
    /// reserved for daystep's own codecs.
    pub tag: u32,
    /// Bytes per element (> 0).
    pub elem_size: u32,
    /// The elements, `elem_size × count` bytes.
    pub bytes: &'a [u8],
}

impl<'a> Section<'a> {
    /// A section of plain structs.
    pub fn of<T: Pod>(tag: u32, items: &'a [T]) -> Section<'a> {
        Section {
            tag,
            elem_size: std::mem::size_of::<T>() as u32,
            bytes: bytemuck::cast_slice(items),
        }
    }
    /// A section of f64 values (e.g. per-sensor visibility, any unit the caller documents).
    pub fn f64s(tag: u32, values: &'a [f64]) -> Section<'a> {
        Self::of(tag, values)
    }
    /// A section of u32 values (e.g. indices).
    pub fn u32s(tag: u32, values: &'a [u32]) -> Section<'a> {
        Self::of(tag, values)
    }
}

/// Where a section lies in a validated record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SectionInfo {
    /// The section's tag.
    pub tag: u32,
    /// Bytes per element.
    pub elem_size: u32,
    /// Number of elements.
    pub count: u64,
    /// Byte offset from the start of the record (a multiple of 8).
    pub offset: u64,
}

impl SectionInfo {
    /// Length in bytes (without padding).
    pub fn byte_len(&self) -> u64 {
        self.elem_size as u64 * self.count
    }
}

fn pad8(n: usize) -> usize {
    n.div_ceil(8) * 8
}

/// Encodes a record of `key` with `sections`, in order (format in the module docs).
///
/// # Panics
/// On caller bugs: an element size of 0, a byte length that is not a multiple of the
/// element size, two sections with one tag, more than [`MAX_SECTIONS`] sections.
pub fn encode(key: &RecordKey, sections: &[Section<'_>]) -> Vec<u8> {
    let mut out = Vec::new();
    write_record(&mut out, key, sections).expect("writing to memory cannot fail");
    out
}

/// Writes the record [`encode`] makes to `w`, without holding it in memory: the header
/// (its payload checksum hashed over the sections where they lie), then each section.
/// Returns the bytes written. For records as large as the interreflection operator,
/// which would otherwise be copied whole before being written.
///
/// # Errors
/// What `w` returns.
///
/// # Panics
/// As [`encode`].
pub fn write_record(
    w: &mut impl std::io::Write,
    key: &RecordKey,
    sections: &[Section<'_>],
) -> std::io::Result<u64> {
    check_sections(sections);
    let h = header_len(sections.len());
    let payload: usize = sections.iter().map(|s| pad8(s.bytes.len())).sum();
    let mut out = vec![0u8; h];
    out[..8].copy_from_slice(&MAGIC);
    out[8..12].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    out[12..16].copy_from_slice(&(h as u32).to_le_bytes());
    out[16..64].copy_from_slice(&key.to_bytes());
    out[64] = HOST_BYTE_ORDER;
    out[68..72].copy_from_slice(&(sections.len() as u32).to_le_bytes());
    out[72..80].copy_from_slice(&(payload as u64).to_le_bytes());
    let mut offset = h;
    let mut hasher = blake3::Hasher::new();
    let zeros = [0u8; 8];
    for (i, s) in sections.iter().enumerate() {
        let e = FIXED_HEADER_BYTES + SECTION_ENTRY_BYTES * i;
        let count = (s.bytes.len() / s.elem_size as usize) as u64;
        out[e..e + 4].copy_from_slice(&s.tag.to_le_bytes());
        out[e + 4..e + 8].copy_from_slice(&s.elem_size.to_le_bytes());
        out[e + 8..e + 16].copy_from_slice(&count.to_le_bytes());
        out[e + 16..e + 24].copy_from_slice(&(offset as u64).to_le_bytes());
        hasher.update(s.bytes);
        hasher.update(&zeros[..pad8(s.bytes.len()) - s.bytes.len()]);
        offset += pad8(s.bytes.len());
    }
    out[80..112].copy_from_slice(hasher.finalize().as_bytes());
    let sum_at = h - CHECKSUM_BYTES;
    let header_sum = *blake3::hash(&out[..sum_at]).as_bytes();
    out[sum_at..h].copy_from_slice(&header_sum);
    w.write_all(&out)?;
    for s in sections {
        w.write_all(s.bytes)?;
        w.write_all(&zeros[..pad8(s.bytes.len()) - s.bytes.len()])?;
    }
    Ok((h + payload) as u64)
}

/// The caller-bug checks of [`encode`].
fn check_sections(sections: &[Section<'_>]) {
    assert!(sections.len() <= MAX_SECTIONS as usize, "too many sections");
    for (i, s) in sections.iter().enumerate() {
        assert!(s.elem_size > 0, "section {} has element size 0", s.tag);
        assert!(
            s.bytes.len() % s.elem_size as usize == 0,
            "section {}: {} bytes is not a whole number of {}-byte elements",
            s.tag,
            s.bytes.len(),
            s.elem_size
        );
        assert!(
            sections[..i].iter().all(|o| o.tag != s.tag),
            "duplicate section tag {}",
            s.tag
        );
    }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

/// Checks everything about `bytes` except which key it should have; returns the embedded
/// key and the section table. Never panics, whatever the bytes.
fn check(bytes: &[u8]) -> Result<(RecordKey, Vec<SectionInfo>), Invalid> {
    let len = bytes.len() as u64;
    let truncated = |needed: usize| Invalid::Truncated {
        len,
        needed: needed as u64,
    };
    if bytes.len() < MAGIC.len() {
        return Err(truncated(header_len(0)));
    }
    if bytes[..8] != MAGIC {
        return Err(Invalid::BadMagic);
    }
    if bytes.len() < FIXED_HEADER_BYTES {
        return Err(truncated(header_len(0)));
    }
    let version = u32_at(bytes, 8);
    if version != FORMAT_VERSION {
        return Err(Invalid::Version { found: version });
    }
    let n = u32_at(bytes, 68);
    if n > MAX_SECTIONS {
        return Err(Invalid::HeaderCorrupt("too many sections"));
    }
    let h = header_len(n as usize);
    if u32_at(bytes, 12) as usize != h {
        return Err(Invalid::HeaderCorrupt(
            "header length disagrees with section count",
        ));
    }
    if bytes.len() < h {
        return Err(truncated(h));
    }
    let sum_at = h - CHECKSUM_BYTES;
    if blake3::hash(&bytes[..sum_at])
        != blake3::Hash::from_bytes(bytes[sum_at..h].try_into().expect("32 bytes"))
    {
        return Err(Invalid::HeaderChecksum);
    }
    let order = bytes[64];
    if order != BYTE_ORDER_LITTLE && order != BYTE_ORDER_BIG {
        return Err(Invalid::HeaderCorrupt("unknown byte order"));
    }
    if order != HOST_BYTE_ORDER {
        return Err(Invalid::ByteOrder);
    }
    if bytes[65..68] != [0, 0, 0] {
        return Err(Invalid::HeaderCorrupt("reserved bytes not zero"));
    }
    let key_bytes: &[u8; RECORD_KEY_BYTES] = bytes[16..64].try_into().expect("48 bytes");
    let key =
        RecordKey::from_bytes(key_bytes).ok_or(Invalid::HeaderCorrupt("key padding not zero"))?;
    let payload = u64_at(bytes, 72);
    let expected = (h as u64)
        .checked_add(payload)
        .ok_or(Invalid::HeaderCorrupt("payload length"))?;
    if len < expected {
        return Err(Invalid::Truncated {
            len,
            needed: expected,
        });
    }
    if len > expected {
        return Err(Invalid::LengthMismatch { len, expected });
    }
    let mut sections = Vec::with_capacity(n as usize);
    for index in 0..n as usize {
        let e = FIXED_HEADER_BYTES + SECTION_ENTRY_BYTES * index;
        let s = SectionInfo {
            tag: u32_at(bytes, e),
            elem_size: u32_at(bytes, e + 4),
            count: u64_at(bytes, e + 8),
            offset: u64_at(bytes, e + 16),
        };
        if s.offset % 8 != 0 {
            return Err(Invalid::SectionMisaligned { index });
        }
        let end = (s.elem_size as u64)
            .checked_mul(s.count)
            .and_then(|b| b.checked_add(s.offset));
        if s.elem_size == 0 || s.offset < h as u64 || end.is_none_or(|end| end > len) {
            return Err(Invalid::SectionOutOfBounds { index });
        }
        sections.push(s);
    }
    let payload_sum: &[u8; 32] = bytes[80..112].try_into().expect("32 bytes");
    if blake3::hash(&bytes[h..]) != blake3::Hash::from_bytes(*payload_sum) {
        return Err(Invalid::PayloadChecksum);
    }
    Ok((key, sections))
}

/// Looks a section up by tag and casts it to `&[T]` in place.
fn section_in<'b, T: Pod>(
    bytes: &'b [u8],
    sections: &[SectionInfo],
    tag: u32,
) -> Result<&'b [T], Invalid> {
    let (index, s) = sections
        .iter()
        .enumerate()
        .find(|(_, s)| s.tag == tag)
        .ok_or(Invalid::MissingSection { tag })?;
    let size = std::mem::size_of::<T>() as u32;
    if s.elem_size != size {
        return Err(Invalid::ElementSize {
            tag,
            expected: size,
            found: s.elem_size,
        });
    }
    // Bounds were checked in validation; `get` keeps this panic-free regardless.
    let raw = usize::try_from(s.offset)
        .ok()
        .zip(usize::try_from(s.byte_len()).ok())
        .and_then(|(o, l)| bytes.get(o..o.checked_add(l)?))
        .ok_or(Invalid::SectionOutOfBounds { index })?;
    bytemuck::try_cast_slice(raw).map_err(|_| Invalid::SectionMisaligned { index })
}

/// A validated record borrowed from a byte slice (a mapped file, or any buffer).
#[derive(Clone, Debug)]
pub struct Record<'a> {
    bytes: &'a [u8],
    key: RecordKey,
    sections: Vec<SectionInfo>,
}

impl<'a> Record<'a> {
    /// Validates `bytes` as a record of `expected`: magic, version, header checksum, byte
    /// order, key, length, section bounds and alignment, payload checksum.
    ///
    /// # Errors
    /// [`Invalid`] saying which check failed first.
    pub fn validate(bytes: &'a [u8], expected: &RecordKey) -> Result<Record<'a>, Invalid> {
        let r = Self::parse(bytes)?;
        if r.key != *expected {
            return Err(Invalid::OtherKey);
        }
        Ok(r)
    }

    /// Validates `bytes` like [`Record::validate`] without knowing which key to expect
    /// (for maintenance: the caller compares [`Record::key`] with the file name).
    ///
    /// # Errors
    /// [`Invalid`] saying which check failed first.
    pub fn parse(bytes: &'a [u8]) -> Result<Record<'a>, Invalid> {
        let (key, sections) = check(bytes)?;
        Ok(Record {
            bytes,
            key,
            sections,
        })
    }

    /// The key embedded in the header.
    pub fn key(&self) -> RecordKey {
        self.key
    }
    /// The section table.
    pub fn sections(&self) -> &[SectionInfo] {
        &self.sections
    }
    /// The whole record.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }
    /// Section `tag` as a slice of `T`, without copying.
    ///
    /// # Errors
    /// [`Invalid::MissingSection`], [`Invalid::ElementSize`], or
    /// [`Invalid::SectionMisaligned`] when the buffer itself is not aligned for `T`.
    pub fn section<T: Pod>(&self, tag: u32) -> Result<&'a [T], Invalid> {
        section_in(self.bytes, &self.sections, tag)
    }
}

/// A validated record that owns its bytes: a memory map of a cache file (from
/// [`super::Store::get`]) or an 8-byte-aligned copy ([`MappedRecord::from_bytes`]).
#[derive(Debug)]
pub struct MappedRecord {
    data: Backing,
    key: RecordKey,
    sections: Vec<SectionInfo>,
}

#[derive(Debug)]
enum Backing {
    Map(memmap2::Mmap),
    Owned { words: Vec<u64>, len: usize },
}

impl MappedRecord {
    /// Validates a memory map as a record of `expected`.
    pub(crate) fn from_map(map: memmap2::Mmap, expected: &RecordKey) -> Result<Self, Invalid> {
        let r = Record::validate(&map, expected)?;
        let (key, sections) = (r.key, r.sections);
        Ok(MappedRecord {
            data: Backing::Map(map),
            key,
            sections,
        })
    }

    /// Reads the `len` bytes of `file` into an 8-byte-aligned buffer and validates them as
    /// a record of `expected`: for small records, where a map's set-up and, above all, its
    /// unmapping (a TLB shoot-down across the process's threads) cost more than a copy.
    pub(crate) fn read_from(
        file: &mut std::fs::File,
        len: usize,
        expected: &RecordKey,
    ) -> Result<Self, Invalid> {
        use std::io::Read;
        let mut words = vec![0u64; len.div_ceil(8)];
        file.read_exact(&mut bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..len])
            .map_err(|e| Invalid::Unreadable(e.to_string()))?;
        let r = Record::validate(&bytemuck::cast_slice::<u64, u8>(&words)[..len], expected)?;
        let (key, sections) = (r.key, r.sections);
        Ok(MappedRecord {
            data: Backing::Owned { words, len },
            key,
            sections,
        })
    }

    /// Copies `bytes` into an 8-byte-aligned buffer and validates it as a record of
    /// `expected` (for records held in memory rather than in a cache folder).
    ///
    /// # Errors
    /// As [`Record::validate`].
    pub fn from_bytes(bytes: &[u8], expected: &RecordKey) -> Result<Self, Invalid> {
        let mut words = vec![0u64; bytes.len().div_ceil(8)];
        bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        let r = Record::validate(
            &bytemuck::cast_slice::<u64, u8>(&words)[..bytes.len()],
            expected,
        )?;
        let (key, sections) = (r.key, r.sections);
        Ok(MappedRecord {
            data: Backing::Owned {
                words,
                len: bytes.len(),
            },
            key,
            sections,
        })
    }

    /// The record's bytes.
    pub fn bytes(&self) -> &[u8] {
        match &self.data {
            Backing::Map(m) => m,
            Backing::Owned { words, len } => &bytemuck::cast_slice::<u64, u8>(words)[..*len],
        }
    }
    /// Gives the map's resident pages back to the kernel (`MADV_DONTNEED`): the process's
    /// resident memory no longer counts them, and a later read faults them in again from
    /// the file (the page cache, usually), with the same bytes. For a large record read
    /// in parts (the operator), so that only the part being read stays resident. Nothing
    /// for a record held in memory; a failed advice only leaves the pages resident.
    pub fn release(&self) {
        if let Backing::Map(m) = &self.data {
            release_map(m);
        }
    }

    /// [`Self::release`] for the pages that hold bytes `range` of the record (and the
    /// neighbouring bytes on their first and last page): for a large array read once in
    /// order, so that only the part still to be read can stay resident.
    pub fn release_range(&self, range: std::ops::Range<usize>) {
        if let Backing::Map(m) = &self.data {
            if range.start < range.end && range.end <= m.len() {
                release_map_range(m, range);
            }
        }
    }

    /// True when backed by a memory-mapped file.
    pub fn is_mapped(&self) -> bool {
        matches!(self.data, Backing::Map(_))
    }
    /// The record's key.
    pub fn key(&self) -> RecordKey {
        self.key
    }
    /// The section table.
    pub fn sections(&self) -> &[SectionInfo] {
        &self.sections
    }
    /// Section `tag` as a slice of `T`, without copying (see [`Record::section`]).
    ///
    /// # Errors
    /// As [`Record::section`].
    pub fn section<T: Pod>(&self, tag: u32) -> Result<&[T], Invalid> {
        section_in(self.bytes(), &self.sections, tag)
    }
    /// Section `tag` as f64 values.
    ///
    /// # Errors
    /// As [`Record::section`].
    pub fn f64s(&self, tag: u32) -> Result<&[f64], Invalid> {
        self.section(tag)
    }
    /// Section `tag` as u32 values.
    ///
    /// # Errors
    /// As [`Record::section`].
    pub fn u32s(&self, tag: u32) -> Result<&[u32], Invalid> {
        self.section(tag)
    }
}

/// `MADV_DONTNEED` on a read-only file map ([`MappedRecord::release`]); elsewhere than
/// Unix, nothing (the pages stay resident).
#[cfg(not(unix))]
fn release_map(_map: &memmap2::Mmap) {}

/// ... on bytes `range` of it ([`MappedRecord::release_range`]).
#[cfg(not(unix))]
fn release_map_range(_map: &memmap2::Mmap, _range: std::ops::Range<usize>) {}

/// `MADV_DONTNEED` on bytes `range` of a read-only file map, widened to whole pages
/// ([`MappedRecord::release_range`]).
#[cfg(unix)]
#[allow(unsafe_code)]
fn release_map_range(map: &memmap2::Mmap, range: std::ops::Range<usize>) {
    // SAFETY: as in `release_map`: a read-only shared map of a file never changed in
    // place, so a discarded page reads back the same bytes.
    let _ = unsafe {
        map.unchecked_advise_range(
            memmap2::UncheckedAdvice::DontNeed,
            range.start,
            range.end - range.start,
        )
    };
}

/// `MADV_DONTNEED` on a read-only file map ([`MappedRecord::release`]).
#[cfg(unix)]
#[allow(unsafe_code)]
fn release_map(map: &memmap2::Mmap) {
    // SAFETY: `unchecked_advise` is unsafe because `MADV_DONTNEED` discards a private
    // mapping's modified pages, which would change what the map reads. Ours is a
    // read-only shared map of a record file (`Store::get`, `map_readonly`): it has no
    // modified pages, and a page discarded here is read again from the same file, whose
    // bytes daystep never changes in place (records are replaced by rename). So every
    // later read sees the bytes `Record::validate` checked; only residency changes.
    let _ = unsafe { map.unchecked_advise(memmap2::UncheckedAdvice::DontNeed) };
}

#[cfg(test)]
#[path = "record_tests.rs"]
mod tests;
