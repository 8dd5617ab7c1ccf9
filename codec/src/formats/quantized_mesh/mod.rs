//! Cesium's quantized-mesh-1.0 terrain tiles: an encoder for zerotile's tile meshes and an
//! independent decoder (for tests, tools and clients written in Rust).
//!
//! References:
//! - CesiumGS/quantized-mesh README (the format, extensions 1, 2 and 4).
//! - CesiumJS `CesiumTerrainProvider.createQuantizedMeshTerrainData` (how clients read it:
//!   32-bit indices above 65 536 vertices, padding to the index size before the triangle
//!   count, little-endian extension lengths) and `QuantizedMeshTerrainData` (edge lists
//!   sorted by v for west/east and by u for south/north, which spares the client a sort).
//! - webgl-loader (Google, 2011), the high-water-mark index code the format adopts.
//!
//! Layout, little-endian throughout:
//!
//! | bytes | field |
//! |---|---|
//! | 88 | header: centre (3 f64, ECEF m), min/max height (2 f32, m), bounding sphere (4 f64, ECEF m), horizon occlusion point (3 f64, ellipsoid-scaled) |
//! | 4 + 6n | vertex count n (u32); u, v, height arrays (u16 each), zig-zag delta coded, values 0..=32767 |
//! | 0–3 | padding to the index size (2 bytes, or 4 when n > 65 536) |
//! | 4 + 3t·w | triangle count t (u32); indices (u16, or u32 when n > 65 536), high-water-mark coded, counter-clockwise in (u, v) |
//! | 4 × (4 + k·w) | west, south, east, north edge lists: count (u32), indices |
//! | … | extensions: id (u8), length (u32), data — 1 oct normals (2n bytes), 2 water mask (1 or 65 536 bytes), 4 metadata (u32 JSON length, JSON) |
//!
//! u runs west → east and v south → north across the tile's longitude/latitude bounds; height
//! runs from the header's minimum to its maximum.
//!
//! ```
//! use zerotile_codec::formats::quantized_mesh::{self, QmOptions};
//! use zerotile_codec::geo::TileGeo;
//! use zerotile_codec::zerotree::TerrainMesh;
//!
//! // Two triangles over a 2 × 2 grid, counter-clockwise seen from above (north up).
//! let mesh = TerrainMesh {
//!     rows: 2,
//!     cols: 2,
//!     positions: vec![[0.0, 0.0, 100.0], [1.0, 0.0, 120.0], [0.0, 1.0, 90.0], [1.0, 1.0, 80.0]],
//!     triangles: vec![[2, 3, 1], [2, 1, 0]],
//! };
//! let tile = TileGeo::geodetic(0.0, 45.0, 1.0, 46.0);
//! let bytes = quantized_mesh::encode(&mesh, &tile, &QmOptions::default())?;
//! let decoded = quantized_mesh::decode(&bytes)?;
//! assert_eq!((decoded.vertex_count(), decoded.triangles.len()), (4, 2));
//! assert_eq!((decoded.header.min_height, decoded.header.max_height), (80.0, 120.0));
//! # Ok::<(), quantized_mesh::QmError>(())
//! ```

mod decode;
mod encode;
mod normals;
mod oct;
#[cfg(test)]
mod tests;

pub use decode::decode;
pub use encode::{encode, encode_with_normals};
pub use normals::{grid_normals, Diagonals};
pub use oct::{oct_decode, oct_encode};

use crate::geo::TileGeo;

/// Largest quantised u, v or height value.
pub const QUANTIZED_MAX: u16 = 32_767;

/// Header size, bytes.
pub const HEADER_BYTES: usize = 88;

/// Above this many vertices, indices are 32-bit. The encoder never writes exactly this
/// many, which CesiumJS cannot read (`encode::cesium_pad`).
pub const MAX_VERTICES_16_BIT: usize = 65_536;

/// Side of a water mask grid, samples.
pub const WATER_MASK_SIDE: usize = 256;

/// Extension ids.
pub const EXTENSION_OCT_NORMALS: u8 = 1;
pub const EXTENSION_WATER_MASK: u8 = 2;
pub const EXTENSION_METADATA: u8 = 4;

/// What to append after the mesh. The server fills it from the extensions a client asks for
/// (`Accept: application/vnd.quantized-mesh;extensions=octvertexnormals-watermask-metadata`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QmOptions {
    /// Extension 1: per-vertex normals (ECEF, oct-encoded): given to
    /// [`encode_with_normals`], else area-weighted over the mesh's own triangles.
    pub octvertexnormals: bool,
    /// Extension 2: the tile's water mask; `WaterMask::Uniform(0)` says "all land".
    pub watermask: Option<WaterMask>,
    /// Extension 4: a JSON object, e.g. child availability from
    /// [`layer_json::availability_metadata`](crate::formats::layer_json::availability_metadata).
    pub metadata: Option<serde_json::Value>,
}

/// A water mask: 0 = land, 255 = water, values between for anti-aliased coasts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum WaterMask {
    /// One value for the whole tile (1 byte on the wire).
    Uniform(u8),
    /// 256 × 256 values, rows north → south, columns west → east (65 536 bytes).
    Grid(Vec<u8>),
}

/// The 88-byte header, as stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QmHeader {
    /// Tile centre, ECEF metres.
    pub center: [f64; 3],
    /// Height range the quantised heights span, metres.
    pub min_height: f32,
    pub max_height: f32,
    /// Bounding sphere, ECEF metres.
    pub bounding_sphere_center: [f64; 3],
    pub bounding_sphere_radius: f64,
    /// Horizon occlusion point, ellipsoid-scaled ECEF. NaN when the tile has none (wider
    /// than a hemisphere): Cesium's visibility test then never culls it.
    pub horizon_occlusion_point: [f64; 3],
}

/// A decoded tile: quantised vertices, triangles and edges as the file has them.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantizedMesh {
    pub header: QmHeader,
    /// West (0) → east (32767).
    pub u: Vec<u16>,
    /// South (0) → north (32767).
    pub v: Vec<u16>,
    /// Minimum (0) → maximum (32767) height.
    pub height: Vec<u16>,
    pub triangles: Vec<[u32; 3]>,
    pub west: Vec<u32>,
    pub south: Vec<u32>,
    pub east: Vec<u32>,
    pub north: Vec<u32>,
    /// Extension 1, two bytes per vertex.
    pub normals: Option<Vec<[u8; 2]>>,
    /// Extension 2.
    pub water_mask: Option<WaterMask>,
    /// Extension 4.
    pub metadata: Option<serde_json::Value>,
    /// Ids of extensions present but not understood (skipped).
    pub unknown_extensions: Vec<u8>,
}

impl QuantizedMesh {
    pub fn vertex_count(&self) -> usize {
        self.u.len()
    }

    /// Height of vertex `i`, metres, as a client computes it; `None` past the last vertex.
    pub fn height_m(&self, i: usize) -> Option<f64> {
        let (lo, hi) = (
            f64::from(self.header.min_height),
            f64::from(self.header.max_height),
        );
        let q = f64::from(*self.height.get(i)?) / f64::from(QUANTIZED_MAX);
        Some(lo + q * (hi - lo))
    }

    /// `[lon°, lat°, height m]` of vertex `i` on `tile`, linear in u and v as the format
    /// defines; `None` past the last vertex.
    pub fn lonlat_height(&self, i: usize, tile: &TileGeo) -> Option<[f64; 3]> {
        let max = f64::from(QUANTIZED_MAX);
        let u = f64::from(*self.u.get(i)?) / max;
        let v = f64::from(*self.v.get(i)?) / max;
        Some([
            tile.west + u * (tile.east - tile.west),
            tile.south + v * (tile.north - tile.south),
            self.height_m(i)?,
        ])
    }
}

/// Why a quantized-mesh tile could not be encoded or decoded, by who is at fault.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum QmError {
    /// The bytes end before a field does.
    #[error("quantized-mesh truncated: {what} needs {need} bytes at offset {at}, {have} left")]
    Truncated {
        what: &'static str,
        at: usize,
        need: u64,
        have: usize,
    },
    /// The bytes are there but say something impossible.
    #[error("malformed quantized-mesh: {0}")]
    Malformed(String),
    /// The mesh handed to the encoder breaks its contract.
    #[error("cannot encode this mesh as quantized-mesh: {0}")]
    InvalidMesh(String),
    /// An option or the tile bounds are out of range.
    #[error("{name} must be {expected}, got {got}")]
    Parameter {
        name: &'static str,
        expected: &'static str,
        got: String,
    },
}
