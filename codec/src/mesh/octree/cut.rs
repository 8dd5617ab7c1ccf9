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
//!
//! A collapse can also line three vertices up (on a lathe's nearly straight meridian): such a
//! sliver is flipped with the face beyond its longest edge, which keeps the parity too.

use std::collections::HashMap;

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
    let (mut kept, mut moved): (Vec<[u32; 3]>, Vec<bool>) = faces
        .iter()
        .map(|f| {
            let g = f.map(|v| map[v as usize]);
            (g, g != *f)
        })
        .filter(|([a, b, c], _)| a != b && b != c && c != a)
        .unzip();
    cancel_coincident_pairs(&mut kept, &mut moved);
    // A collapse can pull three vertices into a line (a lathe's meridian): flip those away.
    flip_slivers(&mut kept, &moved, positions);
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
/// flat); keeps the first of an odd number. Order of the survivors is preserved, and `moved`
/// (one flag per face) follows its faces.
fn cancel_coincident_pairs(faces: &mut Vec<[u32; 3]>, moved: &mut Vec<bool>) {
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
        let mut i = 0;
        moved.retain(|_| {
            i += 1;
            !drop[i - 1]
        });
    }
}

/// A face is a sliver when its height over its longest edge is at most this: under one f32
/// step of coordinates ten times that edge, so a GLB or PLY answer (f32) has it at zero area.
pub const SLIVER_HEIGHT: f64 = 1e-6;

/// Whether a triangle is a sliver; three corners at one point (height 0 over 0) are one too.
pub fn is_sliver(p: [DVec3; 3]) -> bool {
    // NaN, the height of a triangle with no extent, is a sliver too.
    let h = flatness(p).0;
    h.is_nan() || h <= SLIVER_HEIGHT
}

/// Twice the area over the longest edge squared (the height over the longest edge), and which
/// corner faces the longest edge.
pub fn flatness(p: [DVec3; 3]) -> (f64, usize) {
    let edge = |k: usize| p[(k + 2) % 3].distance_squared(p[(k + 1) % 3]);
    // The corner opposite the longest edge; ties go to the first.
    let apex = (0..3).fold(0, |best, k| if edge(k) > edge(best) { k } else { best });
    let twice_area = (p[1] - p[0]).cross(p[2] - p[0]).length();
    (twice_area / edge(apex), apex)
}

/// Flips the longest edge of every sliver the collapse made (`moved`; the input's own faces
/// stay as they are) with the face across it: a sliver (b, c, a) whose apex b lies on its
/// longest edge c–a, and the face (a, c, d) beyond, become (b, c, d) and (a, b, d). Those cover
/// what (a, c, d) covered, so the surface moves by the sliver's own height at most; the four
/// outer edges keep their faces, so no boundary edge appears or goes. A flip is skipped when
/// the edge has no single face beyond it, when b–d is an edge already (the flip would double
/// it), or when either new face would be a sliver or turn against (a, c, d).
pub(super) fn flip_slivers(faces: &mut [[u32; 3]], moved: &[bool], positions: &[DVec3]) {
    let at = |f: [u32; 3]| f.map(|v| positions[v as usize]);
    let sliver = |f: [u32; 3]| is_sliver(at(f));
    let mut slivers: Vec<usize> = (0..faces.len())
        .filter(|&i| moved[i] && sliver(faces[i]))
        .collect();
    if slivers.is_empty() {
        return;
    }
    // Edge → the faces on it, for the few meshes that have a sliver.
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut on_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (i, f) in faces.iter().enumerate() {
        for k in 0..3 {
            on_edge
                .entry(key(f[k], f[(k + 1) % 3]))
                .or_default()
                .push(i);
        }
    }
    let normal = |f: [u32; 3]| {
        let [p, q, r] = at(f);
        (q - p).cross(r - p)
    };
    // Each flip removes a sliver and makes none, so passes end; a later pass takes a sliver
    // whose neighbour an earlier flip reshaped.
    loop {
        let before = slivers.len();
        slivers.retain(|&s| {
            let f = faces[s];
            // An earlier flip may have reshaped it as another sliver's face beyond.
            if !sliver(f) {
                return false;
            }
            let (_, apex) = flatness(at(f));
            // The sliver as (b, c, a): b the apex, c → a its longest edge.
            let (b, c, a) = (f[apex], f[(apex + 1) % 3], f[(apex + 2) % 3]);
            let Some(beyond) = on_edge.get(&key(a, c)) else {
                return true;
            };
            let [g] = beyond
                .iter()
                .copied()
                .filter(|&g| g != s)
                .collect::<Vec<_>>()[..]
            else {
                return true;
            };
            // The face beyond, as (a, c, d): it runs a → c, the other way round.
            let h = faces[g];
            let Some(k) = (0..3).find(|&k| h[k] == a && h[(k + 1) % 3] == c) else {
                return true;
            };
            let d = h[(k + 2) % 3];
            if d == b || on_edge.contains_key(&key(b, d)) {
                return true;
            }
            let (t, u) = ([b, c, d], [a, b, d]);
            let n = normal(h);
            if sliver(t) || sliver(u) || normal(t).dot(n) <= 0.0 || normal(u).dot(n) <= 0.0 {
                return true;
            }
            faces[s] = t;
            faces[g] = u;
            on_edge.remove(&key(a, c));
            on_edge.insert(key(b, d), vec![s, g]);
            // a–b moves from the sliver to the face beyond, c–d the other way.
            for (edge, from, to) in [(key(a, b), s, g), (key(c, d), g, s)] {
                if let Some(list) = on_edge.get_mut(&edge) {
                    for i in list.iter_mut().filter(|i| **i == from) {
                        *i = to;
                    }
                }
            }
            false
        });
        if slivers.len() == before {
            break;
        }
    }
}
