//! `zerotile eval mesh`: simplify one object mesh with one method and report counts, time and
//! Metro distances to the input, one JSON object per line (the benchmark scripts' contract,
//! see `shared/bench/object_mesh.py`) or a readable table.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{ArgGroup, Args, ValueEnum};
use serde::Serialize;
use zerotile_codec::mesh::curvature::{self, CurvatureOptions};
use zerotile_codec::mesh::distance::DEFAULT_SAMPLES;
use zerotile_codec::mesh::io::{self, MeshLimits};
use zerotile_codec::mesh::silhouette::sphere::MAX_LEVEL;
use zerotile_codec::mesh::silhouette::{View, ViewSphere};
use zerotile_codec::mesh::{
    qem, repair, surface_distance, DistanceOptions, OctreeLod, OctreeOptions, QemOptions,
    SurfaceDistance, TriMesh,
};

use super::{cell, median_ms, short};
use crate::bail_usage;
use crate::usage::usage;

/// Timed runs when `--repeat` is not given (the benchmark's peers report medians of 5).
pub const DEFAULT_REPEAT: usize = 5;

/// The most Metro samples `--samples` takes: 50× the default, ~0.5 GB of sample points.
const MAX_SAMPLES: u64 = 10_000_000;

/// The simplifiers `eval mesh` can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Curvature-error vertex decimation, Kim, Lim & Kim 2000 (codec/src/mesh/curvature/curvature.md).
    Curvature,
    /// Octree LOD with region-of-interest refinement, Jung, Cho & Whangbo 2009 (codec/src/mesh/octree/octree.md).
    Octree,
    /// Garland–Heckbert quadric edge collapse, the baseline (codec/src/mesh/qem/qem.md).
    Qem,
    /// Silhouette-preserving view-sphere LOD (codec/src/mesh/silhouette/silhouette.md).
    Silhouette,
}

impl Method {
    /// The name `--method` takes and the JSON gives.
    pub fn name(self) -> &'static str {
        match self {
            Self::Curvature => "curvature",
            Self::Octree => "octree",
            Self::Qem => "qem",
            Self::Silhouette => "silhouette",
        }
    }
}

#[derive(Args, Debug, Clone)]
#[command(group(ArgGroup::new("amount").required(true).args(["error", "level", "faces"])))]
pub struct MeshArgs {
    /// Mesh to simplify: .obj, .ply, .stl or .json.
    pub input: PathBuf,
    /// Simplification method.
    #[arg(long, value_enum)]
    pub method: Method,
    /// Error bound: for qem a fraction of the bounding-box diagonal (0.01 = 1 %); for
    /// curvature the paper's ε.
    #[arg(long, value_name = "E")]
    pub error: Option<f64>,
    /// LOD level (octree, silhouette; curvature 1–3: the nested levels cut at ε 0.15/0.20/0.25).
    #[arg(long, value_name = "K")]
    pub level: Option<u32>,
    /// Target face count.
    #[arg(long, value_name = "N")]
    pub faces: Option<usize>,
    /// Write the result here (.obj, .ply, .glb or .json; replaced atomically; never the input).
    #[arg(long, value_name = "OUT")]
    pub out: Option<PathBuf>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Timed runs, 1–100 (the median is reported).
    #[arg(long, default_value_t = DEFAULT_REPEAT, value_parser = super::parse_repeat())]
    pub repeat: usize,
    /// Metro samples per direction for the distances, 0–10,000,000 (0: skip them).
    // Bounded: each sample is 24 bytes a side, so 10^12 asked for 24 TB and aborted.
    #[arg(long, default_value_t = DEFAULT_SAMPLES,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(0..=MAX_SAMPLES))]
    pub samples: usize,
    /// Merge bit-identical vertex positions first (unwelded exports such as the teapot).
    #[arg(long)]
    pub weld: bool,
    /// Silhouette: view from this point (x,y,z) towards `--target`; facing cells are drawn
    /// one level coarser and silhouette cells one finer.
    #[arg(long, value_name = "X,Y,Z", requires = "target")]
    pub eye: Option<String>,
    /// Silhouette: the point looked at (x,y,z).
    #[arg(long, value_name = "X,Y,Z", requires = "eye")]
    pub target: Option<String>,
}

/// What was asked for, as the report names it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Param {
    Error(f64),
    Level(u32),
    Faces(usize),
}

/// One evaluation, with the field names the benchmark scripts read.
#[derive(Clone, Debug, Serialize)]
pub struct MeshPoint {
    pub input: String,
    pub method: Method,
    pub param: Param,
    pub vertices_in: usize,
    pub faces_in: usize,
    pub vertices: usize,
    pub faces: usize,
    /// Median simplification time: arrays in, arrays out (file I/O and repair excluded).
    pub ms: f64,
    /// Symmetric Hausdorff distance to the input, % of the input's bounding-box diagonal.
    pub hausdorff_pct: Option<f64>,
    /// Mean surface distance (larger direction), % of the diagonal.
    pub mean_pct: Option<f64>,
    /// Method-specific details (for qem: the simplifier's report).
    pub detail: serde_json::Value,
}

/// Runs the evaluation and prints it.
pub fn run(args: &MeshArgs) -> Result<()> {
    let point = evaluate(args)?;
    if let Some(note) = budget_note(&point) {
        eprintln!("zerotile: note: {note}");
    }
    if args.json {
        crate::cli::say(format!("{}\n", serde_json::to_string(&point)?))?;
    } else {
        crate::cli::say(table(&point))?;
    }
    Ok(())
}

/// A budget no method can meet is answered with the fewest faces it reaches (the
/// benchmark compares the octree at such targets): say so, or --faces would look ignored.
pub fn budget_note(p: &MeshPoint) -> Option<String> {
    // The other way round, the run looked like a simplification that removed nothing.
    if let Param::Faces(n) = p.param {
        if n >= p.faces_in {
            return Some(format!(
                "--faces {n}: the mesh has only {}, so the budget asks for no simplification",
                counted(p.faces_in, "face", "faces")
            ));
        }
    }
    let n = match p.param {
        Param::Faces(n) if p.faces > n => n,
        _ => return None,
    };
    let f = p.faces;
    Some(match p.method {
        Method::Octree | Method::Silhouette => format!(
            "--faces {n}: the coarsest {} level with faces has {f} on this mesh; measuring \
             that level",
            p.method.name()
        ),
        Method::Curvature => format!(
            "--faces {n}: curvature decimation stops at {f} faces on this mesh (no vertex \
             left whose removal keeps the surface manifold within its largest ε); measuring \
             that"
        ),
        Method::Qem => format!(
            "--faces {n}: quadric collapses stop at {f} faces on this mesh (no edge left \
             whose collapse keeps it manifold); measuring that"
        ),
    })
}

/// The evaluation without the printing (and `--out` written), so tests can read the point.
pub fn evaluate(args: &MeshArgs) -> Result<MeshPoint> {
    let param = param(args)?;
    let view = match (&args.eye, &args.target) {
        (Some(e), Some(t)) => Some(view(e, t)?),
        _ => None,
    };
    if let Some(out) = &args.out {
        writable("--out", out)?;
        not_the_input(&args.input, out)?;
    }
    // Read and repair: the simplifiers take a clean manifold.
    let input = load(&args.input, args.weld)?;
    // Simplify, timed over a few runs.
    let (ms, result) = median_ms(args.repeat, || simplify(&input, args.method, param, view));
    // What the mesh refuses (an octree level deeper than its octree) names the file.
    let (output, detail) = result.with_context(|| args.input.display().to_string())?;
    // Measure against the input the way Metro does.
    let distance = measure(&input, &output, args.samples)?;
    // Write the result atomically where asked.
    if let Some(out) = &args.out {
        super::write_mesh(&output, out)?;
    }
    Ok(MeshPoint {
        input: args.input.display().to_string(),
        method: args.method,
        param,
        vertices_in: input.vertex_count(),
        faces_in: input.face_count(),
        vertices: output.vertex_count(),
        faces: output.face_count(),
        ms,
        hausdorff_pct: distance.map(|d| d.hausdorff_pct()),
        mean_pct: distance.map(|d| d.mean_pct()),
        detail,
    })
}

/// The one size parameter, refusing before the mesh is read what no mesh could make right:
/// a bad value, none or two of them, one the method does not take, a view for another method.
fn param(args: &MeshArgs) -> Result<Param> {
    let param = match (args.error, args.level, args.faces) {
        (Some(e), None, None) if e.is_finite() && e >= 0.0 => Param::Error(e),
        (Some(e), None, None) => bail_usage!("--error must be finite and ≥ 0, got {e}"),
        (None, Some(k), None) => Param::Level(k),
        (None, None, Some(0)) => bail_usage!("--faces must be > 0"),
        (None, None, Some(n)) => Param::Faces(n),
        _ => bail_usage!("give exactly one of --error, --level, --faces"),
    };
    takes(args.method, param)?;
    if (args.eye.is_some() || args.target.is_some()) && args.method != Method::Silhouette {
        bail_usage!("--eye/--target apply to --method silhouette");
    }
    Ok(param)
}

const QEM_TAKES: &str = "qem takes --faces N or --error E, not --level";
const CURVATURE_LEVELS: &str =
    "curvature --level is 1, 2 or 3 (ε = 0.15, 0.20, 0.25); use --error E for others";
const SILHOUETTE_TAKES: &str = "silhouette takes --level K or --faces N";
const OCTREE_TAKES: &str = "octree takes --level K or --faces N, not --error";

/// Refuses a size parameter `method` does not take. ([`simplify`] says the same if called
/// with one.)
fn takes(method: Method, param: Param) -> Result<()> {
    let refused = match (method, param) {
        (Method::Qem, Param::Level(_)) => QEM_TAKES,
        (Method::Curvature, Param::Level(k))
            if !(1..=curvature::PAPER_LEVELS.len()).contains(&(k as usize)) =>
        {
            CURVATURE_LEVELS
        }
        (Method::Silhouette, Param::Error(_)) => SILHOUETTE_TAKES,
        (Method::Silhouette, Param::Level(k)) if k > u32::from(MAX_LEVEL) => {
            bail_usage!("silhouette --level is 0 to {MAX_LEVEL} (the view sphere's levels)")
        }
        (Method::Octree, Param::Error(_)) => OCTREE_TAKES,
        _ => return Ok(()),
    };
    Err(usage(refused))
}

/// Refuses an output that is the input file itself (by another name too: a symlink, a
/// hard link, `./`): the atomic write would replace the mesh the user gave with its result.
/// A usage error (2): no input could make that command line right.
fn not_the_input(input: &Path, output: &Path) -> Result<()> {
    if same_file(input, output) {
        bail_usage!(
            "{} is the input {}: writing the result there would replace it; choose another output",
            output.display(),
            input.display()
        );
    }
    Ok(())
}

/// Whether two paths name one existing file: by device and inode, which a symlink, a hard
/// link or `./` all share.
#[cfg(unix)]
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let id = |p: &Path| std::fs::metadata(p).map(|m| (m.dev(), m.ino())).ok();
    id(a).is_some_and(|a| Some(a) == id(b))
}

/// Whether two paths name one existing file, by their canonical paths (hard links apart).
#[cfg(not(unix))]
fn same_file(a: &Path, b: &Path) -> bool {
    let id = |p: &Path| std::fs::canonicalize(p).ok();
    id(a).is_some_and(|a| Some(a) == id(b))
}

/// `zerotile subdivide`: the input, repaired as `eval mesh` reads it, Loop-subdivided.
pub fn subdivide(args: &crate::cli::SubdivideArgs) -> Result<()> {
    // Before the work, which takes minutes for the large meshes this is for.
    writable("OUTPUT", &args.output)?;
    not_the_input(&args.input, &args.output)?;
    let mut mesh = load(&args.input, false)?;
    let limit = MeshLimits::default();
    // Checked before the first step, so a run that would pass the limit is refused
    // without building the steps below it.
    if subdivided_faces(mesh.face_count(), args.times, limit.max_faces).is_none() {
        bail!(
            "{} subdivided {} times would have more than the {} faces a mesh may have",
            args.input.display(),
            args.times,
            limit.max_faces
        );
    }
    for _ in 0..args.times {
        mesh = zerotile_codec::mesh::subdivide::loop_subdivide(&mesh);
    }
    super::write_mesh(&mesh, &args.output)?;
    eprintln!(
        "{}: {}, {}",
        args.output.display(),
        counted(mesh.vertex_count(), "vertex", "vertices"),
        counted(mesh.face_count(), "face", "faces")
    );
    Ok(())
}

/// The faces of `faces` Loop-subdivided `times` times (4× a step), if at most `max`.
pub(super) fn subdivided_faces(faces: usize, times: u8, max: usize) -> Option<usize> {
    4usize
        .checked_pow(u32::from(times))
        .and_then(|f| f.checked_mul(faces))
        .filter(|&f| f <= max)
}

pub(super) fn load(path: &Path, weld: bool) -> Result<TriMesh> {
    crate::regular_file::check_input(path)?;
    let mut mesh = io::read_path(path, &MeshLimits::default())
        .with_context(|| format!("reading {}", path.display()))?;
    if weld {
        mesh.weld();
    }
    let (clean, _report) =
        repair(&mesh).with_context(|| format!("repairing {}", path.display()))?;
    crate::serve::meshes::has_surface(&clean).with_context(|| format!("{}", path.display()))?;
    Ok(clean)
}

/// Refuses an output path whose extension names no format a mesh is written in, before the
/// work (the write came after it).
fn writable(what: &str, path: &Path) -> Result<()> {
    match io::Format::from_path(path) {
        Some(f) if io::Format::WRITABLE.contains(&f) => Ok(()),
        found => {
            let names: Vec<_> = io::Format::WRITABLE.iter().map(|f| f.extension()).collect();
            bail_usage!(
                "{what} {}: {}; write .{}",
                path.display(),
                match found {
                    Some(f) => format!("{} is read, not written", f.extension()),
                    None => "unknown mesh extension".to_string(),
                },
                names.join(", .")
            )
        }
    }
}

/// `--eye` and `--target` as a view, refusing one that looks nowhere.
fn view(eye: &str, target: &str) -> Result<View> {
    let view = View {
        eye: point("--eye", eye)?,
        target: point("--target", target)?,
    };
    if view.eye == view.target {
        bail_usage!("--eye and --target must differ: the view looks from one to the other");
    }
    Ok(view)
}

/// `x,y,z` as a finite point.
fn point(flag: &str, s: &str) -> Result<glam::DVec3> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| usage(format!("{flag} must be x,y,z numbers, got {s:?}")))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(glam::DVec3::new(*x, *y, *z)),
        _ => bail_usage!("{flag} must be three finite numbers x,y,z, got {s:?}"),
    }
}

/// One simplification run: the output mesh and the method's report as JSON.
fn simplify(
    input: &TriMesh,
    method: Method,
    param: Param,
    view: Option<View>,
) -> Result<(TriMesh, serde_json::Value)> {
    match method {
        Method::Qem => {
            let options = match param {
                Param::Faces(n) => QemOptions::to_faces(n),
                Param::Error(e) => QemOptions::to_error(e),
                Param::Level(_) => return Err(usage(QEM_TAKES)),
            };
            let (out, report): (TriMesh, qem::QemReport) = qem::simplify(input, &options)?;
            Ok((out, serde_json::to_value(report)?))
        }
        Method::Curvature => {
            let options = CurvatureOptions::default();
            // Per nested level, the time from the level before (`--level` only).
            let mut steps_ms = Vec::new();
            let (out, error) = match param {
                Param::Error(e) => (curvature::to_error(input, e, &options)?, e),
                Param::Faces(n) => curvature::to_faces(input, n, &options)?,
                // Level K of the nested sequence (as the server's `level=K`): one continuing
                // decimation cut at each of the paper's ε up to the K-th.
                Param::Level(k) => {
                    let Some(cuts) = curvature::PAPER_LEVELS
                        .get(..k as usize)
                        .filter(|c| !c.is_empty())
                    else {
                        return Err(usage(CURVATURE_LEVELS));
                    };
                    let mut levels = curvature::levels(input, cuts, &options)?;
                    steps_ms = levels.iter().map(|l| l.ms).collect();
                    let last = levels.pop().context("no curvature level")?;
                    (last.mesh, last.error)
                }
            };
            Ok((
                out,
                serde_json::json!({ "epsilon": error, "steps_ms": steps_ms, "options": options }),
            ))
        }
        Method::Silhouette => {
            let vs = ViewSphere::new(input)?;
            let (out, level) = match param {
                Param::Level(k) => {
                    let k = u8::try_from(k).unwrap_or(u8::MAX);
                    match &view {
                        Some(v) => {
                            let (m, drawn) = vs.view(v, Some(k))?;
                            return Ok((m, serde_json::to_value(drawn)?));
                        }
                        None => (vs.level(k)?, k),
                    }
                }
                // The finest level that meets the target: levels only coarsen downwards.
                Param::Faces(n) => {
                    let mut pick = None;
                    for k in (0..=vs.max_level()).rev() {
                        let m = vs.level(k)?;
                        let done = m.face_count() <= n;
                        pick = Some((m, k));
                        if done {
                            break;
                        }
                    }
                    pick.context("no levels")?
                }
                Param::Error(_) => return Err(usage(SILHOUETTE_TAKES)),
            };
            Ok((out, serde_json::json!({ "level": level })))
        }
        Method::Octree => octree_level(input, param),
    }
}

/// Octree LOD: builds the hierarchy (timed with the level, as a server's first request would
/// be) and cuts one level. `--faces N` takes the deepest non-empty level with at most N faces
/// (levels are coarse steps, so it can fall well below N), or the coarsest non-empty level
/// when none fits ([`run`] says so on stderr).
fn octree_level(input: &TriMesh, param: Param) -> Result<(TriMesh, serde_json::Value)> {
    let lod = OctreeLod::build(input, &OctreeOptions::default())?;
    let level = match param {
        Param::Level(k) => k,
        Param::Faces(n) => lod.level_for_faces(n),
        Param::Error(_) => return Err(usage(OCTREE_TAKES)),
    };
    let out = lod
        .level(level)
        .with_context(|| format!("--level {level}"))?;
    let (boxes, plain_boxes) = lod.box_totals();
    let detail = serde_json::json!({
        "level": level,
        "boxes": boxes,
        "plain_boxes": plain_boxes,
        "levels": lod.levels(),
    });
    Ok((out, detail))
}

pub(super) fn measure(
    input: &TriMesh,
    output: &TriMesh,
    samples: usize,
) -> Result<Option<SurfaceDistance>> {
    if samples == 0 || output.face_count() == 0 {
        return Ok(None);
    }
    let options = DistanceOptions {
        samples,
        ..DistanceOptions::default()
    };
    Ok(Some(surface_distance(input, output, &options)?))
}

/// `n` and the noun: "1 face", not "1 faces", which a one-triangle mesh was told.
fn counted(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// The table `eval mesh` prints for people: the input's counts, then one row for the point.
pub(super) fn table(p: &MeshPoint) -> String {
    let pct = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{}%", cell(v, 4, 10)));
    let param = match p.param {
        Param::Error(e) => format!("error {}", short(e, 8)),
        Param::Level(k) => format!("level {k}"),
        Param::Faces(n) => format!("faces {n}"),
    };
    format!(
        "{} ({}, {})\n\
         {:>10} {:>14} {:>9} {:>9} {:>9} {:>11} {:>11}\n\
         {:>10} {:>14} {:>9} {:>9} {:>9} {:>11} {:>11}\n",
        p.input,
        counted(p.vertices_in, "vertex", "vertices"),
        counted(p.faces_in, "face", "faces"),
        "method",
        "param",
        "vertices",
        "faces",
        "ms",
        "Hausdorff",
        "mean",
        p.method.name(),
        param,
        p.vertices,
        p.faces,
        cell(p.ms, 2, 9),
        pct(p.hausdorff_pct),
        pct(p.mean_pct)
    )
}
