use glam::DVec3;

use super::measure::{measure, Weights};
use super::*;

/// A UV sphere of radius `r`: `rings` latitudes between the poles, `segments` around.
pub(super) fn uv_sphere(rings: usize, segments: usize, r: f64) -> TriMesh {
    let mut positions = vec![DVec3::Z * r];
    for i in 1..=rings {
        let t = std::f64::consts::PI * i as f64 / (rings + 1) as f64;
        for j in 0..segments {
            let p = std::f64::consts::TAU * j as f64 / segments as f64;
            positions.push(r * DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos()));
        }
    }
    positions.push(-DVec3::Z * r);
    let s = (positions.len() - 1) as u32;
    let at = |i: usize, j: usize| (1 + i * segments + j % segments) as u32;
    let mut faces = Vec::new();
    for j in 0..segments {
        faces.push([0, at(0, j), at(0, j + 1)]);
        faces.push([s, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 0..rings - 1 {
        for j in 0..segments {
            faces.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
            faces.push([at(i, j + 1), at(i + 1, j), at(i + 1, j + 1)]);
        }
    }
    TriMesh { positions, faces }
}

/// A flat `n` × `n` grid of unit squares at z = 0, each cut on the same diagonal, rows of
/// vertices from y = 0.
pub(super) fn flat_grid(n: u32) -> TriMesh {
    let positions = (0..n)
        .flat_map(|y| (0..n).map(move |x| DVec3::new(f64::from(x), f64::from(y), 0.0)))
        .collect();
    let mut faces = Vec::new();
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let a = y * n + x;
            faces.push([a, a + 1, a + n + 1]);
            faces.push([a, a + n + 1, a + n]);
        }
    }
    TriMesh { positions, faces }
}

fn per_vertex(mesh: &TriMesh) -> Vec<super::Measure> {
    let mut vf = vec![Vec::new(); mesh.positions.len()];
    for f in &mesh.faces {
        for &v in f {
            vf[v as usize].push(*f);
        }
    }
    (0..mesh.positions.len() as u32)
        .map(|v| {
            measure(
                v,
                &vf[v as usize],
                |i| mesh.positions[i as usize],
                &Weights::default(),
            )
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn a_unit_sphere_reads_k_h_r_one_with_the_quarter_convention() {
    let m = per_vertex(&uv_sphere(50, 100, 1.0));
    for (name, f) in [
        (
            "K",
            (|m: &super::Measure| m.gaussian) as fn(&super::Measure) -> f64,
        ),
        ("H", |m| m.mean),
        ("R", |m| m.bending),
    ] {
        let med = median(m.iter().map(f).collect());
        assert!((med - 1.0).abs() < 0.02, "{name} = {med}");
    }
    // The poles too (the mixed area's reason for being).
    for pole in [&m[0], &m[m.len() - 1]] {
        assert!(
            (pole.gaussian - 1.0).abs() < 0.02,
            "pole K = {}",
            pole.gaussian
        );
        assert!((pole.mean - 1.0).abs() < 0.02, "pole H = {}", pole.mean);
    }
    // Radius 2: curvatures scale as 1/r and 1/r².
    let m2 = per_vertex(&uv_sphere(50, 100, 2.0));
    assert!((median(m2.iter().map(|m| m.mean).collect()) - 0.5).abs() < 0.01);
    assert!((median(m2.iter().map(|m| m.gaussian).collect()) - 0.25).abs() < 0.01);
}

#[test]
fn concave_bends_negative_and_flat_is_zero() {
    // A square pyramid apex: convex when the apex points along the normal side.
    let up = TriMesh {
        positions: vec![
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(0.0, -1.0, 0.0),
        ],
        faces: vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]],
    };
    let m = &per_vertex(&up)[0];
    assert!(m.mean > 0.0 && m.gaussian > 0.0, "{m:?}");
    let mut down = up.clone();
    down.positions[0].z = -1.0;
    let m = &per_vertex(&down)[0];
    assert!(m.mean < 0.0 && m.gaussian > 0.0, "{m:?}");
    let mut flat = up;
    flat.positions[0].z = 0.0;
    let m = &per_vertex(&flat)[0];
    assert!(m.mean.abs() < 1e-12 && m.gaussian.abs() < 1e-12 && m.bending < 1e-6);
}

/// Boundary edges, and whether every edge is manifold and consistently wound.
fn boundary_and_winding(m: &TriMesh) -> (usize, bool) {
    let r = crate::mesh::inspect(m);
    (
        r.boundary_edges,
        r.inconsistent_orientation_edges + r.non_manifold_edges == 0,
    )
}

/// Asserts that `coarse` nests in `fine` the way a continued decimation does: vertices only
/// leave (every coarse vertex is a fine one, unmoved, matched by its position's bits), and a
/// face goes only with a removed vertex (every fine face whose three corners are all still
/// there is still there, same winding). Returns how many fine faces carried over, so a caller
/// can check the second half was not vacuous.
fn assert_nested(fine: &TriMesh, coarse: &TriMesh, what: &str) -> usize {
    use std::collections::HashSet;
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let keys = |m: &TriMesh| m.positions.iter().map(|&p| key(p)).collect::<HashSet<_>>();
    let (fine_keys, coarse_keys) = (keys(fine), keys(coarse));
    // Distinct positions, so a position names one vertex.
    assert_eq!(
        fine_keys.len(),
        fine.positions.len(),
        "{what}: repeated positions"
    );
    let foreign = coarse_keys.difference(&fine_keys).count();
    assert_eq!(
        foreign, 0,
        "{what}: {foreign} coarse vertices are not fine vertices"
    );
    // A face as its corners' keys, rotated so the smallest comes first (winding kept).
    let face = |m: &TriMesh, f: &[u32; 3]| {
        let mut k = f.map(|v| key(m.positions[v as usize]));
        let first = (0..3).min_by_key(|&i| k[i]).unwrap_or(0);
        k.rotate_left(first);
        k
    };
    let coarse_faces: HashSet<_> = coarse.faces.iter().map(|f| face(coarse, f)).collect();
    let mut carried = 0;
    for f in &fine.faces {
        let k = face(fine, f);
        if k.iter().all(|c| coarse_keys.contains(c)) {
            assert!(
                coarse_faces.contains(&k),
                "{what}: fine face {f:?} lost though its corners stayed"
            );
            carried += 1;
        }
    }
    carried
}

#[test]
fn levels_nest_stay_closed_and_shrink_as_epsilon_grows() {
    let sphere = uv_sphere(30, 60, 1.0);
    let out = levels(&sphere, &PAPER_LEVELS, &CurvatureOptions::default()).unwrap();
    // Each level continues from the one before: nested in it, and in the input.
    let mut finer = &sphere;
    for l in &out {
        let carried = assert_nested(finer, &l.mesh, &format!("ε {}", l.error));
        assert!(carried > 0, "ε {}: no face carried over", l.error);
        finer = &l.mesh;
    }
    let mut last = sphere.faces.len();
    for l in &out {
        assert!(
            l.mesh.faces.len() < last,
            "ε {} kept {}",
            l.error,
            l.mesh.faces.len()
        );
        last = l.mesh.faces.len();
        assert_eq!(boundary_and_winding(&l.mesh), (0, true), "ε {}", l.error);
        // Euler characteristic of a sphere.
        assert_eq!(crate::mesh::inspect(&l.mesh).euler_characteristic, 2);
    }
}

#[test]
fn real_meshes_keep_their_order_sphere_most_fandisk_least() {
    use crate::mesh::io::{read_path, MeshLimits};
    let read = |name: &str| {
        read_path(
            &crate::fixtures::shared_data(&format!("meshes/{name}")),
            &MeshLimits::default(),
        )
        .unwrap()
    };
    let kept = |m: &TriMesh| {
        let l = levels(m, &[0.20], &CurvatureOptions::default()).unwrap();
        l[0].mesh.positions.len() as f64 / m.positions.len() as f64
    };
    let (fandisk, sphere) = (read("fandisk.obj"), read("uv-sphere-5002.obj"));
    let (f, s) = (kept(&fandisk), kept(&sphere));
    assert!(s > f, "sphere kept {s}, fandisk {f}");
    // The fandisk's corners stay: its bounding box does not shrink.
    let l = levels(&fandisk, &[0.25], &CurvatureOptions::default()).unwrap();
    let (a, b) = (fandisk.bounding_box(), l[0].mesh.bounding_box());
    assert!((a.diagonal() - b.diagonal()).abs() < 1e-9 * a.diagonal());
    assert!(boundary_and_winding(&l[0].mesh).1);
}

#[test]
fn a_face_target_is_met_and_bad_parameters_are_refused() {
    let sphere = uv_sphere(20, 40, 1.0);
    let (m, eps) = to_faces(&sphere, 300, &CurvatureOptions::default()).unwrap();
    assert!(
        m.faces.len() <= 300 && m.faces.len() >= 290,
        "{}",
        m.faces.len()
    );
    assert!(eps > 0.0);
    assert_eq!(boundary_and_winding(&m), (0, true));
    assert!(levels(&sphere, &[f64::NAN], &CurvatureOptions::default()).is_err());
    assert!(levels(&sphere, &[0.2, 0.1], &CurvatureOptions::default()).is_err());
    let mut o = CurvatureOptions::default();
    o.weights.area = 2.0;
    assert!(levels(&sphere, &[0.2], &o).is_err());
}

#[test]
fn a_crease_vertex_leaves_its_crease_behind() {
    // A roof: two planes meeting at 90° along the x axis, the ridge row in the middle.
    let (w, rows) = (7usize, 5usize);
    let mut positions = Vec::new();
    for r in 0..rows {
        let y = r as f64 - 2.0;
        for i in 0..w {
            let x = i as f64 - 3.0;
            positions.push(DVec3::new(x, y, 2.0 - y.abs()));
        }
    }
    let at = |r: usize, i: usize| (r * w + i) as u32;
    let mut faces = Vec::new();
    for r in 0..rows - 1 {
        for i in 0..w - 1 {
            faces.push([at(r, i), at(r, i + 1), at(r + 1, i + 1)]);
            faces.push([at(r, i), at(r + 1, i + 1), at(r + 1, i)]);
        }
    }
    let mesh = TriMesh { positions, faces };
    let mut vf = vec![Vec::new(); mesh.positions.len()];
    for (k, f) in mesh.faces.iter().enumerate() {
        for &v in f {
            vf[v as usize].push(k as u32);
        }
    }
    let v = at(2, 3);
    let pos = |i: u32| mesh.positions[i as usize];
    let crease = Some(Weights::default().feature_angle);
    let (_, new) = refill::refill(v, &vf, &mesh.faces, pos, 0.5, crease).unwrap();
    let (a, b) = (at(2, 2), at(2, 4));
    let has = |f: &[u32; 3]| f.contains(&a) && f.contains(&b);
    // The chord along the ridge is an edge of two new faces, one on each slope.
    assert_eq!(new.iter().filter(|f| has(f)).count(), 2, "{new:?}");
    // Every new face lies on one slope: none cuts across the ridge.
    for f in &new {
        let y = f.map(|i| pos(i).y);
        assert!(
            y.iter().all(|&y| y <= 0.0) || y.iter().all(|&y| y >= 0.0),
            "{f:?}"
        );
    }
}

#[test]
fn real_meshes_keep_the_papers_order_at_every_level() {
    // Table 1: at each ε the sphere keeps the most vertices, the fandisk the least.
    use crate::mesh::io::{read_path, MeshLimits};
    let kept = |name: &str| {
        let m = read_path(
            &crate::fixtures::shared_data(&format!("meshes/{name}")),
            &MeshLimits::default(),
        )
        .unwrap();
        levels(&m, &PAPER_LEVELS, &CurvatureOptions::default())
            .unwrap()
            .iter()
            .map(|l| l.mesh.positions.len() as f64 / m.positions.len() as f64)
            .collect::<Vec<_>>()
    };
    let (f, s, v) = (
        kept("fandisk.obj"),
        kept("uv-sphere-5002.obj"),
        kept("vase-lathe.obj"),
    );
    for (k, e) in PAPER_LEVELS.iter().enumerate() {
        assert!(
            s[k] > v[k] && v[k] > f[k],
            "ε {e}: sphere {:.3}, vase {:.3}, fandisk {:.3}",
            s[k],
            v[k],
            f[k]
        );
    }
}

#[test]
fn the_decimators_counts_and_worst_error_follow_its_mesh() {
    let sphere = uv_sphere(10, 20, 1.0);
    let mut d = Decimator::new(&sphere, Weights::default(), DEFAULT_LAMBDA_C);
    assert_eq!(
        (d.faces(), d.vertices(), d.worst_error()),
        (sphere.faces.len(), sphere.positions.len(), 0.0)
    );
    // One W per input vertex, the same all round a latitude.
    let w = d.original_curvature();
    assert_eq!(w.len(), sphere.positions.len());
    assert!(
        w[1..=20]
            .iter()
            .all(|&x| x > 0.0 && (x - w[1]).abs() < 1e-9),
        "{w:?}"
    );
    d.run_to_error(0.2);
    let m = d.mesh();
    assert!(m.faces.len() < sphere.faces.len());
    assert_eq!(
        (d.faces(), d.vertices()),
        (m.faces.len(), m.positions.len())
    );
    assert!(
        d.worst_error() > 0.0 && d.worst_error() <= 0.2,
        "{}",
        d.worst_error()
    );
}

#[test]
fn without_an_area_scale_a_flat_sheet_still_decimates() {
    // A flat 6 × 6 sheet and 2,000 unreferenced vertices: the area quantile is 0, so W has
    // no area part and removing a flat vertex costs nothing.
    let mut mesh = flat_grid(6);
    mesh.positions
        .extend((0..2000).map(|i| DVec3::new(100.0 + i as f64, 0.0, 0.0)));
    let mut d = Decimator::new(&mesh, Weights::default(), DEFAULT_LAMBDA_C);
    assert_eq!(d.vertices(), 36);
    d.run_to_error(0.01);
    assert!(d.vertices() < 20, "{} of 36 kept", d.vertices());
    assert_eq!(d.worst_error(), 0.0);
}

#[test]
fn a_removal_whose_epsilon_equals_the_bound_goes_fresh_or_remembered() {
    // The first removal alone, unbounded: its ε is e.
    let sphere = uv_sphere(10, 20, 1.0);
    let n = sphere.faces.len();
    let new = || Decimator::new(&sphere, Weights::default(), DEFAULT_LAMBDA_C);
    let mut d = new();
    d.run_to_error_until(f64::INFINITY, n - 2);
    let (e, first) = (d.worst_error(), d.mesh());
    assert_eq!(first.faces.len(), n - 2);
    assert!(e > 0.0);
    // ε ≤ bound passes: at bound e the same vertex goes first, evaluated afresh…
    let mut d = new();
    d.run_to_error_until(e, n - 2);
    assert_eq!(d.mesh(), first);
    // …or remembered from a level at bound 0 that refused everything.
    let mut d = new();
    d.run_to_error(0.0);
    assert_eq!(d.faces(), n);
    d.run_to_error_until(e, n - 2);
    assert_eq!(d.mesh(), first);
}

#[test]
fn an_unreachable_face_target_ends_at_the_last_level() {
    // No closed mesh reaches 0 faces: the levels stop at ε 64 with what could go gone.
    let sphere = uv_sphere(6, 12, 1.0);
    let (m, eps) = to_faces(&sphere, 0, &CurvatureOptions::default()).unwrap();
    assert!(
        m.faces.len() >= 4 && m.faces.len() < 20,
        "{}",
        m.faces.len()
    );
    assert!(eps > 0.0 && eps < 64.0, "{eps}");
    assert_eq!(boundary_and_winding(&m), (0, true));
}

#[test]
fn a_face_target_costs_at_most_a_step_past_the_level_that_meets_it() {
    // The levels climb 15 % at a time while faces go: a target that ε 0.2 alone meets is
    // met by ε 0.23 at most.
    let sphere = uv_sphere(20, 40, 1.0);
    let o = CurvatureOptions::default();
    assert!(to_error(&sphere, 0.2, &o).unwrap().faces.len() <= 1000);
    let (m, eps) = to_faces(&sphere, 1000, &o).unwrap();
    assert!(
        m.faces.len() <= 1000 && eps <= 0.2 * 1.15,
        "{} faces, ε {eps}",
        m.faces.len()
    );
}

#[test]
fn a_looser_bound_never_keeps_more_faces() {
    // One greedy run straight to each bound kept the vase's 5,851 vertices down to 1 face
    // at ε = 2 and 207 faces at ε = 3, and the teapot 65 faces at 2 but 72 at 2.5.
    let o = CurvatureOptions::default();
    for (name, bounds) in [
        ("vase-lathe.obj", &[1.0, 1.8, 2.0, 3.0, 4.0, 5.0][..]),
        ("teapot.obj", &[2.0, 2.5][..]),
    ] {
        let mesh = shared_mesh(name);
        let faces: Vec<usize> = bounds
            .iter()
            .map(|&e| to_error(&mesh, e, &o).unwrap().faces.len())
            .collect();
        assert!(
            faces.windows(2).all(|w| w[1] <= w[0]),
            "{name}: {bounds:?} keep {faces:?}"
        );
        // A face target was a prefix of one run already (its levels' bounds follow only
        // whether faces went, the same for every target until one stops).
        let targets = [faces[0], faces[0] / 2, faces[0] / 4];
        let kept: Vec<usize> = targets
            .iter()
            .map(|&n| to_faces(&mesh, n, &o).unwrap().0.faces.len())
            .collect();
        assert!(
            kept.windows(2).all(|w| w[1] <= w[0])
                && kept
                    .iter()
                    .zip(targets)
                    .all(|(k, t)| *k <= t || *k == kept[2]),
            "{name}: targets {targets:?} keep {kept:?}"
        );
    }
}

#[test]
fn a_level_that_removed_nothing_leaves_the_next_as_a_fresh_one_runs() {
    // Bound 0 refuses every removal and remembers each refusal; the next level must
    // decide as a fresh decimator does, parking included (the vase parks many).
    let mut ellipsoid = uv_sphere(16, 32, 1.0);
    for p in &mut ellipsoid.positions {
        p.z *= 0.5;
    }
    let vase = crate::mesh::io::read_path(
        &crate::fixtures::shared_data("meshes/vase-lathe.obj"),
        &crate::mesh::io::MeshLimits::default(),
    )
    .unwrap();
    for mesh in [ellipsoid, vase] {
        let new = || Decimator::new(&mesh, Weights::default(), DEFAULT_LAMBDA_C);
        let mut fresh = new();
        fresh.run_to_error(0.15);
        let mut d = new();
        d.run_to_error(0.0);
        assert_eq!(d.faces(), mesh.faces.len());
        d.run_to_error(0.15);
        assert!(fresh.faces() < mesh.faces.len());
        assert_eq!(d.mesh(), fresh.mesh());
    }
}

#[test]
fn a_bound_on_a_paper_level_is_that_level() {
    // From 0.15 up, a bound continues the one run the levels are cut from.
    let fandisk = shared_mesh("fandisk.obj");
    let o = CurvatureOptions::default();
    let nested = levels(&fandisk, &PAPER_LEVELS, &o).unwrap();
    for (level, e) in nested.iter().zip(PAPER_LEVELS) {
        assert_eq!(to_error(&fandisk, e, &o).unwrap(), level.mesh, "ε {e}");
    }
    // Between rungs, the rung below.
    assert_eq!(to_error(&fandisk, 0.249, &o).unwrap(), nested[1].mesh);
}

fn shared_mesh(name: &str) -> TriMesh {
    crate::mesh::io::read_path(
        &crate::fixtures::shared_data(&format!("meshes/{name}")),
        &crate::mesh::io::MeshLimits::default(),
    )
    .unwrap()
}

/// The bound a request is cut at is the rung below it: 0.26 and 0.2999 are both the third
/// level's 0.25, 10 is 1.25^10 ≈ 9.31, and below the first rung the request itself.
#[test]
fn a_bound_between_rungs_is_the_rung_below() {
    assert_eq!(super::bound_of(0.26), 0.25);
    assert_eq!(super::bound_of(0.2999), 0.25);
    assert_eq!(super::bound_of(0.3), 0.3);
    assert_eq!(super::bound_of(0.15), 0.15);
    assert_eq!(super::bound_of(0.1), 0.1);
    assert_eq!(super::bound_of(0.0), 0.0);
    assert!((super::bound_of(10.0) - 1.25_f64.powi(10)).abs() < 1e-12);
}
