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
