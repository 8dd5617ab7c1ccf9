//! Removing one vertex and filling its hole, as both vertex-removal simplifiers do (the
//! curvature decimator and the view sphere's region flattening): order the 1-ring, cut it
//! into ears, and refuse any refill that would break the surface.

use glam::DVec3;

use super::retriangulate::triangulate;
use super::ring::{ring, Ring};

/// The hole `v` would leave and the faces that would fill it; `None` when `v` cannot go:
/// a non-manifold or pinched fan, too few neighbours, no valid ear cutting, a new edge that
/// already exists elsewhere (it would get a third face), or a triangle refill duplicating a
/// face already there (a tetrahedron's cap). `vf` lists each vertex's live faces in `faces`.
///
/// With `crease` (a dihedral angle), a vertex on a crease line (exactly two edges sharper
/// than it, closed fan) has its hole split along the chord joining its two crease
/// neighbours and each side filled alone, as in Schroeder et al.'s decimation, which the
/// paper removes vertices by (its ref. 20): the chord becomes the crease, so removing a
/// vertex along a crease shortens the crease instead of cutting across it.
pub fn refill(
    v: u32,
    vf: &[Vec<u32>],
    faces: &[[u32; 3]],
    pos: impl Fn(u32) -> DVec3,
    lambda_c: f64,
    crease: Option<f64>,
) -> Option<(Ring, Vec<[u32; 3]>)> {
    let own: Vec<[u32; 3]> = vf
        .get(v as usize)?
        .iter()
        .map(|&f| faces[f as usize])
        .collect();
    let r = ring(v, &own)?;
    let k = r.vertices.len();
    if k < if r.open { 2 } else { 3 } {
        return None;
    }
    let split = crease.and_then(|angle| crease_ends(v, &r, &pos, angle));
    let new = if let Some((i, j)) = split {
        // Fan face k is (v, ring[k], ring[k + 1]): faces i..j lie on the first side.
        let side = |from: usize, to: usize| {
            let mut poly = Vec::with_capacity(k);
            let mut normal = DVec3::ZERO;
            let mut at = from;
            loop {
                poly.push(r.vertices[at]);
                if at == to {
                    break;
                }
                let (a, b) = (
                    pos(r.vertices[at]) - pos(v),
                    pos(r.vertices[(at + 1) % k]) - pos(v),
                );
                normal += a.cross(b);
                at = (at + 1) % k;
            }
            triangulate(&poly, &pos, normal, lambda_c)
        };
        let mut new = side(i, j)?;
        new.extend(side(j, i)?);
        new
    } else {
        let normal: DVec3 = own
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(&pos);
                (b - a).cross(c - a)
            })
            .sum();
        triangulate(&r.vertices, &pos, normal, lambda_c)?
    };

    let adjacent = |a: u32, b: u32| {
        vf[a as usize]
            .iter()
            .any(|&f| !faces[f as usize].contains(&v) && faces[f as usize].contains(&b))
    };
    for f in &new {
        for e in 0..3 {
            let (a, b) = (f[e], f[(e + 1) % 3]);
            let on_ring =
                r.vertices.iter().position(|&x| x == a).is_some_and(|i| {
                    r.vertices[(i + 1) % k] == b || r.vertices[(i + k - 1) % k] == b
                });
            let closing = r.open && on_ring && {
                let (first, last) = (r.vertices[0], r.vertices[k - 1]);
                (a == first && b == last) || (a == last && b == first)
            };
            if (!on_ring || closing) && adjacent(a, b) {
                return None;
            }
        }
    }
    if r.open && new.is_empty() && adjacent(r.vertices[0], r.vertices[k - 1]) {
        return None;
    }
    if let [f] = new.as_slice() {
        let same = vf[f[0] as usize].iter().any(|&g| {
            let g = faces[g as usize];
            !g.contains(&v) && f.iter().all(|x| g.contains(x))
        });
        if same {
            return None;
        }
    }
    Some((r, new))
}

/// The ring positions of the two crease neighbours of `v` (closed fan, exactly two edges
/// whose faces meet at more than `angle`), or `None`.
fn crease_ends(v: u32, r: &Ring, pos: impl Fn(u32) -> DVec3, angle: f64) -> Option<(usize, usize)> {
    let k = r.vertices.len();
    if r.open || k < 4 {
        return None;
    }
    let p = pos(v);
    let normal = |i: usize| (pos(r.vertices[i]) - p).cross(pos(r.vertices[(i + 1) % k]) - p);
    // The angle between two normals is above `angle` when its cosine is below cos(angle):
    // no acos per ring edge (this runs for every removal tried). A zero normal gives NaN,
    // which is no crease either way.
    let limit = angle.cos();
    let sharp =
        |a: DVec3, b: DVec3| a.dot(b) / (a.length_squared() * b.length_squared()).sqrt() < limit;
    let mut ends = (0..k).filter(|&i| sharp(normal((i + k - 1) % k), normal(i)));
    match (ends.next(), ends.next(), ends.next()) {
        (Some(i), Some(j), None) => Some((i, j)),
        _ => None,
    }
}
