//! A local east-north-up (ENU) frame: metres about a point on the ellipsoid, x east, y
//! north, z up along the ellipsoid's normal there. A world tile in degrees (x, y) and metres
//! (z) looks squashed in any viewer that takes its units as equal; in ENU a mesh has its true
//! shape, the Earth's curvature included (the edge of a 100 km tile sits ~200 m below its
//! centre's horizon), and CesiumJS places it with
//! `Transforms.eastNorthUpToFixedFrame(origin)` as its model matrix.
//!
//! Reference: the ECEF → ENU rotation, e.g. J. Farrell, M. Barth, "The Global Positioning
//! System and Inertial Navigation" (1999), §2.3.2: the rows of the rotation are the local
//! east, north and up unit vectors at the origin's geodetic longitude and latitude.
//!
//! ```
//! use zerotile_codec::geo::{Ellipsoid, EnuFrame};
//!
//! let f = EnuFrame::at(Ellipsoid::WGS84, -71.5, 44.5, 0.0);
//! let up = f.from_geodetic(-71.5, 44.5, 100.0);
//! assert!((up.z - 100.0).abs() < 1e-6 && up.x.abs() < 1e-6 && up.y.abs() < 1e-6);
//! ```

use glam::{DMat3, DMat4, DVec3};

use super::Ellipsoid;

/// An east-north-up frame at a point of an ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnuFrame {
    ellipsoid: Ellipsoid,
    /// `[lon°, lat°, height m]` of the origin.
    origin: [f64; 3],
    /// The origin in ECEF metres.
    origin_ecef: DVec3,
    /// ECEF → ENU: its rows are east, north and up.
    to_local: DMat3,
}

impl EnuFrame {
    /// The frame at longitude `lon`, latitude `lat` (degrees), `height` metres above
    /// `ellipsoid`.
    pub fn at(ellipsoid: Ellipsoid, lon: f64, lat: f64, height: f64) -> Self {
        let (sin_lon, cos_lon) = lon.to_radians().sin_cos();
        let (sin_lat, cos_lat) = lat.to_radians().sin_cos();
        let east = DVec3::new(-sin_lon, cos_lon, 0.0);
        let north = DVec3::new(-sin_lat * cos_lon, -sin_lat * sin_lon, cos_lat);
        let up = DVec3::new(cos_lat * cos_lon, cos_lat * sin_lon, sin_lat);
        Self {
            ellipsoid,
            origin: [lon, lat, height],
            origin_ecef: ellipsoid.to_ecef(lon, lat, height),
            // Built from columns, so transposed: the rows are the three unit vectors.
            to_local: DMat3::from_cols(east, north, up).transpose(),
        }
    }

    /// `[lon°, lat°, height m]` of the frame's origin.
    pub fn origin(&self) -> [f64; 3] {
        self.origin
    }

    /// An ECEF position (metres) in the frame.
    pub fn from_ecef(&self, p: DVec3) -> DVec3 {
        // Differences of ECEF coordinates near each other: the subtraction is exact to the
        // f64 rounding of each (~1 nm at the Earth's radius), before the rotation.
        self.to_local * (p - self.origin_ecef)
    }

    /// The frame's points → ECEF (metres): the inverse of [`Self::from_ecef`], as one
    /// rigid matrix, for a client that places the frame itself (a 3D Tiles `transform`).
    pub fn to_ecef_matrix(&self) -> DMat4 {
        // The rotation's inverse is its transpose: its columns are east, north and up.
        DMat4::from_mat3_translation(self.to_local.transpose(), self.origin_ecef)
    }

    /// Longitude `lon`, latitude `lat` (degrees) and `height` (metres) in the frame.
    pub fn from_geodetic(&self, lon: f64, lat: f64, height: f64) -> DVec3 {
        self.from_ecef(self.ellipsoid.to_ecef(lon, lat, height))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: Ellipsoid = Ellipsoid::WGS84;

    #[test]
    fn the_origin_is_zero_and_its_normal_is_up() {
        for (lon, lat, h) in [(0.0, 0.0, 0.0), (-71.5, 44.5, 300.0), (179.9, -89.0, -50.0)] {
            let f = EnuFrame::at(W, lon, lat, h);
            assert!(f.from_geodetic(lon, lat, h).length() < 1e-6);
            let up = f.from_geodetic(lon, lat, h + 1234.5);
            assert!((up - DVec3::new(0.0, 0.0, 1234.5)).length() < 1e-6, "{up}");
        }
    }

    /// At (0°, 0°) east is ECEF +y and north ECEF +z, so a degree east is a degree of the
    /// equator along x, and the equator falls away below the horizon.
    #[test]
    fn axes_point_east_and_north() {
        let f = EnuFrame::at(W, 0.0, 0.0, 0.0);
        let east = f.from_geodetic(0.01, 0.0, 0.0);
        let arc = W.a * 0.01_f64.to_radians();
        assert!(
            (east.x - W.a * 0.01_f64.to_radians().sin()).abs() < 1e-6,
            "{east}"
        );
        assert!(
            east.y.abs() < 1e-9 && east.z < 0.0 && east.x < arc,
            "{east}"
        );
        let north = f.from_geodetic(0.0, 0.01, 0.0);
        assert!(
            north.y > 1000.0 && north.x.abs() < 1e-9 && north.z < 0.0,
            "{north}"
        );
    }

    /// Against points worked out apart from this code (a Python transcription of the
    /// textbook formulas, checked by hand: 0.1° of longitude at 44.5° N is 111.32 km ×
    /// 0.1 × cos 44.5° ≈ 7.94 km, and 13.6 km away the ground has fallen ~14.6 m below the
    /// horizon): north-east of the origin is +x +y, south-west −x −y.
    #[test]
    fn reference_points_off_the_equator() {
        for (o, p, want) in [
            (
                [-71.5, 44.5],
                [-71.4, 44.6, 500.0],
                [7939.967582074987, 11118.022011596102, 485.35983988035423],
            ),
            (
                [138.7, -35.3],
                [138.6, -35.4, 10.0],
                [-9084.179855828897, -11099.29254082937, -6.151876955727857],
            ),
        ] {
            let got = EnuFrame::at(W, o[0], o[1], 0.0).from_geodetic(p[0], p[1], p[2]);
            assert!((got - DVec3::from_array(want)).length() < 1e-3, "{got}");
        }
    }

    /// A rotation and a shift: distances between points are those of ECEF.
    #[test]
    fn distances_are_kept() {
        let f = EnuFrame::at(W, 138.7, 35.3, 0.0);
        let pts = [
            (138.6, 35.2, 10.0),
            (138.9, 35.4, 3776.0),
            (138.7, 35.36, 500.0),
        ];
        for a in pts {
            for b in pts {
                let ecef = W.to_ecef(a.0, a.1, a.2).distance(W.to_ecef(b.0, b.1, b.2));
                let local = f
                    .from_geodetic(a.0, a.1, a.2)
                    .distance(f.from_geodetic(b.0, b.1, b.2));
                assert!((ecef - local).abs() < 1e-6, "{ecef} vs {local}");
            }
        }
    }

    /// The matrix takes a frame's points back to ECEF: a CesiumJS `transform` made from it
    /// puts the frame's vertices where their longitude, latitude and height say.
    #[test]
    fn the_ecef_matrix_undoes_the_frame() {
        for (o, p) in [
            ([-71.5, 44.5, 0.0], [-71.4, 44.6, 500.0]),
            ([179.9, -89.0, 20.0], [-179.8, -88.9, -30.0]),
            ([0.0, 0.0, 0.0], [0.5, -0.5, 8000.0]),
        ] {
            let f = EnuFrame::at(W, o[0], o[1], o[2]);
            let m = f.to_ecef_matrix();
            let local = f.from_geodetic(p[0], p[1], p[2]);
            let back = m.transform_point3(local);
            let want = W.to_ecef(p[0], p[1], p[2]);
            assert!(back.distance(want) < 1e-6, "{back} vs {want}");
            // Rigid: its inverse is the frame's own move.
            let again = m.inverse().transform_point3(want);
            assert!(again.distance(local) < 1e-6, "{again} vs {local}");
        }
    }
}
