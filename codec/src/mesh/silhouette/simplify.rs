//! Rendering regions (paper §4): faces whose normals share a view cell and touch form a
//! region; a vertex whose faces all lie in one region is interior to it and goes, its
//! "vertex outline" (1-ring) refilled by ear cutting. Region outlines are never touched, so
//! regions drawn at different levels still meet edge to edge.

use crate::mesh::curvature::decimate::alive_mesh;
use crate::mesh::curvature::refill::refill;
use crate::mesh::indexed::TriMesh;

/// λ_c for the refill: the outline ears are cut for shape, as in the curvature decimator.
const LAMBDA_C: f64 = 0.5;

/// Connected components of faces with equal `key` (sharing an edge): a region id per face.
pub fn regions(mesh: &TriMesh, key: &[u32]) -> Vec<u32> {
    let n = mesh.faces.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    // Edge → first face seen, in a sorted list (no hashing in the hot loop).
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * n);
    for (f, t) in mesh.faces.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            edges.push((a.min(b), a.max(b), f as u32));
        }
    }
    edges.sort_unstable();
    for w in edges.windows(2) {
        let ((a0, b0, f0), (a1, b1, f1)) = (w[0], w[1]);
        if a0 == a1 && b0 == b1 && key[f0 as usize] == key[f1 as usize] {
            let (r0, r1) = (find(&mut parent, f0), find(&mut parent, f1));
            if r0 != r1 {
                parent[r0.max(r1) as usize] = r0.min(r1);
            }
        }
    }
    (0..n as u32).map(|f| find(&mut parent, f)).collect()
}

/// Removes every vertex interior to a region; returns the simplified mesh (unused vertices
/// dropped).
pub fn flatten_regions(mesh: &TriMesh, region: &[u32]) -> TriMesh {
    let n = mesh.positions.len();
    let mut faces: Vec<[u32; 3]> = mesh.faces.clone();
    let mut face_region: Vec<u32> = region.to_vec();
    let mut alive = vec![true; faces.len()];
    let mut vf: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (k, f) in faces.iter().enumerate() {
        for &v in f {
            vf[v as usize].push(k as u32);
        }
    }
    for v in 0..n as u32 {
        let own: Vec<u32> = vf[v as usize].clone();
        let Some(&first) = own.first() else { continue };
        let r = face_region[first as usize];
        if own.iter().any(|&f| face_region[f as usize] != r) {
            continue;
        }
        // Input boundaries are region outlines: only closed fans are interior.
        let Some((fan, new)) = refill(
            v,
            &vf,
            &faces,
            |i| mesh.positions[i as usize],
            LAMBDA_C,
            None,
        ) else {
            continue;
        };
        if fan.open {
            continue;
        }
        for &f in &own {
            alive[f as usize] = false;
            for u in faces[f as usize] {
                vf[u as usize].retain(|&g| g != f);
            }
        }
        for t in new {
            let id = faces.len() as u32;
            faces.push(t);
            face_region.push(r);
            alive.push(true);
            for u in t {
                vf[u as usize].push(id);
            }
        }
    }

    alive_mesh(&mesh.positions, &faces, &alive)
}
