//! glTF 2.0 binary (GLB) writer, after the Khronos glTF 2.0 specification (§4.4 GLB file
//! format): a 12-byte header, a JSON chunk padded with spaces and a BIN chunk padded with
//! zeros, both to 4 bytes. One mesh, one triangle primitive: f32 POSITION (with the `min` /
//! `max` the specification requires), unit f32 NORMAL, u32 indices.
//!
//! f32 keeps 24 bits: a terrain tile in EPSG:3857 metres (x ~ 8·10⁶) would be stored to
//! half a metre, a 4.8 m grid at zoom 15 in steps of 4 or 5 m. On each axis where a mesh lies
//! farther from the origin than its own extent, it is therefore stored relative to its
//! bounding box's centre, which the node's `translation` carries (JSON numbers: f64, as
//! glTF viewers read them).
//!
//! A mesh without faces (an octree level coarser than the object, say) has no primitive
//! glTF could hold (accessors need `count` ≥ 1, meshes a primitive): it is written as a
//! GLB whose one scene is empty, with no node, mesh, buffer or BIN chunk, which viewers
//! load as nothing and the Khronos validator passes without a message. Coordinates beyond
//! f32's range (finite in f64, infinite as f32) are an encoding error: glTF floats are finite.

use std::io::Write;

use glam::{DVec3, Vec3};
use serde_json::json;

use crate::mesh::error::MeshError;
use crate::mesh::indexed::TriMesh;

const FORMAT: &str = "GLB";
const MAGIC: u32 = 0x4654_6C67; // "glTF"
const VERSION: u32 = 2;
const CHUNK_JSON: u32 = 0x4E4F_534A; // "JSON"
const CHUNK_BIN: u32 = 0x004E_4942; // "BIN\0"
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const TRIANGLES: u32 = 4;

fn encode_error(what: impl Into<String>) -> MeshError {
    MeshError::Encode {
        format: FORMAT,
        what: what.into(),
    }
}

/// Which way a mesh's "up" runs. glTF's is +Y (§3.4); terrain's is +Z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Up {
    /// Written as it is (object meshes carry their own convention, mostly Y-up already).
    Y,
    /// Stored as it is and turned by the node a quarter turn about x, +Z onto +Y (north
    /// onto −Z): viewers show the terrain lying flat, and a reader of the accessors alone,
    /// or CesiumJS (which turns Y-up models back to Z-up), gets the coordinates the other
    /// formats carry.
    Z,
}

/// The node's rotation for [`Up::Z`]: −90° about x, (x, y, z) → (x, z, −y).
const Z_UP_TO_Y_UP: [f64; 4] = [
    -std::f64::consts::FRAC_1_SQRT_2,
    0.0,
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
];

/// Writes `mesh`, its normals `normals` (unit, one a vertex) or, without, its own
/// ([`TriMesh::vertex_normals`]).
pub(super) fn write(
    mesh: &TriMesh,
    up: Up,
    normals: Option<&[DVec3]>,
    out: &mut impl Write,
) -> Result<(), MeshError> {
    // Indices in range and finite coordinates, or the accessors would point past their data.
    mesh.check()?;
    if let Some(n) = normals.filter(|n| n.len() != mesh.positions.len()) {
        return Err(encode_error(format!(
            "{} normals for {} vertices",
            n.len(),
            mesh.positions.len()
        )));
    }
    if mesh.faces.is_empty() {
        let doc = json!({
            "asset": {"version": "2.0", "generator": "zerotile"},
            "scene": 0,
            "scenes": [{}],
        });
        return write_container(&doc, None, out);
    }
    // Binary payload: positions, normals, indices, each 4-byte aligned by construction.
    let origin = origin(&mesh.positions);
    let positions: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|p| (*p - origin).as_vec3())
        .collect();
    if let Some((i, p)) = mesh
        .positions
        .iter()
        .zip(&positions)
        .enumerate()
        .find_map(|(i, (p, stored))| (!stored.is_finite()).then_some((i, p)))
    {
        // glTF floats must be finite, and f32 ends near 3.4e38.
        return Err(encode_error(format!(
            "vertex {i} at {p} is beyond f32's range"
        )));
    }
    let normals: Vec<Vec3> = match normals {
        Some(n) => n.iter().map(|n| n.as_vec3()).collect(),
        None => mesh.vertex_normals().iter().map(|n| n.as_vec3()).collect(),
    };
    let mut bin = Vec::with_capacity(24 * positions.len() + 12 * mesh.faces.len());
    for v in positions.iter().chain(&normals) {
        for c in v.to_array() {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in mesh.faces.iter().flatten() {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    // The accessors' bounds are those of the stored f32 values, as validators recompute them.
    let (min, max) = positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let (v, vbytes) = (positions.len(), 12 * positions.len());
    let mut node = json!({"mesh": 0});
    // The node turns then moves (glTF's T·R·S): the translation is the origin turned.
    let (turned, rotation) = match up {
        Up::Y => (origin, None),
        Up::Z => (
            DVec3::new(origin.x, origin.z, -origin.y),
            Some(Z_UP_TO_Y_UP),
        ),
    };
    if let Some(r) = rotation {
        node["rotation"] = json!(r);
    }
    if origin != DVec3::ZERO {
        node["translation"] = json!(turned.to_array());
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "zerotile"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [node],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1},
            "indices": 2,
            "mode": TRIANGLES,
        }]}],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": vbytes, "target": ARRAY_BUFFER},
            {"buffer": 0, "byteOffset": vbytes, "byteLength": vbytes, "target": ARRAY_BUFFER},
            {"buffer": 0, "byteOffset": 2 * vbytes, "byteLength": 12 * mesh.faces.len(),
             "target": ELEMENT_ARRAY_BUFFER},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": FLOAT, "count": v, "type": "VEC3",
             "min": min.to_array(), "max": max.to_array()},
            {"bufferView": 1, "componentType": FLOAT, "count": v, "type": "VEC3"},
            {"bufferView": 2, "componentType": UNSIGNED_INT, "count": 3 * mesh.faces.len(),
             "type": "SCALAR"},
        ],
    });
    write_container(&doc, Some(bin), out)
}

/// What the stored positions are measured from, axis by axis: the bounding box's centre on
/// an axis where the mesh lies farther from the origin than its extent, else 0 (object
/// meshes keep their coordinates). Per axis, because a world tile's axes differ in unit and
/// scale: degrees of longitude beside metres of height.
fn origin(positions: &[DVec3]) -> DVec3 {
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let centre = (lo + hi) / 2.0;
    let far = centre.abs().cmpgt(hi - lo) & centre.is_finite_mask();
    DVec3::select(far, centre, DVec3::ZERO)
}

/// Header, JSON chunk and, when there is one, the BIN chunk; every length must fit the u32
/// fields.
fn write_container(
    doc: &serde_json::Value,
    bin: Option<Vec<u8>>,
    out: &mut impl Write,
) -> Result<(), MeshError> {
    let mut text = serde_json::to_vec(doc).map_err(|e| encode_error(e.to_string()))?;
    pad(&mut text, b' ');
    let bin = bin.map(|mut b| {
        pad(&mut b, 0);
        b
    });
    let total = 12 + 8 + text.len() + bin.as_ref().map_or(0, |b| 8 + b.len());
    let u32_len = |n: usize| {
        u32::try_from(n).map_err(|_| encode_error(format!("{total} bytes exceed GLB's 4 GiB")))
    };
    let mut w = std::io::BufWriter::new(out);
    for word in [
        MAGIC,
        VERSION,
        u32_len(total)?,
        u32_len(text.len())?,
        CHUNK_JSON,
    ] {
        w.write_all(&word.to_le_bytes())?;
    }
    w.write_all(&text)?;
    if let Some(bin) = bin {
        for word in [u32_len(bin.len())?, CHUNK_BIN] {
            w.write_all(&word.to_le_bytes())?;
        }
        w.write_all(&bin)?;
    }
    w.flush()?;
    Ok(())
}

fn pad(bytes: &mut Vec<u8>, with: u8) {
    while !bytes.len().is_multiple_of(4) {
        bytes.push(with);
    }
}
