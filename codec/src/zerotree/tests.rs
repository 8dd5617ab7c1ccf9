use super::*;
use crate::ezw::{self, DecodeLimit, EncodeParams};
use crate::fixtures::n44w072_crop;
use crate::grid::Grid;
use crate::wavelet::Wavelet;
use crate::zerotree::terrain_mesh::assert_watertight;

fn decode_at(g: &Grid<f64>, wavelet: Wavelet, t: f64) -> ezw::Decoded {
    let enc = ezw::encode(g, &EncodeParams::new(wavelet, 1.0)).unwrap();
    ezw::decode(
        &enc.bytes,
        DecodeLimit::Threshold(t),
        ezw::DEFAULT_MAX_SAMPLES,
    )
    .unwrap()
}

fn mesh_at(d: &ezw::Decoded, t: f64) -> TerrainMesh {
    triangulate(
        &Complexity::new(&d.layout, &d.coefficients).leaves(t),
        &d.heights,
        None,
    )
}

#[test]
fn real_tiles_mesh_watertight_at_every_threshold() {
    for (r, c, size) in [
        (300, 500, 257),
        (0, 0, 256),
        (700, 100, 129),
        (40, 900, 100),
    ] {
        let g = n44w072_crop(r, c, size);
        for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
            let d = decode_at(&g, wavelet, 0.5);
            for t in [0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 64.0, 1e9] {
                let m = mesh_at(&d, t);
                assert_watertight(&m, &format!("{size}² at ({r},{c}) {wavelet:?} T={t}"));
                let e = mesh_error(&m, &d.heights);
                assert_eq!(e.uncovered, 0);
            }
        }
    }
}

#[test]
fn triangle_count_falls_as_the_threshold_rises() {
    let g = n44w072_crop(300, 500, 257);
    for wavelet in [Wavelet::Cdf97, Wavelet::LeGall53] {
        let d = decode_at(&g, wavelet, 0.25);
        let c = Complexity::new(&d.layout, &d.coefficients);
        let counts: Vec<usize> = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0]
            .iter()
            .map(|&t| triangulate(&c.leaves(t), &d.heights, None).triangle_count())
            .collect();
        assert!(
            counts.windows(2).all(|w| w[1] <= w[0]),
            "{wavelet:?}: {counts:?}"
        );
        assert!(
            counts[0] > 4 * counts[7],
            "{wavelet:?}: the range should matter: {counts:?}"
        );
    }
}

#[test]
fn zero_threshold_is_the_full_grid_and_reproduces_the_decoded_heights() {
    let g = n44w072_crop(0, 0, 65);
    let d = decode_at(&g, Wavelet::LeGall53, 0.0);
    let m = mesh_at(&d, 0.0);
    assert_eq!(m.triangle_count(), 2 * 64 * 64);
    assert_eq!(m.vertex_count(), 65 * 65);
    let e = mesh_error(&m, &g);
    assert_eq!(
        (e.max_abs, e.uncovered),
        (0.0, 0),
        "lossless decode, full mesh"
    );
}

#[test]
fn leaves_are_nested_across_thresholds() {
    // A leaf at T is covered by a leaf at every larger T: the T_i zerotree contains the T_j
    // zerotree for T_i < T_j (the paper's Fig. 5).
    let g = n44w072_crop(500, 300, 129);
    let d = decode_at(&g, Wavelet::Cdf97, 0.5);
    let c = Complexity::new(&d.layout, &d.coefficients);
    let fine = c.leaves(1.0);
    let coarse = c.leaves(8.0);
    // Both tile the grid, and the thresholds matter: equal sets would nest trivially.
    for m in [&fine, &coarse] {
        let area: usize = m.leaves().iter().map(|l| l.size() * l.size()).sum();
        assert_eq!(area, 128 * 128);
    }
    assert!(
        fine.leaves().len() > 2 * coarse.leaves().len(),
        "{} leaves at T = 1 against {} at T = 8",
        fine.leaves().len(),
        coarse.leaves().len()
    );
    for l in fine.leaves() {
        let inside = coarse.leaves().iter().any(|p| {
            let s = p.size() as u32;
            p.level >= l.level
                && (p.row..p.row + s).contains(&l.row)
                && (p.col..p.col + s).contains(&l.col)
        });
        assert!(inside, "{l:?} is not inside any coarser leaf");
    }
}

#[test]
fn mesh_error_of_a_plane_is_zero_whatever_the_mesh() {
    let g = Grid::new(
        17,
        17,
        (0..17 * 17)
            .map(|k| (k / 17) as f64 * 2.0 - (k % 17) as f64)
            .collect(),
    )
    .unwrap();
    let d = decode_at(&g, Wavelet::LeGall53, 0.0);
    for t in [0.0, 1.0, 100.0] {
        let e = mesh_error(&mesh_at(&d, t), &g);
        assert!(e.max_abs < 1e-9 && e.uncovered == 0, "T={t}: {e:?}");
    }
    // And a mesh of the wrong shape covers nothing.
    let other = Grid::<f64>::zeros(5, 5);
    assert_eq!(mesh_error(&mesh_at(&d, 1.0), &other).uncovered, 25);
}

#[test]
fn border_vertices_are_the_border_leaf_corners() {
    let g = n44w072_crop(300, 500, 65);
    let d = decode_at(&g, Wavelet::Cdf97, 1.0);
    let split = Complexity::new(&d.layout, &d.coefficients).leaves(4.0);
    let b = split.border_vertices();
    let m = triangulate(&split, &d.heights, None);
    // Mesh vertices at (x, y) = at(k) for k along one side.
    let on = |at: &dyn Fn(f64) -> (f64, f64)| -> Vec<bool> {
        (0..65)
            .map(|k| {
                let (x, y) = at(k as f64);
                m.positions.iter().any(|p| p[0] == x && p[1] == y)
            })
            .collect()
    };
    assert_eq!(b.north, on(&|k| (k, 0.0)), "north");
    assert_eq!(b.south, on(&|k| (k, 64.0)), "south");
    assert_eq!(b.west, on(&|k| (0.0, k)), "west");
    assert_eq!(b.east, on(&|k| (64.0, k)), "east");
    // Not only the corners: each side has vertices between them.
    for side in [&b.north, &b.south, &b.west, &b.east] {
        assert!(side[1..64].iter().any(|&v| v));
    }
}

#[test]
fn extra_border_vertices_are_inserted_without_t_junctions() {
    let g = n44w072_crop(300, 500, 65);
    let d = decode_at(&g, Wavelet::Cdf97, 1.0);
    let split = Complexity::new(&d.layout, &d.coefficients).leaves(16.0);
    let mut extra = BorderVertices::empty(65, 65);
    for k in [3, 7, 8, 30, 31, 33, 50] {
        extra.north[k] = true;
        extra.east[k] = true;
        extra.south[64 - k] = true;
        extra.west[k / 2] = true;
    }
    let m = triangulate(&split, &d.heights, Some(&extra));
    assert_watertight(&m, "with extra border vertices");
    let has = |x: usize, y: usize| {
        m.positions
            .iter()
            .any(|p| p[0] == x as f64 && p[1] == y as f64)
    };
    for k in [3, 7, 8, 30, 31, 33, 50] {
        assert!(has(k, 0), "north {k}");
        assert!(has(64, k), "east {k}");
        assert!(has(64 - k, 64), "south {}", 64 - k);
        assert!(has(0, k / 2), "west {}", k / 2);
    }
}

/// One leaf over a 3 × 3 grid (level 1), or a 2 × 2 grid (level 0).
fn one_leaf(heights: &[f64]) -> (Grid<f64>, TerrainMesh) {
    let n = if heights.len() == 9 { 3 } else { 2 };
    let g = Grid::new(n, n, heights.to_vec()).unwrap();
    let leaf = Leaf {
        row: 0,
        col: 0,
        level: (n - 2) as u8,
    };
    let m = triangulate(&SplitMap::new(n, n, vec![leaf]), &g, None);
    (g, m)
}

/// Whether the mesh has an edge between grid samples (x, y) = a and b.
fn has_edge(m: &TerrainMesh, a: (f64, f64), b: (f64, f64)) -> bool {
    let at = |p: (f64, f64)| m.positions.iter().position(|q| (q[0], q[1]) == p).unwrap() as u32;
    let (a, b) = (at(a), at(b));
    m.triangles.iter().any(|t| {
        (0..3).any(|k| (t[k], t[(k + 1) % 3]) == (a, b) || (t[k], t[(k + 1) % 3]) == (b, a))
    })
}

/// A bare leaf splits along the diagonal whose midpoint is nearer the centre sample (which
/// lies on it), so the centre is interpolated with the smaller error; a 1 × 1 cell takes the
/// diagonal with the smaller height step.
#[test]
fn a_bare_leaf_splits_along_the_diagonal_nearer_its_centre() {
    // Row-major 3 × 3, centre 2: the tl–br diagonal's midpoint is 1, the bl–tr one's 9.
    let (_, m) = one_leaf(&[0.0, 0.0, 18.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0]);
    assert_eq!(m.triangle_count(), 2);
    assert!(has_edge(&m, (0.0, 0.0), (2.0, 2.0)));
    let (_, m) = one_leaf(&[18.0, 0.0, 0.0, 0.0, 2.0, 0.0, 2.0, 0.0, 0.0]);
    assert!(has_edge(&m, (2.0, 0.0), (0.0, 2.0)));
    // 2 × 2: tl 0, tr 9, bl 5, br 1: |0 − 1| < |5 − 9|.
    let (_, m) = one_leaf(&[0.0, 9.0, 5.0, 1.0]);
    assert!(has_edge(&m, (0.0, 0.0), (1.0, 1.0)));
    let (_, m) = one_leaf(&[0.0, 1.0, 5.0, 9.0]);
    assert!(has_edge(&m, (1.0, 0.0), (0.0, 1.0)));
}

/// The measure on a mesh worked by hand: two triangles over a 3 × 3 grid that is flat but
/// for its centre, which lies on their shared diagonal and is interpolated as 0: its error
/// is the largest, the eight other samples are exact, RMS = √(6² / 9) = 2.
#[test]
fn mesh_error_of_a_hand_worked_mesh() {
    let (g, m) = one_leaf(&[0.0, 0.0, 0.0, 0.0, 6.0, 0.0, 0.0, 0.0, 0.0]);
    let e = mesh_error(&m, &g);
    assert_eq!(e.uncovered, 0);
    assert!((e.max_abs - 6.0).abs() < 1e-12, "{e:?}");
    assert!((e.rmse - 2.0).abs() < 1e-12, "{e:?}");
}
