//! The view plane of paper eq. 4: the footprint of a camera's view frustum on the terrain
//! plane, and its area A_v against the terrain plane's area A_t.
//!
//! Model (documented in docs/api.md): the terrain plane is the horizontal plane through the
//! target. A symmetric frustum (vertical field of view `fov`, width/height `aspect`, no roll:
//! the camera's right vector stays horizontal) is cut with that plane and the cut is clipped
//! to the disk of radius `far` around the eye's foot (a regular [`DISK_SIDES`]-gon), which
//! bounds the part of the view past the horizon. The footprint is that convex polygon and
//! A_v its area. A wider or taller frustum holds the narrower one, so its footprint holds the
//! narrower one's: A_v never falls as `fov` or `aspect` grow. All lengths are in one
//! horizontal unit (the caller converts degrees or grid samples to metres first).

use glam::{DVec2, DVec3};

/// Why a camera cannot give a view plane.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ViewError {
    #[error("eye and target must be apart (they coincide, or lie too close for a direction between them)")]
    Degenerate,
    #[error("the eye must be above the target (eye z > target z) to see the terrain plane")]
    BelowPlane,
}

/// A pinhole camera looking from `eye` at `target`, z up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub target: DVec3,
    /// Vertical field of view, degrees, in (0, 180).
    pub fov_deg: f64,
    /// Width over height of the image, > 0.
    pub aspect: f64,
}

/// Sides of the polygon standing in for the disk of radius `far`: its area is within 0.2 %
/// of the disk's.
pub const DISK_SIDES: usize = 64;

/// The frustum's footprint on the plane z = target.z, clipped to `far` around the eye's foot:
/// a convex polygon, counter-clockwise seen from above; the target alone when the footprint
/// is too small for f64 to place (below).
///
/// Each side plane of the frustum passes through the eye, so on the terrain plane it is a
/// half-plane; the footprint is the disk cut by the four. (Stopping each corner ray at `far`
/// instead, as this did before, collapsed a wide view to a thin strip: with a large aspect
/// all four rays head nearly sideways.)
pub fn footprint(cam: &Camera, far: f64) -> Result<Vec<DVec2>, ViewError> {
    // Camera frame: forward, a horizontal right, and up completing it.
    let forward = (cam.target - cam.eye)
        .try_normalize()
        .ok_or(ViewError::Degenerate)?;
    let height = cam.eye.z - cam.target.z;
    if height <= 0.0 {
        return Err(ViewError::BelowPlane);
    }
    let right = forward.cross(DVec3::Z).try_normalize().unwrap_or(DVec3::X);
    let up = right.cross(forward);

    let th = (cam.fov_deg.to_radians() / 2.0).tan();
    let tw = th * cam.aspect;
    let foot = cam.eye.truncate();
    let disk: Vec<DVec2> = (0..DISK_SIDES)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / DISK_SIDES as f64;
            foot + DVec2::new(a.cos(), a.sin()) * far
        })
        .collect();
    let mut polygon = disk.clone();
    // The four side planes through the eye, by their normals pointing into the frustum: the
    // ray forward + right·x + up·y is inside when |x| ≤ tw and |y| ≤ th. Written from the
    // frame, not as the cross product of two corner rays: at a small fov those rays are
    // nearly parallel, their cross product was rounding noise, and nothing was clipped (fov
    // 1e-13° saw the whole disk, 1e-11° almost nothing).
    let sides = [
        forward * tw - right,
        forward * th - up,
        forward * tw + right,
        forward * th + up,
    ];
    for n in sides {
        // On the terrain plane (z = -height relative to the eye) the side keeps the points
        // p with n.xy · (p - foot) ≥ n.z · height.
        let keep = |p: DVec2| n.truncate().dot(p - foot) - n.z * height;
        polygon = clip(&polygon, keep);
    }
    // The frustum's axis meets the plane at the target, so the footprint holds it wherever
    // the disk does. The clip's vertices lie out on the disk, placed to ~1e-16 of `far`: a
    // footprint thinner than that (fov 1e-20° on a tilted camera, 1e-18 m wide at 20 km)
    // could come out empty, which read as a view of nothing. The target stands for it.
    let target = cam.target.truncate();
    if polygon.is_empty() && holds(&disk, target) {
        polygon.push(target);
    }
    Ok(polygon)
}

/// Whether convex, counter-clockwise `polygon` holds `p`, edges included.
fn holds(polygon: &[DVec2], p: DVec2) -> bool {
    let after = polygon.iter().skip(1).chain(polygon.first());
    polygon
        .iter()
        .zip(after)
        .all(|(&a, &b)| (b - a).perp_dot(p - a) >= 0.0)
}

/// The part of a convex longitude/latitude polygon (degrees) on the globe: within ±90° of
/// latitude, and one turn of longitude round `lon0` (±180° of it). Longitudes stay as they
/// are round `lon0`, so a polygon across the antimeridian goes past ±180° rather than
/// jumping round the world.
pub fn clip_to_globe(polygon: &[DVec2], lon0: f64) -> Vec<DVec2> {
    let mut p = clip(polygon, |q| 180.0 + (q.x - lon0));
    p = clip(&p, |q| 180.0 - (q.x - lon0));
    p = clip(&p, |q| 90.0 + q.y);
    clip(&p, |q| 90.0 - q.y)
}

/// Sutherland–Hodgman: the part of convex `polygon` where `side` ≥ 0 (`side` linear).
fn clip(polygon: &[DVec2], side: impl Fn(DVec2) -> f64) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(polygon.len() + 1);
    let after = polygon.iter().skip(1).chain(polygon.first());
    for (&a, &b) in polygon.iter().zip(after) {
        let (sa, sb) = (side(a), side(b));
        if sa >= 0.0 {
            out.push(a);
        }
        if (sa >= 0.0) != (sb >= 0.0) {
            out.push(a + (b - a) * (sa / (sa - sb)));
        }
    }
    out
}

/// Area of a simple polygon (shoelace formula), ≥ 0.
pub fn polygon_area(points: &[DVec2]) -> f64 {
    // Each vertex with the next (the first after the last).
    let after = points.iter().skip(1).chain(points.first());
    let twice: f64 = points.iter().zip(after).map(|(a, b)| a.perp_dot(*b)).sum();
    twice.abs() / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_does_not_depend_on_the_winding() {
        let ccw = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)].map(DVec2::from);
        let mut cw = ccw;
        cw.reverse();
        assert_eq!(polygon_area(&ccw), 2.0);
        assert_eq!(polygon_area(&cw), 2.0);
    }

    fn down_from(h: f64) -> Camera {
        Camera {
            eye: DVec3::new(0.0, 0.0, h),
            target: DVec3::new(0.0, 1e-9, 0.0),
            fov_deg: 90.0,
            aspect: 1.0,
        }
    }

    #[test]
    fn looking_straight_down_sees_a_square_of_side_twice_the_height() {
        // tan(45°) = 1: the half-width on the ground equals the height.
        let f = footprint(&down_from(100.0), 1e9).unwrap();
        let a = polygon_area(&f);
        assert!((a - 200.0 * 200.0).abs() < 1e-3, "{a}");
    }

    #[test]
    fn a_higher_camera_sees_more() {
        let low = polygon_area(&footprint(&down_from(100.0), 1e9).unwrap());
        let high = polygon_area(&footprint(&down_from(400.0), 1e9).unwrap());
        assert!(high > 15.0 * low);
    }

    #[test]
    fn rays_above_the_horizon_stop_at_far() {
        let cam = Camera {
            eye: DVec3::new(0.0, 0.0, 10.0),
            target: DVec3::new(100.0, 0.0, 0.0),
            fov_deg: 60.0,
            aspect: 1.5,
        };
        let f = footprint(&cam, 1000.0).unwrap();
        assert!(f.iter().all(|p| p.length() <= 1000.0 + 1e-9));
        assert!(polygon_area(&f) > 0.0);
    }

    #[test]
    fn a_wider_view_never_sees_less() {
        // An oblique camera (the audit's: a large aspect used to collapse the footprint to a
        // strip, A_v 3.8 M → 11 k).
        let area = |fov_deg: f64, aspect: f64| {
            let cam = Camera {
                eye: DVec3::new(600.0, -900.0, 2000.0),
                target: DVec3::new(600.0, -600.0, 300.0),
                fov_deg,
                aspect,
            };
            polygon_area(&footprint(&cam, 5000.0).unwrap())
        };
        // Coordinates of ~10³ m put the shoelace sum's rounding near 10⁻¹⁰ m²: a speck's area
        // is that noise, so the order is checked past it.
        const NOISE: f64 = 1e-9;
        let mut last = 0.0;
        for fov in [
            1e-300, 1e-15, 1e-13, 1e-11, 1e-8, 1e-6, 0.01, 1.0, 10.0, 30.0, 60.0, 90.0, 120.0,
            150.0, 179.0,
        ] {
            let mut row = 0.0;
            for aspect in [0.001, 0.1, 1.0, 2.0, 10.0, 1000.0] {
                let a = area(fov, aspect);
                assert!(a >= row - NOISE, "fov {fov} aspect {aspect}: {a} < {row}");
                row = a;
            }
            let a = area(fov, 1.0);
            assert!(a >= last - NOISE, "fov {fov}: {a} < {last}");
            last = a;
        }
        // Past the horizon the view is the disk's: the widest view sees all of it.
        let disk = std::f64::consts::PI * 5000.0 * 5000.0;
        assert!(area(179.0, 1000.0) > 0.49 * disk, "{}", area(179.0, 1000.0));
        // A telescope sees a speck (fov 1e-13° saw the whole disk when the side planes were
        // cross products of nearly parallel corner rays).
        assert!(area(1e-13, 1.0) < 1e-6, "{}", area(1e-13, 1.0));
    }

    #[test]
    fn a_narrow_view_near_the_horizon_shrinks_with_its_fov() {
        // Nearly level, the case where the corner rays' cross products flipped the order.
        let area = |fov_deg: f64| {
            let cam = Camera {
                eye: DVec3::new(0.0, 0.0, 10.0),
                target: DVec3::new(1000.0, 0.0, 0.0),
                fov_deg,
                aspect: 1.0,
            };
            polygon_area(&footprint(&cam, 5000.0).unwrap())
        };
        let fovs = [1e-300, 1e-12, 1e-10, 1e-8, 1e-4, 0.1, 1.0, 5.0];
        for w in fovs.windows(2) {
            assert!(
                area(w[0]) <= area(w[1]),
                "fov {w:?}: {} > {}",
                area(w[0]),
                area(w[1])
            );
        }
        assert!(area(1e-10) < 1e-6, "{}", area(1e-10));
    }

    /// A tilted telescope sees a speck at the target, however narrow: the clip rounded such a
    /// footprint away (fov 1e-20° came out empty, so `/view` said it saw no terrain, while
    /// 1e-15° gave a speck). A target past the disk is still not seen.
    #[test]
    fn a_footprint_too_thin_to_place_is_the_target() {
        // The QA's camera over N44W072 (0.2° south of the target, 2,700 m above it), in the
        // plane's metres, the disk the dataset's diagonal; and eyes beside it.
        let south = (44.3 - 44.5) * 111_319.490_793_273_57;
        let far = (2.0 * 8_838_620_271.917_036_f64).sqrt();
        for fov_deg in [1e-20, 1e-300] {
            for east in [0.0, 3_967.5, -1_234.5, 20_000.0] {
                let cam = Camera {
                    eye: DVec3::new(east, south, 3000.0),
                    target: DVec3::new(0.0, 0.0, 300.0),
                    fov_deg,
                    aspect: 1.0,
                };
                let f = footprint(&cam, far).unwrap();
                assert!(!f.is_empty(), "fov {fov_deg} eye east {east}");
                assert!(
                    f.iter().all(|p| p.length() < 1e-9),
                    "fov {fov_deg} eye east {east}: {f:?}"
                );
            }
        }
        let beyond = Camera {
            eye: DVec3::new(0.0, south, 3000.0),
            target: DVec3::new(0.0, 0.0, 300.0),
            fov_deg: 1e-20,
            aspect: 1.0,
        };
        assert_eq!(footprint(&beyond, 10_000.0), Ok(vec![]));
    }

    #[test]
    fn the_footprint_holds_the_target() {
        let cam = Camera {
            eye: DVec3::new(10.0, 20.0, 300.0),
            target: DVec3::new(200.0, -50.0, 0.0),
            fov_deg: 40.0,
            aspect: 1.6,
        };
        let f = footprint(&cam, 1e4).unwrap();
        let t = DVec2::new(200.0, -50.0);
        // Convex and counter-clockwise: the target is left of every edge.
        let after = f.iter().skip(1).chain(f.first());
        assert!(f
            .iter()
            .zip(after)
            .all(|(&a, &b)| (b - a).perp_dot(t - a) > 0.0));
    }

    #[test]
    fn an_eye_below_the_plane_is_refused() {
        let cam = Camera {
            eye: DVec3::new(0.0, 0.0, -1.0),
            target: DVec3::ZERO,
            fov_deg: 60.0,
            aspect: 1.0,
        };
        assert_eq!(footprint(&cam, 10.0), Err(ViewError::BelowPlane));
    }

    #[test]
    fn a_footprint_past_a_pole_stops_at_the_globes_edges() {
        let square = [
            DVec2::new(-600.0, 80.0),
            DVec2::new(600.0, 80.0),
            DVec2::new(600.0, 100.0),
            DVec2::new(-600.0, 100.0),
        ];
        let on = clip_to_globe(&square, 0.0);
        assert!(
            on.iter().all(|p| p.x.abs() <= 180.0 && p.y.abs() <= 90.0),
            "{on:?}"
        );
        assert!((polygon_area(&on) - 360.0 * 10.0).abs() < 1e-9, "{on:?}");
        // Round a target by the antimeridian, the turn kept is the one round it.
        let on = clip_to_globe(&square, 170.0);
        assert!(
            on.iter()
                .all(|p| (-10.0..=350.0).contains(&p.x) && p.y <= 90.0),
            "{on:?}"
        );
        assert!((polygon_area(&on) - 360.0 * 10.0).abs() < 1e-9, "{on:?}");
        // A footprint already on the globe is kept as it is.
        let small = [
            DVec2::new(10.0, 10.0),
            DVec2::new(11.0, 10.0),
            DVec2::new(11.0, 11.0),
        ];
        assert_eq!(clip_to_globe(&small, 10.0), small.to_vec());
    }
}
