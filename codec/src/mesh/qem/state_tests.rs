//! Unit checks of the QEM state against hand values and brute force (added after a
//! cargo-mutants run of state.rs: the mesh tests pass with these slips, and the Morton order
//! is only used on meshes of more than 2¹⁶ vertices, which no QEM test simplifies).

use super::*;
use crate::mesh::qem::simplify;

/// xorshift64*: scattered points without a dependency.
struct Rng(u64);

impl Rng {
    /// In [0, 1).
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn point(&mut self, min: DVec3, max: DVec3) -> DVec3 {
        let u = DVec3::new(self.unit(), self.unit(), self.unit());
        min + (max - min) * u
    }
}

/// The Morton key of a point on the 1024³ grid, bit by bit: bit i of x, y and z goes to bits
/// 3i, 3i + 1 and 3i + 2.
fn interleave([x, y, z]: [u64; 3]) -> u32 {
    let mut key = 0u64;
    for i in 0..10 {
        key |= (x >> i & 1) << (3 * i) | (y >> i & 1) << (3 * i + 1) | (z >> i & 1) << (3 * i + 2);
    }
    key as u32
}

#[test]
fn spatial_order_follows_the_morton_curve() {
    // The unit cube: 1 is 1023 on the grid (all ten bits), so corner x + 2y + 4z comes at that
    // place among the corners. The centre is 511 on each axis (bits 0–8 of the key all set),
    // below every corner but the origin; (0.25, 0, 0) is 255 in x, below the centre. The
    // origin twice: ties keep input order.
    let p = DVec3::new;
    let points = [
        p(1.0, 1.0, 1.0),  // corner 7
        p(0.0, 1.0, 0.0),  // corner 2
        p(0.5, 0.5, 0.5),  // centre
        p(0.0, 0.0, 0.0),  // origin
        p(1.0, 0.0, 1.0),  // corner 5
        p(0.25, 0.0, 0.0), // 255 in x
        p(1.0, 0.0, 0.0),  // corner 1
        p(0.0, 0.0, 1.0),  // corner 4
        p(0.0, 0.0, 0.0),  // origin
        p(1.0, 1.0, 0.0),  // corner 3
        p(0.0, 1.0, 1.0),  // corner 6
    ];
    assert_eq!(
        spatial_order(&points),
        vec![3, 8, 5, 2, 6, 1, 9, 7, 4, 10, 0]
    );
    // All in one place, or too far apart for the extent to be finite: input order.
    assert_eq!(spatial_order(&[DVec3::splat(3.0); 4]), vec![0, 1, 2, 3]);
    let far = [DVec3::X * 1e308, DVec3::ZERO, -DVec3::X * 1e308];
    assert_eq!(spatial_order(&far), vec![0, 1, 2]);
}

#[test]
fn spatial_order_sorts_by_interleaved_bits_stably() {
    // Scattered points in a box away from the origin, x the longest side (every axis on a
    // grid of 1023 steps of x's extent), some of them repeated: against the key built bit by
    // bit and a stable sort.
    let (min, max) = (DVec3::new(-7.0, 3.0, 100.0), DVec3::new(9.0, 15.0, 111.0));
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut points: Vec<DVec3> = (0..3000).map(|_| rng.point(min, max)).collect();
    points.extend_from_within(100..400);
    points.extend([min, max]);
    let scale = 1023.0 / (max - min).max_element();
    let keys: Vec<u32> = points
        .iter()
        .map(|p| interleave(((*p - min) * scale).to_array().map(|c| c as u64)))
        .collect();
    // Every axis uses its top bit somewhere.
    assert!((0..3).all(|axis| keys.iter().any(|k| k >> (27 + axis) & 1 == 1)));
    let mut want: Vec<u32> = (0..points.len() as u32).collect();
    want.sort_by_key(|&i| keys[i as usize]);
    assert_eq!(spatial_order(&points), want);
}

#[test]
fn faces_sort_stably_by_their_smallest_vertex() {
    // Smallest corners 2, 1, 2, 0, 1, 7, 1.
    let faces = [
        [5, 2, 7],
        [1, 9, 3],
        [4, 2, 8],
        [0, 6, 1],
        [3, 1, 2],
        [9, 8, 7],
        [2, 4, 1],
    ];
    let want = [
        [0, 6, 1],
        [1, 9, 3],
        [3, 1, 2],
        [2, 4, 1],
        [5, 2, 7],
        [4, 2, 8],
        [9, 8, 7],
    ];
    assert_eq!(sort_by_first_vertex(&faces, 10), want.to_vec());
    // Longer, against the standard library's stable sort.
    let mut rng = Rng(7);
    let n = 500;
    let faces: Vec<[u32; 3]> = (0..3000)
        .map(|_| [0; 3].map(|_| (rng.unit() * f64::from(n)) as u32))
        .collect();
    let mut want = faces.clone();
    want.sort_by_key(|t| t[0].min(t[1]).min(t[2]));
    assert_eq!(sort_by_first_vertex(&faces, n as usize), want);
}

/// The state after setup: quadrics, flags, edges.
/// An `n × n` grid of unit cells in the plane z = 0.
fn flat_grid(n: u32) -> TriMesh {
    crate::mesh::qem::tests::grid(n, |x, y| DVec3::new(f64::from(x), f64::from(y), 0.0))
}

fn state(m: &TriMesh, options: &QemOptions) -> State {
    let mut s = State::new(m, options, m.diagonal()).expect("fits");
    s.classify_edges(options);
    s
}

/// Adds a square of side `s` at `p` (two faces on the diagonal from p) or, as a `book`, three
/// faces on the edge from p to p + s·x (a non-manifold edge, which locks both its ends).
fn add_part(m: &mut TriMesh, p: DVec3, s: f64, book: bool) {
    let o = m.positions.len() as u32;
    if book {
        let pages = [DVec3::Y, DVec3::Z, -DVec3::Y].map(|d| p + d * s);
        m.positions.extend([p, p + DVec3::X * s]);
        m.positions.extend(pages);
        m.faces
            .extend([[o, o + 1, o + 2], [o, o + 1, o + 3], [o, o + 1, o + 4]]);
    } else {
        let corners = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        m.positions.extend(corners.map(|c| p + c * s));
        m.faces.extend([[o, o + 1, o + 2], [o, o + 2, o + 3]]);
    }
}

/// Aggregation partners by their definition, pair by pair: a vertex on a face and on no edge
/// of three or more faces pairs with each such vertex above it that shares no face with it
/// and is closer than t, the nearest 8 of them, both ways. Sorted.
fn partners_by_brute_force(m: &TriMesh, t: f64) -> Vec<Vec<u32>> {
    let n = m.positions.len();
    let mut edge_faces: HashMap<(u32, u32), usize> = HashMap::new();
    let mut alive = vec![false; n];
    for f in &m.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *edge_faces.entry((a.min(b), a.max(b))).or_default() += 1;
            alive[a as usize] = true;
        }
    }
    let mut locked = vec![false; n];
    for (&(a, b), &c) in &edge_faces {
        if c > 2 {
            locked[a as usize] = true;
            locked[b as usize] = true;
        }
    }
    let free = |v: usize| alive[v] && !locked[v];
    let share = |u: u32, v: u32| m.faces.iter().any(|f| f.contains(&u) && f.contains(&v));
    let mut partners = vec![Vec::new(); n];
    for v in (0..n).filter(|&v| free(v)) {
        let mut near: Vec<(f64, u32)> = (v + 1..n)
            .filter(|&u| free(u) && !share(u as u32, v as u32))
            .map(|u| ((m.positions[u] - m.positions[v]).length_squared(), u as u32))
            .filter(|&(d, _)| d < t * t)
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(_, u) in near.iter().take(8) {
            partners[v].push(u);
            partners[u as usize].push(v as u32);
        }
    }
    for p in &mut partners {
        p.sort_unstable();
    }
    partners
}

fn sorted_partners(s: &State) -> Vec<Vec<u32>> {
    let mut partners = s.partners.clone();
    for p in &mut partners {
        p.sort_unstable();
    }
    partners
}

#[test]
fn virtual_pairs_are_the_nearest_free_vertices_closer_than_t() {
    let options = QemOptions {
        aggregation: 0.1,
        ..QemOptions::to_faces(1)
    };
    // Two squares of side 1/8, 2.5 apart in x, with t = 2.5. Exactly t apart is not closer
    // than t (0 and 4, 1 and 5, 3 and 7, 2 and 6); 1 and 2 are 2.375 from 4 and 2.375 (and
    // 1/8 in y) from 7, and the rest further apart. Within a square the corners off its
    // diagonal (1 and 3, 5 and 7) share no face. The cells are 2.5 wide: 4 and 7 are a cell
    // over from 1 and 2.
    let mut two = TriMesh::new(Vec::new(), Vec::new());
    add_part(&mut two, DVec3::ZERO, 0.125, false);
    add_part(&mut two, DVec3::X * 2.5, 0.125, false);
    let mut s = state(&two, &options);
    s.add_virtual_pairs(2.5);
    let want: [&[u32]; 8] = [
        &[],
        &[3, 4, 7],
        &[4, 7],
        &[1],
        &[1, 2],
        &[7],
        &[],
        &[1, 2, 5],
    ];
    assert_eq!(sorted_partners(&s), want.map(<[u32]>::to_vec).to_vec());
    // Scattered squares and books, their sides a tenth of t (so face neighbours are within t,
    // and must be left out), across cells on both sides of the origin, with t above 1 and
    // below; and a cluster where every vertex has more than 8 candidates.
    let mut rng = Rng(42);
    for (t, half, parts) in [
        (2.5, 6.0, 60),
        (1.7, 5.0, 70),
        (0.45, 1.5, 40),
        (0.5, 0.2, 16),
    ] {
        let mut m = TriMesh::new(Vec::new(), Vec::new());
        for k in 0..parts {
            let at = rng.point(DVec3::splat(-half), DVec3::splat(half));
            add_part(&mut m, at, 0.1 * t, k % 5 == 0);
        }
        let want = partners_by_brute_force(&m, t);
        assert!(want.iter().any(|p| !p.is_empty()), "{t}");
        let mut s = state(&m, &options);
        s.add_virtual_pairs(t);
        assert_eq!(sorted_partners(&s), want, "{t}");
    }
}

#[test]
fn virtual_pairs_need_a_positive_finite_distance() {
    // simplify passes aggregation · diagonal, which is 0 for a subnormal aggregation on a
    // small mesh: no pair is closer than 0 (and p / 0 is no grid cell).
    let mut m = TriMesh::new(Vec::new(), Vec::new());
    add_part(&mut m, DVec3::ONE, 0.125, false);
    add_part(&mut m, DVec3::ONE * 1.1, 0.125, false);
    for t in [0.0, -1.0, f64::INFINITY, f64::NAN] {
        let mut s = state(&m, &QemOptions::to_faces(1));
        s.add_virtual_pairs(t);
        assert!(s.partners.iter().all(Vec::is_empty), "{t}");
    }
}

/// Two books (spines 0–1 and 5–6, pages 2–4 and 7–9) joined by the face 0-5-10, and a free
/// face 2-11-12 on a page.
fn two_books() -> TriMesh {
    let mut m = TriMesh::new(Vec::new(), Vec::new());
    add_part(&mut m, DVec3::ZERO, 1.0, true);
    add_part(&mut m, DVec3::X * 3.0, 1.0, true);
    m.positions.extend([
        DVec3::new(1.5, -2.0, 0.0),
        DVec3::new(0.0, 2.0, 1.0),
        DVec3::new(-1.0, 1.5, 0.5),
    ]);
    m.faces.extend([[0, 5, 10], [2, 11, 12]]);
    m
}

#[test]
fn non_manifold_edges_lock_their_ends_and_only_free_pairs_are_ranked() {
    // Every edge but the spines has one face: all vertices are on the boundary, the spines'
    // ends locked too. Ranked: the free face's three edges alone (0-5 and 0-10, 5-10 have
    // a locked end or two; spines are not edges to contract).
    let mut s = state(&two_books(), &QemOptions::to_faces(1));
    let (b, l) = (ALIVE | BOUNDARY, ALIVE | BOUNDARY | LOCKED);
    assert_eq!(s.flags, vec![l, l, b, b, b, l, l, b, b, b, b, b, b]);
    let pairs: Vec<(u32, u32)> = s.collect().iter().map(|e| (e.a, e.b)).collect();
    assert_eq!(pairs, vec![(2, 11), (2, 12), (11, 12)]);
}

/// Where `q` is within 10⁻¹² (relative) of the hand values.
fn assert_quadric(q: &Quadric, a: [f64; 6], b: [f64; 3], c: f64, w: f64, what: &str) {
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1.0);
    let ok = q.a.iter().zip(a).all(|(&x, y)| close(x, y))
        && q.b.to_array().iter().zip(b).all(|(&x, y)| close(x, y))
        && close(q.c, c)
        && close(q.w, w);
    assert!(ok, "{what}: {q:?}, want a {a:?} b {b:?} c {c} w {w}");
}

#[test]
fn a_lone_triangle_gets_a_boundary_plane_on_each_edge() {
    // In z = 3: 0 (1, 2, 3), 1 (2, 2, 3), 2 (1, 3, 3). Its own plane, area ½: zz ½, b
    // ½ · (0, 0, 1) · −3, c ½ · 9. Boundary planes at weight 10 · length²: y = 2 on 0-1
    // (weight 10: yy 10, b (0, −20, 0), c 40), x = 1 on 0-2 (xx 10, b (−10, 0, 0), c 10) and
    // (x + y − 4)/√2 on 1-2 (weight 20: xx, xy, yy 10, b (−40, −40, 0), c 160). Each corner
    // sums its own planes, and is on all of them (Q = 0 there).
    let m = TriMesh::new(
        vec![
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(2.0, 2.0, 3.0),
            DVec3::new(1.0, 3.0, 3.0),
        ],
        vec![[0, 1, 2]],
    );
    let s = state(&m, &QemOptions::to_faces(1));
    let q = |v: usize| s.geo[v].q;
    assert_quadric(
        &q(0),
        [10.0, 0.0, 0.0, 10.0, 0.0, 0.5],
        [-10.0, -20.0, -1.5],
        54.5,
        0.5,
        "0",
    );
    assert_quadric(
        &q(1),
        [10.0, 10.0, 0.0, 20.0, 0.0, 0.5],
        [-40.0, -60.0, -1.5],
        204.5,
        0.5,
        "1",
    );
    assert_quadric(
        &q(2),
        [20.0, 10.0, 0.0, 10.0, 0.0, 0.5],
        [-50.0, -40.0, -1.5],
        174.5,
        0.5,
        "2",
    );
    for v in 0..3 {
        assert!(q(v).eval(m.positions[v]).abs() < 1e-12, "{v}");
    }
}

#[test]
fn creases_get_a_plane_per_face_and_flat_edges_none() {
    // Two faces on edge 0-1 (the x axis, length 2): 0-1-2 in z = 0 (normal z, area 1) and
    // 1-0-3, turned about the axis by `turn` (area 1 too). No boundary planes. Past the crease
    // angle (45°) the edge gets two planes at weight 3 · 2², each through the edge and
    // perpendicular to its face: y = 0 for the first face, and z = 0 for the second turned by
    // 90° (normal y). Below it, on a flat pair, or without crease weight: none.
    let fold = |turn: f64| {
        let r = turn.to_radians();
        TriMesh::new(
            vec![
                DVec3::ZERO,
                DVec3::X * 2.0,
                DVec3::new(0.5, 1.0, 0.0),
                DVec3::new(0.5, -r.cos(), r.sin()),
            ],
            vec![[0, 1, 2], [1, 0, 3]],
        )
    };
    let options = |crease_angle_deg: f64| QemOptions {
        boundary_weight: 0.0,
        crease_angle_deg,
        ..QemOptions::to_faces(1)
    };
    // Turned by 90°: face planes z = 0 (area 1) and y = 0 (area 1) at both ends, plus the
    // crease planes y = 0 and z = 0 at 12 each.
    let s = state(&fold(90.0), &options(45.0));
    for v in [0, 1] {
        let q = s.geo[v].q;
        assert_quadric(
            &q,
            [0.0, 0.0, 0.0, 13.0, 0.0, 13.0],
            [0.0; 3],
            0.0,
            2.0,
            "90°",
        );
    }
    // The far corners have their own face's plane alone.
    assert_quadric(
        &s.geo[2].q,
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [0.0; 3],
        0.0,
        1.0,
        "2",
    );
    // Turned by 30° (below 45°), flat (0°, also at a crease angle of 0: coplanar faces meet
    // at 0°, not more), or without crease weight: the ends' quadrics are the faces' alone.
    let no_crease = |m: &TriMesh, o: &QemOptions, what: &str| {
        let s = state(m, o);
        let mut faces = Quadric::default();
        for t in &m.faces {
            let (n, d, area) = plane(
                m.positions[t[0] as usize],
                m.positions[t[1] as usize],
                m.positions[t[2] as usize],
            )
            .expect("has area");
            faces += Quadric::from_plane(n, d, area);
        }
        for v in [0, 1] {
            assert_eq!(s.geo[v].q, faces, "{what} {v}");
        }
    };
    no_crease(&fold(30.0), &options(45.0), "30°");
    no_crease(&fold(0.0), &options(45.0), "flat");
    no_crease(&fold(0.0), &options(0.0), "flat, crease angle 0");
    let weightless = QemOptions {
        crease_weight: 0.0,
        ..options(45.0)
    };
    no_crease(&fold(90.0), &weightless, "crease weight 0");
}

/// The two squares of [`virtual_pairs_are_the_nearest_free_vertices_closer_than_t`] with
/// their partners: 1–3, 1–4, 1–7, 2–4, 2–7 and 5–7.
fn two_squares_with_partners() -> State {
    let mut m = TriMesh::new(Vec::new(), Vec::new());
    add_part(&mut m, DVec3::ZERO, 0.125, false);
    add_part(&mut m, DVec3::X * 2.5, 0.125, false);
    let options = QemOptions {
        aggregation: 0.1,
        ..QemOptions::to_faces(1)
    };
    let mut s = state(&m, &options);
    s.add_virtual_pairs(2.5);
    s
}

#[test]
fn the_first_ranking_lists_every_edge_and_partner_pair_once() {
    // Each square's five edges, then the six partner pairs, each from its smaller end.
    let mut s = two_squares_with_partners();
    let pairs: Vec<(u32, u32)> = s.collect().iter().map(|e| (e.a, e.b)).collect();
    let mut edges = vec![(0, 1), (0, 2), (0, 3), (1, 2), (2, 3)];
    edges.extend(edges.clone().iter().map(|&(a, b)| (a + 4, b + 4)));
    let (mut first, mut rest) = (pairs[..10].to_vec(), pairs[10..].to_vec());
    first.sort_unstable();
    rest.sort_unstable();
    assert_eq!(first, edges);
    assert_eq!(rest, vec![(1, 3), (1, 4), (1, 7), (2, 4), (2, 7), (5, 7)]);
}

/// The far ends of the pairs [`State::collect_vertex`] lists for `v` (all from `v`), sorted.
fn pairs_of(s: &mut State, v: u32, take: impl Fn(u32) -> bool) -> Vec<u32> {
    let mut out = Vec::new();
    s.collect_vertex(v, take, &mut out);
    assert!(out.iter().all(|e| e.a == v), "{out:?}");
    let mut ends: Vec<u32> = out.iter().map(|e| e.b).collect();
    ends.sort_unstable();
    ends
}

#[test]
fn a_vertex_lists_its_neighbours_and_live_partners_once() {
    let mut s = two_squares_with_partners();
    // 1 is on face 0-1-2 alone; its partners are 3, 4 and 7.
    assert_eq!(pairs_of(&mut s, 1, |_| true), vec![0, 2, 3, 4, 7]);
    // Only the ones `take` accepts, neighbours and partners alike.
    assert_eq!(pairs_of(&mut s, 1, |u| u != 4 && u != 2), vec![0, 3, 7]);
    // A partner that has become a neighbour (merged parts), listed once.
    s.partners[1].push(2);
    assert_eq!(pairs_of(&mut s, 1, |_| true), vec![0, 2, 3, 4, 7]);
    // A partner contracted away is no pair.
    s.flags[7] &= !ALIVE;
    assert_eq!(pairs_of(&mut s, 1, |_| true), vec![0, 2, 3, 4]);
    assert_eq!(pairs_of(&mut s, 2, |_| true), vec![0, 1, 3, 4]);
}

#[test]
fn a_vertex_where_three_faces_touch_lists_its_six_neighbours() {
    // Three faces with only vertex 0 in common (each edge has one face, so nothing is
    // locked): six neighbours, more than its three faces' count plus three.
    let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let m = TriMesh::new(
        vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(-1.0, 0.0, 0.0),
            p(-1.0, -1.0, 0.0),
            p(0.0, 1.0, 1.0),
            p(0.0, -1.0, 1.0),
        ],
        vec![[0, 1, 2], [0, 3, 4], [5, 6, 0]],
    );
    let mut s = state(&m, &QemOptions::to_faces(1));
    assert_eq!(pairs_of(&mut s, 0, |_| true), vec![1, 2, 3, 4, 5, 6]);
}

#[test]
fn flat_pairs_rank_by_their_length_alone() {
    // A flat 3×3 grid without boundary planes: every pair's error is 0 (to rounding, far
    // below 10⁻¹²), so its key is the tie break alone, 10⁻⁸ · length²: 10⁻⁸ on the sides,
    // 2 · 10⁻⁸ on the diagonals.
    let m = flat_grid(3);
    let options = QemOptions {
        boundary_weight: 0.0,
        ..QemOptions::to_faces(1)
    };
    let entries = state(&m, &options).collect();
    assert_eq!(entries.len(), 16);
    let mut diagonals = 0;
    for e in &entries {
        let len_sq = (m.positions[e.a as usize] - m.positions[e.b as usize]).length_squared();
        assert!(len_sq == 1.0 || len_sq == 2.0, "{e:?}");
        diagonals += usize::from(len_sq == 2.0);
        assert_eq!(e.key, key_of((1e-8 * len_sq) as f32), "{e:?}");
    }
    assert_eq!(diagonals, 4);
}

#[test]
fn a_mesh_left_whole_comes_back_as_it_went_in() {
    // Below 2¹⁶ vertices the working order is the input's: a tetrahedron, which cannot
    // collapse, comes back face for face (its faces sorted by smallest corner would be
    // 0-2-1, 0-1-3, 2-0-3, 1-2-3).
    let tetrahedron = TriMesh::new(
        vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
        vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
    );
    let (out, report) = simplify(&tetrahedron, &QemOptions::to_faces(1)).expect("runs");
    assert_eq!(report.collapses, 0);
    assert_eq!(
        (out.positions, out.faces),
        (tetrahedron.positions, tetrahedron.faces)
    );
    // Above it the vertices follow a Morton curve while simplifying: a 257² grid (66,049
    // vertices) already at its face target comes back with its vertices in input order and
    // the same faces, now in the working order.
    let grid = flat_grid(257);
    let (out, report) = simplify(&grid, &QemOptions::to_faces(grid.face_count())).expect("runs");
    assert_eq!(report.collapses, 0);
    assert_eq!(out.positions, grid.positions);
    assert_ne!(out.faces, grid.faces);
    let mut got = out.faces.clone();
    got.sort_unstable();
    let mut want = grid.faces.clone();
    want.sort_unstable();
    assert_eq!(got, want);
}

#[test]
fn compaction_keeps_the_reference_array_near_the_live_mesh() {
    // Each contraction writes the kept vertex's face slice anew at the end of the reference
    // array: a 60² grid taken to 100 faces writes well over twice the array's first length,
    // so it must have been compacted (to its live references, or 4096), and after a last
    // check at most half of it is dead. Every vertex's slice still holds its live faces.
    let grid = flat_grid(60);
    let mut s = state(&grid, &QemOptions::to_faces(100));
    let first = s.refs.len();
    assert_eq!(first, 3 * grid.face_count());
    s.run(100, f64::INFINITY);
    s.maybe_compact();
    assert!(s.refs_compact < first, "{} of {first}", s.refs_compact);
    assert!(
        s.refs.len() <= 2 * s.refs_compact,
        "{} after compacting to {}",
        s.refs.len(),
        s.refs_compact
    );
    let live = |f: u32| s.faces[f as usize][0] != DEAD;
    for v in 0..s.geo.len() as u32 {
        let mut got: Vec<u32> = s.ring(v).iter().copied().filter(|&f| live(f)).collect();
        got.sort_unstable();
        let want: Vec<u32> = (0..s.faces.len() as u32)
            .filter(|&f| live(f) && s.faces[f as usize].contains(&v))
            .collect();
        assert_eq!(got, want, "{v}");
    }
}

#[test]
fn pairs_without_area_around_them_rank_first_not_last() {
    // Two faces on one line: no plane, no boundary plane, a quadric of zero weight at every
    // vertex. Removing them costs nothing: each pair's key is its tie break, 10⁻⁸ · length²
    // (its error 0, not 0 / 0).
    let m = TriMesh::new(
        (0..4).map(|i| DVec3::X * f64::from(i)).collect(),
        vec![[0, 1, 2], [1, 3, 2]],
    );
    let mut s = state(&m, &QemOptions::to_faces(1));
    assert!(s.geo.iter().all(|g| g.q == Quadric::default()));
    let keys: Vec<(u32, u32, u32)> = s.collect().iter().map(|e| (e.a, e.b, e.key)).collect();
    let key = |len_sq: f64| key_of((1e-8 * len_sq) as f32);
    let want = [
        (0, 1, key(1.0)),
        (0, 2, key(4.0)),
        (1, 2, key(1.0)),
        (1, 3, key(4.0)),
        (2, 3, key(1.0)),
    ];
    assert_eq!(keys, want.to_vec());
}
