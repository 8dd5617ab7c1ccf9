//! Filling the hole a removed vertex leaves: ear clipping that always cuts the ear of least
//! connection curvature K_c = λ_c/α + (1 − λ_c)/(eᵢ eⱼ) (paper eq. 10), in the plane of
//! the hole's average normal so no new edge crosses another, and no new face flips.
//!
//! The paper leaves α and e vague ("the ratio of the angle to the largest angle", "the
//! ratio of the edge lengths to the longest"); here α is the ear's smallest angle over
//! 60° (the best a triangle can do) and eᵢ, eⱼ its two polygon sides over the polygon's
//! longest side. Small α (slivers) and short sides both raise K_c.

use glam::{DVec2, DVec3};

/// Least |cos| between a new face's normal and the hole's: 0 would accept a face on edge.
const MIN_NORMAL_AGREEMENT: f64 = 0.05;

/// Triangulates the polygon `ring` (positions from `pos`) seen along `normal`; `None` when
/// no valid triangulation exists this way.
pub fn triangulate(
    ring: &[u32],
    pos: impl Fn(u32) -> DVec3,
    normal: DVec3,
    lambda_c: f64,
) -> Option<Vec<[u32; 3]>> {
    let n = ring.len();
    if n < 3 {
        return Some(Vec::new());
    }
    let normal = normal.try_normalize()?;
    let u = normal.any_orthonormal_vector();
    let w = normal.cross(u);
    let p3: Vec<DVec3> = ring.iter().map(|&i| pos(i)).collect();
    let p2: Vec<DVec2> = p3.iter().map(|p| DVec2::new(p.dot(u), p.dot(w))).collect();
    let longest = (0..n)
        .map(|i| (p3[(i + 1) % n] - p3[i]).length())
        .fold(0.0, f64::max);
    if longest <= 0.0 {
        return None;
    }

    let mut left: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    // Per apex: the ear (a, c) its cost was computed for. A clip changes only its two
    // neighbours' ears, so the rest keep their cost (the acos is half the clipping's time).
    let mut costs: Vec<Option<(usize, usize, Option<f64>)>> = vec![None; n];
    while left.len() > 3 {
        let m = left.len();
        let mut best: Option<(f64, usize)> = None;
        for k in 0..m {
            let (a, b, c) = (left[(k + m - 1) % m], left[k], left[(k + 1) % m]);
            if !is_ear(&p2, &left, a, b, c) {
                continue;
            }
            let cost = match costs[b] {
                Some((ca, cc, cost)) if (ca, cc) == (a, c) => cost,
                _ => {
                    let cost = ear_cost(&p3, a, b, c, normal, longest, lambda_c);
                    costs[b] = Some((a, c, cost));
                    cost
                }
            };
            let Some(cost) = cost else {
                continue;
            };
            if best.is_none_or(|(c0, _)| cost < c0) {
                best = Some((cost, k));
            }
        }
        let (_, k) = best?;
        let m = left.len();
        let (a, b, c) = (left[(k + m - 1) % m], left[k], left[(k + 1) % m]);
        out.push([ring[a], ring[b], ring[c]]);
        left.remove(k);
    }
    let (a, b, c) = (left[0], left[1], left[2]);
    ear_cost(&p3, a, b, c, normal, longest, lambda_c)?;
    out.push([ring[a], ring[b], ring[c]]);
    Some(out)
}

/// Convex at b in the projection and no other remaining vertex inside (a, b, c).
fn is_ear(p: &[DVec2], left: &[usize], a: usize, b: usize, c: usize) -> bool {
    let cross = |o: DVec2, x: DVec2, y: DVec2| (x - o).perp_dot(y - o);
    if cross(p[a], p[b], p[c]) <= 0.0 {
        return false;
    }
    left.iter().all(|&k| {
        k == a || k == b || k == c || {
            let q = p[k];
            !(cross(p[a], p[b], q) >= 0.0
                && cross(p[b], p[c], q) >= 0.0
                && cross(p[c], p[a], q) >= 0.0)
        }
    })
}

/// K_c of ear (a, b, c), or `None` when its face would flip against the hole's normal.
fn ear_cost(
    p: &[DVec3],
    a: usize,
    b: usize,
    c: usize,
    normal: DVec3,
    longest: f64,
    lambda_c: f64,
) -> Option<f64> {
    let (pa, pb, pc) = (p[a], p[b], p[c]);
    let n = (pb - pa).cross(pc - pa);
    let len = n.length();
    if len <= 0.0 || n.dot(normal) < MIN_NORMAL_AGREEMENT * len {
        return None;
    }
    // The smallest angle has the largest cosine: one acos instead of three.
    let cos = |o: DVec3, x: DVec3, y: DVec3| {
        let (u, w) = (x - o, y - o);
        u.dot(w) / (u.length() * w.length())
    };
    let largest_cos = cos(pa, pb, pc).max(cos(pb, pc, pa)).max(cos(pc, pa, pb));
    let smallest = largest_cos.clamp(-1.0, 1.0).acos();
    let alpha = smallest / (std::f64::consts::PI / 3.0);
    let (ei, ej) = ((pb - pa).length() / longest, (pc - pb).length() / longest);
    if alpha <= 0.0 || ei * ej <= 0.0 {
        return None;
    }
    Some(lambda_c / alpha + (1.0 - lambda_c) / (ei * ej))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hexagon_fills_with_four_unflipped_faces() {
        let ring: Vec<u32> = (0..6).collect();
        let pos = |i: u32| {
            let t = f64::from(i) * std::f64::consts::TAU / 6.0;
            DVec3::new(t.cos(), t.sin(), 0.0)
        };
        let faces = triangulate(&ring, pos, DVec3::Z, 0.5).unwrap();
        assert_eq!(faces.len(), 4);
        for f in &faces {
            let [a, b, c] = f.map(pos);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }

    #[test]
    fn a_non_convex_polygon_is_cut_inside_only() {
        // An arrow: the reflex vertex 3 must not be an ear.
        let pts = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 2.0, 0.0),
            DVec3::new(1.0, 0.5, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        ];
        let ring: Vec<u32> = (0..5).collect();
        let faces = triangulate(&ring, |i| pts[i as usize], DVec3::Z, 0.5).unwrap();
        assert_eq!(faces.len(), 3);
        let area: f64 = faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| pts[i as usize]);
                0.5 * (b - a).cross(c - a).z
            })
            .sum();
        // Square 4 minus the notch triangle (0,2)-(1,0.5)-(2,2): 4 − 1.5.
        assert!((area - 2.5).abs() < 1e-12, "{area}");
    }
}
