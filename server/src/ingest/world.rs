//! The geodetic (EPSG:4326, Cesium's TMS grid) and mercator (EPSG:3857, XYZ) pyramids: the
//! deepest zoom is resampled from the source at the tiling's own sample positions, every
//! coarser zoom is the wavelet low-pass of the one below (`zerotile_codec::pyramid`).
//!
//! Lattices are kept with tile rows counted from the north (image order), so a level's
//! children nest by halving indices in both schemes; geodetic tile ids flip to TMS rows
//! (from the south) only when they are written.

use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use zerotile_codec::container::Availability;
use zerotile_codec::geo::tiling::{
    lonlat_to_mercator, mercator_to_lonlat, Bounds, MERCATOR_MAX_LATITUDE,
};
use zerotile_codec::geo::{Resolution, Scheme, TileId, Tiling};
use zerotile_codec::pyramid::Level;
use zerotile_codec::raster::Crs;
use zerotile_codec::Grid;

use super::antimeridian::{
    fold, holds_a_column_twice, join_ends, place_longitudes, tile_columns, Round,
};
use super::resample::Source;
use super::TILE_SIDE;

/// Samples in the deepest lattice before ingest refuses (8 bytes each): 2^27 ≈ 1 GiB.
const MAX_LATTICE_SAMPLES: u64 = 1 << 27;

/// A tile to encode: (level index, lattice tile x, lattice tile y from the north, its id).
pub type Job = (usize, u32, u32, TileId);

/// Every level of a world pyramid, the tiles to encode and what layer.json will publish.
pub struct WorldPyramid {
    pub levels: Vec<Level>,
    pub max_zoom: u8,
    pub jobs: Vec<Job>,
    pub available: Vec<Vec<Availability>>,
    /// West, south, east, north of the source as stored, degrees: on mercator, within
    /// ±85.05°; west past east when the source crosses the antimeridian (Cesium's
    /// `Rectangle` convention), −180 and 180 when it goes all the way round.
    pub bounds: [f64; 4],
    /// The source's latitudes (south, north) when mercator could not store all of them.
    pub clipped_lat: Option<[f64; 2]>,
}

/// Builds the pyramid of `source` in `scheme` down to `max_zoom` (default: the shallowest
/// zoom as fine as the source). The source is freed once the deepest lattice is sampled:
/// the peak is the two side by side, then the lattice and a half-size scratch per coarser
/// level (`Level::coarser`).
pub fn build(source: Source, scheme: Scheme, max_zoom: Option<u8>) -> Result<WorldPyramid> {
    let tiling = Tiling::new(scheme, TILE_SIDE as u32)?;
    let (rows, cols) = source.size();
    let lonlat_of = |r: f64, c: f64| -> [f64; 2] {
        let p = source.position(r, c);
        match source.crs() {
            Crs::WebMercator => mercator_to_lonlat(p),
            _ => p,
        }
    };
    // The source's footprint: its corner sample centres (north-up grids; a rotated grid
    // still has its extremes at corners of an affine image).
    let corners = [
        lonlat_of(0.0, 0.0),
        lonlat_of(0.0, (cols - 1) as f64),
        lonlat_of((rows - 1) as f64, 0.0),
        lonlat_of((rows - 1) as f64, (cols - 1) as f64),
    ];
    let fold = |f: fn(f64, f64) -> f64, k: usize, init: f64| {
        corners
            .iter()
            .filter_map(|p| p.get(k))
            .fold(init, |a, &b| f(a, b))
    };
    let raw = [
        fold(f64::min, 0, f64::INFINITY),
        fold(f64::min, 1, f64::INFINITY),
        fold(f64::max, 0, f64::NEG_INFINITY),
        fold(f64::max, 1, f64::NEG_INFINITY),
    ];
    if !raw.iter().all(|v| v.is_finite()) || raw[1] < -90.0 - 1e-9 || raw[3] > 90.0 + 1e-9 {
        bail!(
            "the source spans lon {:.4}..{:.4}, lat {:.4}..{:.4}: outside the world",
            raw[0],
            raw[2],
            raw[1],
            raw[3]
        );
    }
    // Longitudes go round: a source written past ±180° is placed a whole turn over.
    let (west, east) = place_longitudes(raw[0], raw[2])?;
    let crosses = east > 180.0 + 1e-9;
    let bounds = [west, raw[1], east, raw[3]];

    let max_zoom = match max_zoom {
        Some(z) => z,
        None => {
            let spacing = source.spacing();
            tiling.default_max_zoom(match source.crs() {
                Crs::WebMercator => Resolution::Metres(spacing),
                _ => Resolution::Degrees(spacing),
            })?
        }
    };
    // Web mercator stops at ±85.05°: a source wholly past it would be stored as fill only
    // (the tile range clamps to the tiling's edge rather than coming back empty).
    if scheme == Scheme::Mercator
        && (bounds[1] >= MERCATOR_MAX_LATITUDE || bounds[3] <= -MERCATOR_MAX_LATITUDE)
    {
        bail!(
            "the source spans lat {:.4}..{:.4}, wholly beyond web mercator's ±{:.4}°: use \
             --scheme geodetic",
            bounds[1],
            bounds[3],
            MERCATOR_MAX_LATITUDE
        );
    }
    // Partly past it: the rows beyond are not stored, and the bounds say what is.
    let mut bounds = bounds;
    let mut clipped_lat = None;
    if scheme == Scheme::Mercator
        && (bounds[1] < -MERCATOR_MAX_LATITUDE || bounds[3] > MERCATOR_MAX_LATITUDE)
    {
        clipped_lat = Some([bounds[1], bounds[3]]);
        bounds[1] = bounds[1].max(-MERCATOR_MAX_LATITUDE);
        bounds[3] = bounds[3].min(MERCATOR_MAX_LATITUDE);
    }
    // Tile columns from `x0` to `x1`, counted on past the last (`nx`) round the world when
    // the source crosses the antimeridian: its part east of 180° is in columns `nx` on.
    let published = Bounds {
        min_x: bounds[0],
        min_y: bounds[1],
        max_x: if crosses {
            bounds[2] - 360.0
        } else {
            bounds[2].min(180.0)
        },
        max_y: bounds[3],
    };
    let ranges = published
        .split_at_antimeridian()
        .iter()
        .map(|part| tiling.tile_range(max_zoom, part))
        .collect::<Result<Option<Vec<_>>, _>>()?
        .context("the source lies outside the tiling (beyond mercator's ±85.05°?)")?;
    let (nx, _) = tiling.tiles_per_axis(max_zoom)?;
    let (range, x1) = match ranges.as_slice() {
        [west, east] => (*west, east.x1 + nx),
        [range, ..] => (*range, range.x1),
        [] => bail!("internal: splitting the source's bounds gave no part"),
    };
    let x0 = range.x0;
    // Coarser zooms halve the columns: where one would hold a column of tiles twice (a
    // source reaching into one tile from both sides), the lattice is the world's width from
    // −180° instead, each column sampled once. So it is for a source that covers every
    // longitude (its ends a sample apart or less round the back, as a global grid within
    // ±180° is): its ends meet at the antimeridian whichever side of it they lie.
    let round = Round::of(&source, raw);
    let goes_round = crosses || round.wraps;
    let whole_world = round.wraps || (crosses && holds_a_column_twice(x0, x1, nx, max_zoom));
    let (x0, x1) = if whole_world { (0, nx - 1) } else { (x0, x1) };

    // Rows from the north.
    let (_, ny) = tiling.tiles_per_axis(max_zoom)?;
    let north_row = |y: u32| match scheme {
        Scheme::Geodetic => ny - 1 - y,
        _ => y,
    };
    let (ty0, ty1) = {
        let (a, b) = (north_row(range.y0), north_row(range.y1));
        (a.min(b), a.max(b))
    };
    let (tw, th) = (x1 - x0 + 1, ty1 - ty0 + 1);
    let cells = (TILE_SIDE - 1) as u64;
    let (lat_cols, lat_rows) = (u64::from(tw) * cells + 1, u64::from(th) * cells + 1);
    if lat_cols * lat_rows > MAX_LATTICE_SAMPLES {
        bail!(
            "zoom {max_zoom} needs a {lat_rows}×{lat_cols} lattice ({} tiles): pass a smaller \
             --max-zoom",
            u64::from(tw) * u64::from(th)
        );
    }

    let deepest = lattice(&source, &round, &tiling, scheme, max_zoom, x0, ty0, tw, th)?;
    let fill = source.fill();
    drop(source);
    // Every coarser zoom, each the low-pass of the one below, the root widened to the world.
    let levels = coarser_levels(deepest, &tiling, goes_round, fill, bounds)?;
    // One job a tile, ids modulo the world; availability exactly those tiles.
    let (jobs, available) = jobs_and_availability(&levels, &tiling, scheme, max_zoom)?;
    // What is published: west past east across the antimeridian, the whole circle round.
    let bounds = published_bounds(bounds, crosses, round.wraps);
    Ok(WorldPyramid {
        levels,
        max_zoom,
        jobs,
        available,
        bounds,
        clipped_lat,
    })
}

/// The levels from `deepest` up to zoom 0, each the wavelet low-pass of the one below; a
/// level going round the world as wide as it has its ends joined first; the root widened to
/// every root tile.
fn coarser_levels(
    deepest: Level,
    tiling: &Tiling,
    goes_round: bool,
    fill: f64,
    bounds: [f64; 4],
) -> Result<Vec<Level>> {
    let mut levels = vec![deepest];
    while let Some(level) = levels.last_mut() {
        // A level round the antimeridian as wide as the world has its two ends on one
        // meridian, neighbours: one column of heights, not the two a low-pass left there.
        if goes_round && level.tiles(TILE_SIDE).0 == tiling.tiles_per_axis(level.zoom)?.0 {
            join_ends(level);
        }
        if level.zoom == 0 {
            break;
        }
        let next = level.coarser_in_world(TILE_SIDE, fill);
        levels.push(next);
    }
    // Clients ask for every root tile (CesiumJS requests both geodetic ones): give zoom 0
    // the whole world, filled beyond what the low-pass covers. Across the antimeridian the
    // root goes round, cut opposite the data (mid-way round from its east edge to its west).
    if let Some(root) = levels.last_mut() {
        let (nx0, ny0) = tiling.tiles_per_axis(0)?;
        let gap = (bounds[2] + bounds[0] + 360.0) / 2.0;
        *root = widen(root, nx0, ny0, fill, gap);
    }

    Ok(levels)
}

/// The tiles to encode, (level index, lattice tile x, lattice tile y from the north, id),
/// and per zoom what layer.json publishes of them.
fn jobs_and_availability(
    levels: &[Level],
    tiling: &Tiling,
    scheme: Scheme,
    max_zoom: u8,
) -> Result<(Vec<Job>, Vec<Vec<Availability>>)> {
    let mut jobs = Vec::new();
    let mut available = vec![Vec::new(); usize::from(max_zoom) + 1];
    for (k, level) in levels.iter().enumerate() {
        let (w, h) = level.tiles(TILE_SIDE);
        let (nx, ny) = tiling.tiles_per_axis(level.zoom)?;
        if w > nx {
            bail!(
                "internal: zoom {} would hold a column of tiles twice ({w} of {nx}); the \
                 whole-world lattice should have prevented it",
                level.zoom
            );
        }
        let id_y = |row: u32| match scheme {
            Scheme::Geodetic => ny - 1 - row,
            _ => row,
        };
        let (ya, yb) = (id_y(level.tile_y0), id_y(level.tile_y0 + h - 1));
        let Some(at_zoom) = available.get_mut(usize::from(level.zoom)) else {
            anyhow::bail!("level zoom {} past --max-zoom {max_zoom}", level.zoom);
        };
        // Columns past the last are the world's first again: a range across the
        // antimeridian is published as its two parts.
        for (start_x, end_x) in tile_columns(level.tile_x0, level.tile_x0 + w - 1, nx) {
            at_zoom.push(Availability {
                start_x,
                start_y: ya.min(yb),
                end_x,
                end_y: ya.max(yb),
            });
        }
        for ly in level.tile_y0..level.tile_y0 + h {
            for lx in level.tile_x0..level.tile_x0 + w {
                jobs.push((k, lx, ly, TileId::new(level.zoom, lx % nx, id_y(ly))));
            }
        }
    }
    Ok((jobs, available))
}

/// The bounds published for `bounds` (west, south, east, north; east past 180° when the
/// source `crosses`): west past east across the antimeridian (Cesium's Rectangle
/// convention), −180..180 when it spans the whole circle or `wraps` (covers every longitude
/// with its samples' cells: a cell-registered global grid's centres stop half a cell short
/// of ±180°, and 0..360's of 0°, which read as a world with a gap).
fn published_bounds(bounds: [f64; 4], crosses: bool, wraps: bool) -> [f64; 4] {
    match crosses {
        _ if wraps => [-180.0, bounds[1], 180.0, bounds[3]],
        false => bounds,
        true if bounds[2] - bounds[0] >= 360.0 - 1e-9 => [-180.0, bounds[1], 180.0, bounds[3]],
        true => [bounds[0], bounds[1], bounds[2] - 360.0, bounds[3]],
    }
}

/// The deepest lattice: `tw × th` tiles from tile (`x0`, `y0`) (rows from the north; columns
/// past the tiling's last are its first again), every sample taken from the source at the
/// tiling's position for it.
#[allow(
    clippy::too_many_arguments,
    reason = "one call site; a struct would only rename them"
)]
fn lattice(
    source: &Source,
    round: &Round,
    tiling: &Tiling,
    scheme: Scheme,
    z: u8,
    x0: u32,
    y0: u32,
    tw: u32,
    th: u32,
) -> Result<Level> {
    let last = (TILE_SIDE - 1) as u32;
    let (cols, rows) = (
        tw as usize * TILE_SIDE - (tw as usize - 1),
        th as usize * TILE_SIDE - (th as usize - 1),
    );
    let (nx, ny) = tiling.tiles_per_axis(z)?;
    // Which tile and in-tile sample a lattice index falls on: the last tile owns the end.
    let split = |i: usize, n: u32| -> (u32, u32) {
        let t = ((i / last as usize) as u32).min(n - 1);
        (t, i as u32 - t * last)
    };
    let mut data = vec![0.0; rows * cols];
    data.par_chunks_mut(cols)
        .enumerate()
        .try_for_each(|(r, out)| -> Result<()> {
            let (tr, row) = split(r, th);
            let north = y0 + tr;
            let y = match scheme {
                Scheme::Geodetic => ny - 1 - north,
                _ => north,
            };
            for (c, h) in out.iter_mut().enumerate() {
                let (tc, col) = split(c, tw);
                let p = tiling.sample_position(TileId::new(z, (x0 + tc) % nx, y), row, col)?;
                let lonlat = match scheme {
                    Scheme::Mercator => mercator_to_lonlat(p),
                    _ => p,
                };
                let [sx, sy] = match source.crs() {
                    Crs::WebMercator => lonlat_to_mercator(lonlat),
                    _ => lonlat,
                };
                *h = round.height_at(source, sx, sy);
            }
            Ok(())
        })?;
    Ok(Level {
        zoom: z,
        tile_x0: x0,
        tile_y0: y0,
        heights: Grid::new(rows, cols, data)?,
    })
}

/// `level` placed in a lattice of `nx × ny` tiles from tile (0, 0), filled elsewhere. A level
/// reaching past column `nx` (a source across the antimeridian) goes round the world: each
/// column takes the level's column at its meridian within the turn that ends at longitude
/// `gap` (opposite the data), so the columns at ±180° are one.
fn widen(level: &Level, nx: u32, ny: u32, fill: f64, gap: f64) -> Level {
    let step = TILE_SIDE - 1;
    let (cols, rows) = (nx as usize * step + 1, ny as usize * step + 1);
    let (c0, r0) = (level.tile_x0 as usize * step, level.tile_y0 as usize * step);
    let src = &level.heights;
    // The level's column for lattice column `c`: itself, or the one of its meridian in the
    // turn that ends at `gap` when the level goes round.
    let goes_round = c0 + src.cols() > cols;
    let column = |c: usize| -> Option<usize> {
        let c = if goes_round { fold(c, cols, gap)? } else { c };
        c.checked_sub(c0).filter(|&lc| lc < src.cols())
    };
    let data = (0..rows * cols)
        .map(|k| {
            let (r, c) = (k / cols, k % cols);
            match (r.checked_sub(r0), column(c)) {
                (Some(lr), Some(lc)) if lr < src.rows() => *src.get(lr, lc),
                _ => fill,
            }
        })
        .collect();
    Level {
        zoom: level.zoom,
        tile_x0: 0,
        tile_y0: 0,
        heights: Grid::new(rows, cols, data).unwrap_or_else(|_| Grid::zeros(rows, cols)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;
    use zerotile_codec::raster::Georef;

    fn grid(rows: usize, cols: usize, f: impl Fn(usize, usize) -> f64) -> Grid<f64> {
        Grid::new(
            rows,
            cols,
            (0..rows * cols).map(|k| f(k / cols, k % cols)).collect(),
        )
        .unwrap()
    }

    /// A source reaching past a pole is not on the globe: refused, not clamped.
    #[test]
    fn sources_past_the_pole_are_refused() {
        let g = grid(3, 3, |_, _| 1.0);
        let georef = Georef::north_up(Crs::Geographic, 10.0, 91.0, 0.01, 0.01);
        let source = Source::new(g, &georef, 0.0).unwrap();
        let err = build(source, Scheme::Geodetic, Some(1)).err().unwrap();
        assert!(err.to_string().contains("outside the world"), "{err}");
    }

    /// A source wholly beyond mercator's ±85.05° is refused for mercator (it once became a
    /// dataset of fill only), and still builds as geodetic.
    #[test]
    fn sources_wholly_past_mercator_are_refused_for_mercator() {
        let g = grid(3, 3, |r, c| (r * 3 + c) as f64);
        for north in [89.9, -86.0] {
            let georef = Georef::north_up(Crs::Geographic, 10.0, north, 1.0, 1.0);
            let source = Source::new(g.clone(), &georef, 0.0).unwrap();
            let err = build(source.clone(), Scheme::Mercator, Some(2))
                .err()
                .unwrap();
            assert!(err.to_string().contains("--scheme geodetic"), "{err}");
            assert!(build(source, Scheme::Geodetic, Some(2)).is_ok());
        }
        // Partly inside: built, its bounds what is stored, and the clip reported.
        let georef = Georef::north_up(Crs::Geographic, 10.0, 86.0, 1.0, 1.0);
        let source = Source::new(g, &georef, 0.0).unwrap();
        let w = build(source.clone(), Scheme::Mercator, Some(2)).unwrap();
        assert_eq!(w.bounds[3], MERCATOR_MAX_LATITUDE);
        assert_eq!(w.bounds[1], 84.0);
        assert_eq!(w.clipped_lat, Some([84.0, 86.0]));
        // Geodetic stores it all.
        let w = build(source, Scheme::Geodetic, Some(2)).unwrap();
        assert_eq!(
            (w.bounds[1], w.bounds[3], w.clipped_lat),
            (84.0, 86.0, None)
        );
    }

    /// A lattice too big for memory is refused with what to do, before it is allocated.
    #[test]
    fn a_lattice_past_the_limit_is_refused() {
        // 10° × 10° at zoom 20: ~58 000 geodetic tiles a side.
        let g = grid(3, 3, |_, _| 1.0);
        let georef = Georef::north_up(Crs::Geographic, 0.0, 10.0, 5.0, 5.0);
        let source = Source::new(g, &georef, 0.0).unwrap();
        let err = build(source, Scheme::Geodetic, Some(20)).err().unwrap();
        assert!(err.to_string().contains("smaller --max-zoom"), "{err}");
    }

    /// An EPSG:3857 source is sampled at each mercator sample's own metres, and its metre
    /// spacing picks the zoom.
    #[test]
    fn a_web_mercator_source_is_sampled_where_it_lies() {
        // 21 × 21 samples 1 km apart from (1 000 km, 5 000 km), height = 100 + column.
        let (x0, y0, dx) = (1.0e6, 5.0e6, 1000.0);
        let g = grid(21, 21, |_, c| 100.0 + c as f64);
        let georef = Georef::north_up(Crs::WebMercator, x0, y0, dx, dx);
        let source = Source::new(g, &georef, 0.0).unwrap();
        let w = build(source, Scheme::Mercator, None).unwrap();
        // 2π · 6 378 137 m / 256 samples = 156 543 m at zoom 0; / 2^8 = 611 m ≤ 1 km < / 2^7.
        assert_eq!(w.max_zoom, 8);
        let deepest = &w.levels[0];
        assert_eq!(deepest.zoom, 8);
        let half = std::f64::consts::PI * 6_378_137.0;
        let per = 2.0 * half / f64::from(256u32 << 8);
        let mut checked = 0;
        for r in 0..deepest.heights.rows() {
            for c in 0..deepest.heights.cols() {
                let x = -half + (deepest.tile_x0 as usize * 256 + c) as f64 * per;
                let y = half - (deepest.tile_y0 as usize * 256 + r) as f64 * per;
                let (col, row) = ((x - x0) / dx, (y0 - y) / dx);
                if (0.0..=20.0).contains(&col) && (0.0..=20.0).contains(&row) {
                    let got = *deepest.heights.get(r, c);
                    assert!(
                        (got - (100.0 + col)).abs() < 1e-6,
                        "{r},{c}: {got} vs {col}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000, "{checked} samples inside the source");
    }

    /// A source ending on the antimeridian and the south pole ends in the world's last tile:
    /// the lattice's last sample is that tile's, not one of a tile past the edge.
    #[test]
    fn a_source_at_the_world_edge_fills_the_last_tile() {
        // Lon 178..180, lat −88..−90, 1° apart; the south-east sample is 108.
        let g = grid(3, 3, |r, c| 100.0 + (r * 3 + c) as f64);
        let georef = Georef::north_up(Crs::Geographic, 178.0, -88.0, 1.0, 1.0);
        let source = Source::new(g, &georef, 0.0).unwrap();
        let w = build(source, Scheme::Geodetic, Some(1)).unwrap();
        let deepest = &w.levels[0];
        let (rows, cols) = (deepest.heights.rows(), deepest.heights.cols());
        assert_eq!(*deepest.heights.get(rows - 1, cols - 1), 108.0);
    }

    /// A geographic source `cols` × `rows` from (`west`, `north`) (sample centres), `step`
    /// degrees apart, holding the plane 100 + 3·col + 2·row (bilinear keeps a plane exact).
    #[derive(Clone, Copy)]
    struct Plane {
        west: f64,
        north: f64,
        step: f64,
        rows: usize,
        cols: usize,
    }

    impl Plane {
        fn height(col: f64, row: f64) -> f64 {
            100.0 + 3.0 * col + 2.0 * row
        }

        fn source(self) -> Source {
            let g = grid(self.rows, self.cols, |r, c| {
                Self::height(c as f64, r as f64)
            });
            let georef =
                Georef::north_up(Crs::Geographic, self.west, self.north, self.step, self.step);
            Source::new(g, &georef, -7.0).unwrap()
        }

        fn build(self, scheme: Scheme, max_zoom: u8) -> WorldPyramid {
            build(self.source(), scheme, Some(max_zoom)).unwrap()
        }
    }

    /// Every tile of `w` by id, with its samples.
    fn tiles(w: &WorldPyramid) -> HashMap<TileId, Grid<f64>> {
        w.jobs
            .iter()
            .map(|&(k, x, y, id)| (id, w.levels[k].tile(x, y, TILE_SIDE).unwrap()))
            .collect()
    }

    /// What every world pyramid must be, wherever its source lies: one job a tile; each
    /// zoom's availability exactly its tiles, in ranges that do not overlap; tiles side by
    /// side, across the antimeridian too, sharing their edge column to the bit; the deepest
    /// tiles holding `p`'s plane at every sample within its sample centres, a whole turn
    /// round where it is written past ±180° (the mean where it holds a meridian twice).
    /// Returns how many samples held the source.
    fn check_world(w: &WorldPyramid, scheme: Scheme, p: Plane) -> usize {
        let tiling = Tiling::new(scheme, TILE_SIDE as u32).unwrap();
        let all = tiles(w);
        assert_eq!(all.len(), w.jobs.len(), "a tile encoded twice");
        for (z, ranges) in w.available.iter().enumerate() {
            let at_z: Vec<&TileId> = all.keys().filter(|id| usize::from(id.z) == z).collect();
            for (i, a) in ranges.iter().enumerate() {
                for b in &ranges[i + 1..] {
                    let apart = a.end_x < b.start_x
                        || b.end_x < a.start_x
                        || a.end_y < b.start_y
                        || b.end_y < a.start_y;
                    assert!(apart, "zoom {z}: {a:?} overlaps {b:?}");
                }
            }
            let listed: u128 = ranges.iter().map(Availability::tile_count).sum();
            assert_eq!(listed, at_z.len() as u128, "zoom {z}: {ranges:?}");
            for id in at_z {
                let inside = |a: &Availability| {
                    (a.start_x..=a.end_x).contains(&id.x) && (a.start_y..=a.end_y).contains(&id.y)
                };
                assert!(ranges.iter().any(inside), "{id:?} not in {ranges:?}");
            }
        }
        let last = TILE_SIDE - 1;
        for (id, west_tile) in &all {
            let (nx, _) = tiling.tiles_per_axis(id.z).unwrap();
            let east_id = TileId::new(id.z, (id.x + 1) % nx, id.y);
            if let Some(east_tile) = all.get(&east_id) {
                for r in 0..TILE_SIDE {
                    assert_eq!(
                        west_tile.get(r, last).to_bits(),
                        east_tile.get(r, 0).to_bits(),
                        "{id:?} / {east_id:?} row {r}"
                    );
                }
            }
        }
        let mut held = 0;
        for (id, t) in all.iter().filter(|(id, _)| id.z == w.max_zoom) {
            for r in (0..TILE_SIDE).step_by(4) {
                for c in (0..TILE_SIDE).step_by(4) {
                    let xy = tiling.sample_position(*id, r as u32, c as u32).unwrap();
                    let [lon, lat] = match scheme {
                        Scheme::Mercator => mercator_to_lonlat(xy),
                        _ => xy,
                    };
                    let row = (p.north - lat) / p.step;
                    // The source's columns at this meridian (two where it holds it twice).
                    let cols: Vec<f64> = [-720.0, -360.0, 0.0, 360.0, 720.0]
                        .map(|turn| (lon + turn - p.west) / p.step)
                        .into_iter()
                        .filter(|&col| (0.0..=(p.cols - 1) as f64).contains(&col))
                        .collect();
                    if !(0.0..=(p.rows - 1) as f64).contains(&row) || cols.is_empty() {
                        continue;
                    }
                    let got = *t.get(r, c);
                    // A meridian held twice (a global grid's ±180°) is one: their mean.
                    let twice = cols.len() == 2 && {
                        let mean = cols.iter().map(|&col| Plane::height(col, row)).sum::<f64>();
                        (got - mean / 2.0).abs() < 1e-6
                    };
                    assert!(
                        twice
                            || cols
                                .iter()
                                .any(|&col| (got - Plane::height(col, row)).abs() < 1e-6),
                        "{id:?} ({r}, {c}) at {lon}, {lat}: {got}, source columns {cols:?}"
                    );
                    held += 1;
                }
            }
        }
        held
    }

    /// A source across the antimeridian, written past 180° or before −180°, is ingested on
    /// both sides of it: the deepest tiles west and east of the seam hold its heights, the
    /// seam column is one on both sides at every zoom, the availability is two rectangles,
    /// and the bounds cross (west > east).
    #[test]
    fn a_source_across_the_antimeridian_goes_round_the_world() {
        // Lon 178..182 (or −182..−178), lat 10..6, 0.25° apart.
        for west in [178.0, -182.0] {
            let p = Plane {
                west,
                north: 10.0,
                step: 0.25,
                rows: 17,
                cols: 17,
            };
            for (scheme, z) in [(Scheme::Geodetic, 4), (Scheme::Mercator, 5)] {
                let w = p.build(scheme, z);
                let held = check_world(&w, scheme, p);
                assert!(
                    held > 500,
                    "{scheme:?} {west}: {held} samples of the source"
                );
                // −182..−178 is 178..182 a turn on: both are placed from 178°E.
                assert_eq!(w.bounds, [178.0, 6.0, -178.0, 10.0]);
                // Zoom 4 geodetic is 32 tiles of 11.25°, zoom 5 mercator 32 of 11.25°: the
                // last column and the first.
                let ranges = &w.available[usize::from(z)];
                let xs: Vec<(u32, u32)> = ranges.iter().map(|a| (a.start_x, a.end_x)).collect();
                assert_eq!(xs, [(31, 31), (0, 0)], "{scheme:?}");
                // Both sides hold data: the seam is not at an edge of fill.
                let all = tiles(&w);
                for x in [31, 0] {
                    let id = TileId::new(z, x, ranges[0].start_y);
                    let t = &all[&id];
                    assert!(t.data().iter().any(|&h| h >= 100.0), "{scheme:?} {id:?}");
                }
            }
        }
    }

    /// A source in 0..360° wholly east of 180° is the same place west of it: the same tiles,
    /// the same heights (to rounding), its bounds given from −180° to 180°.
    #[test]
    fn a_source_east_of_180_in_0_to_360_is_placed_west_of_the_antimeridian() {
        let at = |west| Plane {
            west,
            north: 10.0,
            step: 0.5,
            rows: 9,
            cols: 21,
        };
        for (scheme, z) in [(Scheme::Geodetic, 3), (Scheme::Mercator, 4)] {
            let east = at(190.0).build(scheme, z);
            let west = at(-170.0).build(scheme, z);
            assert_eq!(east.bounds, [-170.0, 6.0, -160.0, 10.0]);
            assert_eq!(east.jobs, west.jobs);
            assert_eq!(east.available, west.available);
            for (a, b) in east.levels.iter().zip(&west.levels) {
                let diff = a
                    .heights
                    .data()
                    .iter()
                    .zip(b.heights.data())
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
                assert!(diff < 1e-9, "{scheme:?} zoom {}: {diff}", a.zoom);
            }
            assert!(check_world(&east, scheme, at(190.0)) > 100);
        }
    }

    /// A global grid in 0..360° goes round whole: every tile once, the seam one column at
    /// every zoom. So does one reaching into a tile from both sides at a coarse zoom (lon
    /// −10..190 on mercator's two zoom-1 tiles): its lattice is the world's width. On
    /// geodetic's four zoom-1 tiles the same source is those four, ends joined at −90°, and
    /// six of zoom 2's eight.
    #[test]
    fn near_global_sources_are_sampled_once_round_the_world() {
        let global = Plane {
            west: 0.0,
            north: 60.0,
            step: 2.0,
            rows: 61,
            cols: 181,
        };
        let wide = Plane {
            west: -10.0,
            north: 30.0,
            step: 2.0,
            rows: 31,
            cols: 101,
        };
        for (p, bounds, geodetic_columns) in [
            (global, [-180.0, -60.0, 180.0, 60.0], 8),
            (wide, [-10.0, -30.0, -170.0, 30.0], 6),
        ] {
            for scheme in [Scheme::Geodetic, Scheme::Mercator] {
                let w = p.build(scheme, 2);
                assert_eq!(w.bounds, bounds, "{scheme:?}");
                assert!(check_world(&w, scheme, p) > 1000, "{scheme:?}");
                // Columns of tiles at the deepest zoom: all of mercator's four.
                let nx = match scheme {
                    Scheme::Geodetic => geodetic_columns,
                    _ => 4,
                };
                let xs: std::collections::BTreeSet<u32> = w
                    .jobs
                    .iter()
                    .filter(|j| j.3.z == 2)
                    .map(|j| j.3.x)
                    .collect();
                assert_eq!(xs.len() as u32, nx, "{scheme:?} {bounds:?}");
            }
        }
    }

    /// Global grids inside ±180°, the commonest layout, go round whole too: grid-registered
    /// (samples on −180° and 180°, one meridian held twice) and cell-registered (samples
    /// half a step inside, the seam in the gap between its two ends). Tiles side by side
    /// across the antimeridian share their edge column at every zoom, and every root and
    /// deepest column is a tile.
    #[test]
    fn global_sources_within_180_have_one_seam_at_every_zoom() {
        let grid_registered = Plane {
            west: -180.0,
            north: 10.0,
            step: 1.0,
            rows: 11,
            cols: 361,
        };
        let cell_registered = Plane {
            west: -179.5,
            cols: 360,
            ..grid_registered
        };
        for p in [grid_registered, cell_registered] {
            for (scheme, z) in [(Scheme::Geodetic, 2), (Scheme::Mercator, 3)] {
                let w = p.build(scheme, z);
                assert!(check_world(&w, scheme, p) > 1000, "{scheme:?} {}", p.west);
                // The whole circle, not the sample centres' 359°.
                assert_eq!([w.bounds[0], w.bounds[2]], [-180.0, 180.0], "{}", p.west);
                let tiling = Tiling::new(scheme, TILE_SIDE as u32).unwrap();
                for zoom in 0..=z {
                    let (nx, _) = tiling.tiles_per_axis(zoom).unwrap();
                    let xs: std::collections::BTreeSet<u32> = w
                        .jobs
                        .iter()
                        .filter(|j| j.3.z == zoom)
                        .map(|j| j.3.x)
                        .collect();
                    assert_eq!(xs.len() as u32, nx, "{scheme:?} {} zoom {zoom}", p.west);
                }
            }
        }
    }

    /// More than 360° of longitude would hold meridians twice: refused, saying so, not
    /// clipped. Exactly 360° is the world.
    #[test]
    fn a_source_over_360_degrees_is_refused() {
        let p = |cols| Plane {
            west: -181.0,
            north: 10.0,
            step: 1.0,
            rows: 3,
            cols,
        };
        let err = build(p(363).source(), Scheme::Geodetic, Some(1))
            .err()
            .unwrap()
            .to_string();
        assert!(
            err.contains("362.0000° round") && err.contains("crop it to 360° at most"),
            "{err}"
        );
        let w = p(361).build(Scheme::Geodetic, 1);
        assert_eq!(w.bounds, [-180.0, 8.0, 180.0, 10.0]);
        check_world(&w, Scheme::Geodetic, p(361));
    }

    /// A source whose north edge lies on a tile boundary (45°N, from zoom 2 down) stays
    /// where it is at every zoom: the coarser levels hold the fill north of it. Their
    /// padding repeated the edge row, and N44W072's 45°N row ran to the pole at zooms 0–1.
    #[test]
    fn a_data_edge_on_a_tile_boundary_does_not_run_outwards() {
        // Lon 10..12, lat 45..43, 1° apart.
        let g = grid(3, 3, |r, c| 500.0 + (r * 3 + c) as f64);
        let georef = Georef::north_up(Crs::Geographic, 10.0, 45.0, 1.0, 1.0);
        let source = Source::new(g, &georef, 7.0).unwrap();
        let w = build(source, Scheme::Geodetic, Some(4)).unwrap();
        let tiling = Tiling::new(Scheme::Geodetic, TILE_SIDE as u32).unwrap();
        let mut checked = 0;
        for level in &w.levels {
            let (_, ny) = tiling.tiles_per_axis(level.zoom).unwrap();
            let per_degree = (ny as usize * (TILE_SIDE - 1)) as f64 / 180.0;
            // Lattice row of a latitude, counted from the level's own first row.
            let row0 = level.tile_y0 as usize * (TILE_SIDE - 1);
            let h = &level.heights;
            for r in 0..h.rows() {
                let lat = 90.0 - (row0 + r) as f64 / per_degree;
                if lat > 45.0 + 2.0 / per_degree {
                    let row = h.row(r);
                    assert!(
                        row.iter().all(|&v| v == 7.0),
                        "zoom {}: {lat}°N holds {:?}",
                        level.zoom,
                        row.iter().find(|&&v| v != 7.0)
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 0);
    }

    /// Zoom 0 covers the whole world: the root tile away from the source is all fill.
    #[test]
    fn root_tiles_beyond_the_source_hold_the_fill() {
        // 2° × 2° at lon 10..12, lat 48..50: a few samples even at zoom 0.
        let g = grid(3, 3, |r, c| 500.0 + (r * 3 + c) as f64);
        let georef = Georef::north_up(Crs::Geographic, 10.0, 50.0, 1.0, 1.0);
        let source = Source::new(g, &georef, 7.0).unwrap();
        let w = build(source, Scheme::Geodetic, Some(2)).unwrap();
        let root = w.levels.last().unwrap();
        assert_eq!((root.zoom, root.tiles(TILE_SIDE)), (0, (2, 1)));
        // Lon 10° lies in the eastern tile; the western one never saw the source.
        let west = root.tile(0, 0, TILE_SIDE).unwrap();
        assert!(west.data().iter().all(|&h| h == 7.0));
        assert!(root
            .tile(1, 0, TILE_SIDE)
            .unwrap()
            .data()
            .iter()
            .any(|&h| h > 7.0));
    }
}
