//! Sources across the antimeridian and sources going all the way round, on the geodetic
//! and mercator pyramids (`world.rs`).
//!
//! Why this is its own step: a world pyramid's levels are lattices of tile columns, and
//! each coarser zoom is the wavelet low-pass of the one below (`Level::coarser`), which
//! extends a level's ends symmetrically. A source across 180° would otherwise be two
//! pyramids whose seam columns are low-passed from different neighbours and crack apart,
//! and a global source's two ends, one meridian, likewise. So:
//!
//! 1. [`place_longitudes`]: longitudes are placed by whole turns so west is in
//!    [−180°, 180°); a source across 180° then runs past it, and its lattice runs in tile
//!    columns from x0 on past the tiling's last (nx). Coarser levels halve those indices
//!    as nx halves, so parents nest and the seam is an interior lattice column at every
//!    zoom: one column of heights both sides share.
//! 2. [`holds_a_column_twice`]: where some zoom would reach into one tile from both sides
//!    (a near-global source), the lattice is instead the world's width from −180°; so it is
//!    for a source covering every longitude ([`Round::wraps`]).
//! 3. [`Round`]: the source is read where it holds the point, else a whole turn away, else
//!    (a source covering the world) interpolated across the gap between its two ends;
//!    only then is an edge repeated.
//! 4. [`join_ends`]: every level as wide as the world has its two end columns, one
//!    meridian, set to their mean, before the next is made from it.
//! 5. [`fold`]: the root (zoom 0, widened to the whole world) folds a level running past
//!    nx round at the meridian opposite the data, so its ±180° columns are one.
//! 6. [`tile_columns`]: tile ids are taken modulo nx only where jobs and availability are
//!    made; a range past nx is published as two.
//!
//! Bounds follow CesiumJS's `Rectangle` convention (west past east across 180°), read
//! through `zerotile_codec::geo::antimeridian`.

use anyhow::{bail, Result};
use zerotile_codec::geo::tiling::lonlat_to_mercator;
use zerotile_codec::pyramid::Level;
use zerotile_codec::raster::Crs;

use super::resample::Source;

/// The source's longitudes (`west`, `east`, degrees) placed on the world: as they are within
/// ±180°; else shifted by whole turns so `west` is in [−180°, 180°), `east` then past 180°
/// when the source crosses the antimeridian (a source in 0..360° east of 180° is just west
/// of it). More than 360° is refused: the world would hold those meridians twice.
pub(super) fn place_longitudes(west: f64, east: f64) -> Result<(f64, f64)> {
    if west >= -180.0 - 1e-9 && east <= 180.0 + 1e-9 {
        return Ok((west, east));
    }
    if east - west > 360.0 + 1e-9 {
        bail!(
            "the source spans lon {west:.4}..{east:.4}, {:.4}° round: more than the world's \
             360°, so it would hold some meridians twice; crop it to 360° at most",
            east - west
        );
    }
    let turns = ((west + 180.0) / 360.0).floor();
    Ok((west - 360.0 * turns, east - 360.0 * turns))
}

/// Whether tile columns `x0..=x1` of zoom `z` (`nx` across, columns past it round the world
/// again) would hold some column twice at zoom `z` or any coarser one but 0, where each
/// zoom halves the columns. Zoom 0 is made whole by [`widen`].
pub(super) fn holds_a_column_twice(x0: u32, x1: u32, nx: u32, z: u8) -> bool {
    (0..u32::from(z)).any(|k| (x1 >> k) - (x0 >> k) + 1 > nx >> k)
}

/// Where the source is read when it is written past ±180° or goes all the way round: a
/// point it does not cover is looked for a whole turn east or west, in the source's own CRS
/// units; one in the gap between the east end of a source covering the world and its west
/// end a turn on is interpolated across that gap.
pub(super) struct Round {
    /// One turn: 360° or the web mercator world's width in metres.
    period: f64,
    /// The middle of the source's x extent.
    middle: f64,
    /// The x of the source's west and east sample centres.
    west: f64,
    east: f64,
    /// Whether the source covers every longitude: its ends at most one sample spacing
    /// apart round the back of the world (a grid on −180..180°, or −179.75..179.75° at
    /// 0.5°), so the gap between them is interpolated, not filled from either edge.
    pub(super) wraps: bool,
}

impl Round {
    pub(super) fn of(source: &Source, lonlat_bounds: [f64; 4]) -> Self {
        let to_crs = |lon: f64| match source.crs() {
            Crs::WebMercator => lonlat_to_mercator([lon, 0.0])[0],
            crs => {
                debug_assert_eq!(crs, Crs::Geographic, "world ingest reads lon/lat or 3857");
                lon
            }
        };
        let period = to_crs(180.0) - to_crs(-180.0);
        let (west, east) = (to_crs(lonlat_bounds[0]), to_crs(lonlat_bounds[2]));
        Self {
            period,
            middle: to_crs((lonlat_bounds[0] + lonlat_bounds[2]) / 2.0),
            west,
            east,
            wraps: east - west + source.column_spacing() >= period * (1.0 - 1e-12),
        }
    }

    /// The source's height at (`x`, `y`), read where the source holds that point: at `x`
    /// itself when the source has it among its samples (so sources within ±180° read as
    /// before), else a whole turn away; then, for a source covering the world, linearly
    /// across the gap between its east and west ends; then, as for any source, within half a
    /// sample of its edge (the edge repeated); the fill where it is nowhere. A global grid's
    /// edge border at one end is the other end's data.
    pub(super) fn height_at(&self, source: &Source, x: f64, y: f64) -> f64 {
        if source.holds(x, y) {
            return source.height_at(x, y);
        }
        // The source spans at most a turn, so a copy it holds is within one turn of the
        // turn nearest its middle.
        let near = ((self.middle - x) / self.period).round();
        let copies = [0.0, near - 1.0, near, near + 1.0].map(|k| x + k * self.period);
        if let Some(xk) = copies.into_iter().find(|&xk| source.holds(xk, y)) {
            return source.height_at(xk, y);
        }
        if self.wraps {
            // How far east of the east end, round the world, and the gap to the west end.
            let gap = self.west + self.period - self.east;
            let past = (x - self.east).rem_euclid(self.period);
            if gap > 0.0 && past < gap {
                let (a, b) = (
                    source.height_at(self.east, y),
                    source.height_at(self.west, y),
                );
                return a + (b - a) * (past / gap);
            }
        }
        copies
            .into_iter()
            .find(|&xk| source.covers(xk, y))
            .map_or(source.fill(), |xk| source.height_at(xk, y))
    }
}

/// The two end columns of a level as wide as the world, one meridian, made one: their mean.
pub(super) fn join_ends(level: &mut Level) {
    let (rows, cols) = (level.heights.rows(), level.heights.cols());
    for r in 0..rows {
        let mean = (*level.heights.get(r, 0) + *level.heights.get(r, cols - 1)) / 2.0;
        *level.heights.get_mut(r, 0) = mean;
        *level.heights.get_mut(r, cols - 1) = mean;
    }
}

/// The column, counted on past the world's last, that column `c` of a world lattice `cols`
/// wide (both ends on the antimeridian) takes from a level that goes round: the one of its
/// meridian within the turn that ends at longitude `gap`, so the lattice's ±180° columns
/// are one and the cut lies where the level holds no data.
pub(super) fn fold(c: usize, cols: usize, gap: f64) -> Option<usize> {
    let width = cols as i64 - 1;
    let cut = ((gap + 180.0) / 360.0 * width as f64).round() as i64;
    let start = cut - width;
    usize::try_from(start + (c as i64 - start).rem_euclid(width)).ok()
}

/// Tile columns `first..=last` of a zoom `nx` columns wide, those past the last the world's
/// first again, as ranges within the world: one, or two across the antimeridian.
pub(super) fn tile_columns(first: u32, last: u32, nx: u32) -> Vec<(u32, u32)> {
    if last < nx {
        vec![(first, last)]
    } else {
        vec![(first, nx - 1), (0, last - nx)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn longitudes_are_placed_by_whole_turns_from_west() {
        assert_eq!(place_longitudes(-72.0, -71.0).unwrap(), (-72.0, -71.0));
        assert_eq!(place_longitudes(175.0, 185.0).unwrap(), (175.0, 185.0));
        assert_eq!(place_longitudes(-185.0, -175.0).unwrap(), (175.0, 185.0));
        assert_eq!(place_longitudes(190.0, 200.0).unwrap(), (-170.0, -160.0));
        let err = place_longitudes(-181.0, 181.0).unwrap_err().to_string();
        assert!(err.contains("crop it to 360° at most"), "{err}");
    }

    #[test]
    fn tile_columns_past_the_last_are_the_first_again() {
        assert_eq!(tile_columns(3, 5, 8), [(3, 5)]);
        assert_eq!(tile_columns(6, 9, 8), [(6, 7), (0, 1)]);
        assert_eq!(tile_columns(0, 7, 8), [(0, 7)]);
    }

    /// A world lattice of 9 columns (8 cells, 45° each) and a level from column 5 on past
    /// the last to 11 (lon 45°..315° placed, i.e. 45° east round to −45°): each column takes
    /// the level's column of its meridian in the turn that ends opposite the data (360°,
    /// cut at column 12), so both ends take one column.
    #[test]
    fn the_fold_makes_both_ends_one_meridian() {
        let cols: Vec<Option<usize>> = (0..9).map(|c| fold(c, 9, 360.0)).collect();
        let want = [8, 9, 10, 11, 4, 5, 6, 7, 8].map(Some);
        assert_eq!(cols, want);
    }
}
