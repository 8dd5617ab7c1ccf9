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
        let deviation =
            |m: u32, p: u32, q: u32| (h[m as usize] - (h[p as usize] + h[q as usize]) / 2.0).abs();
        for l in (0..splittable).rev() {
            let range = hierarchy.level_start[l]..hierarchy.level_start[l + 1];
            for t in range {
                let tri = hierarchy.tris[t];
                let m = tri.m as usize;
                // The two finest levels cover no sample but their edges' midpoints, where
                // the plane is the mean of the edge's ends; coarser ones need the scanline.
                let own = if l + 1 == splittable {
                    deviation(tri.m, tri.a, tri.b)
                } else if l + 2 == splittable {
                    let first = hierarchy.first_child(l, t);
                    let (c1, c2) = (hierarchy.tris[first], hierarchy.tris[first + 1]);
                    deviation(tri.m, tri.a, tri.b)
                        .max(deviation(c1.m, c1.a, c1.b))
                        .max(deviation(c2.m, c2.a, c2.b))
                } else {
                    plane_error(&tri, h, n)
                };
                let mut v = value[m].max(round_up(own));
                if l + 1 < splittable {
                    let first = hierarchy.first_child(l, t);
                    for child in &hierarchy.tris[first..first + 2] {
                        v = v.max(value[child.m as usize]);
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
///
/// The triangle's edges run along the axes or the diagonals, so on every row each edge
/// crosses a whole sample and moves by −1, 0 or +1 sample per row: a scanline without
/// divisions.
fn plane_error(t: &Tri, h: &[f64], n: usize) -> f64 {
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

    // Vertices top to bottom; the long edge v0–v2 bounds every row, the short ones split at
    // v1's row.
    let mut v = [pa, pb, pc];
    v.sort_unstable_by_key(|p| p.1);
    let slope = |p: (i64, i64), q: (i64, i64)| {
        if q.1 == p.1 {
            0
        } else {
            (q.0 - p.0) / (q.1 - p.1)
        }
    };
    let (long, upper, lower) = (slope(v[0], v[2]), slope(v[0], v[1]), slope(v[1], v[2]));
    let (mut hi, mut lo) = ([f64::MIN; LANES], [f64::MAX; LANES]);
    for y in v[0].1..=v[2].1 {
        // Rows above v1 see the upper short edge; from v1's row on, the lower one (which
        // also covers a horizontal edge at the top or bottom row).
        let x_long = v[0].0 + long * (y - v[0].1);
        let x_short = if y < v[1].1 {
            v[0].0 + upper * (y - v[0].1)
        } else {
            v[1].0 + lower * (y - v[1].1)
        };
        let (x0, x1) = (x_long.min(x_short), x_long.max(x_short));
        let base = y as usize * n;
        let row = &h[base + x0 as usize..=base + x1 as usize];
        let start = za + gy * (y - pa.1) as f64 + gx * (x0 - pa.0) as f64;
        // Lanes of branch-free min/max so the loop vectorises.
        // The plane restarts every chunk, so rounding never accumulates along a row.
        let ramp: [f64; LANES] = std::array::from_fn(|k| gx * k as f64);
        let mut chunks = row.chunks_exact(LANES);
        let mut at = start;
        for chunk in &mut chunks {
            let origin = at;
            for k in 0..LANES {
                let d = chunk[k] - (origin + ramp[k]);
                hi[k] = if d > hi[k] { d } else { hi[k] };
                lo[k] = if d < lo[k] { d } else { lo[k] };
            }
            at += gx * LANES as f64;
        }
        let origin = at;
        for (k, &z) in chunks.remainder().iter().enumerate() {
            let d = z - (origin + ramp[k]);
            hi[k] = if d > hi[k] { d } else { hi[k] };
            lo[k] = if d < lo[k] { d } else { lo[k] };
        }
    }
    let (hi, lo) = (
        hi.iter().copied().fold(f64::MIN, f64::max),
        lo.iter().copied().fold(f64::MAX, f64::min),
    );
    hi.max(-lo)
}

/// The f32 at or above `v`, so a stored error never understates the f64 one.
fn round_up(v: f64) -> f32 {
    let f = v as f32;
    if f64::from(f) < v {
        f.next_up()
    } else {
        f
    }
}

/// Samples per step of the scanline's inner loop.
const LANES: usize = 4;

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition, by brute force over the bounding box with edge functions.
    fn brute_force(t: &Tri, h: &[f64], n: usize) -> f64 {
        let xy = |s: u32| ((s as usize % n) as i64, (s as usize / n) as i64);
        let p = [xy(t.a), xy(t.b), xy(t.c)];
        let z = [h[t.a as usize], h[t.b as usize], h[t.c as usize]];
        let edge = |a: (i64, i64), b: (i64, i64), q: (i64, i64)| {
            (b.0 - a.0) * (q.1 - a.1) - (b.1 - a.1) * (q.0 - a.0)
        };
        let area = edge(p[0], p[1], p[2]);
        let mut worst = 0f64;
        for y in 0..n as i64 {
            for x in 0..n as i64 {
                let w = [
                    edge(p[1], p[2], (x, y)),
                    edge(p[2], p[0], (x, y)),
                    edge(p[0], p[1], (x, y)),
                ];
                if w.iter().all(|&w| w * area.signum() >= 0) {
                    let plane = (0..3).map(|k| w[k] as f64 * z[k]).sum::<f64>() / area as f64;
                    worst = worst.max((h[y as usize * n + x as usize] - plane).abs());
                }
            }
        }
        worst
    }

    #[test]
    fn every_triangle_error_matches_the_brute_force_definition() {
        let n = 17;
        let h = Hierarchy::new(n).unwrap();
        let g = crate::fixtures::n44w072_crop(700, 700, n);
        for t in &h.tris {
            let fast = plane_error(t, g.data(), n);
            let slow = brute_force(t, g.data(), n);
            assert!(
                (fast - slow).abs() <= 1e-4 * slow.max(1.0),
                "{t:?}: {fast} vs {slow}"
            );
        }
    }

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
