//! Mesh adjacency shared by every simplifier: faces around a vertex, faces on an edge,
//! boundary and non-manifold flags, and the ordered one-ring of a manifold vertex.
//!
//! Built on the classic indexed-mesh adjacency of Botsch et al., *Polygon Mesh Processing*
//! (2010, ch. 2): vertex→face incidence in compressed rows (CSR), undirected edges found by
//! bucketing face sides on their smaller vertex (no hash maps), and manifoldness decided per
//! corner, as in Guéziec et al., *Cutting and Stitching* (1998): two corners of a vertex belong
//! to the same *fan* when their faces share a manifold edge at that vertex; a vertex with more
//! than one fan is pinched.
//!
//! Everything here is read-only and sized exactly once (count, then fill). Indices out of range
//! are ignored rather than trusted: run [`crate::mesh::TriMesh::check`] first when it matters.

use super::indexed::TriMesh;

/// Sentinel for "no edge" (a degenerate side whose two corners are the same vertex).
pub const NO_EDGE: u32 = u32::MAX;

/// Faces around each vertex, in compressed rows. A face appears once per corner it has at the
/// vertex (so twice at `a` for a degenerate `[a, a, b]`).
#[derive(Clone, Debug, Default)]
pub struct VertexFaces {
    offsets: Vec<usize>,
    faces: Vec<u32>,
}

impl VertexFaces {
    /// O(V + F): one counting pass, one filling pass.
    pub fn new(faces: &[[u32; 3]], vertex_count: usize) -> Self {
        debug_assert!(faces.len() <= u32::MAX as usize, "face ids are u32");
        let mut offsets = vec![0usize; vertex_count + 1];
        for &i in faces.iter().flatten() {
            if let Some(o) = offsets.get_mut(i as usize + 1) {
                *o += 1;
            }
        }
        for v in 0..vertex_count {
            offsets[v + 1] += offsets[v];
        }
        let mut cursor = offsets[..vertex_count].to_vec();
        let mut out = vec![0u32; offsets[vertex_count]];
        for (f, t) in faces.iter().enumerate() {
            for &i in t {
                if let Some(c) = cursor.get_mut(i as usize) {
                    out[*c] = f as u32;
                    *c += 1;
                }
            }
        }
        Self {
            offsets,
            faces: out,
        }
    }

    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Faces with a corner at `v` (empty for an unknown vertex).
    pub fn of(&self, v: u32) -> &[u32] {
        let v = v as usize;
        match (self.offsets.get(v), self.offsets.get(v + 1)) {
            (Some(&s), Some(&e)) => &self.faces[s..e],
            _ => &[],
        }
    }

    /// Row offsets and the flat face list, for algorithms that copy the rows into their own
    /// mutable layout (the QEM simplifier does).
    pub fn raw(&self) -> (&[usize], &[u32]) {
        (&self.offsets, &self.faces)
    }
}

/// The distinct undirected edges of a mesh and the faces on each.
///
/// Edge ids are ordered by `(min vertex, max vertex)`, so [`Edges::find`] is a binary search
/// inside the smaller vertex's bucket.
#[derive(Clone, Debug, Default)]
pub struct Edges {
    ends: Vec<[u32; 2]>,
    face_offsets: Vec<usize>,
    faces: Vec<u32>,
    /// Edge id of side `i` of face `f` (from corner `i` to corner `(i + 1) % 3`).
    face_edges: Vec<[u32; 3]>,
    /// Edges whose smaller vertex is `v` are `vertex_offsets[v]..vertex_offsets[v + 1]`.
    vertex_offsets: Vec<usize>,
}

impl Edges {
    /// O(V + F) apart from sorting each vertex's few sides.
    pub fn new(faces: &[[u32; 3]], vertex_count: usize) -> Self {
        // Bucket every non-degenerate side on its smaller vertex: equal edges become neighbours.
        let side = |t: &[u32; 3], i: usize| {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            (a.min(b), a.max(b))
        };
        let in_range = |lo: u32, hi: u32| lo != hi && (hi as usize) < vertex_count;
        let mut bucket = vec![0usize; vertex_count + 1];
        for t in faces {
            for i in 0..3 {
                let (lo, hi) = side(t, i);
                if in_range(lo, hi) {
                    bucket[lo as usize + 1] += 1;
                }
            }
        }
        for v in 0..vertex_count {
            bucket[v + 1] += bucket[v];
        }
        // (other end, face, side) per side, filled bucket by bucket.
        let mut cursor = bucket[..vertex_count].to_vec();
        let mut sides = vec![(0u32, 0u32, 0u8); bucket[vertex_count]];
        for (f, t) in faces.iter().enumerate() {
            for i in 0..3 {
                let (lo, hi) = side(t, i);
                if in_range(lo, hi) {
                    let c = &mut cursor[lo as usize];
                    sides[*c] = (hi, f as u32, i as u8);
                    *c += 1;
                }
            }
        }
        // Sort inside each bucket and cut runs of equal ends into edges.
        let mut ends = Vec::new();
        let mut face_offsets = vec![0usize];
        let mut edge_faces = Vec::with_capacity(sides.len());
        let mut face_edges = vec![[NO_EDGE; 3]; faces.len()];
        let mut vertex_offsets = vec![0usize; vertex_count + 1];
        for lo in 0..vertex_count {
            let run = &mut sides[bucket[lo]..bucket[lo + 1]];
            run.sort_unstable();
            let mut prev = None;
            for &(hi, f, i) in run.iter() {
                if prev != Some(hi) {
                    if prev.is_some() {
                        face_offsets.push(edge_faces.len());
                    }
                    ends.push([lo as u32, hi]);
                    prev = Some(hi);
                }
                face_edges[f as usize][i as usize] = (ends.len() - 1) as u32;
                edge_faces.push(f);
            }
            if prev.is_some() {
                face_offsets.push(edge_faces.len());
            }
            vertex_offsets[lo + 1] = ends.len();
        }
        debug_assert_eq!(face_offsets.len(), ends.len() + 1);
        Self {
            ends,
            face_offsets,
            faces: edge_faces,
            face_edges,
            vertex_offsets,
        }
    }

    pub fn len(&self) -> usize {
        self.ends.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// The two vertices of edge `e`, smaller first.
    pub fn ends(&self, e: u32) -> Option<[u32; 2]> {
        self.ends.get(e as usize).copied()
    }

    /// All edges as `[smaller, larger]` vertex pairs, in id order.
    pub fn all_ends(&self) -> &[[u32; 2]] {
        &self.ends
    }

    /// Faces on edge `e` (1 on a boundary, 2 inside a manifold, more where non-manifold).
    pub fn faces(&self, e: u32) -> &[u32] {
        let e = e as usize;
        match (self.face_offsets.get(e), self.face_offsets.get(e + 1)) {
            (Some(&s), Some(&t)) => &self.faces[s..t],
            _ => &[],
        }
    }

    /// Edge ids of the three sides of face `f` (side `i` runs from corner `i` to `i + 1`);
    /// [`NO_EDGE`] for a degenerate side.
    pub fn of_face(&self, f: u32) -> [u32; 3] {
        self.face_edges
            .get(f as usize)
            .copied()
            .unwrap_or([NO_EDGE; 3])
    }

    /// The edge between `a` and `b`, if any face has it.
    pub fn find(&self, a: u32, b: u32) -> Option<u32> {
        let (lo, hi) = (a.min(b), a.max(b));
        let s = *self.vertex_offsets.get(lo as usize)?;
        let t = *self.vertex_offsets.get(lo as usize + 1)?;
        let i = self.ends[s..t].binary_search_by_key(&hi, |e| e[1]).ok()?;
        Some((s + i) as u32)
    }

    /// One face only: the edge lies on an open boundary.
    pub fn is_boundary(&self, e: u32) -> bool {
        self.faces(e).len() == 1
    }

    /// More than two faces: no surface is a manifold along this edge.
    pub fn is_non_manifold(&self, e: u32) -> bool {
        self.faces(e).len() > 2
    }
}

/// How a vertex sits in the surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexKind {
    /// No face uses it.
    Isolated,
    /// One closed fan of faces: a disc around the vertex.
    Interior,
    /// One open fan: a half-disc, the vertex is on an open boundary.
    Boundary,
    /// Several fans (pinched) or an edge with more than two faces.
    NonManifold,
}

/// The faces and neighbours around a manifold vertex, in winding order (counter-clockwise seen
/// from outside when the faces are consistently oriented).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OneRing {
    /// Neighbour `i` and `i + 1` are the far corners of `faces[i]`. A closed ring has as many
    /// neighbours as faces; an open (boundary) ring has one more, and starts and ends on the
    /// boundary.
    pub vertices: Vec<u32>,
    pub faces: Vec<u32>,
    pub closed: bool,
}

/// Vertex→face and edge→face adjacency plus per-vertex manifold classification.
#[derive(Clone, Debug, Default)]
pub struct Topology {
    pub vertex_faces: VertexFaces,
    pub edges: Edges,
    faces: Vec<[u32; 3]>,
    kinds: Vec<VertexKind>,
    /// Fan id of every corner `3 * f + i`; fans are numbered densely from 0.
    corner_fans: Vec<u32>,
    fan_count: usize,
}

impl Topology {
    /// Builds all adjacency of `mesh` in O(V + F).
    pub fn new(mesh: &TriMesh) -> Self {
        let n = mesh.positions.len();
        // Incidences first: everything else reads them.
        let vertex_faces = VertexFaces::new(&mesh.faces, n);
        let edges = Edges::new(&mesh.faces, n);
        // Fans: corners at the same vertex joined across manifold edges.
        let (corner_fans, fan_count) = corner_fans(&mesh.faces, &edges);
        // Kinds: count fans and boundary / non-manifold edges at each vertex.
        let kinds = classify(&mesh.faces, &vertex_faces, &edges, &corner_fans);
        Self {
            vertex_faces,
            edges,
            faces: mesh.faces.clone(),
            kinds,
            corner_fans,
            fan_count,
        }
    }

    pub fn vertex_kind(&self, v: u32) -> VertexKind {
        self.kinds
            .get(v as usize)
            .copied()
            .unwrap_or(VertexKind::Isolated)
    }

    pub fn is_boundary_vertex(&self, v: u32) -> bool {
        self.vertex_kind(v) == VertexKind::Boundary
    }

    /// Per-vertex kinds, indexed by vertex.
    pub fn vertex_kinds(&self) -> &[VertexKind] {
        &self.kinds
    }

    /// Fan id of the corner of face `f` at slot `i` (0..3); `None` out of range.
    pub fn corner_fan(&self, f: u32, i: usize) -> Option<u32> {
        if i >= 3 {
            return None;
        }
        self.corner_fans.get(3 * f as usize + i).copied()
    }

    /// Number of fans over all vertices: the vertex count once pinched vertices are split.
    pub fn fan_count(&self) -> usize {
        self.fan_count
    }

    /// Distinct neighbours of `v` (any kind of vertex), in no particular order.
    pub fn neighbors(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self
            .vertex_faces
            .of(v)
            .iter()
            .filter_map(|&f| self.faces.get(f as usize))
            .flatten()
            .copied()
            .filter(|&u| u != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The ordered one-ring of an interior or boundary vertex; `None` for non-manifold or
    /// isolated vertices and where neighbouring faces disagree on orientation.
    pub fn one_ring(&self, v: u32) -> Option<OneRing> {
        if !matches!(
            self.vertex_kind(v),
            VertexKind::Interior | VertexKind::Boundary
        ) {
            return None;
        }
        // Each face seen from v: (next corner, previous corner) in winding order.
        let around: Vec<(u32, u32, u32)> = self
            .vertex_faces
            .of(v)
            .iter()
            .filter_map(|&f| {
                let t = self.faces.get(f as usize)?;
                let i = t.iter().position(|&c| c == v)?;
                Some((f, t[(i + 1) % 3], t[(i + 2) % 3]))
            })
            .collect();
        // An open fan starts at the face whose leading side has no face before it.
        let start = around
            .iter()
            .position(|&(_, a, _)| !around.iter().any(|&(_, _, b)| b == a));
        let closed = start.is_none();
        let mut ring = OneRing {
            closed,
            ..OneRing::default()
        };
        let mut cur = start.unwrap_or(0);
        let first = around.get(cur)?.1;
        ring.vertices.push(first);
        for _ in 0..around.len() {
            let (f, _, b) = around[cur];
            ring.faces.push(f);
            if closed && b == first {
                break;
            }
            ring.vertices.push(b);
            match around.iter().position(|&(_, a, _)| a == b) {
                Some(next) => cur = next,
                None => break,
            }
        }
        // A walk that missed or revisited faces means the fan is not consistently oriented.
        let mut seen = ring.faces.clone();
        seen.sort_unstable();
        seen.dedup();
        (seen.len() == around.len() && ring.faces.len() == around.len()).then_some(ring)
    }
}

/// Union-find over corners: two corners at one vertex share a fan when their faces share a
/// manifold (two-face) edge at that vertex. Returns dense fan ids per corner and their count.
fn corner_fans(faces: &[[u32; 3]], edges: &Edges) -> (Vec<u32>, usize) {
    let mut parent: Vec<u32> = (0..3 * faces.len() as u32).collect();
    for e in 0..edges.len() as u32 {
        let fs = edges.faces(e);
        let (Some([a, b]), [f, g]) = (edges.ends(e), fs) else {
            continue;
        };
        for v in [a, b] {
            let (Some(cf), Some(cg)) = (corner_of(faces, *f, v), corner_of(faces, *g, v)) else {
                continue;
            };
            union(&mut parent, cf, cg);
        }
    }
    let mut dense = vec![u32::MAX; parent.len()];
    let mut ids = vec![0u32; parent.len()];
    let mut count = 0u32;
    for c in 0..parent.len() as u32 {
        let r = find(&mut parent, c) as usize;
        if dense[r] == u32::MAX {
            dense[r] = count;
            count += 1;
        }
        ids[c as usize] = dense[r];
    }
    (ids, count as usize)
}

fn corner_of(faces: &[[u32; 3]], f: u32, v: u32) -> Option<u32> {
    let i = faces.get(f as usize)?.iter().position(|&c| c == v)?;
    Some(3 * f + i as u32)
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}

fn classify(
    faces: &[[u32; 3]],
    vertex_faces: &VertexFaces,
    edges: &Edges,
    corner_fans: &[u32],
) -> Vec<VertexKind> {
    let n = vertex_faces.vertex_count();
    let mut kinds = vec![VertexKind::Isolated; n];
    let mut fans = Vec::new();
    for (v, kind) in kinds.iter_mut().enumerate() {
        let v = v as u32;
        let around = vertex_faces.of(v);
        if around.is_empty() {
            continue;
        }
        fans.clear();
        let (mut boundary, mut non_manifold) = (false, false);
        for &f in around {
            let (Some(t), Some(es)) = (faces.get(f as usize), edges.face_edges.get(f as usize))
            else {
                continue;
            };
            for i in 0..3 {
                if t[i] == v {
                    fans.push(corner_fans[3 * f as usize + i]);
                }
                // Sides i (corners i, i+1) touching v.
                if t[i] == v || t[(i + 1) % 3] == v {
                    match edges.faces(es[i]).len() {
                        1 => boundary = true,
                        0 | 2 => {}
                        _ => non_manifold = true,
                    }
                }
            }
        }
        fans.sort_unstable();
        fans.dedup();
        *kind = if non_manifold || fans.len() > 1 {
            VertexKind::NonManifold
        } else if boundary {
            VertexKind::Boundary
        } else {
            VertexKind::Interior
        };
    }
    kinds
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    /// A square of two triangles around the diagonal 0–2, plus its centre-fan variant.
    fn fan(n: u32, closed: bool) -> TriMesh {
        // Vertex 0 at the centre, 1..=n on a circle.
        let mut positions = vec![DVec3::ZERO];
        for i in 0..n {
            let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
            positions.push(DVec3::new(a.cos(), a.sin(), 0.0));
        }
        let m = if closed { n } else { n - 1 };
        let faces = (0..m).map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect();
        TriMesh::new(positions, faces)
    }

    #[test]
    fn closed_fan_has_an_interior_centre_and_ordered_ring() {
        let t = Topology::new(&fan(6, true));
        assert_eq!(t.vertex_kind(0), VertexKind::Interior);
        assert_eq!(t.vertex_kind(1), VertexKind::Boundary);
        let ring = t.one_ring(0).expect("manifold");
        assert!(ring.closed);
        assert_eq!(ring.faces.len(), 6);
        assert_eq!(ring.vertices.len(), 6);
        // Consecutive neighbours are consecutive on the circle (winding order).
        for w in ring.vertices.windows(2) {
            assert_eq!(w[1], 1 + w[0] % 6);
        }
        assert_eq!(t.edges.len(), 12);
        assert_eq!((0..12).filter(|&e| t.edges.is_boundary(e)).count(), 6);
    }

    #[test]
    fn open_fan_starts_and_ends_on_the_boundary() {
        let t = Topology::new(&fan(6, false));
        assert_eq!(t.vertex_kind(0), VertexKind::Boundary);
        let ring = t.one_ring(0).expect("manifold");
        assert!(!ring.closed);
        assert_eq!(ring.vertices, vec![1, 2, 3, 4, 5, 6]);
        assert_eq!(ring.faces, vec![0, 1, 2, 3, 4]);
    }

    #[test]
    fn two_fans_at_one_vertex_are_pinched() {
        // Two closed fans sharing the centre: a bow-tie of discs.
        let a = fan(5, true);
        let mut m = a.clone();
        let off = m.positions.len() as u32 - 1;
        m.positions
            .extend(a.positions[1..].iter().map(|p| *p + DVec3::Z));
        m.faces.extend(
            a.faces
                .iter()
                .map(|t| t.map(|i| if i == 0 { 0 } else { i + off })),
        );
        let t = Topology::new(&m);
        assert_eq!(t.vertex_kind(0), VertexKind::NonManifold);
        assert!(t.one_ring(0).is_none());
        assert_eq!(t.fan_count(), m.positions.len() + 1);
    }

    #[test]
    fn find_locates_every_edge_and_nothing_else() {
        let m = fan(5, true);
        let t = Topology::new(&m);
        for (f, tri) in m.faces.iter().enumerate() {
            let es = t.edges.of_face(f as u32);
            for i in 0..3 {
                let e = t.edges.find(tri[i], tri[(i + 1) % 3]);
                assert_eq!(e, Some(es[i]));
                assert!(t.edges.faces(es[i]).contains(&(f as u32)));
            }
        }
        assert_eq!(t.edges.find(1, 3), None);
        assert_eq!(t.edges.find(0, 99), None);
    }

    #[test]
    fn three_faces_on_an_edge_are_non_manifold() {
        let m = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Y],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        );
        let t = Topology::new(&m);
        let e = t.edges.find(0, 1).expect("edge");
        assert!(t.edges.is_non_manifold(e));
        assert_eq!(t.vertex_kind(0), VertexKind::NonManifold);
        assert_eq!(t.vertex_kind(2), VertexKind::Boundary);
    }
}
