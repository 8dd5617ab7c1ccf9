//! Quadric error metric simplification: Garland & Heckbert, *Surface Simplification Using
//! Quadric Error Metrics* (SIGGRAPH 1997; notes in `seeds/quadric-error-metrics-notes.ko.md`).
//!
//! Pair contraction (v₁, v₂) → v̄ in order of the quadric error of v̄, with the paper's §6
//! refinements: boundary-preserving penalty planes, no face flips, and optional aggregation of
//! vertex pairs closer than t. Beyond the paper, three things decided by measurement (see
//! `qem.md` beside this file):
//! - the mesh stays manifold: an edge contracts only if it passes the link condition of Dey,
//!   Edelsbrunner et al., *Topology Preserving Edge Contraction* (1999);
//! - sharp creases get penalty planes like boundaries, so CAD corners are not shaved off;
//! - pairs are contracted in passes over a sorted list (as meshoptimizer does) instead of one
//!   at a time from a heap: a pass takes pairs in error order while none touches a vertex the
//!   pass already moved, so every error used is exact, and only moved vertices are re-ranked.
//!
//! Layout, for speed: large meshes renumbered along a Morton curve; positions, quadrics and
//! flags in flat arrays; faces as index triples with a dead marker; each vertex's faces a slice
//! of one growing reference array. No hash map is touched in the contraction loop.

mod contract;
mod quadric;
mod ranked;
mod state;

use glam::DVec3;
use serde::Serialize;

pub use quadric::Quadric;

use super::error::MeshError;
use super::indexed::{Aabb, TriMesh};
use crate::error::ParamError;

/// Weight of the boundary penalty planes per unit of squared edge length, relative to the
/// face-area weights of the ordinary planes (paper §6 "Preserving Boundaries").
pub const DEFAULT_BOUNDARY_WEIGHT: f64 = 10.0;
/// Dihedral angle above which an edge is a crease that keeps its shape, in degrees.
pub const DEFAULT_CREASE_ANGLE_DEG: f64 = 45.0;
/// Weight of the crease penalty planes, as [`DEFAULT_BOUNDARY_WEIGHT`] is for boundaries.
pub const DEFAULT_CREASE_WEIGHT: f64 = 3.0;
/// Largest turn of a face normal a collapse may cause, in degrees (paper §6 "Preventing Mesh
/// Inversion"): 90° rejects exactly the collapses that flip a face.
pub const DEFAULT_MAX_NORMAL_TURN_DEG: f64 = 90.0;

/// What to simplify to and how.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QemOptions {
    /// Stop once at most this many faces remain (0: no face target). An interior collapse
    /// removes two faces, so the result has `target_faces` or `target_faces − 1` faces. The
    /// last face is never removed, whatever the target or error limit.
    pub target_faces: usize,
    /// Stop before the first collapse whose error exceeds this fraction of the bounding-box
    /// diagonal (0.01 = 1 %; `f64::INFINITY`: no limit). The error of a vertex is the
    /// area-weighted RMS distance to the planes merged into it.
    pub max_error: f64,
    /// Boundary penalty weight ([`DEFAULT_BOUNDARY_WEIGHT`]; 0 lets boundaries drift).
    pub boundary_weight: f64,
    /// Edges whose faces meet at more than this dihedral angle are creases (degrees, in
    /// [0, 180]; [`DEFAULT_CREASE_ANGLE_DEG`]).
    pub crease_angle_deg: f64,
    /// Crease penalty weight ([`DEFAULT_CREASE_WEIGHT`]; 0 treats creases like any edge).
    pub crease_weight: f64,
    /// Collapses that turn a surviving face's normal by more than this are rejected (degrees,
    /// in (0, 180]; [`DEFAULT_MAX_NORMAL_TURN_DEG`]).
    pub max_normal_turn_deg: f64,
    /// Aggregation distance t as a fraction of the bounding-box diagonal: vertices of different
    /// parts closer than t may merge (paper §3.1). 0 (the default) contracts edges only.
    pub aggregation: f64,
}

impl Default for QemOptions {
    fn default() -> Self {
        Self {
            target_faces: 0,
            max_error: f64::INFINITY,
            boundary_weight: DEFAULT_BOUNDARY_WEIGHT,
            crease_angle_deg: DEFAULT_CREASE_ANGLE_DEG,
            crease_weight: DEFAULT_CREASE_WEIGHT,
            max_normal_turn_deg: DEFAULT_MAX_NORMAL_TURN_DEG,
            aggregation: 0.0,
        }
    }
}

impl QemOptions {
    /// Simplify to `faces` faces, everything else default.
    pub fn to_faces(faces: usize) -> Self {
        Self {
            target_faces: faces,
            ..Self::default()
        }
    }

    /// Simplify while the error stays below `fraction` of the bounding-box diagonal.
    pub fn to_error(fraction: f64) -> Self {
        Self {
            max_error: fraction,
            ..Self::default()
        }
    }

    fn check(&self) -> Result<(), ParamError> {
        let bad = |name, expected, got: f64| ParamError::OutOfRange {
            name,
            expected,
            got: got.to_string(),
        };
        if self.target_faces == 0 && !self.max_error.is_finite() {
            return Err(ParamError::OutOfRange {
                name: "target_faces / max_error",
                expected: "a face target > 0 or a finite error limit",
                got: "neither".into(),
            });
        }
        if self.max_error.is_nan() || self.max_error < 0.0 {
            return Err(bad("max_error", "≥ 0", self.max_error));
        }
        for (name, w) in [
            ("boundary_weight", self.boundary_weight),
            ("crease_weight", self.crease_weight),
        ] {
            if !(w.is_finite() && w >= 0.0) {
                return Err(bad(name, "finite and ≥ 0", w));
            }
        }
        if !(0.0..=180.0).contains(&self.crease_angle_deg) {
            return Err(bad(
                "crease_angle_deg",
                "in [0, 180]",
                self.crease_angle_deg,
            ));
        }
        if !(self.max_normal_turn_deg > 0.0 && self.max_normal_turn_deg <= 180.0) {
            return Err(bad(
                "max_normal_turn_deg",
                "in (0, 180]",
                self.max_normal_turn_deg,
            ));
        }
        if !(0.0..=1.0).contains(&self.aggregation) {
            return Err(bad("aggregation", "in [0, 1]", self.aggregation));
        }
        Ok(())
    }
}

/// Why the simplifier stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// At or below the face target, or down to the one face always kept.
    TargetReached,
    /// The next collapse would exceed the error limit.
    ErrorLimit,
    /// Every remaining collapse would flip a face or break the manifold.
    NoValidCollapse,
}

/// What the simplifier did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QemReport {
    pub vertices_in: usize,
    pub faces_in: usize,
    pub vertices_out: usize,
    pub faces_out: usize,
    /// Edge collapses and aggregations (non-edge pairs) performed.
    pub collapses: usize,
    pub aggregations: usize,
    /// Candidates refused by the link condition and by the normal test (a candidate can be
    /// refused once per pass as its neighbourhood changes).
    pub rejected_topology: usize,
    pub rejected_flip: usize,
    /// Passes over the ranked list.
    pub passes: usize,
    /// Largest error of a performed collapse, as a fraction of the bounding-box diagonal.
    pub max_error: f64,
    pub stop: Stop,
}

/// Simplifies `mesh` by quadric-error pair contraction until `options` say stop.
///
/// The input must pass [`TriMesh::check`]; faces that repeat a vertex are dropped. Vertices on
/// edges with more than two faces are never moved (run [`crate::mesh::repair`] to cut such
/// edges open first). Output vertices are the survivors, in input order.
///
/// ```
/// use zerotile_codec::mesh::{simplify, QemOptions, TriMesh};
/// use glam::DVec3;
/// // A flat 3×3-vertex grid: 8 triangles that one plane describes exactly.
/// let positions = (0..9u32)
///     .map(|i| DVec3::new(f64::from(i % 3), f64::from(i / 3), 0.0))
///     .collect();
/// let mut faces = Vec::new();
/// for (x, y) in [(0u32, 0u32), (1, 0), (0, 1), (1, 1)] {
///     let v = |dx: u32, dy: u32| (x + dx) + 3 * (y + dy);
///     faces.push([v(0, 0), v(1, 0), v(1, 1)]);
///     faces.push([v(0, 0), v(1, 1), v(0, 1)]);
/// }
/// let (out, report) = simplify(&TriMesh::new(positions, faces), &QemOptions::to_faces(6))?;
/// assert!(out.face_count() <= 6 && out.face_count() >= 5);
/// // Flat in, flat out: the error stays far below 0.1 % of the diagonal.
/// assert!(report.max_error < 1e-3);
/// # Ok::<(), zerotile_codec::mesh::MeshError>(())
/// ```
pub fn simplify(mesh: &TriMesh, options: &QemOptions) -> Result<(TriMesh, QemReport), MeshError> {
    // Contracts first: finite coordinates, indices in range, sane options.
    mesh.check()?;
    options.check()?;
    let bounds = mesh.bounding_box();
    let diagonal = bounds.diagonal();
    // A side past f64::MAX (ends of opposite signs near it) makes the diagonal NaN: scaled
    // too. As `> 0.0` it was not, and every error overflowed: a bipyramid 2¹⁰²⁴ tall lost a
    // pole edge under a limit of 20 % that the same shape at any other scale keeps, and
    // reported an error of 0.
    if diagonal != 0.0 && !NATIVE_DIAGONALS.contains(&diagonal) {
        // Scaled by a power of two, exact both ways unless a coordinate is subnormal at
        // either scale: the errors are all relative to the diagonal, so the result is the
        // same mesh at the caller's scale.
        let [s1, s2] = unit_scale(&bounds);
        let unit = TriMesh::new(
            mesh.positions.iter().map(|p| *p * s1 * s2).collect(),
            mesh.faces.clone(),
        );
        if unit.positions.iter().any(|p| !p.is_finite()) {
            return Err(MeshError::Unsupported(format!(
                "a mesh {diagonal:e} across lying as far as {:e} from the origin: its \
                 coordinates do not fit f64 once scaled to simplify it",
                bounds.min.abs().max(bounds.max.abs()).max_element()
            )));
        }
        let (mut out, report) = simplify(&unit, options)?;
        for p in &mut out.positions {
            *p = *p / s2 / s1;
        }
        return Ok((out, report));
    }
    // Per-vertex quadrics from the area-weighted planes of the incident faces (paper §5).
    let mut state = state::State::new(mesh, options, diagonal)?;
    // Penalty planes along open boundaries and creases; non-manifold edges lock their ends.
    state.classify_edges(options);
    // Close non-edge pairs join the candidates when aggregating (paper §3.1–3.2). `>` as `>=`
    // is equivalent: `add_virtual_pairs` adds no pair at t = 0.
    if options.aggregation > 0.0 {
        state.add_virtual_pairs(options.aggregation * diagonal);
    }
    // Contract in error order until the target or the error limit says stop. At least one
    // face stays: a lone triangle contracts away whole, so under a loose error limit an open
    // mesh's parts went one by one and the answer was empty (the vase at 50 % of the diagonal),
    // which no face target gives.
    let limit = options.max_error * diagonal;
    let stop = state.run(options.target_faces.max(1), limit * limit);
    // Survivors out, in input order.
    let (out, mut report) = state.finish();
    report.stop = stop;
    report.max_error = if diagonal > 0.0 {
        report.max_error / diagonal
    } else {
        0.0
    };
    Ok((out, report))
}

/// Two powers of two whose product brings the mesh's longest side near 1. Two, because the
/// product for a side near the ends of the f64 range (2^±1074) is itself out of range; each
/// is within 2^±540. The sides are taken as quarters, which never overflow.
fn unit_scale(b: &Aabb) -> [f64; 2] {
    let quarter = (b.max * 0.25 - b.min * 0.25).max_element();
    let log2 = if quarter > 0.0 {
        quarter.log2() + 2.0
    } else {
        // A side of a few subnormal steps, whose quarter rounds to 0.
        (b.max - b.min).max_element().log2()
    };
    let k = log2.round().clamp(-1100.0, 1100.0) as i32;
    [2f64.powi(-(k / 2)), 2f64.powi(-(k - k / 2))]
}

/// Diagonals simplified as they are; others are scaled near 1 first. Errors are ranked as f32
/// squared distances, which overflow past ~1e19 and flush to zero below ~1e-22 (and the
/// solve's determinant, a sixth power, sooner): a bunny scaled by 1e22 was simplified with
/// every error infinite, so `error=E` collapsed it to its last face and reported `inf`, and
/// one scaled by 1e-25 went the same way with every error zero.
const NATIVE_DIAGONALS: std::ops::RangeInclusive<f64> = 1e-6..=1e9;

/// Unit normal and offset of the plane through a triangle, and its area (zero area: `None`).
fn plane(a: DVec3, b: DVec3, c: DVec3) -> Option<(DVec3, f64, f64)> {
    let n = (b - a).cross(c - a);
    let len = n.length();
    (len > 0.0 && len.is_finite()).then(|| {
        let n = n / len;
        (n, -n.dot(a), 0.5 * len)
    })
}

#[cfg(test)]
mod mod_tests;
#[cfg(test)]
mod tests;
