//! Loop subdivision: Loop, *Smooth Subdivision Surfaces Based on Triangles* (MS thesis, Univ. of
//! Utah, 1987), with the boundary rules of Hoppe et al., *Piecewise Smooth Surface
//! Reconstruction* (SIGGRAPH 1994). Each step splits every triangle in four; used to make large
//! smooth test and benchmark meshes (a 1.1 M-face bunny) from the classic ones.

use glam::DVec3;

use super::indexed::TriMesh;
use super::topology::{Topology, VertexKind};

/// One Loop step: 4× the faces. Edge points are 3/8 (a + b) + 1/8 (c + d) inside and
/// midpoints on boundaries; old vertices move by Loop's β rule inside, by 1/8 – 3/4 – 1/8
/// along boundaries, and stay where the surface is not a manifold. Faces with an out-of-range
/// index are dropped.
pub fn loop_subdivide(mesh: &TriMesh) -> TriMesh {
    let n = mesh.positions.len();
    let kept = mesh
        .faces
        .iter()
        .filter(|t| t.iter().all(|&i| (i as usize) < n));
    let mesh = &TriMesh::new(mesh.positions.clone(), kept.copied().collect());
    let topo = Topology::new(mesh);
    let edges = &topo.edges;
    // Edge points, numbered after the old vertices in edge-id order.
    let mut positions = Vec::with_capacity(n + edges.len());
    positions.extend((0..n as u32).map(|v| smoothed_vertex(mesh, &topo, v)));
    for (e, &[a, b]) in edges.all_ends().iter().enumerate() {
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        let far: Vec<DVec3> = edges
            .faces(e as u32)
            .iter()
            .filter_map(|&f| mesh.faces.get(f as usize))
            .map(|t| mesh.positions[(t[0] ^ t[1] ^ t[2] ^ a ^ b) as usize])
            .collect();
        positions.push(match far.as_slice() {
            [c, d] => 0.375 * (pa + pb) + 0.125 * (*c + *d),
            _ => 0.5 * (pa + pb),
        });
    }
    // Four faces per face: three corners and the middle.
    let mut faces = Vec::with_capacity(4 * mesh.faces.len());
    for (f, t) in mesh.faces.iter().enumerate() {
        let es = edges.of_face(f as u32);
        if es.contains(&super::topology::NO_EDGE) {
            continue;
        }
        let m = es.map(|e| n as u32 + e);
        // Side i runs from corner i to corner i + 1.
        faces.push([t[0], m[0], m[2]]);
        faces.push([t[1], m[1], m[0]]);
        faces.push([t[2], m[2], m[1]]);
        faces.push(m);
    }
    TriMesh::new(positions, faces)
}

fn smoothed_vertex(mesh: &TriMesh, topo: &Topology, v: u32) -> DVec3 {
    let p = mesh.positions[v as usize];
    match topo.vertex_kind(v) {
        VertexKind::Interior => {
            let ring = topo.neighbors(v);
            let k = ring.len() as f64;
            let c = 0.375 + 0.25 * (std::f64::consts::TAU / k).cos();
            let beta = (0.625 - c * c) / k;
            let sum: DVec3 = ring.iter().map(|&u| mesh.positions[u as usize]).sum();
            (1.0 - k * beta) * p + beta * sum
        }
        VertexKind::Boundary => {
            let ends: Vec<DVec3> = topo
                .neighbors(v)
                .into_iter()
                .filter(|&u| {
                    topo.edges
                        .find(v, u)
                        .is_some_and(|e| topo.edges.is_boundary(e))
                })
                .map(|u| mesh.positions[u as usize])
                .collect();
            match ends.as_slice() {
                [a, b] => 0.75 * p + 0.125 * (*a + *b),
                _ => p,
            }
        }
        VertexKind::NonManifold | VertexKind::Isolated => p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::validate::inspect;

    #[test]
    fn subdivision_quadruples_faces_and_keeps_topology() {
        let m = crate::mesh::io::read_path(
            &crate::fixtures::shared_data("meshes/npm-bunny.obj"),
            &crate::mesh::io::MeshLimits::default(),
        )
        .expect("npm bunny");
        let s = loop_subdivide(&m);
        assert_eq!(s.face_count(), 4 * m.face_count());
        assert_eq!(s.vertex_count(), m.vertex_count() + m.edge_count());
        let r = inspect(&s);
        assert_eq!(r.euler_characteristic, 2);
        assert_eq!((r.boundary_edges, r.non_manifold_edges), (0, 0));
        // Smoothing shrinks the surface a little, never grows the box.
        assert!(s.diagonal() <= m.diagonal() * (1.0 + 1e-9));
    }
}
