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
    ///
    /// Per level, finest first, so children are final before their parents. Where the
    /// time went was not the coarse levels' passes over the tile (their few big triangles
    /// scan in vectorised rows, ~30 µs a level at 257²) but the 2^(2k) small triangles
    /// of the fine levels, each fetched from the hierarchy with its corners found by
    /// division. The two finest levels are now row-major sweeps over the grid
    /// ([`finest_two_levels`]), the next [`SHAPED_LEVELS`] read per-shape lists of sample
    /// offsets ([`Shapes`]) instead of setting up a scanline, and corners come from a
    /// multiply ([`Coords`]). The values are those of the per-triangle pass bit for bit.
    pub fn new(hierarchy: &Hierarchy, heights: &Grid<f64>) -> Self {
        let n = hierarchy.side();
        let mut value = vec![0f32; n * n];
        debug_assert_eq!((heights.rows(), heights.cols()), (n, n));
        if heights.rows() != n || heights.cols() != n {
            return Self { n, value };
        }
        let h = heights.data();
        let coords = Coords::new(n);
        let splittable = hierarchy.levels() - 1;
        finest_two_levels(h, n, &mut value);
        for l in (0..splittable.saturating_sub(2)).rev() {
            let range = hierarchy.level_start[l]..hierarchy.level_start[l + 1];
            let shapes = hierarchy.shapes.get(l).and_then(Option::as_ref);
            for t in range {
                let tri = hierarchy.tris[t];
                let m = tri.m as usize;
                let own = match shapes {
                    Some(shapes) => shapes.error(&tri, h, coords),
                    None => plane_error(&tri, h, coords),
                };
                let first = hierarchy.first_child(l, t);
                let (c1, c2) = (hierarchy.tris[first].m, hierarchy.tris[first + 1].m);
                value[m] = value[m]
                    .max(round_up(own))
                    .max(value[c1 as usize])
                    .max(value[c2 as usize]);
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

/// The values of the two finest splittable levels, whose triangles cover no sample but their
/// corners and edges' midpoints, where the plane is the mean of the edge's ends.
///
/// The finest level splits the sides of the 2 × 2 cells at their midpoints (x + y odd): a
/// diamond's two triangles share that side as hypotenuse, so the value is the midpoint's
/// deviation from its side's ends. The level above splits each 2 × 2 cell along a diagonal
/// at its centre (x, y odd); the diagonals alternate in a checkerboard, `\` where the cell's
/// column plus row is even, as the roots' `\` starts it. A centre's two triangles cover the
/// centre and the cell's four side midpoints, so its value is the larger of its own
/// deviation and theirs.
fn finest_two_levels(h: &[f64], n: usize, value: &mut [f32]) {
    let deviation = |m: usize, p: usize, q: usize| (h[m] - (h[p] + h[q]) / 2.0).abs();
    for y in 0..n {
        let row = y * n;
        // Even rows: the horizontal sides' midpoints at odd x; odd rows: the vertical
        // sides' at even x.
        let first = if y % 2 == 0 { 1 } else { 0 };
        for x in (first..n).step_by(2) {
            let s = row + x;
            let d = if y % 2 == 0 {
                deviation(s, s - 1, s + 1)
            } else {
                deviation(s, s - n, s + n)
            };
            value[s] = round_up(d);
        }
    }
    for y in (1..n).step_by(2) {
        for x in (1..n).step_by(2) {
            let s = y * n + x;
            let backslash = (x / 2 + y / 2) % 2 == 0;
            let d = if backslash {
                deviation(s, s - n - 1, s + n + 1)
            } else {
                deviation(s, s - n + 1, s + n - 1)
            };
            value[s] = round_up(d)
                .max(value[s - 1])
                .max(value[s + 1])
                .max(value[s - n])
                .max(value[s + n]);
        }
    }
}

/// The scanned levels next above the two finest that read offset lists instead: from 4
/// (about 10 samples a triangle) to 64 (about 300), where a scanline's per-row set-up
/// costs more than the list's gathers.
const SHAPED_LEVELS: usize = 6;

/// Sample index → (x, y) without a division: `y = ⌊s · magic / 2⁴⁰⌋`. With `magic` =
/// ⌊2⁴⁰/n⌋ + 1 the quotient is exact while `s · n < 2⁴⁰`, far above any grid the
/// hierarchy allows (n ≤ 4097, s < n²: s · n < 2³⁷).
#[derive(Clone, Copy, Debug)]
struct Coords {
    n: u64,
    magic: u64,
}

impl Coords {
    fn new(n: usize) -> Self {
        let n = n as u64;
        Self {
            n,
            magic: (1 << 40) / n + 1,
        }
    }

    #[inline]
    fn xy(self, s: u32) -> (i64, i64) {
        let y = (u64::from(s) * self.magic) >> 40;
        ((u64::from(s) - y * self.n) as i64, y as i64)
    }
}

/// A triangle's plane `z = z_a + g_x·(x − x_a) + g_y·(y − y_a)`.
struct Plane {
    xa: i64,
    ya: i64,
    za: f64,
    gx: f64,
    gy: f64,
}

impl Plane {
    /// `None` for a degenerate triangle (never one of the bintree's).
    fn of(t: &Tri, h: &[f64], coords: Coords) -> Option<Self> {
        let (pa, pb, pc) = (coords.xy(t.a), coords.xy(t.b), coords.xy(t.c));
        let (za, zb, zc) = (h[t.a as usize], h[t.b as usize], h[t.c as usize]);
        let (ux, uy, uz) = ((pb.0 - pa.0) as f64, (pb.1 - pa.1) as f64, zb - za);
        let (vx, vy, vz) = ((pc.0 - pa.0) as f64, (pc.1 - pa.1) as f64, zc - za);
        let det = ux * vy - uy * vx;
        if det == 0.0 {
            return None;
        }
        Some(Self {
            xa: pa.0,
            ya: pa.1,
            za,
            gx: (uz * vy - uy * vz) / det,
            gy: (ux * vz - uz * vx) / det,
        })
    }
}

/// The samples one triangle shape covers, for every triangle of one level: a level holds a
/// few shapes (the hypotenuse along one axis or diagonal, the right angle on either side,
/// either end first), each with the same samples relative to its corner `a`.
#[derive(Debug)]
pub(super) struct Shapes {
    shapes: Vec<(ShapeKey, Vec<Offset>)>,
}

/// Per level, the shape lists of the levels [`TileErrors::new`] reads them for: built once
/// per grid size with the [`Hierarchy`] (finding a level's shapes looks at every triangle of
/// it, ~0.1 ms per tile at 257² when done per tile).
pub(super) fn level_shapes(hierarchy: &Hierarchy) -> Vec<Option<Shapes>> {
    let splittable = hierarchy.levels() - 1;
    let coords = Coords::new(hierarchy.side());
    (0..splittable)
        .map(|l| {
            (l + 2 < splittable && l + SHAPED_LEVELS + 2 >= splittable)
                .then(|| Shapes::of_level(hierarchy, l, coords))
        })
        .collect()
}

/// Corner b − a and c − a.
type ShapeKey = (i64, i64, i64, i64);

/// A covered sample: index offset from a, x − x_a, y − y_a.
type Offset = (isize, f64, f64);

impl Shapes {
    fn of_level(hierarchy: &Hierarchy, l: usize, coords: Coords) -> Self {
        let n = hierarchy.side() as i64;
        let mut shapes: Vec<(ShapeKey, Vec<Offset>)> = Vec::new();
        for t in &hierarchy.tris[hierarchy.level_start[l]..hierarchy.level_start[l + 1]] {
            let key = Self::key(t, coords);
            if shapes.iter().any(|(k, _)| *k == key) {
                continue;
            }
            let (bx, by, cx, cy) = key;
            // The closed triangle (0, 0), (bx, by), (cx, cy) by edge functions.
            let edge = |p: (i64, i64), q: (i64, i64), r: (i64, i64)| {
                (q.0 - p.0) * (r.1 - p.1) - (q.1 - p.1) * (r.0 - p.0)
            };
            let (a, b, c) = ((0, 0), (bx, by), (cx, cy));
            let sign = edge(a, b, c).signum();
            let mut samples = Vec::new();
            for y in 0.min(by).min(cy)..=0.max(by).max(cy) {
                for x in 0.min(bx).min(cx)..=0.max(bx).max(cx) {
                    let inside = [edge(b, c, (x, y)), edge(c, a, (x, y)), edge(a, b, (x, y))]
                        .iter()
                        .all(|&w| w * sign >= 0);
                    if inside {
                        samples.push(((y * n + x) as isize, x as f64, y as f64));
                    }
                }
            }
            shapes.push((key, samples));
        }
        Self { shapes }
    }

    #[inline]
    fn key(t: &Tri, coords: Coords) -> ShapeKey {
        let (pa, pb, pc) = (coords.xy(t.a), coords.xy(t.b), coords.xy(t.c));
        (pb.0 - pa.0, pb.1 - pa.1, pc.0 - pa.0, pc.1 - pa.1)
    }

    /// What [`plane_error`] returns for `t`, residual for residual: the same expression on
    /// the same samples (order does not change a max).
    fn error(&self, t: &Tri, h: &[f64], coords: Coords) -> f64 {
        let key = Self::key(t, coords);
        let (Some(plane), Some((_, samples))) = (
            Plane::of(t, h, coords),
            self.shapes.iter().find(|(k, _)| *k == key),
        ) else {
            return plane_error(t, h, coords);
        };
        let a = t.a as isize;
        let (mut hi, mut lo) = (f64::MIN, f64::MAX);
        for &(offset, dx, dy) in samples {
            let z = h[(a + offset) as usize];
            let d = z - (plane.za + (plane.gx * dx + plane.gy * dy));
            hi = if d > hi { d } else { hi };
            lo = if d < lo { d } else { lo };
        }
        hi.max(-lo)
    }
}

/// Largest |height − plane(a, b, c)| over the samples the triangle covers (edges included).
///
/// The triangle's edges run along the axes or the diagonals, so on every row each edge
/// crosses a whole sample and moves by −1, 0 or +1 sample per row: a scanline without
/// divisions. Each residual is `z − (z_a + (g_x·Δx + g_y·Δy))`, the expression
/// [`Shapes::error`] evaluates too, so both give one value for one triangle.
fn plane_error(t: &Tri, h: &[f64], coords: Coords) -> f64 {
    let Some(plane) = Plane::of(t, h, coords) else {
        return 0.0;
    };
    let n = coords.n as usize;
    let (pa, pb, pc) = (coords.xy(t.a), coords.xy(t.b), coords.xy(t.c));

    // Vertices top to bottom; the long edge v0–v2 bounds every row, the short ones split at
    // v1's row.
    let mut v = [pa, pb, pc];
    if v[0].1 > v[1].1 {
        v.swap(0, 1);
    }
    if v[1].1 > v[2].1 {
        v.swap(1, 2);
    }
    if v[0].1 > v[1].1 {
        v.swap(0, 1);
    }
    let slope = |p: (i64, i64), q: (i64, i64)| {
        if q.1 == p.1 {
            0
        } else {
            (q.0 - p.0) / (q.1 - p.1)
        }
    };
    let (long, upper, lower) = (slope(v[0], v[2]), slope(v[0], v[1]), slope(v[1], v[2]));
    let (mut hi, mut lo) = ([f64::MIN; LANES], [f64::MAX; LANES]);
    let lane: [f64; LANES] = std::array::from_fn(|k| k as f64);
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
        // Branch-free min/max lanes so the loop vectorises; offsets are small integers,
        // exact in f64.
        let gy_dy = plane.gy * (y - plane.ya) as f64;
        let mut dx = (x0 - plane.xa) as f64;
        let mut chunks = row.chunks_exact(LANES);
        for chunk in &mut chunks {
            for k in 0..LANES {
                let d = chunk[k] - (plane.za + (plane.gx * (dx + lane[k]) + gy_dy));
                hi[k] = if d > hi[k] { d } else { hi[k] };
                lo[k] = if d < lo[k] { d } else { lo[k] };
            }
            dx += LANES as f64;
        }
        for (k, &z) in chunks.remainder().iter().enumerate() {
            let d = z - (plane.za + (plane.gx * (dx + lane[k]) + gy_dy));
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
    use crate::ezw;
    use crate::wavelet::Wavelet;

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

    fn real_tiles() -> Vec<(String, Grid<f64>)> {
        let n = 257;
        let dem = crate::fixtures::n44w072();
        let mut tiles = Vec::new();
        for (row, col) in [(300, 500), (0, 0), (900, 100)] {
            let g = dem.crop(row, col, n, n).unwrap();
            for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
                let enc = ezw::encode(&g, &ezw::EncodeParams::new(wavelet, 1.0)).unwrap();
                for t in [0.5, 4.0] {
                    let limit = ezw::DecodeLimit::Threshold(t);
                    let d = ezw::decode(&enc.bytes, limit, ezw::DEFAULT_MAX_SAMPLES).unwrap();
                    let what = format!("{} T={t} at {row},{col}", wavelet.name());
                    tiles.push((what, d.heights));
                }
            }
            tiles.push((format!("raw {row},{col}"), g));
        }
        tiles
    }

    #[test]
    fn coords_divide_exactly_on_the_smallest_and_largest_grids() {
        for n in [3usize, 257, 4097] {
            let coords = Coords::new(n);
            for s in 0..(n * n) as u32 {
                let (x, y) = coords.xy(s);
                assert_eq!(
                    (x as usize, y as usize),
                    (s as usize % n, s as usize / n),
                    "{n}"
                );
            }
        }
    }

    #[test]
    fn shapes_give_the_scanline_error_bit_for_bit() {
        let h = Hierarchy::new(257).unwrap();
        let coords = Coords::new(257);
        let splittable = h.levels() - 1;
        for (what, g) in real_tiles() {
            // Every level a shape list can serve, beyond those that use one.
            for l in 0..splittable {
                let shapes = Shapes::of_level(&h, l, coords);
                assert!(
                    shapes.shapes.len() <= 8,
                    "level {l}: {}",
                    shapes.shapes.len()
                );
                for t in &h.tris[h.level_start[l]..h.level_start[l + 1]] {
                    let (fast, slow) = (
                        shapes.error(t, g.data(), coords),
                        plane_error(t, g.data(), coords),
                    );
                    assert_eq!(fast.to_bits(), slow.to_bits(), "{what}, level {l}: {t:?}");
                }
            }
        }
    }

    /// Against the error pass as it was (every triangle scanned, its corners found by
    /// division, the plane stepped along each row and restarted per chunk of lanes rather
    /// than evaluated per sample; the two finest levels per triangle rather than swept).
    /// Rounding could put a value one f32 step away; on these tiles, raw and decoded, not
    /// one is.
    #[test]
    fn values_equal_the_former_scanline_on_real_tiles() {
        fn old_plane_error(t: &Tri, h: &[f64], n: usize) -> f64 {
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
        // Every grid size up to 129 too: the sweep of the two finest levels is per size.
        let small = [3, 5, 9, 17, 33, 65, 129].map(|n| {
            (
                format!("raw {n}² at 700,700"),
                crate::fixtures::n44w072_crop(700, 700, n),
            )
        });
        for (what, g) in real_tiles().into_iter().chain(small) {
            let n = g.rows();
            let h = Hierarchy::new(n).unwrap();
            let e = TileErrors::new(&h, &g);
            let splittable = h.levels() - 1;
            let mut value = vec![0f32; n * n];
            for l in (0..splittable).rev() {
                for t in h.level_start[l]..h.level_start[l + 1] {
                    let tri = h.tris[t];
                    let m = tri.m as usize;
                    let mut v = value[m].max(round_up(old_plane_error(&tri, g.data(), n)));
                    if l + 1 < splittable {
                        let first = h.first_child(l, t);
                        v = v.max(value[h.tris[first].m as usize]);
                        v = v.max(value[h.tris[first + 1].m as usize]);
                    }
                    value[m] = v;
                }
            }
            for (s, (&new, &old)) in e.value.iter().zip(&value).enumerate() {
                assert_eq!(
                    new.to_bits(),
                    old.to_bits(),
                    "{what} sample {s}: {new} vs {old}"
                );
            }
        }
    }

    #[test]
    fn every_triangle_error_matches_the_brute_force_definition() {
        let n = 17;
        let h = Hierarchy::new(n).unwrap();
        let g = crate::fixtures::n44w072_crop(700, 700, n);
        for t in &h.tris {
            let fast = plane_error(t, g.data(), Coords::new(n));
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
