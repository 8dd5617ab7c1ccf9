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

/// Border samples of a mesh that are vertices, as flags (north/south by column, west/east by
/// row).
fn border_of(m: &TerrainMesh) -> BorderVertices {
    let has = |x: usize, y: usize| {
        m.positions
            .iter()
            .any(|p| p[0] == x as f64 && p[1] == y as f64)
    };
    let (last_r, last_c) = (m.rows - 1, m.cols - 1);
    BorderVertices {
        north: (0..m.cols).map(|c| has(c, 0)).collect(),
        south: (0..m.cols).map(|c| has(c, last_r)).collect(),
        west: (0..m.rows).map(|r| has(0, r)).collect(),
        east: (0..m.rows).map(|r| has(last_c, r)).collect(),
    }
}

/// Extra border vertices add exactly themselves: the mesh's border is the leaves' corners and
/// the extra flags, nothing more, and flags past the grid's edges are ignored.
#[test]
fn extra_border_vertices_add_exactly_themselves() {
    let g = n44w072_crop(300, 500, 65);
    let d = decode_at(&g, Wavelet::Cdf97, 1.0);
    let split = Complexity::new(&d.layout, &d.coefficients).leaves(16.0);
    let mut extra = BorderVertices::empty(65, 65);
    for k in [5, 6, 21, 40, 63] {
        extra.north[k] = true;
        extra.south[k - 2] = true;
        extra.west[k - 1] = true;
        extra.east[k] = true;
    }
    let m = triangulate(&split, &d.heights, Some(&extra));
    assert_watertight(&m, "extra");
    assert_eq!(border_of(&m), split.border_vertices().union(&extra));
    // Flags past the grid's edges change nothing.
    let mut long = extra.clone();
    for side in [
        &mut long.north,
        &mut long.south,
        &mut long.west,
        &mut long.east,
    ] {
        side.extend([true; 4]);
    }
    assert_eq!(triangulate(&split, &d.heights, Some(&long)), m);
}

/// No leaves (a grid of one row or column) is no mesh, extra border vertices or not.
#[test]
fn no_leaves_no_vertices() {
    let mut extra = BorderVertices::empty(3, 3);
    extra.north[1] = true;
    let m = triangulate(
        &SplitMap::new(3, 3, vec![]),
        &Grid::zeros(3, 3),
        Some(&extra),
    );
    assert_eq!(
        (m.rows, m.cols, m.vertex_count(), m.triangle_count()),
        (3, 3, 0, 0)
    );
}

#[test]
fn union_sets_the_flags_of_either_and_keeps_its_own_lengths() {
    let mut a = BorderVertices::empty(3, 4);
    let mut b = BorderVertices::empty(5, 2);
    a.north[3] = true;
    a.west[0] = true;
    b.north[1] = true;
    b.west[0] = true;
    b.east[4] = true; // past a's 3 rows: dropped
    b.south[0] = true;
    let u = a.union(&b);
    assert_eq!(u.north, [false, true, false, true]);
    assert_eq!(u.south, [true, false, false, false]);
    assert_eq!(u.west, [true, false, false]);
    assert_eq!(u.east, [false, false, false]);
    assert_eq!(b.union(&a).east, [false, false, false, false, true]);
}

/// A 5 × 5 grid of small integers (every sample distinct from its neighbours).
fn grid5() -> Grid<f64> {
    Grid::new(5, 5, (0..25).map(|k| ((k * 7) % 11) as f64).collect()).unwrap()
}

/// The fan's triangle counts, from the module doc: a polygon of V vertices gives V − 2
/// triangles from an apex (a vertex alone on its side, or a corner between two bare sides),
/// V from the centre sample when every busy side has several vertices.
#[test]
fn fans_have_the_table_counts() {
    let g = grid5();
    let whole = SplitMap::new(
        5,
        5,
        vec![Leaf {
            row: 0,
            col: 0,
            level: 2,
        }],
    );
    let mut extra = BorderVertices::empty(5, 5);
    // One vertex on the north side: V = 5, apex on it.
    extra.north[1] = true;
    let m = triangulate(&whole, &g, Some(&extra));
    assert_watertight(&m, "one on north");
    assert_eq!((m.vertex_count(), m.triangle_count()), (5, 3));
    // Two on the north side: the apex is a bottom corner (both its sides bare), V = 6.
    extra.north[3] = true;
    let m = triangulate(&whole, &g, Some(&extra));
    assert_watertight(&m, "two on north");
    assert_eq!((m.vertex_count(), m.triangle_count()), (6, 4));
    // Two on the west side as well: the top corners touch a busy side, the bottom ones
    // are bare on both, V = 8.
    extra.west[1] = true;
    extra.west[2] = true;
    let m = triangulate(&whole, &g, Some(&extra));
    assert_watertight(&m, "north and west");
    assert_eq!((m.vertex_count(), m.triangle_count()), (8, 6));
    // Two on the west and two on the east side: every corner touches a busy side, so the
    // fan is from the centre sample, a vertex of its own: V = 8 and 8 triangles.
    let mut extra = BorderVertices::empty(5, 5);
    extra.west[1] = true;
    extra.west[2] = true;
    extra.east[1] = true;
    extra.east[3] = true;
    let m = triangulate(&whole, &g, Some(&extra));
    assert_watertight(&m, "west and east");
    assert_eq!((m.vertex_count(), m.triangle_count()), (9, 8));
    assert!(m.positions.iter().any(|p| (p[0], p[1]) == (2.0, 2.0)));
    // Inside the grid: three level-1 leaves and four 1 × 1 cells in the bottom-left
    // quarter. The top-left leaf has one vertex on its south side and the bottom-right one
    // on its west side: 3 + 3 + 2 + 4 × 2 triangles.
    let mut leaves = vec![
        Leaf {
            row: 0,
            col: 0,
            level: 1,
        },
        Leaf {
            row: 0,
            col: 2,
            level: 1,
        },
    ];
    for (row, col) in [(2, 0), (2, 1), (3, 0), (3, 1)] {
        leaves.push(Leaf { row, col, level: 0 });
    }
    leaves.push(Leaf {
        row: 2,
        col: 2,
        level: 1,
    });
    let m = triangulate(&SplitMap::new(5, 5, leaves), &g, None);
    assert_watertight(&m, "mixed levels");
    assert_eq!((m.vertex_count(), m.triangle_count()), (14, 16));
}

/// Where the two bare-leaf rules disagree: a 3 × 3 leaf follows its centre sample even
/// against the smaller corner step, a 1 × 1 cell the smaller step even against the
/// midpoint nearer its top-left corner.
#[test]
fn the_diagonal_rule_depends_on_the_leaf_size() {
    // tl 0, br 10 (midpoint 5), bl = tr = 0 (step 0); centre 5.
    let (_, m) = one_leaf(&[0.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 10.0]);
    assert!(has_edge(&m, (0.0, 0.0), (2.0, 2.0)));
    // tl 0, tr 5, bl 5, br 3: steps 3 and 0, midpoints 1.5 and 5.
    let (_, m) = one_leaf(&[0.0, 5.0, 5.0, 3.0]);
    assert!(has_edge(&m, (1.0, 0.0), (0.0, 1.0)));
    // tl −3, tr 2, bl 0, br 3: steps 6 and 2 (the sums would say 0 and 2).
    let (_, m) = one_leaf(&[-3.0, 2.0, 0.0, 3.0]);
    assert!(has_edge(&m, (1.0, 0.0), (0.0, 1.0)));
}

/// The centre rule's arithmetic, on cases found by search to tell it from every one-operator
/// change: tl = tr = bl = −3, br = 2, centre −2 misses the midpoints by 1.5 and 1, so the
/// anti-diagonal; a flat −3 is a tie, which goes to the main diagonal.
#[test]
fn the_centre_rule_measures_the_midpoints_against_the_centre() {
    let (_, m) = one_leaf(&[-3.0, 0.0, -3.0, 0.0, -2.0, 0.0, -3.0, 0.0, 2.0]);
    assert!(has_edge(&m, (2.0, 0.0), (0.0, 2.0)));
    let (_, m) = one_leaf(&[-3.0, 0.0, -3.0, 0.0, -3.0, 0.0, -3.0, 0.0, -3.0]);
    assert!(has_edge(&m, (0.0, 0.0), (2.0, 2.0)));
}

#[test]
fn height_range_is_the_extreme_vertex_heights() {
    let mut m = TerrainMesh::default();
    assert_eq!(m.height_range(), None);
    m.positions = vec![
        [0.0, 0.0, 3.5],
        [1.0, 0.0, -2.25],
        [0.0, 1.0, 7.0],
        [1.0, 1.0, 0.0],
    ];
    assert_eq!(m.height_range(), Some((-2.25, 7.0)));
    m.positions.truncate(1);
    assert_eq!(m.height_range(), Some((3.5, 3.5)));
}

/// The measure does not depend on a triangle's winding, nor on triangles staying inside the
/// grid, and a mesh that covers nothing has no error, not NaN.
#[test]
fn mesh_error_takes_either_winding_and_clips_to_the_grid() {
    // 3 × 3, flat 0 but for the east-north corner, 6: the triangle (0,0) (2,0) (2,2) in
    // (x, y) carries it, the triangle (0,0) (0,2) (2,2) is flat.
    let mut g = Grid::<f64>::zeros(3, 3);
    *g.get_mut(0, 2) = 6.0;
    *g.get_mut(0, 1) = 3.0;
    *g.get_mut(1, 2) = 3.0;
    let corners = vec![
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 6.0],
        [0.0, 2.0, 0.0],
        [2.0, 2.0, 0.0],
    ];
    // Opposite windings in (x, y), each listed first once.
    for triangles in [vec![[0, 2, 3], [0, 1, 3]], vec![[0, 1, 3], [0, 2, 3]]] {
        let m = TerrainMesh {
            rows: 3,
            cols: 3,
            positions: corners.clone(),
            triangles,
        };
        let e = mesh_error(&m, &g);
        assert_eq!((e.max_abs, e.rmse, e.uncovered), (0.0, 0.0, 0), "{m:?}");
        // Alone, the flat triangle covers its own six samples (x ≤ y), all exact.
        let flat = TerrainMesh {
            triangles: vec![[0, 2, 3]],
            ..m.clone()
        };
        let e = mesh_error(&flat, &g);
        assert_eq!((e.max_abs, e.uncovered), (0.0, 3), "{flat:?}");
    }
    // One triangle far past the grid, on the plane z = x + 2y, covers every sample once.
    let plane = Grid::new(3, 3, (0..9).map(|k| (k % 3 + 2 * (k / 3)) as f64).collect()).unwrap();
    let big = TerrainMesh {
        rows: 3,
        cols: 3,
        positions: vec![[-4.0, -4.0, -12.0], [10.0, -4.0, 2.0], [-4.0, 10.0, 16.0]],
        triangles: vec![[0, 1, 2]],
    };
    let e = mesh_error(&big, &plane);
    assert_eq!((e.max_abs, e.rmse, e.uncovered), (0.0, 0.0, 0));
    // A grid of another shape, if only on one axis, is not measured.
    for other in [Grid::<f64>::zeros(3, 4), Grid::zeros(4, 3)] {
        let e = mesh_error(&big, &other);
        assert!(
            e.max_abs.is_nan() && e.rmse.is_nan() && e.uncovered == 12,
            "{e:?}"
        );
    }
    // No triangle: nothing covered, no error.
    let empty = TerrainMesh {
        rows: 3,
        cols: 3,
        ..TerrainMesh::default()
    };
    let e = mesh_error(&empty, &plane);
    assert_eq!((e.max_abs, e.rmse, e.uncovered), (0.0, 0.0, 9));
}
