//! Error-bounded terrain meshes on the right-triangle bintree (RTIN) of a decoded tile.
//!
//! Why beside [`crate::zerotree`]: meshing straight from the EZW significance map, as the
//! paper does, needs about 2.5× Martini's triangles for the same true max error on real
//! SRTM tiles (docs/terrain-mesh.md gives the measurements): the 5/3 update step lets a
//! significant coefficient just outside a leaf bend the decoded surface inside it, and a
//! two-triangle leaf cannot follow a bilinear patch's twist. The bintree is the quadtree of
//! the wavelet layout with each level split in two (cell centres, then edge midpoints), and
//! its per-vertex values are a zerotree too: a vertex and all its descendants below the
//! tolerance make one leaf. What changes is the value: the exact error of the triangle's
//! plane over the decoded samples, so the tolerance is a guaranteed bound.
//!
//! Split by lifetime like Martini: [`Hierarchy`] per grid size, [`TileErrors`] per decoded
//! tile, [`extract`] per request.
//!
//! ```
//! use zerotile_codec::bintree::{extract, Hierarchy, TileErrors};
//! use zerotile_codec::zerotree::mesh_error;
//! use zerotile_codec::Grid;
//!
//! let n = 65;
//! let heights = Grid::new(n, n, (0..n * n).map(|k| {
//!     let (r, c) = ((k / n) as f64, (k % n) as f64);
//!     (r * 0.2).sin() * 30.0 + c
//! }).collect()).unwrap();
//! let hierarchy = Hierarchy::new(n).unwrap();        // per grid size
//! let errors = TileErrors::new(&hierarchy, &heights); // per tile
//! let mesh = extract(&hierarchy, &errors, &heights, 2.0, None); // per request
//! assert!(mesh_error(&mesh, &heights).max_abs <= 2.0);
//! assert!(mesh.triangle_count() < 2 * 64 * 64 / 4);
//! ```

mod errors;
mod extract;
mod hierarchy;

pub use errors::TileErrors;
pub use extract::{border_vertices, extract, Forced};
pub use hierarchy::Hierarchy;

/// Share of an error budget T spent on decoding: the stream is read to T/8 and the mesh gets
/// the rest, so the mesh's true error stays within T. Reading deeper buys few triangles and
/// costs bytes and time. Here, not in the server, so the server, `eval terrain` and the
/// terrain bench split a budget by one number.
pub const DECODE_SHARE: f64 = 0.125;

#[cfg(test)]
mod tests;
