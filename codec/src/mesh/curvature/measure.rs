//! Discrete curvature of one vertex from the faces around it (paper §3.1, DESIGN §3.1):
//! Gaussian curvature by the angle deficit, mean curvature by Steiner's formula with signed
//! dihedral angles, bending R = √(2H² − K), and the weighted R' the removal order uses.
//!
//! Area: Meyer et al.'s mixed Voronoi area (*Discrete Differential-Geometry Operators for
//! Triangulated 2-Manifolds*, 2002), not the paper's barycentric A/3. Both read a unit
//! sphere's regular vertices as K = H = 1, but A/3 reads 0.75 at a UV sphere's poles, whose
//! fans of thin triangles put the barycentre far from the Voronoi cell; the mixed area does
//! not, and it still sums to the surface area, so A/A_max in W keeps its meaning.
//!
//! H uses ¼ Σ eᵢ dᵢ: each edge's ½ e β belongs half to each end vertex. With the paper's ½
//! a unit sphere would read H = 2.

use std::f64::consts::PI;

use glam::DVec3;
use smallvec::SmallVec;

/// Weights and thresholds of the measure (paper eqs. 6–8; the paper picks them by
/// experiment and does not print its values).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Weights {
    /// λ_a: share of area in W (the rest is bending).
    pub area: f64,
    /// λ_f: bending multiplier of feature vertices (on a crease or a boundary).
    pub feature: f64,
    /// λ_s: bending multiplier of saddle vertices (K < 0).
    pub saddle: f64,
    /// Dihedral angle above which an edge is a feature edge, radians.
    pub feature_angle: f64,
    /// Which quantile of the input's A and R' is the scale "max" of eq. 8 (1 = the paper's
    /// maximum). A few sharp corners make the maximum of R' an outlier that flattens W on
    /// every smooth vertex; a high quantile keeps W's spread where the surface is.
    pub scale_quantile: f64,
}

impl Default for Weights {
    fn default() -> Self {
        Self {
            area: 0.6,
            feature: 1.5,
            saddle: 1.5,
            feature_angle: 40f64.to_radians(),
            scale_quantile: 0.97,
        }
    }
}

/// One vertex's curvature figures.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measure {
    /// Mixed area around the vertex.
    pub area: f64,
    pub gaussian: f64,
    pub mean: f64,
    /// R = √max(2H² − K, 0): clamped because cone-like corners make it negative.
    pub bending: f64,
    /// R' = λ_f R or λ_s R or R.
    pub weighted: f64,
    /// Feature edges at the vertex (creases above the angle, and boundary edges).
    pub feature_edges: u32,
    pub boundary: bool,
    /// An edge with more than two faces or a fan that is not one strip.
    pub non_manifold: bool,
}

impl Measure {
    /// A corner (three or more feature edges) holds the shape; decimation keeps it.
    pub fn is_corner(&self) -> bool {
        self.feature_edges >= 3
    }
}

/// What a face contributes to each of its corners, computed once per face: the trig is
/// the cost of decimation, and a face's corners are measured many times.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceGeom {
    pub normal: DVec3,
    pub area: f64,
    /// Interior angle and mixed-area share at each corner, in the face's vertex order.
    pub angle: [f64; 3],
    pub mixed: [f64; 3],
}

impl FaceGeom {
    /// `None` for a degenerate (zero-area or non-finite) face.
    pub fn new(p: [DVec3; 3]) -> Option<Self> {
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = n.length();
        let area = 0.5 * len;
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        let mut angle = [0.0; 3];
        let mut mixed = [0.0; 3];
        for k in 0..3 {
            let (o, a, b) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            angle[k] = self::angle(a - o, b - o);
            mixed[k] = mixed_area(o, a, b, area);
        }
        Some(Self {
            normal: n / len,
            area,
            angle,
            mixed,
        })
    }
}

/// Measures vertex `v` from its incident faces (each contains `v`, in the mesh's winding
/// order) and positions looked up by `pos`.
pub fn measure(
    v: u32,
    faces: &[[u32; 3]],
    pos: impl Fn(u32) -> DVec3,
    weights: &Weights,
) -> Measure {
    let with_geom = faces
        .iter()
        .filter_map(|&f| FaceGeom::new(f.map(&pos)).map(|g| (f, g)))
        .collect::<Vec<_>>();
    measure_with(v, with_geom, pos, weights)
}

/// [`measure`] from faces whose geometry is already known.
pub fn measure_with(
    v: u32,
    faces: impl IntoIterator<Item = ([u32; 3], FaceGeom)>,
    pos: impl Fn(u32) -> DVec3,
    weights: &Weights,
) -> Measure {
    let p = pos(v);
    let mut m = Measure::default();
    let mut angle_sum = 0.0;
    // Per neighbour: (neighbour, faces seen, normal of the first face, its far vertex).
    let mut edges: SmallVec<[(u32, u32, DVec3, DVec3); 16]> = SmallVec::new();
    let mut edge_term = 0.0;
    for (f, g) in faces {
        let Some(k) = f.iter().position(|&x| x == v) else {
            continue;
        };
        let (a, b) = (f[(k + 1) % 3], f[(k + 2) % 3]);
        angle_sum += g.angle[k];
        m.area += g.mixed[k];
        let normal = g.normal;
        for (u, far) in [(a, b), (b, a)] {
            match edges.iter_mut().find(|e| e.0 == u) {
                Some(e) => {
                    e.1 += 1;
                    if e.1 == 2 {
                        let d = signed_dihedral(p, e.2, e.3, normal, pos(far));
                        if d.abs() > weights.feature_angle {
                            m.feature_edges += 1;
                        }
                        edge_term += (pos(u) - p).length() * d;
                    }
                }
                None => edges.push((u, 1, normal, pos(far))),
            }
        }
    }
    for e in &edges {
        match e.1 {
            1 => {
                m.boundary = true;
                m.feature_edges += 1;
            }
            2 => {}
            _ => m.non_manifold = true,
        }
    }
    if m.area <= 0.0 {
        return m;
    }
    let full = if m.boundary { PI } else { 2.0 * PI };
    m.gaussian = (full - angle_sum) / m.area;
    m.mean = 0.25 * edge_term / m.area;
    m.bending = (2.0 * m.mean * m.mean - m.gaussian).max(0.0).sqrt();
    let feature = m.feature_edges > 0;
    m.weighted = m.bending
        * if feature {
            weights.feature
        } else if m.gaussian < 0.0 {
            weights.saddle
        } else {
            1.0
        };
    m
}

/// Discrete curvature W (paper eq. 8) with the original mesh's maxima as the scale, so W
/// before and after a removal are comparable.
pub fn discrete_curvature(m: &Measure, area_max: f64, weighted_max: f64, w: &Weights) -> f64 {
    let a = if area_max > 0.0 {
        m.area / area_max
    } else {
        0.0
    };
    let r = if weighted_max > 0.0 {
        m.weighted / weighted_max
    } else {
        0.0
    };
    w.area * a + (1.0 - w.area) * r
}

fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The dihedral at an edge from p between a face with unit normal `n1` (far vertex `f1`) and one
/// with `n2` (far vertex `f2`): the angle between the normals, positive where the surface
/// bends away from the normals (convex), negative where it folds towards them.
fn signed_dihedral(p: DVec3, n1: DVec3, f1: DVec3, n2: DVec3, f2: DVec3) -> f64 {
    let gamma = angle(n1, n2);
    // Convex when each face's far vertex lies below the other face's plane.
    let below = (f2 - p).dot(n1) + (f1 - p).dot(n2);
    if below < 0.0 {
        gamma
    } else if below > 0.0 {
        -gamma
    } else {
        0.0
    }
}

/// The share of triangle (p, a, b) of area `area` in p's mixed Voronoi cell (Meyer et al.,
/// fig. 4): the Voronoi part when the triangle is not obtuse, else half or a quarter of it.
fn mixed_area(p: DVec3, a: DVec3, b: DVec3, area: f64) -> f64 {
    let (pa, pb, ab) = (a - p, b - p, b - a);
    if pa.dot(pb) < 0.0 {
        return area / 2.0;
    }
    if (-pa).dot(ab) < 0.0 || (-pb).dot(-ab) < 0.0 {
        return area / 4.0;
    }
    // cot of the angles at a and b.
    let cot = |u: DVec3, w: DVec3| u.dot(w) / u.cross(w).length();
    let cot_a = cot(p - a, b - a);
    let cot_b = cot(p - b, a - b);
    (pb.length_squared() * cot_a + pa.length_squared() * cot_b) / 8.0
}
