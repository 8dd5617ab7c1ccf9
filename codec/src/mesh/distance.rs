//! Metro-style surface distances: Cignoni, Rocchini and Scopigno, *Metro: Measuring Error on
//! Simplified Surfaces* (Computer Graphics Forum 1998), as Garland & Heckbert's §6.1 evaluates
//! approximations.
//!
//! Each surface is sampled (its vertices plus area-weighted uniform points on its faces, from a
//! seeded generator so runs repeat exactly) and every sample's distance to the other surface is
//! found exactly (point–triangle distance, Ericson, *Real-Time Collision Detection* §5.1.5)
//! through a bounding-volume hierarchy of the other surface's triangles. The one-sided maxima
//! give the symmetric Hausdorff distance; the one-sided means the mean surface distance.

use glam::DVec3;
use serde::Serialize;

use super::error::{InvalidMesh, MeshError};
use super::indexed::{Aabb, TriMesh};
use crate::error::ParamError;

/// Metro's usual sample count per direction, and the benchmark's.
pub const DEFAULT_SAMPLES: usize = 200_000;
/// DVec3s per worker chunk: fixed so results do not depend on the thread count.
const CHUNK: usize = 8192;
/// Triangles per BVH leaf.
const LEAF: usize = 4;

/// How densely to sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct DistanceOptions {
    /// Face samples per direction (vertices are sampled in addition).
    pub samples: usize,
    /// Seed of the sample generator: the same seed gives the same numbers.
    pub seed: u64,
}

impl Default for DistanceOptions {
    fn default() -> Self {
        Self {
            samples: DEFAULT_SAMPLES,
            seed: 0x05EE_D0F3_E7E0,
        }
    }
}

/// Distances from the samples of one surface to the other surface, in mesh units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct OneSided {
    pub max: f64,
    pub mean: f64,
    pub rms: f64,
    pub samples: usize,
}

/// Both directions between surfaces A and B, with A's bounding-box diagonal as the unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SurfaceDistance {
    /// From A's samples to B.
    pub a_to_b: OneSided,
    /// From B's samples to A.
    pub b_to_a: OneSided,
    /// A's bounding-box diagonal.
    pub diagonal: f64,
}

impl SurfaceDistance {
    /// Symmetric Hausdorff distance: the larger one-sided maximum.
    pub fn hausdorff(&self) -> f64 {
        self.a_to_b.max.max(self.b_to_a.max)
    }

    /// Mean surface distance: the larger one-sided mean (as Metro and the benchmarks report).
    pub fn mean(&self) -> f64 {
        self.a_to_b.mean.max(self.b_to_a.mean)
    }

    /// [`Self::hausdorff`] as a percentage of A's diagonal.
    pub fn hausdorff_pct(&self) -> f64 {
        self.pct(self.hausdorff())
    }

    /// [`Self::mean`] as a percentage of A's diagonal.
    pub fn mean_pct(&self) -> f64 {
        self.pct(self.mean())
    }

    fn pct(&self, d: f64) -> f64 {
        if self.diagonal > 0.0 {
            100.0 * d / self.diagonal
        } else {
            0.0
        }
    }
}

/// Symmetric distances between `a` (the reference, usually the original) and `b`.
pub fn surface_distance(
    a: &TriMesh,
    b: &TriMesh,
    options: &DistanceOptions,
) -> Result<SurfaceDistance, MeshError> {
    // Both meshes must be usable and non-empty; a sample count of zero measures nothing.
    for m in [a, b] {
        m.check()?;
        if m.faces.is_empty() {
            return Err(InvalidMesh::Empty.into());
        }
    }
    if options.samples == 0 {
        return Err(ParamError::OutOfRange {
            name: "samples",
            expected: "> 0",
            got: "0".into(),
        }
        .into());
    }
    // A hierarchy over each surface's triangles answers the other one's nearest-point queries.
    let (bvh_a, bvh_b) = (Bvh::new(a), Bvh::new(b));
    // DVec3 each surface and measure against the other.
    let a_to_b = one_sided(&sample(a, options.samples, options.seed), &bvh_b);
    let b_to_a = one_sided(&sample(b, options.samples, options.seed ^ 1), &bvh_a);
    Ok(SurfaceDistance {
        a_to_b,
        b_to_a,
        diagonal: a.diagonal(),
    })
}

/// The referenced vertices, then `n` points spread over the faces in proportion to area
/// (error diffusion decides each face's count, a seeded generator the positions).
pub fn sample(mesh: &TriMesh, n: usize, seed: u64) -> Vec<DVec3> {
    let mut used = vec![false; mesh.positions.len()];
    for &i in mesh.faces.iter().flatten() {
        if let Some(u) = used.get_mut(i as usize) {
            *u = true;
        }
    }
    let mut out: Vec<DVec3> = mesh
        .positions
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(p, _)| *p)
        .collect();
    let areas = mesh.face_areas();
    let total: f64 = areas.iter().sum();
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return out;
    }
    out.reserve(n);
    let mut rng = SplitMix64(seed);
    let mut carry = 0.0;
    for (f, &area) in areas.iter().enumerate() {
        carry += n as f64 * area / total;
        let k = carry.floor();
        carry -= k;
        let Some([a, b, c]) = mesh.corners(f) else {
            continue;
        };
        for _ in 0..k as usize {
            let (mut s, mut t) = (rng.unit(), rng.unit());
            if s + t > 1.0 {
                (s, t) = (1.0 - s, 1.0 - t);
            }
            out.push(a + s * (b - a) + t * (c - a));
        }
    }
    out
}

/// Distances from every sample to the surface in `bvh`, in fixed-size chunks over the
/// available cores; chunk results are combined in order, so the numbers do not depend on the
/// thread count.
fn one_sided(samples: &[DVec3], bvh: &Bvh) -> OneSided {
    let chunks: Vec<&[DVec3]> = samples.chunks(CHUNK).collect();
    let workers = std::thread::available_parallelism()
        .map_or(1, std::num::NonZeroUsize::get)
        .clamp(1, chunks.len().max(1));
    let mut parts = vec![(0.0f64, 0.0f64, 0.0f64); chunks.len()];
    std::thread::scope(|s| {
        for (w, slots) in parts
            .chunks_mut(chunks.len().div_ceil(workers).max(1))
            .enumerate()
        {
            let first = w * chunks.len().div_ceil(workers).max(1);
            let chunks = &chunks;
            s.spawn(move || {
                for (i, slot) in slots.iter_mut().enumerate() {
                    *slot = measure_chunk(chunks[first + i], bvh);
                }
            });
        }
    });
    let (mut max, mut sum, mut sum_sq) = (0.0f64, 0.0, 0.0);
    for (m, s, q) in parts {
        max = max.max(m);
        sum += s;
        sum_sq += q;
    }
    let n = samples.len().max(1) as f64;
    OneSided {
        max,
        mean: sum / n,
        rms: (sum_sq / n).sqrt(),
        samples: samples.len(),
    }
}

/// (max, sum, sum of squares) of the distances of one chunk. Consecutive samples lie on the
/// same or neighbouring faces, so the last nearest face is a tight first bound for the next.
fn measure_chunk(samples: &[DVec3], bvh: &Bvh) -> (f64, f64, f64) {
    let (mut max, mut sum, mut sum_sq) = (0.0f64, 0.0, 0.0);
    let mut hint = 0;
    for &p in samples {
        let (d2, face) = bvh.nearest(p, hint);
        hint = face;
        let d = d2.sqrt();
        max = max.max(d);
        sum += d;
        sum_sq += d2;
    }
    (max, sum, sum_sq)
}

/// SplitMix64 (Steele, Lea and Flood 2014): tiny, seedable, good enough for sample positions.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 53 random bits.
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// A bounding-volume hierarchy over a mesh's triangles for nearest-point queries: median
/// splits on the longest axis of the centroids, nodes in depth-first order (the left child
/// follows its parent).
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangle corners in leaf order, and their original face ids.
    tris: Vec<[DVec3; 3]>,
    ids: Vec<u32>,
}

struct Node {
    bounds: Aabb,
    /// Leaf: first triangle; inner: index of the right child.
    index: u32,
    /// Leaf: number of triangles; inner: 0.
    count: u32,
}

impl Bvh {
    /// Builds the hierarchy over the faces of `mesh` whose indices are in range.
    pub fn new(mesh: &TriMesh) -> Self {
        let mut items: Vec<(u32, [DVec3; 3], DVec3)> = (0..mesh.faces.len())
            .filter_map(|f| {
                let t = mesh.corners(f)?;
                Some((f as u32, t, (t[0] + t[1] + t[2]) / 3.0))
            })
            .collect();
        let mut nodes = Vec::with_capacity(2 * items.len() / LEAF + 1);
        if !items.is_empty() {
            build(&mut items, 0, &mut nodes);
        }
        Self {
            nodes,
            tris: items.iter().map(|i| i.1).collect(),
            ids: items.iter().map(|i| i.0).collect(),
        }
    }

    /// Squared distance from `p` to the nearest triangle and that triangle's leaf-order slot;
    /// `hint` (a slot from an earlier query) seeds the search bound. Infinite when empty.
    pub fn nearest(&self, p: DVec3, hint: u32) -> (f64, u32) {
        let mut best = (f64::INFINITY, 0);
        if let Some(t) = self.tris.get(hint as usize) {
            best = (point_triangle_sq(p, t), hint);
        }
        let mut stack = [0u32; 64];
        let mut top = usize::from(!self.nodes.is_empty());
        while top > 0 {
            top -= 1;
            let i = stack[top] as usize;
            let node = &self.nodes[i];
            if box_distance_sq(p, &node.bounds) >= best.0 {
                continue;
            }
            if node.count > 0 {
                let s = node.index as usize;
                for (k, t) in self.tris[s..s + node.count as usize].iter().enumerate() {
                    let d = point_triangle_sq(p, t);
                    if d < best.0 {
                        best = (d, (s + k) as u32);
                    }
                }
                continue;
            }
            // Visit the nearer child first: push it last.
            let (l, r) = (i + 1, node.index as usize);
            let dl = box_distance_sq(p, &self.nodes[l].bounds);
            let dr = box_distance_sq(p, &self.nodes[r].bounds);
            let (near, far) = if dl <= dr { (l, r) } else { (r, l) };
            if top + 2 <= stack.len() {
                stack[top] = far as u32;
                stack[top + 1] = near as u32;
                top += 2;
            }
        }
        best
    }

    /// The original face id of a leaf-order slot returned by [`Self::nearest`].
    pub fn face_id(&self, slot: u32) -> Option<u32> {
        self.ids.get(slot as usize).copied()
    }
}

/// Builds the subtree over `items` (placed from triangle slot `first`); returns its node index.
fn build(items: &mut [(u32, [DVec3; 3], DVec3)], first: usize, nodes: &mut Vec<Node>) -> usize {
    let bounds = items
        .iter()
        .flat_map(|i| i.1)
        .fold(Aabb::default(), Aabb::grow);
    let me = nodes.len();
    nodes.push(Node {
        bounds,
        index: first as u32,
        count: items.len() as u32,
    });
    if items.len() <= LEAF {
        return me;
    }
    let centres = items.iter().fold(Aabb::default(), |b, i| b.grow(i.2));
    let extent = centres.max - centres.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.2[axis].total_cmp(&b.2[axis]));
    let (left, right) = items.split_at_mut(mid);
    build(left, first, nodes);
    let r = build(right, first + mid, nodes);
    nodes[me].index = r as u32;
    nodes[me].count = 0;
    me
}

fn box_distance_sq(p: DVec3, b: &Aabb) -> f64 {
    let d = (b.min - p).max(p - b.max).max(DVec3::ZERO);
    d.length_squared()
}

/// Squared distance from `p` to triangle `t` (Ericson §5.1.5, closest point by Voronoi region).
pub fn point_triangle_sq(p: DVec3, t: &[DVec3; 3]) -> f64 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (ap - v * ab).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (ap - w * ac).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + w * (c - b))).length_squared();
    }
    let denom = va + vb + vc;
    if denom.abs() <= f64::MIN_POSITIVE {
        // Degenerate (zero-area) triangle: the nearest of its three edges.
        let seg = |u: DVec3, v: DVec3| {
            let e = v - u;
            let l = e.length_squared();
            let s = if l > 0.0 {
                ((p - u).dot(e) / l).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (u + s * e)).length_squared()
        };
        return seg(a, b).min(seg(b, c)).min(seg(c, a));
    }
    let (v, w) = (vb / denom, vc / denom);
    (p - (a + ab * v + ac * w)).length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_square(z: f64) -> TriMesh {
        TriMesh::new(
            vec![
                DVec3::new(0.0, 0.0, z),
                DVec3::new(1.0, 0.0, z),
                DVec3::new(1.0, 1.0, z),
                DVec3::new(0.0, 1.0, z),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn point_triangle_distance_in_every_region() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let cases = [
            (DVec3::new(0.2, 0.2, 1.0), 1.0),   // face
            (DVec3::new(-1.0, -1.0, 0.0), 2.0), // vertex a
            (DVec3::new(2.0, 0.0, 0.0), 1.0),   // vertex b
            (DVec3::new(0.0, 3.0, 0.0), 4.0),   // vertex c
            (DVec3::new(0.5, -2.0, 0.0), 4.0),  // edge ab
            (DVec3::new(-3.0, 0.5, 0.0), 9.0),  // edge ac
            (DVec3::new(1.0, 1.0, 0.0), 0.5),   // edge bc
            (DVec3::new(0.25, 0.25, 0.0), 0.0), // inside
        ];
        for (p, want) in cases {
            assert!((point_triangle_sq(p, &t) - want).abs() < 1e-12, "{p}");
        }
    }

    #[test]
    fn parallel_squares_are_their_offset_apart() {
        let d = surface_distance(
            &unit_square(0.0),
            &unit_square(0.25),
            &DistanceOptions {
                samples: 5000,
                ..DistanceOptions::default()
            },
        )
        .expect("measurable");
        assert!((d.hausdorff() - 0.25).abs() < 1e-12);
        assert!((d.mean() - 0.25).abs() < 1e-12);
        assert!((d.hausdorff_pct() - 25.0 / 2f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        let mesh = crate::mesh::io::read_path(
            &crate::fixtures::shared_data("meshes/npm-bunny.obj"),
            &crate::mesh::io::MeshLimits::default(),
        )
        .expect("npm bunny");
        let bvh = Bvh::new(&mesh);
        let tris: Vec<[DVec3; 3]> = (0..mesh.faces.len())
            .filter_map(|f| mesh.corners(f))
            .collect();
        let mut rng = SplitMix64(7);
        let b = mesh.bounding_box();
        for _ in 0..300 {
            let u = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 1.4 - 0.2;
            let p = b.min + u * (b.max - b.min);
            let brute = tris
                .iter()
                .map(|t| point_triangle_sq(p, t))
                .fold(f64::INFINITY, f64::min);
            let (d, slot) = bvh.nearest(p, (rng.next() % 100) as u32);
            assert_eq!(d, brute);
            assert!(bvh.face_id(slot).is_some());
        }
    }

    #[test]
    fn same_seed_same_numbers() {
        let a = unit_square(0.0);
        let mut b = unit_square(0.0);
        b.positions[2].z = 0.3;
        let o = DistanceOptions {
            samples: 20_000,
            seed: 42,
        };
        let x = surface_distance(&a, &b, &o).expect("ok");
        let y = surface_distance(&a, &b, &o).expect("ok");
        assert_eq!(x, y);
        assert!(x.hausdorff() > 0.1 && x.hausdorff() <= 0.3);
    }

    #[test]
    fn empty_or_zero_samples_are_errors() {
        let empty = TriMesh::default();
        let o = DistanceOptions::default();
        assert!(surface_distance(&empty, &unit_square(0.0), &o).is_err());
        let zero = DistanceOptions {
            samples: 0,
            seed: 0,
        };
        assert!(surface_distance(&unit_square(0.0), &unit_square(0.0), &zero).is_err());
    }
}
