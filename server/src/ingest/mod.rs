//! `zerotile ingest`: a heightmap in, one dataset container out, written atomically.
//!
//! Steps: read the raster; lay the full-resolution lattice over whole tiles (edge samples
//! repeated, samples without data filled); build every coarser level from the wavelet
//! low-pass (`zerotile_codec::pyramid`); EZW-encode every tile in parallel; write the
//! container to a temporary file beside the target, sync it, and rename it over the target.
//! A failed or killed ingest leaves the previous dataset of that name untouched.
//!
//! Memory: the source's samples (8 bytes each) are freed once the deepest lattice holds them,
//! and a coarser level is made without a padded copy of the finer one (`Level::coarser`), so
//! the peak is the source and the deepest lattice side by side: 16–17 bytes a sample for a
//! local grid (6,000²: 0.58 GB, 12,000²: 2.3 GB; it was 40 bytes), the source plus its
//! resampled lattice on a world scheme.
//!
//! Schemes: `local` tiles the source grid itself; `geodetic` and `mercator` resample the
//! source at the tiling's sample positions (see `world`). Sources in EPSG:4326 or
//! EPSG:3857 go to either world scheme; other CRSs are refused with a pointer to gdalwarp.

mod antimeridian;
mod resample;
mod world;

use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use zerotile_codec::container::{Availability, Metadata, TileId, ViewParams, Writer};
use zerotile_codec::ezw::{self, EncodeParams};
use zerotile_codec::formats::terrain_rgb;
use zerotile_codec::geo::{Scheme, Tiling, VerticalDatum};
use zerotile_codec::pyramid::Level;
use zerotile_codec::raster::{self, Crs, Encoding, Heightmap, ReadOptions};
use zerotile_codec::wavelet::Wavelet;
use zerotile_codec::Grid;

/// Samples per tile side: 2^8 + 1.
pub const TILE_SIDE: usize = 257;
/// Container file extension.
pub const EXTENSION: &str = "ztd";

/// Whether `serve` lists `path` as a dataset: its extension is [`EXTENSION`] in any case, as
/// mesh files are read (a `.ZTD` copied from elsewhere).
pub fn is_dataset_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(EXTENSION))
}

/// What to ingest and how.
#[derive(Clone, Debug)]
pub struct Ingest {
    pub input: PathBuf,
    pub name: String,
    pub data: PathBuf,
    pub scheme: String,
    pub wavelet: Wavelet,
    /// Max |stored − source| in metres; `None` keeps every bit plane (lossless to the step
    /// with 5/3).
    pub precision: Option<f64>,
    pub encoding: Option<Encoding>,
    pub npz_key: Option<String>,
    pub fill: Option<f64>,
    /// Deepest zoom of a geodetic or mercator pyramid (default: as fine as the source).
    pub max_zoom: Option<u8>,
    /// What the heights are measured from (default: what the source says, if it does).
    pub vertical_datum: Option<VerticalDatum>,
    pub progress: bool,
}

impl Ingest {
    /// The file the dataset is written to: `DATA/NAME.ztd`.
    pub fn target(&self) -> PathBuf {
        self.data.join(format!("{}.{EXTENSION}", self.name))
    }
}

/// Levels, the tiles to encode and their published ranges: what a scheme contributes.
struct Plan {
    levels: Vec<Level>,
    max_zoom: u8,
    /// (level index, lattice tile x, lattice tile y, the tile's id in the container).
    jobs: Vec<(usize, u32, u32, TileId)>,
    available: Vec<Vec<Availability>>,
    bounds: [f64; 4],
}

/// The container a command names: a path to a `.ztd` file; else the dataset `NAME` in the
/// folder `data` when it is there; else an existing path; else `NAME` in `data` again (for
/// the caller's "no such dataset" message).
pub fn dataset_path(dataset: &OsStr, data: &Path) -> Result<PathBuf> {
    let as_path = Path::new(dataset);
    if as_path.extension().is_some_and(|e| e == EXTENSION) {
        // `info n44.ztd --data d` meant the file in d when there is none here.
        let in_data = data.join(as_path);
        if !as_path.exists() && as_path.is_relative() && in_data.is_file() {
            return Ok(in_data);
        }
        return Ok(as_path.to_path_buf());
    }
    // A dataset of that name wins over a file or folder of that name in the current
    // folder: `info n44 --data d` once read a stray ./n44, and `info web` the folder.
    // A name is UTF-8; anything else is a path (a Latin-1 file name from an old archive).
    let Some(name) = dataset.to_str() else {
        return Ok(as_path.to_path_buf());
    };
    let named = check_name(name).map(|()| data.join(format!("{name}.{EXTENSION}")));
    if named.as_ref().is_ok_and(|f| f.is_file()) {
        return named;
    }
    // Otherwise a path that exists is what was meant (a folder is refused by the caller).
    if as_path.exists() {
        return Ok(as_path.to_path_buf());
    }
    named
}

/// [`dataset_path`] for a dataset that must exist (info, export): a folder or a missing
/// file is refused with what to give instead, not an OS error.
pub fn existing_dataset_path(dataset: &OsStr, data: &Path) -> Result<PathBuf> {
    // Neither a path that exists nor a name: `info README.md` run elsewhere was a mistyped
    // or missing file, which "use 1–64 characters from …" alone did not say.
    let path = dataset_path(dataset, data).map_err(|e| {
        anyhow::anyhow!(
            "{}: no such file, and not a dataset name in --data {} ({e:#})",
            Path::new(dataset).display(),
            data.display()
        )
    })?;
    if path.is_dir() {
        bail!(
            "{}: a folder; give a .ztd file, or a dataset name with --data FOLDER",
            path.display()
        );
    }
    if !path.is_file() {
        // A FIFO or device that is there is not a typo to look for (and opening a FIFO
        // would block until something wrote to it).
        if let Some(what) = std::fs::metadata(&path)
            .ok()
            .and_then(|m| crate::regular_file::kind(&m))
        {
            bail!(
                "{}: not a regular file ({what}); give a .ztd file",
                path.display()
            );
        }
        bail!(
            "{}: no such dataset file (give a .ztd path, or a name in --data {})",
            path.display(),
            data.display()
        );
    }
    Ok(path)
}

/// Dataset names become file names: keep them to a safe alphabet.
pub fn check_name(name: &str) -> Result<()> {
    check_name_of("dataset", name)
}

/// [`check_name`] for names of other things (`kind`: "mesh"), which follow the same rule
/// and are file names too; the message says which name was wrong.
pub fn check_name_of(kind: &str, name: &str) -> Result<()> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if !ok {
        crate::bail_usage!(
            "{kind} name {}: use 1–64 characters from A–Z, a–z, 0–9, '-' and '_'",
            crate::serve::error::echo(name)
        );
    }
    Ok(())
}

/// Errors if `data` names a file: caught before any work, where writing the finished
/// dataset would only say "File exists", after all the encoding.
pub fn check_data_dir(data: &Path) -> Result<()> {
    // `serve --data` reads store URLs; a write here would make a local folder named "s3:".
    if crate::serve::storage::is_url(&data.to_string_lossy()) {
        crate::bail_usage!(
            "--data {}: ingest writes a local folder; ingest there, then copy the .ztd file \
             to the store (serve --data reads store URLs)",
            data.display()
        );
    }
    if data.exists() && !data.is_dir() {
        bail!(
            "--data {}: is a file, not a folder; give the folder the datasets go in",
            data.display()
        );
    }
    Ok(())
}

/// Refuses bad options before any work; returns the scheme.
fn check(job: &Ingest) -> Result<&str> {
    check_name(&job.name)?;
    let scheme = match job.scheme.as_str() {
        "local" | "geodetic" | "mercator" => job.scheme.as_str(),
        other => crate::bail_usage!("--scheme {other}: use geodetic, mercator or local"),
    };
    check_data_dir(&job.data)?;
    if job.max_zoom.is_some() && scheme == "local" {
        crate::bail_usage!("--max-zoom applies to geodetic and mercator; a local pyramid ends at the source's resolution");
    }
    if let Some(p) = job.precision {
        if !(p.is_finite() && p > 0.0) {
            crate::bail_usage!("--precision must be finite and > 0 metres, got {p}");
        }
    }
    if let Some(f) = job.fill {
        if !f.is_finite() {
            crate::bail_usage!("--fill must be a finite height, got {f}");
        }
    }
    Ok(scheme)
}

#[cfg(test)]
impl Ingest {
    /// `name` from `{name}.hgt` into `data` with every default (5/3, no flags), quiet: what
    /// the tests that build a dataset from a heightmap in memory start from.
    pub(crate) fn for_test(name: &str, scheme: &str, data: &Path) -> Self {
        Self {
            input: PathBuf::from(format!("{name}.hgt")),
            name: name.into(),
            data: data.to_path_buf(),
            scheme: scheme.into(),
            wavelet: zerotile_codec::wavelet::Wavelet::LeGall53,
            precision: None,
            encoding: None,
            npz_key: None,
            fill: None,
            max_zoom: None,
            vertical_datum: None,
            progress: false,
        }
    }
}

/// Builds the dataset and returns where it was written and its metadata.
pub fn run(job: &Ingest) -> Result<(PathBuf, Metadata)> {
    let scheme = check(job)?;
    crate::regular_file::check_input(&job.input)?;
    // Formats with no georeference at all are refused by name, before their samples are
    // read: a 0.5 MB PNG of 16,000² took 2.4 GB and 3 s to be told it has none.
    let ext = raster::extension(&job.input);
    if scheme != "local" && (ext == "png" || ext == "npy") {
        crate::bail_usage!(
            "{}: a .{ext} carries no georeference, so it cannot be placed on the globe (use \
             --scheme local, or a GeoTIFF, .npz with bounds, or ASCII grid with a .prj)",
            job.input.display()
        );
    }
    let opts = ReadOptions {
        encoding: job.encoding,
        npz_key: job.npz_key.clone(),
        ..ReadOptions::default()
    };
    let map = raster::read_heightmap(&job.input, &opts)?;
    build(job, map)
}

/// Builds the dataset from a heightmap already in memory (`job.input` only names it). The
/// heightmap is taken so its samples are freed as soon as the deepest lattice holds them: the
/// ingest's peak is then the source and that lattice, not the source beside every level.
pub fn build(job: &Ingest, map: Heightmap) -> Result<(PathBuf, Metadata)> {
    let scheme = check(job)?;
    let (lo, hi) = map
        .min_max()
        .with_context(|| format!("{}: no valid samples", job.input.display()))?;
    let step = map.step.unwrap_or(0.01);
    // What the metadata needs of the source once its samples are gone.
    let (rows, cols) = (map.heights.rows(), map.heights.cols());
    let has_nodata = map.has_nodata();
    let source_crs = map.georef.map_or("none".into(), |g| g.crs.to_string());
    let vertical_datum = job.vertical_datum.or(map.vertical_datum);
    let Heightmap {
        heights, georef, ..
    } = map;
    // A local grid's holes take its lowest height; a world tiling's surroundings and holes
    // are sea level; unless told otherwise.
    let fill = job.fill.unwrap_or(if scheme == "local" { lo } else { 0.0 });
    check_span(job, lo, hi, fill, step)?;
    if let Some(e) = job.precision {
        // The dataset's span bounds every tile's, so no tile refuses what passes here (`e`
        // is finite and > 0, `check`'s).
        let least = ezw::min_max_error(step, hi.max(fill) - lo.min(fill));
        if e < least {
            bail!(
                "--precision {e}: {} has heights {lo} … {hi} in steps of {step}, which a bound \
                 below {least:e} cannot be held to (f64 resolution); give at least that",
                job.input.display()
            );
        }
    }
    let plan = if scheme == "local" {
        // The tiling the server will open the dataset with: a grid it refuses (under 2 × 2)
        // is refused here, before anything is written.
        Tiling::new(Scheme::Local { rows, cols }, TILE_SIDE as u32)
            .with_context(|| format!("{}: cannot be tiled", job.input.display()))?;
        check_local_lattice(rows, cols)
            .with_context(|| format!("{}: cannot be tiled", job.input.display()))?;
        local_plan(heights, fill)
    } else {
        let georef = georef.with_context(|| {
            // The formats placed by a convention the file can miss: a .hgt by its name (a
            // renamed copy loses it), an .npz by scalar keys (bounds alone do not place it).
            let ext = job.input.extension().map(|e| e.to_ascii_lowercase());
            let how = match ext.as_ref().and_then(|e| e.to_str()) {
                Some("hgt") => "; an SRTM .hgt is placed by its file name, as N44W072.hgt",
                Some("npz") => {
                    "; an .npz is placed by scalar xmin, ymin, ymax, dx and dy beside the array \
                     (xmax optional), agreeing with its shape"
                }
                _ => "",
            };
            format!(
                "{}: no georeference, so it cannot be placed on the globe (use --scheme local){how}",
                job.input.display(),
            )
        })?;
        if !matches!(georef.crs, Crs::Geographic | Crs::WebMercator) {
            let npz = raster::extension(&job.input) == "npz";
            let what = match georef.crs {
                // An .npz names no CRS: its bounds are degrees when they can be.
                Crs::Unknown if npz => "not known (an .npz's bounds are taken as degrees when \
                                        its cell centres lie within -180..180° or 0..360° of \
                                        longitude and its rows within ±90° of latitude, and \
                                        these do not)"
                    .to_string(),
                Crs::Unknown => "not known (an ESRI ASCII grid's is read from the .prj beside \
                                 it, when that names WGS 84 or Web Mercator)"
                    .to_string(),
                crs => crs.to_string(),
            };
            bail!(
                "{}: its CRS is {what}; geodetic and mercator ingest read EPSG:4326 or EPSG:3857 \
                 (reproject first, e.g. `gdalwarp -t_srs EPSG:4326 IN OUT.tif`), or use \
                 --scheme local",
                job.input.display(),
            );
        }
        let place = || job.input.display().to_string();
        let source = resample::Source::new(heights, &georef, fill).with_context(place)?;
        let scheme = if scheme == "geodetic" {
            Scheme::Geodetic
        } else {
            Scheme::Mercator
        };
        let w = world::build(source, scheme, job.max_zoom).with_context(place)?;
        if let Some([south, north]) = w.clipped_lat {
            eprintln!(
                "zerotile: note: {} spans latitudes {south:.4}..{north:.4}; web mercator stops at \
                 ±{:.4}°, so the rows beyond are not stored (--scheme geodetic keeps them)",
                job.input.display(),
                zerotile_codec::geo::MERCATOR_MAX_LATITUDE
            );
        }
        Plan {
            levels: w.levels,
            max_zoom: w.max_zoom,
            jobs: w
                .jobs
                .into_iter()
                .map(|(k, x, y, id)| {
                    (
                        k,
                        x,
                        y,
                        TileId {
                            z: id.z,
                            x: id.x,
                            y: id.y,
                        },
                    )
                })
                .collect(),
            available: w.available,
            bounds: w.bounds,
        }
    };
    // Said once here, where the heights are known: every PNG tile would clamp silently.
    let (rgb_lo, rgb_hi) = terrain_rgb::height_range(Encoding::TerrainRgb)?;
    if lo < rgb_lo || hi > rgb_hi {
        let (t_lo, t_hi) = terrain_rgb::height_range(Encoding::Terrarium)?;
        eprintln!(
            "zerotile: note: {} has heights {lo} … {hi} m; its terrain-RGB PNG tiles clamp them \
             to {rgb_lo} … {rgb_hi} m (?encoding=terrarium codes {t_lo} … {t_hi} m; the mesh \
             formats keep every height)",
            job.input.display()
        );
    }
    let (source_lo, source_hi) = (lo, hi);
    // The fill is stored wherever there is no data, so it belongs to the range then.
    let (lo, hi) = if has_nodata || scheme != "local" {
        (lo.min(fill), hi.max(fill))
    } else {
        (lo, hi)
    };

    // Encode in parallel.
    let bar = tile_bar("encoding", job.progress, plan.jobs.len() as u64);
    let params = EncodeParams {
        max_error: job.precision,
        ..EncodeParams::new(job.wavelet, step)
    };
    let encoded: Vec<(TileId, [f64; 4], Vec<u8>)> = plan
        .jobs
        .par_iter()
        .map(|&(k, x, y, id)| {
            let name = || format!("tile {}/{}/{}", id.z, id.x, id.y);
            let tile = plan
                .levels
                .get(k)
                .and_then(|level| level.tile(x, y, TILE_SIDE))
                .with_context(|| format!("{} outside its level", name()))?;
            let corners = corners(&tile);
            let stream =
                ezw::encode(&tile, &params).with_context(|| format!("encoding {}", name()))?;
            bar.inc(1);
            Ok((id, corners, stream.bytes))
        })
        .collect::<Result<_>>()?;
    bar.finish_and_clear();
    // Every tile is encoded: the lattices are not needed for writing the container.
    drop(plan.levels);

    // Container, written atomically.
    let mut writer = Writer::new();
    let mut stream_bytes = 0u64;
    for (id, c, bytes) in &encoded {
        stream_bytes += bytes.len() as u64;
        writer.add(*id, *c, bytes);
    }
    let metadata = Metadata {
        name: job.name.clone(),
        scheme: scheme.to_string(),
        tile_side: TILE_SIDE,
        min_zoom: 0,
        max_zoom: plan.max_zoom,
        bounds: plan.bounds,
        source_size: [rows, cols],
        wavelet: job.wavelet,
        step,
        precision: job.precision,
        height_range: [lo, hi],
        source_height_range: Some([source_lo, source_hi]),
        fill,
        vertical_datum,
        view: ViewParams {
            a: (hi - lo) / 32.0,
            b: 0.0,
        },
        available: plan.available,
        source: job
            .input
            .file_name()
            .map_or_else(String::new, |f| f.to_string_lossy().into_owned()),
        source_crs,
        samples: (encoded.len() * TILE_SIDE * TILE_SIDE) as u64,
        stream_bytes,
        created: now_rfc3339(),
    };
    let bytes = writer.finish(&metadata)?;
    let target = job.target();
    write_atomically(&target, &bytes)?;
    Ok((target, metadata))
}

/// The `local` pyramid: the source grid at the deepest zoom, its holes given `fill`, halved
/// until one tile holds it. The source is freed once the deepest lattice holds it.
fn local_plan(heights: Grid<f64>, fill: f64) -> Plan {
    let (rows, cols) = (heights.rows(), heights.cols());
    let mut levels = vec![full_resolution(&heights, fill)];
    drop(heights);
    while let Some(next) = levels
        .last()
        .filter(|l| l.tiles(TILE_SIDE) != (1, 1))
        .map(|l| l.coarser(TILE_SIDE))
    {
        levels.push(next);
    }
    // A 257-sample tile doubles per zoom, so even a 2^40-sample side needs < 40 zooms.
    let max_zoom = (levels.len() - 1) as u8;
    for (k, level) in levels.iter_mut().enumerate() {
        level.zoom = max_zoom - k as u8;
    }

    // Tiles that hold source samples, every level.
    let mut jobs = Vec::new();
    let mut available = vec![Vec::new(); levels.len()];
    for (k, level) in levels.iter().enumerate() {
        let scale = 1usize << (max_zoom - level.zoom);
        let span = (TILE_SIDE - 1) * scale;
        let (w, h) = level.tiles(TILE_SIDE);
        let inside_x = ((cols - 1).div_ceil(span).max(1) as u32).min(w);
        let inside_y = ((rows - 1).div_ceil(span).max(1) as u32).min(h);
        // Zooms run 0..=max_zoom, one list each: always present.
        if let Some(at_zoom) = available.get_mut(level.zoom as usize) {
            at_zoom.push(Availability {
                start_x: 0,
                start_y: 0,
                end_x: inside_x - 1,
                end_y: inside_y - 1,
            });
        }
        for y in 0..inside_y {
            for x in 0..inside_x {
                jobs.push((
                    k,
                    x,
                    y,
                    TileId {
                        z: level.zoom,
                        x,
                        y,
                    },
                ));
            }
        }
    }
    Plan {
        levels,
        max_zoom,
        jobs,
        available,
        bounds: [0.0, (rows - 1) as f64, (cols - 1) as f64, 0.0],
    }
}

/// Refuses heights, fill included, whose range the wavelet cannot code
/// ([`ezw::max_range_steps`]), before any work: a `--fill` of -1e300 ran the whole ingest,
/// then failed on the first tile with a message about no-data sentinels. A tile's own range
/// is at most the dataset's, so what passes here never fails there for its range.
fn check_span(job: &Ingest, lo: f64, hi: f64, fill: f64, step: f64) -> Result<()> {
    let (a, b) = (lo.min(fill), hi.max(fill));
    let limit = ezw::max_range_steps(job.wavelet);
    if (b - a) / step < limit {
        return Ok(());
    }
    let what = format!(
        "span {} steps of {step}, more than the {limit} the {} wavelet codes",
        (b - a) / step,
        job.wavelet.name()
    );
    match job.fill.filter(|f| !(lo..=hi).contains(f)) {
        Some(f) => bail!(
            "--fill {f}: with heights {lo} … {hi} the dataset would {what}; give a fill near \
             the heights"
        ),
        // 9/7 (the default) codes the wider range: no other wavelet to point to then.
        None if job.wavelet == Wavelet::LeGall53 => bail!(
            "{}: heights {a} … {b} {what} (a no-data value the file does not mark as such? \
             --wavelet 97 takes a wider range)",
            job.input.display()
        ),
        None => bail!(
            "{}: heights {a} … {b} {what} (a no-data value the file does not mark as such? \
             mark it, e.g. gdal_edit.py -a_nodata VALUE FILE)",
            job.input.display()
        ),
    }
}

/// Samples a local grid's padded lattice may hold: the input limit, with room for a square
/// input's padding to whole tiles. The input limit alone does not bound it: a 2 × 30,000,000
/// grid (60 M samples) pads to 257 rows, 7.7 G samples, and the ingest aborted out of memory.
const MAX_LOCAL_LATTICE: u64 = raster::DEFAULT_MAX_SAMPLES as u64 / 4 * 5;

/// A side of `n` samples padded to whole tiles.
fn padded(n: usize) -> usize {
    let step = TILE_SIDE - 1;
    n.saturating_sub(1).div_ceil(step).max(1) * step + 1
}

/// Refuses a grid whose lattice, padded to whole tiles, would pass [`MAX_LOCAL_LATTICE`],
/// before any of it is built.
fn check_local_lattice(rows: usize, cols: usize) -> Result<()> {
    let (r, c) = (padded(rows), padded(cols));
    let samples = r as u64 * c as u64;
    if samples > MAX_LOCAL_LATTICE {
        bail!(
            "a grid of {rows} × {cols} samples (rows × columns) pads to whole {TILE_SIDE}-sample \
             tiles as \
             {r} × {c} \
             ({samples} samples, more than the {MAX_LOCAL_LATTICE} an ingest holds): a long, \
             thin grid pads most; crop it, or split it into datasets"
        );
    }
    Ok(())
}

/// The full-resolution lattice: the source padded to whole tiles by repeating its last row
/// and column, a sample without data (not finite) taking `fill`. Filled here, not in a
/// filled copy of the source first: that copy was 8 more bytes a sample at the peak.
fn full_resolution(heights: &Grid<f64>, fill: f64) -> Level {
    let (rows, cols) = (padded(heights.rows()), padded(heights.cols()));
    let data = (0..rows * cols)
        .map(|k| {
            let r = (k / cols).min(heights.rows() - 1);
            let c = (k % cols).min(heights.cols() - 1);
            let h = *heights.get(r, c);
            if h.is_finite() {
                h
            } else {
                fill
            }
        })
        .collect();
    Level {
        zoom: 0,
        tile_x0: 0,
        tile_y0: 0,
        heights: Grid::new(rows, cols, data).unwrap_or_else(|_| Grid::zeros(rows, cols)),
    }
}

/// North-west, north-east, south-west, south-east samples of a tile.
fn corners(tile: &Grid<f64>) -> [f64; 4] {
    let (r, c) = (tile.rows() - 1, tile.cols() - 1);
    [
        *tile.get(0, 0),
        *tile.get(0, c),
        *tile.get(r, 0),
        *tile.get(r, c),
    ]
}

/// The progress bar of a pass over `len` tiles ("encoding", "exporting", "verifying"); hidden
/// unless `show` (`--quiet`, JSON output).
pub fn tile_bar(verb: &str, show: bool, len: u64) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    let template = format!("{verb} {{bar:40}} {{pos}}/{{len}} tiles {{eta}}");
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style);
    }
    bar
}

/// Writes `bytes` to a temporary file in `target`'s folder, syncs it and renames it over
/// `target`: readers see the old file or the new one, never a partial one. Each call has a
/// temporary file of its own (the process id and a call count name it), so two writes of
/// one target at once each rename a whole file: the last rename wins.
pub fn write_atomically(target: &Path, bytes: &[u8]) -> Result<()> {
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = target
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    // Named with the target: the folder alone did not say which write failed.
    std::fs::create_dir_all(dir)
        .with_context(|| format!("writing {}: creating {}", target.display(), dir.display()))?;
    let name = target
        .file_name()
        .map_or_else(String::new, |f| f.to_string_lossy().into_owned());
    sweep_leftovers(dir, &format!(".{name}.tmp-"));
    let tmp = dir.join(format!(".{name}.tmp-{}-{n}", std::process::id()));
    let result = (|| -> Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, target)?;
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.with_context(|| format!("writing {}", target.display()))
}

/// Removes the files or folders in `dir` named `PREFIX{pid}…` whose process is gone: what a
/// run killed mid-write (Ctrl-C, SIGKILL) left of its temporary copy, which nothing else
/// would remove. A run still going keeps its own. Only where `/proc` tells which processes
/// live (Linux); elsewhere nothing is removed. It assumes one host writes the folder.
pub fn sweep_leftovers(dir: &Path, prefix: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(prefix)) else {
            continue;
        };
        let pid = rest.split('-').next().unwrap_or_default();
        if pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        if Path::new("/proc").join(pid).exists() {
            continue;
        }
        let path = entry.path();
        let removed = if path.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        if removed.is_ok() {
            tracing::info!("removed {}, left by an interrupted run", path.display());
        }
    }
}

/// Seconds since the epoch as RFC 3339 UTC, without a date-time dependency.
fn now_rfc3339() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_checked() {
        assert!(check_name("n44w072_srtm-3").is_ok());
        for bad in ["", "../etc", "a/b", "x y", "é", &"x".repeat(65)] {
            assert!(check_name(bad).is_err(), "{bad:?}");
        }
    }

    /// The padded lattice is bounded, not only the input: a long, thin grid is refused before
    /// its lattice is built, a square one at the input limit is not.
    #[test]
    fn a_grid_whose_padded_lattice_is_too_large_is_refused_up_front() {
        assert!(check_local_lattice(16_384, 16_384).is_ok());
        assert!(check_local_lattice(2, 400_000).is_ok());
        let e = check_local_lattice(2, 30_000_000).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "a grid of 2 × 30000000 samples (rows × columns) pads to whole 257-sample \
                 tiles as \
                 257 × 30000129"
            ),
            "{e}"
        );
        // Through the ingest: refused before any lattice (514 M samples here) is built.
        let data = scratch("thin");
        let cols = 2_000_000;
        let map = Heightmap::new(
            Grid::new(2, cols, vec![1.0; 2 * cols]).unwrap(),
            Some(1.0),
            None,
        );
        let e = format!(
            "{:#}",
            build(&job("thin", "local", &data), map).unwrap_err()
        );
        assert!(
            e.contains("cannot be tiled: a grid of 2 × 2000000 samples (rows × columns) pads"),
            "{e}"
        );
        assert!(!data.join("thin.ztd").exists());
        let _ = std::fs::remove_dir_all(&data);
    }

    /// A temporary file an interrupted run left goes at the next write of that target; one of
    /// a live process (this one) and those of other targets stay.
    #[test]
    fn a_killed_runs_temporary_file_is_swept_at_the_next_write() {
        let dir = scratch("sweep");
        std::fs::create_dir_all(&dir).unwrap();
        let dead = dir.join(".a.ztd.tmp-4294967295-0");
        // A name this process's own writes never take (they count up from 0): `-9` was the
        // tenth write's, and in a full run the write below could be it and rename it away.
        let live = dir.join(format!(".a.ztd.tmp-{}-live", std::process::id()));
        let other = dir.join(".b.ztd.tmp-4294967295-0");
        for f in [&dead, &live, &other] {
            std::fs::write(f, b"partial").unwrap();
        }
        write_atomically(&dir.join("a.ztd"), b"whole").unwrap();
        assert_eq!(std::fs::read(dir.join("a.ztd")).unwrap(), b"whole");
        assert!(!dead.exists() && live.exists() && other.exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The lattice repeats the last row and column, and a hole (not finite) takes the fill,
    /// in the padding too.
    #[test]
    fn full_resolution_pads_to_whole_tiles_and_fills_holes() {
        let mut g = Grid::new(300, 10, (0..3000).map(f64::from).collect()).unwrap();
        *g.get_mut(5, 3) = f64::NAN;
        *g.get_mut(299, 9) = f64::NEG_INFINITY;
        let l = full_resolution(&g, -7.0);
        assert_eq!((l.heights.rows(), l.heights.cols()), (513, 257));
        assert_eq!(*l.heights.get(512, 256), -7.0);
        assert_eq!(*l.heights.get(512, 8), *g.get(299, 8));
        assert_eq!((*l.heights.get(5, 3), *l.heights.get(5, 4)), (-7.0, 54.0));
    }

    #[test]
    fn rfc3339_has_the_right_shape() {
        let t = now_rfc3339();
        assert_eq!(t.len(), 20);
        assert!(t.starts_with("20") && t.ends_with('Z'));
    }

    /// Seconds since the epoch of a UTC civil time, counted day by day from 1970-01-01.
    fn epoch_seconds(y: u64, m: u64, d: u64, hh: u64, mm: u64, ss: u64) -> u64 {
        let leap =
            |y: u64| (y.is_multiple_of(4) && !y.is_multiple_of(100)) || y.is_multiple_of(400);
        let month_days = |y: u64, m: u64| match m {
            2 if leap(y) => 29,
            2 => 28,
            4 | 6 | 9 | 11 => 30,
            _ => 31,
        };
        let days = (1970..y)
            .map(|y| if leap(y) { 366 } else { 365 })
            .sum::<u64>()
            + (1..m).map(|m| month_days(y, m)).sum::<u64>()
            + (d - 1);
        ((days * 24 + hh) * 60 + mm) * 60 + ss
    }

    /// `created` must name the actual UTC second, not just look like a timestamp.
    #[test]
    fn rfc3339_names_the_current_utc_second() {
        let secs = || {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_secs()
        };
        let before = secs();
        let t = now_rfc3339();
        let after = secs();
        let n = |a: usize, b: usize| t[a..b].parse::<u64>().unwrap();
        let got = epoch_seconds(n(0, 4), n(5, 7), n(8, 10), n(11, 13), n(14, 16), n(17, 19));
        assert!(
            (before..=after).contains(&got),
            "{t}: {got} not in {before}..={after}"
        );
    }

    /// The name rule allows up to 64 characters: the 64th must not be refused.
    #[test]
    fn a_64_character_name_is_accepted() {
        assert!(check_name(&"x".repeat(64)).is_ok());
        assert!(check_name("a").is_ok());
    }

    fn job(name: &str, scheme: &str, data: &Path) -> Ingest {
        Ingest::for_test(name, scheme, data)
    }

    /// The vertical datum recorded is the flag's, else the source's, else none.
    #[test]
    fn the_vertical_datum_is_the_flags_else_the_sources() {
        let data = scratch("datum");
        let heights = Grid::new(3, 3, (0..9).map(f64::from).collect()).unwrap();
        let srtm = Heightmap {
            vertical_datum: Some(VerticalDatum::Egm96),
            ..Heightmap::new(heights.clone(), Some(1.0), None)
        };
        let plain = Heightmap::new(heights, Some(1.0), None);
        for (flag, map, want) in [
            (None, &srtm, Some(VerticalDatum::Egm96)),
            (
                Some(VerticalDatum::Ellipsoid),
                &srtm,
                Some(VerticalDatum::Ellipsoid),
            ),
            (None, &plain, None),
            (
                Some(VerticalDatum::Egm96),
                &plain,
                Some(VerticalDatum::Egm96),
            ),
        ] {
            let j = Ingest {
                vertical_datum: flag,
                ..job("d", "local", &data)
            };
            let (path, m) = build(&j, map.clone()).unwrap();
            assert_eq!(m.vertical_datum, want, "{flag:?}");
            // And it is what the file holds.
            let read = crate::serve::dataset::Dataset::open(&path).unwrap();
            assert_eq!(read.metadata().vertical_datum, want, "{flag:?}");
        }
    }

    /// A data folder not made yet: ingest makes it.
    fn scratch(tag: &str) -> PathBuf {
        crate::fixtures::scratch(&format!("ingest-{tag}")).join("data")
    }

    /// A fill the coder cannot span with the heights is refused before any work.
    #[test]
    fn a_fill_too_far_from_the_heights_is_refused_up_front() {
        let data = scratch("far-fill");
        let mut h = vec![100.0; 9];
        h[4] = f64::NAN;
        let map = Heightmap::new(Grid::new(3, 3, h).unwrap(), Some(1.0), None);
        for (wavelet, fill, ok) in [
            (Wavelet::Cdf97, -1e300, false),
            (Wavelet::Cdf97, 1e16, false),
            (Wavelet::Cdf97, -1e6, true),
            // The integer 5/3 path codes below 2^19 steps: 524,388 is past it, 400,000 not.
            (Wavelet::LeGall53, -524_388.0, false),
            (Wavelet::LeGall53, -400_000.0, true),
        ] {
            let j = Ingest {
                fill: Some(fill),
                wavelet,
                ..job("f", "local", &data)
            };
            match build(&j, map.clone()) {
                Ok(_) => assert!(ok, "{fill}"),
                Err(e) if ok => panic!("{fill}: {e:#}"),
                Err(e) => {
                    let e = e.to_string();
                    assert!(
                        !ok && e.starts_with(&format!("--fill {fill}:")),
                        "{fill}: {e}"
                    );
                }
            }
        }
    }

    /// Heights past the wavelet's range point at an unmarked no-data value, and at 9/7 only
    /// from 5/3: with 9/7 (the default) the hint was "--wavelet 97 takes a wider range".
    #[test]
    fn heights_past_the_range_get_a_hint_the_wavelet_can_use() {
        let data = scratch("wide-heights");
        let mut h = vec![1.0; 16];
        (h[3], h[4]) = (3e38, -3e38);
        let map = Heightmap::new(Grid::new(4, 4, h).unwrap(), Some(1.0), None);
        for (wavelet, hint) in [
            (Wavelet::LeGall53, "--wavelet 97 takes a wider range"),
            (
                Wavelet::Cdf97,
                "mark it, e.g. gdal_edit.py -a_nodata VALUE FILE",
            ),
        ] {
            let j = Ingest {
                wavelet,
                ..job("w", "local", &data)
            };
            let e = build(&j, map.clone()).unwrap_err().to_string();
            assert!(
                e.contains("(a no-data value the file does not mark as such? "),
                "{e}"
            );
            assert!(e.ends_with(&format!("{hint})")), "{wavelet:?}: {e}");
        }
    }

    /// A --precision finer than the heights' f64 resolution is refused once, naming the flag,
    /// the file and the least bound (it was "encoding tile 1/0/0: max_error must be at
    /// least …"); at that least bound every tile encodes.
    #[test]
    fn a_precision_below_what_the_heights_can_hold_is_refused_by_its_flag() {
        let data = scratch("fine-precision");
        // -11,000 … 8,848 m in 1 mm steps: the floor is the range's 2^-40, 1.8e-8 m.
        let h: Vec<f64> = (0..25).map(|i| -11_000.0 + 827.0 * f64::from(i)).collect();
        let map = Heightmap::new(Grid::new(5, 5, h).unwrap(), None, None);
        let least = ezw::min_max_error(0.01, 19_848.0);
        assert!((least - 19_848.0 / 2f64.powi(40)).abs() < 1e-20, "{least}");
        let j = Ingest {
            precision: Some(1e-9),
            wavelet: Wavelet::Cdf97,
            ..job("p", "local", &data)
        };
        let e = build(&j, map.clone()).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "--precision 0.000000001: p.hgt has heights -11000 … 8848 in steps of 0.01"
            ) && e.ends_with(&format!(
                "below {least:e} cannot be held to (f64 resolution); give at least that"
            )),
            "{e}"
        );
        let j = Ingest {
            precision: Some(least),
            wavelet: Wavelet::Cdf97,
            ..job("p", "local", &data)
        };
        build(&j, map).unwrap();
        // A coarse step's floor is the step's 2^-20.
        assert_eq!(ezw::min_max_error(1.0, 100.0), 1.0 / 2f64.powi(20));
    }

    /// A placement off the globe names the file (it was "the source spans …" alone).
    #[test]
    fn a_source_off_the_globe_is_refused_by_its_file() {
        let data = scratch("off-globe");
        let georef =
            zerotile_codec::raster::Georef::north_up(Crs::Geographic, 10.0, 91.0, 0.01, 0.01);
        let map = Heightmap::new(
            Grid::new(3, 3, vec![1.0; 9]).unwrap(),
            Some(1.0),
            Some(georef),
        );
        let e = build(&job("pole", "geodetic", &data), map).unwrap_err();
        let e = format!("{e:#}");
        assert!(
            e.starts_with("pole.hgt: the source spans") && e.contains("outside the world"),
            "{e}"
        );
    }

    /// A .hgt without a georeference (a renamed copy) is told how one is placed.
    #[test]
    fn a_hgt_without_a_georeference_is_told_it_is_placed_by_its_name() {
        let data = scratch("hgt-name");
        let map = Heightmap::new(Grid::new(3, 3, vec![1.0; 9]).unwrap(), Some(1.0), None);
        let e = build(&job("copy", "geodetic", &data), map)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with(
                "(use --scheme local); an SRTM .hgt is placed by its file name, as N44W072.hgt"
            ),
            "{e}"
        );
    }

    /// An .npz without its placement keys is told which they are: bounds without dx and dy
    /// were refused with no word of them.
    #[test]
    fn an_npz_without_a_georeference_is_told_the_keys_that_place_it() {
        let data = scratch("npz-keys");
        let map = Heightmap::new(Grid::new(3, 3, vec![1.0; 9]).unwrap(), Some(1.0), None);
        let j = Ingest {
            input: "bounds.npz".into(),
            ..job("b", "geodetic", &data)
        };
        let e = build(&j, map).unwrap_err().to_string();
        assert!(
            e.ends_with(
                "(use --scheme local); an .npz is placed by scalar xmin, ymin, ymax, dx and dy \
                 beside the array (xmax optional), agreeing with its shape"
            ),
            "{e}"
        );
    }

    /// An .npz whose bounds are not degrees is told so, not pointed at an ASCII grid's .prj
    /// (which it was: QA's grid from -180.5° read "an ESRI ASCII grid's is read from the
    /// .prj").
    #[test]
    fn an_npz_whose_bounds_are_not_degrees_is_told_why() {
        use zerotile_codec::raster::{Crs, Georef};
        let data = scratch("npz-not-degrees");
        let georef = Georef::north_up(Crs::Unknown, -180.5, 10.0, 1.0, 1.0);
        let map = Heightmap::new(Grid::new(3, 3, vec![1.0; 9]).unwrap(), None, Some(georef));
        let j = Ingest {
            input: "west.npz".into(),
            ..job("w", "geodetic", &data)
        };
        let e = build(&j, map).unwrap_err().to_string();
        assert!(
            e.contains("west.npz: its CRS is not known (an .npz's bounds are taken as degrees")
                && e.contains("and these do not)")
                && !e.contains(".prj"),
            "{e}"
        );
    }

    /// An ESRI ASCII grid goes on the globe when the `.prj` beside it names WGS 84: it was
    /// refused as "its CRS is unknown CRS" with or without one.
    #[test]
    fn an_ascii_grid_with_a_wgs84_prj_ingests_as_geodetic() {
        let data = scratch("asc-prj");
        let dir = data.parent().unwrap().to_path_buf();
        std::fs::create_dir_all(&dir).unwrap();
        // N44W072's north-west 60 × 60 samples, 3 arc-seconds apart.
        let n = 1201;
        let hgt = std::fs::read(crate::fixtures::shared_data("dem/N44W072.hgt")).unwrap();
        let mut text = format!(
            "ncols 60\nnrows 60\nxllcenter -72\nyllcenter {}\ncellsize {}\n",
            45.0 - 59.0 / 1200.0,
            1.0 / 1200.0
        );
        for r in 0..60 {
            let row: Vec<String> = (0..60)
                .map(|c| {
                    let k = 2 * (r * n + c);
                    i16::from_be_bytes([hgt[k], hgt[k + 1]]).to_string()
                })
                .collect();
            text += &(row.join(" ") + "\n");
        }
        let asc = dir.join("nw.asc");
        std::fs::write(&asc, text).unwrap();
        let j = Ingest {
            input: asc.clone(),
            max_zoom: Some(9),
            ..job("nw", "geodetic", &data)
        };
        let e = run(&j).unwrap_err().to_string();
        assert!(
            e.contains("its CRS is not known") && e.contains(".prj"),
            "{e}"
        );
        std::fs::write(
            dir.join("nw.prj"),
            r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#,
        )
        .unwrap();
        let (_, m) = run(&j).unwrap();
        let [w, s, e, n] = m.bounds;
        assert!(
            (w + 72.0).abs() < 1e-9 && (n - 45.0).abs() < 1e-9,
            "{:?}",
            m.bounds
        );
        assert!(
            (e - w - 59.0 / 1200.0).abs() < 1e-9 && n > s,
            "{:?}",
            m.bounds
        );
        assert_eq!(m.source_crs, "EPSG:4326");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A fill or precision that is not a finite number would poison every tile: refused up front.
    #[test]
    fn non_finite_fill_and_precision_are_refused() {
        let data = scratch("finite");
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let j = Ingest {
                fill: Some(bad),
                ..job("f", "local", &data)
            };
            assert!(
                check(&j).unwrap_err().to_string().contains("--fill"),
                "{bad}"
            );
            let j = Ingest {
                precision: Some(bad),
                ..job("p", "local", &data)
            };
            assert!(
                check(&j).unwrap_err().to_string().contains("--precision"),
                "{bad}"
            );
        }
        let j = Ingest {
            fill: Some(-5.0),
            precision: Some(0.5),
            ..job("ok", "local", &data)
        };
        assert_eq!(check(&j).unwrap(), "local");
    }

    /// Record corners are, by the container's definition, NW, NE, SW, SE.
    #[test]
    fn corners_are_north_west_north_east_south_west_south_east() {
        // 3×3 samples numbered row by row from the north-west: corners 0, 2, 6, 8.
        let g = Grid::new(3, 3, (0..9).map(f64::from).collect()).unwrap();
        assert_eq!(corners(&g), [0.0, 2.0, 6.0, 8.0]);
    }

    /// Reads back tile `id` of the container at `path` as the server does, every pass decoded.
    fn stored_tile(path: &Path, id: TileId) -> Grid<f64> {
        let rec = crate::serve::dataset::Dataset::open(path)
            .unwrap()
            .read_tile(id)
            .unwrap();
        ezw::decode(&rec.stream, ezw::DecodeLimit::All, ezw::DEFAULT_MAX_SAMPLES)
            .unwrap()
            .heights
    }

    /// A local hole takes the lowest valid height by default, and the stored tile holds it.
    #[test]
    fn local_holes_get_the_lowest_height() {
        let data = scratch("holes");
        let h = [
            10.0,
            20.0,
            30.0,
            40.0,
            50.0,
            f64::NAN,
            70.0,
            80.0,
            90.0,
            100.0,
            110.0,
            120.0,
        ];
        let map = Heightmap::new(Grid::new(3, 4, h.to_vec()).unwrap(), Some(1.0), None);
        let (path, m) = build(&job("holes", "local", &data), map).unwrap();
        assert_eq!((m.fill, m.height_range), (10.0, [10.0, 120.0]));
        let t = stored_tile(&path, TileId { z: 0, x: 0, y: 0 });
        assert_eq!(
            (*t.get(1, 1), *t.get(1, 2), *t.get(2, 3)),
            (10.0, 70.0, 120.0)
        );
        let _ = std::fs::remove_dir_all(&data);
    }

    /// A local grid without holes stores no fill, so a far-off --fill stays out of the range.
    #[test]
    fn a_fill_that_is_never_stored_stays_out_of_the_height_range() {
        let data = scratch("unused-fill");
        let map = Heightmap::new(
            Grid::new(2, 2, vec![5.0, 6.0, 7.0, 8.0]).unwrap(),
            Some(1.0),
            None,
        );
        let j = Ingest {
            fill: Some(1000.0),
            ..job("full", "local", &data)
        };
        let (_, m) = build(&j, map).unwrap();
        assert_eq!(m.height_range, [5.0, 8.0]);
        let _ = std::fs::remove_dir_all(&data);
    }

    /// A world tiling stores the fill around the source, so its range reaches the fill.
    #[test]
    fn a_world_height_range_takes_in_the_fill() {
        use zerotile_codec::raster::Georef;
        let data = scratch("world-range");
        let grid = Grid::new(3, 3, (100..109).map(f64::from).collect()).unwrap();
        let georef = Georef::north_up(Crs::Geographic, 10.0, 50.0, 0.01, 0.01);
        let map = Heightmap::new(grid, Some(1.0), Some(georef));
        let j = Ingest {
            max_zoom: Some(1),
            ..job("w", "geodetic", &data)
        };
        let (_, m) = build(&j, map).unwrap();
        assert_eq!((m.fill, m.height_range), (0.0, [0.0, 108.0]));
        // The source's own range is kept beside it.
        assert_eq!(m.source_height_range, Some([100.0, 108.0]));
        let _ = std::fs::remove_dir_all(&data);
    }

    /// A grid the server's tiling refuses (one sample, one row) is refused at ingest, before
    /// a file is written: it was written, then could not be opened by `serve`.
    #[test]
    fn a_grid_under_two_by_two_is_refused_before_anything_is_written() {
        let data = scratch("one");
        for (rows, cols) in [(1, 1), (1, 5), (5, 1)] {
            let map = Heightmap::new(
                Grid::new(rows, cols, vec![42.0; rows * cols]).unwrap(),
                Some(1.0),
                None,
            );
            let err = format!("{:#}", build(&job("one", "local", &data), map).unwrap_err());
            assert!(
                err.contains("at least 2 × 2 samples"),
                "{rows}×{cols}: {err}"
            );
            assert!(!data.join("one.ztd").exists());
        }
        // The smallest grid it takes is one whole tile at zoom 0, published as the only one.
        let map = Heightmap::new(Grid::new(2, 2, vec![42.0; 4]).unwrap(), Some(1.0), None);
        let (path, m) = build(&job("one", "local", &data), map).unwrap();
        assert_eq!((m.max_zoom, m.bounds), (0, [0.0, 1.0, 1.0, 0.0]));
        let a = m.available[0][0];
        assert_eq!((m.available.len(), a.end_x, a.end_y), (1, 0, 0));
        assert_eq!(
            *stored_tile(&path, TileId { z: 0, x: 0, y: 0 }).get(256, 256),
            42.0
        );
        let _ = std::fs::remove_dir_all(&data);
    }

    /// A 300-row, 600-column grid: 3×2 tiles of 256 steps, then 2×1, then 1; bounds are
    /// [west 0, south rows − 1, east cols − 1, north 0] in samples.
    #[test]
    fn the_local_plan_counts_tiles_per_axis() {
        let g = Grid::new(300, 600, vec![1.0; 300 * 600]).unwrap();
        let plan = local_plan(g, 0.0);
        assert_eq!(plan.max_zoom, 2);
        assert_eq!(plan.bounds, [0.0, 299.0, 599.0, 0.0]);
        let ends: Vec<(u32, u32)> = plan
            .available
            .iter()
            .map(|z| (z[0].end_x, z[0].end_y))
            .collect();
        assert_eq!(ends, [(0, 0), (1, 0), (2, 1)]);
        assert_eq!(plan.jobs.len(), 1 + 2 + 6);
        assert!(plan
            .jobs
            .iter()
            .all(|&(k, x, y, id)| { plan.levels[k].zoom == id.z && (x, y) == (id.x, id.y) }));
    }

    /// Writes of one file from several threads at once each succeed and leave one of them
    /// whole, with no temporary file behind (they shared one temporary file before).
    #[test]
    fn writes_of_one_file_at_once_each_rename_a_whole_file() {
        let dir = crate::fixtures::scratch("atomic-race");
        let target = dir.join("m.obj");
        let bodies: Vec<Vec<u8>> = (0..4u8).map(|k| vec![b'a' + k; 300_000]).collect();
        for round in 0..8 {
            let start = std::sync::Barrier::new(bodies.len());
            std::thread::scope(|s| {
                for body in &bodies {
                    let (target, start) = (&target, &start);
                    s.spawn(move || {
                        start.wait();
                        if let Err(e) = write_atomically(target, body) {
                            panic!("round {round}: {e:#}");
                        }
                    });
                }
            });
            let got = std::fs::read(&target).unwrap();
            assert!(bodies.contains(&got), "round {round}: a torn file");
            assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "round {round}");
        }
    }
}
