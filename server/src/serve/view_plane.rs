//! The view plane of paper eq. 4: the footprint of a camera's view frustum on the terrain
//! plane, and its area A_v against the terrain plane's area A_t.
//!
//! Model (documented in docs/api.md): the terrain plane is the horizontal plane through the
//! target point. The four corner rays of a symmetric frustum (vertical field of view `fov`,
//! width/height `aspect`, no roll: the camera's right vector stays horizontal) are cut with
//! that plane; a ray that never meets it, or meets it farther than `far` from the eye's
//! foot, is stopped at horizontal distance `far` along its own heading. A_v is the area of
//! the quadrilateral through the four points. All lengths are in one horizontal unit (the
//! caller converts degrees or grid samples to metres first).

use glam::{DVec2, DVec3};

/// Why a camera cannot give a view plane.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ViewError {
    #[error("eye and target must differ")]
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

/// The frustum's footprint on the plane z = target.z, as four points (counter-clockwise
/// seen from above), each no farther than `far` from the eye's foot.
pub fn footprint(cam: &Camera, far: f64) -> Result<[DVec2; 4], ViewError> {
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

    // Corner rays, cut with the plane or stopped at `far`.
    let th = (cam.fov_deg.to_radians() / 2.0).tan();
    let tw = th * cam.aspect;
    let foot = cam.eye.truncate();
    let corner = |sx: f64, sy: f64| {
        let d = forward + right * (sx * tw) + up * (sy * th);
        let heading = d.truncate();
        let along = if d.z < 0.0 {
            heading.length() * height / -d.z
        } else {
            f64::INFINITY
        };
        let dir = heading.try_normalize().unwrap_or(DVec2::ZERO);
        foot + dir * along.min(far)
    };
    Ok([
        corner(-1.0, -1.0),
        corner(1.0, -1.0),
        corner(1.0, 1.0),
        corner(-1.0, 1.0),
    ])
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
    fn an_eye_below_the_plane_is_refused() {
        let cam = Camera {
            eye: DVec3::new(0.0, 0.0, -1.0),
            target: DVec3::ZERO,
            fov_deg: 60.0,
            aspect: 1.0,
        };
        assert_eq!(footprint(&cam, 10.0), Err(ViewError::BelowPlane));
    }
}
