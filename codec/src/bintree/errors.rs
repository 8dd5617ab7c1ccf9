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
    /// Per level, finest first, so children are final before their parents. The two
    /// finest levels are row-major sweeps over the grid (`finest_two_levels`); every
    /// level whose shapes each hold at least `LANES` triangles (at 257², all but the
    /// three coarsest) is evaluated `LANES` triangles of one shape side by side over
    /// the shape's precomputed rows (`Shapes`), which vectorises however short the rows
    /// are; the few big triangles left scan in vectorised rows (`plane_error`). Both
    /// evaluate each residual by one expression, so the values are those of the
    /// per-triangle pass bit for bit.
    pub fn new(hierarchy: &Hierarchy, heights: &Grid<f64>) -> Self {
        Self::exact_above(hierarchy, heights, 0.0)
    }

    /// Values that every tolerance ≥ `floor` reads as [`Self::new`]'s: where the exact value
    /// exceeds `floor` it is returned exactly; elsewhere a value may be lower (never above
    /// `floor`). A decoded tile is only ever meshed at tolerances above some floor (the
    /// server reads a stream to T/8 and meshes within 7T/8, so a decode depth fixes a lower
    /// bound on T), and whole regions can then skip the fine levels.
    ///
    /// The bound: inside a triangle τ with error E_τ, the plane of a descendant σ differs
    /// from τ's by at most E_τ (both interpolate heights, and at σ's corners τ's plane is
    /// within E_τ of them), so E_σ ≤ 2·E_τ. Every descendant of a triangle with 2·E_τ ≤
    /// `floor` is below any tolerance it will be read at: it is "quiet", its error is not
    /// computed (taken as 0), and only the raise of its children's values runs, which keeps
    /// the values of neighbouring, non-quiet diamonds propagating upwards. The test is made
    /// every `PRUNE_STEP` levels.
    pub fn exact_above(hierarchy: &Hierarchy, heights: &Grid<f64>, floor: f64) -> Self {
        let n = hierarchy.side();
        let mut value = vec![0f32; n * n];
        debug_assert_eq!((heights.rows(), heights.cols()), (n, n));
        if heights.rows() != n || heights.cols() != n {
            return Self { n, value };
        }
        let h = heights.data();
        let coords = Coords::new(n);
        // `levels() / 1` (the cell-centre level once more, through the general pass) moves
        // no value on the test tiles: that level's plane errors are the deviations
        // `finest_two_levels` took (a plane is the mean of an edge's ends along it), equal
        // unless the two expressions round to different f32, which
        // `values_equal_the_former_scanline_on_real_tiles` finds nowhere.
        let splittable = hierarchy.levels() - 1;
        finest_two_levels(h, n, &mut value);
        // The children's midpoints are those of c–a and b–c; their extents are even, so
        // the midpoint's index is the mean of the ends' (y·n + x is linear). The order of
        // the updates within a level does not matter: every value is a max of values that
        // are never −0, so the max of a set is one number whatever the order.
        let mut raise = |&Tri { a, b, c, m }: &Tri, own: f64| {
            let (a, b, c) = (a as usize, b as usize, c as usize);
            let (m, c1, c2) = (m as usize, (a + c) / 2, (b + c) / 2);
            value[m] = value[m].max(round_up(own)).max(value[c1]).max(value[c2]);
        };
        let prune = Prune::new(hierarchy, h, coords, floor);
        for l in (0..splittable.saturating_sub(2)).rev() {
            let level = &hierarchy.tris[hierarchy.level_start[l]..hierarchy.level_start[l + 1]];
            if let Some(own) = prune.own(l) {
                // A pruning level: its errors were computed on the way down.
                for (t, &own) in level.iter().zip(own) {
                    raise(t, own);
                }
                continue;
            }
            let quiet = prune.quiet_at(l);
            level_errors(hierarchy, l, h, coords, quiet.as_ref(), |_, t, own| {
                raise(t, own)
            });
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

/// Levels between the tests of [`TileErrors::exact_above`]: each test evaluates a level
/// top-down (reused on the way up). Testing every level measured the same as every second
/// (criterion `parts_257/tile_errors_above_*`, alternating runs, within 3 %).
const PRUNE_STEP: usize = 2;

/// Which triangles of a level lie inside a quiet triangle of a pruning level above it.
struct Quiet<'a> {
    flags: &'a [bool],
    /// log2 of the level gap: triangle i's ancestor is `i >> shift`.
    shift: usize,
}

impl Quiet<'_> {
    #[inline]
    fn get(&self, i: usize) -> bool {
        self.flags.get(i >> self.shift).copied().unwrap_or(false)
    }
}

/// The pruning levels' errors (computed coarse to fine, skipping quiet regions) and quiet
/// flags. Empty when `floor` is 0: every value is then exact.
struct Prune {
    /// (level, own error per triangle of it (0 where quiet from above), quiet flags)
    levels: Vec<(usize, Vec<f64>, Vec<bool>)>,
}

impl Prune {
    fn new(hierarchy: &Hierarchy, h: &[f64], coords: Coords, floor: f64) -> Self {
        let mut levels: Vec<(usize, Vec<f64>, Vec<bool>)> = Vec::new();
        let splittable = hierarchy.levels() - 1;
        if floor.is_nan() || floor <= 0.0 {
            return Self { levels };
        }
        // A hair of slack for the rounding of the residuals.
        let quiet_below = floor / (2.0 * (1.0 + 1e-6));
        for l in (PRUNE_STEP..splittable.saturating_sub(2)).step_by(PRUNE_STEP) {
            let level = &hierarchy.tris[hierarchy.level_start[l]..hierarchy.level_start[l + 1]];
            let above = quiet_in(&levels, l);
            let mut own = vec![0.0; level.len()];
            level_errors(hierarchy, l, h, coords, above.as_ref(), |i, _, e| {
                if let Some(slot) = own.get_mut(i) {
                    *slot = e;
                }
            });
            let quiet = own
                .iter()
                .enumerate()
                .map(|(i, &e)| above.as_ref().is_some_and(|q| q.get(i)) || e <= quiet_below)
                .collect();
            levels.push((l, own, quiet));
        }
        Self { levels }
    }

    /// The errors of `l` if it is a pruning level.
    fn own(&self, l: usize) -> Option<&[f64]> {
        // Only a saving: returning None recomputes the level under `quiet_at(l)`, the same
        // flags (of the pruning level above it) its errors were computed under, so the same
        // errors.
        self.levels
            .iter()
            .find(|(p, _, _)| *p == l)
            .map(|(_, own, _)| own.as_slice())
    }

    /// The quiet flags that apply to level `l`.
    fn quiet_at(&self, l: usize) -> Option<Quiet<'_>> {
        quiet_in(&self.levels, l)
    }
}

/// The quiet flags of the deepest pruning level of `levels` above `l`. None when nothing
/// there is quiet (a fine floor on rough ground), which spares the filter.
fn quiet_in(levels: &[(usize, Vec<f64>, Vec<bool>)], l: usize) -> Option<Quiet<'_>> {
    levels
        .iter()
        .rev()
        // `<=` would change nothing: callers never ask for a pruning level's own flags (a
        // pruning level reads its errors from `Prune::own`, and `Prune::new` asks before
        // pushing the level).
        .find(|(p, _, _)| *p < l)
        .filter(|(_, _, flags)| flags.contains(&true))
        .map(|(p, _, flags)| Quiet {
            flags: flags.as_slice(),
            shift: l - p,
        })
}

/// The own error of every triangle of level `l`, handed to `sink` with its index in the
/// level: through the level's shapes where it has them, else by scanline; 0, unevaluated,
/// for the triangles `quiet` names.
fn level_errors(
    hierarchy: &Hierarchy,
    l: usize,
    h: &[f64],
    coords: Coords,
    quiet: Option<&Quiet>,
    mut sink: impl FnMut(usize, &Tri, f64),
) {
    let level = &hierarchy.tris[hierarchy.level_start[l]..hierarchy.level_start[l + 1]];
    match hierarchy.shapes.get(l).and_then(Option::as_ref) {
        Some(shapes) => shapes.errors::<LANES>(level, h, quiet, sink),
        None => {
            for (i, t) in level.iter().enumerate() {
                let skip = quiet.is_some_and(|q| q.get(i));
                sink(i, t, if skip { 0.0 } else { plane_error(t, h, coords) });
            }
        }
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
    let deviation = |m: f64, p: f64, q: f64| round_up((m - (p + q) / 2.0).abs());
    for y in 0..n {
        let row = y * n;
        let out = &mut value[row..row + n];
        if y % 2 == 0 {
            // The horizontal sides' midpoints at odd x.
            let here = &h[row..row + n];
            for x in (1..n).step_by(2) {
                out[x] = deviation(here[x], here[x - 1], here[x + 1]);
            }
        } else {
            // The vertical sides' at even x.
            let (up, here, down) = (&h[row - n..row], &h[row..row + n], &h[row + n..row + 2 * n]);
            for x in (0..n).step_by(2) {
                out[x] = deviation(here[x], up[x], down[x]);
            }
        }
    }
    for y in (1..n).step_by(2) {
        let row = y * n;
        let (up, here, down) = (&h[row - n..row], &h[row..row + n], &h[row + n..row + 2 * n]);
        let (above, rest) = value[row - n..row + 2 * n].split_at_mut(n);
        let (out, below) = rest.split_at_mut(n);
        for x in (1..n).step_by(2) {
            let backslash = (x / 2 + y / 2) % 2 == 0;
            let d = if backslash {
                deviation(here[x], up[x - 1], down[x + 1])
            } else {
                deviation(here[x], up[x + 1], down[x - 1])
            };
            out[x] = d
                .max(out[x - 1])
                .max(out[x + 1])
                .max(above[x])
                .max(below[x]);
        }
    }
}

/// Sample index → (x, y) without a division: `y = ⌊s · magic / 2⁴⁰⌋`. With `magic` =
/// ⌊2⁴⁰/n⌋ + 1 the quotient is exact while `s · n < 2⁴⁰`, far above any grid the
/// hierarchy allows (n ≤ 4097, s < n²: s · n < 2³⁷).
#[derive(Clone, Copy, Debug)]
pub(super) struct Coords {
    n: u64,
    magic: u64,
}

impl Coords {
    pub(super) fn new(n: usize) -> Self {
        let n = n as u64;
        Self {
            n,
            magic: (1 << 40) / n + 1,
        }
    }

    #[inline]
    pub(super) fn xy(self, s: u32) -> (i64, i64) {
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
///
/// Each shape keeps its triangles' indices, so a level is evaluated [`LANES`] triangles
/// of one shape at a time: the lanes share the shape's rows and run the scanline's
/// expression side by side, where one triangle's short rows would leave the lanes idle.
#[derive(Debug)]
pub(super) struct Shapes {
    shapes: Vec<Shape>,
}

#[derive(Debug)]
struct Shape {
    /// Corner b − a and c − a as the plane's set-up reads them.
    ux: f64,
    uy: f64,
    vx: f64,
    vy: f64,
    det: f64,
    /// `1 / det` when `det` is a power of two, so that `x * inv` is `x / det` bit for bit
    /// (true of every bintree shape: ±2s² or ±4s² for a power of two s).
    inv: Option<f64>,
    /// The covered samples, one contiguous run per row.
    rows: Vec<Run>,
    /// The columns the runs cover: x − x_a from `dx0` to `dx0 + width − 1`.
    dx0: f64,
    width: usize,
    /// The level's triangles of this shape (index within the level); [`Shapes::errors`]
    /// fills a short last group of lanes with copies of its last triangle.
    tris: Vec<u32>,
}

/// One row of a shape: `len` samples from index offset `offset` (relative to a), in
/// the shape's columns from `column` on, at y − y_a = `dy`.
#[derive(Clone, Copy, Debug)]
struct Run {
    offset: isize,
    len: usize,
    column: usize,
    dy: f64,
}

/// Per level, the shape lists of the levels [`TileErrors::new`] reads them for (below the
/// two finest, where every shape fills the lanes): built once per grid size with the
/// [`Hierarchy`] (finding a level's shapes looks at every triangle of it, ~0.1 ms per tile
/// at 257² when done per tile).
pub(super) fn level_shapes(hierarchy: &Hierarchy) -> Vec<Option<Shapes>> {
    let splittable = hierarchy.levels() - 1;
    let coords = Coords::new(hierarchy.side());
    (0..splittable)
        .map(|l| {
            let shapes = (l + 2 < splittable)
                .then(|| Shapes::group(hierarchy, l, coords))
                .filter(|groups| groups.iter().all(|(_, tris)| tris.len() >= LANES))?;
            Some(Shapes::of_groups(hierarchy.side(), shapes))
        })
        .collect()
}

/// Corner b − a and c − a.
type ShapeKey = (i64, i64, i64, i64);

impl Shapes {
    #[cfg(test)]
    fn of_level(hierarchy: &Hierarchy, l: usize, coords: Coords) -> Self {
        Self::of_groups(hierarchy.side(), Self::group(hierarchy, l, coords))
    }

    /// The level's triangles (indices within it) by shape.
    fn group(hierarchy: &Hierarchy, l: usize, coords: Coords) -> Vec<(ShapeKey, Vec<u32>)> {
        let level = &hierarchy.tris[hierarchy.level_start[l]..hierarchy.level_start[l + 1]];
        let mut groups: Vec<(ShapeKey, Vec<u32>)> = Vec::new();
        for (i, t) in level.iter().enumerate() {
            let key = Self::key(t, coords);
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, tris)) => tris.push(i as u32),
                None => groups.push((key, vec![i as u32])),
            }
        }
        groups
    }

    fn of_groups(n: usize, groups: Vec<(ShapeKey, Vec<u32>)>) -> Self {
        let n = n as i64;
        let mut shapes: Vec<Shape> = Vec::new();
        for (key, tris) in groups {
            let (bx, by, cx, cy) = key;
            // The closed triangle (0, 0), (bx, by), (cx, cy) by edge functions.
            let edge = |p: (i64, i64), q: (i64, i64), r: (i64, i64)| {
                (q.0 - p.0) * (r.1 - p.1) - (q.1 - p.1) * (r.0 - p.0)
            };
            let (a, b, c) = ((0, 0), (bx, by), (cx, cy));
            let sign = edge(a, b, c).signum();
            let mut rows = Vec::new();
            let (x_min, x_max) = (0.min(bx).min(cx), 0.max(bx).max(cx));
            for y in 0.min(by).min(cy)..=0.max(by).max(cy) {
                let covered: Vec<i64> = (x_min..=x_max)
                    .filter(|&x| {
                        [edge(b, c, (x, y)), edge(c, a, (x, y)), edge(a, b, (x, y))]
                            .iter()
                            .all(|&w| w * sign >= 0)
                    })
                    .collect();
                if let (Some(&x0), Some(&x1)) = (covered.first(), covered.last()) {
                    // A triangle is convex: its samples on a row are one run.
                    debug_assert_eq!(covered.len() as i64, x1 - x0 + 1);
                    rows.push(Run {
                        offset: (y * n + x0) as isize,
                        len: covered.len(),
                        column: (x0 - x_min) as usize,
                        dy: y as f64,
                    });
                }
            }
            let (ux, uy, vx, vy) = (bx as f64, by as f64, cx as f64, cy as f64);
            let det = ux * vy - uy * vx;
            let inv =
                (det != 0.0 && det.abs().to_bits() & ((1u64 << 52) - 1) == 0).then(|| 1.0 / det);
            shapes.push(Shape {
                ux,
                uy,
                vx,
                vy,
                det,
                inv,
                rows,
                dx0: x_min as f64,
                width: (x_max - x_min + 1) as usize,
                tris,
            });
        }
        Self { shapes }
    }

    #[inline]
    fn key(t: &Tri, coords: Coords) -> ShapeKey {
        let (pa, pb, pc) = (coords.xy(t.a), coords.xy(t.b), coords.xy(t.c));
        (pb.0 - pa.0, pb.1 - pa.1, pc.0 - pa.0, pc.1 - pa.1)
    }

    /// What [`plane_error`] returns for each triangle of the level `level` (its
    /// triangles), handed to `sink` with the triangle and its index in the level, shape by
    /// shape: the same expression on the same samples, residual for residual (order does
    /// not change a max).
    ///
    /// Triangles `quiet` names are handed over with 0 and not evaluated.
    fn errors<const L: usize>(
        &self,
        level: &[Tri],
        h: &[f64],
        quiet: Option<&Quiet>,
        mut sink: impl FnMut(usize, &Tri, f64),
    ) {
        let mut active = Vec::new();
        for shape in &self.shapes {
            if shape.det == 0.0 {
                // Degenerate (never one of the bintree's): as plane_error.
                for &t in &shape.tris {
                    sink(t as usize, &level[t as usize], 0.0);
                }
                continue;
            }
            let tris = match quiet {
                None => &shape.tris,
                Some(q) => {
                    active.clear();
                    for &t in &shape.tris {
                        if q.get(t as usize) {
                            sink(t as usize, &level[t as usize], 0.0);
                        } else {
                            active.push(t);
                        }
                    }
                    &active
                }
            };
            let mut products = vec![[0.0; L]; shape.width];
            for group in tris.chunks(L) {
                // A short last group repeats its last triangle.
                let tri: [Tri; L] =
                    std::array::from_fn(|k| level[group[k.min(group.len() - 1)] as usize]);
                let err = shape.error(&tri, h, &mut products);
                for ((&t, tri), err) in group.iter().zip(&tri).zip(err) {
                    sink(t as usize, tri, err);
                }
            }
        }
    }
}

impl Shape {
    /// The errors of [`L`] triangles of this shape, side by side.
    #[inline]
    fn error<const L: usize>(
        &self,
        tri: &[Tri; L],
        h: &[f64],
        products: &mut [[f64; L]],
    ) -> [f64; L] {
        let (mut za, mut gx, mut gy) = ([0f64; L], [0f64; L], [0f64; L]);
        for k in 0..L {
            // Plane::of with the shape's constants.
            let t = &tri[k];
            let (a, b, c) = (h[t.a as usize], h[t.b as usize], h[t.c as usize]);
            let (uz, vz) = (b - a, c - a);
            let (px, py) = (uz * self.vy - self.uy * vz, self.ux * vz - uz * self.vx);
            za[k] = a;
            (gx[k], gy[k]) = match self.inv {
                Some(inv) => (px * inv, py * inv),
                None => (px / self.det, py / self.det),
            };
        }
        // g_x·Δx once per column rather than once per sample: the same products.
        for (j, p) in products.iter_mut().enumerate() {
            let dx = self.dx0 + j as f64;
            *p = std::array::from_fn(|k| gx[k] * dx);
        }
        let mut worst = [f64::MIN; L];
        for run in &self.rows {
            let row: [&[f64]; L] = std::array::from_fn(|k| {
                let start = (tri[k].a as isize + run.offset) as usize;
                &h[start..start + run.len]
            });
            let gy_dy: [f64; L] = std::array::from_fn(|k| gy[k] * run.dy);
            let gx_dx = &products[run.column..run.column + run.len];
            for (j, gx_dx) in gx_dx.iter().enumerate() {
                for k in 0..L {
                    let d = (row[k][j] - (za[k] + (gx_dx[k] + gy_dy[k]))).abs();
                    // `>=` is equivalent: an equal `d` is the same number (no −0 from
                    // `abs`, and `f64::MIN` is below any), and a NaN fails both.
                    worst[k] = if d > worst[k] { d } else { worst[k] };
                }
            }
        }
        worst
    }
}

/// Largest |height − plane(a, b, c)| over the samples the triangle covers (edges included).
///
/// The triangle's edges run along the axes or the diagonals, so on every row each edge
/// crosses a whole sample and moves by −1, 0 or +1 sample per row: a scanline without
/// divisions. Each residual is `|z − (z_a + (g_x·Δx + g_y·Δy))|`, the expression
/// [`Shapes::errors`] evaluates too, so both give one value for one triangle. (The largest
/// |d| is the larger of the largest d and −(the smallest d), what the pass computed before,
/// and NaN residuals are skipped by both.)
fn plane_error(t: &Tri, h: &[f64], coords: Coords) -> f64 {
    let Some(plane) = Plane::of(t, h, coords) else {
        return 0.0;
    };
    let n = coords.n as usize;
    let (pa, pb, pc) = (coords.xy(t.a), coords.xy(t.b), coords.xy(t.c));

    // Vertices top to bottom; the long edge v0–v2 bounds every row, the short ones split at
    // v1's row. `>=` in the three tests is equivalent: it also swaps two vertices on one row
    // (the top or the bottom), which trades the long edge's role with a short one's; each row
    // is bounded by the same two edges, and their `min` and `max` are unchanged.
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
    // g_x·Δx once per column (Δx is a small integer, exact in f64).
    let x_min = v[0].0.min(v[1].0).min(v[2].0);
    let x_max = v[0].0.max(v[1].0).max(v[2].0);
    let products: Vec<f64> = (x_min..=x_max)
        .map(|x| plane.gx * (x - plane.xa) as f64)
        .collect();
    let mut worst = [f64::MIN; LANES];
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
        let gx_dx = &products[(x0 - x_min) as usize..=(x1 - x_min) as usize];
        // Branch-free max lanes so the loop vectorises.
        let gy_dy = plane.gy * (y - plane.ya) as f64;
        let mut chunks = row.chunks_exact(LANES).zip(gx_dx.chunks_exact(LANES));
        // `>=` for `>` in both loops is equivalent, as in `Shape::error`.
        for (z, p) in &mut chunks {
            for k in 0..LANES {
                let d = (z[k] - (plane.za + (p[k] + gy_dy))).abs();
                worst[k] = if d > worst[k] { d } else { worst[k] };
            }
        }
        let done = row.len() / LANES * LANES;
        for (k, (&z, &p)) in row[done..].iter().zip(&gx_dx[done..]).enumerate() {
            let d = (z - (plane.za + (p + gy_dy))).abs();
            worst[k] = if d > worst[k] { d } else { worst[k] };
        }
    }
    worst.iter().copied().fold(f64::MIN, f64::max)
}

/// The f32 at or above `v`, so a stored error never understates the f64 one.
///
/// `f32::next_up` of `v as f32` when that is below `v`, without a branch: the hot loops
/// meet both cases about equally often, and a mispredicted branch cost more than the rest
/// of a sample. Below `v` means `v as f32` is finite or −∞ and not −0, where the next f32
/// up is one bit pattern up for a positive and one down for a negative.
#[inline]
fn round_up(v: f64) -> f32 {
    let f = v as f32;
    let up = u32::from(f64::from(f) < v);
    let bits = f.to_bits();
    f32::from_bits(bits.wrapping_add(up).wrapping_sub((up & (bits >> 31)) << 1))
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

    /// Above the floor the pruned values are the exact ones, below it never higher; and
    /// pruning skipped something on every real tile at a coarse floor.
    #[test]
    fn values_above_the_floor_are_exact_and_below_it_never_higher() {
        let h = Hierarchy::new(257).unwrap();
        for (what, g) in real_tiles() {
            let exact = TileErrors::new(&h, &g);
            for floor in [0.5, 3.0, 12.0, 48.0, 200.0] {
                let pruned = TileErrors::exact_above(&h, &g, floor);
                let mut lowered = 0;
                for (m, (&e, &p)) in exact.value.iter().zip(&pruned.value).enumerate() {
                    assert!(p <= e, "{what} floor {floor}: sample {m} {p} > exact {e}");
                    if f64::from(e) > floor {
                        assert_eq!(p, e, "{what} floor {floor}: sample {m}");
                    } else if p < e {
                        lowered += 1;
                    }
                }
                if floor >= 48.0 {
                    assert!(
                        lowered > 1000,
                        "{what} floor {floor}: pruned only {lowered}"
                    );
                }
            }
        }
    }

    /// What the mesher sees: at any tolerance at or above the floor, the pruned errors give
    /// the exact errors' mesh, triangle for triangle.
    #[test]
    fn meshes_at_or_above_the_floor_are_the_exact_ones() {
        let h = Hierarchy::new(257).unwrap();
        for (what, g) in real_tiles().into_iter().step_by(2) {
            let exact = TileErrors::new(&h, &g);
            for floor in [2.0, 12.0, 48.0] {
                let pruned = TileErrors::exact_above(&h, &g, floor);
                for tol in [floor, floor * 1.3, floor * 4.0] {
                    let a = super::super::extract(&h, &exact, &g, tol, None);
                    let b = super::super::extract(&h, &pruned, &g, tol, None);
                    assert_eq!(a.triangles, b.triangles, "{what} floor {floor} tol {tol}");
                }
            }
        }
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

    /// The branch-free `round_up` against its definition, `next_up` when below.
    #[test]
    fn round_up_is_the_f32_at_or_above() {
        fn reference(v: f64) -> f32 {
            let f = v as f32;
            if f64::from(f) < v {
                f.next_up()
            } else {
                f
            }
        }
        let mut values = vec![
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            1e-46,
            -1e-46,
            f64::from(f32::MAX),
            f64::from(f32::MAX) * (1.0 + 1e-12),
            -f64::from(f32::MAX) * (1.0 + 1e-12),
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut x = 0x1234_5678_9abc_def0u64;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = (x >> 11) as f64 / (1u64 << 53) as f64 * 2000.0 - 1000.0;
            values.push(v);
            values.push(v * 1e-30);
        }
        for v in values {
            assert_eq!(round_up(v).to_bits(), reference(v).to_bits(), "{v:e}");
        }
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
                // Every bintree det is a power of two: the plane divides by multiplying.
                assert!(shapes.shapes.iter().all(|s| s.inv.is_some()), "level {l}");
                let level = &h.tris[h.level_start[l]..h.level_start[l + 1]];
                let mut own = vec![f64::NAN; level.len()];
                shapes.errors::<LANES>(level, g.data(), None, |t, _, e| own[t] = e);
                for (t, fast) in level.iter().zip(own) {
                    let slow = plane_error(t, g.data(), coords);
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

    /// The shapes serve every level whose shapes each fill the lanes, except the two finest
    /// (`finest_two_levels` sweeps them): levels 3 to `splittable` − 3, so at 257² all but the
    /// three coarsest (2, 4 and 8 triangles in 2 or 4 shapes), which the scanline evaluates.
    /// A served level's shapes hold each of its triangles once.
    #[test]
    fn shapes_serve_every_level_but_the_three_coarsest_and_the_two_finest() {
        for n in [5usize, 9, 17, 257] {
            let h = Hierarchy::new(n).unwrap();
            let splittable = h.levels() - 1;
            assert_eq!(h.shapes.len(), splittable, "n {n}");
            for (l, shapes) in h.shapes.iter().enumerate() {
                let served = (3..splittable.saturating_sub(2)).contains(&l);
                assert_eq!(shapes.is_some(), served, "n {n} level {l}");
                let Some(shapes) = shapes else { continue };
                assert!(
                    shapes.shapes.iter().all(|s| s.tris.len() >= LANES),
                    "n {n} level {l}"
                );
                let mut tris: Vec<u32> =
                    shapes.shapes.iter().flat_map(|s| s.tris.clone()).collect();
                tris.sort_unstable();
                assert_eq!(tris, (0..2u32 << l).collect::<Vec<_>>(), "n {n} level {l}");
            }
        }
    }

    /// A shape whose det is not a power of two (no bintree triangle's: legs of 3 samples, det
    /// ±9) divides rather than multiplying by an inexact `1 / det`, and still gives the
    /// scanline's error bit for bit, for a full group of lanes and a short one; a degenerate
    /// shape gives 0, as the scanline does.
    #[test]
    fn shapes_of_any_det_give_the_scanline_error_bit_for_bit() {
        let n = 9;
        let g = crate::fixtures::n44w072_crop(700, 700, n);
        let coords = Coords::new(n);
        let s = |x: u32, y: u32| y * n as u32 + x;
        let tri = |a, b, c| Tri { a, b, c, m: 0 };
        // Corners a, b, c from (x, y).
        type Corners = fn(u32, u32) -> [(u32, u32); 3];
        let cases: [(&str, Corners, f64, Option<f64>); 4] = [
            (
                "legs of 3",
                |x, y| [(x, y), (x + 3, y), (x, y + 3)],
                9.0,
                None,
            ),
            (
                "mirrored",
                |x, y| [(x, y), (x, y + 3), (x + 3, y)],
                -9.0,
                None,
            ),
            (
                "legs of 2",
                |x, y| [(x, y), (x + 2, y), (x, y + 2)],
                4.0,
                Some(0.25),
            ),
            ("degenerate", |x, y| [(x, y); 3], 0.0, None),
        ];
        for (what, corners, det, inv) in cases {
            // Five triangles: a full group of lanes and a short one.
            let level: Vec<Tri> = [(0, 0), (5, 0), (2, 3), (0, 5), (4, 5)]
                .map(|(x, y)| {
                    let [a, b, c] = corners(x, y).map(|(x, y)| s(x, y));
                    tri(a, b, c)
                })
                .to_vec();
            let key = Shapes::key(&level[0], coords);
            assert!(
                level.iter().all(|t| Shapes::key(t, coords) == key),
                "{what}"
            );
            let shapes = Shapes::of_groups(n, vec![(key, (0..5).collect())]);
            assert_eq!(
                (shapes.shapes[0].det, shapes.shapes[0].inv),
                (det, inv),
                "{what}"
            );
            let mut own = vec![f64::NAN; level.len()];
            shapes.errors::<LANES>(&level, g.data(), None, |i, _, e| own[i] = e);
            for (t, fast) in level.iter().zip(own) {
                let slow = plane_error(t, g.data(), coords);
                assert_eq!(fast.to_bits(), slow.to_bits(), "{what}: {t:?}");
                if det == 0.0 {
                    assert_eq!(fast, 0.0, "{what}: {t:?}");
                } else {
                    let defined = brute_force(t, g.data(), n);
                    assert!(defined > 0.0, "{what}: {t:?}");
                    assert!((fast - defined).abs() <= 1e-9 * defined, "{what}: {t:?}");
                }
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
