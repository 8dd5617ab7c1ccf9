//! Unit checks of `simplify`'s own steps against their definitions (added after a
//! cargo-mutants run of mod.rs, which the mesh tests pass with these slips): the option
//! bounds, `unit_scale`'s powers of two (through `simplify` a wrong power still lands in or
//! re-enters the native range, where the result is the same), the error report and the
//! aggregation distance as fractions of the diagonal, and meshes with a diagonal of 0 or NaN.

use glam::DVec3;

use super::*;

/// `tests.rs`' triangular bipyramid (poles 0 and 1 at z = ±1, the equator 2, 3, 4 on the unit
/// circle), scaled. Its diagonal is √9.25 ≈ 3.04 times the scale.
fn bipyramid(scale: f64) -> TriMesh {
    let mut m = super::tests::bipyramid();
    m.positions.iter_mut().for_each(|p| *p *= scale);
    m
}

/// The plane of a triangle worked out apart: unit normal by the right-hand rule, offset, and
/// the area by Heron's formula.
fn plane_by_hand(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, f64, f64) {
    let n = (b - a).cross(c - a).normalize();
    let [x, y, z] = [(b - a).length(), (c - b).length(), (a - c).length()];
    let s = 0.5 * (x + y + z);
    (n, -n.dot(a), (s * (s - x) * (s - y) * (s - z)).sqrt())
}

/// The documented range of every option: the bounds themselves in or out as the docs say.
#[test]
fn options_are_checked_at_their_documented_bounds() {
    let base = QemOptions::to_faces(10);
    let ok = |o: QemOptions| assert_eq!(o.check(), Ok(()), "{o:?}");
    let bad = |o: QemOptions| assert!(o.check().is_err(), "{o:?}");
    let expect = |o: QemOptions, good: bool| if good { ok(o) } else { bad(o) };
    ok(base.clone());
    ok(QemOptions::to_error(0.0));
    ok(QemOptions::to_error(0.01));
    bad(QemOptions::default());
    for max_error in [-1e-9, -1.0, f64::NAN, f64::NEG_INFINITY] {
        bad(QemOptions {
            max_error,
            ..base.clone()
        });
    }
    for w in [0.0, 1e-300, 10.0, 1e300] {
        ok(QemOptions {
            boundary_weight: w,
            ..base.clone()
        });
        ok(QemOptions {
            crease_weight: w,
            ..base.clone()
        });
    }
    // Negative, infinite or not a number: refused, for either weight.
    for w in [-1e-300, -1.0, f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
        bad(QemOptions {
            boundary_weight: w,
            ..base.clone()
        });
        bad(QemOptions {
            crease_weight: w,
            ..base.clone()
        });
    }
    for (deg, good) in [
        (0.0, true),
        (180.0, true),
        (-1e-9, false),
        (180.000_001, false),
        (f64::NAN, false),
    ] {
        let o = QemOptions {
            crease_angle_deg: deg,
            ..base.clone()
        };
        expect(o, good);
    }
    for (deg, good) in [
        (1e-9, true),
        (180.0, true),
        (0.0, false),
        (-1.0, false),
        (180.000_001, false),
        (f64::NAN, false),
    ] {
        let o = QemOptions {
            max_normal_turn_deg: deg,
            ..base.clone()
        };
        expect(o, good);
    }
    for (t, good) in [
        (0.0, true),
        (1.0, true),
        (-1e-9, false),
        (1.000_001, false),
        (f64::NAN, false),
    ] {
        let o = QemOptions {
            aggregation: t,
            ..base.clone()
        };
        expect(o, good);
    }
}

/// `unit_scale`'s promise: two powers of two, each within 2^±540, whose product takes the
/// longest side to within a factor √2 of 1 (it rounds log₂ of the side), checked for boxes
/// from a few subnormal steps across to nearly the whole f64 range, at and away from the
/// origin.
#[test]
fn unit_scale_brings_the_longest_side_near_one() {
    let tiny = f64::from_bits(1); // 2⁻¹⁰⁷⁴, the smallest subnormal
    let boxes = [
        (DVec3::ZERO, DVec3::new(3.0, 1.0, 2.0)),
        (DVec3::new(-5.0, 2.0, 7.0), DVec3::new(-4.9, 2.3, 7.05)),
        (DVec3::splat(1e10), DVec3::new(1e10 + 3e4, 1e10 + 1.0, 1e10)),
        (DVec3::new(-1e300, 0.0, 0.0), DVec3::new(3e300, 1e300, 0.0)),
        (DVec3::splat(-1.5e308), DVec3::splat(1.5e308)),
        (DVec3::ZERO, DVec3::new(1e-300, 3e-301, 0.0)),
        (DVec3::splat(-1e-310), DVec3::splat(1e-310)),
        // Sides of one and two subnormal steps, whose quarters round to 0, and of three.
        (DVec3::ZERO, DVec3::new(tiny, 0.0, 0.0)),
        (DVec3::new(-tiny, 0.0, 0.0), DVec3::new(tiny, 0.0, 0.0)),
        (DVec3::ZERO, DVec3::new(0.0, 0.0, 3.0 * tiny)),
    ];
    for (min, max) in boxes {
        let b = Aabb { min, max };
        let [s1, s2] = unit_scale(&b);
        for s in [s1, s2] {
            assert!(
                s.is_normal() && s.log2().fract() == 0.0 && s.log2().abs() <= 540.0,
                "{min} {max}: {s:e}"
            );
        }
        // The longest side, scaled; where it overflows, its half (halving both ends is
        // exact there), scaled and doubled.
        let side = (max - min).max_element();
        let unit = if side.is_finite() {
            side * s1 * s2
        } else {
            (max * 0.5 - min * 0.5).max_element() * s1 * s2 * 2.0
        };
        assert!(
            (std::f64::consts::FRAC_1_SQRT_2..=std::f64::consts::SQRT_2).contains(&unit),
            "{min} {max}: side {side:e} scaled to {unit:e} by {s1:e} · {s2:e}"
        );
    }
}

/// A 13×13-vertex height field z = 0.3 sin(x) cos(0.7 y) on [0, 4]², scaled: its errors
/// grow gradually, so an error limit stops it part way.
fn wavy(scale: f64) -> TriMesh {
    super::tests::grid(13, |x, y| {
        let (x, y) = (f64::from(x) / 3.0, f64::from(y) / 3.0);
        DVec3::new(x, y, 0.3 * x.sin() * (0.7 * y).cos()) * scale
    })
}

/// Two bipyramids, pole to pole 0.15 apart (3.2 % of the diagonal of both, 4.74).
fn two_bipyramids(scale: f64) -> TriMesh {
    let one = bipyramid(scale);
    let mut m = one.clone();
    m.positions
        .extend(one.positions.iter().map(|p| *p + DVec3::Z * 2.15 * scale));
    m.faces.extend(one.faces.iter().map(|t| t.map(|i| i + 5)));
    m
}

/// Simplified at two scales inside the native range (no rescaling), a mesh gives one result
/// up to the scale, to the bit: every error is relative to the diagonal, the error limit and
/// the aggregation distance included. The diagonals here are 4.7 and 5.7, so at 2⁻¹⁰ and 2¹⁰
/// `fraction · diagonal` and `fraction / diagonal` differ by a factor of ~10⁷.
#[test]
fn native_scales_give_the_same_mesh_to_the_bit() {
    type Case = (fn(f64) -> TriMesh, QemOptions);
    let cases: [Case; 4] = [
        (wavy, QemOptions::to_error(0.002)),
        (wavy, QemOptions::to_error(0.02)),
        (
            wavy,
            QemOptions {
                max_error: 0.005,
                ..QemOptions::to_faces(100)
            },
        ),
        (
            two_bipyramids,
            QemOptions {
                aggregation: 0.04,
                ..QemOptions::to_faces(2)
            },
        ),
    ];
    for (mesh, o) in &cases {
        let (small, rs) = simplify(&mesh(2f64.powi(-10)), o).expect("runs");
        let (large, rl) = simplify(&mesh(2f64.powi(10)), o).expect("runs");
        assert!(rs.collapses > 0, "{o:?}: {rs:?}");
        assert_eq!(rs, rl, "{o:?}");
        assert_eq!(small.faces, large.faces, "{o:?}");
        let back: Vec<DVec3> = large
            .positions
            .iter()
            .map(|p| *p * 2f64.powi(-20))
            .collect();
        assert_eq!(small.positions, back, "{o:?}");
    }
}

/// The reported error is the ranked error of the worst collapse taken, √(Q(v̄)/w + tie break)
/// over the diagonal: one pole edge of the bipyramid, whose cost is worked out here from its
/// faces' planes, at scales in and out of the native range.
#[test]
fn reports_the_collapse_error_as_a_fraction_of_the_diagonal() {
    // Crease weight 0 below: every edge here is sharper than 45°, and without their planes
    // the quadrics are the faces' alone.
    let unit = bipyramid(1.0);
    // Pole edge (0, 2): vertex 0's three faces and vertex 2's four, the two they share twice.
    let corner_quadric = |v: u32| {
        unit.faces
            .iter()
            .filter(|t| t.contains(&v))
            .map(|t| {
                let [a, b, c] = t.map(|i| unit.positions[i as usize]);
                let (n, d, area) = plane_by_hand(a, b, c);
                Quadric::from_plane(n, d, area)
            })
            .fold(Quadric::default(), |s, q| s + q)
    };
    let (p, q) = (unit.positions[0], unit.positions[2]);
    let sum = corner_quadric(0) + corner_quadric(2);
    let (_, e) = sum.minimize(p, q);
    let ranked = e / sum.w + 1e-8 * (q - p).length_squared();
    let want = ranked.sqrt() / unit.diagonal();
    assert!(want > 0.01, "{want}");
    for scale in [1.0, 2f64.powi(-10), 1e-3, 2f64.powi(10), 1e3, 1e12, 1e-12] {
        let m = bipyramid(scale);
        let options = QemOptions {
            crease_weight: 0.0,
            ..QemOptions::to_faces(4)
        };
        // Every pole edge costs the same (symmetry); one goes.
        let (out, report) = simplify(&m, &options).expect("runs");
        assert_eq!((out.face_count(), report.collapses), (4, 1), "{report:?}");
        // The key keeps 14 mantissa bits of the squared error: 6 · 10⁻⁵ of it.
        assert!(
            (report.max_error - want).abs() < 1e-4 * want,
            "{scale:e}: {} against {want}",
            report.max_error
        );
    }
}

/// Two flat squares side by side, `gap` apart along x: their facing corners are the closest
/// vertices of different parts.
fn two_squares(gap: f64) -> TriMesh {
    let square = |x0: f64| {
        [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(x, y)| DVec3::new(x0 + x, y, 0.0))
    };
    let mut positions = square(0.0).to_vec();
    positions.extend(square(1.0 + gap));
    TriMesh::new(positions, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
}

/// Aggregation pairs vertices of different parts closer than t = `aggregation` · diagonal.
#[test]
fn aggregation_distance_is_a_fraction_of_the_diagonal() {
    for scale in [1.0, 1e-3, 1e3, 1e12] {
        let m = two_squares(0.5);
        let m = TriMesh::new(
            m.positions.iter().map(|p| *p * scale).collect(),
            m.faces.clone(),
        );
        // The gap as a fraction of the diagonal (2.5 × 1).
        let gap = 0.5 / 7.25f64.sqrt();
        for (factor, joins) in [(0.9, false), (1.1, true)] {
            let options = QemOptions {
                aggregation: gap * factor,
                ..QemOptions::to_faces(1)
            };
            let (_, report) = simplify(&m, &options).expect("runs");
            assert_eq!(
                report.aggregations > 0,
                joins,
                "{scale:e} at {factor} × the gap: {report:?}"
            );
        }
    }
}

/// A mesh with no extent has a diagonal of 0: it is simplified as it is (nothing to scale),
/// every error is 0, and the reported error is 0, not 0 / 0.
#[test]
fn a_mesh_without_extent_simplifies_with_no_error() {
    let p = DVec3::new(1.0, -2.0, 3.0);
    let grid = |at: DVec3| super::tests::grid(3, |_, _| at);
    for (what, m) in [
        ("at the origin", grid(DVec3::ZERO)),
        ("away from it", grid(p)),
        ("no faces", TriMesh::new(vec![p; 3], Vec::new())),
    ] {
        assert_eq!(m.diagonal(), 0.0, "{what}");
        for o in [QemOptions::to_faces(4), QemOptions::to_error(0.01)] {
            let (out, report) = simplify(&m, &o).expect(what);
            assert_eq!(report.max_error, 0.0, "{what}: {report:?}");
            assert!(out.positions.iter().all(|q| *q == m.positions[0]), "{what}");
            assert!(out.face_count() <= m.face_count(), "{what}");
        }
    }
}

/// A mesh whose span overflows f64 (ends of opposite signs near f64::MAX) has a NaN
/// diagonal, and is scaled to simplify like any other outside the native range: its result is
/// the unit mesh's, to the bit, as at every other power-of-two scale.
#[test]
fn a_mesh_wider_than_f64_max_gives_the_same_mesh_to_the_bit() {
    for options in [QemOptions::to_faces(4), QemOptions::to_error(0.2)] {
        let (unit, r1) = simplify(&bipyramid(1.0), &options).expect("runs");
        for e in [1022, 1023] {
            let m = bipyramid(2f64.powi(e));
            // 2¹⁰²³ is the poles' height: the span 2¹⁰²⁴ overflows.
            assert_eq!(m.diagonal().is_nan(), e == 1023);
            let (out, r) = simplify(&m, &options).expect("runs");
            assert_eq!(r, r1, "2^{e} {options:?}");
            assert_eq!(out.faces, unit.faces, "2^{e} {options:?}");
            let back: Vec<DVec3> = out.positions.iter().map(|p| *p * 2f64.powi(-e)).collect();
            assert_eq!(back, unit.positions, "2^{e} {options:?}");
        }
    }
}
