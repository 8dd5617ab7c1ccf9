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
            // New faces run along the ring forwards only (ear cutting keeps the ring's
            // order; a crease side's chord runs back along a ring edge only on a side with
            // no face), so the backward test never decides, and a diagonal is in two new
            // faces, once each way: mutants that change what it matches are equivalent.
            let on_ring =
                r.vertices.iter().position(|&x| x == a).is_some_and(|i| {
                    r.vertices[(i + 1) % k] == b || r.vertices[(i + k - 1) % k] == b
                });
            let closing = r.open && on_ring && {
                let (first, last) = (r.vertices[0], r.vertices[k - 1]);
                // The gap runs last → first, the only ring edge from `last` or to `first`:
                // `a == last || b == first` is an equivalent mutant.
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
    // which is no crease either way. `<=` for `<` differs only where a cosine rounds to
    // cos(angle) itself: an equivalent mutant.
    let limit = angle.cos();
    let sharp =
        |a: DVec3, b: DVec3| a.dot(b) / (a.length_squared() * b.length_squared()).sqrt() < limit;
    let mut ends = (0..k).filter(|&i| sharp(normal((i + k - 1) % k), normal(i)));
    match (ends.next(), ends.next(), ends.next()) {
        (Some(i), Some(j), None) => Some((i, j)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each vertex's faces, as `refill` takes them.
    fn vf(n: usize, faces: &[[u32; 3]]) -> Vec<Vec<u32>> {
        let mut vf = vec![Vec::new(); n];
        for (k, f) in faces.iter().enumerate() {
            for &v in f {
                vf[v as usize].push(k as u32);
            }
        }
        vf
    }

    fn run(
        v: u32,
        pts: &[DVec3],
        faces: &[[u32; 3]],
        crease: Option<f64>,
    ) -> Option<(Ring, Vec<[u32; 3]>)> {
        refill(
            v,
            &vf(pts.len(), faces),
            faces,
            |i| pts[i as usize],
            0.5,
            crease,
        )
    }

    fn area(pts: &[DVec3], faces: &[[u32; 3]]) -> DVec3 {
        faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| pts[i as usize]);
                0.5 * (b - a).cross(c - a)
            })
            .sum()
    }

    /// A flat hexagon fan (centre 0 off the hexagon's centre by `dy`) moved by `at`.
    fn hexagon(at: DVec3, dy: f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut pts = vec![at + DVec3::new(0.0, dy, 0.0)];
        pts.extend((0..6).map(|i| {
            let t = f64::from(i) * std::f64::consts::TAU / 6.0;
            at + DVec3::new(t.cos(), t.sin(), 0.0)
        }));
        let faces = (1..=6).map(|i| [0, i, i % 6 + 1]).collect();
        (pts, faces)
    }

    #[test]
    fn a_flat_fan_refills_with_its_area_and_winding_anywhere_in_space() {
        // Where the mesh sits must not matter: the hole's normal is a sum of face normals
        // relative to the removed vertex, which far from the origin and off the ring's
        // centre is the flip side of a wrong one.
        for at in [
            DVec3::ZERO,
            DVec3::new(100.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, -50.0),
        ] {
            let (pts, faces) = hexagon(at, 0.3);
            let (r, new) = run(0, &pts, &faces, None).unwrap();
            assert_eq!(r.vertices, [1, 2, 3, 4, 5, 6]);
            assert!(!r.open);
            assert_eq!(new.len(), 4, "{at}: {new:?}");
            let hexagon = 1.5 * 3f64.sqrt();
            let a = area(&pts, &new);
            assert!((a - DVec3::Z * hexagon).length() < 1e-9, "{at}: {a}");
            for f in &new {
                assert!(area(&pts, &[*f]).z > 0.0, "{at}: {f:?} flips");
            }
        }
    }

    #[test]
    fn too_few_neighbours_or_a_face_already_there_refuse() {
        let pts = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.3, 0.3, -0.2),
        ];
        // A lone triangle's corner may go, leaving nothing.
        let lone = [[0, 1, 2]];
        let (r, new) = run(0, &pts, &lone, None).unwrap();
        assert_eq!((r.vertices, r.open, new.len()), (vec![1, 2], true, 0));
        // Two faces back to back: a closed fan of two neighbours has no hole to fill.
        assert!(run(0, &pts, &[[0, 1, 2], [0, 2, 1]], None).is_none());
        // A valence-3 vertex inside triangle 0 1 2 refills with that triangle ...
        let split = [[4, 1, 0], [4, 2, 1], [4, 0, 2]];
        let (r, new) = run(4, &pts, &split, None).unwrap();
        assert_eq!((r.vertices.len(), r.open), (3, false));
        assert_eq!(new.len(), 1);
        assert!(area(&pts, &new).z < 0.0, "{new:?}");
        // ... also when the triangle is the floor of a tetrahedron 0 1 2 3 ...
        let sides = [[0, 1, 3], [1, 2, 3], [2, 0, 3]];
        let closed: Vec<_> = split.iter().chain(&sides).copied().collect();
        assert_eq!(run(4, &pts, &closed, None).unwrap().1.len(), 1);
        // ... but a tetrahedron's apex does not: its cap is the face opposite, there already.
        let tetra = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        assert!(run(3, &pts, &tetra, None).is_none());
    }

    #[test]
    fn a_new_edge_already_in_the_mesh_refuses() {
        // A square pyramid on a floor of two faces: the ear cutter's diagonal for the
        // square is the same whatever the floor, so exactly one of the two floors (the one
        // with that diagonal) makes the removal give an edge four faces.
        let pts = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(0.0, -1.0, 0.0),
        ];
        let top = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        let floors = [[[1, 3, 2], [1, 4, 3]], [[2, 4, 3], [2, 1, 4]]];
        let mut refused = 0;
        for floor in floors {
            let faces: Vec<_> = top.iter().chain(&floor).copied().collect();
            match run(0, &pts, &faces, None) {
                None => refused += 1,
                Some((_, new)) => {
                    assert_eq!(new.len(), 2);
                    // The diagonal the floor has is not the refill's.
                    let [a, b, _] = floor[0];
                    let uses = |f: &[u32; 3]| f.contains(&a) && f.contains(&b);
                    assert!(!new.iter().any(uses), "{floor:?}: {new:?}");
                }
            }
        }
        assert_eq!(refused, 1);
    }

    /// A flat grid, `w` × `h` vertices one apart, two faces a cell, wound up.
    fn grid(w: u32, h: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let at = |r: u32, i: u32| r * w + i;
        let pts = (0..h)
            .flat_map(|r| (0..w).map(move |i| DVec3::new(f64::from(i), f64::from(r), 0.0)))
            .collect();
        let mut faces = Vec::new();
        for r in 0..h - 1 {
            for i in 0..w - 1 {
                faces.push([at(r, i), at(r, i + 1), at(r + 1, i + 1)]);
                faces.push([at(r, i), at(r + 1, i + 1), at(r + 1, i)]);
            }
        }
        (pts, faces)
    }

    #[test]
    fn a_border_vertex_goes_unless_its_gap_closes_a_hole() {
        // Vertex 2, mid bottom row of a 5 × 3 grid: an open fan of three faces whose ring
        // edges all have a face beyond; the refill spans the gap 1 → 3 along the border and
        // keeps the fan's area.
        let (mut pts, faces) = grid(5, 3);
        let (r, new) = run(2, &pts, &faces, None).unwrap();
        assert_eq!((r.vertices, r.open), (vec![3, 8, 7, 1], true));
        assert_eq!(new.len(), 2);
        assert!((area(&pts, &new) - DVec3::Z * 1.5).length() < 1e-12);
        // With 2 lifted into the grid and a face 1 15 3 below the border, 1 2 3 is a
        // triangular hole: the gap edge 1 3 is there already, and filling it would close
        // the hole.
        pts[2].y = 0.5;
        pts.push(DVec3::new(2.0, -1.0, 0.0));
        assert!(run(2, &pts, &faces, None).is_some());
        let mut holed = faces.clone();
        holed.push([1, 15, 3]);
        assert!(run(2, &pts, &holed, None).is_none());
    }

    #[test]
    fn a_lone_faces_corner_goes_but_not_one_with_a_neighbour() {
        // A unit square of two faces, 0 1 3 and 0 3 2: vertex 1 has one face, and the gap
        // 3 → 0 its removal leaves is an open ring's closing edge, which the other face has.
        let (pts, faces) = grid(2, 2);
        assert!(run(1, &pts, &faces, None).is_none());
        let (r, new) = run(1, &pts, &faces[..1], None).unwrap();
        assert_eq!((r.vertices, r.open, new.len()), (vec![3, 0], true, 0));
    }

    /// A vertex on a ridge along x: ridge neighbours 1 and 3 at ±`l`, one neighbour down
    /// each slope (2 at +y, 4 at −y), slopes `half` below level, so the faces meet at twice
    /// `half`; all scaled by `scale` about the vertex at `at`. Ring 2 1 4 3.
    fn ridge(at: DVec3, l: f64, half: f64, scale: f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let (s, c) = half.sin_cos();
        let pts = [
            DVec3::ZERO,
            DVec3::new(-l, 0.0, 0.0),
            DVec3::new(0.0, c, -s),
            DVec3::new(l, 0.0, 0.0),
            DVec3::new(0.0, -c, -s),
        ]
        .map(|p| at + scale * p);
        let faces = vec![[0, 2, 1], [0, 1, 4], [0, 4, 3], [0, 3, 2]];
        (pts.to_vec(), faces)
    }

    #[test]
    fn a_crease_is_two_edges_sharper_than_the_angle_at_any_size_and_place() {
        let angle = 40f64.to_radians();
        for at in [DVec3::ZERO, DVec3::new(300.0, -200.0, 50.0)] {
            for scale in [0.01, 1.0, 100.0] {
                for (degrees, split) in [(44.0, Some((1, 3))), (36.0, None)] {
                    let half = f64::to_radians(degrees) / 2.0;
                    let (pts, faces) = ridge(at, 3.0, half, scale);
                    let r = ring(0, &faces).unwrap();
                    assert_eq!(r.vertices, [2, 1, 4, 3]);
                    assert_eq!(
                        crease_ends(0, &r, |i| pts[i as usize], angle),
                        split,
                        "{degrees}° at {at} × {scale}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_four_neighbour_crease_vertex_refills_along_its_crease() {
        // Across the ridge (chord 2 4) is the ear cutter's own choice for this long, flat
        // diamond; the crease split keeps the ridge (chord 1 3), one face on each slope.
        let angle = Some(40f64.to_radians());
        for at in [DVec3::ZERO, DVec3::new(300.0, -200.0, 50.0)] {
            let (pts, faces) = ridge(at, 3.0, 45f64.to_radians(), 1.0);
            let chord = |new: &[[u32; 3]], a, b| {
                new.iter()
                    .filter(|f| f.contains(&a) && f.contains(&b))
                    .count()
            };
            let (_, plain) = run(0, &pts, &faces, None).unwrap();
            assert_eq!(chord(&plain, 2, 4), 2, "{plain:?}");
            let (_, split) = run(0, &pts, &faces, angle).unwrap();
            assert_eq!(chord(&split, 1, 3), 2, "{at}: {split:?}");
            assert!(area(&pts, &split).z > 0.0);
        }
    }

    #[test]
    fn a_border_vertex_on_a_ridge_is_not_split() {
        // The ridge less its face 0 3 2: an open fan, whose gap 3 → 2 would read as a
        // second sharp edge (its "normal" is the missing face's). A border vertex has no
        // crease line to keep, so the refill is the ear cutter's, across the ridge.
        let (pts, mut faces) = ridge(DVec3::ZERO, 3.0, 45f64.to_radians(), 1.0);
        faces.pop();
        let angle = Some(40f64.to_radians());
        let (r, plain) = run(0, &pts, &faces, None).unwrap();
        assert_eq!((r.vertices, r.open), (vec![2, 1, 4, 3], true));
        assert!(plain.iter().any(|f| f.contains(&2) && f.contains(&4)));
        assert_eq!(run(0, &pts, &faces, angle).unwrap().1, plain);
    }
}
