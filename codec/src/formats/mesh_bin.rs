//! `ZTM1`: a compact little-endian binary mesh per terrain tile, for flight-sim and game
//! clients that want triangles without parsing quantized-mesh's deltas and quantisation.
//!
//! Layout (little-endian, 72-byte header, every field naturally aligned):
//!
//! | offset | size | type | field |
//! |---|---|---|---|
//! | 0 | 4 | `[u8; 4]` | magic `ZTM1` |
//! | 4 | 2 | u16 | version, 1 |
//! | 6 | 2 | u16 | flags: bit 0 set = 32-bit indices; other bits 0 |
//! | 8 | 4 | u32 | CRS of the bounds: 4326 (degrees), 3857 (metres), 0 (local grid samples) |
//! | 12 | 4 | u32 | vertex count n |
//! | 16 | 4 | u32 | triangle count t |
//! | 20 | 4 | u32 | reserved, 0 |
//! | 24 | 8 | f64 | minimum height, metres |
//! | 32 | 8 | f64 | maximum height, metres |
//! | 40 | 32 | 4 × f64 | tile bounds: left (west), bottom (south), right (east), top (north) |
//! | 72 | 12n | n × 3 × f32 | positions (x, y, z) |
//! | 72 + 12n | 6t or 12t | 3t × u16 or u32 | triangles, counter-clockwise seen from +z |
//!
//! Positions: x and y are normalised 0..1 across the tile — x = 0 on the left (west) edge,
//! 1 on the right; y = 0 on the bottom (south) edge, 1 on the top — and z is the height in
//! metres. A point's CRS position is (left + x · (right − left), bottom + y · (top − bottom)).
//! Normalised coordinates keep f32's 24 bits for the tile itself: absolute EPSG:3857 metres
//! (up to 2·10⁷) would round to 2 m steps in f32. For a local grid (CRS 0) the bounds are
//! sample coordinates with rows growing downwards, so `bottom` > `top` and the same formula
//! gives the row. Indices are 16-bit when n ≤ 65 536, else 32-bit.
//!
//! ```
//! use zerotile_codec::formats::mesh_bin::{self, MeshCrs};
//! use zerotile_codec::geo::Bounds;
//! use zerotile_codec::zerotree::TerrainMesh;
//!
//! let mesh = TerrainMesh {
//!     rows: 2,
//!     cols: 2,
//!     positions: vec![[0.0, 0.0, 100.0], [1.0, 0.0, 120.0], [0.0, 1.0, 90.0], [1.0, 1.0, 80.0]],
//!     triangles: vec![[2, 3, 1], [2, 1, 0]],
//! };
//! let bounds = Bounds { min_x: 6.0, min_y: 45.0, max_x: 7.0, max_y: 46.0 };
//! let bytes = mesh_bin::encode(&mesh, MeshCrs::Geographic, &bounds)?;
//! assert_eq!(bytes.len(), 72 + 12 * 4 + 6 * 2);
//! let tile = mesh_bin::decode(&bytes)?;
//! assert_eq!(tile.positions[0], [0.0, 1.0, 100.0]); // north-west corner: top-left
//! # Ok::<(), mesh_bin::MeshBinError>(())
//! ```

use crate::geo::Bounds;
use crate::zerotree::TerrainMesh;

/// First four bytes.
pub const MAGIC: [u8; 4] = *b"ZTM1";

/// The layout version this module writes and reads.
pub const VERSION: u16 = 1;

/// Header size, bytes.
pub const HEADER_BYTES: usize = 72;

/// Flag bit: indices are u32.
const FLAG_WIDE: u16 = 1;

/// The CRS a tile's bounds are in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshCrs {
    /// EPSG:4326, degrees.
    Geographic,
    /// EPSG:3857, metres.
    WebMercator,
    /// A local grid's sample coordinates (no georeference).
    LocalGrid,
}

impl MeshCrs {
    /// The u32 stored in the header.
    pub fn code(self) -> u32 {
        match self {
            Self::Geographic => 4326,
            Self::WebMercator => 3857,
            Self::LocalGrid => 0,
        }
    }

    fn from_code(code: u32) -> Option<Self> {
        match code {
            4326 => Some(Self::Geographic),
            3857 => Some(Self::WebMercator),
            0 => Some(Self::LocalGrid),
            _ => None,
        }
    }
}

/// A decoded tile mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshBin {
    pub crs: MeshCrs,
    pub min_height: f64,
    pub max_height: f64,
    /// Left, bottom, right, top: see the module doc.
    pub edges: [f64; 4],
    /// Normalised x, y and height in metres.
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// Why a mesh could not be written or read.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum MeshBinError {
    #[error("cannot encode this mesh: {0}")]
    InvalidMesh(String),
    #[error("ZTM1 truncated: {what} needs {need} bytes, {have} present")]
    Truncated {
        what: &'static str,
        need: u64,
        have: usize,
    },
    #[error("malformed ZTM1: {0}")]
    Malformed(String),
    #[error("unsupported ZTM1: {0}")]
    Unsupported(String),
}

/// Encodes `mesh` (the [`TerrainMesh`] contract: grid x = column, y = row from the north,
/// z metres, counter-clockwise seen from above) for a tile with `bounds` in `crs`, as
/// returned by [`Tiling::tile_bounds`](crate::geo::Tiling::tile_bounds).
pub fn encode(mesh: &TerrainMesh, crs: MeshCrs, bounds: &Bounds) -> Result<Vec<u8>, MeshBinError> {
    // Check the mesh and the bounds.
    let bad = |m: String| Err(MeshBinError::InvalidMesh(m));
    if mesh.rows < 2 || mesh.cols < 2 {
        return bad(format!("a {}×{} grid has no area", mesh.rows, mesh.cols));
    }
    let n = mesh.positions.len();
    let (Ok(n32), Ok(t32)) = (u32::try_from(n), u32::try_from(mesh.triangles.len())) else {
        return bad("more than 2^32 − 1 vertices or triangles".into());
    };
    if let Some(i) = mesh
        .positions
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return bad(format!("vertex {i} is not finite"));
    }
    if let Some(t) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&i| i >= n32))
    {
        return bad(format!("triangle {t} points past the {n} vertices"));
    }
    let b = [bounds.min_x, bounds.min_y, bounds.max_x, bounds.max_y];
    if !b.iter().all(|v| v.is_finite()) {
        return bad(format!("bounds {bounds:?} are not finite"));
    }

    // Edges: left, bottom, right, top; a local grid's bottom is its larger row.
    let edges = match crs {
        MeshCrs::LocalGrid => [bounds.min_x, bounds.max_y, bounds.max_x, bounds.min_y],
        _ => b,
    };
    let (min_h, max_h) = mesh.height_range().unwrap_or((0.0, 0.0));

    // Count, then fill.
    let wide = n > 65_536;
    let total = HEADER_BYTES + 12 * n + 3 * mesh.triangles.len() * if wide { 4 } else { 2 };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(if wide { FLAG_WIDE } else { 0 }).to_le_bytes());
    for word in [crs.code(), n32, t32, 0] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    for v in [min_h, max_h].iter().chain(&edges) {
        out.extend_from_slice(&v.to_le_bytes());
    }

    // Positions: normalised x east, y north; heights in metres.
    let (w, h) = ((mesh.cols - 1) as f64, (mesh.rows - 1) as f64);
    for &[x, y, z] in &mesh.positions {
        for v in [(x / w) as f32, ((h - y) / h) as f32, z as f32] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for &index in mesh.triangles.iter().flatten() {
        if wide {
            out.extend_from_slice(&index.to_le_bytes());
        } else {
            // n ≤ 65 536, so every index fits.
            out.extend_from_slice(&(index as u16).to_le_bytes());
        }
    }
    debug_assert_eq!(out.len(), total);
    Ok(out)
}

/// Decodes a `ZTM1` tile. The byte length must match the header's counts exactly; indices
/// are checked against the vertex count.
pub fn decode(bytes: &[u8]) -> Result<MeshBin, MeshBinError> {
    // Header: magic, version, flags, counts.
    let header = bytes.get(..HEADER_BYTES).ok_or(MeshBinError::Truncated {
        what: "header",
        need: HEADER_BYTES as u64,
        have: bytes.len(),
    })?;
    if header[..4] != MAGIC {
        return Err(MeshBinError::Malformed(format!(
            "magic {:?}, expected ZTM1",
            &header[..4]
        )));
    }
    let u16_at = |at: usize| u16::from_le_bytes([header[at], header[at + 1]]);
    let u32_at = |at: usize| {
        u32::from_le_bytes([header[at], header[at + 1], header[at + 2], header[at + 3]])
    };
    let f64_at = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&header[at..at + 8]);
        f64::from_le_bytes(b)
    };
    let version = u16_at(4);
    if version != VERSION {
        return Err(MeshBinError::Unsupported(format!(
            "version {version} (this reader knows 1)"
        )));
    }
    let flags = u16_at(6);
    if flags & !FLAG_WIDE != 0 {
        return Err(MeshBinError::Unsupported(format!("flags {flags:#06x}")));
    }
    let crs = MeshCrs::from_code(u32_at(8))
        .ok_or_else(|| MeshBinError::Unsupported(format!("CRS code {}", u32_at(8))))?;
    let (n, t) = (u64::from(u32_at(12)), u64::from(u32_at(16)));
    let wide = flags & FLAG_WIDE != 0;
    if !wide && n > 65_536 {
        return Err(MeshBinError::Malformed(format!(
            "16-bit indices for {n} vertices"
        )));
    }

    // Exact size: nothing allocated for counts the bytes cannot hold.
    let need = HEADER_BYTES as u64 + 12 * n + 3 * t * if wide { 4 } else { 2 };
    if need > bytes.len() as u64 {
        return Err(MeshBinError::Truncated {
            what: "positions and triangles",
            need,
            have: bytes.len(),
        });
    }
    if need < bytes.len() as u64 {
        return Err(MeshBinError::Malformed(format!(
            "{} bytes after the triangles",
            bytes.len() as u64 - need
        )));
    }

    // Body.
    let body = &bytes[HEADER_BYTES..];
    let (pos_bytes, index_bytes) = body.split_at(12 * n as usize);
    let f32_of = |c: &[u8]| f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    let positions = pos_bytes
        .chunks_exact(12)
        .map(|c| [f32_of(&c[0..4]), f32_of(&c[4..8]), f32_of(&c[8..12])])
        .collect();
    let indices: Vec<u32> = if wide {
        index_bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    } else {
        index_bytes
            .chunks_exact(2)
            .map(|c| u32::from(u16::from_le_bytes([c[0], c[1]])))
            .collect()
    };
    if let Some(k) = indices.iter().position(|&i| u64::from(i) >= n) {
        return Err(MeshBinError::Malformed(format!(
            "triangle {} points past the {n} vertices",
            k / 3
        )));
    }
    Ok(MeshBin {
        crs,
        min_height: f64_at(24),
        max_height: f64_at(32),
        edges: [f64_at(40), f64_at(48), f64_at(56), f64_at(64)],
        positions,
        triangles: indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::{Scheme, TileId, Tiling};

    /// The unit square: bounds for tests where the placement does not matter.
    const UNIT: Bounds = Bounds {
        min_x: 0.0,
        min_y: 0.0,
        max_x: 1.0,
        max_y: 1.0,
    };

    fn grid_mesh(rows: usize, cols: usize) -> TerrainMesh {
        let mut positions = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                positions.push([c as f64, r as f64, 1000.0 + (r * 7 + c * 3) as f64 * 0.25]);
            }
        }
        let id = |r: usize, c: usize| (r * cols + c) as u32;
        let mut triangles = Vec::new();
        for r in 0..rows - 1 {
            for c in 0..cols - 1 {
                triangles.push([id(r + 1, c), id(r + 1, c + 1), id(r, c + 1)]);
                triangles.push([id(r + 1, c), id(r, c + 1), id(r, c)]);
            }
        }
        TerrainMesh {
            rows,
            cols,
            positions,
            triangles,
        }
    }

    #[test]
    fn round_trip_keeps_positions_triangles_and_bounds() {
        let tiling = Tiling::new(Scheme::Mercator, 9).unwrap();
        let bounds = tiling.tile_bounds(TileId::new(4, 3, 5)).unwrap();
        let mesh = grid_mesh(9, 9);
        let bytes = encode(&mesh, MeshCrs::WebMercator, &bounds).unwrap();
        assert_eq!(&bytes[..4], b"ZTM1");
        assert_eq!(bytes.len(), 72 + 12 * 81 + 6 * 128);
        let tile = decode(&bytes).unwrap();
        assert_eq!(tile.crs, MeshCrs::WebMercator);
        assert_eq!(tile.triangles, mesh.triangles);
        assert_eq!(
            tile.edges,
            [bounds.min_x, bounds.min_y, bounds.max_x, bounds.max_y]
        );
        assert_eq!(
            (tile.min_height, tile.max_height),
            mesh.height_range().unwrap()
        );
        // Each position maps back to its sample's CRS position.
        let [left, bottom, right, top] = tile.edges;
        for (k, p) in tile.positions.iter().enumerate() {
            let (r, c) = ((k / 9) as u32, (k % 9) as u32);
            let [x, y] = tiling.sample_position(TileId::new(4, 3, 5), r, c).unwrap();
            let px = left + f64::from(p[0]) * (right - left);
            let py = bottom + f64::from(p[1]) * (top - bottom);
            assert!(
                (px - x).abs() < 1e-7 * (right - left) && (py - y).abs() < 1e-7 * (top - bottom),
                "{k}"
            );
            assert_eq!(f64::from(p[2]), mesh.positions[k][2]);
        }
        // Counter-clockwise seen from +z.
        for t in &tile.triangles {
            let [a, b, c] = t.map(|i| tile.positions[i as usize]);
            let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
            assert!(area2 > 0.0);
        }
    }

    #[test]
    fn local_grid_bounds_map_rows_downwards() {
        let tiling = Tiling::new(
            Scheme::Local {
                rows: 1201,
                cols: 1201,
            },
            9,
        )
        .unwrap();
        let id = TileId::new(tiling.max_zoom(), 2, 3);
        let bounds = tiling.tile_bounds(id).unwrap();
        let tile = decode(&encode(&grid_mesh(9, 9), MeshCrs::LocalGrid, &bounds).unwrap()).unwrap();
        let [left, bottom, right, top] = tile.edges;
        assert!(bottom > top);
        // Sample (row 2, col 5) of the tile.
        let p = tile.positions[2 * 9 + 5];
        let col = left + f64::from(p[0]) * (right - left);
        let row = bottom + f64::from(p[1]) * (top - bottom);
        assert_eq!([col, row], tiling.sample_position(id, 2, 5).unwrap());
    }

    #[test]
    fn big_meshes_use_32_bit_indices() {
        let mesh = grid_mesh(257, 257);
        let b = UNIT;
        let bytes = encode(&mesh, MeshCrs::Geographic, &b).unwrap();
        assert_eq!(u16::from_le_bytes([bytes[6], bytes[7]]), 1);
        assert_eq!(bytes.len(), 72 + 12 * 66_049 + 12 * mesh.triangles.len());
        assert_eq!(decode(&bytes).unwrap().triangles, mesh.triangles);
    }

    #[test]
    fn bad_bytes_and_meshes_are_errors() {
        let b = UNIT;
        let good = encode(&grid_mesh(3, 3), MeshCrs::Geographic, &b).unwrap();
        for cut in 0..good.len() {
            assert!(decode(&good[..cut]).is_err(), "prefix {cut}");
        }
        let mut long = good.clone();
        long.push(0);
        assert!(matches!(decode(&long), Err(MeshBinError::Malformed(_))));
        let patch = |at: usize, v: &[u8]| {
            let mut x = good.clone();
            x[at..at + v.len()].copy_from_slice(v);
            decode(&x)
        };
        assert!(matches!(patch(0, b"ZTM2"), Err(MeshBinError::Malformed(_))));
        assert!(matches!(
            patch(4, &2u16.to_le_bytes()),
            Err(MeshBinError::Unsupported(_))
        ));
        assert!(matches!(
            patch(6, &4u16.to_le_bytes()),
            Err(MeshBinError::Unsupported(_))
        ));
        assert!(matches!(
            patch(8, &32632u32.to_le_bytes()),
            Err(MeshBinError::Unsupported(_))
        ));
        assert!(matches!(
            patch(12, &u32::MAX.to_le_bytes()),
            Err(MeshBinError::Malformed(_))
        ));
        assert!(matches!(
            patch(16, &u32::MAX.to_le_bytes()),
            Err(MeshBinError::Truncated { .. })
        ));
        assert!(matches!(
            patch(72 + 12 * 9, &200u16.to_le_bytes()),
            Err(MeshBinError::Malformed(_))
        ));

        let mut m = grid_mesh(3, 3);
        m.triangles[0][0] = 99;
        assert!(encode(&m, MeshCrs::Geographic, &b).is_err());
        let mut m = grid_mesh(3, 3);
        m.positions[1][2] = f64::INFINITY;
        assert!(encode(&m, MeshCrs::Geographic, &b).is_err());
        let nan = Bounds {
            min_x: f64::NAN,
            ..b
        };
        assert!(encode(&grid_mesh(3, 3), MeshCrs::Geographic, &nan).is_err());
    }

    #[test]
    fn exactly_65536_vertices_keep_16_bit_indices() {
        // The doc's boundary: 16-bit when n ≤ 65 536 (256² vertices), 32-bit above.
        let mesh = grid_mesh(256, 256);
        let b = UNIT;
        let bytes = encode(&mesh, MeshCrs::Geographic, &b).unwrap();
        assert_eq!(u16::from_le_bytes([bytes[6], bytes[7]]), 0);
        assert_eq!(bytes.len(), 72 + 12 * 65_536 + 6 * mesh.triangles.len());
        let tile = decode(&bytes).unwrap();
        assert_eq!(tile.triangles, mesh.triangles);
        // The largest index, 65 535, survives the 16-bit round trip.
        assert!(tile.triangles.iter().flatten().any(|&i| i == 65_535));
    }
}
