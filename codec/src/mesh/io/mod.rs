//! Reading and writing object meshes: OBJ, PLY (ASCII and binary), STL (ASCII and binary) and
//! JSON in; OBJ, binary PLY, GLB (glTF 2.0 binary) and JSON out.
//!
//! Parsing is left to well-kept crates (`tobj`, `ply-rs-bw`, `stl_io`); this module adds what a
//! server needs around them: a format chosen by extension or by magic bytes, [`MeshLimits`]
//! checked before anything is sized from a header, polygons cut into triangles in their plane
//! ([`polygon`]), and the [`TriMesh::check`] contract (finite coordinates, indices in range) on every mesh returned.

mod glb;
mod json;
mod obj;
mod obj_locate;
mod ply;
mod polygon;
mod stl;

use std::borrow::Cow;
use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::error::{InvalidMesh, MeshError};
use super::indexed::TriMesh;

/// The mesh file formats this module knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    Obj,
    Ply,
    Stl,
    /// glTF 2.0 binary container (write only).
    Glb,
    /// `{"positions": [x, y, z, ...], "indices": [a, b, c, ...]}`.
    Json,
}

impl Format {
    /// The format a file name's extension names (case-insensitive), if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Self::from_extension(&ext)
    }

    /// The formats [`read_bytes`] reads (GLB is written only).
    pub const READABLE: [Self; 4] = [Self::Json, Self::Obj, Self::Ply, Self::Stl];

    /// The formats [`write_to`] writes (STL is read only).
    pub const WRITABLE: [Self; 4] = [Self::Obj, Self::Ply, Self::Glb, Self::Json];

    /// The file extension of the format, lower case: what [`Self::from_extension`] reads back.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Obj => "obj",
            Self::Ply => "ply",
            Self::Stl => "stl",
            Self::Glb => "glb",
            Self::Json => "json",
        }
    }

    /// `"obj"`, `"ply"`, `"stl"`, `"glb"`, `"json"` (case-insensitive).
    pub fn from_extension(ext: &str) -> Option<Self> {
        match ext.to_ascii_lowercase().as_str() {
            "obj" => Some(Self::Obj),
            "ply" => Some(Self::Ply),
            "stl" => Some(Self::Stl),
            "glb" => Some(Self::Glb),
            "json" => Some(Self::Json),
            _ => None,
        }
    }

    /// Guesses the format from the first bytes, for uploads that carry no file name.
    /// Binary STL has no magic: it is recognised by its exact length (84 + 50 × count).
    pub fn sniff(bytes: &[u8]) -> Option<Self> {
        let text = skip_bom_and_space(bytes);
        if without_bom(bytes).starts_with(b"ply") {
            Some(Self::Ply)
        } else if bytes.starts_with(b"glTF") {
            Some(Self::Glb)
        } else if stl::is_binary(bytes) || text.starts_with(b"solid") {
            Some(Self::Stl)
        } else if text.starts_with(b"{") {
            Some(Self::Json)
        } else if obj::looks_like_obj(text) {
            Some(Self::Obj)
        } else {
            None
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Obj => "OBJ",
            Self::Ply => "PLY",
            Self::Stl => "STL",
            Self::Glb => "GLB",
            Self::Json => "JSON",
        }
    }
}

fn without_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}

/// `bytes` as text for a reader that wants UTF-8, each byte of an invalid sequence replaced
/// by `?`: mesh numbers and keywords are ASCII, and old exporters write Latin-1 in comments
/// and names. One byte for one keeps the copy the input's size, where
/// `String::from_utf8_lossy`'s three-byte U+FFFD tripled it for binary-looking input.
fn lenient_text(bytes: &[u8]) -> Cow<'_, str> {
    if let Ok(text) = std::str::from_utf8(bytes) {
        return text.into();
    }
    let mut text = String::with_capacity(bytes.len());
    push_lenient(&mut text, bytes);
    text.into()
}

/// Appends `bytes` to `text` as [`lenient_text`] reads them.
fn push_lenient(text: &mut String, bytes: &[u8]) {
    for chunk in bytes.utf8_chunks() {
        text.push_str(chunk.valid());
        text.extend(std::iter::repeat_n('?', chunk.invalid().len()));
    }
}

fn skip_bom_and_space(bytes: &[u8]) -> &[u8] {
    let b = without_bom(bytes);
    let start = b
        .iter()
        .position(|c| !c.is_ascii_whitespace())
        .unwrap_or(b.len());
    &b[start..]
}

/// Resource limits for reading untrusted meshes. Checked against header counts before any
/// buffer is sized from them, and against the result after parsing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshLimits {
    /// Most vertices accepted (after welding where the format welds, as STL does).
    pub max_vertices: usize,
    /// Most triangles accepted, after polygons are cut into triangles.
    pub max_faces: usize,
    /// Largest input in bytes.
    pub max_bytes: u64,
    /// Most corners of one polygon that is not convex. Such a polygon is ear-clipped, in time
    /// growing with the square of its corners; a convex one is fanned, whatever its size.
    pub max_polygon_corners: usize,
}

/// 5 million triangles: a 1.1 M-face scan with room to spare, ~250 MB of OBJ text.
pub const DEFAULT_MAX_FACES: usize = 5_000_000;
/// As many vertices as faces: closed meshes have half as many, unwelded ones up to three times.
pub const DEFAULT_MAX_VERTICES: usize = 5_000_000;
/// 512 MiB of input.
pub const DEFAULT_MAX_BYTES: u64 = 512 << 20;
/// A floor plan's or a lettering's outline has some hundreds. At this size ear clipping took
/// 5–12 µs a corner for a simple polygon and 25 µs for a self-crossing tangle on a 2-core test
/// machine, so a 2M-triangle mesh of such polygons is read in under a minute; beyond it the cost
/// keeps growing: one concave polygon of 100,000 corners took 9 s, 23 s as a tangle.
pub const DEFAULT_MAX_POLYGON_CORNERS: usize = 4096;

impl Default for MeshLimits {
    fn default() -> Self {
        Self {
            max_vertices: DEFAULT_MAX_VERTICES,
            max_faces: DEFAULT_MAX_FACES,
            max_bytes: DEFAULT_MAX_BYTES,
            max_polygon_corners: DEFAULT_MAX_POLYGON_CORNERS,
        }
    }
}

impl MeshLimits {
    fn vertices(&self, n: u64) -> Result<(), MeshError> {
        limit("vertices", n, self.max_vertices as u64)
    }

    fn faces(&self, n: u64) -> Result<(), MeshError> {
        limit("faces", n, self.max_faces as u64)
    }

    fn bytes(&self, n: u64) -> Result<(), MeshError> {
        limit("bytes", n, self.max_bytes)
    }

    fn polygon_corners(&self, n: u64) -> Result<(), MeshError> {
        limit(
            "the corners of a polygon that is not convex",
            n,
            self.max_polygon_corners as u64,
        )
    }
}

fn limit(what: &'static str, got: u64, limit: u64) -> Result<(), MeshError> {
    if got > limit {
        Err(MeshError::Limit { what, got, limit })
    } else {
        Ok(())
    }
}

/// Reads a mesh file, choosing the format by extension (or by content when the extension is
/// unknown). The file's size is checked against `limits` before it is read.
pub fn read_path(path: &Path, limits: &MeshLimits) -> Result<TriMesh, MeshError> {
    read_file(std::fs::File::open(path)?, path, limits)
}

/// [`read_path`] of a file already open (`path` names its format): a server opens it its
/// own way, so as not to block on a FIFO. No more than `limits` allows is read into memory,
/// even from a pipe, whose size says nothing, or a file that grows while it is read.
pub fn read_file(
    file: std::fs::File,
    path: &Path,
    limits: &MeshLimits,
) -> Result<TriMesh, MeshError> {
    use std::io::Read;
    // Refuse oversized files before reading them into memory.
    let len = file.metadata()?.len();
    limits.bytes(len)?;
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
    file.take(limits.max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    let by_name = Format::from_path(path);
    match read_bytes(&bytes, by_name, limits) {
        // Any text with a line starting `v` sniffs as OBJ: under a name that does not say
        // mesh, "no faces" would describe a README rather than refuse it.
        Err(MeshError::Invalid(InvalidMesh::Empty)) if by_name.is_none() => {
            Err(MeshError::Unsupported(format!(
                "not a mesh: the name does not end in .obj, .ply, .stl or .json, and read as {} \
                 by its content it has no faces",
                Format::sniff(&bytes).map_or("a mesh", Format::name)
            )))
        }
        other => other,
    }
}

/// Reads a mesh from bytes in `format`, or in the format [`Format::sniff`] recognises when
/// `format` is `None`.
pub fn read_bytes(
    bytes: &[u8],
    format: Option<Format>,
    limits: &MeshLimits,
) -> Result<TriMesh, MeshError> {
    // Size first: every parser below is bounded by the input length.
    limits.bytes(bytes.len() as u64)?;
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(MeshError::decode("mesh", "the input is empty"));
    }
    let format = match format.or_else(|| Format::sniff(bytes)) {
        Some(f) => f,
        None => {
            return Err(MeshError::Unsupported(
                "unrecognised mesh bytes (expected OBJ, PLY, STL or JSON)".into(),
            ))
        }
    };
    // Parse with the format's crate, counts checked against the limits on the way.
    let mesh = match format {
        // The text formats may start with a UTF-8 byte-order mark (editors on Windows write
        // one), which sniffing already skips: the parsers took it for part of the first line.
        // A PLY's header is text whatever its body, so a BOM before it goes too.
        Format::Obj => obj::read(without_bom(bytes), limits)?,
        Format::Ply => ply::read(without_bom(bytes), limits)?,
        Format::Stl => stl::read(bytes, limits)?,
        Format::Json => json::read(without_bom(bytes), limits)?,
        Format::Glb => {
            return Err(MeshError::Unsupported(
                "reading GLB is not supported; send OBJ, PLY, STL or JSON".into(),
            ))
        }
    };
    // The contract every algorithm relies on: finite numbers, indices in range, some faces.
    limits.vertices(mesh.positions.len() as u64)?;
    limits.faces(mesh.faces.len() as u64)?;
    mesh.check()?;
    if mesh.faces.is_empty() {
        return Err(InvalidMesh::Empty.into());
    }
    Ok(mesh)
}

/// Encodes `mesh` in `format`. Coordinates are written as f64 where the format allows (OBJ,
/// JSON) and f32 where it does not (PLY, GLB).
pub fn write_bytes(mesh: &TriMesh, format: Format) -> Result<Vec<u8>, MeshError> {
    let mut out = Vec::new();
    write_to(mesh, format, &mut out)?;
    Ok(out)
}

/// Encodes `mesh` in `format`, a mesh whose z is up (a terrain tile or view): as GLB, the
/// node turns it so that it lies flat under glTF's +Y up; other formats as [`write_bytes`].
pub fn write_z_up_bytes(mesh: &TriMesh, format: Format) -> Result<Vec<u8>, MeshError> {
    let mut out = Vec::new();
    match format {
        Format::Glb => glb::write(mesh, glb::Up::Z, None, &mut out)?,
        _ => write_to(mesh, format, &mut out)?,
    }
    Ok(out)
}

/// GLB of a z-up `mesh` (as [`write_z_up_bytes`]) with the vertex normals given, one a
/// vertex: for a mesh whose own would be wrong for shading, such as a terrain tile whose
/// skirts should shade as the edge they hang from.
pub fn write_z_up_glb_with_normals(
    mesh: &TriMesh,
    normals: &[DVec3],
) -> Result<Vec<u8>, MeshError> {
    let mut out = Vec::new();
    glb::write(mesh, glb::Up::Z, Some(normals), &mut out)?;
    Ok(out)
}

/// Encodes `mesh` in `format` into any writer.
pub fn write_to(mesh: &TriMesh, format: Format, out: &mut impl Write) -> Result<(), MeshError> {
    match format {
        Format::Obj => obj::write(mesh, out),
        Format::Ply => ply::write(mesh, out),
        Format::Glb => glb::write(mesh, glb::Up::Y, None, out),
        Format::Json => json::write(mesh, out),
        Format::Stl => Err(MeshError::Unsupported(
            "writing STL is not supported; use OBJ, PLY, GLB or JSON".into(),
        )),
    }
}

/// Writes `mesh` to `path` in the format its extension names, atomically: the bytes go to a
/// temporary file beside it which is then renamed over `path`, so readers never see half a file.
pub fn write_path(mesh: &TriMesh, path: &Path) -> Result<(), MeshError> {
    let format = Format::from_path(path).ok_or_else(|| {
        MeshError::Unsupported(format!(
            "{}: unknown extension (use .obj, .ply, .glb or .json)",
            path.display()
        ))
    })?;
    let bytes = write_bytes(mesh, format)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let written = std::fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(&bytes)?;
        f.sync_all()
    });
    match written.and_then(|()| std::fs::rename(&tmp, path)) {
        Ok(()) => Ok(()),
        Err(e) => {
            // Best effort: the write already failed, a leftover temp file is all we can fix.
            let _ = std::fs::remove_file(&tmp);
            Err(e.into())
        }
    }
}

#[cfg(test)]
mod tests;
