//! A mesh from a cut through the octree (the paper's §II.2.3 and §III.2.1): every box on the
//! cut collapses its interior vertices onto its representative (the vertex-collapse operator),
//! triangles left with a repeated vertex disappear, and everything else — connection
//! triangles and vertices, boxes below the cut — is kept as it is.
//!
//! Why this never opens a hole: collapsing is a vertex map, and a vertex map sends every closed
//! surface to a closed one (as chains mod 2, the boundary of the image is the image of the
//! boundary). So an edge of the result lies on an odd number of triangles only where the input
//! had a boundary. The one thing that can cancel in that count, two triangles landing on the
//! same three vertices, is removed in pairs so the parity stays even.

use glam::DVec3;

use super::classify::Classes;
use super::tree::Octree;
use crate::mesh::indexed::TriMesh;

/// A mesh cut from the hierarchy, with where each of its vertices came from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CutMesh {
    pub mesh: TriMesh,
    /// For each output vertex, its index in the input mesh.
    pub source: Vec<u32>,
}

/// Cuts the mesh at the boxes in `collapsed` (internal boxes; none an ancestor of another).
pub fn extract(
    tree: &Octree,
    classes: &Classes,
    positions: &[DVec3],
    faces: &[[u32; 3]],
    collapsed: &[u32],
) -> CutMesh {
    // Vertex collapse: interior vertices of a cut box go to its representative.
    let map = vertex_map(tree, classes, positions.len(), collapsed);
    // Re-point triangles; those with a repeated vertex were inside one box and vanish.
    let mut kept: Vec<[u32; 3]> = faces
        .iter()
        .map(|f| f.map(|v| map[v as usize]))
        .filter(|[a, b, c]| a != b && b != c && c != a)
        .collect();
    cancel_coincident_pairs(&mut kept);
    // Compact: only vertices some triangle still uses, in first-use order.
    let mut remap = vec![u32::MAX; positions.len()];
    let mut source = Vec::new();
    for v in kept.iter_mut().flatten() {
        let r = &mut remap[*v as usize];
        if *r == u32::MAX {
            *r = source.len() as u32;
            source.push(*v);
        }
        *v = *r;
    }
    let out_positions = source.iter().map(|&v| positions[v as usize]).collect();
    CutMesh {
        mesh: TriMesh::new(out_positions, kept),
        source,
    }
}

/// Where each input vertex goes in the cut: the representative of the collapsed box it is
/// interior to, or itself.
pub fn vertex_map(
    tree: &Octree,
    classes: &Classes,
    vertices: usize,
    collapsed: &[u32],
) -> Vec<u32> {
    let mut map: Vec<u32> = (0..vertices as u32).collect();
    for &b in collapsed {
        let Some(node) = tree.nodes.get(b as usize) else {
            continue;
        };
        let rep = classes.representative[b as usize];
        // With `&&` for `||` the same: a leaf never has a representative, and an internal box
        // has none only when none of its vertices is interior, so the loop maps nothing.
        if node.is_leaf() || rep == u32::MAX {
            continue;
        }
        for &v in &tree.order[node.vertex_range()] {
            if classes.is_interior(v, node.depth) {
                map[v as usize] = rep;
            }
        }
    }
    map
}

/// Removes triangles on the same three vertices two at a time (a collapse folded a sliver
/// flat); keeps the first of an odd number. Order of the survivors is preserved.
fn cancel_coincident_pairs(faces: &mut Vec<[u32; 3]>) {
    let key = |f: &[u32; 3]| {
        let mut k = *f;
        k.sort_unstable();
        k
    };
    let mut by_key: Vec<(u32, [u32; 3])> = faces
        .iter()
        .enumerate()
        .map(|(i, f)| (i as u32, key(f)))
        .collect();
    by_key.sort_unstable_by_key(|&(i, k)| (k, i));
    let mut drop = vec![false; faces.len()];
    let mut any = false;
    for run in by_key.chunk_by(|a, b| a.1 == b.1) {
        // Pairs cancel; an odd one out (the first) stays.
        for &(i, _) in run.iter().skip(run.len() % 2) {
            drop[i as usize] = true;
            any = true;
        }
    }
    if any {
        let mut i = 0;
        faces.retain(|_| {
            i += 1;
            !drop[i - 1]
        });
    }
}
