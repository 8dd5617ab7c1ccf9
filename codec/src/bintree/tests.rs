use super::hierarchy::NONE;
use super::*;
use crate::fixtures::{n44w072, n44w072_crop};
use crate::grid::Grid;
use crate::zerotree::mesh_error;
use crate::zerotree::terrain_mesh::assert_watertight;

#[test]
fn real_tile_meshes_are_watertight_and_within_tolerance() {
    let g = n44w072_crop(300, 500, 257);
    let h = Hierarchy::new(257).unwrap();
    let e = TileErrors::new(&h, &g);
    let mut last = usize::MAX;
    for tol in [0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 64.0, 1e6] {
        let m = extract(&h, &e, &g, tol, None);
        assert_watertight(&m, &format!("tolerance {tol}"));
        let err = mesh_error(&m, &g);
        assert_eq!(err.uncovered, 0);
        assert!(
            err.max_abs <= tol + 1e-6,
            "tolerance {tol}: true error {}",
            err.max_abs
        );
        assert!(
            m.triangle_count() <= last,
            "more triangles at a larger tolerance"
        );
        last = m.triangle_count();
    }
    assert_eq!(extract(&h, &e, &g, 1e6, None).triangle_count(), 2);
}

#[test]
fn zero_tolerance_on_rough_terrain_is_nearly_the_full_grid() {
    let g = n44w072_crop(0, 0, 65);
    let h = Hierarchy::new(65).unwrap();
    let m = extract(&h, &TileErrors::new(&h, &g), &g, 0.0, None);
    assert_eq!(mesh_error(&m, &g).max_abs, 0.0);
    assert!(m.triangle_count() > 2 * 64 * 64 * 8 / 10);
}

#[test]
fn forced_border_vertices_appear_and_keep_the_mesh_conforming() {
    let g = n44w072_crop(300, 500, 129);
    let h = Hierarchy::new(129).unwrap();
    let e = TileErrors::new(&h, &g);
    let border = [1usize, 7, 33, 64, 100, 127];
    let forced = Forced::new(
        &h,
        border
            .iter()
            .copied()
            .chain(border.iter().map(|&r| r * 129 + 128)),
    );
    let m = extract(&h, &e, &g, 32.0, Some(&forced));
    assert_watertight(&m, "forced");
    for &k in &border {
        assert!(
            m.positions.iter().any(|p| p[1] == 0.0 && p[0] == k as f64),
            "north {k}"
        );
        assert!(
            m.positions
                .iter()
                .any(|p| p[0] == 128.0 && p[1] == k as f64),
            "east {k}"
        );
    }
    let plain = extract(&h, &e, &g, 32.0, None);
    assert!(m.triangle_count() > plain.triangle_count());
}

/// The walk compares in f32; a tolerance between two f32 values must split exactly the
/// triangles an f64 comparison would: a value v splits at any tolerance below it, however
/// close, and not at v itself.
#[test]
fn tolerances_between_f32_values_split_as_in_f64() {
    let g = n44w072_crop(300, 500, 65);
    let h = Hierarchy::new(65).unwrap();
    let e = TileErrors::new(&h, &g);
    let root = e.max();
    assert!(root > 0.0);
    let at = f64::from(root);
    // Just below the root value, closer than any f32 below it.
    let below = at - f64::from(root - root.next_down()) / 4.0;
    assert!(below < at && below as f32 == root);
    assert_eq!(extract(&h, &e, &g, at, None).triangle_count(), 2);
    assert!(extract(&h, &e, &g, below, None).triangle_count() > 2);
    assert_eq!(extract(&h, &e, &g, f64::NAN, None).triangle_count(), 2);
    assert_eq!(extract(&h, &e, &g, f64::INFINITY, None).triangle_count(), 2);
}

/// What a neighbour must force onto a shared edge is exactly what this tile's mesh has on it.
#[test]
fn border_vertices_are_the_mesh_vertices_on_each_edge() {
    let n = 65;
    let g = n44w072_crop(300, 500, n);
    let h = Hierarchy::new(n).unwrap();
    let e = TileErrors::new(&h, &g);
    let last = (n - 1) as f64;
    for tol in [1.0, 4.0, 16.0] {
        let m = extract(&h, &e, &g, tol, None);
        let b = border_vertices(&h, &e, tol);
        let on = |at: &dyn Fn(f64) -> (f64, f64)| -> Vec<bool> {
            (0..n)
                .map(|k| {
                    let (x, y) = at(k as f64);
                    m.positions.iter().any(|p| p[0] == x && p[1] == y)
                })
                .collect()
        };
        assert_eq!(b.north, on(&|k| (k, 0.0)), "north at {tol}");
        assert_eq!(b.south, on(&|k| (k, last)), "south at {tol}");
        assert_eq!(b.west, on(&|k| (0.0, k)), "west at {tol}");
        assert_eq!(b.east, on(&|k| (last, k)), "east at {tol}");
        for side in [&b.north, &b.south, &b.west, &b.east] {
            assert!(side[1..n - 1].iter().any(|&v| v), "tolerance {tol}");
        }
    }
}

/// Forcing adds only what is forced and its ancestors: forcing nothing, or the plain mesh's
/// own vertices (already closed under ancestors), gives the plain mesh back exactly. The mesh
/// also carries the grid size it covers.
#[test]
fn forcing_nothing_or_the_meshs_own_vertices_changes_nothing() {
    let n = 65;
    let g = n44w072_crop(300, 500, n);
    let h = Hierarchy::new(n).unwrap();
    let e = TileErrors::new(&h, &g);
    for tol in [2.0, 16.0] {
        let plain = extract(&h, &e, &g, tol, None);
        assert_eq!((plain.rows, plain.cols), (n, n));
        assert!(plain.triangle_count() < 2 * 64 * 64, "tolerance {tol}");
        let none = extract(&h, &e, &g, tol, Some(&Forced::new(&h, [])));
        assert_eq!(none.positions, plain.positions, "tolerance {tol}");
        assert_eq!(none.triangles, plain.triangles, "tolerance {tol}");
        let own = plain
            .positions
            .iter()
            .map(|p| p[1] as usize * n + p[0] as usize);
        let same = extract(&h, &e, &g, tol, Some(&Forced::new(&h, own)));
        assert_eq!(same.positions, plain.positions, "tolerance {tol}");
        assert_eq!(same.triangles, plain.triangles, "tolerance {tol}");
    }
}

/// Errors or heights of another size than the hierarchy's are a broken contract: a debug
/// assertion names it (rather than an index out of bounds or a mesh of the wrong grid), and
/// a release build returns an empty mesh.
#[test]
fn shapes_other_than_the_hierarchys_are_refused() {
    let n = 65;
    let h = Hierarchy::new(n).unwrap();
    let g = n44w072_crop(300, 500, n);
    let small = n44w072_crop(300, 500, 33);
    let small_errors = TileErrors::new(&Hierarchy::new(33).unwrap(), &small);
    let e = TileErrors::new(&h, &g);
    let wide = n44w072().crop(300, 500, n, n + 1).unwrap();
    let tall = n44w072().crop(300, 500, n + 1, n).unwrap();
    let cases: [(&str, &TileErrors, &Grid<f64>); 3] = [
        ("errors", &small_errors, &g),
        ("columns", &e, &wide),
        ("rows", &e, &tall),
    ];
    for (what, errors, heights) in cases {
        let got = std::panic::catch_unwind(|| extract(&h, errors, heights, 4.0, None));
        if cfg!(debug_assertions) {
            let message = got.err().and_then(|p| {
                p.downcast_ref::<&str>()
                    .map(|m| m.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
            });
            assert!(
                message
                    .as_deref()
                    .is_some_and(|m| m.contains("shapes differ")),
                "{what}: {message:?}"
            );
        } else {
            let m = got.unwrap();
            assert_eq!(m.triangle_count(), 0, "{what}");
        }
    }
}

/// The vertices of a mesh as row-major sample indices, sorted.
fn vertex_samples(m: &crate::zerotree::TerrainMesh) -> Vec<u32> {
    let mut v: Vec<u32> = m
        .positions
        .iter()
        .map(|p| (p[1] as usize * m.cols + p[0] as usize) as u32)
        .collect();
    v.sort_unstable();
    v
}

/// The corner samples every stitched tile forces (`Hierarchy::edge_spill`): exactly the
/// positions along an edge that forcing the whole of another edge reaches, on that edge and
/// mirrored onto its opposite one; a staircase towards each corner (at 257², the four
/// corners and 13 samples inside each edge), not whole edges. Forcing is read back from a
/// flat tile's mesh at an infinite tolerance, whose only vertices are the corners and the
/// forced samples.
#[test]
fn edge_spill_is_what_forcing_one_edge_reaches_on_the_others_mirrored() {
    for n in [17, 129, 257] {
        let h = Hierarchy::new(n).unwrap();
        let flat = Grid::<f64>::zeros(n, n);
        let e = TileErrors::new(&h, &flat);
        let at = |e: usize, i: usize| extract::edge_sample(n, e, i);
        let mut expected = std::collections::BTreeSet::new();
        for from in 0..4 {
            let forced = Forced::new(&h, (0..n).map(|i| at(from, i)));
            let m = extract(&h, &e, &flat, f64::INFINITY, Some(&forced));
            let vertices = vertex_samples(&m);
            assert!(
                (0..n).all(|i| vertices.binary_search(&(at(from, i) as u32)).is_ok()),
                "n {n}: edge {from} is forced"
            );
            for to in (0..4).filter(|&to| to != from) {
                for i in 0..n {
                    if vertices.binary_search(&(at(to, i) as u32)).is_ok() {
                        expected.insert(at(to, i) as u32);
                        expected.insert(at(to ^ 1, i) as u32);
                    }
                }
            }
        }
        let spill = h.edge_spill();
        assert_eq!(
            spill,
            expected.into_iter().collect::<Vec<_>>().as_slice(),
            "n {n}"
        );
        // A staircase towards each corner, not whole edges: at most two samples per power
        // of two along each edge, and the corners.
        let steps = (n - 1).ilog2() as usize;
        assert!(spill.len() <= 4 + 4 * 2 * steps, "n {n}: {}", spill.len());
    }
}

/// Every triangle of the hierarchy, on grids up to 2049² (k = 11, where n³ passes u32's
/// range): a right isosceles half with its right angle at `c`, wound as the roots are, of
/// half its parent's area; halved at `m`, the sample midway along a hypotenuse of even
/// extents, on every level but the last, which holds the unit halves and has [`NONE`] there.
/// 2k + 1 levels, each twice the one above.
#[test]
fn every_triangle_is_a_right_isosceles_half_split_at_its_hypotenuse_midpoint() {
    for n in [3usize, 5, 65, 2049] {
        let h = Hierarchy::new(n).unwrap();
        let k = (n - 1).ilog2() as usize;
        assert_eq!(h.levels(), 2 * k + 1, "n {n}");
        assert_eq!(h.tris.len(), h.level_start[h.levels()], "n {n}");
        let side = n as i64;
        let xy = |s: u32| {
            assert!((s as usize) < n * n, "n {n}: sample {s} outside the grid");
            (i64::from(s) % side, i64::from(s) / side)
        };
        for l in 0..h.levels() {
            let level = &h.tris[h.level_start[l]..h.level_start[l + 1]];
            assert_eq!(level.len(), 2 << l, "n {n} level {l}");
            let splittable = l + 1 < h.levels();
            // Twice the area: (n − 1)² over the level's triangle count.
            let twice_area = ((side - 1) * (side - 1)) >> l;
            for (i, t) in level.iter().enumerate() {
                let ((ax, ay), (bx, by), (cx, cy)) = (xy(t.a), xy(t.b), xy(t.c));
                let (ca, cb) = ((ax - cx, ay - cy), (bx - cx, by - cy));
                assert_eq!(
                    ca.0 * cb.0 + ca.1 * cb.1,
                    0,
                    "n {n} level {l} triangle {i}: right angle at c"
                );
                assert_eq!(
                    ca.0 * ca.0 + ca.1 * ca.1,
                    cb.0 * cb.0 + cb.1 * cb.1,
                    "n {n} level {l} triangle {i}: legs"
                );
                // The roots' winding (counter-clockwise with north, row 0, up) has c→a × c→b
                // negative in row-major coordinates.
                assert_eq!(
                    ca.0 * cb.1 - ca.1 * cb.0,
                    -twice_area,
                    "n {n} level {l} triangle {i}: winding, area"
                );
                if splittable {
                    assert!(
                        (bx - ax) % 2 == 0 && (by - ay) % 2 == 0,
                        "n {n} level {l} triangle {i}: odd extents"
                    );
                    let m = (ay + by) / 2 * side + (ax + bx) / 2;
                    assert_eq!(i64::from(t.m), m, "n {n} level {l} triangle {i}: midpoint");
                } else {
                    assert_eq!(
                        t.m, NONE,
                        "n {n} level {l} triangle {i}: a unit half splits"
                    );
                }
            }
        }
    }
}

/// A sample's parents, what must be mesh vertices before it can be one (conformity), are the
/// right angles of the triangles whose hypotenuse it halves: two inside the grid, one on
/// either side of that hypotenuse and so different, one on the border, none at the corners
/// (never a midpoint) and at the centre (the roots' midpoint). Filled slots come first.
#[test]
fn a_samples_parents_are_the_right_angles_of_the_triangles_it_halves() {
    for n in [5usize, 65] {
        let h = Hierarchy::new(n).unwrap();
        let mut expected = vec![Vec::new(); n * n];
        for t in &h.tris[h.level_start[1]..] {
            if t.m != NONE {
                expected[t.m as usize].push(t.c);
            }
        }
        let centre = n / 2 * n + n / 2;
        for (s, &[p, q]) in h.parents.iter().enumerate() {
            assert!(p != NONE || q == NONE, "n {n} sample {s}: {p}, {q}");
            let mut got: Vec<u32> = [p, q].into_iter().filter(|&p| p != NONE).collect();
            got.sort_unstable();
            expected[s].sort_unstable();
            assert_eq!(got, expected[s], "n {n} sample {s}");
            let (x, y) = (s % n, s / n);
            let edges = [x == 0, y == 0, x == n - 1, y == n - 1];
            let count = match edges.iter().filter(|&&e| e).count() {
                _ if s == centre => 0,
                0 => 2,
                1 => 1,
                _ => 0,
            };
            assert_eq!(got.len(), count, "n {n} sample {s}");
        }
    }
}

/// The side comes from a dataset's header: past 2¹² + 1 (a hierarchy of ~1 GB at 4097²) it is
/// refused before anything is allocated, as are sides one off a power of two plus one.
#[test]
fn sides_past_4097_are_refused() {
    let top = 1usize << (usize::BITS - 1);
    for n in [(1 << 13) + 1, (1 << 16) + 1, (1 << 31) + 1, top + 1] {
        for side in [n - 1, n, n + 1] {
            assert!(Hierarchy::new(side).is_none(), "side {side}");
        }
    }
    assert!(Hierarchy::new(usize::MAX).is_none());
}
