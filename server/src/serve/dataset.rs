//! One dataset opened for serving: its header parsed once, its tile records read on demand.
//!
//! Opening reads only the header (one bounded read, checked by its CRC); each tile request
//! then reads one record at a known offset, so a dataset of any size costs its index in
//! memory. Records carry their own CRC: a flipped bit fails that tile, not the dataset.

use std::fs::File;
use std::hash::{Hash, Hasher};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use zerotile_codec::bintree::Hierarchy;
use zerotile_codec::container::{
    Container, Fixed, Limits, Metadata, TileId, TileRecord, FIXED_LEN,
};
use zerotile_codec::geo::{Scheme, Tiling};

/// A dataset ready for tile requests.
#[derive(Debug)]
pub struct Dataset {
    /// The URL name: the file's stem.
    pub name: String,
    pub path: PathBuf,
    pub container: Container,
    pub tiling: Tiling,
    /// Per tile side: the mesher's tables, shared by every tile of the dataset.
    pub hierarchy: Hierarchy,
    /// Identifies this build of the dataset (its header and size): part of every ETag, so
    /// re-ingesting invalidates client caches.
    pub version: u64,
    file: File,
    file_len: u64,
}

impl Dataset {
    /// Opens `path`, checks its header and that every record lies inside the file.
    pub fn open(path: &Path) -> Result<Self> {
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        crate::ingest::check_name(&name)?;
        let file = File::open(path).with_context(|| format!("opening {}", path.display()))?;
        let file_len = file.metadata()?.len();

        // The fixed part says how long the header is; read exactly that.
        let limits = Limits::default();
        let mut fixed = [0u8; FIXED_LEN];
        file.read_exact_at(&mut fixed, 0)
            .context("reading the fixed header")?;
        let fixed = Fixed::parse(&fixed, &limits)?;
        if fixed.header_len as u64 > file_len {
            bail!(
                "header of {} bytes in a {file_len}-byte file",
                fixed.header_len
            );
        }
        let mut header = vec![0u8; fixed.header_len];
        file.read_exact_at(&mut header, 0)
            .context("reading the header")?;
        let container = Container::parse(&header, &limits)?;

        // Records must lie inside the file: a truncated copy is refused whole.
        if let Some((id, _)) = container
            .tiles()
            .find(|(_, e)| e.offset.saturating_add(u64::from(e.len)) > file_len)
        {
            bail!("tile {id} record ends past the end of the file (truncated copy?)");
        }
        let m = &container.metadata;
        let tiling = tiling_of(m)?;
        let hierarchy = Hierarchy::new(m.tile_side)
            .with_context(|| format!("tile side {} is not 2^n + 1", m.tile_side))?;
        if container.tiles().any(|(id, _)| id.z > tiling.max_zoom()) {
            bail!("tiles deeper than the tiling's zoom {}", tiling.max_zoom());
        }

        let mut h = std::collections::hash_map::DefaultHasher::new();
        header.hash(&mut h);
        file_len.hash(&mut h);
        Ok(Self {
            name,
            path: path.to_path_buf(),
            container,
            tiling,
            hierarchy,
            version: h.finish(),
            file,
            file_len,
        })
    }

    pub fn metadata(&self) -> &Metadata {
        &self.container.metadata
    }

    pub fn has_tile(&self, id: TileId) -> bool {
        self.container.entry(id).is_some()
    }

    /// Reads and checks one tile record: corners and EZW stream (blocking file I/O).
    pub fn read_tile(&self, id: TileId) -> Result<OwnedRecord> {
        let entry = self
            .container
            .entry(id)
            .with_context(|| format!("tile {id} is not in {}", self.name))?;
        debug_assert!(entry.offset + u64::from(entry.len) <= self.file_len);
        let mut bytes = vec![0u8; entry.len as usize];
        self.file
            .read_exact_at(&mut bytes, entry.offset)
            .with_context(|| format!("reading tile {id} of {}", self.path.display()))?;
        let rec = TileRecord::parse(id, &bytes, &entry)?;
        let corners = rec.corners;
        let stream_start = bytes.len() - rec.stream.len();
        bytes.drain(..stream_start);
        Ok(OwnedRecord {
            corners,
            stream: bytes,
        })
    }
}

/// A checked tile record, owned.
#[derive(Clone, Debug)]
pub struct OwnedRecord {
    pub corners: [f64; 4],
    pub stream: Vec<u8>,
}

/// The tiling a dataset's metadata names.
pub fn tiling_of(m: &Metadata) -> Result<Tiling> {
    let scheme = match m.scheme.as_str() {
        "geodetic" => Scheme::Geodetic,
        "mercator" => Scheme::Mercator,
        "local" => Scheme::Local {
            rows: m.source_size[0],
            cols: m.source_size[1],
        },
        other => bail!("unknown tiling scheme {other:?}"),
    };
    let side = u32::try_from(m.tile_side).context("tile side")?;
    Ok(Tiling::new(scheme, side)?)
}
