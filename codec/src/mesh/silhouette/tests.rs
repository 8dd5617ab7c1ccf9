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
    // First in the list: a degenerate face's key must not depend on its index being > 0.
    m.faces.insert(0, [a, copy, c]);
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

/// A closed cube on [10, 12]³ whose +x side is a fan of four triangles around its centre
/// (the other sides two triangles each): 14 faces, none degenerate.
fn fanned_cube() -> TriMesh {
    let mut positions: Vec<DVec3> = (0..8)
        .map(|i| {
            DVec3::new(10.0, 10.0, 10.0)
                + 2.0 * DVec3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2) as f64)
        })
        .collect();
    positions.push(DVec3::new(12.0, 11.0, 11.0));
    let quads = [
        [0, 2, 6, 4], // −x
        [0, 4, 5, 1], // −y
        [2, 3, 7, 6], // +y
        [0, 1, 3, 2], // −z
        [4, 6, 7, 5], // +z
    ];
    let mut faces: Vec<[u32; 3]> = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, c, b], [a, d, c]])
        .collect();
    // +x: 1, 5, 7, 3 around the centre 8.
    for [a, b] in [[1, 5], [5, 7], [7, 3], [3, 1]] {
        faces.push([a, 8, b]);
    }
    TriMesh::new(positions, faces)
}

#[test]
fn a_view_counts_every_face_by_the_kind_of_its_cell() {
    let cube = fanned_cube();
    assert_eq!(boundary_and_winding(&cube), (0, true));
    let vs = ViewSphere::new(&cube).unwrap();
    let centre = DVec3::splat(11.0);
    for level in [1, 3, MAX_LEVEL] {
        // From +x: the fan faces the eye, the four sides are edge-on, −x faces away.
        let view = View {
            eye: centre + DVec3::X * 100.0,
            target: centre,
        };
        let (m, drawn) = vs.view(&view, Some(level)).unwrap();
        let want = Drawn {
            level,
            facing_faces: 4,
            silhouette_faces: 8,
            other_faces: 2,
        };
        assert_eq!(drawn, want, "from +x at {level}");
        // The fan's centre is interior to its region at every level.
        assert_eq!(m.faces.len(), 12, "from +x at {level}");
        assert_eq!(boundary_and_winding(&m), (0, true));
        // From −x the fan faces away and −x's two faces the eye.
        let view = View {
            eye: centre - DVec3::X * 100.0,
            target: centre,
        };
        let (_, drawn) = vs.view(&view, Some(level)).unwrap();
        let want = Drawn {
            facing_faces: 2,
            other_faces: 4,
            ..want
        };
        assert_eq!(drawn, want, "from −x at {level}");
    }
    // At level 0 the fan's octant is 55° off the view at its centre, so no cell faces the
    // eye; the sides are still silhouette.
    let view = View {
        eye: centre + DVec3::X * 100.0,
        target: centre,
    };
    let (m, drawn) = vs.view(&view, Some(0)).unwrap();
    let want = Drawn {
        level: 0,
        facing_faces: 0,
        silhouette_faces: 8,
        other_faces: 6,
    };
    assert_eq!((m.faces.len(), drawn), (12, want));
    assert_eq!(vs.max_level(), MAX_LEVEL);
}

#[test]
fn the_level_drops_by_one_per_doubling_of_the_distance_past_one_diagonal() {
    // Box [10, 12]³: centre (11, 11, 11), diagonal 2√3. An eye off the origin, so that the
    // distance is measured from the box's centre.
    let vs = ViewSphere::new(&fanned_cube()).unwrap();
    let (centre, diagonal) = (DVec3::splat(11.0), 2.0 * 3f64.sqrt());
    let dir = DVec3::new(1.0, -2.0, 2.0) / 3.0;
    for (diagonals, level) in [
        (0.0, 7),
        (0.5, 7),
        (0.99, 7),
        (1.01, 6),
        (1.5, 6),
        (1.99, 6),
        (2.01, 5),
        (3.0, 5),
        (4.5, 4),
        (9.0, 3),
        (17.0, 2),
        (33.0, 1),
        (65.0, 0),
        (1e6, 0),
    ] {
        let view = View {
            eye: centre + dir * diagonals * diagonal,
            target: centre,
        };
        assert_eq!(vs.level_for(&view), level, "{diagonals} diagonals");
        if diagonals > 0.0 {
            // With no level given, the view takes this one.
            assert_eq!(vs.view(&view, None).unwrap().1.level, level, "{diagonals}");
        }
    }
}

#[test]
fn views_with_a_non_finite_end_are_refused() {
    let vs = ViewSphere::new(&fanned_cube()).unwrap();
    for (eye, target) in [
        (DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ZERO),
        (DVec3::X, DVec3::new(0.0, f64::INFINITY, 0.0)),
    ] {
        let e = vs.view(&View { eye, target }, Some(2)).unwrap_err();
        assert!(
            e.to_string().contains("eye and target must be finite"),
            "{e}"
        );
    }
}

/// An open fan of four triangles around a centre lifted `h` off a unit square whose plane has
/// normal `n`: the faces' normals lean from `n` by an angle that grows with `h`.
fn lifted_fan(n: DVec3, h: f64) -> TriMesh {
    let u = n.any_orthonormal_vector();
    let w = n.cross(u);
    let positions = vec![n * h, u, w, -u, -w];
    let faces = vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
    TriMesh::new(positions, faces)
}

#[test]
fn silhouette_cells_are_drawn_one_level_finer_and_facing_ones_one_coarser() {
    // A fan round the centre of a level-3 cell, lifted until its normals still share that
    // cell but no longer one level-4 cell: drawn at 3 its centre goes (2 faces), at 4 it stays.
    let level = 3;
    let n = sphere::cell_of(DVec3::new(1.0, 2.0, 3.0), level)
        .unwrap()
        .centre();
    let share = |m: &TriMesh, level: u8| {
        let cells: Vec<_> = m
            .face_normals()
            .iter()
            .map(|&d| cell_of(d, level))
            .collect();
        cells.iter().all(|c| *c == cells[0])
    };
    let fan = (1..400)
        .map(|k| lifted_fan(n, f64::from(k) * 0.001))
        .find(|m| share(m, level) && !share(m, level + 1))
        .expect("a lift that parts the level-4 cells");
    let vs = ViewSphere::new(&fan).unwrap();
    assert_eq!(vs.level(level).unwrap().faces.len(), 2);
    assert_eq!(vs.level(level + 1).unwrap().faces.len(), 4);

    let u = n.any_orthonormal_vector();
    let at = |eye: DVec3, level: u8| {
        let (m, drawn) = vs
            .view(
                &View {
                    eye,
                    target: DVec3::ZERO,
                },
                Some(level),
            )
            .unwrap();
        (m.faces.len(), drawn)
    };
    let drawn = |level, facing_faces, silhouette_faces, other_faces| Drawn {
        level,
        facing_faces,
        silhouette_faces,
        other_faces,
    };
    // Edge-on (the cell's centre ⟂ the view): drawn at 4, the centre stays.
    assert_eq!(at(u * 100.0, level), (4, drawn(level, 0, 4, 0)));
    // Head-on at 4: drawn at 3, the centre goes.
    assert_eq!(at(n * 100.0, level + 1), (2, drawn(level + 1, 4, 0, 0)));
    // From 60° off the normal: neither, drawn at the level asked.
    let oblique = (n * 0.5 + u * 0.75f64.sqrt()) * 100.0;
    assert_eq!(at(oblique, level), (2, drawn(level, 0, 0, 4)));
    assert_eq!(at(oblique, level + 1), (4, drawn(level + 1, 0, 0, 4)));
}

#[test]
fn regions_join_faces_across_shared_edges_of_one_key_only() {
    // Only the faces' vertex lists count. 1 shares the edge 2–0 with 0 (each face's third
    // edge, from its last vertex back to its first); 2 shares only the vertex 0 with both,
    // first in each list; 3 shares the edge 0–1 with 0 but has another key.
    let faces = vec![[0, 1, 2], [2, 3, 0], [0, 4, 5], [1, 0, 6]];
    let m = TriMesh::new(vec![DVec3::ZERO; 7], faces);
    assert_eq!(simplify::regions(&m, &[5, 5, 5, 6]), [0, 0, 2, 3]);
    // With one key the edge 0–1 joins 3 too; 2, touching at a vertex, stays alone.
    assert_eq!(simplify::regions(&m, &[5, 5, 5, 5]), [0, 0, 2, 0]);
}

/// `cell` with the axes `i` and `j` swapped: their octant bits, and at every level the child
/// indices `i` and `j` (the corner sub-triangles at those axes; in the middle one too, whose
/// corners are the edge midpoints opposite them).
fn swap_axes(cell: Cell, i: u8, j: u8) -> Cell {
    let bit = |octant: u8, k: u8| (octant >> k) & 1;
    let mut octant = cell.octant & !(1 << i | 1 << j);
    octant |= bit(cell.octant, i) << j | bit(cell.octant, j) << i;
    let mut path = 0;
    for k in (0..cell.level).rev() {
        let child = (cell.path >> (2 * k)) & 3;
        let child = match child {
            c if c == u16::from(i) => u16::from(j),
            c if c == u16::from(j) => u16::from(i),
            c => c,
        };
        path = path << 2 | child;
    }
    Cell {
        octant,
        path,
        ..cell
    }
}

#[test]
fn swapping_a_directions_axes_swaps_its_cell_ties_included() {
    // The sphere treats the axes alike, so a mesh turned by swapping two axes is drawn the
    // same. Small whole components put many directions on cell edges, e.g. (1, 1, 0) on the
    // edge of the corner cells 0 and 1 and the middle one: a tie goes to the middle cell,
    // which has no favourite axis.
    for x in -3..=3 {
        for y in -3..=3 {
            for z in -3..=3 {
                let d = [f64::from(x), f64::from(y), f64::from(z)];
                let Some(cell) = cell_of(DVec3::from(d), MAX_LEVEL) else {
                    continue;
                };
                for (i, j) in [(0, 1), (0, 2), (1, 2)] {
                    let mut e = d;
                    e.swap(usize::from(i), usize::from(j));
                    let want = swap_axes(cell, i, j);
                    assert_eq!(
                        cell_of(DVec3::from(e), MAX_LEVEL),
                        Some(want),
                        "{d:?} {i}↔{j}"
                    );
                }
            }
        }
    }
    for (d, middle) in [
        (DVec3::new(1.0, 1.0, 0.0), 3),
        (DVec3::new(0.0, 1.0, 1.0), 3),
        (DVec3::new(1.0, 0.0, 1.0), 3),
    ] {
        assert_eq!(cell_of(d, 1).map(|c| c.path), Some(middle), "{d}");
    }
}

#[test]
fn a_zero_component_of_either_sign_counts_as_positive() {
    // Axis-aligned faces (exact zeros in their normals, of either sign) all go to one octant,
    // the positive one, as `cell_of` says.
    for d in [
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(-0.0, 1.0, -0.0),
        DVec3::new(1.0, 0.0, -0.0),
        DVec3::new(-0.0, -0.0, 1.0),
    ] {
        assert_eq!(cell_of(d, 0).map(|c| c.octant), Some(0), "{d}");
    }
    assert_eq!(
        cell_of(DVec3::new(-0.0, -1.0, -0.0), 0).map(|c| c.octant),
        Some(2)
    );
}

#[test]
fn every_cells_centre_lies_in_that_cell() {
    // `Cell::centre` works down from the octant's corners, `cell_of` down from a direction,
    // so each checks the other, at every level and every path: a direction that leaves a
    // corner cell for another goes through the corner cell's rescaling.
    let mut cells = 0;
    for level in 0..=MAX_LEVEL {
        for octant in 0..8 {
            for path in 0..1u32 << (2 * level) {
                let cell = Cell {
                    level,
                    octant,
                    path: path as u16,
                };
                assert_eq!(cell_of(cell.centre(), level), Some(cell));
                cells += 1;
            }
        }
    }
    assert_eq!(cells, 8 * (4usize.pow(8) - 1) / 3);
}

/// Unit view directions: along the axes, the diagonals, and a few in between.
fn view_directions() -> Vec<DVec3> {
    let mut dirs = Vec::new();
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        dirs.extend([axis, -axis]);
    }
    dirs.extend([
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(-1.0, 1.0, 1.0),
        DVec3::new(0.3, -0.5, 0.8),
        DVec3::new(0.05, 0.02, -1.0),
        DVec3::new(-0.7, 0.1, 0.2),
    ]);
    dirs.into_iter().map(DVec3::normalize).collect()
}

#[test]
fn every_edge_on_face_is_drawn_finer_from_any_view_at_any_level() {
    // A face whose own normal is in the silhouette band lies in a silhouette cell, whatever
    // the view and level. Tested on cell centres, no level-0 cell was silhouette from an
    // axis, and at levels 1–6 edge-on faces in cells centred just outside the band were
    // missed (from +x: 400 of 4,272 at level 1, 192 at level 3).
    let m = read("uv-sphere-5002.obj");
    let vs = ViewSphere::new(&m).unwrap();
    let normals: Vec<DVec3> = m.face_normals().iter().map(|n| n.normalize()).collect();
    for dir in view_directions() {
        for level in 0..=MAX_LEVEL {
            let mut edge_on = 0;
            for (f, n) in normals.iter().enumerate() {
                // Clear of the bound by more than rounding.
                if n.dot(dir).abs() >= DEFAULT_SILHOUETTE_COS - 1e-9 {
                    continue;
                }
                edge_on += 1;
                let cell = vs.cells[f].unwrap();
                let finer = (level + 1).min(MAX_LEVEL);
                assert_eq!(
                    classify(cell, dir, level),
                    (Kind::Silhouette, finer),
                    "face {f} (normal {n}) from {dir} at level {level}"
                );
            }
            assert!(edge_on > 1_000, "{dir}: {edge_on} faces edge-on");
        }
    }
}

#[test]
fn a_far_view_from_an_axis_refines_the_outline_of_real_meshes() {
    // An eye 64 diagonals or more away draws level 0, the far object the method is for. From
    // an axis that drew plain level 0 (no silhouette face); every octant holds normals
    // edge-on to an axis, so all but the level-1 cells round the view axis are refined.
    for name in ["cow.obj", "fandisk.obj"] {
        // Repaired, as the server serves it.
        let m = crate::mesh::repair(&read(name)).unwrap().0;
        let vs = ViewSphere::new(&m).unwrap();
        let plain = vs.level(0).unwrap();
        let b = m.bounding_box();
        let centre = (b.min + b.max) / 2.0;
        for axis in [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Z] {
            let view = View {
                eye: centre + axis * 100.0 * m.diagonal(),
                target: centre,
            };
            let (viewed, drawn) = vs.view(&view, None).unwrap();
            assert_eq!(drawn.level, 0, "{name} from {axis}");
            assert!(drawn.silhouette_faces > 0, "{name} from {axis}: {drawn:?}");
            assert!(
                viewed.faces.len() > plain.faces.len(),
                "{name} from {axis}: {} faces, plain level 0 {}",
                viewed.faces.len(),
                plain.faces.len()
            );
            assert_eq!(
                boundary_and_winding(&viewed),
                boundary_and_winding(&plain),
                "{name} from {axis}"
            );
        }
    }
}

#[test]
fn a_cells_least_cos_to_a_direction_bounds_every_direction_in_it() {
    // `min_abs_cos` against directions sampled over the cell: never above any of them (a cell
    // holding an edge-on normal is never missed) and close to the least of them.
    let samples = 40;
    for level in 0..=3u8 {
        for octant in [0u8, 3, 6] {
            for path in (0..1u16 << (2 * level)).step_by(3) {
                let cell = Cell {
                    level,
                    octant,
                    path,
                };
                let [a, b, c] = cell.corners();
                for dir in view_directions() {
                    let mut least = f64::INFINITY;
                    for i in 0..=samples {
                        for j in 0..=samples - i {
                            let (u, v) = (f64::from(i), f64::from(j));
                            let w = f64::from(samples) - u - v;
                            let d = (a * u + b * v + c * w).normalize();
                            least = least.min(d.dot(dir).abs());
                        }
                    }
                    let got = cell.min_abs_cos(dir);
                    assert!(got <= least + 1e-12, "{cell:?} {dir}: {got} > {least}");
                    assert!(least - got < 0.05, "{cell:?} {dir}: {got} vs {least}");
                }
            }
        }
    }
}
