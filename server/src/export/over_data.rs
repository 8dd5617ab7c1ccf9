//! A world tile's mesh cut to the dataset's data. A coarse world tile
//! spans far more than the data (a zoom-0 geodetic tile is a hemisphere), and the rest is
//! the fill: quantized-mesh needs it (the globe is made of those tiles), but a 3D Tiles
//! tileset is drawn over a globe of its own, where a hemisphere of flat fill would hide it.

use std::collections::HashMap;

use glam::DVec3;
use zerotile_codec::geo::{lonlat_to_mercator, Scheme, MERCATOR_MAX_LATITUDE};
use zerotile_codec::mesh::TriMesh;

/// Cuts `mesh` (in the scheme's coordinates, heights up) to `bounds` (`[west, south, east,
/// north]`, degrees; west past east crosses the antimeridian): faces within are kept as
/// they are, faces across the edge are clipped to it (Sutherland–Hodgman, heights along
/// the face's plane, so the cut surface is the mesh's own) and fanned, faces outside go, as
/// do the vertices no face uses. New points are welded by position, so faces that shared an
/// edge share its cut point, and a neighbouring tile, clipping the same edge, computes the
/// same point.
pub fn over_data(mesh: &mut TriMesh, scheme: Scheme, [west, south, east, north]: [f64; 4]) {
    let to_scheme = |lon: f64, lat: f64| match scheme {
        Scheme::Mercator => {
            let lat = lat.clamp(-MERCATOR_MAX_LATITUDE, MERCATOR_MAX_LATITUDE);
            lonlat_to_mercator([lon, lat])
        }
        Scheme::Geodetic | Scheme::Local { .. } => [lon, lat],
    };
    let rects: Vec<Rect> = if west <= east {
        vec![(west, east)]
    } else {
        vec![(west, 180.0), (-180.0, east)]
    }
    .into_iter()
    .map(|(w, e)| {
        let [x0, y0] = to_scheme(w, south);
        let [x1, y1] = to_scheme(e, north);
        Rect { x0, y0, x1, y1 }
    })
    .collect();

    let mut at: HashMap<[u64; 3], u32> = HashMap::new();
    for (i, p) in mesh.positions.iter().enumerate() {
        at.entry(key(*p)).or_insert(i as u32);
    }
    let faces = std::mem::take(&mut mesh.faces);
    for f in faces {
        let corners = f.map(|i| mesh.positions.get(i as usize).copied().unwrap_or_default());
        for r in &rects {
            if corners.iter().all(|p| r.holds(*p)) {
                mesh.faces.push(f);
                continue;
            }
            let polygon = r.clip(&corners);
            if polygon.len() < 3 {
                continue;
            }
            let mut index = |p: DVec3| {
                *at.entry(key(p)).or_insert_with(|| {
                    mesh.positions.push(p);
                    (mesh.positions.len() - 1) as u32
                })
            };
            let ids: Vec<u32> = polygon.into_iter().map(&mut index).collect();
            let first = ids.first().copied().unwrap_or_default();
            for pair in ids.get(1..).unwrap_or_default().windows(2) {
                if let [b, c] = *pair {
                    if first != b && b != c && c != first {
                        mesh.faces.push([first, b, c]);
                    }
                }
            }
        }
    }
    // Fanned slivers of no area (a corner exactly on the edge) go too.
    let positions = &mesh.positions;
    mesh.faces.retain(|f| {
        let [a, b, c] = f.map(|i| positions.get(i as usize).copied().unwrap_or_default());
        (b - a).truncate().perp_dot((c - a).truncate()) != 0.0
    });
    mesh.drop_unreferenced();
}

/// A position's bits, with −0 as 0: the weld key.
fn key(p: DVec3) -> [u64; 3] {
    (p + DVec3::ZERO).to_array().map(f64::to_bits)
}

/// The data's box in the scheme's coordinates.
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn holds(&self, p: DVec3) -> bool {
        (self.x0..=self.x1).contains(&p.x) && (self.y0..=self.y1).contains(&p.y)
    }

    /// The face's part within, a convex polygon in the face's winding (empty when none).
    fn clip(&self, face: &[DVec3; 3]) -> Vec<DVec3> {
        let mut poly = face.to_vec();
        // (coordinate, bound, keep the side above it)
        for (axis, bound, above) in [
            (0, self.x0, true),
            (0, self.x1, false),
            (1, self.y0, true),
            (1, self.y1, false),
        ] {
            let inside = |p: DVec3| {
                let v = if axis == 0 { p.x } else { p.y };
                if above {
                    v >= bound
                } else {
                    v <= bound
                }
            };
            let mut out = Vec::with_capacity(poly.len() + 2);
            for (k, &p) in poly.iter().enumerate() {
                let q = poly.get((k + 1) % poly.len()).copied().unwrap_or(p);
                if inside(p) {
                    out.push(p);
                }
                if inside(p) != inside(q) {
                    out.push(crossing(p, q, axis, bound));
                }
            }
            poly = out;
            if poly.is_empty() {
                break;
            }
        }
        poly
    }
}

/// Where the segment p–q crosses `coordinate = bound`, worked from its lesser end so that
/// either direction (two faces, or two tiles, sharing the edge) gives the same bits.
fn crossing(p: DVec3, q: DVec3, axis: usize, bound: f64) -> DVec3 {
    let (a, b) = if p.to_array() <= q.to_array() {
        (p, q)
    } else {
        (q, p)
    };
    let (va, vb) = if axis == 0 { (a.x, b.x) } else { (a.y, b.y) };
    let t = (bound - va) / (vb - va);
    let mut c = a + (b - a) * t;
    // Exactly on the line, whatever the rounding of the interpolation.
    if axis == 0 {
        c.x = bound;
    } else {
        c.y = bound;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles of a unit square at `x0`, heights on the plane z = x + 2y.
    fn square(x0: f64) -> TriMesh {
        let p = |x: f64, y: f64| DVec3::new(x0 + x, y, x0 + x + 2.0 * y);
        TriMesh::new(
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    fn area(m: &TriMesh) -> f64 {
        m.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| m.positions[i as usize]);
                (b - a).truncate().perp_dot((c - a).truncate()) / 2.0
            })
            .sum()
    }

    /// A face across the data's edge is cut there: what is left covers the data's part of
    /// the square (counter-clockwise, as the faces were), on the faces' own plane, and
    /// nothing past the edge.
    #[test]
    fn faces_are_cut_at_the_data_edge() {
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [0.6, 0.0, 1.0, 0.2]);
        assert!((area(&m) - 0.4 * 0.2).abs() < 1e-12, "{}", area(&m));
        for p in &m.positions {
            assert!(
                (0.6..=1.0).contains(&p.x) && (0.0..=0.2).contains(&p.y),
                "{p}"
            );
            assert!((p.z - p.x - 2.0 * p.y).abs() < 1e-12, "{p}");
        }
        // Wholly within: the mesh as it was.
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [-1.0, -1.0, 2.0, 2.0]);
        assert_eq!(m, square(0.0));
        // Touching at a corner or along an edge is no overlap.
        for bounds in [
            [1.0, 1.0, 3.0, 3.0],
            [1.0, 0.0, 3.0, 3.0],
            [1.5, 0.0, 3.0, 3.0],
        ] {
            let mut m = square(0.0);
            over_data(&mut m, Scheme::Geodetic, bounds);
            assert!(m.faces.is_empty() && m.positions.is_empty(), "{bounds:?}");
        }
    }

    /// The diagonal both faces share is cut once: one point, used by both, so the cut
    /// mesh has no open edge inside it (skirts hang only at its rim).
    #[test]
    fn a_shared_edge_is_cut_at_one_shared_point() {
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [0.5, -1.0, 2.0, 2.0]);
        assert!((area(&m) - 0.5).abs() < 1e-12);
        // (1,0), (1,1), and the cuts at (0.5, 0), (0.5, 0.5), (0.5, 1).
        assert_eq!(m.positions.len(), 5, "{:?}", m.positions);
        let mut keys: Vec<_> = m.positions.iter().map(|p| key(*p)).collect();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), 5);
        // Either direction along an edge gives the same bits.
        let (p, q) = (DVec3::new(0.1, 0.3, 5.0), DVec3::new(0.9, 0.7, -2.0));
        for (axis, bound) in [(0, 0.37), (1, 0.41)] {
            assert_eq!(crossing(p, q, axis, bound), crossing(q, p, axis, bound));
        }
    }

    /// Data across the antimeridian (west past east) keeps its part on both sides of it.
    #[test]
    fn data_across_the_antimeridian_keeps_both_sides() {
        let bounds = [179.5, 0.0, -179.5, 1.0];
        for (x0, kept) in [(179.0, 0.5), (-180.0, 0.5), (100.0, 0.0), (-179.0, 0.0)] {
            let mut m = square(x0);
            over_data(&mut m, Scheme::Geodetic, bounds);
            assert!(
                (area(&m) - kept).abs() < 1e-9,
                "square at {x0}: {}",
                area(&m)
            );
        }
    }

    /// Mercator meshes are in EPSG:3857 metres: the bounds go there first.
    #[test]
    fn mercator_bounds_are_taken_to_metres() {
        let metres_per_degree = 20_037_508.342_789_244 / 180.0;
        let near = |lon: f64| {
            let x = lon * metres_per_degree;
            TriMesh::new(
                vec![
                    DVec3::new(x, 0.0, 0.0),
                    DVec3::new(x + 1000.0, 0.0, 0.0),
                    DVec3::new(x, 1000.0, 0.0),
                ],
                vec![[0, 1, 2]],
            )
        };
        let mut inside = near(10.0);
        over_data(&mut inside, Scheme::Mercator, [9.9, -0.1, 10.1, 0.1]);
        assert_eq!(inside, near(10.0));
        let mut outside = near(12.0);
        over_data(&mut outside, Scheme::Mercator, [9.9, -0.1, 10.1, 0.1]);
        assert!(outside.faces.is_empty());
        // Bounds to the pole stop at mercator's edge, not at infinity.
        let mut polar = near(10.0);
        over_data(&mut polar, Scheme::Mercator, [9.9, -0.1, 10.1, 90.0]);
        assert_eq!(polar, near(10.0));
    }
}
