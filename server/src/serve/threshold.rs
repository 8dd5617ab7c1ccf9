//! The threshold T of a tile request: explicit, from the view ratio of eq. 4, from a camera,
//! or the zoom's default. And how T is split between decoding and meshing.
//!
//! T is an error budget in metres. The stream is read to T · [`DECODE_SHARE`] (rounded down
//! to a power of two, so nearby budgets share one cached decode) and the mesh gets the rest,
//! T · (1 − [`DECODE_SHARE`]). `zerotile eval terrain` reads to the same depth but, having
//! the source, meshes within T minus the decode's measured error.

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use serde::Serialize;
use zerotile_codec::ezw::DecodeLimit;
use zerotile_codec::geo::{Bounds, Scheme};

use super::dataset::Dataset;
use super::error::{echo, ApiError, ECHO_CHARS};
use super::view_plane::{clip_to_globe, footprint, polygon_area, Camera};

/// Share of the budget spent on decoding, the same depth `zerotile eval terrain` reads to.
pub use crate::eval::terrain::DECODE_SHARE;
/// Largest threshold accepted, metres: far above any relief, so larger values are mistakes.
pub const MAX_THRESHOLD: f64 = 100_000.0;
/// Largest view ratio A_v / A_t accepted.
pub const MAX_RATIO: f64 = 1.0e6;
/// Largest coordinate accepted in `eye` and `target` (degrees, samples or metres).
pub const MAX_COORDINATE: f64 = 1.0e8;
/// Metres per degree of latitude (and of longitude on the equator), spherical.
const METRES_PER_DEGREE: f64 = 111_319.490_793_273_57;
/// Decode depths finer than 2^-20 m read the whole stream anyway.
const FINEST_LEVEL: i32 = -20;

/// How T was chosen: reported in `/view` and in logs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "source", rename_all = "snake_case")]
pub enum Choice {
    Threshold,
    Ratio { ratio: f64 },
    View { ratio: f64, a_v: f64, a_t: f64 },
    Default,
}

/// A threshold and where it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Threshold {
    pub t: f64,
    pub choice: Choice,
}

/// Which passes of the streams are decoded: every pass at or above 2^level metres, or all
/// of them (T = 0: the stream's own precision).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Depth {
    All,
    Level(i32),
}

impl Depth {
    pub fn for_threshold(t: f64) -> Self {
        Self::for_budget(t * DECODE_SHARE)
    }

    /// The depth a decode budget of `d` metres reads to: `d` rounded down to a power of two,
    /// so that nearby budgets share one cached decode. `zerotile eval terrain` rounds its
    /// budgets (other shares too) by it, to read as deep as the tiles.
    pub fn for_budget(d: f64) -> Self {
        if d <= 0.0 {
            return Self::All;
        }
        let level = d.log2().floor() as i32;
        if level < FINEST_LEVEL {
            Self::All
        } else {
            Self::Level(level)
        }
    }

    /// The smallest mesh tolerance a request decoded to this depth is meshed at: every T
    /// with T · share in [2^k, 2^(k+1)) meshes within T · (1 − share) ≥ 2^k (1 − share) / share
    /// (a hair less, for rounding). The error tree is exact above it (`TileErrors::exact_above`).
    pub fn mesh_floor(self) -> f64 {
        match self {
            Self::All => 0.0,
            Self::Level(k) => mesh_tolerance(f64::from(k).exp2() / DECODE_SHARE) * (1.0 - 1e-6),
        }
    }

    pub fn limit(self) -> DecodeLimit {
        match self {
            Self::All => DecodeLimit::All,
            Self::Level(k) => DecodeLimit::Threshold(f64::from(k).exp2()),
        }
    }
}

/// The mesh's share of the budget.
pub fn mesh_tolerance(t: f64) -> f64 {
    t * (1.0 - DECODE_SHARE)
}

/// The default threshold at zoom `z`: the level's geometric error (Cesium's error budget,
/// `Tiling::level_geometric_error`), capped at the dataset's relief, beyond which every
/// budget gives the same two-triangle mesh. For a local grid the error is in sample spacings,
/// read as metres (a grid without georeference has no other scale).
pub fn default_threshold(d: &Dataset, z: u8) -> f64 {
    d.tiling.level_geometric_error(z).min(relief(d))
}

/// The dataset's height range (at least a metre): no mesh of it errs by more.
pub fn relief(d: &Dataset) -> f64 {
    let [lo, hi] = d.metadata().height_range;
    (hi - lo).max(1.0)
}

/// The threshold a request asks for: `threshold`, `ratio`, or `eye`+`target`+`fov`
/// (+`aspect`), else the zoom's default. At most one of the three may be given.
pub fn from_query(d: &Dataset, z: u8, q: &HashMap<String, String>) -> Result<Threshold, ApiError> {
    let has = |k: &str| q.contains_key(k);
    one_source(q)?;
    if let Some(s) = q.get("threshold") {
        let t = number("threshold", s, 0.0, MAX_THRESHOLD)?;
        return Ok(Threshold {
            t,
            choice: Choice::Threshold,
        });
    }
    if let Some(s) = q.get("ratio") {
        let ratio = number("ratio", s, 0.0, MAX_RATIO)?;
        return Ok(Threshold {
            t: eq4(d, ratio),
            choice: Choice::Ratio { ratio },
        });
    }
    if CAMERA.iter().any(|k| has(k)) {
        let ViewPlane {
            ratio, a_v, a_t, ..
        } = view_plane(d, q)?;
        return Ok(Threshold {
            t: eq4(d, ratio),
            choice: Choice::View { ratio, a_v, a_t },
        });
    }
    Ok(Threshold {
        t: default_threshold(d, z),
        choice: Choice::Default,
    })
}

/// The parameters of a camera; any one of them makes the query a view.
pub const CAMERA: [&str; 4] = ["eye", "target", "fov", "aspect"];

/// At most one source of T in a query: `threshold`, `ratio` or a camera (any of
/// [`CAMERA`]: `?threshold=4&fov=60` is two sources, not a threshold with a stray camera part
/// dropped). Tiles and `/view` share it, so a second source is refused everywhere rather than
/// ignored somewhere.
pub fn one_source(q: &HashMap<String, String>) -> Result<(), ApiError> {
    let camera = CAMERA.iter().any(|k| q.contains_key(*k));
    let given = ["threshold", "ratio"]
        .iter()
        .filter(|k| q.contains_key(**k))
        .count()
        + usize::from(camera);
    if given > 1 {
        return Err(ApiError::bad_request(
            "conflicting_threshold",
            "give one of threshold, ratio or a camera (eye, target, fov, aspect)",
        ));
    }
    Ok(())
}

/// Paper eq. 4: T = a · ratio + b, never below the finest threshold (0) nor above the cap.
pub fn eq4(d: &Dataset, ratio: f64) -> f64 {
    let v = d.metadata().view;
    (v.a * ratio + v.b).clamp(0.0, MAX_THRESHOLD)
}

/// A camera's view plane on a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewPlane {
    /// A_v / A_t.
    pub ratio: f64,
    /// Footprint area and terrain area: square metres (square samples for a local grid).
    pub a_v: f64,
    pub a_t: f64,
    /// The footprint, a convex polygon in the query's own coordinates: longitude and
    /// latitude degrees, or column and row. Longitudes run on round the target, so a
    /// footprint across the antimeridian has some past ±180°.
    pub footprint: Vec<[f64; 2]>,
    /// The camera's target, in the same coordinates: what the view looks at, so inside the
    /// footprint whenever the target is on the ground.
    pub target: [f64; 2],
}

/// The view plane of the camera in the query (see docs/api.md for the model).
pub fn view_plane(d: &Dataset, q: &HashMap<String, String>) -> Result<ViewPlane, ApiError> {
    let get = |k: &str| {
        q.get(k).ok_or_else(|| {
            ApiError::bad_request(
                "missing_parameter",
                format!("a view needs eye, target and fov; {k} is missing"),
            )
        })
    };
    let m = d.metadata();
    let [west, south, east, north] = m.bounds;
    let local = matches!(d.tiling.scheme(), Scheme::Local { .. });
    let point = |name: &str| -> Result<DVec3, ApiError> {
        let s = get(name)?;
        if local {
            vec3(name, s)
        } else {
            lon_lat_height(name, s)
        }
    };
    let eye = point("eye")?;
    let target = point("target")?;
    let fov_deg = number("fov", get("fov")?, f64::MIN_POSITIVE, 179.0)?;
    let aspect = q.get("aspect").map_or(Ok(1.0), |s| aspect(s, 1e-3, 1e3))?;

    // Horizontal metres around the target (degrees scaled at the target's latitude; grid
    // samples as they are, rows flipped so y points north), and back. Longitudes the short
    // way round: an eye at 179.9° is 0.2° from a target at −179.9°, not 359.8°.
    // ±180° are one meridian: one camera, one answer (and cache entry) either way written.
    let lon0 = if local {
        target.x
    } else {
        zerotile_codec::geo::wrap_longitude(target.x)
    };
    let lat0 = target.y;
    let k = lat0.to_radians().cos().max(1e-6);
    let to_plane = |p: DVec3| {
        if local {
            DVec3::new(p.x, -p.y, p.z)
        } else {
            DVec3::new(
                zerotile_codec::geo::wrap_longitude(p.x - lon0) * METRES_PER_DEGREE * k,
                (p.y - lat0) * METRES_PER_DEGREE,
                p.z,
            )
        }
    };
    let from_plane = |p: &DVec2| {
        if local {
            DVec2::new(p.x, -p.y)
        } else {
            DVec2::new(
                lon0 + p.x / (METRES_PER_DEGREE * k),
                lat0 + p.y / METRES_PER_DEGREE,
            )
        }
    };
    let a_t = if local {
        ((east - west) * (south - north)).abs()
    } else {
        let mid = ((south + north) / 2.0).to_radians().cos();
        // West past east: across the antimeridian, the width eastwards from west over 180°.
        let width = Bounds::from(m.bounds).lon_width();
        (width * mid * (north - south)).abs() * METRES_PER_DEGREE.powi(2)
    };
    let cam = Camera {
        eye: to_plane(eye),
        target: to_plane(target),
        fov_deg,
        aspect,
    };
    // The view past the horizon stops at the terrain's own diagonal.
    let far = (2.0 * a_t).sqrt().max(1.0);
    let points =
        footprint(&cam, far).map_err(|e| ApiError::bad_request("bad_view", e.to_string()))?;
    let a_v = polygon_area(&points);
    let a_t = a_t.max(1.0);
    let mut footprint: Vec<DVec2> = points.iter().map(from_plane).collect();
    if !local {
        // Near a pole a metre of longitude is many degrees: the footprint stops at the
        // globe's edges (and at one turn round the target). It still holds the target.
        footprint = clip_to_globe(&footprint, lon0);
    }
    Ok(ViewPlane {
        ratio: a_v / a_t,
        a_v,
        a_t,
        footprint: footprint.iter().map(|p| p.to_array()).collect(),
        target: [lon0, lat0],
    })
}

/// A world dataset's `eye` and `target` are longitude, latitude (degrees) and height: a
/// point past the poles or the antimeridian is a mistake, not a view, and the range an
/// error quotes is the globe's, not [`MAX_COORDINATE`].
fn lon_lat_height(name: &str, s: &str) -> Result<DVec3, ApiError> {
    vec3_within(name, s, |i| match i {
        0 => (
            format!("{name}'s longitude (degrees, on a world dataset)"),
            180.0,
        ),
        1 => (
            format!("{name}'s latitude (degrees, on a world dataset)"),
            90.0,
        ),
        _ => (format!("{name}'s height"), MAX_COORDINATE),
    })
}

/// `aspect` in [lo, hi], as a number (`1.78`) or as width/height (`16/9`), the way
/// screens are named.
pub fn aspect(s: &str, lo: f64, hi: f64) -> Result<f64, ApiError> {
    let Some((w, h)) = s.split_once('/') else {
        return number("aspect", s, lo, hi);
    };
    let w = number("aspect width", w, f64::MIN_POSITIVE, 1e9)?;
    let h = number("aspect height", h, f64::MIN_POSITIVE, 1e9)?;
    number("aspect", &(w / h).to_string(), lo, hi)
}

/// A finite number in [lo, hi].
pub fn number(name: &str, s: &str, lo: f64, hi: f64) -> Result<f64, ApiError> {
    let v: f64 = s.trim().parse().map_err(|_| {
        ApiError::bad_request(
            "bad_number",
            format!("{name} must be a number, got {}", echo(s)),
        )
    })?;
    // A lower bound of the smallest positive (normal) f64 is "above 0" to a reader, and is
    // taken so: the subnormals below it are in (0, hi] too.
    let below = if lo == f64::MIN_POSITIVE {
        v <= 0.0
    } else {
        v < lo
    };
    if !v.is_finite() || below || v > hi {
        let low = if lo == f64::MIN_POSITIVE {
            "(0".to_owned()
        } else {
            format!("[{}", short(lo))
        };
        return Err(ApiError::bad_request(
            "out_of_range",
            format!(
                "{name} must be in {low}, {}], got {}",
                short(hi),
                as_given(s)
            ),
        ));
    }
    // −0 + 0 is +0: `-0` is the same request as `0`, under the same ETag and cache entry.
    Ok(v + 0.0)
}

/// A number that parsed, as the client wrote it: unquoted, unless it is long or holds
/// anything but the number's own characters (spaces and newlines around it parse too).
fn as_given(s: &str) -> String {
    let plain = s
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c));
    if plain && s.len() <= ECHO_CHARS {
        s.to_owned()
    } else {
        echo(s)
    }
}

/// [`number`] that must also be whole: a count or a size, where 1.5 would otherwise be
/// cut to 1 without a word.
pub fn integer(name: &str, s: &str, lo: f64, hi: f64) -> Result<f64, ApiError> {
    let v = number(name, s, lo, hi)?;
    if v.fract() != 0.0 {
        return Err(ApiError::bad_request(
            "out_of_range",
            format!(
                "{name} must be an integer in [{lo}, {hi}], got {}",
                as_given(s)
            ),
        ));
    }
    Ok(v)
}

/// A threshold of 1e-300 is valid and goes into headers: quoted short, as the codec does.
pub use zerotile_codec::error::short;

/// `x,y,z`, each finite and within [`MAX_COORDINATE`].
pub fn vec3(name: &str, s: &str) -> Result<DVec3, ApiError> {
    vec3_within(name, s, |_| (name.to_owned(), MAX_COORDINATE))
}

/// `x,y,z`, component `i` finite and within ±`bound(i).1`, named `bound(i).0` in errors.
fn vec3_within(
    name: &str,
    s: &str,
    bound: impl Fn(usize) -> (String, f64),
) -> Result<DVec3, ApiError> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(ApiError::bad_request(
            "bad_vector",
            format!("{name} must be x,y,z, got {}", echo(s)),
        ));
    }
    let mut v = [0.0; 3];
    for (i, (slot, p)) in v.iter_mut().zip(&parts).enumerate() {
        let (what, limit) = bound(i);
        *slot = number(&what, p, -limit, limit)?;
    }
    Ok(DVec3::from_array(v))
}

/// The geometric error of every zoom, for the dataset description.
pub fn defaults(d: &Dataset) -> Vec<(u8, f64)> {
    let m = d.metadata();
    (m.min_zoom..=m.max_zoom)
        .map(|z| (z, default_threshold(d, z)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_rounds_the_decode_share_down_to_a_power_of_two() {
        assert_eq!(Depth::for_threshold(0.0), Depth::All);
        assert_eq!(Depth::for_threshold(8.0), Depth::Level(0));
        assert_eq!(Depth::for_threshold(15.9), Depth::Level(0));
        assert_eq!(Depth::for_threshold(16.0), Depth::Level(1));
        assert_eq!(Depth::for_threshold(1e-12), Depth::All);
    }

    /// The decoded tile's error tree is exact only above its depth's floor, so every T that
    /// maps to a depth must mesh at a tolerance at or above that floor, at the edges of the
    /// depth's range too.
    #[test]
    fn every_threshold_meshes_at_or_above_its_depths_floor() {
        let mut checked = 0;
        for k in -20..=14 {
            let edge = f64::from(k).exp2() / DECODE_SHARE;
            for t in [
                edge,
                edge.next_down(),
                edge.next_up(),
                edge * 1.5,
                edge * 2.0 - edge * 1e-12,
            ] {
                let depth = Depth::for_threshold(t);
                assert!(
                    mesh_tolerance(t) >= depth.mesh_floor(),
                    "T {t}: tolerance {} below the floor {} of {depth:?}",
                    mesh_tolerance(t),
                    depth.mesh_floor()
                );
                checked += 1;
            }
        }
        assert!(checked > 100);
        assert_eq!(Depth::All.mesh_floor(), 0.0);
        assert!(Depth::Level(3).mesh_floor() > 0.99 * 7.0 * 8.0);
    }

    #[test]
    fn numbers_are_checked() {
        assert!(number("t", "NaN", 0.0, 1.0).is_err());
        assert!(number("t", "inf", 0.0, 1.0).is_err());
        assert!(number("t", "-1", 0.0, 1.0).is_err());
        assert!(number("t", "1e300", 0.0, 1.0).is_err());
        assert!(number("t", "x", 0.0, 1.0).is_err());
        assert_eq!(number("t", "0.5", 0.0, 1.0), Ok(0.5));
    }

    /// A fourth number is a mistake (a 4-vector, a typo), not something to drop.
    #[test]
    fn vectors_take_exactly_three_numbers() {
        assert_eq!(vec3("eye", "1,2,3"), Ok(DVec3::new(1.0, 2.0, 3.0)));
        for bad in ["1,2", "1,2,3,4", "", "1,2,3,"] {
            let err = vec3("eye", bad).unwrap_err().to_string();
            assert!(err.contains("eye must be x,y,z"), "{bad:?}: {err}");
        }
    }

    #[test]
    fn ranges_and_numbers_read_short() {
        let message = |r: Result<f64, ApiError>| r.unwrap_err().to_string();
        let fov = message(number("fov", "0", f64::MIN_POSITIVE, 179.0));
        assert!(fov.contains("fov must be in (0, 179], got 0"), "{fov}");
        let t = message(number("threshold", "-1", 0.0, MAX_THRESHOLD));
        assert!(t.contains("in [0, 100000]"), "{t}");
        assert_eq!(short(1e-300), "1e-300");
        assert_eq!(short(2.0), "2");
        assert_eq!(short(0.125), "0.125");
        assert_eq!(short(0.0), "0");
        for v in [1e-300, 3.7e-7, 0.1, 148.25, 1e20, 12_345.678] {
            assert_eq!(short(v).parse::<f64>(), Ok(v));
            assert!(short(v).len() < 24, "{}", short(v));
        }
    }
}
