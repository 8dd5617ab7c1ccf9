//! Per decoded tile: the exact error of every bintree triangle, as a zerotree over vertices.
//!
//! Martini (after Evans et al.) gives each vertex the interpolation error at that one
//! sample, raised to its descendants' errors; the error of a triangle's *plane* over the
//! samples it covers is then only estimated, and the benchmarks measure the true error of
//! its meshes at up to 1.7× the parameter. Here the value of a triangle is the largest
//! |height − plane| over every sample it covers, so a triangle kept at tolerance E is within
//! E everywhere: the tolerance is the mesh's true max error against the heights it was given.
//!
//! Values live on the hypotenuse midpoints, shared by the two triangles of a diamond, and are
//! raised to the values of the midpoints below (the zerotree property: a vertex below E has
//! every descendant below E). That makes extraction conforming: both triangles of a diamond
//! split together, and a split vertex's parents are split before it.

use super::hierarchy::{Hierarchy, Tri};
use crate::grid::Grid;

/// Per-vertex values of one tile (height units).
#[derive(Clone, Debug)]
pub struct TileErrors {
    n: usize,
    /// Per sample: max error of every triangle this sample splits and of all their
    /// descendants; 0 for samples that split nothing.
    pub(crate) value: Vec<f32>,
}

impl TileErrors {
    /// Exact errors of `heights` over `hierarchy`. `heights` must be `side × side`; another
    /// shape is a broken contract (debug assertion) and gives an all-zero map in release.
    pub fn new(hierarchy: &Hierarchy, heights: &Grid<f64>) -> Self {
        let n = hierarchy.side();
        let mut value = vec![0f32; n * n];
        debug_assert_eq!((heights.rows(), heights.cols()), (n, n));
        if heights.rows() != n || heights.cols() != n {
            return Self { n, value };
        }
        let h = heights.data();
        // Finest splittable level first, so children are final before their parents.
        let splittable = hierarchy.levels() - 1;
        for l in (0..splittable).rev() {
            let range = hierarchy.level_start[l]..hierarchy.level_start[l + 1];
            for t in range {
                let tri = hierarchy.tris[t];
                let m = hierarchy.midpoint(&tri) as usize;
                let mut v = value[m].max(plane_error(&tri, h, n));
                if l + 1 < splittable {
                    let first = hierarchy.first_child(l, t);
                    for child in &hierarchy.tris[first..first + 2] {
                        v = v.max(value[hierarchy.midpoint(child) as usize]);
                    }
                }
                value[m] = v;
            }
        }
        Self { n, value }
    }

    pub fn side(&self) -> usize {
        self.n
    }

    /// The value of the root diamond: the tolerance at and above which the tile is two
    /// triangles.
    pub fn max(&self) -> f32 {
        self.value.iter().copied().fold(0.0, f32::max)
    }
}

/// Largest |height − plane(a, b, c)| over the samples the triangle covers (edges included).
fn plane_error(t: &Tri, h: &[f64], n: usize) -> f32 {
    let xy = |s: u32| ((s as usize % n) as i64, (s as usize / n) as i64);
    let (pa, pb, pc) = (xy(t.a), xy(t.b), xy(t.c));
    let (za, zb, zc) = (h[t.a as usize], h[t.b as usize], h[t.c as usize]);
    // Plane z = z_a + gx·(x − x_a) + gy·(y − y_a).
    let (ux, uy, uz) = ((pb.0 - pa.0) as f64, (pb.1 - pa.1) as f64, zb - za);
    let (vx, vy, vz) = ((pc.0 - pa.0) as f64, (pc.1 - pa.1) as f64, zc - za);
    let det = ux * vy - uy * vx;
    if det == 0.0 {
        return 0.0;
    }
    let gx = (uz * vy - uy * vz) / det;
    let gy = (ux * vz - uz * vx) / det;

    let edges = [(pa, pb), (pb, pc), (pc, pa)];
    let (y0, y1) = (pa.1.min(pb.1).min(pc.1), pa.1.max(pb.1).max(pc.1));
    let mut worst = 0f64;
    for y in y0..=y1 {
        // Span of the row: the triangle's edges are axis-aligned or diagonal, so every
        // crossing is a whole sample.
        let (mut lo, mut hi) = (i64::MAX, i64::MIN);
        for &(p, q) in &edges {
            if p.1 == q.1 {
                if y == p.1 {
                    lo = lo.min(p.0.min(q.0));
                    hi = hi.max(p.0.max(q.0));
                }
            } else if (p.1.min(q.1)..=p.1.max(q.1)).contains(&y) {
                let x = p.0 + (y - p.1) * (q.0 - p.0) / (q.1 - p.1);
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
        if lo > hi {
            continue;
        }
        let row = &h[y as usize * n..(y as usize + 1) * n];
        let base = za + gy * (y - pa.1) as f64 - gx * pa.0 as f64;
        for (x, &z) in row[lo as usize..=hi as usize].iter().enumerate() {
            let plane = base + gx * (lo + x as i64) as f64;
            worst = worst.max((z - plane).abs());
        }
    }
    worst as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_has_zero_error_everywhere() {
        let n = 33;
        let h = Hierarchy::new(n).unwrap();
        let g = Grid::new(
            n,
            n,
            (0..n * n)
                .map(|k| 3.0 * (k / n) as f64 - 0.5 * (k % n) as f64)
                .collect(),
        )
        .unwrap();
        assert!(TileErrors::new(&h, &g).max() < 1e-9);
    }

    #[test]
    fn one_bump_raises_exactly_its_ancestors() {
        let n = 17;
        let h = Hierarchy::new(n).unwrap();
        let mut g = Grid::<f64>::zeros(n, n);
        *g.get_mut(5, 3) = 4.0;
        let e = TileErrors::new(&h, &g);
        assert_eq!(e.max(), 4.0);
        // The bump's own value: it splits triangles that do not cover it beyond their edge.
        assert!(e.value[5 * n + 3] > 0.0);
        // A far corner region stays flat.
        assert_eq!(e.value[(n - 2) * n + (n - 2)], 0.0);
    }
}
