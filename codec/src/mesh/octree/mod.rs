//! Octree LOD and region-of-interest browsing: Jung, Cho & Whangbo, *Detailed-information
//! Browsing Technology based on Level of Detail for 3D Cultural Asset Data* (Journal of the
//! Korea Contents Association, 2009; `seeds/octree-lod-browsing.ko.md`).
//!
//! Built once per mesh ([`OctreeLod::build`]), then queried per request:
//! - [`OctreeLod::level`]: the level-K mesh, every box at depth K collapsed onto its
//!   representative, connection triangles kept, so levels join without holes;
//! - [`OctreeLod::browse`]: a mixed-level mesh, full detail in a screen region of interest and
//!   the base level elsewhere.
//!
//! Choices the paper leaves open are in `octree.md` beside this file.
//!
//! ```
//! use glam::DVec3;
//! use zerotile_codec::mesh::octree::{OctreeLod, OctreeOptions, Roi, View};
//! use zerotile_codec::mesh::{subdivide::loop_subdivide, TriMesh};
//!
//! // An octahedron, subdivided into a 2,048-face ball.
//! let octahedron = TriMesh::new(
//!     vec![DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z],
//!     vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]],
//! );
//! let sphere = (0..4).fold(octahedron, |m, _| loop_subdivide(&m));
//! let lod = OctreeLod::build(&sphere, &OctreeOptions::default())?;
//! let coarse = lod.level(3)?;
//! assert!(coarse.face_count() < sphere.face_count());
//! // Look at the sphere from +X and ask for full detail in the middle of the screen.
//! let view = View::looking_at(DVec3::new(4.0, 0.0, 0.0), DVec3::ZERO, 45.0, 1.0);
//! let roi = Roi { x0: -0.1, y0: -0.1, x1: 0.1, y1: 0.1 };
//! let browsed = lod.browse(3, &view, &roi)?;
//! assert!(browsed.cut.mesh.face_count() < sphere.face_count());
//! # Ok::<(), zerotile_codec::mesh::MeshError>(())
//! ```

mod browse;
mod classify;
mod cut;
mod tree;

#[cfg(test)]
mod tests;

use serde::Serialize;

pub use browse::{Refinement, Roi, View};
pub use classify::relation_degree;
pub use cut::CutMesh;

use super::error::MeshError;
use super::indexed::TriMesh;
use crate::error::ParamError;
use classify::Classes;
use tree::Octree;

/// Depth the octree stops at by default: 1,024 boxes a side, fine enough that the deepest
/// level is the input on the test meshes (bunny, fandisk) and coarse enough to build fast.
pub const DEFAULT_MAX_DEPTH: u32 = 10;
/// A box holding at most this many vertices is not split (the paper splits "until a box holds
/// the set amount of data"); 1 makes the deepest level the input itself.
pub const DEFAULT_LEAF_VERTICES: usize = 1;
/// Largest accepted `max_depth`: 2²⁰ boxes a side is already below f64 resolution of most
/// scans, and bounds the work per vertex.
pub const MAX_DEPTH_LIMIT: u32 = 20;
/// Bytes one vertex takes in memory (three f64), for the memory figures.
pub const VERTEX_BYTES: usize = 24;
/// Bytes one triangle takes in memory (three u32 indices).
pub const FACE_BYTES: usize = 12;

/// How the octree is built.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OctreeOptions {
    /// Deepest box depth (root = 0), in 1..=[`MAX_DEPTH_LIMIT`]; [`DEFAULT_MAX_DEPTH`].
    pub max_depth: u32,
    /// Boxes with at most this many vertices stay leaves (≥ 1; [`DEFAULT_LEAF_VERTICES`]).
    pub leaf_vertices: usize,
}

impl Default for OctreeOptions {
    fn default() -> Self {
        Self {
            max_depth: DEFAULT_MAX_DEPTH,
            leaf_vertices: DEFAULT_LEAF_VERTICES,
        }
    }
}

impl OctreeOptions {
    fn check(&self) -> Result<(), ParamError> {
        if !(1..=MAX_DEPTH_LIMIT).contains(&self.max_depth) {
            return Err(ParamError::OutOfRange {
                name: "max_depth",
                expected: "in 1..=20",
                got: self.max_depth.to_string(),
            });
        }
        if self.leaf_vertices == 0 {
            return Err(ParamError::OutOfRange {
                name: "leaf_vertices",
                expected: "at least 1",
                got: "0".into(),
            });
        }
        Ok(())
    }
}

/// Sizes of one level, computed at build time so callers can pick a level by size.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct LevelStats {
    pub level: u32,
    /// Boxes at this depth in the modified adaptive octree.
    pub boxes: usize,
    /// Boxes at this depth in the plain adaptive octree (AOSP).
    pub plain_boxes: usize,
    pub vertices: usize,
    pub faces: usize,
}

/// A browse result: the mixed-level mesh and what it cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Browsed {
    pub cut: CutMesh,
    pub refinement: Refinement,
    /// Memory of the mixed mesh ([`VERTEX_BYTES`] per vertex + [`FACE_BYTES`] per face).
    pub bytes: usize,
    /// The same for the full model.
    pub full_bytes: usize,
}

/// The octree LOD hierarchy of one mesh.
#[derive(Clone, Debug)]
pub struct OctreeLod {
    mesh: TriMesh,
    tree: Octree,
    classes: Classes,
    levels: Vec<LevelStats>,
}

impl OctreeLod {
    /// Builds the hierarchy. The mesh must have finite coordinates and in-range indices (run
    /// [`crate::mesh::repair`] first for files from outside); closed manifolds give levels
    /// without boundary edges.
    pub fn build(mesh: &TriMesh, options: &OctreeOptions) -> Result<Self, MeshError> {
        options.check()?;
        mesh.check()?;
        // Spatial hierarchy: the modified adaptive octree.
        let tree = Octree::build(&mesh.positions, options.max_depth, options.leaf_vertices);
        // Relation degrees → interior / connection vertices, representatives, box normals.
        let classes = Classes::new(&tree, &mesh.positions, &mesh.faces);
        let mut lod = Self {
            mesh: mesh.clone(),
            tree,
            classes,
            levels: Vec::new(),
        };
        // Level sizes, bottom-up as the paper builds them, so `--faces N` can pick one.
        let depth = lod.tree.max_depth();
        let mut levels: Vec<LevelStats> = (0..=depth)
            .rev()
            .map(|k| {
                let m = lod.level_cut(k).mesh;
                LevelStats {
                    level: k,
                    boxes: lod.tree.boxes_per_depth[k as usize],
                    plain_boxes: lod.tree.plain_boxes_per_depth[k as usize],
                    vertices: m.vertex_count(),
                    faces: m.face_count(),
                }
            })
            .collect();
        levels.reverse();
        lod.levels = levels;
        Ok(lod)
    }

    /// The input mesh the hierarchy was built on.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// Per-level sizes, level 0 (the root box: everything interior collapsed) first; the last
    /// level is the input's full detail when every deepest box holds one vertex.
    pub fn levels(&self) -> &[LevelStats] {
        &self.levels
    }

    /// The deepest level.
    pub fn max_level(&self) -> u32 {
        self.tree.max_depth()
    }

    /// Total boxes of the modified octree and of the plain adaptive octree.
    pub fn box_totals(&self) -> (usize, usize) {
        (
            self.tree.boxes_per_depth.iter().sum(),
            self.tree.plain_boxes_per_depth.iter().sum(),
        )
    }

    /// The level-`k` mesh (`k` in `0..=max_level()`).
    pub fn level(&self, k: u32) -> Result<TriMesh, MeshError> {
        self.check_level(k)?;
        Ok(self.level_cut(k).mesh)
    }

    /// The deepest non-empty level with at most `faces` faces; when even the coarsest
    /// non-empty level has more (levels are coarse steps: fandisk goes 0 → 1,624 faces), that
    /// coarsest non-empty level, the nearest above the budget. An empty mesh answers no budget.
    pub fn level_for_faces(&self, faces: usize) -> u32 {
        let non_empty = || self.levels.iter().filter(|l| l.faces > 0);
        non_empty()
            .rev()
            .find(|l| l.faces <= faces)
            .or_else(|| non_empty().next())
            .map_or(self.max_level(), |l| l.level)
    }

    /// Full detail in the screen region `roi` of `view`, the `base` level elsewhere: base boxes
    /// meeting the region and facing the viewer are refined depth by depth down to the leaves
    /// while their sub-boxes still meet the region.
    pub fn browse(&self, base: u32, view: &View, roi: &Roi) -> Result<Browsed, MeshError> {
        self.check_level(base)?;
        let camera = view.camera()?;
        roi.check()?;
        // Select and refine boxes (Fig. 9).
        let refinement = browse::refine(&self.tree, &self.classes.normal_sum, base, &camera, roi);
        // Join the refined boxes to the base level through their connection triangles.
        let cut = self.cut(&refinement.collapsed);
        let bytes = cut.mesh.vertex_count() * VERTEX_BYTES + cut.mesh.face_count() * FACE_BYTES;
        let full_bytes =
            self.mesh.vertex_count() * VERTEX_BYTES + self.mesh.face_count() * FACE_BYTES;
        Ok(Browsed {
            cut,
            refinement,
            bytes,
            full_bytes,
        })
    }

    fn level_cut(&self, k: u32) -> CutMesh {
        let collapsed: Vec<u32> = self
            .tree
            .nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.depth == k && !n.is_leaf())
            .map(|(i, _)| i as u32)
            .collect();
        self.cut(&collapsed)
    }

    fn cut(&self, collapsed: &[u32]) -> CutMesh {
        cut::extract(
            &self.tree,
            &self.classes,
            &self.mesh.positions,
            &self.mesh.faces,
            collapsed,
        )
    }

    fn check_level(&self, k: u32) -> Result<(), ParamError> {
        if k > self.max_level() {
            return Err(ParamError::OutOfRange {
                name: "level",
                expected: "at most the octree's deepest level",
                got: format!("{k} (deepest {})", self.max_level()),
            });
        }
        Ok(())
    }
}
