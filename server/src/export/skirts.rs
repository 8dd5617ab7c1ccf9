//! Skirts: a wall hung below every open edge of a tile's mesh. 3D Tiles draws neighbouring
//! tiles at different levels side by side, and their edges, meshed within different
//! thresholds, part: a slit through which the sky shows along the seam. Quantized-mesh has
//! the same gap and CesiumJS hides it with skirts it adds itself; glTF content gets none, so
//! the export adds them.

use std::collections::HashMap;

use glam::DVec3;
use zerotile_codec::mesh::TriMesh;

/// What [`add_skirts`] added: the faces and vertices from these on, and the surface vertex
/// each added vertex copies.
#[derive(Clone, Debug, Default)]
pub struct Skirts {
    first_face: usize,
    first_vertex: usize,
    sources: Vec<u32>,
}

impl Skirts {
    /// Vertex normals of `mesh` (the skirted mesh, moved wherever since) that shade each
    /// skirt as the edge it hangs from, as CesiumJS shades its own: the surface's normals
    /// from the surface's faces alone, and each skirt vertex its edge vertex's. With the
    /// walls' own (level), a seam showed as a band lit unlike the ground.
    pub fn normals(&self, mesh: &TriMesh) -> Vec<DVec3> {
        let surface = TriMesh {
            positions: mesh.positions.clone(),
            faces: mesh
                .faces
                .get(..self.first_face)
                .unwrap_or_default()
                .to_vec(),
        };
        let mut normals = surface.vertex_normals();
        for (k, &from) in self.sources.iter().enumerate() {
            let n = normals.get(from as usize).copied().unwrap_or(DVec3::Z);
            if let Some(slot) = normals.get_mut(self.first_vertex + k) {
                *slot = n;
            }
        }
        normals
    }
}

/// Hangs a wall `depth` metres deep (down the z axis: the mesh is in the scheme's
/// coordinates, heights up) below every edge of `mesh` that only one face uses, facing
/// outwards (a face's open edge seen from beside it). The walls have vertices of their own,
/// so the surface's normals are not bent by them.
pub fn add_skirts(mesh: &mut TriMesh, depth: f64) -> Skirts {
    let mut skirts = Skirts {
        first_face: mesh.faces.len(),
        first_vertex: mesh.positions.len(),
        sources: Vec::new(),
    };
    // Directed edges as the faces run them, counter-clockwise seen from above.
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    let mut open: Vec<(u32, u32)> = Vec::new();
    for f in &mesh.faces {
        let [p, q, r] = upward(&mesh.positions, *f);
        for (a, b) in [(p, q), (q, r), (r, p)] {
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            open.push((a, b));
        }
    }
    open.retain(|&(a, b)| uses.get(&(a.min(b), a.max(b))) == Some(&1));
    // One top and one bottom copy of each vertex on an open edge.
    let mut copies: HashMap<u32, [u32; 2]> = HashMap::new();
    for &(a, b) in &open {
        for v in [a, b] {
            if let std::collections::hash_map::Entry::Vacant(e) = copies.entry(v) {
                let Some(&p) = mesh.positions.get(v as usize) else {
                    continue;
                };
                let top = mesh.positions.len() as u32;
                mesh.positions.push(p);
                mesh.positions.push(p - DVec3::Z * depth);
                skirts.sources.extend([v, v]);
                e.insert([top, top + 1]);
            }
        }
    }
    for (a, b) in open {
        let (Some(&[at, ab]), Some(&[bt, bb])) = (copies.get(&a), copies.get(&b)) else {
            continue;
        };
        // Outside is to the right of a → b: these two turn their fronts that way.
        mesh.faces.push([bt, at, ab]);
        mesh.faces.push([bt, ab, bb]);
    }
    skirts
}

/// The face, turned counter-clockwise seen from above (+z) if it was not.
fn upward(positions: &[DVec3], f: [u32; 3]) -> [u32; 3] {
    let p = |i: u32| positions.get(i as usize).copied().unwrap_or_default();
    let (a, b, c) = (p(f[0]), p(f[1]), p(f[2]));
    let twice_area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if twice_area < 0.0 {
        [f[0], f[2], f[1]]
    } else {
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles of a unit square, the second given clockwise.
    fn square() -> TriMesh {
        let p = |x: f64, y: f64| DVec3::new(x, y, 10.0);
        TriMesh::new(
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
            vec![[0, 1, 2], [0, 3, 2]],
        )
    }

    /// Four open edges, four walls of two faces, each facing away from the square and
    /// reaching `depth` below it; the shared diagonal gets none, and the surface is as it
    /// was.
    #[test]
    fn every_open_edge_gets_an_outward_wall() {
        let mut m = square();
        let skirts = add_skirts(&mut m, 3.0);
        assert_eq!(m.faces.len(), 2 + 4 * 2);
        assert_eq!(m.positions.len(), 4 + 4 * 2);
        assert_eq!(&m.faces[..2], &[[0, 1, 2], [0, 3, 2]]);
        let centre = DVec3::new(0.5, 0.5, 10.0);
        for f in &m.faces[2..] {
            let [a, b, c] = f.map(|i| m.positions[i as usize]);
            let normal = (b - a).cross(c - a);
            assert!(normal.length() > 0.0, "{f:?}");
            assert!(normal.z.abs() < 1e-12, "a wall is upright: {normal}");
            let mid = (a + b + c) / 3.0;
            assert!(normal.dot(mid - centre) > 0.0, "{f:?} faces inwards");
        }
        let lowest = m
            .positions
            .iter()
            .map(|p| p.z)
            .fold(f64::INFINITY, f64::min);
        assert_eq!(lowest, 7.0);
        // Shaded as the ground: each skirt vertex has its edge vertex's normal (the square's
        // second face runs clockwise, so its own corner's points down).
        let normals = skirts.normals(&m);
        assert_eq!(normals.len(), m.positions.len());
        for (k, n) in normals.iter().enumerate().skip(4) {
            let top = m.positions[k] + DVec3::Z * (10.0 - m.positions[k].z);
            let from = m.positions[..4].iter().position(|p| *p == top).unwrap();
            assert_eq!(*n, normals[from], "vertex {k}");
        }
        assert_eq!(normals[3], -DVec3::Z);
        // Closed edges only (a lone face's three, each hung once) where there were open ones.
        let mut one = TriMesh::new(m.positions[..3].to_vec(), vec![[0, 1, 2]]);
        add_skirts(&mut one, 1.0);
        assert_eq!(one.faces.len(), 1 + 3 * 2);
    }

    /// On a slope, each skirt vertex takes the normal of the surface vertex it hangs from,
    /// not the level one its wall would give it.
    #[test]
    fn skirts_shade_as_the_edge_they_hang_from() {
        let mut m = TriMesh::new(
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 1.0),
                DVec3::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2]],
        );
        let skirts = add_skirts(&mut m, 2.0);
        let normals = skirts.normals(&m);
        let slope = DVec3::new(-1.0, 0.0, 1.0).normalize();
        for (i, n) in normals.iter().enumerate() {
            assert!((*n - slope).length() < 1e-12, "vertex {i}: {n}");
        }
    }
}
