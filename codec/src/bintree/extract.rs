//! Per request: the conforming triangulation of one tile at a tolerance.
//!
//! A triangle splits when its hypotenuse midpoint's value exceeds the tolerance, or when the
//! midpoint is forced (a vertex a neighbouring tile puts on the shared border, or an ancestor
//! of one). Forcing raises every ancestor along the parent links, so the forced mesh is as
//! conforming as the plain one.

use super::errors::{Coords, TileErrors};
use super::hierarchy::{Hierarchy, Tri, NONE};
use crate::grid::Grid;
use crate::zerotree::{BorderVertices, TerrainMesh};

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

/// Sample `i` of edge `e` of an `n × n` tile, row-major: edges north, south, west, east
/// (`e ^ 1` is the opposite edge), each from its first row or column.
pub(crate) fn edge_sample(n: usize, e: usize, i: usize) -> usize {
    let last = n - 1;
    match e {
        0 => i,
        1 => last * n + i,
        2 => i * n,
        _ => i * n + last,
    }
}

/// The border samples that forcing vertices on one edge can make vertices of another edge,
/// mirrored onto the opposite edge too; sorted, row-major.
///
/// A forced border vertex needs its ancestors, and near a corner some lie on the tile's
/// other edge: a vertex a west neighbour forces can put one on the north edge that the north
/// neighbour, which never sees the west neighbour, does not have (a T-junction). Forcing
/// every such sample in every tile closes that door: whatever is forced, the other edges
/// only gain samples both tiles of each edge already force. Mirrored, because the tile on
/// the other side of an edge sees it as its opposite edge (the south edge of the tile to the
/// north). A few dozen samples, near the corners.
pub(crate) fn edge_spill(hierarchy: &Hierarchy) -> Vec<u32> {
    let n = hierarchy.side();
    let edge = |e: usize, i: usize| edge_sample(n, e, i);
    // Positions along the edge, for the two edge directions (rows: north/south, columns:
    // west/east), that some other edge's forcing reaches.
    let mut along = [vec![false; n], vec![false; n]];
    for from in 0..4 {
        let forced = Forced::new(hierarchy, (0..n).map(|i| edge(from, i)));
        for to in (0..4).filter(|&to| to != from) {
            // `to / 2` (and `e / 2` below) as `% 2` changes nothing: the bintree of a square is
            // symmetric under the transpose and the half turn, and what forcing reaches on an
            // edge is symmetric end to end (checked by mutation up to 1025²), so every edge
            // gets one set of positions however the four are paired.
            for (i, hit) in along[to / 2].iter_mut().enumerate() {
                if forced.get(edge(to, i) as u32) {
                    *hit = true;
                }
            }
        }
    }
    let mut out: Vec<u32> = (0..4)
        .flat_map(|e| {
            let hits = &along[e / 2];
            (0..n)
                .filter(move |&i| hits[i])
                .map(move |i| edge(e, i) as u32)
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
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
        tolerance: f32_at_or_below(tolerance),
        forced,
        splittable: hierarchy.levels() - 1,
    };

    // One walk: a vertex gets its id when a leaf first names it. Counting first would size
    // the buffers exactly but walks the tree twice, which costs more than the growth.
    let mut id = vec![u32::MAX; n * n];
    let h = heights.data();
    // Coordinates by multiply-shift: a 64-bit division per new vertex was more than half of
    // the walk at 2 m (criterion `parts_257/extract_tol_2`: 2.29 → 0.95 ms, same session).
    let coords = Coords::new(n);
    walk.leaves(&mut |t: &Tri| {
        let mut tri = [0u32; 3];
        for (k, s) in [t.a, t.b, t.c].into_iter().enumerate() {
            let slot = &mut id[s as usize];
            if *slot == u32::MAX {
                let (x, y) = coords.xy(s);
                *slot = mesh.positions.len() as u32;
                mesh.positions.push([x as f64, y as f64, h[s as usize]]);
            }
            tri[k] = *slot;
        }
        mesh.triangles.push(tri);
    });
    mesh
}

/// The samples on each border edge that the plain mesh at `tolerance` has as vertices: what
/// a neighbouring tile must force onto the shared edge. Walks only the triangles that have
/// an edge on the border.
pub fn border_vertices(
    hierarchy: &Hierarchy,
    errors: &TileErrors,
    tolerance: f64,
) -> BorderVertices {
    let n = hierarchy.side();
    let mut out = BorderVertices::empty(n, n);
    if errors.side() != n {
        debug_assert!(false, "border_vertices: shapes differ");
        return out;
    }
    let walk = Walk {
        hierarchy,
        value: &errors.value,
        tolerance: f32_at_or_below(tolerance),
        forced: None,
        // `levels() / 1` (one level more) changes nothing here: the extra splits cut unit
        // triangles at (a + b) / 2, which marks a border sample only if its value is above
        // the tolerance, and such a sample is a vertex of the plain mesh already (its
        // ancestors' values are at least its own).
        splittable: hierarchy.levels() - 1,
    };
    let last = (n - 1) as i64;
    let coords = Coords::new(n);
    walk.border_leaves(n, &mut |t: &Tri| {
        for (p, q) in [(t.a, t.b), (t.b, t.c), (t.c, t.a)] {
            let ((px, py), (qx, qy)) = (coords.xy(p), coords.xy(q));
            for (x, y) in [(px, py), (qx, qy)] {
                if py == qy && py == 0 {
                    out.north[x as usize] = true;
                }
                if py == qy && py == last {
                    out.south[x as usize] = true;
                }
                if px == qx && px == 0 {
                    out.west[y as usize] = true;
                }
                if px == qx && px == last {
                    out.east[y as usize] = true;
                }
            }
        }
    });
    out
}

/// The largest f32 at or below `v` (NaN stays NaN, so nothing splits, as in f64).
fn f32_at_or_below(v: f64) -> f32 {
    let f = v as f32;
    if f64::from(f) > v {
        f.next_down()
    } else {
        f
    }
}

struct Walk<'a> {
    hierarchy: &'a Hierarchy,
    value: &'a [f32],
    /// The tolerance as the largest f32 not above it: `v > tolerance` for an f32 `v` is then
    /// `v > tolerance` in f64 exactly, without a conversion per visited triangle.
    tolerance: f32,
    forced: Option<&'a Forced>,
    splittable: usize,
}

impl Walk<'_> {
    /// Whether the hypotenuse midpoint of triangle `t` (level `l`) is split.
    #[inline]
    fn splits(&self, l: usize, tri: &Tri) -> bool {
        l < self.splittable
            && (self.value[tri.m as usize] > self.tolerance
                || self.forced.is_some_and(|f| f.get(tri.m)))
    }

    /// Calls `emit` for every leaf triangle with an edge on the grid's border.
    fn border_leaves(&self, n: usize, emit: &mut impl FnMut(&Tri)) {
        let last = (n - 1) as i64;
        let coords = Coords::new(n);
        // Only pruning: the caller marks border edges itself, so a looser test here (either
        // `&&` as `||`, either `py == qy`/`px == qx` as `!=`: a triangle with an edge on the
        // border also has one leaving it from a border vertex) visits more triangles and
        // finds the same ones.
        self.walk(
            |t: &Tri| {
                [(t.a, t.b), (t.b, t.c), (t.c, t.a)].iter().any(|&(p, q)| {
                    let ((px, py), (qx, qy)) = (coords.xy(p), coords.xy(q));
                    (py == qy && (py == 0 || py == last)) || (px == qx && (px == 0 || px == last))
                })
            },
            emit,
        );
    }

    /// Calls `emit` for every leaf triangle.
    fn leaves(&self, emit: &mut impl FnMut(&Tri)) {
        self.walk(|_| true, emit);
    }

    /// Depth first from the two roots, in the hierarchy's order, children derived from
    /// their parent ([`Tri::children`]); a triangle `keep` refuses is skipped with all
    /// its descendants.
    #[inline]
    fn walk(&self, keep: impl Fn(&Tri) -> bool, emit: &mut impl FnMut(&Tri)) {
        let roots = &self.hierarchy.tris[..2];
        let mut stack: Vec<(u32, Tri)> = Vec::with_capacity(2 * self.splittable + 2);
        stack.push((0, roots[1]));
        stack.push((0, roots[0]));
        while let Some((l, tri)) = stack.pop() {
            if !keep(&tri) {
                continue;
            }
            if self.splits(l as usize, &tri) {
                let [first, second] = tri.children();
                stack.push((l + 1, second));
                stack.push((l + 1, first));
                continue;
            }
            emit(&tri);
        }
    }
}
