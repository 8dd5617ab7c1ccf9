//! Default object meshes: analytic surfaces whose curvature is known, so the LOD methods
//! have a smooth case (sphere), a lathe with creases at its rim (vase) and a surface with
//! saddles (torus).

use glam::DVec3;
use std::f64::consts::{PI, TAU};
use zerotile_codec::mesh::TriMesh;

/// Every default mesh with its file stem.
pub fn all() -> Vec<(&'static str, TriMesh)> {
    vec![
        ("uv-sphere", uv_sphere(50, 100)),
        ("vase", vase(64, 96)),
        ("torus", torus(96, 48, 1.0, 0.35)),
    ]
}

/// A unit UV sphere: `rings` latitude rings between the poles, `segments` around. 50 × 100
/// gives the curvature paper's 5,002 vertices.
pub fn uv_sphere(rings: usize, segments: usize) -> TriMesh {
    let mut positions = vec![DVec3::Z];
    for i in 1..=rings {
        let theta = PI * i as f64 / (rings + 1) as f64;
        for j in 0..segments {
            let phi = TAU * j as f64 / segments as f64;
            positions.push(DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    positions.push(-DVec3::Z);
    let south = (positions.len() - 1) as u32;
    let at = |i: usize, j: usize| (1 + i * segments + j % segments) as u32;
    let mut faces = Vec::new();
    for j in 0..segments {
        faces.push([0, at(0, j), at(0, j + 1)]);
        faces.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 0..rings - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
            faces.push([a, c, b]);
            faces.push([b, c, d]);
        }
    }
    TriMesh { positions, faces }
}

/// An open-top vase: a profile radius r(t) revolved about z, closed at the base by a fan.
pub fn vase(rings: usize, segments: usize) -> TriMesh {
    let radius = |t: f64| 0.35 + 0.25 * (PI * t * 1.4).sin() + 0.1 * (t * 9.0).cos() * t;
    let mut positions = vec![DVec3::ZERO];
    for i in 0..rings {
        let t = i as f64 / (rings - 1) as f64;
        let r = radius(t);
        for j in 0..segments {
            let phi = TAU * j as f64 / segments as f64;
            positions.push(DVec3::new(r * phi.cos(), r * phi.sin(), 1.5 * t));
        }
    }
    let at = |i: usize, j: usize| (1 + i * segments + j % segments) as u32;
    let mut faces = Vec::new();
    for j in 0..segments {
        faces.push([0, at(0, j + 1), at(0, j)]);
    }
    for i in 0..rings - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
            faces.push([a, b, c]);
            faces.push([b, d, c]);
        }
    }
    TriMesh { positions, faces }
}

/// A torus around z with radii `big` and `small`.
pub fn torus(around: usize, tube: usize, big: f64, small: f64) -> TriMesh {
    let mut positions = Vec::with_capacity(around * tube);
    for i in 0..around {
        let u = TAU * i as f64 / around as f64;
        for j in 0..tube {
            let v = TAU * j as f64 / tube as f64;
            let r = big + small * v.cos();
            positions.push(DVec3::new(r * u.cos(), r * u.sin(), small * v.sin()));
        }
    }
    let at = |i: usize, j: usize| ((i % around) * tube + j % tube) as u32;
    let mut faces = Vec::new();
    for i in 0..around {
        for j in 0..tube {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
            faces.push([a, b, c]);
            faces.push([c, b, d]);
        }
    }
    TriMesh { positions, faces }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_has_the_papers_count_and_outward_faces() {
        let m = uv_sphere(50, 100);
        assert_eq!(m.positions.len(), 5002);
        assert_eq!(m.faces.len(), 10_000);
        for f in &m.faces {
            let [a, b, c] = f.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot(a + b + c) > 0.0, "inward face {f:?}");
        }
    }

    /// Boundary edges, and whether every edge is manifold and consistently wound.
    fn boundary_and_winding(m: &TriMesh) -> (usize, bool) {
        let r = zerotile_codec::mesh::inspect(m);
        (
            r.boundary_edges,
            r.inconsistent_orientation_edges + r.non_manifold_edges == 0,
        )
    }

    #[test]
    fn closed_meshes_are_closed_and_consistently_wound() {
        assert_eq!(boundary_and_winding(&uv_sphere(8, 12)), (0, true));
        assert_eq!(boundary_and_winding(&torus(12, 8, 1.0, 0.3)), (0, true));
        // The vase is open at the top: one loop of `segments` edges.
        assert_eq!(boundary_and_winding(&vase(10, 16)), (16, true));
    }
}
