//! Command-line parsing: one place where flags become typed options.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{ArgGroup, Args, Parser, Subcommand};
use zerotile_codec::formats::terrain_rgb::PngCompression;
use zerotile_codec::geo::VerticalDatum;
use zerotile_codec::raster::Encoding;
use zerotile_codec::wavelet::Wavelet;

use crate::eval::{self, terrain};

#[derive(Parser, Debug)]
#[command(
    name = "zerotile",
    version,
    about = "EZW terrain tiles: ingest, serve, evaluate"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// Commands taking numbers allow negative ones as values (`allow_negative_numbers`): `--step
/// -1` is then refused by the option's own check instead of clap's "unexpected argument '-1'"
/// and its wrong tip to write `-- -1`.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Build a dataset (an EZW tile pyramid in one container file) from a heightmap.
    #[command(allow_negative_numbers = true)]
    Ingest(IngestArgs),
    /// Serve every dataset of a folder over HTTP (routes: docs/api.md).
    #[command(allow_negative_numbers = true)]
    Serve(ServeArgs),
    /// Write a dataset as a static tile tree (z/x/y files, and layer.json for terrain) for a CDN.
    #[command(allow_negative_numbers = true)]
    Export(ExportArgs),
    /// Describe a dataset file (tiling, zooms, bytes per zoom); with --verify, read and
    /// decode every tile (check a copy before serving it). Exit 0 when every check passes,
    /// 3 when a check failed (the report says which; a truncated or garbled header too), 1
    /// when the system would not give the file (none there, no permission, an I/O error).
    Info(InfoArgs),
    /// Measure the codec and mesher on one input.
    #[command(subcommand)]
    Eval(EvalCommand),
    /// Generate the default data (a synthetic terrain dataset and object meshes) into DATA
    /// unless it already has some; `serve` does this on its default folder.
    DemoData(DemoArgs),
    /// Loop-subdivide a mesh (4× the faces a step) into a large smooth test mesh, e.g. the
    /// 1.1M-face bunny the QEM figures use: `subdivide stanford-bunny.obj bunny-x16.obj`.
    #[command(allow_negative_numbers = true)]
    Subdivide(SubdivideArgs),
    /// Exit 0 if a server answers GET /healthz with 200 within 3 s (for container health
    /// checks, where there is no curl).
    Healthcheck(HealthArgs),
}

#[derive(Args, Debug)]
pub struct ExportArgs {
    /// Dataset: a name in DATA, or the path of a .ztd file.
    pub dataset: std::ffi::OsString,
    /// Folder of datasets.
    #[arg(long, default_value = "data")]
    pub data: PathBuf,
    /// Tile format: terrain (Cesium quantized-mesh, with layer.json), png (terrain-RGB, 512²),
    /// a mesh in the scheme's coordinates (json, bin, obj, glb), or 3dtiles (glb tiles in
    /// metres about each tile's centre under a 3D Tiles tileset.json, for CesiumJS's
    /// Cesium3DTileset and the Cesium engine plugins; geodetic and mercator datasets).
    #[arg(long, default_value = "terrain")]
    pub format: String,
    /// Output folder: new, empty or an earlier export holding only its own files (any other
    /// folder, a file, or an export with files added is refused); replaced atomically when
    /// the export is complete.
    #[arg(long)]
    pub out: PathBuf,
    /// Zooms to export: A-B or Z (default: all).
    #[arg(long, value_name = "A-B", value_parser = crate::export::parse_zooms)]
    pub zoom: Option<(u8, u8)>,
    /// Where the tree will be served from (http(s) URL of the --out folder): a png export
    /// of a mercator dataset then also writes tiles.json (TileJSON, absolute tile URLs), the
    /// `url` of a MapLibre raster-dem source.
    #[arg(long, value_name = "URL")]
    pub base_url: Option<String>,
    /// DEFLATE effort of png tiles: fast | balanced | best (the same pixels; balanced takes
    /// ~4× fast's time for ~30 % fewer bytes, best tries four row filters, ~3.5× balanced's
    /// time for up to ~1 % fewer). Default: balanced.
    #[arg(long, value_name = "EFFORT")]
    pub png_compression: Option<PngCompression>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Dataset: a name in DATA, or the path of a .ztd file.
    pub dataset: std::ffi::OsString,
    /// Folder of datasets.
    #[arg(long, default_value = "data")]
    pub data: PathBuf,
    /// Read every tile record (checksums) and decode every stream to its end.
    #[arg(long)]
    pub verify: bool,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct HealthArgs {
    /// Address of the server, HOST:PORT.
    #[arg(long, default_value = "127.0.0.1:8080", value_parser = host_port)]
    pub addr: String,
}

#[derive(Args, Debug)]
pub struct SubdivideArgs {
    /// Mesh: .obj, .ply or .stl.
    pub input: PathBuf,
    /// Output mesh (.obj, .ply, .glb or .json), written atomically; never the input.
    pub output: PathBuf,
    /// Loop steps, each 4× the faces: 1–4.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=4))]
    pub times: u8,
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Folder of datasets.
    #[arg(long, default_value = "data")]
    pub data: PathBuf,
    /// Build the demo's files even when the folder already has datasets and meshes; files of
    /// the same names the demo did not write (your own meshes/torus.obj) are kept, with a note.
    #[arg(long)]
    pub force: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct IngestArgs {
    /// Heightmap: .hgt, .tif (GeoTIFF), .png (gray, terrain-RGB, Terrarium), .asc, .npy, .npz.
    pub input: PathBuf,
    /// Dataset name (1–64 of A–Z, a–z, 0–9, '-', '_'): the file is DATA/NAME.ztd.
    #[arg(long)]
    pub name: String,
    /// Folder of datasets.
    #[arg(long, default_value = "data")]
    pub data: PathBuf,
    /// Tiling: local (the source grid as is), geodetic (EPSG:4326, Cesium quantized-mesh
    /// TMS) or mercator (EPSG:3857, XYZ as MapLibre uses); the last two need a source in
    /// EPSG:4326 or EPSG:3857.
    #[arg(long, default_value = "local", value_parser = ["local", "geodetic", "mercator"])]
    pub scheme: String,
    /// Deepest zoom of a geodetic or mercator pyramid (default: the first zoom as fine as
    /// the source).
    #[arg(long, value_name = "Z", value_parser = clap::value_parser!(u8).range(0..=28))]
    pub max_zoom: Option<u8>,
    /// Wavelet: 97 (CDF 9/7, default) or 53 (reversible LeGall 5/3).
    #[arg(long, default_value = "97")]
    pub wavelet: Wavelet,
    /// Guarantee |stored − source| ≤ METRES with the residual pass (default: keep every
    /// bit plane).
    #[arg(long, value_name = "METRES")]
    pub precision: Option<f64>,
    /// How colour PNGs encode heights: terrain-rgb | terrarium | gray.
    #[arg(long)]
    pub encoding: Option<Encoding>,
    /// Array name inside an .npz file.
    #[arg(long)]
    pub key: Option<String>,
    /// Height for samples without data (default: the lowest valid height for local
    /// datasets, 0 m around and inside geodetic and mercator ones). Below sea level is
    /// written as it is: `--fill -5`.
    #[arg(long, value_name = "METRES", allow_negative_numbers = true)]
    pub fill: Option<f64>,
    /// What the heights are measured from: egm96 (mean sea level, as SRTM's) or ellipsoid
    /// (WGS84; `wgs84` says the same; either in any case). Quantized-mesh tiles and `frame=enu` meshes of egm96 heights are raised by
    /// the geoid's undulation to the ellipsoid, which Cesium draws on. Default: egm96 for
    /// `.hgt` and for a GeoTIFF whose VerticalCSTypeGeoKey is EGM96 (EPSG:5773), otherwise
    /// served as they are.
    #[arg(long, value_name = "DATUM")]
    pub vertical_datum: Option<VerticalDatum>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Folder of datasets (`*.ztd`, as `zerotile ingest` writes them), or a store URL
    /// (`s3://bucket/prefix`, `http(s)://…`; credentials and endpoint from the usual `AWS_*`
    /// variables) read by byte ranges. Without it the server uses `data/`, generating the
    /// default data there first if it has none.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Address to listen on, HOST:PORT (an IP address or a name such as localhost); port 0
    /// picks a free port (the URL is printed).
    #[arg(long, default_value = "127.0.0.1:8080", value_parser = listen_addr)]
    pub addr: std::net::SocketAddr,
    /// Decoded-tile cache size, MiB.
    #[arg(long, default_value_t = 256, value_name = "MIB")]
    pub cache_mb: u64,
    /// Allow only this origin in CORS (repeatable; default: any origin), e.g.
    /// `--cors-origin https://maps.example.org`.
    #[arg(long = "cors-origin", value_name = "ORIGIN")]
    pub cors_origins: Vec<String>,
    /// Renders (decode + mesh + encode) run at once; default twice the cores.
    #[arg(long, value_name = "N")]
    pub cpu_jobs: Option<usize>,
    /// Renders allowed to wait for a slot; past it requests get 503 + Retry-After at once
    /// (load shedding). Default 64 per core.
    #[arg(long, value_name = "N")]
    pub cpu_queue: Option<usize>,
    /// Threads that decode and mesh, shared by all renders; one render's independent parts
    /// (a cold tile's five decodes, a view's tiles) run on them side by side. Default: the
    /// cores; at most 1024.
    #[arg(long, value_name = "N")]
    pub render_threads: Option<usize>,
    /// DEFLATE effort of terrain-RGB PNG tiles: fast | balanced | best. The same pixels;
    /// rendered on request, fast keeps a cold 512² tile's compression to a few ms where
    /// balanced takes ~4× as long for ~30 % fewer bytes. Default: fast.
    #[arg(long, value_name = "EFFORT")]
    pub png_compression: Option<PngCompression>,
    /// The URL clients reach the server at, e.g. `https://tiles.example.org/terrain`: the
    /// absolute tile URLs of tiles.json (TileJSON) start with it. Default: each request's
    /// Host header, over http.
    #[arg(long, value_name = "URL")]
    pub public_url: Option<String>,
    /// Take tiles.json's scheme, host and path prefix from X-Forwarded-Proto, -Host and
    /// -Prefix (the last value of each). Only behind a proxy that sets them: any client can
    /// send them, and the answer is cacheable.
    #[arg(long)]
    pub trust_forwarded: bool,
    /// Refuse mesh uploads (POST /v1/meshes/NAME is 403 read_only). For a server anyone can
    /// reach: uploads are otherwise stored in the data folder, up to --mesh-quota.
    #[arg(long)]
    pub read_only: bool,
    /// Faces the served meshes may hold together; an upload that would pass it is 507
    /// mesh_quota (each mesh counts as at least 10,000). Meshes put in the folder are served
    /// whatever they hold [default: 10000000]
    #[arg(long, value_name = "FACES")]
    pub mesh_quota: Option<u64>,
    /// Rescan the datasets (and the meshes of DATA/meshes) every SECS seconds: a dataset
    /// ingested, replaced or removed, or a mesh file, is served, served anew or gone without
    /// a restart (SIGHUP rescans at once). 0: only on SIGHUP. Default: 5 for a folder; for a
    /// store URL only on SIGHUP (each listing is a request the store bills).
    #[arg(long, value_name = "SECS")]
    pub rescan: Option<u64>,
}

#[derive(Subcommand, Debug)]
pub enum EvalCommand {
    /// Rate, distortion and mesh figures of the terrain codec on one heightmap.
    #[command(allow_negative_numbers = true)]
    Terrain(TerrainArgs),
    /// Simplify one object mesh: counts, time and Metro distances to the input.
    #[command(allow_negative_numbers = true)]
    Mesh(eval::mesh::MeshArgs),
}

#[derive(Args, Debug)]
#[command(group(ArgGroup::new("sweep").required(true).args(["threshold", "bpp", "max_error", "lossless"])))]
pub struct TerrainArgs {
    /// Heightmap: .hgt, .tif (GeoTIFF), .png (gray, terrain-RGB, Terrarium), .asc, .npy, .npz.
    pub input: PathBuf,
    /// Evaluate the SIZE×SIZE window whose top-left sample is (ROW, COL); SIZE 2 … 8192.
    /// Without it the whole file, up to 2^26 samples (one stream).
    #[arg(long, value_name = "ROW,COL,SIZE", value_parser = terrain::parse_crop)]
    pub crop: Option<(usize, usize, usize)>,
    /// How colour PNGs encode heights: terrain-rgb | terrarium | gray.
    #[arg(long)]
    pub encoding: Option<Encoding>,
    /// Array name inside an .npz file.
    #[arg(long)]
    pub key: Option<String>,
    /// Wavelet: 53 (reversible LeGall 5/3) or 97 (CDF 9/7, default for lossy modes).
    #[arg(long)]
    pub wavelet: Option<Wavelet>,
    /// Height quantum (default: the file's native step, or 0.01 for float data).
    #[arg(long)]
    pub step: Option<f64>,
    /// Decode to these EZW thresholds (height units), comma-separated.
    #[arg(long, value_name = "T,..")]
    pub threshold: Option<String>,
    /// Truncate the embedded stream at these bits per sample (the header included, so a rate
    /// must be at least the header's: a smaller one is refused with the smallest usable rate).
    #[arg(long, value_name = "B,..")]
    pub bpp: Option<String>,
    /// Guarantee |error| ≤ E height units with the residual pass.
    #[arg(long = "max-error", value_name = "E,..")]
    pub max_error: Option<String>,
    /// Lossless (reversible 5/3, every pass).
    #[arg(long)]
    pub lossless: bool,
    /// Print one JSON object per operating point.
    #[arg(long)]
    pub json: bool,
    /// Also write each point's mesh to DIR/MODE-PARAM.obj (x = column, y = minus the row, z =
    /// height: a local dataset's frame, counter-clockwise from above), for any mesh viewer.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Rescale the window to 0..=255 integers first (the paper's 8-bit setting; PSNR peak 255).
    #[arg(long = "8bit")]
    pub eight_bit: bool,
    /// Terrain mesher: bintree (exact error, default on (2^k+1)² grids) or zerotree (the
    /// paper's quadtree from the decoder's significance map).
    #[arg(long, value_enum)]
    pub mesher: Option<terrain::Mesher>,
    /// Timed runs per measurement, 1–100 (medians are reported).
    #[arg(long, default_value_t = 3, value_parser = eval::parse_repeat())]
    pub repeat: usize,
    /// Bintree, threshold mode: read the stream to T × this share, rounded down to a power
    /// of two as the server does (default: the server's, 0.125), mesh with the rest. For
    /// measuring other shares; must be in (0, 1).
    #[arg(long = "decode-share", value_name = "S")]
    pub decode_share: Option<f64>,
}

/// Parses the arguments and runs the command; errors print one line and exit non-zero.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Eval(EvalCommand::Terrain(args)) => eval_terrain(args),
        Command::Eval(EvalCommand::Mesh(args)) => eval::mesh::run(&args),
        Command::Ingest(args) => ingest(args),
        Command::DemoData(args) => demo_data(&args),
        Command::Subdivide(args) => eval::mesh::subdivide(&args),
        Command::Healthcheck(args) => healthcheck(&args.addr),
        Command::Serve(args) => serve(args),
        Command::Export(args) => export(args),
        Command::Info(args) => info(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of the output went away (`info --json | head -c 1`): done, quietly, as
        // the standard tools are.
        Err(e) if closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("zerotile: {e:#}");
            if e.is::<crate::info::ChecksFailed>() {
                ExitCode::from(crate::info::CHECKS_FAILED)
            } else if crate::usage::is_usage(&e) {
                ExitCode::from(crate::usage::EXIT)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Writes `text` to stdout. `print!` panicked when the reader had gone (exit 101 with a
/// backtrace); this returns the error, which [`run`] takes for the end of the output.
pub fn say(text: impl std::fmt::Display) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    write!(out, "{text}")?;
    out.flush()?;
    Ok(())
}

/// Whether `e` is stdout's reader having gone.
fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain()
        .filter_map(|c| c.downcast_ref::<std::io::Error>())
        .any(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

/// Errors when `--encoding` or `--key` is given for an input whose reader does not use it:
/// the readers ignore options that do not apply, which would hide a mistaken file or flag.
fn check_reader_flags(
    input: &std::path::Path,
    encoding: Option<Encoding>,
    key: Option<&str>,
) -> anyhow::Result<()> {
    let ext = zerotile_codec::raster::extension(input);
    if let Some(e) = encoding {
        if ext != "png" {
            crate::bail_usage!(
                "--encoding {e}: applies to .png inputs only; {} is not a PNG",
                input.display()
            );
        }
    }
    if let Some(k) = key {
        if ext != "npz" {
            crate::bail_usage!(
                "--key {k}: applies to .npz inputs only; {} is not an .npz",
                input.display()
            );
        }
    }
    Ok(())
}

fn ingest(a: IngestArgs) -> anyhow::Result<()> {
    check_reader_flags(&a.input, a.encoding, a.key.as_deref())?;
    let job = crate::ingest::Ingest {
        input: a.input,
        name: a.name,
        data: a.data,
        scheme: a.scheme,
        wavelet: a.wavelet,
        precision: a.precision,
        encoding: a.encoding,
        npz_key: a.key,
        fill: a.fill,
        max_zoom: a.max_zoom,
        vertical_datum: a.vertical_datum,
        progress: !a.quiet,
    };
    let started = std::time::Instant::now();
    let existed = job.target().is_file();
    let (path, m) = crate::ingest::run(&job)?;
    say(format!(
        "{}\n",
        ingest_summary(&path, &m, started.elapsed().as_secs_f64(), existed)
    ))?;
    Ok(())
}

/// The line a finished ingest prints: what was built, its size and rate, and how long; and
/// whether it replaced a dataset of that name, which would otherwise go without a word.
fn ingest_summary(
    path: &std::path::Path,
    m: &zerotile_codec::container::Metadata,
    secs: f64,
    replaced: bool,
) -> String {
    let tiles: u128 = m.available.iter().flatten().map(|a| a.tile_count()).sum();
    let replaced = if replaced {
        " (replaced the dataset of that name; a running server serves it at its next rescan, \
         5 s by default, or on SIGHUP)"
    } else {
        ""
    };
    format!(
        "{}: {tiles} tiles, zooms {}..={}, {} stream bytes ({:.3} bits/sample), {secs:.1} \
         s{replaced}",
        path.display(),
        m.min_zoom,
        m.max_zoom,
        m.stream_bytes,
        m.stream_bytes as f64 * 8.0 / m.samples.max(1) as f64,
    )
}

fn export(a: ExportArgs) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    if let Some(note) = unused_png_compression(&a.format, a.png_compression) {
        eprintln!("note: {note}");
    }
    let job = crate::export::Export {
        dataset: a.dataset,
        data: a.data,
        format: a.format,
        out: a.out,
        zooms: a.zoom,
        base_url: a.base_url,
        png_compression: a.png_compression.unwrap_or(PngCompression::Balanced),
        progress: !a.quiet,
    };
    let done = crate::export::run(&job)?;
    for note in export_notes(&job, &done) {
        eprintln!("note: {note}");
    }
    say(format!(
        "{}: {} tiles, {} bytes, {:.1} s\n",
        job.out.display(),
        done.tiles,
        done.bytes,
        started.elapsed().as_secs_f64()
    ))?;
    Ok(())
}

/// `--png-compression` given for a tree with no PNG in it would otherwise look applied.
fn unused_png_compression(format: &str, given: Option<PngCompression>) -> Option<String> {
    given.filter(|_| format != "png").map(|_| {
        format!("--png-compression applies to --format png; a {format} export has no PNG tiles")
    })
}

/// What a finished export should tell its user it did not do.
fn export_notes(job: &crate::export::Export, done: &crate::export::Exported) -> Vec<String> {
    let mut notes = Vec::new();
    if done.no_tilejson {
        notes.push(
            "no tiles.json written (a MapLibre raster-dem source's url): give --base-url URL, \
             where the tree will be served, to get one"
                .to_string(),
        );
    }
    if let Some([lo, hi]) = done.clamped {
        use zerotile_codec::formats::terrain_rgb::height_range;
        use zerotile_codec::raster::Encoding;
        let range = |e| height_range(e).map_or_else(|_| "?".into(), |(a, b)| format!("{a} … {b}"));
        notes.push(format!(
            "heights {lo} … {hi} m pass what terrain-RGB codes ({} m): the PNG tiles clamp them \
             there (the server's ?encoding=terrarium keeps {} m)",
            range(Encoding::TerrainRgb),
            range(Encoding::Terrarium)
        ));
    }
    if let Some((z0 @ 1.., _)) = job.zooms.filter(|_| job.format == "terrain") {
        notes.push(format!(
            "{} has no zooms below {z0}, which CesiumJS needs from level 0 on: serve it beside \
             an export of those zooms, or export from 0",
            job.out.display()
        ));
    }
    notes
}

fn info(a: InfoArgs) -> anyhow::Result<()> {
    let run = crate::info::run(&crate::info::Info {
        dataset: a.dataset,
        data: a.data,
        verify: a.verify,
        progress: !a.quiet && !a.json,
    });
    let report = match run.map_err(|e| e.downcast::<crate::info::Unreadable>()) {
        Ok(report) => report,
        // Read but not sound: still one JSON object for --json, and exit 3.
        Err(Ok(unreadable)) => {
            if a.json {
                say(format!("{}\n", serde_json::to_string(&unreadable)?))?;
            }
            return Err(crate::info::ChecksFailed(unreadable.to_string()).into());
        }
        Err(Err(e)) => return Err(e),
    };
    if a.json {
        say(format!("{}\n", crate::info::json(&report)?))?;
    } else {
        say(crate::info::render(&report))?;
    }
    let problems = report.problems();
    if !problems.is_empty() {
        return Err(
            crate::info::ChecksFailed(format!("{}: {}", report.path, problems.join("; "))).into(),
        );
    }
    Ok(())
}

/// `--addr`: `HOST:PORT`, the host an IP address or a name, resolved once at start. Of a
/// name's addresses the first IPv4 one is taken: `localhost` often lists `::1` first, and a
/// server on `[::1]` alone is not reached at `127.0.0.1`, nor can it bind where IPv6 is off.
fn listen_addr(s: &str) -> Result<std::net::SocketAddr, String> {
    use std::net::ToSocketAddrs;
    let all: Vec<_> = s
        .to_socket_addrs()
        .map_err(|e| format!("{s:?} is not HOST:PORT ({e})"))?
        .collect();
    all.iter()
        .find(|a| a.is_ipv4())
        .or(all.first())
        .copied()
        .ok_or_else(|| format!("{s:?} resolves to no address"))
}

/// `healthcheck --addr`: `HOST:PORT` in form only. The name is resolved when the check
/// runs, so one that does not resolve yet (a container still starting) fails the check,
/// exit 1, rather than the command line.
fn host_port(s: &str) -> Result<String, String> {
    // A port after the host (after the brackets of an IPv6 address), as the Host header's
    // check takes them.
    let port = s
        .rsplit_once(':')
        .filter(|(host, _)| !s.starts_with('[') || host.ends_with(']'))
        .map(|(_, port)| port);
    match port {
        Some(p) if crate::serve::public_url::valid_host(s) => match p.parse::<u16>() {
            Ok(1..) => Ok(s.to_string()),
            _ => Err(format!("{s:?}: port {p:?} is not 1–65535")),
        },
        _ => Err(format!("{s:?} is not HOST:PORT (e.g. 127.0.0.1:8080)")),
    }
}

/// How long `healthcheck` waits for the whole check, name lookup to status line: a
/// container runtime kills a check that outlives its own timeout, and reports that, not why.
const HEALTH_DEADLINE: std::time::Duration = std::time::Duration::from_secs(3);

fn healthcheck(addr: &str) -> anyhow::Result<()> {
    check_health(addr, HEALTH_DEADLINE)
}

/// [`healthcheck`] within `limit`. One deadline for every step: a timeout per read let a
/// server dripping a byte every 2 s hold the check for 22 s and then pass it.
fn check_health(addr: &str, limit: std::time::Duration) -> anyhow::Result<()> {
    use anyhow::Context;
    use std::io::{ErrorKind, Read, Write};
    use std::time::Instant;
    let deadline = Instant::now() + limit;
    let secs = limit.as_secs_f64();
    let late = |what: &str| anyhow::anyhow!("{what} {addr} within {secs} s");
    let left = || {
        deadline
            .checked_duration_since(Instant::now())
            .filter(|d| !d.is_zero())
    };
    let target = resolve(addr, limit)?;
    // Each step names the address: a bare "Connection refused" does not say which server.
    let mut s = std::net::TcpStream::connect_timeout(
        &target,
        left().ok_or_else(|| late("no connection to"))?,
    )
    .map_err(|e| match e.kind() {
        ErrorKind::TimedOut | ErrorKind::WouldBlock => late("no connection to"),
        _ => anyhow::Error::new(e).context(format!("connecting to {addr}")),
    })?;
    s.set_write_timeout(Some(left().ok_or_else(|| late("no answer from"))?))?;
    s.write_all(format!("GET /healthz HTTP/1.0\r\nHost: {addr}\r\n\r\n").as_bytes())
        .map_err(|e| match e.kind() {
            ErrorKind::TimedOut | ErrorKind::WouldBlock => late("no answer from"),
            _ => anyhow::Error::new(e).context(format!("asking {addr} for /healthz")),
        })?;
    // "HTTP/1.x 200": the status is all the check reads.
    let late_status = |got: usize| match got {
        0 => late("no answer from"),
        _ => late("no whole status line from"),
    };
    let mut head = [0u8; 12];
    let mut got = 0;
    while let Some(rest) = head.get_mut(got..).filter(|r| !r.is_empty()) {
        let Some(wait) = left() else {
            return Err(late_status(got));
        };
        s.set_read_timeout(Some(wait))?;
        match s.read(rest) {
            Ok(0) => anyhow::bail!(
                "reading {addr}'s answer to /healthz: it closed the connection after {got} bytes"
            ),
            Ok(n) => got += n,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) => {
                return Err(late_status(got))
            }
            Err(e) => {
                return Err(e).with_context(|| format!("reading {addr}'s answer to /healthz"))
            }
        }
    }
    if &head[9..12] != b"200" {
        anyhow::bail!(
            "{addr}: /healthz answered {}",
            String::from_utf8_lossy(&head)
        );
    }
    Ok(())
}

/// `addr`'s first address, looked up within `limit`: a resolver that does not answer (a
/// container's DNS still starting) would otherwise hold the check past its deadline. The
/// lookup runs on a thread left behind if it is late; the process ends soon after.
fn resolve(addr: &str, limit: std::time::Duration) -> anyhow::Result<std::net::SocketAddr> {
    use anyhow::Context;
    use std::net::ToSocketAddrs;
    let (tx, rx) = std::sync::mpsc::channel();
    let owned = addr.to_string();
    std::thread::spawn(move || {
        let _ = tx.send(owned.to_socket_addrs().map(|mut a| a.next()));
    });
    match rx.recv_timeout(limit) {
        Ok(found) => found
            .with_context(|| format!("--addr {addr}"))?
            .ok_or_else(|| anyhow::anyhow!("--addr {addr}: no address")),
        Err(_) => anyhow::bail!(
            "--addr {addr}: the name did not resolve within {} s",
            limit.as_secs_f64()
        ),
    }
}

fn demo_data(a: &DemoArgs) -> anyhow::Result<()> {
    let built = crate::demo::ensure(&a.data, a.force, !a.quiet)?;
    say(format!("{}\n", demo_summary(&a.data, &built)))?;
    Ok(())
}

fn demo_summary(data: &std::path::Path, built: &crate::demo::Built) -> String {
    match (built.terrain, built.meshes) {
        (false, 0) => format!("{}: already has datasets and meshes", data.display()),
        (terrain, meshes) => format!(
            "{}: built {}{meshes} meshes",
            data.display(),
            if terrain {
                format!("dataset {}, ", crate::demo::TERRAIN_NAME)
            } else {
                String::new()
            }
        ),
    }
}

fn serve(a: ServeArgs) -> anyhow::Result<()> {
    let config = serve_config(&a)?;
    let data = match a.data {
        Some(dir) => dir,
        None => {
            let dir = PathBuf::from("data");
            let built = crate::demo::ensure(&dir, false, true)?;
            if built.terrain || built.meshes > 0 {
                eprintln!(
                    "zerotile: generated the default data in {} ({} dataset, {} meshes)",
                    dir.display(),
                    if built.terrain { "1" } else { "no" },
                    built.meshes
                );
            }
            dir
        }
    };
    crate::serve::run(crate::serve::ServeOptions {
        data,
        addr: a.addr,
        config,
        rescan: match a.rescan {
            None => crate::serve::reload::Rescan::Default,
            Some(0) => crate::serve::reload::Rescan::Never,
            Some(s) => crate::serve::reload::Rescan::Every(std::time::Duration::from_secs(s)),
        },
    })
}

/// `--rescan`'s ceiling, a day: past it the flag is a typo more likely than a wish.
const MAX_RESCAN: u64 = 86_400;

/// `--render-threads`' ceiling: a pool this size starts in about a second.
const MAX_RENDER_THREADS: usize = 1024;

/// `serve`'s flags as the service's configuration, refusing what it could not honour before
/// anything is bound or generated.
fn serve_config(a: &ServeArgs) -> anyhow::Result<crate::serve::Config> {
    for o in &a.cors_origins {
        // A browser's Origin is scheme://host[:port] and nothing after: a value with a path
        // (or a query) could never match one.
        let ok = ["http://", "https://"].iter().any(|scheme| {
            o.strip_prefix(scheme)
                .is_some_and(|host| !host.is_empty() && !host.contains(['/', '?', '#']))
        }) && o.bytes().all(|b| b.is_ascii_graphic());
        if !ok {
            crate::bail_usage!("--cors-origin {o:?}: give a scheme and host, e.g. https://maps.example.org (no path, no trailing slash)");
        }
    }
    if let Some(url) = a.data.as_deref().and_then(|d| d.to_str()) {
        if crate::serve::storage::is_url(url) {
            crate::serve::storage::check_url(url)
                .map_err(|why| crate::usage::usage(format!("--data {url}: {why}")))?;
        }
    }
    let defaults = crate::serve::Config::default();
    if a.cpu_jobs == Some(0) {
        crate::bail_usage!("--cpu-jobs 0: at least one render must be able to run");
    }
    if a.render_threads == Some(0) {
        crate::bail_usage!("--render-threads 0: renders need at least one thread");
    }
    // Each thread is spawned at start: 5,000 took 47 s, 20,000 never came up.
    if let Some(n) = a.render_threads.filter(|&n| n > MAX_RENDER_THREADS) {
        crate::bail_usage!(
            "--render-threads {n}: at most {MAX_RENDER_THREADS} (more threads than cores only \
             share them)"
        );
    }
    if let Some(s) = a.rescan.filter(|&s| s > MAX_RESCAN) {
        crate::bail_usage!(
            "--rescan {s}: at most {MAX_RESCAN} seconds (a day; 0 rescans only on SIGHUP)"
        );
    }
    let public_url = match &a.public_url {
        Some(u) => Some(
            crate::serve::public_url::parse_base(u)
                .map_err(|why| crate::usage::usage(format!("--public-url {u:?}: {why}")))?,
        ),
        None => None,
    };
    Ok(crate::serve::Config {
        cache_bytes: a.cache_mb.saturating_mul(1 << 20),
        cors_origins: a.cors_origins.clone(),
        public_url,
        trust_forwarded: a.trust_forwarded,
        read_only: a.read_only,
        mesh_quota: a.mesh_quota.unwrap_or(defaults.mesh_quota),
        cpu_jobs: a.cpu_jobs.unwrap_or(defaults.cpu_jobs),
        cpu_queue: a.cpu_queue.unwrap_or(defaults.cpu_queue),
        render_threads: a.render_threads.unwrap_or(defaults.render_threads),
        png_compression: a.png_compression.unwrap_or(defaults.png_compression),
        ..defaults
    })
}

fn eval_terrain(a: TerrainArgs) -> anyhow::Result<()> {
    let json = a.json;
    let points = terrain::run(&terrain_eval(a)?)?;
    for warning in points.iter().filter_map(terrain::floor_warning) {
        eprintln!("{warning}");
    }
    if json {
        for p in &points {
            say(format!("{}\n", serde_json::to_string(p)?))?;
        }
    } else {
        say(terrain::table(&points))?;
    }
    Ok(())
}

/// `eval terrain`'s flags as a run, refusing values no run could use.
fn terrain_eval(a: TerrainArgs) -> anyhow::Result<terrain::TerrainEval> {
    check_reader_flags(&a.input, a.encoding, a.key.as_deref())?;
    let sweep = if let Some(t) = &a.threshold {
        let ts = eval::parse_list("--threshold", t, true).map_err(crate::usage::usage)?;
        terrain::Sweep::Threshold(ts)
    } else if let Some(b) = &a.bpp {
        // 0 buys no byte of any stream (each has a header): a usage error, not a failed run.
        // A rate above 0 but below this window's header is refused once the stream is coded,
        // with the smallest usable rate.
        terrain::Sweep::Bpp(eval::parse_list("--bpp", b, false).map_err(crate::usage::usage)?)
    } else if let Some(e) = &a.max_error {
        let es = eval::parse_list("--max-error", e, false)
            .map_err(|e| crate::usage::usage(format!("{e} (use --lossless for exact)")))?;
        terrain::Sweep::MaxError(es)
    } else {
        terrain::Sweep::Lossless
    };
    if let Some(s) = a.step {
        if !(s.is_finite() && s > 0.0) {
            crate::bail_usage!("--step must be finite and > 0, got {s}");
        }
    }
    if let Some(share) = a.decode_share {
        if !(share > 0.0 && share < 1.0) {
            crate::bail_usage!("--decode-share must be in (0, 1), got {share}");
        }
        // Taken and ignored, a share would read as measured.
        if !matches!(sweep, terrain::Sweep::Threshold(_)) {
            crate::bail_usage!(
                "--decode-share applies to --threshold; --bpp, --max-error and --lossless fix \
                 how far the stream is read themselves"
            );
        }
        if a.mesher == Some(terrain::Mesher::Zerotree) {
            crate::bail_usage!(
                "--decode-share applies to the bintree mesher; the zerotree mesher meshes at \
                 the threshold it decoded to"
            );
        }
    }
    // The crop fixes the grid's side, so a side the bintree cannot take is the command
    // line's fault (without --crop the file's size decides, checked once it is read).
    if let Some((_, _, size)) = a.crop {
        let bintree = a.mesher == Some(terrain::Mesher::Bintree);
        if (bintree || a.decode_share.is_some())
            && !zerotile_codec::bintree::Hierarchy::supports(size)
        {
            crate::bail_usage!(
                "--crop …,{size}: the bintree mesher ({}) needs a side of 2^k + 1 (3 … 4097), \
                 e.g. 257",
                if bintree {
                    "--mesher bintree"
                } else {
                    "which --decode-share measures"
                }
            );
        }
    }
    Ok(terrain::TerrainEval {
        input: a.input,
        crop: a.crop,
        encoding: a.encoding,
        npz_key: a.key,
        wavelet: a.wavelet,
        step: a.step,
        sweep,
        repeat: a.repeat,
        eight_bit: a.eight_bit,
        mesher: a.mesher,
        decode_share: a.decode_share,
        out: a.out,
    })
}

#[cfg(test)]
#[path = "cli_tests.rs"]
mod tests;
