//! The modified adaptive octree of the paper's §II.1 (Fig. 2): breadth-first from a bounding
//! cube of the mesh, a box is split only while it holds more than `leaf_vertices` vertices, and
//! of its eight octants only those holding a vertex become children. Empty octants are counted
//! (the plain adaptive octree, AOSP, creates them) but never stored.

use std::collections::VecDeque;

use glam::DVec3;

/// One box of the octree. Children are stored contiguously; vertices of the box are the
/// contiguous slice `order[first..end]` of [`Octree::order`], so a box's vertices are a
/// range and never a list of its own.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub centre: DVec3,
    /// Half the side of the (cubic) box.
    pub half: f64,
    pub depth: u32,
    pub parent: u32,
    /// Index of the first child (`children == 0` for a leaf).
    pub first_child: u32,
    pub children: u8,
    /// The box's vertices: `order[first..end]`.
    pub first: u32,
    pub end: u32,
}

impl Node {
    /// A root box around a tree's first `points` vertices, not yet split.
    pub fn root(centre: DVec3, half: f64, points: u32) -> Self {
        Self {
            centre,
            half,
            depth: 0,
            parent: u32::MAX,
            first_child: 0,
            children: 0,
            first: 0,
            end: points,
        }
    }

    pub fn is_leaf(&self) -> bool {
        self.children == 0
    }

    pub fn child_range(&self) -> std::ops::Range<usize> {
        self.first_child as usize..self.first_child as usize + usize::from(self.children)
    }

    pub fn vertex_range(&self) -> std::ops::Range<usize> {
        self.first as usize..self.end as usize
    }

    pub fn min(&self) -> DVec3 {
        self.centre - DVec3::splat(self.half)
    }

    pub fn max(&self) -> DVec3 {
        self.centre + DVec3::splat(self.half)
    }
}

/// The octree over a mesh's vertices, nodes in breadth-first order (so every depth is a
/// contiguous run and parents precede children).
#[derive(Clone, Debug)]
pub struct Octree {
    pub nodes: Vec<Node>,
    /// Vertex ids grouped by box: each node's vertices are a contiguous range.
    pub order: Vec<u32>,
    /// The leaf holding each vertex.
    pub leaf_of: Vec<u32>,
    /// Boxes per depth of this (modified) octree.
    pub boxes_per_depth: Vec<usize>,
    /// Boxes per depth of the plain adaptive octree on the same splits (all eight octants of
    /// a split box created, the empty ones left unsplit).
    pub plain_boxes_per_depth: Vec<usize>,
}

/// The root cube (centre, half side) round the bounding box `min`..`max`: its side is the
/// box's longest, and on each axis the data sits centred in the smallest of the cube's slabs
/// (side / 2^k, k ≤ `max_depth`) that holds it.
///
/// Centred on the box, the cube's mid-plane cut every axis at depth 1 through the data's middle:
/// across a thin sheet (a bumpy height field 100 wide, 0.4 thick) every triangle then spanned
/// that plane, so no vertex was interior below the root and every level was the input. Centred
/// in its slab, the data is first cut where the boxes are about as thin as it, through its
/// middle as before. An axis longer than half the side (every axis of fandisk, the bunny,
/// the sphere and the vase) is placed as before.
pub fn root_cube(min: DVec3, max: DVec3, max_depth: u32) -> (DVec3, f64) {
    let side = (max - min).max_element();
    let mut centre = (min + max) * 0.5;
    for axis in 0..3 {
        let extent = max[axis] - min[axis];
        // Halve while the data fits in half the slab with room to spare: then no plane of
        // the slab's depth or above lies in it.
        let mut slab = side;
        for _ in 0..max_depth {
            if slab / 2.0 <= extent {
                break;
            }
            slab /= 2.0;
        }
        // The slab is the cube's first on this axis, its middle the data's. (For the whole
        // side this adds 0, so a cube centred on the box is exactly that.)
        centre[axis] += (side - slab) / 2.0;
    }
    (centre, side * 0.5)
}

impl Octree {
    /// Builds the tree; `positions` must be finite (the caller checked the mesh).
    pub fn build(positions: &[DVec3], max_depth: u32, leaf_vertices: usize) -> Self {
        // The root is a bounding cube, so every depth's boxes are cubes of one size.
        let (min, max) = positions
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        let (centre, half) = if positions.is_empty() {
            (DVec3::ZERO, 0.0)
        } else {
            root_cube(min, max, max_depth)
        };
        let n = positions.len();
        let mut nodes = vec![Node::root(centre, half, n as u32)];
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut boxes_per_depth = vec![1];
        let mut plain_boxes_per_depth = vec![1];
        let mut scratch: Vec<u32> = Vec::new();
        // Breadth-first, as the paper's queue: depths come out in order.
        let mut queue = VecDeque::from([0usize]);
        while let Some(t) = queue.pop_front() {
            let node = nodes[t].clone();
            let count = node.vertex_range().len();
            if count <= leaf_vertices || node.depth >= max_depth {
                continue;
            }
            // Bucket the box's vertices by octant (a stable counting sort in place).
            // The three bits are disjoint: `^` for either `|` gives the same octant.
            let octant = |v: u32| {
                let d = positions[v as usize] - node.centre;
                usize::from(d.x >= 0.0)
                    | usize::from(d.y >= 0.0) << 1
                    | usize::from(d.z >= 0.0) << 2
            };
            let slice = &mut order[node.vertex_range()];
            let mut counts = [0usize; 8];
            for &v in slice.iter() {
                counts[octant(v)] += 1;
            }
            scratch.clear();
            scratch.extend_from_slice(slice);
            let mut starts = [0usize; 8];
            for o in 1..8 {
                starts[o] = starts[o - 1] + counts[o - 1];
            }
            let mut cursor = starts;
            for &v in &scratch {
                let o = octant(v);
                slice[cursor[o]] = v;
                cursor[o] += 1;
            }
            // Only octants holding data become children (the paper's modification).
            let child_depth = node.depth + 1;
            let first_child = nodes.len() as u32;
            let mut made = 0u8;
            for o in 0..8 {
                if counts[o] == 0 {
                    continue;
                }
                let sign = |bit: usize| if o & bit != 0 { 1.0 } else { -1.0 };
                let offset = DVec3::new(sign(1), sign(2), sign(4)) * (node.half * 0.5);
                queue.push_back(nodes.len());
                nodes.push(Node {
                    centre: node.centre + offset,
                    half: node.half * 0.5,
                    depth: child_depth,
                    parent: t as u32,
                    first_child: 0,
                    children: 0,
                    first: node.first + starts[o] as u32,
                    end: node.first + (starts[o] + counts[o]) as u32,
                });
                made += 1;
            }
            nodes[t].first_child = first_child;
            nodes[t].children = made;
            let d = child_depth as usize;
            if boxes_per_depth.len() <= d {
                boxes_per_depth.push(0);
                plain_boxes_per_depth.push(0);
            }
            boxes_per_depth[d] += usize::from(made);
            plain_boxes_per_depth[d] += 8;
        }
        // Each vertex's leaf, for the per-vertex walks up the tree.
        let mut leaf_of = vec![0u32; n];
        for (i, node) in nodes.iter().enumerate() {
            if node.is_leaf() {
                for &v in &order[node.vertex_range()] {
                    leaf_of[v as usize] = i as u32;
                }
            }
        }
        Self {
            nodes,
            order,
            leaf_of,
            boxes_per_depth,
            plain_boxes_per_depth,
        }
    }

    /// The deepest depth any box reached.
    pub fn max_depth(&self) -> u32 {
        self.boxes_per_depth.len().saturating_sub(1) as u32
    }

    /// The lowest common ancestor of two boxes.
    pub fn common_ancestor(&self, mut a: u32, mut b: u32) -> u32 {
        while self.nodes[a as usize].depth > self.nodes[b as usize].depth {
            a = self.nodes[a as usize].parent;
        }
        while self.nodes[b as usize].depth > self.nodes[a as usize].depth {
            b = self.nodes[b as usize].parent;
        }
        while a != b {
            a = self.nodes[a as usize].parent;
            b = self.nodes[b as usize].parent;
        }
        a
    }
}
