//! Heights above the geoid (EGM96) made heights above the WGS84 ellipsoid: h = H + N.
//!
//! SRTM and most national elevation models give orthometric heights H, above mean sea level
//! as the EGM96 geoid models it. Cesium's quantized-mesh and an ENU frame take heights above
//! the WGS84 ellipsoid; served as they are, SRTM terrain is off by N, the undulation of the
//! EGM96 geoid: −28 m in New Hampshire (the terrain 28 m too high), +41 m at Mount Fuji,
//! −107 m south of India. N is evaluated from the geoid's degree-360 spherical harmonics
//! (NGA's F477 program, as the `egm96` crate ports it).
//!
//! One evaluation costs about a millisecond, too slow for every vertex. N is smooth, so it
//! is evaluated at the nodes of a lattice, once each (kept), and interpolated bilinearly
//! between them. The finest lattice is 7.5′, half NGA's own 15′ grid: bilinear between its
//! nodes, N was within 0.15 m of the full sum at the roughest places tried (the Puerto Rico
//! trench, the Himalaya) and 0.03 m over N44W072, where 15′ gave 0.53 m and 0.09 m. The
//! lattice's step depends only on the span asked for, so the tiles of one zoom share a
//! lattice and a vertex on the edge of two of them gets one N: the offset opens no crack. A
//! tile of any zoom spans at most [`MAX_CELLS`] cells, so a world tile costs a few dozen
//! evaluations, not millions. Coarse lattices are far off (up to 49 m at 45°, 3.6 m at 1°,
//! at 300 random places) but only wide tiles take them, whose geometric error is far
//! larger (77 km at geodetic zoom 0, 2.4 km at zoom 5).
//!
//! Reference: F. G. Lemoine et al., "The Development of the Joint NASA GSFC and NIMA
//! Geopotential Model EGM96", NASA/TP-1998-206861; NGA's test values for F477 in the tests.

use std::collections::HashMap;
use std::str::FromStr;
use std::sync::{LazyLock, Mutex, PoisonError};

use serde::{Deserialize, Serialize};

use super::{Bounds, TileGeo};
use crate::zerotree::TerrainMesh;

/// What a dataset's heights are measured from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VerticalDatum {
    /// The EGM96 geoid (mean sea level): SRTM's, and most DEMs'. Offset by N where
    /// ellipsoidal heights are due.
    Egm96,
    /// The WGS84 ellipsoid itself: served as they are everywhere.
    Ellipsoid,
}

impl FromStr for VerticalDatum {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "egm96" => Ok(Self::Egm96),
            "ellipsoid" | "wgs84" => Ok(Self::Ellipsoid),
            _ => Err(format!(
                "vertical datum {s:?}: egm96 (heights above mean sea level, as SRTM's) or \
                 ellipsoid (above WGS84)"
            )),
        }
    }
}

/// The lattice steps, degrees: 7.5′ and coarser ones for wide spans. Each divides 180 and
/// 360, so a lattice has a node on both poles and wraps round the antimeridian.
const STEPS: [f64; 9] = [0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 10.0, 20.0, 45.0];

/// Cells across the span a lattice is chosen for, at most (unless the coarsest step is
/// finer than the span allows).
pub const MAX_CELLS: f64 = 8.0;

/// Nodes kept before the cache starts over: ~50 MB with the map's buckets, a quarter of
/// the world at 7.5′.
const MAX_NODES: usize = 1 << 20;

/// The lattice for a mesh `span` degrees of longitude across: the finest whose cells it
/// spans at most [`MAX_CELLS`] of.
pub fn lattice_for(span: f64) -> Lattice {
    let level = STEPS
        .iter()
        .position(|&s| span / s <= MAX_CELLS)
        .unwrap_or(STEPS.len() - 1);
    Lattice { level: level as u8 }
}

/// The nodes over the box `west`, `south`, `east`, `north` (degrees; west past east crosses
/// the antimeridian) on the lattice of its larger side. A tile's is its width (no tile is
/// taller than wide), so the tiles of a zoom share a lattice; a tall, thin box's is its
/// height, so it fetches a few dozen nodes, not a column of thousands.
pub fn patch_over(west: f64, south: f64, east: f64, north: f64) -> Patch {
    let wide = Bounds::from([west, south, east, north]).lon_width();
    lattice_for(wide.max((north - south).abs())).patch(west, south, east, north)
}

/// One of the [`STEPS`] lattices; see [`lattice_for`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lattice {
    level: u8,
}

impl Lattice {
    /// The finest lattice, 7.5′.
    pub const FINEST: Self = Self { level: 0 };

    /// Its step in degrees.
    pub fn step(self) -> f64 {
        STEPS[usize::from(self.level)]
    }

    /// Cells from pole to pole and round a parallel.
    fn cells(self) -> (i32, i32) {
        let step = self.step();
        ((180.0 / step) as i32, (360.0 / step) as i32)
    }

    /// N (metres) at `lon`, `lat` (degrees; any longitude, latitude clamped to ±90),
    /// interpolated bilinearly between this lattice's nodes of EGM96.
    pub fn undulation(self, lon: f64, lat: f64) -> f64 {
        self.interpolate(lon, lat, |i, j| node(self.level, i, j))
    }

    /// The nodes over the box `west`, `south`, `east`, `north` (degrees; west past east
    /// crosses the antimeridian), fetched once: [`Patch::undulation`] is then
    /// [`Lattice::undulation`] without a lock on the shared nodes for each of a mesh's
    /// vertices.
    pub fn patch(self, west: f64, south: f64, east: f64, north: f64) -> Patch {
        let (_, cols) = self.cells();
        let i0 = self.row_of(south.min(north)).0;
        let n_rows = self.row_of(south.max(north)).0 + 2 - i0;
        let j0 = self.column_of(west).0;
        let width = Bounds::from([west, south, east, north]).lon_width();
        // A NaN width casts to 0: the patch then holds two columns, and the rest come from
        // the shared nodes.
        let n_cols = ((width / self.step()).ceil() as i32)
            .saturating_add(2)
            .clamp(1, cols);
        let values = (i0..i0 + n_rows)
            .flat_map(|i| (j0..j0 + n_cols).map(move |j| (i, j % cols)))
            .map(|(i, j)| node(self.level, i, j))
            .collect();
        Patch {
            lattice: self,
            i0,
            j0,
            n_rows,
            n_cols,
            values,
        }
    }

    /// N at `lon`, `lat` bilinear between the nodes `n(i, j)` gives.
    fn interpolate(self, lon: f64, lat: f64, n: impl Fn(i32, i32) -> f64) -> f64 {
        if !lon.is_finite() || !lat.is_finite() {
            return 0.0;
        }
        let (i, fy) = self.row_of(lat);
        let (j, j1, fx) = self.column_of(lon);
        // Along the meridians first: [`OnGrid`] does that once per row, in these steps.
        let west = n(i, j) * (1.0 - fy) + n(i + 1, j) * fy;
        let east = n(i, j1) * (1.0 - fy) + n(i + 1, j1) * fy;
        west * (1.0 - fx) + east * fx
    }

    /// Row `i` and fraction `fy` of latitude `lat` (finite), as [`Lattice::interpolate`]
    /// takes them.
    fn row_of(self, lat: f64) -> (i32, f64) {
        let (rows, _) = self.cells();
        let y = ((lat.clamp(-90.0, 90.0) + 90.0) / self.step()).clamp(0.0, f64::from(rows));
        let i = (y.floor() as i32).min(rows - 1);
        (i, y - f64::from(i))
    }

    /// Columns `j`, `j + 1` (wrapped) and fraction `fx` of longitude `lon` (finite).
    fn column_of(self, lon: f64) -> (i32, i32, f64) {
        let (_, cols) = self.cells();
        let x = (lon + 180.0).rem_euclid(360.0) / self.step();
        let j = (x.floor() as i32).min(cols - 1);
        (j, (j + 1) % cols, x - f64::from(j))
    }
}

/// A lattice's nodes over a box, held by the mesh being raised; see [`Lattice::patch`].
#[derive(Clone, Debug)]
pub struct Patch {
    lattice: Lattice,
    /// The first node's row and column, and how many of each are held, row-major.
    i0: i32,
    j0: i32,
    n_rows: i32,
    n_cols: i32,
    values: Vec<f64>,
}

impl Patch {
    /// How many nodes it holds.
    pub fn nodes(&self) -> usize {
        self.values.len()
    }

    /// [`Lattice::undulation`], from the nodes held where they cover the point.
    pub fn undulation(&self, lon: f64, lat: f64) -> f64 {
        self.lattice.interpolate(lon, lat, |i, j| {
            self.held(i, j)
                .unwrap_or_else(|| node(self.lattice.level, i, j))
        })
    }

    /// Column `j`'s place among the columns held, if it is one.
    fn column(&self, j: i32) -> Option<i32> {
        let (_, cols) = self.lattice.cells();
        let dj = (j - self.j0).rem_euclid(cols);
        (dj < self.n_cols).then_some(dj)
    }

    /// The index in `values` of node (`i`, `j`), if held.
    fn index(&self, i: i32, j: i32) -> Option<usize> {
        let di = i - self.i0;
        let dj = self.column(j).filter(|_| (0..self.n_rows).contains(&di))?;
        Some((di * self.n_cols + dj) as usize)
    }

    fn held(&self, i: i32, j: i32) -> Option<f64> {
        self.index(i, j).map(|k| self.values[k])
    }

    /// [`Patch::undulation`] at the points of a grid, `lons` across and `lats` down (a
    /// tile's sample lattice), bit for bit, in a few nanoseconds a point: each row's
    /// latitude step is taken once for the patch's columns, leaving one step along the
    /// parallel per point.
    pub fn on_grid(&self, lons: &[f64], lats: &[f64]) -> OnGrid<'_> {
        let columns = lons
            .iter()
            .map(|&lon| {
                let (j, j1, fx) = self.lattice.column_of(lon);
                let dj = |j| self.column(j).map(|d| d as usize);
                (lon.is_finite())
                    .then(|| Some((dj(j)?, dj(j1)?, fx)))
                    .flatten()
            })
            .collect();
        let rows = lats
            .iter()
            .map(|&lat| {
                let (i, fy) = self.lattice.row_of(lat);
                let along = |dj: i32| {
                    let j = self.j0 + dj;
                    Some(self.held(i, j)? * (1.0 - fy) + self.held(i + 1, j)? * fy)
                };
                (lat.is_finite())
                    .then(|| (0..self.n_cols).map(along).collect::<Option<Vec<f64>>>())
                    .flatten()
            })
            .collect();
        OnGrid {
            patch: self,
            lons: lons.to_vec(),
            lats: lats.to_vec(),
            columns,
            rows,
        }
    }
}

/// Raises `mesh`, over `tile`, by `patch`'s undulation at each vertex. The patch's lattice
/// is the tile's zoom's and a vertex's place is exact on every edge, so a vertex on an edge
/// two tiles share is raised by one value in both: the offset opens no crack.
pub fn raise(mesh: &mut TerrainMesh, tile: &TileGeo, patch: &Patch) {
    let last = mesh.cols.max(2) - 1;
    let at = |k: usize| k as f64 / last as f64;
    // Exact at both edges, as the neighbour's own edge is.
    let lon_at = |t: f64| tile.west * (1.0 - t) + tile.east * t;
    // The sample lattice's longitudes and latitudes, exact on the edges.
    let lons: Vec<f64> = (0..=last).map(|k| lon_at(at(k))).collect();
    let lats: Vec<f64> = (0..=last)
        .map(|k| match k {
            0 => tile.north,
            k if k == last => tile.south,
            k => tile.latitude_at(at(k)),
        })
        .collect();
    let grid = patch.on_grid(&lons, &lats);
    let sample =
        |v: f64| (v.fract() == 0.0 && (0.0..=last as f64).contains(&v)).then_some(v as usize);
    for [c, r, h] in &mut mesh.positions {
        // Vertices sit on samples; one that did not would be placed on its own.
        *h += match (sample(*c), sample(*r)) {
            (Some(col), Some(row)) => grid.at(col, row),
            _ => patch.undulation(lon_at(*c / last as f64), tile.latitude_at(*r / last as f64)),
        };
    }
}

/// A patch's undulation over a grid's points; see [`Patch::on_grid`].
pub struct OnGrid<'a> {
    patch: &'a Patch,
    lons: Vec<f64>,
    lats: Vec<f64>,
    /// Per column, the patch columns either side and the fraction between them: `None`
    /// where the patch does not hold them (the point is worked out whole).
    columns: Vec<Option<(usize, usize, f64)>>,
    /// Per row, the undulation at its latitude on each of the patch's columns.
    rows: Vec<Option<Vec<f64>>>,
}

impl OnGrid<'_> {
    /// The undulation at grid point (`col`, `row`); 0 past the grid.
    pub fn at(&self, col: usize, row: usize) -> f64 {
        match (self.columns.get(col), self.rows.get(row)) {
            (Some(Some((a, b, fx))), Some(Some(along))) => along[*a] * (1.0 - fx) + along[*b] * fx,
            (Some(_), Some(_)) => self.patch.undulation(self.lons[col], self.lats[row]),
            _ => 0.0,
        }
    }
}

/// N of the nodes evaluated, by (lattice level, row, column).
type Nodes = HashMap<(u8, i32, i32), f64>;

/// N at node (`i`, `j`) of lattice `level`: latitude −90° + i·step, longitude −180° + j·step.
fn node(level: u8, i: i32, j: i32) -> f64 {
    static NODES: LazyLock<Mutex<Nodes>> = LazyLock::new(|| Mutex::new(HashMap::new()));
    // A poisoned lock guards only values that are recomputed the same.
    let nodes = || NODES.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(&n) = nodes().get(&(level, i, j)) {
        return n;
    }
    let step = STEPS[usize::from(level)];
    // Outside the lock: two threads may both work one node out, to the same value.
    let n = undulation_exact(-180.0 + f64::from(j) * step, -90.0 + f64::from(i) * step);
    let mut held = nodes();
    if held.len() >= MAX_NODES {
        held.clear();
    }
    held.insert((level, i, j), n);
    n
}

/// N (metres) at `lon`, `lat` (degrees) from EGM96's spherical harmonics: ~1 ms.
pub fn undulation_exact(lon: f64, lat: f64) -> f64 {
    egm96::egm96_compute_altitude_offset(lat, lon)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The check values NGA ships with EGM96: latitude, east longitude (0–360), N in metres
    /// to the millimetre. The harmonic sum meets them within 4 mm.
    const NGA: [(f64, f64, f64); 6] = [
        (38.628_155, 269.779_155, -31.628),
        (-14.621_217, 305.021_114, -2.969),
        (46.874_319, 102.448_729, -43.575),
        (-23.617_446, 133.874_712, 15.871),
        (38.625_473, 359.999_500, 50.066),
        (-0.466_744, 0.002_300, 17.329),
    ];

    #[test]
    fn exact_matches_ngas_check_values() {
        for (lat, lon, n) in NGA {
            let got = undulation_exact(lon, lat);
            assert!((got - n).abs() < 0.005, "{lat}, {lon}: {got} against {n}");
            // West longitudes are the same meridians.
            let west = undulation_exact(lon - 360.0, lat);
            assert!((west - got).abs() < 1e-9, "{lon}: {west} against {got}");
        }
    }

    #[test]
    fn finest_lattice_is_close_to_the_exact_geoid() {
        // Over the test data's places (New Hampshire, Fuji, Texas), NGA's points and two of
        // the geoid's roughest (the Puerto Rico trench, the Himalaya), off the nodes.
        let places = [
            (-71.63, 44.41),
            (138.73, 35.36),
            (-98.17, 33.21),
            (-65.93, 19.61),
            (86.93, 27.99),
        ];
        let nga = NGA.map(|(lat, lon, _)| (lon, lat));
        for (lon, lat) in places.into_iter().chain(nga) {
            let exact = undulation_exact(lon, lat);
            let lattice = Lattice::FINEST.undulation(lon, lat);
            assert!(
                (lattice - exact).abs() < 0.15,
                "{lon}, {lat}: {lattice} against {exact}"
            );
        }
    }

    #[test]
    fn nodes_are_exact_and_cells_interpolate_between_them() {
        let l = lattice_for(3.0); // 0.5°: 6 cells
        assert_eq!(l.step(), 0.5);
        let at = |lon, lat| l.undulation(lon, lat);
        let exact = undulation_exact(-71.5, 44.5);
        assert_eq!(at(-71.5, 44.5), exact);
        let mid = at(-71.25, 44.5);
        let (w, e) = (exact, undulation_exact(-71.0, 44.5));
        assert!((mid - (w + e) / 2.0).abs() < 1e-9, "{mid} between {w}, {e}");
        // The antimeridian: 180° and −180° are one meridian, one node.
        assert_eq!(at(180.0, 10.0), at(-180.0, 10.0));
        assert!((at(179.999, 10.0) - at(-179.999, 10.0)).abs() < 0.01);
        // Poles: one value whatever the longitude (every node there is the pole).
        assert!((at(0.0, 90.0) - at(123.0, 90.0)).abs() < 1e-6);
        assert!((at(0.0, -95.0) - at(0.0, -90.0)).abs() < 1e-12);
        assert_eq!(at(f64::NAN, 0.0), 0.0);
    }

    #[test]
    fn lattices_coarsen_with_the_span_to_a_bounded_node_count() {
        assert_eq!(lattice_for(0.01), Lattice::FINEST);
        assert_eq!(lattice_for(1.0).step(), 0.125);
        assert_eq!(lattice_for(1.1).step(), 0.25);
        assert_eq!(lattice_for(2.1).step(), 0.5);
        assert_eq!(lattice_for(180.0).step(), 45.0);
        assert_eq!(lattice_for(360.0).step(), 45.0);
        for span in [0.1, 1.0, 5.0, 11.25, 22.5, 45.0, 90.0, 180.0] {
            let step = lattice_for(span).step();
            assert!(span / step <= MAX_CELLS, "{span}° at {step}°");
            // And not coarser than it needs: the next finer would be too many cells.
            if let Some(finer) = STEPS.iter().rev().find(|&&s| s < step) {
                assert!(span / finer > MAX_CELLS, "{span}° could take {finer}°");
            }
            for s in STEPS {
                assert_eq!((180.0 / s).fract(), 0.0);
                assert_eq!((360.0 / s).fract(), 0.0);
            }
        }
    }

    /// A patch answers as its lattice does, bit for bit, inside its box and out, across
    /// the antimeridian too.
    #[test]
    fn a_patch_is_its_lattice() {
        for (w, s, e, n) in [
            (-72.0, 44.0, -71.0, 45.0),
            (179.5, -10.0, -179.5, -9.0),
            (-180.0, -90.0, 180.0, 90.0),
            (10.0, 89.5, 11.0, 90.0),
        ] {
            let span = if e >= w { e - w } else { e + 360.0 - w };
            let l = lattice_for(span);
            let p = l.patch(w, s, e, n);
            for k in 0..=20 {
                for m in 0..=20 {
                    let lon = w + span * f64::from(k) / 20.0;
                    let lat = s + (n - s) * f64::from(m) / 20.0;
                    assert_eq!(
                        p.undulation(lon, lat),
                        l.undulation(lon, lat),
                        "{lon} {lat}"
                    );
                }
            }
            // Outside the box, from the shared nodes.
            assert_eq!(p.undulation(w - 30.0, 0.0), l.undulation(w - 30.0, 0.0));
            assert!(p.values.len() <= ((MAX_CELLS + 3.0) * (MAX_CELLS + 3.0)) as usize);
        }
        // On a grid, bit for bit: a tile's lattice of samples, and one past its patch.
        for (w, s, e, n) in [(-72.0, 44.0, -71.8, 44.2), (179.9, 0.0, -179.9, 0.2)] {
            let span = if e >= w { e - w } else { e + 360.0 - w };
            let p = lattice_for(span).patch(w, s, e, n);
            let lons: Vec<f64> = (0..=16).map(|k| w + span * f64::from(k) / 16.0).collect();
            let mut lats: Vec<f64> = (0..=16)
                .map(|k| n - (n - s) * f64::from(k) / 16.0)
                .collect();
            lats.push(n + 3.0);
            let grid = p.on_grid(&lons, &lats);
            for (c, &lon) in lons.iter().enumerate() {
                for (r, &lat) in lats.iter().enumerate() {
                    assert_eq!(grid.at(c, r), p.undulation(lon, lat), "{lon} {lat}");
                }
            }
            assert_eq!(grid.at(lons.len(), 0), 0.0);
        }
        let nan = Lattice::FINEST.patch(f64::NAN, 0.0, f64::NAN, 1.0);
        assert_eq!(nan.undulation(f64::NAN, 0.5), 0.0);
    }

    /// A vertex on the edge two tiles of a zoom share is raised by one value in both, so the
    /// offset opens no crack: east–west and north–south, in both row spacings.
    #[test]
    fn neighbours_raise_their_shared_edge_alike() {
        let mesh = |positions| TerrainMesh {
            rows: 257,
            cols: 257,
            positions,
            triangles: Vec::new(),
        };
        let column = |col: f64| mesh((0..=256).map(|k| [col, f64::from(k), 100.0]).collect());
        let row = |row: f64| mesh((0..=256).map(|k| [f64::from(k), row, 100.0]).collect());
        let raised = |mut m: TerrainMesh, g: &TileGeo| {
            let patch = lattice_for(g.east - g.west).patch(g.west, g.south, g.east, g.north);
            raise(&mut m, g, &patch);
            m.positions.iter().map(|p| p[2]).collect::<Vec<_>>()
        };
        for geo in [
            |w: f64, s: f64| TileGeo::geodetic(w, s, w + 0.703_125, s + 0.703_125),
            |w: f64, s: f64| TileGeo {
                rows: crate::geo::RowSpacing::MercatorY,
                ..TileGeo::geodetic(w, s, w + 0.703_125, s + 0.703_125)
            },
        ] {
            // West tile's east column against the east tile's west column.
            let (a, b) = (geo(-109.687_5, 15.468_75), geo(-108.984_375, 15.468_75));
            let east = raised(column(256.0), &a);
            let west = raised(column(0.0), &b);
            assert_eq!(east, west);
            // North tile's south row against the south tile's north row.
            let (n, s) = (geo(-109.687_5, 16.171_875), geo(-109.687_5, 15.468_75));
            let south = raised(row(256.0), &n);
            let north = raised(row(0.0), &s);
            assert_eq!(south, north);
            assert!(south.iter().all(|&h| (h - 100.0).abs() > 1.0));
        }
    }

    #[test]
    fn datum_names_read_back() {
        for (d, name) in [
            (VerticalDatum::Egm96, "egm96"),
            (VerticalDatum::Ellipsoid, "ellipsoid"),
        ] {
            assert_eq!(name.parse::<VerticalDatum>(), Ok(d));
            assert_eq!(serde_json::to_string(&d).unwrap(), format!("\"{name}\""));
        }
        assert!("navd88"
            .parse::<VerticalDatum>()
            .unwrap_err()
            .contains("egm96"));
    }
}
