//! Zerotree → adaptive triangle mesh (Yu, Lee and Ra, "Fast triangular mesh approximation
//! for terrain data using wavelet coefficients", J. KITE 1997, §II–III; DESIGN.md §2.4).
//!
//! The decoder's zerotree is the complexity map: no analysis pass over the heights.
//! 1. [`Complexity::new`] summarises the decoded coefficients per quadtree cell (once per
//!    decoded tile).
//! 2. [`Complexity::leaves`] walks it top-down for a threshold T: a cell whose detail
//!    coefficients, descendants and edges included, are all below T is one leaf; otherwise
//!    it splits in four (per threshold).
//! 3. [`triangulate`] turns the leaves into triangles without T-junctions, with vertex
//!    heights from the decoded grid (the same zerotree limits mesh and image).
//!
//! ```
//! use zerotile_codec::ezw::{self, DecodeLimit, EncodeParams};
//! use zerotile_codec::wavelet::Wavelet;
//! use zerotile_codec::zerotree::{self, Complexity};
//! use zerotile_codec::Grid;
//!
//! // A 33 × 33 tile: a plane with one bump.
//! let heights = Grid::new(33, 33, (0..33 * 33).map(|k| {
//!     let (r, c) = (k / 33, k % 33);
//!     (r + c) as f64 + if (r, c) == (20, 9) { 40.0 } else { 0.0 }
//! }).collect()).unwrap();
//! let stream = ezw::encode(&heights, &EncodeParams::new(Wavelet::LeGall53, 1.0)).unwrap();
//! let decoded = ezw::decode(&stream.bytes, DecodeLimit::Threshold(2.0), 1 << 20).unwrap();
//! let complexity = Complexity::new(&decoded.layout, &decoded.coefficients);
//! let mesh = zerotree::triangulate(&complexity.leaves(2.0), &decoded.heights, None);
//! assert!(mesh.triangle_count() < 2 * 32 * 32 / 4); // the plane is coarse, the bump fine
//! ```

mod complexity;
mod leaves;
mod measure;
pub(crate) mod terrain_mesh;
mod triangulate;

pub use complexity::Complexity;
pub use leaves::{BorderVertices, Leaf, SplitMap};
pub use measure::{mesh_error, MeshError};
pub use terrain_mesh::TerrainMesh;
pub use triangulate::triangulate;

#[cfg(test)]
mod tests;
