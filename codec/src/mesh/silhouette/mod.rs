//! Silhouette-preserving view-dependent LOD: Kim et al., *A Multiresolution Model Generation
//! Method Preserving View Directional Feature* (`seeds/view-sphere-silhouette-lod.ko.md`).
//!
//! Face normals go on a hierarchical view sphere ([`sphere`]: 8 octant cells, four children
//! per level). At level L, faces of one cell that touch form a region, and each region is
//! drawn as the triangulation of its outline ([`simplify`]): a coarse level has big cells,
//! big nearly-flat regions, few faces. For a view the object's level L comes from its
//! distance; cells facing the viewer are drawn one level coarser (their detail does not show)
//! and silhouette cells (holding normals ⟂ view) one level finer (it is all that shows), the
//! paper's fig. 9 traversal.
//!
//! Built once per mesh ([`ViewSphere::new`]: each face's finest cell); every query groups
//! and flattens in O(faces). Choices and figures: `silhouette.md` beside this file.

pub mod simplify;
pub mod sphere;

use glam::DVec3;
use serde::Serialize;

use super::error::MeshError;
use super::indexed::TriMesh;
use crate::error::ParamError;
use sphere::{cell_of, Cell, MAX_LEVEL};

/// A cell holding a direction whose |cos| to the view direction is below this is a
/// silhouette cell (within ~17° of edge-on).
pub const DEFAULT_SILHOUETTE_COS: f64 = 0.3;
/// cos between a cell's centre and the direction to the viewer above which the cell faces
/// the viewer (within ~37° of head-on).
pub const DEFAULT_FACING_COS: f64 = 0.8;

/// A viewer far enough that one direction stands for the whole object (the paper's setting).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct View {
    pub eye: DVec3,
    pub target: DVec3,
}

/// What a query drew.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Drawn {
    pub level: u8,
    /// Faces per kind of cell in the input: facing (coarsened), silhouette (refined), other.
    pub facing_faces: usize,
    pub silhouette_faces: usize,
    pub other_faces: usize,
}

/// A mesh with its view sphere.
pub struct ViewSphere {
    mesh: TriMesh,
    /// Each face's finest cell (`None`: degenerate face, never merged).
    cells: Vec<Option<Cell>>,
}

impl ViewSphere {
    pub fn new(mesh: &TriMesh) -> Result<Self, MeshError> {
        mesh.check()?;
        let cells = mesh
            .face_normals()
            .into_iter()
            .map(|n| cell_of(n, MAX_LEVEL))
            .collect();
        Ok(Self {
            mesh: mesh.clone(),
            cells,
        })
    }

    pub fn max_level(&self) -> u8 {
        MAX_LEVEL
    }

    /// The mesh at one level everywhere (no view).
    pub fn level(&self, level: u8) -> Result<TriMesh, MeshError> {
        let level = check_level(level)?;
        let keys: Vec<u32> = self.keys(|_| level);
        Ok(self.draw(&keys))
    }

    /// The mesh for a view: `level` (default: from the distance, see [`Self::level_for`])
    /// with facing cells one coarser and silhouette cells one finer.
    pub fn view(&self, view: &View, level: Option<u8>) -> Result<(TriMesh, Drawn), MeshError> {
        let dir = self.view_direction(view)?;
        let level = match level {
            Some(l) => check_level(l)?,
            None => self.level_for(view),
        };
        let (mut facing, mut silhouette, mut other) = (0, 0, 0);
        let keys = self.keys(|cell| {
            let (kind, drawn) = classify(cell, dir, level);
            match kind {
                Kind::Facing => facing += 1,
                Kind::Silhouette => silhouette += 1,
                Kind::Other => other += 1,
            }
            drawn
        });
        Ok((
            self.draw(&keys),
            Drawn {
                level,
                facing_faces: facing,
                silhouette_faces: silhouette,
                other_faces: other,
            },
        ))
    }

    /// The base level from the distance (paper §5.1): full detail within one bounding-box
    /// diagonal, one level coarser per doubling of the distance beyond it.
    pub fn level_for(&self, view: &View) -> u8 {
        let diagonal = self.mesh.diagonal().max(f64::MIN_POSITIVE);
        let centre = self.centre();
        let distance = (view.eye - centre).length() / diagonal;
        // At one diagonal log2 is 0, so `>=` would give the same level.
        let coarser = if distance > 1.0 {
            distance.log2().ceil() as i64
        } else {
            0
        };
        (i64::from(MAX_LEVEL) - coarser).clamp(0, i64::from(MAX_LEVEL)) as u8
    }

    fn centre(&self) -> DVec3 {
        let b = self.mesh.bounding_box();
        (b.min + b.max) / 2.0
    }

    fn view_direction(&self, view: &View) -> Result<DVec3, MeshError> {
        let finite = |p: DVec3| p.is_finite();
        if !finite(view.eye) || !finite(view.target) {
            return Err(bad("eye and target", "finite", f64::NAN).into());
        }
        (view.target - view.eye)
            .try_normalize()
            .ok_or_else(|| bad("the distance from eye to target", "> 0", 0.0).into())
    }

    /// Per face, the region key of its cell at the level `level_of(finest cell)` picks.
    fn keys(&self, mut level_of: impl FnMut(Cell) -> u8) -> Vec<u32> {
        self.cells
            .iter()
            .enumerate()
            .map(|(f, c)| match c {
                Some(c) => c.ancestor(level_of(*c)).key(),
                // Degenerate faces are their own region, so nothing merges through them.
                None => u32::MAX - f as u32,
            })
            .collect()
    }

    fn draw(&self, keys: &[u32]) -> TriMesh {
        let region = simplify::regions(&self.mesh, keys);
        simplify::flatten_regions(&self.mesh, &region)
    }
}

/// How a view draws a face's cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Facing,
    Silhouette,
    Other,
}

/// The kind of the cell `cell` (a face's finest) lies in for the view direction `dir` at
/// `level`, and the level its face is drawn at: the fig. 9 traversal, which draws a
/// silhouette cell one level finer and merges a facing one a level coarser.
///
/// A cell is a silhouette cell when some direction *in* it is within the silhouette band,
/// tested on the cell one level finer, the one the face would be drawn in. Its centre alone
/// misses the band whenever the cells are wide next to it: every octant's centre is 55° from
/// each axis, so from an axis no level-0 cell was silhouette and the view changed nothing.
/// Facing is judged by the centre at `level`; from level 1 down the two cannot overlap (a
/// centre within 37° of the view, plus the cell's 35° radius, stays short of the band at
/// 72.5°), and at level 0, where nothing is coarser, refining wins.
fn classify(cell: Cell, dir: DVec3, level: u8) -> (Kind, u8) {
    let finer = cell.ancestor((level + 1).min(MAX_LEVEL));
    if finer.min_abs_cos(dir) < DEFAULT_SILHOUETTE_COS {
        return (Kind::Silhouette, finer.level);
    }
    // `>=` here would differ only for a centre exactly at the bound, which a cell's centre
    // meets at most by rounding.
    if -cell.ancestor(level).centre().dot(dir) > DEFAULT_FACING_COS {
        (Kind::Facing, level.saturating_sub(1))
    } else {
        (Kind::Other, level)
    }
}

fn check_level(level: u8) -> Result<u8, ParamError> {
    if level > MAX_LEVEL {
        return Err(bad("view-sphere level", "0..=7", f64::from(level)));
    }
    Ok(level)
}

fn bad(name: &'static str, expected: &'static str, got: f64) -> ParamError {
    ParamError::OutOfRange {
        name,
        expected,
        got: got.to_string(),
    }
}

#[cfg(test)]
mod tests;
