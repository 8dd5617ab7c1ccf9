//! What a dataset says about itself: the JSON at the head of the container.

use serde::{Deserialize, Serialize};

use crate::geo::{Scheme, Tiling, TilingError, VerticalDatum};
use crate::wavelet::Wavelet;

/// Dataset-wide facts, fixed at ingest.
///
/// Unknown fields are kept out of the type but tolerated when reading, so a newer writer's
/// extra facts do not make an older server refuse a dataset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    pub name: String,
    /// `geodetic` (EPSG:4326 TMS), `mercator` (EPSG:3857 XYZ) or `local` (the source grid).
    pub scheme: String,
    /// Samples per tile side: 2^n + 1.
    pub tile_side: usize,
    pub min_zoom: u8,
    pub max_zoom: u8,
    /// West, south, east, north of the data: degrees, or samples for `local`.
    pub bounds: [f64; 4],
    /// Rows and columns of the source grid (the `local` scheme's full-resolution pyramid).
    pub source_size: [usize; 2],
    pub wavelet: Wavelet,
    /// Height units per coder unit (metres): the source's native step.
    pub step: f64,
    /// Max |stored − source| guaranteed by the streams' residual pass; `None` when the
    /// streams are lossless to the step.
    pub precision: Option<f64>,
    /// Lowest and highest height in the dataset (metres), the fill included where it is
    /// stored.
    pub height_range: [f64; 2],
    /// Lowest and highest height of the source's own samples, which on a world dataset
    /// `height_range` hides behind the fill around it. Absent in datasets ingested before
    /// it was recorded (read as `None`; not written then, so their bytes stay the same).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_height_range: Option<[f64; 2]>,
    /// Height given to samples outside the source or without data.
    pub fill: f64,
    /// What the heights are measured from. `Egm96` ones are offset by the geoid's
    /// undulation where heights above the ellipsoid are due (quantized-mesh, ENU). `None`
    /// (not recorded: a source that does not say, or a dataset ingested before it was
    /// recorded, whose bytes stay the same) serves them as they are, as does a datum this
    /// build does not model (a newer writer's): the dataset stays servable.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "datum_or_unknown"
    )]
    pub vertical_datum: Option<VerticalDatum>,
    /// Eq. 4 of the paper: T = a·(A_v / A_t) + b.
    pub view: ViewParams,
    /// Per zoom (index = zoom − min_zoom), the tile ranges that exist.
    pub available: Vec<Vec<Availability>>,
    /// The source file's name and its coordinate reference system.
    pub source: String,
    pub source_crs: String,
    /// Samples coded and stream bytes stored, over the whole pyramid.
    pub samples: u64,
    pub stream_bytes: u64,
    /// RFC 3339 time of the ingest.
    pub created: String,
}

/// `vertical_datum` as read: a name this build knows, `None` for null or another name; a
/// value that is no name at all is refused, named.
fn datum_or_unknown<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Option<VerticalDatum>, D::Error> {
    match Option::<serde_json::Value>::deserialize(d)? {
        None | Some(serde_json::Value::Null) => Ok(None),
        Some(serde_json::Value::String(s)) => Ok(s.parse().ok()),
        Some(other) => Err(serde::de::Error::custom(format!(
            "vertical_datum {other}: not a datum's name (egm96, ellipsoid)"
        ))),
    }
}

impl Metadata {
    /// The tiling the metadata names: its scheme, tile side and (for `local`) grid size.
    pub fn tiling(&self) -> Result<Tiling, String> {
        let scheme = match self.scheme.as_str() {
            "geodetic" => Scheme::Geodetic,
            "mercator" => Scheme::Mercator,
            "local" => Scheme::Local {
                rows: self.source_size[0],
                cols: self.source_size[1],
            },
            other => return Err(format!("scheme {other:?}: not geodetic, mercator or local")),
        };
        let side = u32::try_from(self.tile_side).unwrap_or(u32::MAX);
        Tiling::new(scheme, side).map_err(|e| match e {
            TilingError::Side(_) => format!("tile_side {}: {e}", self.tile_side),
            _ => format!("source_size {:?}: {e}", self.source_size),
        })
    }

    /// Checks what the server relies on and JSON cannot say: a header whose CRC holds but
    /// whose values came from a buggy writer (or a hand edit) was served, and failed later
    /// on every `layer.json` or tile (a zoom past the tiling's deepest, a latitude of 100°,
    /// a step of 0). Refused here, it fails `info` naming the field, and `serve` lists the
    /// file under `skipped` with the same reason.
    ///
    /// Longitudes west past east are valid: the dataset crosses the antimeridian
    /// (CesiumJS's `Rectangle` convention, `geo::antimeridian`). A `local` dataset's bounds
    /// are sample coordinates, rows counted down, so its south is the larger number.
    pub fn check(&self) -> Result<(), String> {
        let tiling = self.tiling()?;
        // The tiling takes sides up to 32769; the mesher's tables stop at 4097, and a side past
        // them was refused later as "not 2^n + 1", which it is.
        if !crate::bintree::Hierarchy::supports(self.tile_side) {
            return Err(format!(
                "tile_side {}: this build meshes tiles of 2^n + 1 samples from 3 to 4097",
                self.tile_side
            ));
        }
        if self.min_zoom > self.max_zoom {
            return Err(format!(
                "min_zoom {} is past max_zoom {}",
                self.min_zoom, self.max_zoom
            ));
        }
        if self.max_zoom > tiling.max_zoom() {
            let of = match tiling.scheme() {
                Scheme::Local { rows, cols } => format!("a local grid of {rows} × {cols} samples"),
                _ => format!("the {} scheme", self.scheme),
            };
            return Err(format!(
                "max_zoom {} is deeper than the tiling's deepest zoom {} ({of})",
                self.max_zoom,
                tiling.max_zoom()
            ));
        }
        // Every zoom the server announces (layer.json, tiles.json, the description) lists
        // tiles, which `info --verify` checks are stored: a max_zoom past the lists (a hand
        // edit, the CRC resealed) announced a zoom of nothing but 404s, and passed.
        let zooms = usize::from(self.max_zoom - self.min_zoom) + 1;
        if self.available.len() != zooms {
            return Err(format!(
                "available lists {} zooms, but min_zoom {} to max_zoom {} are {zooms}",
                self.available.len(),
                self.min_zoom,
                self.max_zoom
            ));
        }
        if let Some(k) = self.available.iter().position(Vec::is_empty) {
            return Err(format!(
                "available lists no tiles at zoom {}, which max_zoom {} announces",
                usize::from(self.min_zoom) + k,
                self.max_zoom
            ));
        }
        let local = match tiling.scheme() {
            Scheme::Local { rows, cols } => Some((rows, cols)),
            _ => None,
        };
        if let Some((rows, cols)) = local {
            self.check_local_zooms(rows, cols, tiling.max_zoom())?;
        }
        self.check_available_in(&tiling)?;
        if let Some((rows, cols)) = local {
            self.check_local_bounds(rows, cols)?;
        }
        if self.source_size.contains(&0) {
            return Err(format!(
                "source_size {:?}: a source has at least one row and column",
                self.source_size
            ));
        }
        check_bounds(&self.scheme, self.bounds)?;
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(format!("step {}: must be finite and > 0", self.step));
        }
        if let Some(p) = self.precision {
            if !(p.is_finite() && p > 0.0) {
                return Err(format!("precision {p}: must be finite and > 0, or null"));
            }
        }
        check_range("height_range", self.height_range)?;
        if let Some(r) = self.source_height_range {
            check_range("source_height_range", r)?;
        }
        if !self.fill.is_finite() {
            return Err(format!("fill {}: not finite", self.fill));
        }
        if !(self.view.a.is_finite() && self.view.b.is_finite()) {
            return Err(format!(
                "view {{a: {}, b: {}}}: not finite",
                self.view.a, self.view.b
            ));
        }
        Ok(())
    }

    /// A local dataset's tiles are placed by `source_size` alone (a zoom-z tile spans
    /// 2^(deepest − z) · (side − 1) samples), so a size that disagrees with what was coded
    /// scaled every mesh (2401² on a 1201² dataset: twice its real coordinates). Ingest codes
    /// the grid's full resolution at `max_zoom` and writes its bounds in samples
    /// ([`Self::check_local_bounds`]), which tie the size down.
    fn check_local_zooms(&self, rows: usize, cols: usize, deepest: u8) -> Result<(), String> {
        if self.max_zoom != deepest {
            let cells = self.tile_side as u64 - 1;
            let z = u32::from(self.max_zoom);
            let lo = if z == 0 { 2 } else { (cells << (z - 1)) + 2 };
            return Err(format!(
                "source_size [{rows}, {cols}]: max_zoom {} is a local grid's full resolution \
                 when its longer side is {lo} to {} samples ({}-sample tiles), not {}",
                self.max_zoom,
                (cells << z) + 1,
                self.tile_side,
                rows.max(cols)
            ));
        }
        Ok(())
    }

    /// Bounds of a local grid are its samples' extent, `source_size` − 1 (rows counted down).
    fn check_local_bounds(&self, rows: usize, cols: usize) -> Result<(), String> {
        let spans = [0.0, (rows - 1) as f64, (cols - 1) as f64, 0.0];
        if self.bounds != spans {
            return Err(format!(
                "bounds {:?}: source_size [{rows}, {cols}] makes a local grid's bounds {spans:?} \
                 (west, south, east, north in samples)",
                self.bounds
            ));
        }
        Ok(())
    }

    /// Every announced range lies in its zoom's tiles: the server would announce tiles it
    /// cannot place (an export failed on them, "outside zoom 1's 1×2 tiles", after verify
    /// passed).
    fn check_available_in(&self, tiling: &Tiling) -> Result<(), String> {
        for (z, ranges) in (self.min_zoom..=self.max_zoom).zip(&self.available) {
            let (nx, ny) = tiling.tiles_per_axis(z).map_err(|e| e.to_string())?;
            for r in ranges {
                if r.start_x.max(r.end_x) < nx && r.start_y.max(r.end_y) < ny {
                    continue;
                }
                let of = match tiling.scheme() {
                    Scheme::Local { rows, cols } => {
                        format!("a local grid of source_size [{rows}, {cols}] (rows, columns)")
                    }
                    _ => format!("the {} scheme", self.scheme),
                };
                return Err(format!(
                    "available at zoom {z}: tiles x {}–{}, y {}–{} are outside its {nx} × {ny} \
                     tiles (x 0–{}, y 0–{}) in {of}",
                    r.start_x,
                    r.end_x,
                    r.start_y,
                    r.end_y,
                    nx - 1,
                    ny - 1
                ));
            }
        }
        Ok(())
    }
}

/// Slack on the world's edges: ingest takes a source up to 1e-9° past them as inside.
const EDGE_SLACK: f64 = 1e-6;

fn check_bounds(scheme: &str, bounds: [f64; 4]) -> Result<(), String> {
    let [west, south, east, north] = bounds;
    let bad = |why: &str| Err(format!("bounds {bounds:?}: {why}"));
    if !bounds.iter().all(|v| v.is_finite()) {
        return bad("not finite");
    }
    if scheme == "local" {
        // Columns and rows of the source grid; no wrap round a local grid.
        if west > east {
            return bad("west past east in a local grid");
        }
        return Ok(());
    }
    let lon = -180.0 - EDGE_SLACK..=180.0 + EDGE_SLACK;
    let lat = -90.0 - EDGE_SLACK..=90.0 + EDGE_SLACK;
    if !lon.contains(&west) || !lon.contains(&east) {
        return bad("longitudes must be within -180..180°");
    }
    if !lat.contains(&south) || !lat.contains(&north) {
        return bad("latitudes must be within -90..90°");
    }
    if south > north {
        return bad("south is north of north");
    }
    Ok(())
}

fn check_range(field: &str, [lo, hi]: [f64; 2]) -> Result<(), String> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(format!("{field} [{lo}, {hi}]: not finite"));
    }
    if lo > hi {
        return Err(format!("{field} [{lo}, {hi}]: lowest above highest"));
    }
    Ok(())
}

/// Per-dataset settings of the view-driven threshold (paper eq. 4), in height units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewParams {
    pub a: f64,
    pub b: f64,
}

/// An inclusive rectangle of tiles at one zoom (Cesium's layer.json form).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Availability {
    pub start_x: u32,
    pub start_y: u32,
    pub end_x: u32,
    pub end_y: u32,
}

impl Availability {
    /// Tiles in the rectangle, exactly (the whole u32 square holds 2^64, one more than a
    /// u64); 0 for an inverted one (a hand-edited header), not an underflow.
    pub fn tile_count(&self) -> u128 {
        let side = |start: u32, end: u32| end.checked_sub(start).map_or(0, |d| u128::from(d) + 1);
        side(self.start_x, self.end_x) * side(self.start_y, self.end_y)
    }
}

#[cfg(test)]
mod tests {
    use super::Availability;

    #[test]
    fn an_availability_counts_its_inclusive_rectangle() {
        let a = |start_x, start_y, end_x, end_y| Availability {
            start_x,
            start_y,
            end_x,
            end_y,
        };
        assert_eq!(a(0, 0, 0, 0).tile_count(), 1);
        assert_eq!(a(2, 5, 4, 5).tile_count(), 3);
        assert_eq!(a(1, 1, 2, 3).tile_count(), 6);
        assert_eq!(a(0, 0, u32::MAX, 0).tile_count(), 1 << 32);
        assert_eq!(a(0, 0, u32::MAX, u32::MAX).tile_count(), 1 << 64);
        assert_eq!(a(3, 0, 2, 9).tile_count(), 0);
        assert_eq!(a(0, 4, 9, 3).tile_count(), 0);
    }
}
