//! `zerotile eval terrain`: rate, distortion and mesh figures per operating point,
//! one JSON object per line (the benchmark scripts' contract) or a table like the paper's.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use glam::DVec3;
use serde::Serialize;
use zerotile_codec::bintree::{self, Hierarchy, TileErrors};
use zerotile_codec::ezw::{self, DecodeLimit, EncodeParams};
use zerotile_codec::mesh::TriMesh;
use zerotile_codec::raster::{self, Encoding, ReadOptions};
use zerotile_codec::wavelet::Wavelet;
use zerotile_codec::zerotree::{self, Complexity};
use zerotile_codec::Grid;

use super::{cell, median_ms, short};
use crate::serve::threshold::Depth;

/// What to sweep.
#[derive(Clone, Debug, PartialEq)]
pub enum Sweep {
    Threshold(Vec<f64>),
    Bpp(Vec<f64>),
    MaxError(Vec<f64>),
    Lossless,
}

#[derive(Clone, Debug)]
pub struct TerrainEval {
    pub input: PathBuf,
    pub crop: Option<(usize, usize, usize)>,
    pub encoding: Option<Encoding>,
    pub npz_key: Option<String>,
    pub wavelet: Option<Wavelet>,
    pub step: Option<f64>,
    pub sweep: Sweep,
    pub repeat: usize,
    /// Rescale the window linearly to 0..=255 integers first: the paper's 8-bit setting.
    pub eight_bit: bool,
    /// Which mesher; `None` picks the bintree on (2^k + 1)² grids, the zerotree elsewhere.
    pub mesher: Option<Mesher>,
    /// Bintree in threshold mode: the share of T the decode gets (`None`: [`DECODE_SHARE`];
    /// another only to measure it).
    pub decode_share: Option<f64>,
    /// A folder for each point's mesh as OBJ (`--out`).
    pub out: Option<PathBuf>,
}

/// The two terrain meshers (see `zerotile_codec::bintree` for why there are two).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Mesher {
    /// The paper's: quadtree leaves where the decoder's zerotree is insignificant at T.
    Zerotree,
    /// Exact-error right-triangle bintree over the decoded heights: T is the true max error.
    Bintree,
}

impl Mesher {
    pub fn name(self) -> &'static str {
        match self {
            Self::Zerotree => "zerotree",
            Self::Bintree => "bintree",
        }
    }
}

/// Share of a threshold-mode error budget T spent on decoding; the mesh gets what the decode
/// left (T − its measured max error).
pub use zerotile_codec::bintree::DECODE_SHARE;

/// One operating point, with the field names the benchmark scripts read.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    pub input: String,
    pub rows: usize,
    pub cols: usize,
    pub wavelet: &'static str,
    /// `bintree` (T bounds the mesh's true error) or `zerotree` (the paper's: T is where the
    /// decoder's zerotree stops; the mesh errs by more). Picked by the grid's shape unless
    /// `--mesher` says: named so that a 256 crop's larger mesh error is not a surprise.
    pub mesher: &'static str,
    pub mode: &'static str,
    pub param: Option<f64>,
    /// The threshold of the last pass decoded; infinite (`null` in the JSON, `inf` in the
    /// table) when the decode read no pass: none reached the threshold it was read to, or the
    /// stream holds none (a `--step` so coarse that no coefficient reaches the finest pass,
    /// step/16: the coarsest coefficients grow with the mean height and the levels, so
    /// N44W072's 257 window has a pass at `--step 1e6`, none at `1e8`).
    pub threshold: f64,
    pub bytes: usize,
    pub bps: f64,
    pub psnr_db: Option<f64>,
    pub max_abs_err: f64,
    pub rmse: f64,
    pub mesh_triangles: usize,
    pub mesh_vertices: usize,
    pub mesh_max_abs_err: f64,
    pub mesh_rmse: f64,
    pub mesh_psnr_db: Option<f64>,
    pub encode_ms: f64,
    pub decode_ms: f64,
    pub mesh_ms: f64,
    /// Bintree threshold points: the decode alone erred by more than T, so the mesh gets none
    /// of T (it follows the decoded heights exactly) and its error is the stream's floor, not
    /// T (see [`floor_warning`]). Not in the JSON, whose fields are the benchmark scripts'
    /// contract; its errors say it.
    #[serde(skip)]
    pub below_floor: bool,
}

/// Loads the input (cropped) and returns heights, the step and the PSNR peak.
pub fn load(eval: &TerrainEval) -> Result<(Grid<f64>, f64, f64)> {
    crate::regular_file::check_input(&eval.input)?;
    // The whole window is one stream, which the decoder takes up to its sample limit: a
    // larger file was read, encoded and only then refused ("decoding our own stream"),
    // after gigabytes. With --crop the window's size is checked on the command line.
    let whole = eval.crop.is_none();
    let mut opts = ReadOptions {
        encoding: eval.encoding,
        npz_key: eval.npz_key.clone(),
        ..ReadOptions::default()
    };
    if whole {
        opts.max_samples = ezw::DEFAULT_MAX_SAMPLES;
    }
    let mut map = match raster::read_heightmap(&eval.input, &opts) {
        Err(e @ raster::RasterError::Limit { .. }) if whole => {
            return Err(anyhow::Error::new(e).context(format!(
                "eval terrain codes the window as one stream of at most {} samples; give \
                 --crop ROW,COL,SIZE (SIZE up to {})",
                ezw::DEFAULT_MAX_SAMPLES,
                MAX_WINDOW_SIDE
            )))
        }
        r => r?,
    };
    if let Some((row, col, size)) = eval.crop {
        map = map
            .crop(row, col, size, size)
            .with_context(|| format!("--crop {row},{col},{size}"))?;
    }
    if map.has_nodata() {
        bail!(
            "{}: the evaluated window holds {} no-data samples; choose a --crop without them",
            eval.input.display(),
            map.nodata_count
        );
    }
    let (lo, hi) = map.min_max().context("empty raster")?;
    if eval.eight_bit {
        let scale = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
        let heights = map.heights.map(|h| ((h - lo) * scale).round());
        return Ok((heights, 1.0, 255.0));
    }
    let step = eval.step.or(map.step).unwrap_or(0.01);
    // PSNR peak: the window's height range (255 for 8-bit data, as the paper uses); the step
    // only for a flat window, which has none (a --step past the range made it the peak:
    // 545 dB beside a 1.9 km error).
    let peak = if is_8bit(&map.heights, map.step) {
        255.0
    } else if hi > lo {
        hi - lo
    } else {
        step
    };
    Ok((map.heights, step, peak))
}

/// The largest `--crop` SIZE: a SIZE² window within the decoder's sample limit.
pub const MAX_WINDOW_SIDE: usize = 8192;
const _: () = assert!(MAX_WINDOW_SIDE * MAX_WINDOW_SIDE <= ezw::DEFAULT_MAX_SAMPLES);

/// Integer heights in 0..=255: 8-bit data, whose PSNR peak is 255 whatever the window's
/// range (the paper's convention).
pub(super) fn is_8bit(g: &Grid<f64>, step: Option<f64>) -> bool {
    step == Some(1.0) && g.data().iter().all(|&h| (0.0..=255.0).contains(&h))
}

/// Runs the sweep and returns one point per parameter.
pub fn run(eval: &TerrainEval) -> Result<Vec<Point>> {
    // Before any work: it was a bare "File exists (os error 17)" after the first point
    // (for /dev/null too: not a file, not a folder).
    if let Some(out) = eval.out.as_ref().filter(|o| o.exists() && !o.is_dir()) {
        bail!(
            "--out {}: is not a folder; give a folder for the meshes",
            out.display()
        );
    }
    let (heights, step, peak) = load(eval)?;
    let side = heights.rows();
    // Once per run: the hierarchy of a 257² grid takes as long as meshing it.
    let hierarchy = (heights.cols() == side)
        .then(|| Hierarchy::new(side))
        .flatten();
    // Refused before any point is measured (with --crop the command line is refused
    // earlier, as a usage error).
    if hierarchy.is_none() {
        let name = eval.input.display();
        let (rows, cols) = (heights.rows(), heights.cols());
        if eval.mesher == Some(Mesher::Bintree) {
            bail!("{name}: --mesher bintree needs a square (2^k + 1)-sample grid, this one is {rows}×{cols} (e.g. --crop R,C,257)");
        }
        if eval.decode_share.is_some() {
            bail!("{name}: --decode-share applies to the bintree mesher, which needs a square (2^k + 1)-sample grid; this one is {rows}×{cols} (e.g. --crop R,C,257)");
        }
    }
    let src = Source {
        name: eval.input.display().to_string(),
        heights: &heights,
        peak,
        hierarchy: hierarchy.as_ref(),
    };
    let lossy_wavelet = eval.wavelet.unwrap_or(Wavelet::Cdf97);
    let mut points = Vec::new();
    match &eval.sweep {
        Sweep::Threshold(ts) | Sweep::Bpp(ts) => {
            let params = EncodeParams::new(lossy_wavelet, step);
            let (encode_ms, enc) = median_ms(eval.repeat, || ezw::encode(&heights, &params));
            let enc = enc.with_context(|| encoding(eval, None))?;
            let threshold_mode = matches!(eval.sweep, Sweep::Threshold(_));
            if !threshold_mode {
                check_rates(ts, enc.header_len, heights.len())?;
            }
            for &p in ts {
                let limit = if threshold_mode {
                    DecodeLimit::Threshold(p)
                } else {
                    DecodeLimit::Bytes(rate_bytes(p, heights.len()))
                };
                let mode = if threshold_mode { "threshold" } else { "bpp" };
                points.push(measure(
                    eval,
                    &src,
                    &enc.bytes,
                    limit,
                    mode,
                    Some(p),
                    encode_ms,
                )?);
            }
        }
        Sweep::MaxError(es) => {
            for &e in es {
                let params = EncodeParams {
                    max_error: Some(e),
                    ..EncodeParams::new(lossy_wavelet, step)
                };
                let (encode_ms, enc) = median_ms(eval.repeat, || ezw::encode(&heights, &params));
                let enc = enc.with_context(|| encoding(eval, Some(e)))?;
                points.push(measure(
                    eval,
                    &src,
                    &enc.bytes,
                    DecodeLimit::All,
                    "max-error",
                    Some(e),
                    encode_ms,
                )?);
            }
        }
        Sweep::Lossless => {
            if eval.wavelet == Some(Wavelet::Cdf97) {
                crate::bail_usage!("--lossless needs the reversible 5/3 wavelet (--wavelet 53)");
            }
            // Lossless is exact in height steps; float heights off the step grid would come
            // back rounded to it, which is a max-error point, not a lossless one.
            let off_grid = heights
                .data()
                .iter()
                .map(|&h| (h / step - (h / step).round()).abs())
                .fold(0.0, f64::max);
            if off_grid > 1e-6 {
                bail!(
                    "{}: heights are not multiples of the height step {step} (float data), so \
                     no decode of them is exact; use --max-error {} to keep every height within \
                     half a step, or --step to choose the step",
                    eval.input.display(),
                    step / 2.0
                );
            }
            let params = EncodeParams::new(Wavelet::LeGall53, step);
            let (encode_ms, enc) = median_ms(eval.repeat, || ezw::encode(&heights, &params));
            let enc = enc.with_context(|| encoding(eval, None))?;
            let point = measure(
                eval,
                &src,
                &enc.bytes,
                DecodeLimit::All,
                "lossless",
                None,
                encode_ms,
            )?;
            // Exact means equal in height steps: 0.1 m steps are not exact in binary, so the
            // decoded (units + offset) × step and the reader's own product may differ in the
            // last bits of the f64.
            if point.max_abs_err > step * 1e-6 {
                bail!(
                    "internal error: lossless decode differs by {} (please report)",
                    point.max_abs_err
                );
            }
            // Exact, so report it as exact: the f64 residue (~1e-13) would print as a
            // ~330 dB PSNR that means nothing. So is the mesh when it keeps every sample, as
            // the zerotree mesher does at the lossless threshold (the bintree meshes within
            // it, one step).
            let mut point = Point {
                max_abs_err: 0.0,
                rmse: 0.0,
                psnr_db: None,
                ..point
            };
            if point.mesh_max_abs_err <= step * 1e-6 {
                point.mesh_max_abs_err = 0.0;
                point.mesh_rmse = 0.0;
                point.mesh_psnr_db = None;
            }
            points.push(point);
        }
    }
    Ok(points)
}

/// The stream prefix, in bytes, that `bpp` bits per sample buy over `samples` samples.
fn rate_bytes(bpp: f64, samples: usize) -> usize {
    ((bpp * samples as f64) / 8.0).floor() as usize
}

/// Errors unless every `--bpp` rate keeps the whole stream header (`header_len` bytes over
/// `samples`): a shorter prefix decodes to nothing, so no point can be measured there.
pub(super) fn check_rates(rates: &[f64], header_len: usize, samples: usize) -> Result<()> {
    // Rounded up to 4 decimals so that the rate printed is itself usable.
    let smallest = (header_len as f64 * 8.0 / samples.max(1) as f64 * 1e4).ceil() / 1e4;
    if let Some(p) = rates.iter().find(|&&p| rate_bytes(p, samples) < header_len) {
        bail!(
            "--bpp {p}: below the smallest usable rate for this window, {smallest} bits/sample \
             (the stream's {header_len}-byte header over {samples} samples); a prefix without \
             the whole header holds no data to decode"
        );
    }
    Ok(())
}

/// An encoder refusal's context: the file, and the flags that set what it refused (the
/// encoder's own words are its parameters', `max_error` and `step`).
fn encoding(eval: &TerrainEval, max_error: Option<f64>) -> String {
    let mut flags = Vec::new();
    if let Some(s) = eval.step {
        flags.push(format!("--step {s}"));
    }
    if let Some(e) = max_error {
        flags.push(format!("--max-error {e}"));
    }
    let with = if flags.is_empty() {
        String::new()
    } else {
        format!(" with {}", flags.join(" "))
    };
    format!("{}: encoding the window{with}", eval.input.display())
}

/// What every operating point of a run is measured against.
struct Source<'a> {
    name: String,
    heights: &'a Grid<f64>,
    /// PSNR peak.
    peak: f64,
    /// The bintree of a square (2^k + 1)² window, else `None`.
    hierarchy: Option<&'a Hierarchy>,
}

fn measure(
    eval: &TerrainEval,
    src: &Source<'_>,
    bytes: &[u8],
    limit: DecodeLimit,
    mode: &'static str,
    param: Option<f64>,
    encode_ms: f64,
) -> Result<Point> {
    let (name, heights, peak, hierarchy) = (&src.name, src.heights, src.peak, src.hierarchy);
    let n = heights.len() as f64;
    let mesher = eval.mesher.unwrap_or(if hierarchy.is_some() {
        Mesher::Bintree
    } else {
        Mesher::Zerotree
    });
    // The bintree spends T on decode and mesh together (see DECODE_SHARE), decoding as deep
    // as the server does for that T.
    let limit = match (mesher, limit) {
        (Mesher::Bintree, DecodeLimit::Threshold(t)) => {
            Depth::for_budget(t * eval.decode_share.unwrap_or(DECODE_SHARE)).limit()
        }
        (_, l) => l,
    };
    // Time the decode this mesher is served from: the bintree's (the server's tiles) reads
    // heights alone, the zerotree mesher also takes the decoder's coefficients, whose copy
    // and scaling would otherwise be billed to a mesh that never reads them.
    let max = ezw::DEFAULT_MAX_SAMPLES;
    let (decode_ms, dec) = match mesher {
        Mesher::Bintree => median_ms(eval.repeat, || {
            ezw::decode_heights(bytes, limit, max).map(|d| (d, None))
        }),
        Mesher::Zerotree => median_ms(eval.repeat, || {
            ezw::decode(bytes, limit, max).map(|d| {
                let (heights, coefficients) = d.split_coefficients();
                (heights, Some(coefficients))
            })
        }),
    };
    let (dec, coefficients) = dec.context("decoding our own stream")?;
    let (max_abs_err, rmse) = errors(&dec.heights, heights);
    let below_floor =
        mesher == Mesher::Bintree && mode == "threshold" && param.is_some_and(|t| max_abs_err > t);
    let mesh_t = match (mesher, param) {
        // Budget minus the decode's measured error (eval knows the source; the server reads
        // the bound the stream records).
        (Mesher::Bintree, Some(t)) if mode == "threshold" => (t - max_abs_err).max(0.0),
        _ => match limit {
            DecodeLimit::Threshold(t) => t,
            _ => dec.threshold,
        },
    };
    let (mesh_ms, mesh) = match (mesher, hierarchy) {
        (Mesher::Bintree, Some(h)) => median_ms(eval.repeat, || {
            let errors = TileErrors::exact_above(h, &dec.heights, mesh_t);
            bintree::extract(h, &errors, &dec.heights, mesh_t, None)
        }),
        (Mesher::Bintree, None) => {
            bail!("--mesher bintree needs a square (2^k + 1)-sample grid (e.g. --crop R,C,257)")
        }
        (Mesher::Zerotree, _) => {
            let coefficients =
                coefficients.context("the zerotree decode keeps its coefficients")?;
            median_ms(eval.repeat, || {
                // The decoder's zerotree, cut at the threshold this point decoded to.
                let leaves = Complexity::new(&dec.layout, &coefficients).leaves(mesh_t);
                zerotree::triangulate(&leaves, &dec.heights, None)
            })
        }
    };
    let merr = zerotree::mesh_error(&mesh, heights);
    if let Some(dir) = &eval.out {
        write_mesh(dir, mode, param, &mesh)?;
    }
    let bytes_used = dec.bytes_used;
    let wavelet = if mode == "lossless" {
        Wavelet::LeGall53
    } else {
        eval.wavelet.unwrap_or(Wavelet::Cdf97)
    };
    Ok(Point {
        input: name.clone(),
        rows: heights.rows(),
        cols: heights.cols(),
        wavelet: wavelet.name(),
        mesher: mesher.name(),
        mode,
        param,
        threshold: dec.threshold,
        bytes: bytes_used,
        bps: bytes_used as f64 * 8.0 / n,
        psnr_db: psnr(peak, rmse),
        max_abs_err,
        rmse,
        mesh_triangles: mesh.triangle_count(),
        mesh_vertices: mesh.vertex_count(),
        mesh_max_abs_err: merr.max_abs,
        mesh_rmse: merr.rmse,
        mesh_psnr_db: psnr(peak, merr.rmse),
        encode_ms,
        decode_ms,
        mesh_ms,
        below_floor,
    })
}

/// What to tell the user about a point whose T the stream cannot reach: a lossy stream
/// stops at a finest pass set by the height step, and below its error no threshold buys more.
/// The mesh is then cut at 0 on the decoded heights, which drops every vertex they place on a
/// plane: it said "keeps every sample" over 2 triangles when a `--step` past the window's
/// range had coded no pass and the decode was flat. So the warning gives the mesh's size.
pub fn floor_warning(p: &Point) -> Option<String> {
    let t = short(p.param.filter(|_| p.below_floor)?, 12);
    let reach = if p.threshold.is_finite() {
        format!("its last pass decodes within {:.4}", p.max_abs_err)
    } else {
        format!(
            "it decodes no pass at all, so only within {:.4}; a --step near or past the \
             window's height range leaves the stream none",
            p.max_abs_err
        )
    };
    Some(format!(
        "warning: --threshold {t}: below what this {} stream can reach ({reach}), so none of T \
         is left for the mesh: it follows the decoded heights exactly ({} triangles, {} of \
         {} samples) and errs by up to {:.4}, not {t}; --wavelet 53 decodes exactly, a \
         smaller --step lowers the floor",
        p.wavelet,
        p.mesh_triangles,
        p.mesh_vertices,
        p.rows * p.cols,
        p.mesh_max_abs_err,
    ))
}

/// Writes `mesh` as `dir/MODE-PARAM.obj` (atomically, as every mesh file is written), in
/// the server's local-scheme coordinates (`render::tri_mesh`): x the window's column, y minus
/// its row, z the height. The mesher's (column, row) plane is mirrored, so its triangles were
/// clockwise from above and every viewer lit the terrain's underside.
pub(crate) fn write_mesh(
    dir: &Path,
    mode: &str,
    param: Option<f64>,
    mesh: &zerotree::TerrainMesh,
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("--out {}", dir.display()))?;
    let name = match param {
        Some(p) => format!("{mode}-{p}.obj"),
        None => format!("{mode}.obj"),
    };
    let tri = TriMesh {
        positions: mesh
            .positions
            .iter()
            .map(|&[c, r, h]| DVec3::new(c, -r, h))
            .collect(),
        faces: mesh.triangles.clone(),
    };
    let path = dir.join(name);
    super::write_mesh(&tri, &path)
}

/// Max |a − b| and RMSE over all samples.
pub fn errors(a: &Grid<f64>, b: &Grid<f64>) -> (f64, f64) {
    let (mut max, mut sum) = (0.0f64, 0.0);
    for (x, y) in a.data().iter().zip(b.data()) {
        let d = (x - y).abs();
        max = max.max(d);
        sum += d * d;
    }
    (max, (sum / a.len().max(1) as f64).sqrt())
}

/// 20·log10(peak / RMSE); `None` when exact (infinite: JSON has no infinity).
pub fn psnr(peak: f64, rmse: f64) -> Option<f64> {
    (rmse > 0.0).then(|| 20.0 * (peak / rmse).log10())
}

/// The paper's Table 1 layout, for people. `remain` is each mesh's triangles as a share of
/// the full grid's, 2 (rows − 1)(cols − 1), the paper's "remaining" column ("-" for a grid
/// without cells).
pub fn table(points: &[Point]) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    if let Some(p) = points.first() {
        // What the bintree guarantees: the mesh within its tolerance of the decoded heights.
        // `--threshold` gives it T minus the decode's error; the other modes their last pass,
        // the T column, on top of the decode's error (which "mesh err ≤ T" hid).
        let bound = match (p.mesher, p.mode) {
            ("bintree", "threshold") => {
                "mesh within param − max err of the decoded heights, so mesh err ≤ param"
            }
            ("bintree", _) => "mesh within T of the decoded heights, so mesh err ≤ T + max err",
            _ => "T stops the zerotree; mesh err not bounded by T",
        };
        let _ = writeln!(
            out,
            "{} ({}×{}, {}, {} mesher: {bound})",
            p.input, p.rows, p.cols, p.wavelet, p.mesher
        );
    }
    let _ = writeln!(
        out,
        "{:>10} {:>9} {:>9} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>7} {:>8}",
        "mode",
        "param",
        "T",
        "bps",
        "PSNR dB",
        "max err",
        "RMSE",
        "mesh dB",
        "mesh err",
        "triangles",
        "remain",
        "dec+mesh"
    );
    for p in points {
        let f = |v: Option<f64>| v.map_or("inf".to_string(), |v| cell(v, 2, 9));
        let full = 2 * p.rows.saturating_sub(1) * p.cols.saturating_sub(1);
        let remain = if full == 0 {
            String::from("-")
        } else {
            format!("{:.1}%", 100.0 * p.mesh_triangles as f64 / full as f64)
        };
        let _ = writeln!(
            out,
            "{:>10} {:>9} {:>9} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10} {:>7} {:>6}ms",
            p.mode,
            p.param.map_or("-".into(), |v| short(v, 9)),
            cell(p.threshold, 3, 9),
            cell(p.bps, 3, 7),
            f(p.psnr_db),
            cell(p.max_abs_err, 3, 9),
            cell(p.rmse, 3, 9),
            f(p.mesh_psnr_db),
            cell(p.mesh_max_abs_err, 3, 9),
            p.mesh_triangles,
            remain,
            cell(p.decode_ms + p.mesh_ms, 2, 6)
        );
    }
    out
}

/// Parses `ROW,COL,SIZE`.
pub fn parse_crop(s: &str) -> Result<(usize, usize, usize), String> {
    let v: Vec<usize> = s
        .split(',')
        .map(|p| p.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--crop '{s}': expected ROW,COL,SIZE (whole numbers)"))?;
    match v.as_slice() {
        [r, c, n] if (2..=MAX_WINDOW_SIDE).contains(n) => Ok((*r, *c, *n)),
        [_, _, n] if *n > MAX_WINDOW_SIDE => Err(format!(
            "--crop '{s}': SIZE must be at most {MAX_WINDOW_SIDE} (the window is coded as one \
             stream of at most {} samples)",
            ezw::DEFAULT_MAX_SAMPLES
        )),
        // One sample holds no triangle: a 1 × 1 window measured T as inf and 0 triangles.
        [_, _, _] => Err(format!(
            "--crop '{s}': SIZE must be at least 2 (a window needs 2 × 2 samples for a triangle)"
        )),
        _ => Err(format!(
            "--crop '{s}': expected ROW,COL,SIZE (whole numbers)"
        )),
    }
}

/// The input's display name for errors.
pub fn display(p: &Path) -> String {
    p.display().to_string()
}
