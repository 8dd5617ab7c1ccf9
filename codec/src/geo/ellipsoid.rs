//! The WGS84 ellipsoid: geodetic (longitude, latitude, height) ↔ Earth-centred Earth-fixed
//! (ECEF) coordinates, surface normals and Cesium's ellipsoid-scaled space.
//!
//! References:
//! - NIMA TR8350.2, "Department of Defense World Geodetic System 1984", 3rd ed. (2000), §3:
//!   a = 6 378 137 m, 1/f = 298.257 223 563; geodetic → ECEF, eq. 4-14.
//! - B. R. Bowring, "Transformation from spatial to geographical coordinates", Survey Review
//!   23(181), 1976: the ECEF → geodetic latitude iteration on the parametric latitude β.
//! - CesiumJS `Ellipsoid.transformPositionToScaledSpace`: scaled space divides each axis by
//!   its radius, so the ellipsoid becomes the unit sphere (used by horizon culling).
//!
//! Angles in the public API are degrees, heights and coordinates metres. ECEF axes: x through
//! (lon 0°, lat 0°), y through (lon 90°E, lat 0°), z through the north pole.
//!
//! ```
//! use zerotile_codec::geo::Ellipsoid;
//!
//! let p = Ellipsoid::WGS84.to_ecef(0.0, 0.0, 0.0);
//! assert_eq!(p.to_array(), [6_378_137.0, 0.0, 0.0]);
//! let [lon, lat, h] = Ellipsoid::WGS84.to_geodetic(p);
//! assert!(lon.abs() < 1e-12 && lat.abs() < 1e-12 && h.abs() < 1e-6);
//! ```

use glam::DVec3;

/// Bowring iterations in [`Ellipsoid::to_geodetic`]. One already gives ~0.1 mm for points
/// within 10 km of the surface; three reach the f64 floor for any terrestrial height.
const BOWRING_ITERATIONS: usize = 3;

/// An ellipsoid of revolution about the z axis, radii in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipsoid {
    /// Equatorial (semi-major) radius, metres.
    pub a: f64,
    /// Polar (semi-minor) radius, metres.
    pub b: f64,
}

impl Ellipsoid {
    /// WGS84: a = 6 378 137 m, f = 1 / 298.257 223 563 (TR8350.2 table 3.1).
    pub const WGS84: Self = Self {
        a: 6_378_137.0,
        b: 6_378_137.0 * (1.0 - 1.0 / 298.257_223_563),
    };

    /// First eccentricity squared, e² = (a² − b²) / a².
    pub fn e2(&self) -> f64 {
        (self.a * self.a - self.b * self.b) / (self.a * self.a)
    }

    /// Second eccentricity squared, e'² = (a² − b²) / b².
    pub fn ep2(&self) -> f64 {
        (self.a * self.a - self.b * self.b) / (self.b * self.b)
    }

    /// ECEF position (metres) of longitude `lon` and latitude `lat` (degrees) at `height`
    /// metres above the ellipsoid.
    pub fn to_ecef(&self, lon: f64, lat: f64, height: f64) -> DVec3 {
        let (sin_lon, cos_lon) = lon.to_radians().sin_cos();
        let (sin_lat, cos_lat) = lat.to_radians().sin_cos();
        // Prime-vertical radius of curvature N(φ) = a / √(1 − e² sin² φ).
        let n = self.a / (1.0 - self.e2() * sin_lat * sin_lat).sqrt();
        DVec3::new(
            (n + height) * cos_lat * cos_lon,
            (n + height) * cos_lat * sin_lon,
            (n * (1.0 - self.e2()) + height) * sin_lat,
        )
    }

    /// `[longitude°, latitude°, height m]` of an ECEF position (metres), by Bowring's
    /// iteration. Stable at the poles (longitude is then 0); the centre of the Earth has no
    /// geodetic coordinates and returns latitude ±90° with height −b.
    pub fn to_geodetic(&self, p: DVec3) -> [f64; 3] {
        let lon = p.y.atan2(p.x).to_degrees();
        let r = p.x.hypot(p.y);

        // Start from the parametric latitude of the point's direction, then refine:
        // tan φ = (z + e'² b sin³β) / (r − e² a cos³β), tan β = (1 − f) tan φ.
        let ratio = self.b / self.a;
        let mut beta = p.z.atan2(ratio * r);
        let mut phi = beta;
        for _ in 0..BOWRING_ITERATIONS {
            let (sin_b, cos_b) = beta.sin_cos();
            phi = (p.z + self.ep2() * self.b * sin_b.powi(3))
                .atan2(r - self.e2() * self.a * cos_b.powi(3));
            beta = (ratio * phi.sin()).atan2(phi.cos());
        }

        // Height along the normal, in a form with no division by cos φ (fine at the poles).
        let (sin_phi, cos_phi) = phi.sin_cos();
        let h = r * cos_phi + p.z * sin_phi - self.a * (1.0 - self.e2() * sin_phi * sin_phi).sqrt();
        [lon, phi.to_degrees(), h]
    }

    /// Unit outward normal of the ellipsoid at longitude `lon`, latitude `lat` (degrees):
    /// the direction of geodetic "up".
    pub fn surface_normal(&self, lon: f64, lat: f64) -> DVec3 {
        let (sin_lon, cos_lon) = lon.to_radians().sin_cos();
        let (sin_lat, cos_lat) = lat.to_radians().sin_cos();
        DVec3::new(cos_lat * cos_lon, cos_lat * sin_lon, sin_lat)
    }

    /// Unit geodetic normal through an ECEF position: the gradient of x²/a² + y²/a² + z²/b²,
    /// normalised. `None` at the centre.
    pub fn surface_normal_at(&self, p: DVec3) -> Option<DVec3> {
        let a2 = self.a * self.a;
        DVec3::new(p.x / a2, p.y / a2, p.z / (self.b * self.b)).try_normalize()
    }

    /// `p` in the ellipsoid-scaled frame, where the ellipsoid is the unit sphere.
    pub fn to_scaled_space(&self, p: DVec3) -> DVec3 {
        DVec3::new(p.x / self.a, p.y / self.a, p.z / self.b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: Ellipsoid = Ellipsoid::WGS84;

    #[test]
    fn wgs84_constants_match_tr8350() {
        // b = 6 356 752.314 245 m, e² = 0.006 694 379 990 14 (TR8350.2 table 3.3).
        assert!((W.b - 6_356_752.314_245).abs() < 1e-6, "{}", W.b);
        assert!((W.e2() - 0.006_694_379_990_14).abs() < 5e-15, "{}", W.e2());
    }

    #[test]
    fn cardinal_points_land_on_the_axes() {
        assert_eq!(W.to_ecef(0.0, 0.0, 0.0).to_array(), [6_378_137.0, 0.0, 0.0]);
        let east = W.to_ecef(90.0, 0.0, 0.0);
        assert!(east.x.abs() < 1e-9 && (east.y - W.a).abs() < 1e-9 && east.z == 0.0);
        let pole = W.to_ecef(0.0, 90.0, 100.0);
        assert!(
            pole.x.abs() < 1e-9 && (pole.z - (W.b + 100.0)).abs() < 1e-8,
            "{pole}"
        );
        let west = W.to_ecef(-180.0, 0.0, 1000.0);
        assert!((west.x + W.a + 1000.0).abs() < 1e-9);
    }

    #[test]
    fn lat_45_matches_the_published_ecef() {
        // (0°E, 45°N, 0 m) → X = 4 517 590.879 m, Z = 4 487 348.409 m, the value geodesy
        // converters (e.g. NGS's XYZ tool) print for WGS84/GRS80 at this point.
        let p = W.to_ecef(0.0, 45.0, 0.0);
        assert!((p.x - 4_517_590.879).abs() < 1e-3, "{}", p.x);
        assert!(p.y == 0.0);
        assert!((p.z - 4_487_348.409).abs() < 1e-3, "{}", p.z);
    }

    #[test]
    fn geodetic_round_trip_is_sub_millimetre_everywhere() {
        for lat in [-90.0, -89.999, -60.0, -1e-9, 0.0, 33.3, 45.0, 89.9999, 90.0] {
            for lon in [-180.0, -97.5, 0.0, 12.25, 179.999] {
                for h in [-11_000.0, -100.0, 0.0, 8_848.0, 40_000.0] {
                    let p = W.to_ecef(lon, lat, h);
                    let [lon2, lat2, h2] = W.to_geodetic(p);
                    assert!((lat2 - lat).abs() < 1e-11, "lat {lat} → {lat2}");
                    assert!((h2 - h).abs() < 1e-6, "h {h} → {h2} at lat {lat}");
                    if lat.abs() < 90.0 {
                        let dlon = (lon2 - lon + 540.0).rem_euclid(360.0) - 180.0;
                        assert!(dlon.abs() < 1e-11, "lon {lon} → {lon2}");
                    }
                }
            }
        }
    }

    #[test]
    fn surface_normals_agree_and_are_unit() {
        for (lon, lat) in [(0.0, 0.0), (45.0, 45.0), (-120.0, -30.0), (10.0, 90.0)] {
            let n = W.surface_normal(lon, lat);
            assert!((n.length() - 1.0).abs() < 1e-15);
            let at = W.surface_normal_at(W.to_ecef(lon, lat, 0.0)).unwrap();
            assert!((n - at).length() < 1e-12, "{n} vs {at}");
        }
        assert_eq!(W.surface_normal_at(DVec3::ZERO), None);
    }

    #[test]
    fn scaled_space_maps_the_surface_to_the_unit_sphere() {
        for (lon, lat) in [(0.0, 0.0), (30.0, 60.0), (0.0, 90.0)] {
            let s = W.to_scaled_space(W.to_ecef(lon, lat, 0.0));
            assert!((s.length() - 1.0).abs() < 1e-15);
        }
    }
}
