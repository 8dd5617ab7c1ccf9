//! Mesh validation and repair: count what is wrong with a mesh from outside, refuse what no
//! repair can fix, and turn the rest into a clean 2-manifold (possibly with boundary) that the
//! simplifiers can rely on. A face without area is no valid face: it has no normal to shade or
//! simplify by, so repair drops it, as it drops a face that repeats a vertex.
//!
//! The checks follow Botsch et al., *Polygon Mesh Processing* (2010, §2.1, manifoldness);
//! non-manifold edges and pinched vertices are handled as in Guéziec, Taubin, Lazarus and Horn,
//! *Cutting and Stitching: Converting Sets of Polygons to Manifold Surfaces* (IEEE TVCG 2001):
//! every fan of faces around a vertex gets its own copy of the vertex, which splits a pinched
//! vertex in two and cuts an edge shared by more than two faces open along its sheets.

use glam::DVec3;
use serde::Serialize;

use super::error::MeshError;
use super::indexed::TriMesh;
use super::topology::{Topology, VertexKind};

/// What is wrong with a mesh, counted on the input as given.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ValidationReport {
    pub vertices: usize,
    pub faces: usize,
    /// Vertices with a NaN or infinite coordinate: an error.
    pub nan_coordinates: usize,
    /// Face indices at or past the vertex count: an error.
    pub out_of_range_indices: usize,
    /// Faces that repeat a vertex (`[a, a, b]`): removed by [`repair`].
    pub degenerate_faces: usize,
    /// Faces with three distinct vertices but zero area (on one line, or too close together
    /// for f64 to tell a side): removed by [`repair`].
    pub zero_area_faces: usize,
    /// Faces over the same three vertices as an earlier face, either winding: removed.
    pub duplicate_faces: usize,
    /// Edges with more than two faces: cut open by [`repair`].
    pub non_manifold_edges: usize,
    /// Vertices where several fans of faces meet at a point only (pinched): split by [`repair`].
    pub non_manifold_vertices: usize,
    /// Edges with one face.
    pub boundary_edges: usize,
    /// Two-face edges whose faces run along them in the same direction (flipped neighbours).
    pub inconsistent_orientation_edges: usize,
    /// Vertices no face uses: dropped by [`repair`].
    pub unreferenced_vertices: usize,
    /// Connected components of faces (sharing a vertex joins them).
    pub components: usize,
    /// V − E + F over the referenced vertices.
    pub euler_characteristic: i64,
}

impl ValidationReport {
    /// True when nothing needs repair: no errors, no removals, no splits.
    pub fn is_clean(&self) -> bool {
        self.nan_coordinates == 0
            && self.out_of_range_indices == 0
            && self.degenerate_faces == 0
            && self.zero_area_faces == 0
            && self.duplicate_faces == 0
            && self.non_manifold_edges == 0
            && self.non_manifold_vertices == 0
            && self.unreferenced_vertices == 0
    }
}

/// Counts every defect of `mesh` without changing it; never fails.
pub fn inspect(mesh: &TriMesh) -> ValidationReport {
    let n = mesh.positions.len();
    let mut r = ValidationReport {
        vertices: n,
        faces: mesh.faces.len(),
        nan_coordinates: mesh.positions.iter().filter(|p| !p.is_finite()).count(),
        ..ValidationReport::default()
    };
    // Index faults first: everything after only looks at faces that are fully in range.
    let in_range: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .filter(|t| {
            let bad = t.iter().filter(|&&i| i as usize >= n).count();
            r.out_of_range_indices += bad;
            bad == 0
        })
        .copied()
        .collect();
    // Face-level defects: repeated corners, zero area, repeated vertex sets.
    let (kept, degenerate, duplicate) = clean_faces(&in_range);
    r.degenerate_faces = degenerate;
    r.duplicate_faces = duplicate;
    r.zero_area_faces = in_range
        .iter()
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
        .filter(|t| without_area(&mesh.positions, t))
        .count();
    // Edge- and vertex-level defects on the cleaned faces.
    let clean = TriMesh::new(mesh.positions.clone(), kept);
    let topo = Topology::new(&clean);
    count_topology(&clean, &topo, &mut r);
    r.unreferenced_vertices = topo
        .vertex_kinds()
        .iter()
        .filter(|&&k| k == VertexKind::Isolated)
        .count();
    r.components = components(&clean);
    r.euler_characteristic = clean.euler_characteristic();
    r
}

/// Inspects `mesh`, refuses it if it has NaN coordinates or out-of-range indices, and returns
/// a repaired copy: degenerate, zero-area and duplicate faces removed, non-manifold edges cut
/// open, pinched vertices split (one vertex per fan), unreferenced vertices dropped. The
/// report describes the input.
pub fn repair(mesh: &TriMesh) -> Result<(TriMesh, ValidationReport), MeshError> {
    // Refuse what cannot be repaired, with the first offender named.
    mesh.check()?;
    let report = inspect(mesh);
    // Drop faces that add no surface or repeat one.
    let (mut faces, _, _) = clean_faces(&mesh.faces);
    let with_zero_area = faces.len();
    faces.retain(|t| !without_area(&mesh.positions, t));
    let flattened = with_zero_area > faces.len();
    let mut out = TriMesh::new(mesh.positions.clone(), faces);
    // Give every fan its own vertex: splits pinched vertices and cuts non-manifold edges. A
    // face without area may have joined two fans that now meet at a point only.
    if report.non_manifold_edges > 0 || report.non_manifold_vertices > 0 || flattened {
        out = split_fans(&out);
    }
    out.drop_unreferenced();
    Ok((out, report))
}

/// Whether a face's corners enclose no area (on one line or at one point) to within the f64
/// rounding of its coordinates. Exactly zero was too strict: corners on one line written in
/// decimal are rarely on one line once read (0,0 / 0.1,0.7 / 0.3,2.1 gives a cross product of
/// 2.8e-17), and such a face was kept with a normal pointing anywhere. A coordinate read is
/// off by up to half an ulp, so on an axis whose largest magnitude among the corners is `m`
/// each difference is off by up to ε·m; each component of the cross product of corners truly
/// on one line is then at most that of the other two axes' errors times the edges' extents
/// on them, and the bound allows 16 times it. Per component, so that a large coordinate on
/// one axis excuses no extent on another, and no length is taken, which underflows for
/// edges of 1e-100. An axis the corners share exactly adds no error (they were written
/// alike): a unit triangle at x = 1.7e308 is a face.
fn without_area(positions: &[DVec3], t: &[u32; 3]) -> bool {
    const ROUNDING: f64 = 32.0 * f64::EPSILON;
    let [a, b, c] = t.map(|i| positions[i as usize]);
    let (ab, ac) = (b - a, c - a);
    let m = a.abs().max(b.abs()).max(c.abs());
    let e = DVec3::select(
        ab.cmpeq(DVec3::ZERO) & ac.cmpeq(DVec3::ZERO),
        DVec3::ZERO,
        m,
    );
    let s = ab.abs() + ac.abs();
    let bound = DVec3::new(
        e.y * s.z + e.z * s.y,
        e.z * s.x + e.x * s.z,
        e.x * s.y + e.y * s.x,
    ) * ROUNDING;
    // An area past the f64 range is no zero area (`has_surface` says what it is).
    let n = ab.cross(ac);
    n.is_finite() && n.abs().cmple(bound).all()
}

/// Removes faces with a repeated corner and faces whose vertex set appeared before; returns
/// the kept faces and the two counts.
fn clean_faces(faces: &[[u32; 3]]) -> (Vec<[u32; 3]>, usize, usize) {
    let key = |t: &[u32; 3]| {
        let mut k = *t;
        k.sort_unstable();
        k
    };
    // Sort face ids by vertex set: repeats become neighbours, the earliest one is kept.
    let mut order: Vec<usize> = (0..faces.len()).collect();
    order.sort_unstable_by_key(|&f| (key(&faces[f]), f));
    let mut keep = vec![true; faces.len()];
    let (mut degenerate, mut duplicate) = (0, 0);
    let mut prev: Option<[u32; 3]> = None;
    for &f in &order {
        let k = key(&faces[f]);
        if k[0] == k[1] || k[1] == k[2] {
            keep[f] = false;
            degenerate += 1;
        } else if prev == Some(k) {
            keep[f] = false;
            duplicate += 1;
        }
        prev = Some(k);
    }
    let kept = faces
        .iter()
        .zip(&keep)
        .filter(|(_, &k)| k)
        .map(|(t, _)| *t)
        .collect();
    (kept, degenerate, duplicate)
}

fn count_topology(mesh: &TriMesh, topo: &Topology, r: &mut ValidationReport) {
    let edges = &topo.edges;
    let mut on_non_manifold_edge = vec![false; mesh.positions.len()];
    for (e, ends) in edges.all_ends().iter().enumerate() {
        let fs = edges.faces(e as u32);
        match fs.len() {
            1 => r.boundary_edges += 1,
            2 => {
                // Consistent neighbours traverse the shared edge in opposite directions.
                let dir = |f: u32| {
                    let t = mesh.faces[f as usize];
                    (0..3).any(|i| t[i] == ends[0] && t[(i + 1) % 3] == ends[1])
                };
                if dir(fs[0]) == dir(fs[1]) {
                    r.inconsistent_orientation_edges += 1;
                }
            }
            _ => {
                r.non_manifold_edges += 1;
                on_non_manifold_edge[ends[0] as usize] = true;
                on_non_manifold_edge[ends[1] as usize] = true;
            }
        }
    }
    // Pinched: several fans although every edge at the vertex is manifold.
    r.non_manifold_vertices = topo
        .vertex_kinds()
        .iter()
        .zip(&on_non_manifold_edge)
        .filter(|&(&k, &on_edge)| k == VertexKind::NonManifold && !on_edge)
        .count();
}

/// Connected components of faces, joined through shared vertices (union-find on vertices).
fn components(mesh: &TriMesh) -> usize {
    let n = mesh.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let find = |p: &mut Vec<u32>, mut x: u32| {
        while p[x as usize] != x {
            let up = p[p[x as usize] as usize];
            p[x as usize] = up;
            x = up;
        }
        x
    };
    let mut used = vec![false; n];
    for t in &mesh.faces {
        for &i in t {
            used[i as usize] = true;
        }
        for i in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[i]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    (0..n as u32)
        .filter(|&v| used[v as usize] && find(&mut parent, v) == v)
        .count()
}

/// One vertex per fan: the first fan met at a vertex keeps its index, later fans get copies
/// appended after the existing vertices.
fn split_fans(mesh: &TriMesh) -> TriMesh {
    let topo = Topology::new(mesh);
    let mut positions = mesh.positions.clone();
    let mut fan_vertex = vec![u32::MAX; topo.fan_count()];
    let mut taken = vec![false; positions.len()];
    let mut faces = mesh.faces.clone();
    for (f, t) in faces.iter_mut().enumerate() {
        for (i, v) in t.iter_mut().enumerate() {
            let Some(fan) = topo.corner_fan(f as u32, i) else {
                continue;
            };
            let slot = &mut fan_vertex[fan as usize];
            if *slot == u32::MAX {
                *slot = if taken[*v as usize] {
                    positions.push(positions[*v as usize]);
                    (positions.len() - 1) as u32
                } else {
                    taken[*v as usize] = true;
                    *v
                };
            }
            *v = *slot;
        }
    }
    TriMesh::new(positions, faces)
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::mesh::error::InvalidMesh;
    use crate::mesh::io::{read_path, MeshLimits};

    fn shared_mesh(name: &str) -> TriMesh {
        let path = crate::fixtures::shared_data(&format!("meshes/{name}"));
        read_path(&path, &MeshLimits::default()).expect("shared test mesh reads")
    }

    #[test]
    fn fandisk_is_a_closed_two_manifold() {
        let r = inspect(&shared_mesh("fandisk.obj"));
        assert_eq!((r.vertices, r.faces), (6475, 12946));
        assert_eq!(r.boundary_edges, 0);
        assert_eq!(r.non_manifold_edges + r.non_manifold_vertices, 0);
        assert_eq!(r.inconsistent_orientation_edges, 0);
        assert_eq!((r.components, r.euler_characteristic), (1, 2));
        assert!(r.is_clean());
    }

    #[test]
    fn cow_has_exactly_one_pinched_vertex_and_repair_splits_it() {
        let cow = shared_mesh("cow.obj");
        let r = inspect(&cow);
        assert_eq!(r.non_manifold_vertices, 1);
        assert_eq!((r.non_manifold_edges, r.boundary_edges), (0, 0));
        assert_eq!(r.euler_characteristic, 1);
        let (fixed, _) = repair(&cow).expect("cow repairs");
        assert_eq!(fixed.vertex_count(), cow.vertex_count() + 1);
        let again = inspect(&fixed);
        assert_eq!(again.non_manifold_vertices, 0);
        assert_eq!(again.euler_characteristic, 2);
        assert!(again.is_clean());
    }

    #[test]
    fn teapot_has_open_boundaries_that_welding_closes_partly() {
        let mut teapot = shared_mesh("teapot.obj");
        let r = inspect(&teapot);
        assert_eq!(r.boundary_edges, 1036);
        assert_eq!(r.euler_characteristic, -34);
        assert!(teapot.weld() > 0);
        assert!(inspect(&teapot).boundary_edges < r.boundary_edges);
    }

    #[test]
    fn bunny_has_five_holes_and_unreferenced_vertices_are_not_counted_in_chi() {
        let r = inspect(&shared_mesh("stanford-bunny.obj"));
        assert_eq!(r.faces, 69451);
        assert_eq!(r.boundary_edges, 223);
        assert_eq!(r.euler_characteristic, -3);
    }

    #[test]
    fn repair_removes_degenerate_and_duplicate_faces() {
        let m = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE],
            vec![[0, 1, 2], [2, 1, 0], [1, 1, 3], [1, 3, 2], [0, 1, 2]],
        );
        let (fixed, r) = repair(&m).expect("repairable");
        assert_eq!((r.degenerate_faces, r.duplicate_faces), (1, 2));
        assert_eq!(fixed.faces, vec![[0, 1, 2], [1, 3, 2]]);
    }

    /// A face whose corners lie on one line was kept, served in every LOD, though it is no
    /// valid face. It goes; two fans it joined at a vertex are split as a pinch is.
    #[test]
    fn repair_drops_faces_without_area() {
        // A tetrahedron, and a face along its edge 0-1 through the edge's midpoint (vertex 4).
        let tetrahedron = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::X / 2.0],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3], [0, 4, 1]],
        );
        let (fixed, r) = repair(&tetrahedron).expect("repairable");
        assert_eq!(r.zero_area_faces, 1);
        assert!(!r.is_clean());
        assert_eq!(fixed.faces, tetrahedron.faces[..4]);
        assert_eq!(fixed.vertex_count(), 4);
        assert!(inspect(&fixed).is_clean());
        // Vertex 0's faces are one fan only through the flat face 0 1 2 along the x axis:
        // without it, two triangles meet at vertex 0 alone.
        let bow = TriMesh::new(
            vec![
                DVec3::ZERO,
                DVec3::X,
                -DVec3::X,
                DVec3::new(1.0, -1.0, 0.0),
                DVec3::new(-1.0, -1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 3, 1], [0, 2, 4]],
        );
        assert_eq!(inspect(&bow).non_manifold_vertices, 0);
        let (fixed, _) = repair(&bow).expect("repairable");
        assert_eq!(fixed.face_count(), 2);
        assert_eq!(fixed.vertex_count(), 6, "vertex 0 split");
        assert_eq!(inspect(&fixed).non_manifold_vertices, 0);
    }

    /// Corners on one line as decimals are read a rounding off it (the first face's cross
    /// product is 2.8e-17, the midpoint's 1e-17): still no area. A face 1e-12 of its size
    /// thin at the origin, or 1e-6 a million units out, is a face.
    #[test]
    fn corners_on_one_line_to_within_rounding_have_no_area() {
        let on_line = |p: [[f64; 2]; 3], shift: f64| {
            let positions = p.map(|[x, y]| DVec3::new(x + shift, y + shift, shift));
            without_area(&positions, &[0, 1, 2])
        };
        assert!(on_line([[0.0, 0.0], [0.1, 0.7], [0.3, 2.1]], 0.0));
        assert!(on_line([[0.1, 0.7], [0.2, 0.8], [0.3, 0.9]], 0.0));
        assert!(on_line([[0.1, 0.7], [0.2, 0.8], [0.3, 0.9]], 1e6 + 0.1));
        let c = DVec3::new(0.1, 0.7, 0.0);
        assert_ne!(
            (c * 3.0).cross(c),
            DVec3::ZERO,
            "the case exact zero missed"
        );
        // A million out, coordinates are 1.2e-10 apart: 1e-6 there is some ten thousand.
        for (shift, thin) in [(0.0, 1e-12), (1e6, 1e-6)] {
            assert!(!on_line([[0.0, 0.0], [1.0, thin], [2.0, 0.0]], shift));
            assert!(!on_line([[0.0, 0.0], [1.0, 1e-3], [0.5, 0.0]], shift));
        }
        // An axis the corners share adds no rounding: a unit triangle at x = 1.7e308 is a
        // face, as is one whose area is past the f64 range.
        let far = [DVec3::ZERO, DVec3::Y, DVec3::Z].map(|p| p + DVec3::X * 1.7e308);
        assert!(!without_area(&far, &[0, 1, 2]));
        let huge = [DVec3::ZERO, DVec3::X * 1e200, DVec3::Y * 1e200];
        assert!(!without_area(&huge, &[0, 1, 2]));
        // Nor does a large coordinate on one axis excuse a small extent on another; and a
        // face of 1e-100, whose cross product's length underflows, is a face.
        let tall = [
            DVec3::new(0.0, 0.0, 1e9),
            DVec3::new(1.0, 0.0, 1e9 + 1.0),
            DVec3::new(0.0, 1e-6, 1e9),
        ];
        assert!(!without_area(&tall, &[0, 1, 2]));
        let tiny = [DVec3::ZERO, DVec3::X * 1e-100, DVec3::Y * 1e-100];
        assert!(!without_area(&tiny, &[0, 1, 2]));
        let m = TriMesh::new(
            vec![
                DVec3::ZERO,
                DVec3::new(0.1, 0.7, 0.0),
                DVec3::new(0.3, 2.1, 0.0),
            ],
            vec![[0, 1, 2]],
        );
        assert_eq!(inspect(&m).zero_area_faces, 1);
        assert_eq!(repair(&m).expect("repairable").0.face_count(), 0);
    }

    #[test]
    fn repair_cuts_an_edge_with_three_faces_open() {
        let m = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Y],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        );
        let r = inspect(&m);
        assert_eq!(r.non_manifold_edges, 1);
        let (fixed, _) = repair(&m).expect("repairable");
        let again = inspect(&fixed);
        assert_eq!(again.non_manifold_edges, 0);
        assert_eq!(again.non_manifold_vertices, 0);
        assert_eq!(fixed.vertex_count(), 9);
    }

    #[test]
    fn repair_refuses_nan_and_out_of_range() {
        let mut m = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 2]]);
        m.positions[1].x = f64::NAN;
        assert_eq!(inspect(&m).nan_coordinates, 1);
        assert!(matches!(
            repair(&m),
            Err(MeshError::Invalid(InvalidMesh::NonFiniteCoordinates { .. }))
        ));
        let m = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 3]]);
        assert_eq!(inspect(&m).out_of_range_indices, 1);
        assert!(matches!(
            repair(&m),
            Err(MeshError::Invalid(InvalidMesh::IndexOutOfRange { .. }))
        ));
    }
}
