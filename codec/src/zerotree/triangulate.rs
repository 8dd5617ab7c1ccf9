//! Leaves → triangles without T-junctions.
//!
//! Gross, Gatti and Staadt ("Fast multiresolution surface meshing", IEEE Visualization 1995)
//! triangulate the leaves of a restricted quadtree with a lookup table indexed by which edge
//! midpoints carry a neighbour's vertex. The zerotree's quadtree is not restricted (a leaf can
//! border cells several levels finer), so the table is generalised to a fan:
//!
//! - no vertex on the edges: two triangles, split along the diagonal that passes closer to
//!   the cell's centre sample;
//! - otherwise a fan over the cell's boundary polygon from an apex that sees every other
//!   boundary vertex off its own line: a vertex that is alone on its edge, or a corner whose
//!   two edges are bare. That gives V − 2 triangles, the table's count;
//! - if no such apex exists (every edge with vertices has several), a fan from the centre
//!   sample: V triangles.
//!
//! Every vertex on a leaf's boundary is in its polygon, so neighbouring leaves share every
//! edge piece exactly: the mesh is watertight and free of T-junctions.

use super::leaves::{BorderVertices, Leaf, SplitMap};
use super::terrain_mesh::TerrainMesh;
use crate::grid::Grid;

/// Triangulates `split`'s leaves with vertex heights from `heights` (the decoded grid). With
/// `extra`, those border samples become vertices too (a neighbour tile's border vertices).
///
/// `heights` must have the split map's shape; a mismatch is a broken contract (debug
/// assertion) and gives an empty mesh in release.
pub fn triangulate(
    split: &SplitMap,
    heights: &Grid<f64>,
    extra: Option<&BorderVertices>,
) -> TerrainMesh {
    let (rows, cols) = (split.rows(), split.cols());
    let mesh = TerrainMesh {
        rows,
        cols,
        ..TerrainMesh::default()
    };
    debug_assert_eq!((heights.rows(), heights.cols()), (rows, cols));
    // The shape test's first `||` as `&&` only matters past the assertion, in release.
    if heights.rows() != rows || heights.cols() != cols || split.leaves().is_empty() {
        return mesh;
    }
    let mut b = Builder {
        heights,
        cols,
        id: vec![0; rows * cols],
        mesh,
    };

    // Vertices: every leaf corner, then any extra border sample.
    for l in split.leaves() {
        let (r0, c0, s) = (l.row as usize, l.col as usize, l.size());
        for (r, c) in [(r0, c0), (r0 + s, c0), (r0 + s, c0 + s), (r0, c0 + s)] {
            b.vertex(r, c);
        }
    }
    if let Some(e) = extra {
        for (c, _) in e.north.iter().enumerate().filter(|(c, &v)| v && *c < cols) {
            b.vertex(0, c);
        }
        for (c, _) in e.south.iter().enumerate().filter(|(c, &v)| v && *c < cols) {
            b.vertex(rows - 1, c);
        }
        for (r, _) in e.west.iter().enumerate().filter(|(r, &v)| v && *r < rows) {
            b.vertex(r, 0);
        }
        for (r, _) in e.east.iter().enumerate().filter(|(r, &v)| v && *r < rows) {
            b.vertex(r, cols - 1);
        }
    }

    // Triangles: one small polygon per leaf (the reserve is a capacity hint: its `*` as `+`
    // or `/` changes no output).
    b.mesh.triangles.reserve(2 * split.leaves().len());
    let mut polygon = Vec::with_capacity(16);
    for l in split.leaves() {
        b.leaf(l, extra.is_some(), &mut polygon);
    }
    b.mesh
}

struct Builder<'a> {
    heights: &'a Grid<f64>,
    cols: usize,
    /// Vertex index + 1 per sample; 0 = not a vertex.
    id: Vec<u32>,
    mesh: TerrainMesh,
}

/// A boundary vertex of a leaf's polygon: its sample and which side it lies on (0 left,
/// 1 bottom, 2 right, 3 top; corners carry `CORNER`).
#[derive(Clone, Copy)]
struct Corner {
    r: usize,
    c: usize,
    side: u8,
}

const CORNER: u8 = u8::MAX;

impl Builder<'_> {
    fn vertex(&mut self, r: usize, c: usize) -> u32 {
        let slot = &mut self.id[r * self.cols + c];
        if *slot == 0 {
            self.mesh
                .positions
                .push([c as f64, r as f64, *self.heights.get(r, c)]);
            *slot = self.mesh.positions.len() as u32;
        }
        *slot - 1
    }

    #[inline]
    fn is_vertex(&self, r: usize, c: usize) -> bool {
        self.id[r * self.cols + c] != 0
    }

    fn index(&self, p: Corner) -> u32 {
        self.id[p.r * self.cols + p.c] - 1
    }

    /// Boundary polygon of one leaf, counter-clockwise seen from above (north up):
    /// top-left → down the west edge → along the south edge → up the east edge → back
    /// along the north edge.
    fn leaf(&mut self, l: &Leaf, scan_border: bool, polygon: &mut Vec<Corner>) {
        let (r0, c0, s) = (l.row as usize, l.col as usize, l.size());
        let (r1, c1) = (r0 + s, c0 + s);
        let (last_r, last_c) = (self.heights.rows() - 1, self.cols - 1);
        polygon.clear();
        let corner = |r, c| Corner { r, c, side: CORNER };

        // Each `scan_border &&` as `||` is equivalent, only slower: a scan finds what the
        // bisection finds on any edge, and extra vertices sit only on border edges.
        polygon.push(corner(r0, c0));
        let border = scan_border && c0 == 0;
        self.edge(polygon, border, (r0, c0), (r1, c0), 0);
        polygon.push(corner(r1, c0));
        let border = scan_border && r1 == last_r;
        self.edge(polygon, border, (r1, c0), (r1, c1), 1);
        polygon.push(corner(r1, c1));
        let border = scan_border && c1 == last_c;
        self.edge(polygon, border, (r1, c1), (r0, c1), 2);
        polygon.push(corner(r0, c1));
        let border = scan_border && r0 == 0;
        self.edge(polygon, border, (r0, c1), (r0, c0), 3);

        if polygon.len() == 4 {
            self.two_triangles(polygon, r0, c0, s);
        } else if let Some(apex) = apex(polygon) {
            let n = polygon.len();
            for k in 1..n - 1 {
                let (a, b) = (polygon[(apex + k) % n], polygon[(apex + k + 1) % n]);
                let t = [self.index(polygon[apex]), self.index(a), self.index(b)];
                self.mesh.triangles.push(t);
            }
        } else {
            // Several vertices on every busy edge: fan from the centre sample.
            let half = s / 2;
            let centre = self.vertex(r0 + half, c0 + half);
            let n = polygon.len();
            for k in 0..n {
                let (a, b) = (polygon[k], polygon[(k + 1) % n]);
                self.mesh
                    .triangles
                    .push([centre, self.index(a), self.index(b)]);
            }
        }
    }

    /// Appends the vertices strictly between `from` and `to` (an axis-aligned leaf edge),
    /// in that direction. Inside the grid a vertex on a leaf edge is a corner of a finer
    /// neighbour, so if the midpoint is bare the whole edge is: recurse on midpoints. On the
    /// grid's border, extra vertices can sit anywhere: scan.
    fn edge(
        &self,
        out: &mut Vec<Corner>,
        scan: bool,
        from: (usize, usize),
        to: (usize, usize),
        side: u8,
    ) {
        if scan {
            let n = from.0.abs_diff(to.0).max(from.1.abs_diff(to.1));
            let step = |a: usize, b: usize, k: usize| match b.cmp(&a) {
                std::cmp::Ordering::Greater => a + k,
                std::cmp::Ordering::Less => a - k,
                std::cmp::Ordering::Equal => a,
            };
            for k in 1..n {
                let (r, c) = (step(from.0, to.0, k), step(from.1, to.1, k));
                if self.is_vertex(r, c) {
                    out.push(Corner { r, c, side });
                }
            }
        } else {
            self.bisect(out, from, to, side);
        }
    }

    fn bisect(&self, out: &mut Vec<Corner>, a: (usize, usize), b: (usize, usize), side: u8) {
        let len = a.0.abs_diff(b.0).max(a.1.abs_diff(b.1));
        if len < 2 {
            return;
        }
        let mid = ((a.0 + b.0) / 2, (a.1 + b.1) / 2);
        if !self.is_vertex(mid.0, mid.1) {
            return;
        }
        self.bisect(out, a, mid, side);
        out.push(Corner {
            r: mid.0,
            c: mid.1,
            side,
        });
        self.bisect(out, mid, b, side);
    }

    /// A bare leaf: two triangles along the diagonal whose midpoint height is nearer the
    /// centre sample (for 1 × 1 cells, the diagonal with the smaller height step).
    fn two_triangles(&mut self, p: &[Corner], r0: usize, c0: usize, s: usize) {
        let h = |q: Corner| *self.heights.get(q.r, q.c);
        let (tl, bl, br, tr) = (p[0], p[1], p[2], p[3]);
        let main_diagonal = if s >= 2 {
            let centre = *self.heights.get(r0 + s / 2, c0 + s / 2);
            ((h(tl) + h(br)) / 2.0 - centre).abs() <= ((h(bl) + h(tr)) / 2.0 - centre).abs()
        } else {
            (h(tl) - h(br)).abs() <= (h(bl) - h(tr)).abs()
        };
        let [tl, bl, br, tr] = [tl, bl, br, tr].map(|q| self.index(q));
        if main_diagonal {
            self.mesh.triangles.push([tl, bl, br]);
            self.mesh.triangles.push([tl, br, tr]);
        } else {
            self.mesh.triangles.push([tl, bl, tr]);
            self.mesh.triangles.push([bl, br, tr]);
        }
    }
}

/// Index of a fan apex that sees every other polygon vertex off its own line: a vertex alone
/// on its side, else a corner whose two sides are bare.
fn apex(polygon: &[Corner]) -> Option<usize> {
    let mut count = [0usize; 4];
    for p in polygon.iter().filter(|p| p.side != CORNER) {
        count[usize::from(p.side)] += 1;
    }
    if let Some(k) = polygon
        .iter()
        .position(|p| p.side != CORNER && count[usize::from(p.side)] == 1)
    {
        return Some(k);
    }
    // Corner k of the polygon sits between side (k−1) and side k, counter-clockwise from the
    // top-left: TL between top (3) and left (0), BL between left (0) and bottom (1), …
    let corners: Vec<usize> = (0..polygon.len())
        .filter(|&k| polygon[k].side == CORNER)
        .collect();
    corners
        .iter()
        .enumerate()
        .find(|&(i, _)| count[(i + 3) % 4] == 0 && count[i] == 0)
        .map(|(_, &k)| k)
}
