//! Classification of the paper's §II.2.1–2.2: relation degrees, interior and connection
//! vertices, and the representative vertex of each box.
//!
//! The relation degree of a triangle in a box is how many of its vertices lie in the box; a
//! vertex is *interior* to a box when every triangle around it has degree 3 there, otherwise it
//! is a *connection* vertex. Boxes are nested, so a vertex interior to a box is interior to all
//! of that box's ancestors: one number per vertex says where the switch happens. That number is
//! the depth of the deepest box holding the vertex and all its neighbours, the common ancestor
//! of the leaves of its triangles' vertices ([`Classes::home_depth`]).

use glam::DVec3;

use super::tree::Octree;
use crate::mesh::topology::Edges;

/// Per-vertex and per-box classification, computed once per mesh.
#[derive(Clone, Debug)]
pub struct Classes {
    /// Vertex v is interior to its box at depth d iff `d <= home_depth[v]`. Vertices on an open
    /// boundary or a non-manifold edge of the input are never interior (`-1`): collapsing them
    /// would move the outline of a hole, which no box seam could repair.
    pub home_depth: Vec<i32>,
    /// Representative of each box: its interior vertex farthest from the box centre
    /// (`u32::MAX` when the box has no interior vertex, or is a leaf).
    pub representative: Vec<u32>,
    /// Sum of the area-weighted normals of the triangles around each box's vertices: the
    /// paper's average normal (eq. 2) before normalising.
    pub normal_sum: Vec<DVec3>,
}

impl Classes {
    pub fn new(tree: &Octree, positions: &[DVec3], faces: &[[u32; 3]]) -> Self {
        let n = positions.len();
        // Relation degree 3 everywhere in a box ⇔ the box holds the triangle's common ancestor:
        // the vertex's home is the shallowest such ancestor over its triangles.
        let mut home_depth: Vec<i32> = tree
            .leaf_of
            .iter()
            .map(|&l| tree.nodes[l as usize].depth as i32)
            .collect();
        let mut vertex_normal = vec![DVec3::ZERO; n];
        for f in faces {
            let [a, b, c] = f.map(|i| i as usize);
            let lca = tree.common_ancestor(
                tree.common_ancestor(tree.leaf_of[a], tree.leaf_of[b]),
                tree.leaf_of[c],
            );
            let d = tree.nodes[lca as usize].depth as i32;
            let normal = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
            for v in [a, b, c] {
                home_depth[v] = home_depth[v].min(d);
                vertex_normal[v] += normal;
            }
        }
        // Vertices on the input's own boundary stay connection vertices at every depth.
        let edges = Edges::new(faces, n);
        for (e, ends) in edges.all_ends().iter().enumerate() {
            let e = e as u32;
            if edges.is_boundary(e) || edges.is_non_manifold(e) {
                for &v in ends {
                    home_depth[v as usize] = -1;
                }
            }
        }
        // Representative: the interior vertex farthest from the centre keeps the outline
        // (the paper's Fig. 4: nearest-to-centre rounds corners off).
        let mut representative = vec![u32::MAX; tree.nodes.len()];
        let mut normal_sum = vec![DVec3::ZERO; tree.nodes.len()];
        for (i, node) in tree.nodes.iter().enumerate() {
            let vertices = &tree.order[node.vertex_range()];
            normal_sum[i] = vertices.iter().map(|&v| vertex_normal[v as usize]).sum();
            if node.is_leaf() {
                continue;
            }
            let depth = node.depth as i32;
            let mut best = (f64::NEG_INFINITY, u32::MAX);
            for &v in vertices {
                if home_depth[v as usize] >= depth {
                    let d2 = positions[v as usize].distance_squared(node.centre);
                    // Ties go to the lower id so the choice does not depend on the order.
                    if d2 > best.0 || (d2 == best.0 && v < best.1) {
                        best = (d2, v);
                    }
                }
            }
            representative[i] = best.1;
        }
        Self {
            home_depth,
            representative,
            normal_sum,
        }
    }

    /// Whether `v` is an interior vertex of a box at `depth` that holds it.
    pub fn is_interior(&self, v: u32, depth: u32) -> bool {
        self.home_depth
            .get(v as usize)
            .is_some_and(|&h| h >= depth as i32)
    }
}

/// The paper's relation degree: how many of a triangle's vertices lie in a box, given which
/// box (at the box's depth) each vertex falls in.
pub fn relation_degree(face: [u32; 3], in_box: impl Fn(u32) -> bool) -> usize {
    face.iter().filter(|&&v| in_box(v)).count()
}
