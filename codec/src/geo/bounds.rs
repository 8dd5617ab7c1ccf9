//! Bounding volumes of a tile's ECEF points: a bounding sphere, and the horizon occlusion
//! point that lets a client cull a tile hidden behind the Earth.
//!
//! References:
//! - J. Ritter, "An Efficient Bounding Sphere", Graphics Gems (1990), pp. 301–303: a sphere
//!   from the most distant pair of axis-extreme points, grown in one more pass.
//!   CesiumJS `BoundingSphere.fromPoints` runs Ritter beside the "naive" sphere (box centre,
//!   farthest point) and keeps the smaller; we do the same.
//! - K. Ring, "Computing the horizon occlusion point", Cesium blog (2013-05-09), and CesiumJS
//!   `EllipsoidalOccluder.computeHorizonCullingPoint`: in ellipsoid-scaled space (the
//!   ellipsoid is the unit sphere), the point on the ray along a chosen direction that is
//!   hidden by the horizon only when every given point is. Each point at distance m from the
//!   centre, at angle α from the direction, needs the occlusion point at magnitude
//!   1 / cos(α + β) with cos β = 1/m; the answer is the largest of these.
//!
//! ```
//! use glam::DVec3;
//! use zerotile_codec::geo::{horizon_occlusion_point, BoundingSphere, Ellipsoid};
//!
//! let e = Ellipsoid::WGS84;
//! let points: Vec<DVec3> = [(10.0, 45.0), (10.1, 45.0), (10.0, 45.1), (10.1, 45.1)]
//!     .iter()
//!     .map(|&(lon, lat)| e.to_ecef(lon, lat, 500.0))
//!     .collect();
//! let sphere = BoundingSphere::from_points(&points).unwrap();
//! assert!(points.iter().all(|p| p.distance(sphere.center) <= sphere.radius + 1e-6));
//! let hop = horizon_occlusion_point(&e, sphere.center, &points).unwrap();
//! assert!(hop.length() > 1.0); // scaled space: just above the unit sphere
//! ```

use glam::DVec3;

use super::Ellipsoid;

/// A sphere enclosing a set of points, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingSphere {
    pub center: DVec3,
    pub radius: f64,
}

impl BoundingSphere {
    /// The smaller of Ritter's sphere and the box-centred sphere around `points`; `None` when
    /// there are no points or a coordinate is not finite.
    pub fn from_points(points: &[DVec3]) -> Option<Self> {
        if points.is_empty() || !points.iter().all(|p| p.is_finite()) {
            return None;
        }

        // Extreme points per axis: their most distant pair seeds Ritter's sphere.
        let mut lo = [points[0]; 3];
        let mut hi = [points[0]; 3];
        for &p in points {
            for axis in 0..3 {
                if p[axis] < lo[axis][axis] {
                    lo[axis] = p;
                }
                if p[axis] > hi[axis][axis] {
                    hi[axis] = p;
                }
            }
        }
        let seed = (0..3)
            .max_by(|&i, &j| {
                lo[i]
                    .distance_squared(hi[i])
                    .total_cmp(&lo[j].distance_squared(hi[j]))
            })
            .unwrap_or(0);
        let mut ritter = Self {
            center: (lo[seed] + hi[seed]) * 0.5,
            radius: lo[seed].distance(hi[seed]) * 0.5,
        };

        // Grow: a point outside moves the centre towards it just enough to take it in.
        for &p in points {
            let d = p.distance(ritter.center);
            if d > ritter.radius {
                let radius = (ritter.radius + d) * 0.5;
                ritter.center = p + (ritter.center - p) * (radius / d);
                ritter.radius = radius;
            }
        }
        // Rounding in the growth step can leave a point a hair outside: close the gap.
        ritter.radius = points
            .iter()
            .map(|p| p.distance(ritter.center))
            .fold(ritter.radius, f64::max);

        // The naive sphere wins for some point sets (box-like clouds).
        let (min, max) = points.iter().fold((points[0], points[0]), |(mn, mx), &p| {
            (mn.min(p), mx.max(p))
        });
        let center = (min + max) * 0.5;
        let naive = Self {
            center,
            radius: points
                .iter()
                .map(|p| p.distance(center))
                .fold(0.0, f64::max),
        };
        Some(if naive.radius < ritter.radius {
            naive
        } else {
            ritter
        })
    }

    /// Whether `p` lies within the sphere, allowing `tolerance` metres.
    pub fn contains(&self, p: DVec3, tolerance: f64) -> bool {
        p.distance(self.center) <= self.radius + tolerance
    }
}

/// Cesium's horizon occlusion point for `points` (ECEF metres) along `direction` (ECEF, any
/// length; Cesium uses the bounding sphere's centre), in ellipsoid-scaled space: if this
/// point is below the horizon, so is every point. Points below the ellipsoid count as on it.
///
/// `None` where Cesium's construction has no answer: no points, a zero direction, or a point
/// 90° or more from the direction (a tile spanning a hemisphere, such as a level-0 geodetic
/// tile), where no finite point works.
pub fn horizon_occlusion_point(
    ellipsoid: &Ellipsoid,
    direction: DVec3,
    points: &[DVec3],
) -> Option<DVec3> {
    // Work in scaled space, where the horizon of the unit sphere is simple.
    let d = ellipsoid.to_scaled_space(direction).try_normalize()?;

    // Each point asks for magnitude 1 / cos(α + β); keep the largest.
    let mut magnitude: f64 = 0.0;
    for &p in points {
        let s = ellipsoid.to_scaled_space(p);
        let m = s.length().max(1.0);
        let dir = s.try_normalize()?;
        let cos_alpha = dir.dot(d);
        let sin_alpha = dir.cross(d).length();
        let cos_beta = 1.0 / m;
        let sin_beta = (m * m - 1.0).sqrt() * cos_beta;
        let candidate = 1.0 / (cos_alpha * cos_beta - sin_alpha * sin_beta);
        if candidate.is_nan() || candidate <= 0.0 {
            // α + β ≥ 90°: this point is never hidden while the ray's points are.
            return None;
        }
        magnitude = magnitude.max(candidate);
    }

    // An empty set, or an overflow to infinity, has no occlusion point.
    (magnitude > 0.0 && magnitude.is_finite()).then(|| d * magnitude)
}

/// Whether a camera at `camera` (ECEF metres) sees the scaled-space point `occludee` over
/// the ellipsoid's horizon: Cesium's `EllipsoidalOccluder.isScaledSpacePointVisible`, here
/// to test the occlusion point against its definition.
pub fn is_scaled_point_visible(ellipsoid: &Ellipsoid, camera: DVec3, occludee: DVec3) -> bool {
    let cv = ellipsoid.to_scaled_space(camera);
    let vh2 = cv.length_squared() - 1.0;
    let vt = occludee - cv;
    let vt_dot_vc = -vt.dot(cv);
    // Below the surface the culling plane passes through the camera.
    let occluded = if vh2 < 0.0 {
        vt_dot_vc > 0.0
    } else {
        vt_dot_vc > vh2 && vt_dot_vc * vt_dot_vc / vt.length_squared() > vh2
    };
    !occluded
}

#[cfg(test)]
mod tests {
    use super::*;

    const E: Ellipsoid = Ellipsoid::WGS84;

    fn patch(lon0: f64, lat0: f64, span: f64, h: f64) -> Vec<DVec3> {
        let mut pts = Vec::new();
        for i in 0..=8 {
            for j in 0..=8 {
                let lon = lon0 + span * f64::from(i) / 8.0;
                let lat = lat0 + span * f64::from(j) / 8.0;
                pts.push(E.to_ecef(lon, lat, h * f64::from((i * j) % 3)));
            }
        }
        pts
    }

    #[test]
    fn sphere_contains_every_point_and_is_tight() {
        let pts = patch(5.0, 40.0, 1.0, 1000.0);
        let s = BoundingSphere::from_points(&pts).unwrap();
        assert!(pts.iter().all(|&p| s.contains(p, 1e-6)));
        // The patch's diagonal is ~134 km; a tight sphere's radius is about half of it.
        let diag = pts[0].distance(pts[pts.len() - 1]);
        assert!(
            s.radius < 0.6 * diag,
            "radius {} for diagonal {diag}",
            s.radius
        );
    }

    #[test]
    fn sphere_of_one_point_and_of_nothing() {
        let p = DVec3::new(1.0, 2.0, 3.0);
        assert_eq!(
            BoundingSphere::from_points(&[p]),
            Some(BoundingSphere {
                center: p,
                radius: 0.0
            })
        );
        assert_eq!(BoundingSphere::from_points(&[]), None);
        assert_eq!(BoundingSphere::from_points(&[DVec3::NAN]), None);
    }

    #[test]
    fn occlusion_point_is_hidden_only_when_every_point_is() {
        let pts = patch(10.0, 45.0, 2.0, 3000.0);
        let s = BoundingSphere::from_points(&pts).unwrap();
        let hop = horizon_occlusion_point(&E, s.center, &pts).unwrap();
        // Cameras all round the globe, low and high: whenever the point is hidden, every
        // vertex must be hidden too (conservative), and the point hides for some cameras.
        let mut hidden = 0;
        for lon in (-180..180).step_by(15) {
            for lat in (-80..=80).step_by(20) {
                for h in [100.0, 10_000.0, 1e6, 2e7] {
                    let cam = E.to_ecef(f64::from(lon), f64::from(lat), h);
                    if !is_scaled_point_visible(&E, cam, hop) {
                        hidden += 1;
                        for &p in &pts {
                            let ps = E.to_scaled_space(p);
                            assert!(
                                !is_scaled_point_visible(&E, cam, ps),
                                "camera at ({lon}, {lat}, {h}) sees a vertex of a culled tile"
                            );
                        }
                    }
                }
            }
        }
        assert!(
            hidden > 100,
            "the point is hidden from only {hidden} cameras"
        );
    }

    #[test]
    fn hemisphere_tiles_have_no_occlusion_point() {
        // A level-0 geodetic tile (lon −180..0): its edge points are 90° from the centre.
        let pts: Vec<DVec3> = [(-180.0, 0.0), (-90.0, 0.0), (0.0, 0.0), (-90.0, 89.0)]
            .iter()
            .map(|&(lon, lat)| E.to_ecef(lon, lat, 10.0))
            .collect();
        assert_eq!(
            horizon_occlusion_point(&E, E.to_ecef(-90.0, 0.0, 0.0), &pts),
            None
        );
        assert_eq!(horizon_occlusion_point(&E, DVec3::ZERO, &pts), None);
        assert_eq!(horizon_occlusion_point(&E, DVec3::X, &[]), None);
    }

    #[test]
    fn points_on_the_surface_along_the_direction_give_magnitude_one() {
        let p = E.to_ecef(30.0, 20.0, 0.0);
        let hop = horizon_occlusion_point(&E, p, &[p]).unwrap();
        assert!((hop.length() - 1.0).abs() < 1e-12);
        assert!((hop - E.to_scaled_space(p)).length() < 1e-12);
    }
}
