use glam::DVec3;

use super::*;
use crate::mesh::io::{read_path, MeshLimits};

fn read(name: &str) -> TriMesh {
    read_path(
        &crate::fixtures::shared_data(&format!("meshes/{name}")),
        &MeshLimits::default(),
    )
    .unwrap()
}

/// Boundary edges, and whether every edge is manifold and consistently wound.
fn boundary_and_winding(m: &TriMesh) -> (usize, bool) {
    let r = crate::mesh::inspect(m);
    (
        r.boundary_edges,
        r.inconsistent_orientation_edges + r.non_manifold_edges == 0,
    )
}

#[test]
fn coarser_levels_have_fewer_faces_and_stay_closed() {
    let input = read("uv-sphere-5002.obj");
    let vs = ViewSphere::new(&input).unwrap();
    // At the finest level every face of a 100-segment sphere has its own cell.
    assert_eq!(vs.level(MAX_LEVEL).unwrap().faces.len(), input.faces.len());
    let mut last = input.faces.len();
    for level in (0..MAX_LEVEL).rev() {
        let m = vs.level(level).unwrap();
        assert!(
            m.faces.len() <= last,
            "level {level}: {} > {last}",
            m.faces.len()
        );
        last = m.faces.len();
        assert_eq!(boundary_and_winding(&m), (0, true), "level {level}");
    }
    assert!(last < input.faces.len() / 4, "level 0 kept {last}");
}

#[test]
fn a_view_refines_the_silhouette_and_coarsens_what_faces_the_viewer() {
    let input = read("uv-sphere-5002.obj");
    let vs = ViewSphere::new(&input).unwrap();
    let view = View {
        eye: DVec3::new(0.0, 0.0, 0.0) + DVec3::new(10.0, 0.0, 0.0),
        target: DVec3::ZERO,
    };
    let level = 3;
    let uniform = vs.level(level).unwrap();
    let (viewed, drawn) = vs.view(&view, Some(level)).unwrap();
    assert!(drawn.silhouette_faces > 0 && drawn.facing_faces > 0);
    let dir = (view.target - view.eye).normalize();
    // Faces by kind of normal, in an output mesh.
    let count = |m: &TriMesh| {
        let (mut sil, mut front) = (0, 0);
        for n in m.face_normals() {
            let c = -n.dot(dir);
            if c.abs() < 0.2 {
                sil += 1;
            } else if c > 0.9 {
                front += 1;
            }
        }
        (sil, front)
    };
    let ((sil_u, front_u), (sil_v, front_v)) = (count(&uniform), count(&viewed));
    assert!(sil_v > sil_u, "silhouette faces {sil_v} vs uniform {sil_u}");
    assert!(
        front_v < front_u,
        "facing faces {front_v} vs uniform {front_u}"
    );
    assert_eq!(boundary_and_winding(&viewed), (0, true));
}

#[test]
fn open_and_real_meshes_keep_their_boundaries_and_bad_views_are_refused() {
    let teapot = {
        let mut m = read("teapot.obj");
        m.weld();
        crate::mesh::repair(&m).unwrap().0
    };
    let vs = ViewSphere::new(&teapot).unwrap();
    let before = boundary_and_winding(&teapot).0;
    for level in [2, 4] {
        let m = vs.level(level).unwrap();
        assert!(m.faces.len() < teapot.faces.len());
        // Region outlines stay, and input boundaries are outlines.
        assert_eq!(boundary_and_winding(&m).0, before, "level {level}");
    }
    let same = View {
        eye: DVec3::ONE,
        target: DVec3::ONE,
    };
    let e = vs.view(&same, None).unwrap_err().to_string();
    assert_eq!(
        e, "the distance from eye to target must be > 0, got 0",
        "{e}"
    );
    assert!(vs.level(MAX_LEVEL + 1).is_err());
    let far = View {
        eye: DVec3::new(0.0, 0.0, 1e4),
        target: DVec3::ZERO,
    };
    assert!(vs.level_for(&far) < MAX_LEVEL);
}

#[test]
fn degenerate_faces_stay_their_own_region() {
    // Split one edge of the sphere at a copy of its end vertex: two zero-area faces, the mesh
    // still closed. They have no normal, so no cell: merged into a neighbour's region they
    // would be flattened away with it, and the vertex copy's fan reshaped through them.
    let mut m = read("uv-sphere-5002.obj");
    let in_first_octant = |m: &TriMesh, f: &[u32; 3]| {
        f.iter()
            .all(|&i| m.positions[i as usize].min_element() > 0.1)
    };
    let f = m.faces.iter().position(|t| in_first_octant(&m, t)).unwrap();
    let [a, b, c] = m.faces[f];
    let g = m
        .faces
        .iter()
        .position(|t| (0..3).any(|e| t[e] == b && t[(e + 1) % 3] == a))
        .unwrap();
    let d = m.faces[g].into_iter().find(|&v| v != a && v != b).unwrap();
    let copy = m.positions.len() as u32;
    m.positions.push(m.positions[a as usize]);
    m.faces[f] = [copy, b, c];
    m.faces[g] = [b, copy, d];
    m.faces.push([a, copy, c]);
    m.faces.push([copy, a, d]);
    assert_eq!(boundary_and_winding(&m), (0, true));

    let area = |m: &TriMesh, t: &[u32; 3]| {
        let p = |k: usize| m.positions[t[k] as usize];
        (p(1) - p(0)).cross(p(2) - p(0)).length()
    };
    let vs = ViewSphere::new(&m).unwrap();
    for level in [0, 2] {
        let out = vs.level(level).unwrap();
        assert!(out.faces.len() < m.faces.len() / 2, "level {level}");
        let flat = out.faces.iter().filter(|t| area(&out, t) == 0.0).count();
        assert_eq!(flat, 2, "level {level}: the zero-area faces");
        assert_eq!(boundary_and_winding(&out), (0, true), "level {level}");
    }
}
