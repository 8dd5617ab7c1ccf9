//! A world tile's mesh cut to the triangles over the dataset's data. A coarse world tile
//! spans far more than the data (a zoom-0 geodetic tile is a hemisphere), and the rest is
//! the fill: quantized-mesh needs it (the globe is made of those tiles), but a 3D Tiles
//! tileset is drawn over a globe of its own, where a hemisphere of flat fill would hide it.

use zerotile_codec::geo::{mercator_to_lonlat, Scheme};
use zerotile_codec::mesh::TriMesh;

/// Keeps the faces of `mesh` (in the scheme's coordinates) whose longitude–latitude box
/// overlaps `bounds` (`[west, south, east, north]`, degrees; west past east crosses the
/// antimeridian), and the vertices they use, in their order. A face that only touches the
/// data's edge goes: outside it, it would hang an apron down to the fill around the data.
pub fn over_data(mesh: &mut TriMesh, scheme: Scheme, [west, south, east, north]: [f64; 4]) {
    let lonlat: Vec<[f64; 2]> = mesh
        .positions
        .iter()
        .map(|p| match scheme {
            Scheme::Mercator => mercator_to_lonlat([p.x, p.y]),
            Scheme::Geodetic | Scheme::Local { .. } => [p.x, p.y],
        })
        .collect();
    // Open intervals, but for data of no width (one meridian, one parallel), which a
    // face must then cross or touch.
    let overlaps = |lo: f64, hi: f64, a: f64, b: f64| match a < b {
        true => lo < b && hi > a,
        false => lo <= b && hi >= a,
    };
    let spans = |lo: f64, hi: f64| {
        let meets = |a: f64, b: f64| overlaps(lo, hi, a, b);
        if west <= east {
            meets(west, east)
        } else {
            meets(west, 180.0) || meets(-180.0, east)
        }
    };
    mesh.faces.retain(|f| {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for &i in f {
            let Some(&[x, y]) = lonlat.get(i as usize) else {
                return false;
            };
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        spans(lo[0], hi[0]) && overlaps(lo[1], hi[1], south, north)
    });
    mesh.drop_unreferenced();
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Two triangles of a unit square at `x0`: faces (0,1,2) and (0,2,3).
    fn square(x0: f64) -> TriMesh {
        let p = |x: f64, y: f64| DVec3::new(x0 + x, y, 7.0);
        TriMesh::new(
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    /// Faces whose box misses the data go, and their vertices with them, as do faces that
    /// only touch its edge.
    #[test]
    fn faces_off_the_data_and_touching_it_go() {
        // Data over the lower-right half's box only: x in [0.6, 1], y in [0, 0.2].
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [0.6, 0.0, 1.0, 0.2]);
        // (0,2,3) spans x 0..1, y 0..1 too: its box meets the data. Boxes, not areas.
        assert_eq!(m.faces.len(), 2);
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [1.0, 1.0, 3.0, 3.0]);
        assert!(m.faces.is_empty(), "a shared corner is not an overlap");
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [1.0, 0.0, 3.0, 3.0]);
        assert!(m.faces.is_empty(), "nor a shared edge");
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [0.5, 0.5, 0.5, 0.5]);
        assert_eq!(m.faces.len(), 2, "data of no size inside both boxes");
        let mut m = square(0.0);
        over_data(&mut m, Scheme::Geodetic, [1.5, 0.0, 3.0, 3.0]);
        assert!(m.faces.is_empty() && m.positions.is_empty());
        // A face whose box meets the data while its neighbour's does not.
        let mut m = TriMesh::new(
            vec![
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(1.0, 0.0, 2.0),
                DVec3::new(0.0, 1.0, 3.0),
                DVec3::new(5.0, 5.0, 4.0),
                DVec3::new(6.0, 5.0, 5.0),
                DVec3::new(5.0, 6.0, 6.0),
            ],
            vec![[3, 4, 5], [0, 1, 2]],
        );
        over_data(&mut m, Scheme::Geodetic, [0.5, 0.5, 2.0, 2.0]);
        assert_eq!(m.faces, vec![[0, 1, 2]]);
        assert_eq!(m.positions[2], DVec3::new(0.0, 1.0, 3.0));
    }

    /// Data across the antimeridian (west past east) keeps faces on both sides of it.
    #[test]
    fn data_across_the_antimeridian_keeps_both_sides() {
        let bounds = [179.5, 0.0, -179.5, 1.0];
        for (x0, kept) in [(179.0, 2), (-180.0, 2), (100.0, 0), (-179.0, 0)] {
            let mut m = square(x0);
            over_data(&mut m, Scheme::Geodetic, bounds);
            assert_eq!(m.faces.len(), kept, "square at {x0}");
        }
    }

    /// Mercator meshes are in EPSG:3857 metres: judged in degrees.
    #[test]
    fn mercator_points_are_judged_in_degrees() {
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
        assert_eq!(inside.faces.len(), 1);
        let mut outside = near(12.0);
        over_data(&mut outside, Scheme::Mercator, [9.9, -0.1, 10.1, 0.1]);
        assert!(outside.faces.is_empty());
    }
}
