use super::*;
use crate::fixtures::n44w072_crop;
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
