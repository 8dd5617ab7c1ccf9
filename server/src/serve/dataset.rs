//! One dataset opened for serving: its header parsed once, its tile records read on demand.
//!
//! Opening reads only the header (one bounded read, checked by its CRC); each tile request
//! then reads one record at a known offset, so a dataset of any size costs its index in
//! memory, and a dataset in an object store costs one range request per tile. Records carry
//! their own CRC: a flipped bit fails that tile, not the dataset.

use std::hash::{Hash, Hasher};
use std::path::Path;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use object_store::ObjectStore;
use zerotile_codec::bintree::Hierarchy;
use zerotile_codec::container::{
    Container, Fixed, Limits, Metadata, TileId, TileRecord, FIXED_LEN,
};
use zerotile_codec::geo::Tiling;

use super::storage::Source;

/// A dataset ready for tile requests.
#[derive(Debug)]
pub struct Dataset {
    /// The URL name: the file's stem.
    pub name: String,
    /// Where it was read from (a path or a store URL), for messages.
    pub location: String,
    pub container: Container,
    pub tiling: Tiling,
    /// The mesher's tables for the dataset's tile side, shared by every dataset of that side.
    pub hierarchy: Arc<Hierarchy>,
    /// Identifies this build of the dataset (its header and size): part of every ETag, so
    /// re-ingesting invalidates client caches, and the same file gives the same ETags from
    /// local disk or a store (replicas agree behind one CDN).
    pub version: u64,
    source: Source,
    len: u64,
    /// The file's modification time when it was opened: a tile that fails its checks in a
    /// file modified since was written over in place, not corrupt.
    opened_modified: Option<std::time::SystemTime>,
}

/// A tile read failed because the dataset's file was written over in place since it was
/// opened (`cp` onto it): the next rescan opens the new file, so it is worth a retry.
#[derive(Debug, thiserror::Error)]
#[error("{0} was written over since it was opened")]
pub struct ChangedOnDisk(pub String);

impl Dataset {
    /// Opens a local file, checks its header and that every record lies inside the file.
    pub fn open(path: &Path) -> Result<Self> {
        Self::open_as(path, &path.display().to_string())
    }

    /// [`Dataset::open`], its failure to open the file told under `shown`: a server lists
    /// skipped files to any client by their names in its folder, not by its own paths.
    pub fn open_as(path: &Path, shown: &str) -> Result<Self> {
        Self::open_file(path, shown, true)
    }

    /// [`Dataset::open`] whatever the file is called: `info` describes a copy named
    /// `n44.v2.ztd` too, which only serving it under that name would refuse.
    pub fn open_any_name(path: &Path) -> Result<Self> {
        Self::open_file(path, &path.display().to_string(), false)
    }

    fn open_file(path: &Path, shown: &str, named: bool) -> Result<Self> {
        // Only a regular file (see `regular_file`): opening a FIFO blocks until something
        // writes to it (a server that found one named `x.ztd` never started, or stopped
        // rescanning).
        let (file, meta) =
            crate::regular_file::open(path).with_context(|| format!("opening {shown}"))?;
        let mut d = Self::from_source(
            path.file_stem().map(|s| s.to_string_lossy().into_owned()),
            path.display().to_string(),
            Source::File(file),
            meta.len(),
            named,
        )?;
        d.opened_modified = meta.modified().ok();
        Ok(d)
    }

    /// Opens an object of a store, as [`Dataset::open`] does a file.
    pub fn open_object(
        store: &Arc<dyn ObjectStore>,
        meta: &object_store::ObjectMeta,
    ) -> Result<Self> {
        let name = meta
            .location
            .filename()
            .and_then(|f| f.rsplit_once('.'))
            .map(|(stem, _)| stem.to_string());
        Self::from_source(
            name,
            format!("{store}/{}", meta.location),
            Source::Object {
                store: Arc::clone(store),
                path: meta.location.clone(),
            },
            meta.size,
            true,
        )
    }

    fn from_source(
        name: Option<String>,
        location: String,
        source: Source,
        len: u64,
        named: bool,
    ) -> Result<Self> {
        let name = name.unwrap_or_default();
        if named {
            crate::ingest::check_name(&name)?;
        }

        // The fixed part says how long the header is; read exactly that.
        let limits = Limits::default();
        if len < FIXED_LEN as u64 {
            bail!("{len} bytes: shorter than the fixed header");
        }
        let fixed = source
            .read_at(0, FIXED_LEN)
            .context("reading the fixed header")?;
        let fixed = Fixed::parse(&fixed, &limits)?;
        if fixed.header_len as u64 > len {
            bail!("header of {} bytes in a {len}-byte file", fixed.header_len);
        }
        let header = source
            .read_at(0, fixed.header_len)
            .context("reading the header")?;
        let container = Container::parse(&header, &limits)?;

        // Records must lie inside the file: a truncated copy is refused whole.
        if let Some((id, _)) = container
            .tiles()
            .find(|(_, e)| e.offset.saturating_add(u64::from(e.len)) > len)
        {
            bail!("tile {id} record ends past the end of the file (truncated copy?)");
        }
        let m = &container.metadata;
        let tiling = m.tiling().map_err(anyhow::Error::msg)?;
        let hierarchy = shared_hierarchy(m.tile_side)
            .with_context(|| format!("tile side {} is not 2^n + 1", m.tile_side))?;
        if container.tiles().any(|(id, _)| id.z > tiling.max_zoom()) {
            bail!("tiles deeper than the tiling's zoom {}", tiling.max_zoom());
        }

        let mut h = std::collections::hash_map::DefaultHasher::new();
        header.hash(&mut h);
        len.hash(&mut h);
        Ok(Self {
            name,
            location,
            container,
            tiling,
            hierarchy,
            version: h.finish(),
            source,
            len,
            opened_modified: None,
        })
    }

    pub fn metadata(&self) -> &Metadata {
        &self.container.metadata
    }

    /// [`Self::version`] as clients see it: the dataset description's and layer.json's
    /// `version`, and the `?v=` that busts caches in the tile URLs the manifests list.
    pub fn version_tag(&self) -> String {
        format!("{:016x}", self.version)
    }

    /// The device and inode of the file this dataset reads (`None` for an object): a rescan
    /// keeps this build in service past a new file that fails to open only when the new one
    /// is another file, renamed over it; written over in place, the old build's bytes are
    /// gone with it.
    pub fn file_id(&self) -> Option<(u64, u64)> {
        use std::os::unix::fs::MetadataExt;
        match &self.source {
            Source::File(f) => f.metadata().ok().map(|m| (m.dev(), m.ino())),
            Source::Object { .. } => None,
        }
    }

    pub fn has_tile(&self, id: TileId) -> bool {
        self.container.entry(id).is_some()
    }

    /// Reads and checks one tile record: corners and EZW stream (blocking I/O). A record that
    /// fails because the file was written over in place carries [`ChangedOnDisk`], and the
    /// watcher is asked to rescan now rather than at its next period.
    pub fn read_tile(&self, id: TileId) -> Result<OwnedRecord> {
        self.read_record(id).map_err(|e| {
            if self.changed_on_disk() {
                super::reload::rescan_soon();
                e.context(ChangedOnDisk(self.name.clone()))
            } else {
                e
            }
        })
    }

    /// Whether the open file's length or modification time moved since it was opened.
    fn changed_on_disk(&self) -> bool {
        match &self.source {
            Source::File(f) => f
                .metadata()
                .is_ok_and(|m| m.len() != self.len || m.modified().ok() != self.opened_modified),
            Source::Object { .. } => false,
        }
    }

    fn read_record(&self, id: TileId) -> Result<OwnedRecord> {
        let entry = self
            .container
            .entry(id)
            .with_context(|| format!("tile {id} is not in {}", self.name))?;
        debug_assert!(entry.offset + u64::from(entry.len) <= self.len);
        let mut bytes = self
            .source
            .read_at(entry.offset, entry.len as usize)
            .with_context(|| format!("reading tile {id} of {}", self.location))?;
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

/// The mesher's tables for tiles of `side` samples, built once a process: they are the same
/// for every dataset of that side, and a 257² hierarchy holds about 4 MB, which each dataset
/// used to build for itself (400 small datasets held 1.96 GB).
fn shared_hierarchy(side: usize) -> Option<Arc<Hierarchy>> {
    static BUILT: std::sync::Mutex<Vec<Arc<Hierarchy>>> = std::sync::Mutex::new(Vec::new());
    let mut built = BUILT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(h) = built.iter().find(|h| h.side() == side) {
        return Some(Arc::clone(h));
    }
    let h = Arc::new(Hierarchy::new(side)?);
    built.push(Arc::clone(&h));
    Some(h)
}

/// A checked tile record, owned.
#[derive(Clone, Debug)]
pub struct OwnedRecord {
    pub corners: [f64; 4],
    pub stream: Vec<u8>,
}
