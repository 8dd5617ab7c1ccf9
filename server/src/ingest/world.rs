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

use super::resample::Source;
use super::TILE_SIDE;

/// Samples in the deepest lattice before ingest refuses (8 bytes each): 2^27 ≈ 1 GiB.
const MAX_LATTICE_SAMPLES: u64 = 1 << 27;

/// Every level of a world pyramid, the tiles to encode and what layer.json will publish.
pub struct WorldPyramid {
    pub levels: Vec<Level>,
    pub max_zoom: u8,
    /// (level index, lattice tile x, lattice tile y from the north, the tile's id).
    pub jobs: Vec<(usize, u32, u32, TileId)>,
    pub available: Vec<Vec<Availability>>,
    /// West, south, east, north of the source as stored, degrees: on mercator, within
    /// ±85.05°.
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
    let bounds = [
        fold(f64::min, 0, f64::INFINITY),
        fold(f64::min, 1, f64::INFINITY),
        fold(f64::max, 0, f64::NEG_INFINITY),
        fold(f64::max, 1, f64::NEG_INFINITY),
    ];
    if bounds[0] < -180.0 - 1e-9
        || bounds[2] > 180.0 + 1e-9
        || bounds[1] < -90.0 - 1e-9
        || bounds[3] > 90.0 + 1e-9
    {
        bail!(
            "the source spans lon {:.4}..{:.4}, lat {:.4}..{:.4}: outside the world",
            bounds[0],
            bounds[2],
            bounds[1],
            bounds[3]
        );
    }

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
    let bbox = Bounds {
        min_x: bounds[0],
        min_y: bounds[1],
        max_x: bounds[2],
        max_y: bounds[3],
    };
    let range = tiling
        .tile_range(max_zoom, &bbox)?
        .context("the source lies outside the tiling (beyond mercator's ±85.05°?)")?;

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
    let (tw, th) = (range.x1 - range.x0 + 1, ty1 - ty0 + 1);
    let cells = (TILE_SIDE - 1) as u64;
    let (lat_cols, lat_rows) = (u64::from(tw) * cells + 1, u64::from(th) * cells + 1);
    if lat_cols * lat_rows > MAX_LATTICE_SAMPLES {
        bail!(
            "zoom {max_zoom} needs a {lat_rows}×{lat_cols} lattice ({} tiles): pass a smaller \
             --max-zoom",
            u64::from(tw) * u64::from(th)
        );
    }

    let deepest = lattice(&source, &tiling, scheme, max_zoom, range.x0, ty0, tw, th)?;
    let fill = source.fill();
    drop(source);
    let mut levels = vec![deepest];
    while let Some(next) = levels
        .last()
        .filter(|l| l.zoom > 0)
        .map(|l| l.coarser(TILE_SIDE))
    {
        levels.push(next);
    }
    // Clients ask for every root tile (CesiumJS requests both geodetic ones): give zoom 0
    // the whole world, filled beyond what the low-pass covers.
    if let Some(root) = levels.last_mut() {
        let (nx, ny0) = tiling.tiles_per_axis(0)?;
        *root = widen(root, nx, ny0, fill);
    }

    let mut jobs = Vec::new();
    let mut available = vec![Vec::new(); usize::from(max_zoom) + 1];
    for (k, level) in levels.iter().enumerate() {
        let (w, h) = level.tiles(TILE_SIDE);
        let (_, ny) = tiling.tiles_per_axis(level.zoom)?;
        let id_y = |row: u32| match scheme {
            Scheme::Geodetic => ny - 1 - row,
            _ => row,
        };
        let (ya, yb) = (id_y(level.tile_y0), id_y(level.tile_y0 + h - 1));
        let Some(at_zoom) = available.get_mut(usize::from(level.zoom)) else {
            anyhow::bail!("level zoom {} past --max-zoom {max_zoom}", level.zoom);
        };
        at_zoom.push(Availability {
            start_x: level.tile_x0,
            start_y: ya.min(yb),
            end_x: level.tile_x0 + w - 1,
            end_y: ya.max(yb),
        });
        for ly in level.tile_y0..level.tile_y0 + h {
            for lx in level.tile_x0..level.tile_x0 + w {
                jobs.push((k, lx, ly, TileId::new(level.zoom, lx, id_y(ly))));
            }
        }
    }
    Ok(WorldPyramid {
        levels,
        max_zoom,
        jobs,
        available,
        bounds,
        clipped_lat,
    })
}

/// The deepest lattice: `tw × th` tiles from tile (`x0`, `y0`) (rows from the north),
/// every sample taken from the source at the tiling's position for it.
#[allow(
    clippy::too_many_arguments,
    reason = "one call site; a struct would only rename them"
)]
fn lattice(
    source: &Source,
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
    let (_, ny) = tiling.tiles_per_axis(z)?;
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
                let p = tiling.sample_position(TileId::new(z, x0 + tc, y), row, col)?;
                let lonlat = match scheme {
                    Scheme::Mercator => mercator_to_lonlat(p),
                    _ => p,
                };
                let [sx, sy] = match source.crs() {
                    Crs::WebMercator => lonlat_to_mercator(lonlat),
                    _ => lonlat,
                };
                *h = source.height_at(sx, sy);
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

/// `level` placed in a lattice of `nx × ny` tiles from tile (0, 0), filled elsewhere.
fn widen(level: &Level, nx: u32, ny: u32, fill: f64) -> Level {
    let step = TILE_SIDE - 1;
    let (cols, rows) = (nx as usize * step + 1, ny as usize * step + 1);
    let (c0, r0) = (level.tile_x0 as usize * step, level.tile_y0 as usize * step);
    let src = &level.heights;
    let data = (0..rows * cols)
        .map(|k| {
            let (r, c) = (k / cols, k % cols);
            match (r.checked_sub(r0), c.checked_sub(c0)) {
                (Some(lr), Some(lc)) if lr < src.rows() && lc < src.cols() => *src.get(lr, lc),
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
