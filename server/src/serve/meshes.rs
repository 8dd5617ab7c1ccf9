//! Object meshes of the data folder (`DATA/meshes/*.obj|ply|stl`) and their LODs.
//!
//! Meshes are read and repaired once, at start, upload or when their file changes (the
//! rescan is [`super::mesh_reload`]). LOD structures are built on first use and kept with
//! the mesh (the view sphere, the octree and the nested curvature levels
//! once per mesh); answers are cached by bytes. Uploads are size-limited, validated and written atomically
//! before they replace anything.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError, RwLock, RwLockReadGuard, RwLockWriteGuard};
use std::time::Duration;

use anyhow::Result;
use quick_cache::sync::Cache;
use quick_cache::Weighter;
use zerotile_codec::mesh::curvature::{self, CurvatureOptions, Level, PAPER_LEVELS};
use zerotile_codec::mesh::io::{self, Format, MeshLimits};
use zerotile_codec::mesh::silhouette::ViewSphere;
use zerotile_codec::mesh::{repair, TriMesh};
use zerotile_codec::mesh::{OctreeLod, OctreeOptions};

use super::built_once::{BuildError, BuiltOnce};
use super::mesh_reload::Seen;

/// Folder of meshes inside the data folder.
pub const MESH_DIR: &str = "meshes";

/// Largest upload, bytes (also the largest file read at start).
pub const MAX_UPLOAD_BYTES: usize = 64 << 20;

/// Largest mesh served, faces: LOD structures hold a few copies of it.
pub const MAX_FACES: usize = 2_000_000;

/// Faces the served meshes may hold together before uploads are refused (`serve
/// --mesh-quota`): five of the largest. Each mesh is kept in memory with the LOD structures
/// it is asked for (a 2M-face mesh ~47 MB, its curvature levels as much again), and
/// without a bound, uploads under new names would grow the server until it is killed.
pub const DEFAULT_MESH_QUOTA: u64 = 10_000_000;

/// What the quota charges a mesh at the least, in faces: its entry, file and cached answers
/// cost something however small it is, so one-triangle uploads under ever new names
/// cannot grow the catalog without bound (the default quota holds 1,000 of them).
pub const SMALLEST_CHARGE: u64 = 10_000;

/// A mesh's charge against the quota.
fn charge(faces: usize) -> u64 {
    (faces as u64).max(SMALLEST_CHARGE)
}

/// One mesh, repaired, with its LOD structures built when first asked for.
pub struct MeshEntry {
    pub name: String,
    pub mesh: TriMesh,
    /// A hash of the mesh as served (after repair), which names its cached answers and
    /// their ETags: a replacement with other content never matches an old answer, in this
    /// process or after a restart (a count of loads, which restarts from 1, gave a mesh
    /// replaced before a restart its predecessor's tags, and a revalidating client a 304 for
    /// the old mesh).
    pub content: u64,
    pub source: PathBuf,
    /// The file's triangles that repair dropped (no area, a repeated vertex, or the corners
    /// of an earlier face): a mesh that lost some is no longer the file's.
    pub faces_dropped: usize,
    silhouette: BuiltOnce<ViewSphere>,
    octree: BuiltOnce<OctreeLod>,
    curvature: BuiltOnce<Vec<Level>>,
}

/// A mesh's LOD structures, each built on first use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Structure {
    CurvatureLevels,
    Octree,
    ViewSphere,
}

impl Structure {
    pub fn name(self) -> &'static str {
        match self {
            Self::CurvatureLevels => "curvature levels",
            Self::Octree => "octree",
            Self::ViewSphere => "view sphere",
        }
    }
}

impl MeshEntry {
    pub(super) fn new(name: String, read: Repaired, source: PathBuf) -> Self {
        Self {
            name,
            content: content_hash(&read.mesh),
            mesh: read.mesh,
            faces_dropped: read.faces_dropped,
            source,
            silhouette: BuiltOnce::default(),
            octree: BuiltOnce::default(),
            curvature: BuiltOnce::default(),
        }
    }

    /// How long another request has been building `s`, while it is under way.
    pub fn building_for(&self, s: Structure) -> Option<Duration> {
        match s {
            Structure::CurvatureLevels => self.curvature.building_for(),
            Structure::Octree => self.octree.building_for(),
            Structure::ViewSphere => self.silhouette.building_for(),
        }
    }

    /// The octree hierarchy, built once.
    pub fn octree(&self) -> Result<&OctreeLod, BuildError> {
        self.octree.get_or_build(|| {
            OctreeLod::build(&self.mesh, &OctreeOptions::default()).map_err(|e| e.to_string())
        })
    }

    /// The nested curvature levels cut at the paper's ε, built once: one continuing
    /// decimation gives all of them for the price of the coarsest.
    pub fn curvature_levels(&self) -> Result<&[Level], BuildError> {
        self.curvature
            .get_or_build(|| {
                curvature::levels(&self.mesh, &PAPER_LEVELS, &CurvatureOptions::default())
                    .map_err(|e| e.to_string())
            })
            .map(Vec::as_slice)
    }

    /// The view sphere, built once.
    pub fn view_sphere(&self) -> Result<&ViewSphere, BuildError> {
        self.silhouette
            .get_or_build(|| ViewSphere::new(&self.mesh).map_err(|e| e.to_string()))
    }
}

/// An encoded LOD answer.
#[derive(Debug)]
pub struct MeshAnswer {
    pub bytes: bytes::Bytes,
    pub vertices: usize,
    pub faces: usize,
    /// The method's own error figure (ε, level, or the QEM error), for `X-Error`.
    pub error: f64,
    /// The deepest level of a level-indexed method, for `X-Max-Level`.
    pub max_level: Option<u32>,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct AnswerBytes;

impl Weighter<u64, Arc<MeshAnswer>> for AnswerBytes {
    fn weight(&self, _key: &u64, val: &Arc<MeshAnswer>) -> u64 {
        val.bytes.len() as u64 + 64
    }
}

/// The meshes, by name, and the answer cache.
pub struct MeshCatalog {
    pub(super) dir: PathBuf,
    /// `serve --read-only`: uploads are refused though there is a folder to keep them in.
    read_only: bool,
    /// [`DEFAULT_MESH_QUOTA`] unless set.
    quota: u64,
    entries: RwLock<BTreeMap<String, Arc<MeshEntry>>>,
    /// Held from an upload's write to its insert, so the file on disk and the mesh served
    /// are the same upload's when two arrive for one name (and an upload under another
    /// extension cannot remove the file the other just wrote), and through a rescan of the
    /// folder. Uploads are rare; the parsing and repair, their cost, happen before it is
    /// taken. It guards what the last rescan found.
    pub(super) store: Mutex<Seen>,
    /// Mesh files not served, with the reason, as of the last rescan: apart from the store
    /// lock, which a rescan holds while it reads meshes, so `/v1/meshes` never waits on it.
    pub(super) skipped: RwLock<Vec<(String, String)>>,
    pub answers: Cache<u64, Arc<MeshAnswer>, AnswerBytes>,
}

/// Read limits for served meshes.
pub fn limits() -> MeshLimits {
    MeshLimits {
        max_faces: MAX_FACES,
        max_vertices: MAX_FACES,
        max_bytes: MAX_UPLOAD_BYTES as u64,
        ..MeshLimits::default()
    }
}

impl MeshCatalog {
    /// No meshes (uploads are refused: there is no folder to keep them in).
    pub fn empty(answer_bytes: u64) -> Self {
        Self::with_entries(PathBuf::new(), BTreeMap::new(), answer_bytes)
    }

    fn with_entries(
        dir: PathBuf,
        entries: BTreeMap<String, Arc<MeshEntry>>,
        answer_bytes: u64,
    ) -> Self {
        let items = (answer_bytes / 200_000).clamp(16, 1 << 16) as usize;
        // One shard: quick_cache admits nothing heavier than a shard's hot share, and by
        // default a shard is 1/(4 × cores) of the budget, so an 11 MB answer (the bunny's
        // `curvature?error=0.3`, half a minute of work) was never kept and every ask of it
        // was computed again. Answers are few and slow to make; a lock held for a lookup
        // costs nothing beside them.
        let options = quick_cache::OptionsBuilder::new()
            .shards(1)
            .estimated_items_capacity(items)
            .weight_capacity(answer_bytes.max(1))
            .build()
            .unwrap_or_else(|_| unreachable!("both capacities are set"));
        Self {
            dir,
            read_only: false,
            quota: DEFAULT_MESH_QUOTA,
            entries: RwLock::new(entries),
            store: Mutex::new(Seen::default()),
            skipped: RwLock::default(),
            answers: Cache::with_options(
                options,
                AnswerBytes,
                Default::default(),
                Default::default(),
            ),
        }
    }

    /// Opens `data/meshes` (absent: an empty catalog). A mesh that fails to read is logged
    /// and skipped; of two files of one name, the first in name order (json, obj, ply, stl)
    /// that reads is served.
    pub fn open(data: &Path, answer_bytes: u64) -> Self {
        let catalog = Self::with_entries(data.join(MESH_DIR), BTreeMap::new(), answer_bytes);
        if let Err(e) = catalog.rescan(true) {
            tracing::warn!("reading the meshes: {e:#}");
        }
        catalog
    }

    /// Refuses uploads from now on (`serve --read-only`): a server anyone can reach would
    /// otherwise let anyone fill its disk and memory with meshes.
    pub fn read_only(mut self) -> Self {
        self.read_only = true;
        self
    }

    /// Sets the faces the served meshes may hold together ([`DEFAULT_MESH_QUOTA`]). Meshes
    /// in the folder at start are all served, whatever they hold; uploads that would pass
    /// the quota are refused.
    pub fn with_quota(mut self, faces: u64) -> Self {
        self.quota = faces;
        self
    }

    /// Whether an upload could be kept, asked before its body is read.
    pub fn takes_uploads(&self) -> Result<(), UploadError> {
        if self.read_only {
            Err(UploadError::ReadOnly)
        } else if self.dir.as_os_str().is_empty() {
            Err(UploadError::NoFolder)
        } else {
            Ok(())
        }
    }

    pub fn list(&self) -> Vec<Arc<MeshEntry>> {
        self.served().values().cloned().collect()
    }

    pub fn get(&self, name: &str) -> Option<Arc<MeshEntry>> {
        self.served().get(name).cloned()
    }

    /// The served meshes. A poisoned lock is taken as it is: every write is one insert or a
    /// whole map swapped in, so the map is sound whatever panicked, and refusing it would
    /// answer every mesh 404 until a restart.
    pub(super) fn served(&self) -> RwLockReadGuard<'_, BTreeMap<String, Arc<MeshEntry>>> {
        self.entries.read().unwrap_or_else(PoisonError::into_inner)
    }

    /// [`MeshCatalog::served`] to change.
    pub(super) fn served_mut(&self) -> RwLockWriteGuard<'_, BTreeMap<String, Arc<MeshEntry>>> {
        self.entries.write().unwrap_or_else(PoisonError::into_inner)
    }

    /// Mesh files of the folder not served, with the reason, as of the last rescan.
    pub fn skipped(&self) -> Vec<(String, String)> {
        self.skipped
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// Validates `bytes` as a mesh, writes it atomically as `meshes/NAME.EXT` (replacing an
    /// older file of that name only once the new one is whole) and serves it from now on,
    /// if `put` allows it, judged under the store lock the rescan takes (so a rescan that
    /// removes or adds the mesh while an upload's body is read cannot slip past it). Also
    /// says whether a mesh of that name was replaced (HTTP tells 200 from 201 by it).
    pub fn upload(
        &self,
        name: &str,
        bytes: &[u8],
        format: Option<Format>,
        put: Put,
    ) -> Result<(Arc<MeshEntry>, bool), UploadError> {
        self.upload_unless(name, bytes, format, put, None)
    }

    /// [`MeshCatalog::upload`], refused too where `refuses` says so of the mesh served under
    /// the name, judged under the same lock (an `If-None-Match` of tags, which only the
    /// route can compare: a mesh placed while the body was read is judged, not only the one
    /// there before).
    pub fn upload_unless(
        &self,
        name: &str,
        bytes: &[u8],
        format: Option<Format>,
        put: Put,
        refuses: Option<Refuses>,
    ) -> Result<(Arc<MeshEntry>, bool), UploadError> {
        self.takes_uploads()?;
        let read = io::read_bytes(bytes, format, &limits()).map_err(anyhow::Error::from);
        let served = read
            .and_then(|m| repaired(&m))
            .map_err(UploadError::Invalid)?;
        let format = format
            .or_else(|| Format::sniff(bytes))
            .unwrap_or(Format::Obj);
        // Stored as sent (a readable format: read_bytes refused anything else), under the
        // extension `open` reads it back by.
        let path = self.dir.join(format!("{name}.{}", format.extension()));
        // A poisoned lock (a rescan's reader that panicked) guards only a cache of stamps.
        let mut seen = self.store.lock().unwrap_or_else(PoisonError::into_inner);
        match (put, self.get(name)) {
            (Put::Replace, None) => return Err(UploadError::Gone),
            (Put::Create, Some(_)) => return Err(UploadError::Exists),
            (_, Some(e)) if refuses.as_ref().is_some_and(|f| f(&e)) => {
                return Err(UploadError::Matched)
            }
            _ => {}
        }
        // Under the store lock, so two uploads cannot both take the last room. A mesh
        // replaced frees its own charge.
        let held: u64 = self
            .list()
            .iter()
            .filter(|e| e.name != name)
            .map(|e| charge(e.mesh.face_count()))
            .sum();
        let faces = served.mesh.face_count();
        if held.saturating_add(charge(faces)) > self.quota {
            return Err(UploadError::Quota {
                held,
                quota: self.quota,
                faces,
            });
        }
        crate::ingest::write_atomically(&path, bytes).map_err(UploadError::Store)?;
        // An older upload under another extension would shadow this one at the next start.
        for other in Format::READABLE.iter().filter(|&&f| f != format) {
            let _ = std::fs::remove_file(self.dir.join(format!("{name}.{}", other.extension())));
        }
        // The rescan then knows the file for the one it has just been read as.
        self.uploaded(&mut seen, name, &path);
        let entry = Arc::new(MeshEntry::new(name.to_string(), served, path));
        let mut map = self.served_mut();
        let replaced = map.insert(name.to_string(), entry.clone()).is_some();
        Ok((entry, replaced))
    }
}

/// Whether an upload may not go over the mesh served now; see [`MeshCatalog::upload_unless`].
pub type Refuses = Box<dyn Fn(&MeshEntry) -> bool + Send>;

/// What an upload may do to a mesh of its name: HTTP's `If-Match: *` and `If-None-Match: *`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Put {
    /// Create it or replace it.
    Any,
    /// Only replace one served.
    Replace,
    /// Only create one.
    Create,
}

/// Why an upload was not stored: the client's mesh, or this server.
#[derive(Debug, thiserror::Error)]
pub enum UploadError {
    /// The body is not a mesh this server serves (unreadable, too large, no surface).
    #[error("{0:#}")]
    Invalid(anyhow::Error),
    /// The server reads its data from an object store and has no folder to keep meshes in.
    #[error("this server has no mesh folder to store uploads in")]
    NoFolder,
    /// The server was started with `--read-only`.
    #[error("this server takes no uploads (serve --read-only)")]
    ReadOnly,
    /// Keeping the mesh would pass the quota of faces the served meshes may hold.
    #[error(
        "the served meshes hold {held} faces of the {quota} this server keeps (serve \
         --mesh-quota; each mesh counts as at least {SMALLEST_CHARGE}); this one has {faces}: \
         replace a mesh of the same name or ask the operator for room"
    )]
    Quota { held: u64, quota: u64, faces: usize },
    /// A [`Put::Replace`] found no mesh of its name: it was removed (a rescan) while the
    /// body was read.
    #[error("no mesh of this name is served, and If-Match: * replaces only")]
    Gone,
    /// A [`Put::Create`] found a mesh of its name (one placed meanwhile, or there all along).
    #[error("a mesh of this name is served, and If-None-Match: * creates only")]
    Exists,
    /// The mesh served is one the upload's `If-None-Match` names (placed meanwhile, or there
    /// all along).
    #[error(
        "If-None-Match names the mesh served under this name, and the upload would replace it"
    )]
    Matched,
    /// The mesh was fine; writing it was not.
    #[error("storing the mesh: {0:#}")]
    Store(anyhow::Error),
}

/// [`MeshEntry::content`]: every coordinate's bits and every index.
fn content_hash(mesh: &TriMesh) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    mesh.positions.len().hash(&mut h);
    for p in &mesh.positions {
        p.to_array().map(f64::to_bits).hash(&mut h);
    }
    mesh.faces.hash(&mut h);
    h.finish()
}

/// A file's mesh as served, with the count of its triangles repair dropped.
#[derive(Debug)]
pub(super) struct Repaired {
    pub mesh: TriMesh,
    pub faces_dropped: usize,
}

/// The served mesh read from `path`. Errors do not name the path: the rescan's log line and
/// `/v1/meshes`' skipped entry name the file, and the listing is public, so the server's
/// folder stays out of it.
pub(super) fn load(path: &Path) -> Result<Repaired> {
    // Opened without blocking: the file a rescan listed may be a FIFO by now.
    let (file, _) = crate::regular_file::open(path)?;
    let mesh = io::read_file(file, path, &limits())?;
    repaired(&mesh)
}

/// The repaired mesh, or why it cannot be served: repair drops the faces without area, and a
/// mesh left with none has no surface to simplify or view (QEM's error, a fraction of the
/// diagonal, has nothing to measure against).
fn repaired(mesh: &TriMesh) -> Result<Repaired> {
    // GLB and binary PLY store f32: a finite f64 past its range would make every such
    // answer fail (GLB) or carry infinities (PLY).
    let limit = f64::from(f32::MAX);
    if let Some((i, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| p.abs().max_element() > limit)
    {
        anyhow::bail!(
            "vertex {} at {p} lies beyond ±{limit:e}, the range of the f32 coordinates GLB and \
             PLY answers carry",
            i + 1
        );
    }
    let (clean, _) = repair(mesh)?;
    has_surface(&clean)?;
    Ok(Repaired {
        faces_dropped: mesh.face_count() - clean.face_count(),
        mesh: clean,
    })
}

/// Refuses a repaired mesh without faces, too large to measure, or whose faces all have zero
/// area. `eval mesh` asks the same, so it never reports distances for a mesh the server would
/// not take.
pub(crate) fn has_surface(clean: &TriMesh) -> Result<()> {
    const NO_AREA: &str = "the mesh has no valid faces: every face has zero area (its corners \
                           coincide or lie on one line)";
    // The file had faces (a reader refuses one without), so repair dropped them all, and
    // repair drops only faces without area and repeats of a face it keeps.
    if clean.faces.is_empty() {
        anyhow::bail!(NO_AREA);
    }
    // Distances are fractions of the diagonal: past f64 (two small triangles ±1.7e308 apart)
    // it is infinite or NaN, and a simplification that dropped one of them measured 0 %.
    let diagonal = clean.diagonal();
    if !diagonal.is_finite() {
        anyhow::bail!(
            "the mesh spans more than the f64 range (its bounding box's diagonal is {diagonal}): \
             too large to measure"
        );
    }
    let areas = clean.face_areas();
    // Past ~1e77 apart a face's area overflows (uploads stop at 3.4e38; `eval mesh` does
    // not): areas weigh the distance samples, so an infinite one makes every figure NaN.
    if let Some(f) = areas.iter().position(|a| !a.is_finite()) {
        anyhow::bail!(
            "face {} has an area beyond the f64 range: the mesh is too large ({:e} across) to \
             measure",
            f + 1,
            diagonal
        );
    }
    // Corners ~1e-160 apart: a cross product that is not zero, whose length underflows.
    if !areas.iter().any(|&a| a > 0.0) {
        anyhow::bail!(NO_AREA);
    }
    Ok(())
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// One face over three distinct vertices at the same point: it survives repair (no
    /// repeated index) but has no area.
    const FLAT: &[u8] = b"v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n";
    pub(in crate::serve) const TRI: &[u8] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

    fn scratch(tag: &str) -> PathBuf {
        let dir = crate::fixtures::scratch(&format!("meshcat-{tag}"));
        std::fs::create_dir_all(dir.join(MESH_DIR)).unwrap();
        dir
    }

    /// An answer is kept whatever its size under the budget, not only under one shard's
    /// share of it (an 11 MB answer was computed again on every ask under 64 MiB).
    #[test]
    fn an_answer_of_most_of_the_budget_is_kept() {
        let budget = 64 << 20;
        let cat = MeshCatalog::empty(budget);
        let answer = |len: usize| {
            Arc::new(MeshAnswer {
                bytes: bytes::Bytes::from(vec![0u8; len]),
                vertices: 3,
                faces: 1,
                error: 0.0,
                max_level: None,
            })
        };
        cat.answers.insert(1, answer(11 << 20));
        assert!(cat.answers.get(&1).is_some(), "an 11 MiB answer");
        cat.answers.insert(2, answer(40 << 20));
        assert!(cat.answers.get(&2).is_some(), "a 40 MiB answer");
        // Over the budget: not kept, rather than kept by evicting everything and more.
        cat.answers.insert(3, answer(budget as usize + 1));
        assert!(cat.answers.get(&3).is_none());
    }

    #[test]
    fn a_mesh_without_area_is_refused_on_upload_and_skipped_at_start() {
        let dir = scratch("area");
        std::fs::write(dir.join(MESH_DIR).join("flat.obj"), FLAT).unwrap();
        std::fs::write(dir.join(MESH_DIR).join("tri.obj"), TRI).unwrap();
        let cat = MeshCatalog::open(&dir, 1 << 20);
        let names: Vec<String> = cat.list().iter().map(|e| e.name.clone()).collect();
        assert_eq!(names, ["tri"]);

        let Err(err) = cat.upload("g10", FLAT, Some(Format::Obj), Put::Any) else {
            panic!("a mesh without area was accepted");
        };
        assert!(format!("{err:#}").contains("zero area"), "{err:#}");
        assert!(cat.get("g10").is_none());
        assert!(!dir.join(MESH_DIR).join("g10.obj").exists());
        assert!(cat.upload("g10", TRI, Some(Format::Obj), Put::Any).is_ok());
        let huge = b"v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n";
        let Err(err) = cat.upload("huge", huge, Some(Format::Obj), Put::Any) else {
            panic!("a mesh beyond f32 was accepted");
        };
        assert!(format!("{err:#}").contains("vertex 2 at"), "{err:#}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    pub(in crate::serve) const QUAD_PLY: &[u8] =
        b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nelement face 2\nproperty list uchar int \
        vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";

    /// Of two files of one name the first in name order (json, obj, ply, stl) is served, so
    /// an upload in another format removes the older file: it would shadow the upload at the
    /// next start.
    #[test]
    fn an_upload_in_another_format_replaces_the_older_file() {
        let dir = scratch("formats");
        let meshes = dir.join(MESH_DIR);
        std::fs::write(meshes.join("a.obj"), TRI).unwrap();
        std::fs::write(meshes.join("a.ply"), QUAD_PLY).unwrap();
        let cat = MeshCatalog::open(&dir, 1 << 20);
        assert_eq!(cat.get("a").unwrap().mesh.face_count(), 1);

        std::fs::remove_file(meshes.join("a.ply")).unwrap();
        let (e, replaced) = cat
            .upload("a", QUAD_PLY, Some(Format::Ply), Put::Any)
            .unwrap();
        assert!(replaced);
        assert_eq!(e.source, meshes.join("a.ply"));
        assert!(!meshes.join("a.obj").exists());
        let reopened = MeshCatalog::open(&dir, 1 << 20);
        assert_eq!(reopened.get("a").unwrap().mesh.face_count(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A JSON mesh (what `?format=json` answers), sent without a format to sniff it by, is
    /// stored as JSON and read back as JSON at the next start; stored as `.obj`, it was
    /// served at once and then skipped as an OBJ with no faces.
    #[test]
    fn a_json_upload_is_stored_as_json_and_survives_a_restart() {
        let dir = scratch("json");
        let meshes = dir.join(MESH_DIR);
        std::fs::write(meshes.join("a.obj"), TRI).unwrap();
        let cat = MeshCatalog::open(&dir, 1 << 20);
        let quad = br#"{"positions": [0,0,0, 1,0,0, 1,1,0, 0,1,0], "indices": [0,1,2, 0,2,3]}"#;
        let (e, _) = cat.upload("a", quad, None, Put::Any).unwrap();
        assert_eq!(e.source, meshes.join("a.json"));
        assert_eq!(std::fs::read(meshes.join("a.json")).unwrap(), quad);
        assert!(!meshes.join("a.obj").exists());
        let reopened = MeshCatalog::open(&dir, 1 << 20);
        assert_eq!(reopened.get("a").unwrap().mesh.face_count(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Answers are cached under (name, content): an upload with other content gets a tag no
    /// entry had, one with the same content shares the old answers, and a restart over the
    /// same files gives the same tags.
    #[test]
    fn a_replacing_upload_gets_a_new_content_tag() {
        let dir = scratch("content");
        std::fs::write(dir.join(MESH_DIR).join("a.obj"), TRI).unwrap();
        std::fs::write(dir.join(MESH_DIR).join("b.obj"), TRI).unwrap();
        let cat = MeshCatalog::open(&dir, 1 << 20);
        let before: Vec<u64> = cat.list().iter().map(|e| e.content).collect();
        assert_eq!(before[0], before[1], "one mesh, one tag");
        let quad = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
        for name in ["b", "a"] {
            let (e, _) = cat.upload(name, quad, Some(Format::Obj), Put::Any).unwrap();
            assert!(!before.contains(&e.content), "{name}: {} reused", e.content);
            assert_eq!(cat.get(name).unwrap().mesh.face_count(), 2);
        }
        let reopened = MeshCatalog::open(&dir, 1 << 20);
        for name in ["a", "b"] {
            assert_eq!(
                reopened.get(name).unwrap().content,
                cat.get(name).unwrap().content
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// An n × n grid of quads at height `z`: as OBJ, or as the JSON `?format=json` answers.
    fn grid(n: usize, z: f64, json: bool) -> Vec<u8> {
        let points = (0..=n).flat_map(|r| (0..=n).map(move |c| (c as f64, r as f64)));
        let quads = (0..n).flat_map(|r| (0..n).map(move |c| r * (n + 1) + c));
        let faces = quads.flat_map(|k| [[k, k + 1, k + n + 2], [k, k + n + 2, k + n + 1]]);
        if json {
            let positions: Vec<f64> = points.flat_map(|(x, y)| [x, y, z]).collect();
            let indices: Vec<usize> = faces.flatten().collect();
            serde_json::to_vec(&serde_json::json!({"positions": positions, "indices": indices}))
                .unwrap()
        } else {
            let mut text: String = points.map(|(x, y)| format!("v {x} {y} {z}\n")).collect();
            for [a, b, c] in faces {
                text += &format!("f {} {} {}\n", a + 1, b + 1, c + 1);
            }
            text.into_bytes()
        }
    }

    /// Uploads to one name at once, in two formats: each succeeds, and when they are done the
    /// one file of the name on disk is the mesh served, whole, with no temporary file left.
    /// All writes shared one temporary file per process before, so most failed (ENOENT, a
    /// 422) and the file on disk could be another upload's than the one served, or torn.
    #[test]
    fn uploads_to_one_name_at_once_leave_the_served_mesh_on_disk() {
        let dir = scratch("race");
        let cat = MeshCatalog::open(&dir, 1 << 20);
        let bodies = [
            (grid(60, 1.0, false), Format::Obj),
            (grid(50, 2.0, true), Format::Json),
            (grid(70, 3.0, false), Format::Obj),
        ];
        for round in 0..4 {
            let start = std::sync::Barrier::new(6);
            std::thread::scope(|s| {
                for t in 0..6 {
                    let (body, format) = &bodies[(t + round) % bodies.len()];
                    let (cat, start) = (&cat, &start);
                    s.spawn(move || {
                        start.wait();
                        if let Err(e) = cat.upload("a", body, Some(*format), Put::Any) {
                            panic!("round {round}, upload {t}: {e}");
                        }
                    });
                }
            });
            let files: Vec<String> = std::fs::read_dir(dir.join(MESH_DIR))
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(files.len(), 1, "round {round}: {files:?}");
            let on_disk = MeshCatalog::open(&dir, 1 << 20);
            assert_eq!(
                on_disk.get("a").map(|e| e.content),
                cat.get("a").map(|e| e.content),
                "round {round}: the file {files:?} is not the mesh served"
            );
        }
    }
}
