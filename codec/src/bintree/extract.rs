//! Per request: the conforming triangulation of one tile at a tolerance.
//!
//! A triangle splits when its hypotenuse midpoint's value exceeds the tolerance, or when the
//! midpoint is forced (a vertex a neighbouring tile puts on the shared border, or an ancestor
//! of one). Forcing raises every ancestor along the parent links, so the forced mesh is as
//! conforming as the plain one. Counted first, then filled: the buffers are exactly sized.

use super::errors::TileErrors;
use super::hierarchy::{Hierarchy, Tri, NONE};
use crate::grid::Grid;
use crate::zerotree::TerrainMesh;

/// Samples that must be vertices whatever the tolerance (grid's row-major indices).
#[derive(Clone, Debug, Default)]
pub struct Forced {
    flags: Vec<bool>,
}

impl Forced {
    /// Forces `samples` and, along the hierarchy's parent links, every vertex they need.
    pub fn new(hierarchy: &Hierarchy, samples: impl IntoIterator<Item = usize>) -> Self {
        let n = hierarchy.side();
        let mut flags = vec![false; n * n];
        let mut stack: Vec<u32> = samples
            .into_iter()
            .filter(|&s| s < n * n)
            .map(|s| s as u32)
            .collect();
        while let Some(s) = stack.pop() {
            let slot = &mut flags[s as usize];
            if *slot {
                continue;
            }
            *slot = true;
            for &p in &hierarchy.parents[s as usize] {
                if p != NONE && !flags[p as usize] {
                    stack.push(p);
                }
            }
        }
        Self { flags }
    }

    #[inline]
    fn get(&self, s: u32) -> bool {
        self.flags.get(s as usize).copied().unwrap_or(false)
    }
}

/// The mesh of `errors`' tile at `tolerance` (height units), vertex heights from `heights`.
/// Every triangle is within `tolerance` of the heights the errors were computed from.
pub fn extract(
    hierarchy: &Hierarchy,
    errors: &TileErrors,
    heights: &Grid<f64>,
    tolerance: f64,
    forced: Option<&Forced>,
) -> TerrainMesh {
    let n = hierarchy.side();
    let mut mesh = TerrainMesh {
        rows: n,
        cols: n,
        ..TerrainMesh::default()
    };
    if errors.side() != n || heights.rows() != n || heights.cols() != n {
        debug_assert!(false, "extract: shapes differ");
        return mesh;
    }
    let walk = Walk {
        hierarchy,
        value: &errors.value,
        tolerance: tolerance as f32,
        forced,
        splittable: hierarchy.levels() - 1,
    };

    // Count, then fill.
    let mut id = vec![0u32; n * n];
    let (mut vertices, mut triangles) = (0usize, 0usize);
    walk.leaves(&mut |t: &Tri| {
        triangles += 1;
        for s in [t.a, t.b, t.c] {
            if id[s as usize] == 0 {
                vertices += 1;
                id[s as usize] = u32::MAX;
            }
        }
    });
    mesh.positions.reserve_exact(vertices);
    mesh.triangles.reserve_exact(triangles);
    let h = heights.data();
    walk.leaves(&mut |t: &Tri| {
        let mut tri = [0u32; 3];
        for (k, s) in [t.a, t.b, t.c].into_iter().enumerate() {
            let slot = &mut id[s as usize];
            if *slot == u32::MAX {
                let (x, y) = (s as usize % n, s as usize / n);
                mesh.positions.push([x as f64, y as f64, h[s as usize]]);
                *slot = mesh.positions.len() as u32 - 1;
            }
            tri[k] = *slot;
        }
        mesh.triangles.push(tri);
    });
    mesh
}

struct Walk<'a> {
    hierarchy: &'a Hierarchy,
    value: &'a [f32],
    tolerance: f32,
    forced: Option<&'a Forced>,
    splittable: usize,
}

impl Walk<'_> {
    /// Calls `emit` for every leaf triangle, depth first from the two roots.
    fn leaves(&self, emit: &mut impl FnMut(&Tri)) {
        let mut stack: Vec<(usize, usize)> = Vec::with_capacity(2 * self.splittable + 2);
        stack.push((0, 1));
        stack.push((0, 0));
        while let Some((l, t)) = stack.pop() {
            let tri = &self.hierarchy.tris[t];
            if l < self.splittable {
                let m = self.hierarchy.midpoint(tri);
                let split = self.value[m as usize] > self.tolerance
                    || self.forced.is_some_and(|f| f.get(m));
                if split {
                    let first = self.hierarchy.first_child(l, t);
                    stack.push((l + 1, first + 1));
                    stack.push((l + 1, first));
                    continue;
                }
            }
            emit(tri);
        }
    }
}
