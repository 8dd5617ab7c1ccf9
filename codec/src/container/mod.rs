//! The dataset container: one file per dataset holding a whole tile pyramid.
//!
//! ```text
//! offset  size  field
//!      0     4  magic "ZTD1"
//!      4     2  version (1), little-endian like every number here
//!      6     2  flags (0; a reader refuses any it does not know)
//!      8     4  header_len: bytes from offset 0 to the first tile record
//!     12     4  metadata_len
//!     16     4  index_count
//!     20     4  CRC-32 of bytes 24..header_len (metadata and index)
//!     24     …  metadata: UTF-8 JSON ([`Metadata`])
//!      …     …  index: index_count × 25 bytes, sorted by (z, x, y):
//!               z u8 | x u32 | y u32 | offset u64 | len u32 | CRC-32 of the record u32
//! header_len …  tile records: 4 × f64 exact corner heights (NW, NE, SW, SE) | EZW stream
//! ```
//!
//! Everything a server needs before the first tile request is in the header, so opening a
//! dataset is one bounded read, and every tile is one range read at a known offset (a file or
//! an object store alike). Each record carries its own CRC-32: a flipped bit makes that tile
//! fail, not the dataset. Writers build the whole file in memory and callers write it
//! atomically (temp file + rename): a failed ingest never leaves a half-written dataset.

mod metadata;

use std::collections::BTreeMap;

pub use metadata::{Availability, Metadata, ViewParams};

/// First bytes of every container.
pub const MAGIC: &[u8; 4] = b"ZTD1";
/// The version this code writes and reads.
pub const VERSION: u16 = 1;
/// Fixed part of the header, before the metadata.
pub const FIXED_LEN: usize = 24;
const ENTRY_LEN: usize = 25;
const CORNERS_LEN: usize = 32;

/// Limits on what a header may ask for before anything is allocated from it.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    pub max_header_bytes: usize,
    pub max_record_bytes: usize,
}

impl Default for Limits {
    /// 256 MiB of header (about ten million tiles) and 64 MiB per tile record.
    fn default() -> Self {
        Self {
            max_header_bytes: 256 << 20,
            max_record_bytes: 64 << 20,
        }
    }
}

/// A container could not be read.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ContainerError {
    #[error("not a zerotile dataset (bad magic)")]
    Magic,
    #[error("dataset version {0} is not supported (this build reads version {VERSION})")]
    Version(u16),
    #[error(
        "dataset header flags {0:#06x} are not known to this build (version {VERSION} defines none)"
    )]
    Flags(u16),
    #[error("dataset metadata is invalid: {0}")]
    Metadata(String),
    #[error("dataset is truncated: {0}")]
    Truncated(&'static str),
    #[error("dataset is malformed: {0}")]
    Malformed(String),
    #[error("dataset exceeds a limit: {0}")]
    Limit(String),
    #[error("checksum mismatch in {0}")]
    Checksum(String),
}

/// A tile's address in the pyramid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TileId {
    pub z: u8,
    pub x: u32,
    pub y: u32,
}

impl std::fmt::Display for TileId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}/{}", self.z, self.x, self.y)
    }
}

/// Where a tile's record is and how to check it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IndexEntry {
    pub offset: u64,
    pub len: u32,
    pub crc: u32,
}

/// One tile as stored: the exact source heights at its corners (shared by the four tiles
/// that meet there, so stitched meshes agree) and its EZW stream.
#[derive(Clone, Debug, PartialEq)]
pub struct TileRecord<'a> {
    pub corners: [f64; 4],
    pub stream: &'a [u8],
}

/// The bytes that say how long the header is: the first read of an open.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fixed {
    pub header_len: usize,
    metadata_len: usize,
    index_count: usize,
    crc: u32,
}

impl Fixed {
    /// Parses the first [`FIXED_LEN`] bytes and checks them against `limits`.
    pub fn parse(bytes: &[u8], limits: &Limits) -> Result<Self, ContainerError> {
        let b = bytes
            .get(..FIXED_LEN)
            .ok_or(ContainerError::Truncated("fixed header"))?;
        if &b[..4] != MAGIC {
            return Err(ContainerError::Magic);
        }
        let version = u16::from_le_bytes([b[4], b[5]]);
        if version != VERSION {
            return Err(ContainerError::Version(version));
        }
        // Outside the CRC, so a flipped bit here passed unseen; and a future writer's flag
        // may change how the rest reads, which this reader cannot honour.
        let flags = u16::from_le_bytes([b[6], b[7]]);
        if flags != 0 {
            return Err(ContainerError::Flags(flags));
        }
        let u32_at = |k: usize| u32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]) as usize;
        let (header_len, metadata_len, index_count) = (u32_at(8), u32_at(12), u32_at(16));
        if header_len > limits.max_header_bytes {
            return Err(ContainerError::Limit(format!(
                "header of {header_len} bytes (limit {})",
                limits.max_header_bytes
            )));
        }
        let expected = index_count
            .checked_mul(ENTRY_LEN)
            .and_then(|i| i.checked_add(metadata_len))
            .and_then(|i| i.checked_add(FIXED_LEN));
        if expected != Some(header_len) {
            return Err(ContainerError::Malformed(format!(
                "header length {header_len} does not fit {metadata_len} bytes of metadata and \
                 {index_count} index entries"
            )));
        }
        Ok(Self {
            header_len,
            metadata_len,
            index_count,
            crc: u32_at(20) as u32,
        })
    }
}

/// An opened container: metadata and index, ready to locate tiles.
#[derive(Clone, Debug)]
pub struct Container {
    pub metadata: Metadata,
    index: BTreeMap<TileId, IndexEntry>,
    header_len: usize,
}

impl Container {
    /// Parses a whole header (`bytes` holds at least `fixed.header_len` bytes).
    pub fn parse(bytes: &[u8], limits: &Limits) -> Result<Self, ContainerError> {
        // Fixed part, then the checksum over everything it announces.
        let fixed = Fixed::parse(bytes, limits)?;
        let header = bytes
            .get(..fixed.header_len)
            .ok_or(ContainerError::Truncated("header"))?;
        if crc32fast::hash(&header[FIXED_LEN..]) != fixed.crc {
            return Err(ContainerError::Checksum("the header".into()));
        }
        // Metadata.
        let meta_end = FIXED_LEN + fixed.metadata_len;
        let metadata: Metadata = serde_json::from_slice(&header[FIXED_LEN..meta_end])
            .map_err(|e| ContainerError::Malformed(format!("metadata: {e}")))?;
        metadata.check().map_err(ContainerError::Metadata)?;
        // Index: sorted, records after the header.
        let mut index = BTreeMap::new();
        for e in header[meta_end..].chunks_exact(ENTRY_LEN) {
            let u32_at = |k: usize| u32::from_le_bytes([e[k], e[k + 1], e[k + 2], e[k + 3]]);
            let id = TileId {
                z: e[0],
                x: u32_at(1),
                y: u32_at(5),
            };
            let mut off = [0u8; 8];
            off.copy_from_slice(&e[9..17]);
            let entry = IndexEntry {
                offset: u64::from_le_bytes(off),
                len: u32_at(17),
                crc: u32_at(21),
            };
            if entry.offset < fixed.header_len as u64 || (entry.len as usize) < CORNERS_LEN {
                return Err(ContainerError::Malformed(format!(
                    "index entry of tile {id}"
                )));
            }
            if (entry.len as usize) > limits.max_record_bytes {
                return Err(ContainerError::Limit(format!(
                    "tile {id} record of {} bytes (limit {})",
                    entry.len, limits.max_record_bytes
                )));
            }
            if index.insert(id, entry).is_some() {
                return Err(ContainerError::Malformed(format!(
                    "tile {id} indexed twice"
                )));
            }
        }
        debug_assert_eq!(index.len(), fixed.index_count);
        Ok(Self {
            metadata,
            index,
            header_len: fixed.header_len,
        })
    }

    pub fn header_len(&self) -> usize {
        self.header_len
    }

    pub fn entry(&self, id: TileId) -> Option<IndexEntry> {
        self.index.get(&id).copied()
    }

    pub fn tiles(&self) -> impl Iterator<Item = (TileId, IndexEntry)> + '_ {
        self.index.iter().map(|(k, v)| (*k, *v))
    }

    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Total bytes of tile records.
    pub fn data_bytes(&self) -> u64 {
        self.index.values().map(|e| u64::from(e.len)).sum()
    }
}

impl TileRecord<'_> {
    /// Checks a record read at `entry` and splits it.
    pub fn parse<'a>(
        id: TileId,
        bytes: &'a [u8],
        entry: &IndexEntry,
    ) -> Result<TileRecord<'a>, ContainerError> {
        if bytes.len() != entry.len as usize {
            return Err(ContainerError::Truncated("tile record"));
        }
        if crc32fast::hash(bytes) != entry.crc {
            return Err(ContainerError::Checksum(format!("tile {id}")));
        }
        let mut corners = [0f64; 4];
        for (k, c) in corners.iter_mut().enumerate() {
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[8 * k..8 * k + 8]);
            *c = f64::from_le_bytes(b);
        }
        if corners.iter().any(|c| !c.is_finite()) {
            return Err(ContainerError::Malformed(format!(
                "tile {id} corner heights"
            )));
        }
        Ok(TileRecord {
            corners,
            stream: &bytes[CORNERS_LEN..],
        })
    }
}

/// Builds a container in memory; callers write the bytes atomically.
#[derive(Debug, Default)]
pub struct Writer {
    tiles: BTreeMap<TileId, Vec<u8>>,
}

impl Writer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds (or replaces) a tile.
    pub fn add(&mut self, id: TileId, corners: [f64; 4], stream: &[u8]) {
        let mut rec = Vec::with_capacity(CORNERS_LEN + stream.len());
        for c in corners {
            rec.extend_from_slice(&c.to_le_bytes());
        }
        rec.extend_from_slice(stream);
        self.tiles.insert(id, rec);
    }

    pub fn len(&self) -> usize {
        self.tiles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tiles.is_empty()
    }

    /// The whole file: header, index, records in (z, x, y) order.
    pub fn finish(self, metadata: &Metadata) -> Result<Vec<u8>, ContainerError> {
        let meta = serde_json::to_vec(metadata)
            .map_err(|e| ContainerError::Malformed(format!("metadata: {e}")))?;
        let header_len = FIXED_LEN + meta.len() + ENTRY_LEN * self.tiles.len();
        let too_big = |what: &str| ContainerError::Limit(format!("{what} exceeds 4 GiB"));
        let header_len32 = u32::try_from(header_len).map_err(|_| too_big("the header"))?;
        let data_len: usize = self.tiles.values().map(Vec::len).sum();
        let mut out = Vec::with_capacity(header_len + data_len);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out.extend_from_slice(&header_len32.to_le_bytes());
        out.extend_from_slice(&(meta.len() as u32).to_le_bytes());
        out.extend_from_slice(&(self.tiles.len() as u32).to_le_bytes());
        out.extend_from_slice(&[0; 4]); // CRC, filled below
        out.extend_from_slice(&meta);
        let mut offset = header_len as u64;
        for (id, rec) in &self.tiles {
            let len = u32::try_from(rec.len()).map_err(|_| too_big("a tile record"))?;
            out.push(id.z);
            out.extend_from_slice(&id.x.to_le_bytes());
            out.extend_from_slice(&id.y.to_le_bytes());
            out.extend_from_slice(&offset.to_le_bytes());
            out.extend_from_slice(&len.to_le_bytes());
            out.extend_from_slice(&crc32fast::hash(rec).to_le_bytes());
            offset += u64::from(len);
        }
        let crc = crc32fast::hash(&out[FIXED_LEN..]);
        out[20..24].copy_from_slice(&crc.to_le_bytes());
        for rec in self.tiles.values() {
            out.extend_from_slice(rec);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
