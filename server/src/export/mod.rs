//! `zerotile export`: a dataset as a static tile tree (`{z}/{x}/{y}.EXT`; `layer.json` for
//! quantized-mesh, for MapLibre a `tiles.json` once the tree's URL is known, and for 3D Tiles
//! a `tileset.json` over glTF tiles in ENU, [`tileset`]) for a CDN or any file server,
//! rendered exactly as `zerotile serve` renders it at each zoom's default threshold.
//!
//! Written into a temporary folder beside `--out` and swapped in at the end: a failed export
//! leaves an existing `--out` as it was. Only an empty folder or an earlier export (which
//! holds [`MARKER`]) holding nothing but what an export writes is replaced: the swap deletes
//! what `--out` held, so anything else there is the user's and is refused.

mod over_data;
mod skirts;
mod tileset;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::Mutex;

use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use zerotile_codec::container::TileId;
use zerotile_codec::formats::terrain_rgb::{self, PngCompression};
use zerotile_codec::geo::{Scheme, MAX_ZOOM};
use zerotile_codec::mesh::{io, Aabb};

use crate::serve::codings::Coding;
use crate::serve::dataset::Dataset;
use crate::serve::frame::{self, Frame};
use crate::serve::negotiate::Extensions;
use crate::serve::pipeline::{self, Cancel};
use crate::serve::render;
use crate::serve::routes::meta::{layer, raster_dem};
use crate::serve::routes::tiles::{png_encoding, render_tile, TileFormat, Variant};
use crate::serve::{public_url, threshold, AppState, Catalog, Config};

/// The file every export writes at its root, so that a later export knows the folder is
/// one it may replace.
pub const MARKER: &str = ".zerotile-export";

/// What to export.
#[derive(Clone, Debug)]
pub struct Export {
    /// A dataset name in `data`, or a path to a `.ztd` file (any bytes: a path need not be
    /// UTF-8).
    pub dataset: std::ffi::OsString,
    pub data: PathBuf,
    pub format: String,
    pub out: PathBuf,
    pub zooms: Option<(u8, u8)>,
    /// The URL the tree will be served from: TileJSON needs absolute tile URLs.
    pub base_url: Option<String>,
    /// DEFLATE effort of PNG tiles: written once, so `Balanced` by default.
    pub png_compression: PngCompression,
    pub progress: bool,
}

/// What was written.
#[derive(Debug)]
pub struct Exported {
    pub tiles: u64,
    pub bytes: u64,
    /// A mercator png export written without `--base-url`, so without tiles.json.
    pub no_tilejson: bool,
    /// A png export of heights terrain-RGB cannot hold: the dataset's range, clamped in the
    /// tiles to [`terrain_rgb::height_range`].
    pub clamped: Option<[f64; 2]>,
}

/// The extensions of the tiles an export writes.
const TILE_EXTENSIONS: [&str; 6] = ["terrain", "png", "json", "bin", "obj", "glb"];

/// The PNG tiles an export writes (and its tiles.json lists): terrain-RGB, 512 pixels a side.
const PNG_TERRARIUM: bool = false;
const PNG_SIZE: u32 = 512;

/// Parses `A-B` or `Z`.
pub fn parse_zooms(s: &str) -> Result<(u8, u8), String> {
    // Past MAX_ZOOM no dataset has tiles: a usage error, whatever the dataset.
    let parse = |v: &str| {
        v.trim()
            .parse::<u8>()
            .ok()
            .filter(|z| *z <= MAX_ZOOM)
            .ok_or_else(|| format!("zoom {v:?} is not 0..={MAX_ZOOM}"))
    };
    let (a, b) = match s.split_once('-') {
        Some((a, b)) => (parse(a)?, parse(b)?),
        None => (parse(s)?, parse(s)?),
    };
    if a > b {
        return Err(format!(
            "--zoom {s}: the first zoom must not exceed the second"
        ));
    }
    Ok((a, b))
}

/// Errors unless `out` may be replaced by an export: absent, an empty folder or an earlier
/// export with nothing added. Refusing before any work keeps a user's files (or a file named like the folder)
/// from being swapped away.
fn check_out(out: &Path) -> Result<()> {
    // `.` inside an earlier export is a folder, but one with no name to make a sibling by.
    if out.file_name().is_none() {
        crate::bail_usage!(
            "--out {}: name the folder itself (`../tiles`, say), not `.` or `..`: the export is \
             made beside it and swapped in",
            out.display()
        );
    }
    let meta = match std::fs::symlink_metadata(out) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e).with_context(|| format!("--out {}", out.display())),
    };
    if meta.file_type().is_symlink() {
        bail!(
            "--out {}: is a symbolic link; give the folder itself or a new path",
            out.display()
        );
    }
    if !meta.is_dir() {
        bail!(
            "--out {}: is a file, not a folder; give a new or empty folder",
            out.display()
        );
    }
    if out.join(MARKER).is_file() {
        return only_own_files(out);
    }
    // Named, as an earlier export's additions are: the user sees what the export would have
    // replaced (a folder is one entry, not walked).
    let mut entries = std::fs::read_dir(out)
        .and_then(|d| {
            d.map(|e| e.map(|e| PathBuf::from(e.file_name())))
                .collect::<std::io::Result<Vec<_>>>()
        })
        .with_context(|| format!("--out {}", out.display()))?;
    entries.sort();
    let Some((what, them)) = name_entries(&entries) else {
        return Ok(());
    };
    bail!(
        "--out {}: the folder has files and is not an earlier zerotile export (no {MARKER}): \
         {what} not an export's own; an export replaces everything in the folder, so move \
         {them} out first or give a new or empty folder",
        out.display()
    );
}

/// Errors unless the earlier export `out` holds only what an export writes: the swap deletes
/// the whole folder, and the marker alone said nothing of an `index.html` a user had added
/// since (it was deleted with exit 0). Names the first few, and how many there are.
fn only_own_files(out: &Path) -> Result<()> {
    let foreign = foreign_entries(out).with_context(|| format!("--out {}", out.display()))?;
    let Some((what, them)) = name_entries(&foreign) else {
        return Ok(());
    };
    bail!(
        "--out {}: an earlier zerotile export, but {what} not the export's own; an export \
         replaces the whole folder, so move {them} out first or give another --out",
        out.display()
    );
}

/// `entries` for a refusal: ("X is" | "N entries (X, Y and M more) are", what to move);
/// `None` when there are none.
fn name_entries(entries: &[PathBuf]) -> Option<(String, String)> {
    const SHOWN: usize = 5;
    match entries {
        [] => None,
        [one] => Some((
            format!("{} in it is", one.display()),
            one.display().to_string(),
        )),
        many => {
            let mut listed = many
                .iter()
                .take(SHOWN)
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ");
            if many.len() > SHOWN {
                listed += &format!(" and {} more", many.len() - SHOWN);
            }
            Some((
                format!("{} entries in it ({listed}) are", many.len()),
                "them".into(),
            ))
        }
    }
}

/// What in the export `out` no export writes, relative to `out`, sorted: anything but
/// [`MARKER`], `layer.json`, `tiles.json`, `tileset.json` and `{z}/{x}/{y}.EXT` of a tile
/// format. A folder that is not the export's is one entry, not walked; a symbolic link is
/// never its own.
fn foreign_entries(out: &Path) -> std::io::Result<Vec<PathBuf>> {
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let tile = |s: &str| {
        s.split_once('.')
            .is_some_and(|(y, ext)| digits(y) && TILE_EXTENSIONS.contains(&ext))
    };
    let mut foreign = Vec::new();
    // (folder relative to `out`, its depth: 0 the root, 1 a zoom, 2 a column)
    let mut stack = vec![(PathBuf::new(), 0u8)];
    while let Some((rel, depth)) = stack.pop() {
        for entry in std::fs::read_dir(out.join(&rel))? {
            let entry = entry?;
            let kind = entry.file_type()?;
            let name = entry.file_name();
            let path = rel.join(&name);
            let name = name.to_str().unwrap_or("");
            let own = match depth {
                0 if kind.is_file() => {
                    [MARKER, "layer.json", "tiles.json", "tileset.json"].contains(&name)
                }
                0 | 1 => kind.is_dir() && digits(name),
                _ => kind.is_file() && tile(name),
            };
            if !own {
                foreign.push(path);
            } else if kind.is_dir() {
                stack.push((path, depth + 1));
            }
        }
    }
    foreign.sort();
    Ok(foreign)
}

pub fn run(job: &Export) -> Result<Exported> {
    check_out(&job.out)?;
    let (format, ext) = match job.format.as_str() {
        "terrain" => (TileFormat::Terrain, "terrain"),
        "png" => (TileFormat::Png, "png"),
        "json" => (TileFormat::Json, "json"),
        "bin" => (TileFormat::Bin, "bin"),
        "obj" => (TileFormat::Obj, "obj"),
        "glb" | "3dtiles" => (TileFormat::Glb, "glb"),
        other => {
            crate::bail_usage!("--format {other}: use terrain, png, json, bin, obj, glb or 3dtiles")
        }
    };
    // glTF tiles in ENU under a tileset.json, where a plain glb tree is in the scheme's CRS.
    let tiles3d = job.format == "3dtiles";
    // The flags alone rule this out, whatever the dataset.
    if job.base_url.is_some() && format != TileFormat::Png {
        crate::bail_usage!(
            "--base-url writes a TileJSON for MapLibre, which reads terrain-RGB PNG: use it \
             with --format png"
        );
    }
    let variant = match format {
        // The extensions layer.json lists, which CesiumJS skips unless it asked for them.
        // Not `metadata`: CesiumJS parses that one whether it asked or not, and without a
        // `metadataAvailability` in layer.json (which lists full availability instead) it
        // fails every such tile.
        TileFormat::Terrain => Variant::Terrain {
            ext: Extensions {
                octvertexnormals: true,
                watermask: true,
                metadata: false,
            },
            coding: Coding::Identity,
        },
        TileFormat::Png => Variant::Png {
            terrarium: PNG_TERRARIUM,
            size: PNG_SIZE,
        },
        TileFormat::Glb => Variant::Glb {
            frame: if tiles3d { Frame::Enu } else { Frame::Scheme },
        },
        _ => Variant::Mesh {
            coding: Coding::Identity,
            frame: Frame::Scheme,
        },
    };

    let path = crate::ingest::existing_dataset_path(&job.dataset, &job.data)?;
    let d = Dataset::open(&path).with_context(|| path.display().to_string())?;
    let m = d.metadata().clone();
    let world = !matches!(d.tiling.scheme(), Scheme::Local { .. });
    if format == TileFormat::Terrain && !world {
        bail!("{}: a local grid has no georeference; quantized-mesh needs a geodetic or mercator dataset (export png or json)", d.name);
    }
    if tiles3d && !world {
        bail!("{}: a local grid has no georeference; 3D Tiles places tiles on the Earth, so it needs a geodetic or mercator dataset (export glb for the meshes in grid coordinates)", d.name);
    }
    // What MapLibre's raster-dem reads: terrain-RGB PNG on the Web Mercator grid.
    let maplibre = format == TileFormat::Png && matches!(d.tiling.scheme(), Scheme::Mercator);
    let base_url = match &job.base_url {
        None => None,
        Some(_) if !maplibre => bail!(
            "{}: --base-url writes a TileJSON for MapLibre, which tiles PNG on the mercator \
             grid: use it on a dataset ingested with --scheme mercator",
            d.name
        ),
        Some(u) => Some(public_url::parse_base(u).map_err(|why| {
            crate::usage::usage(format!(
                "--base-url {u:?}: {why}; give the absolute URL the tree will be served from"
            ))
        })?),
    };
    let clamped = format == TileFormat::Png && {
        let (lo, hi) = terrain_rgb::height_range(png_encoding(PNG_TERRARIUM))?;
        m.height_range[0] < lo || m.height_range[1] > hi
    };
    let (z0, z1) = job.zooms.unwrap_or((m.min_zoom, m.max_zoom));
    if z1 > m.max_zoom || z0 < m.min_zoom {
        bail!(
            "--zoom {}: {} has zooms {}-{}",
            if z0 == z1 {
                z0.to_string()
            } else {
                format!("{z0}-{z1}")
            },
            d.name,
            m.min_zoom,
            m.max_zoom
        );
    }
    let tiles: Vec<TileId> = d
        .container
        .tiles()
        .map(|(id, _)| id)
        .filter(|id| (z0..=z1).contains(&id.z))
        .collect();
    if tiles.is_empty() {
        bail!("{}: no tiles in zooms {z0}-{z1}", d.name);
    }
    // The TileJSON, checked before any tile is rendered.
    let tilejson = match &base_url {
        Some(base) => {
            // A file server ignores the query; a CDN keying on it drops an older build.
            let template = format!("{base}/{{z}}/{{x}}/{{y}}.png?v={}", d.version_tag());
            Some(raster_dem(&d, template, (z0, z1), PNG_TERRARIUM, PNG_SIZE).to_value()?)
        }
        None => None,
    };

    // Render into a fresh folder beside the target.
    let parent = job
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
    let name = job
        .out
        .file_name()
        .context("--out has no name (check_out refuses that)")?
        .to_string_lossy()
        .into_owned();
    crate::ingest::sweep_leftovers(parent, &format!(".{name}.export-"));
    let tmp = parent.join(format!(".{name}.export-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    // The dataset goes into a private server state (opened once): its decode cache serves
    // the neighbours that stitching needs.
    let mut catalog = Catalog::default();
    catalog.insert(d);
    let config = Config {
        png_compression: job.png_compression,
        ..Config::default()
    };
    let state = AppState::new(catalog, config)?;
    let d = state
        .catalog()
        .iter()
        .next()
        .context("dataset vanished")?
        .clone();
    // Made here, so a folder that cannot hold the tree is named once, before any render.
    std::fs::create_dir(&tmp).with_context(|| {
        format!(
            "--out {}: cannot create {} beside it",
            job.out.display(),
            tmp.display()
        )
    })?;
    let result = render_all(
        (&state, &d),
        &tiles,
        (format, variant, tiles3d),
        ext,
        &tmp,
        job.progress,
    )
    .and_then(|(n, nodes)| {
        // layer.json is CesiumJS's quantized-mesh manifest: other trees would only mislead it.
        if format == TileFormat::Terrain {
            // Only the exported zooms: CesiumJS asks for every level layer.json makes
            // available, and a file server answers 404 for levels left out.
            let mut layer = layer(&d)?;
            layer.maxzoom = z1;
            layer.available.truncate(usize::from(z1) + 1);
            let mut value = layer.to_value()?;
            // Static trees keep tiles beside layer.json, not under tiles/.
            if let Some(o) = value.as_object_mut() {
                o.insert(
                    "tiles".into(),
                    serde_json::json!([format!("{{z}}/{{x}}/{{y}}.{ext}?v={{version}}")]),
                );
            }
            let bytes = serde_json::to_vec_pretty(&value)?;
            std::fs::write(tmp.join("layer.json"), &bytes)?;
        }
        if let Some(doc) = &tilejson {
            std::fs::write(tmp.join("tiles.json"), serde_json::to_vec_pretty(doc)?)?;
        }
        if tiles3d {
            // Above the coarsest level's error and twice the top tiles', so the content-less
            // root refines into them from any view in which they show.
            let tops = nodes.iter().map(|n| n.error).fold(0.0, f64::max);
            let root_error = (2.0 * tops).max(d.tiling.level_geometric_error(0));
            let uri = |id: TileId| format!("{}/{}/{}.{ext}", id.z, id.x, id.y);
            let doc = tileset::tileset(&nodes, &uri, &d.version_tag(), root_error)?;
            std::fs::write(tmp.join("tileset.json"), serde_json::to_vec(&doc)?)?;
        }
        std::fs::write(
            tmp.join(MARKER),
            format!("zerotile export of {} as {}\n", d.name, job.format),
        )?;
        Ok(n)
    });
    let exported = match result {
        Ok((tiles, bytes)) => Exported {
            tiles,
            bytes,
            no_tilejson: maplibre && tilejson.is_none(),
            clamped: clamped.then_some(m.height_range),
        },
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(e);
        }
    };
    // Swap: the old tree moves aside only once the new one is complete. Checked again: the
    // render took a while and `--out` may have been filled meanwhile.
    if let Err(e) = check_out(&job.out) {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    // One step where the OS offers it: a web server publishing `--out` never finds it gone.
    let old = parent.join(format!(".{name}.old-{}", std::process::id()));
    if let Err(e) = crate::swap_dir::replace(&tmp, &job.out, &old) {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e).with_context(|| format!("writing {}", job.out.display()));
    }
    Ok(exported)
}

/// Renders `tiles` of `d` (held by `state`, whose caches it uses) into `dir`; returns the
/// tile files and bytes written, and for 3D Tiles (`tiles3d`) each tile's place and bounds.
fn render_all(
    (state, d): (&AppState, &Dataset),
    tiles: &[TileId],
    (format, variant, tiles3d): (TileFormat, Variant, bool),
    ext: &str,
    dir: &Path,
    progress: bool,
) -> Result<((u64, u64), Vec<tileset::Node>)> {
    let bar = crate::ingest::tile_bar("exporting", progress, tiles.len() as u64);
    let bytes = AtomicU64::new(0);
    let files = AtomicU64::new(0);
    let nodes = Mutex::new(Vec::new());
    // Neighbouring tiles share decodes: go zoom by zoom, row by row.
    let mut order = tiles.to_vec();
    order.sort_by_key(|t| (t.z, t.y, t.x));
    // On the render pool, where each tile's own decodes run too: one pool, the cores.
    state.pool.install(|| {
        order.par_iter().try_for_each(|&id| -> Result<()> {
            let t = threshold::default_threshold(d, id.z);
            let what = || format!("{}: tile {}/{}/{}", d.location, id.z, id.x, id.y);
            let body = if tiles3d {
                let (body, node) = enu_glb(state, d, id, t).with_context(what)?;
                nodes
                    .lock()
                    .map_err(|_| anyhow::anyhow!("a render failed"))?
                    .push(node);
                body.map(bytes::Bytes::from)
            } else {
                let enc = render_tile(state, d, id, t, format, variant, false, &Cancel::default())
                    .with_context(what)?;
                Some(enc.bytes)
            };
            // A 3D Tiles tile with nothing over the data is only a node of the tree.
            let Some(body) = body else {
                bar.inc(1);
                return Ok(());
            };
            // Paths follow the serving URLs, which use the stored y: TMS rows for geodetic
            // (layer.json scheme "tms"), XYZ rows for mercator ("slippyMap").
            let y = id.y;
            let folder = dir.join(id.z.to_string()).join(id.x.to_string());
            let file = folder.join(format!("{y}.{ext}"));
            std::fs::create_dir_all(&folder)
                .and_then(|()| std::fs::write(&file, &body))
                .with_context(|| format!("writing {}", file.display()))?;
            bytes.fetch_add(body.len() as u64, Relaxed);
            files.fetch_add(1, Relaxed);
            bar.inc(1);
            Ok(())
        })
    })?;
    bar.finish_and_clear();
    let nodes = nodes
        .into_inner()
        .map_err(|_| anyhow::anyhow!("a render failed"))?;
    Ok(((files.into_inner(), bytes.into_inner()), nodes))
}

/// The geometric error of a 3D Tiles tile at zoom `z` meshed within `t` whose flat faces dip
/// `dip` below the curved ground: `t` bounds the heights on the grid, not the chords between
/// them, and a zoom-0 face spans tens of degrees. At least the level's error as CesiumJS
/// reckons it for terrain (halving each zoom; `t` stops halving at the relief, and a chain
/// of tiles of one error would be loaded all at once).
fn tile_error(d: &Dataset, z: u8, t: f64, dip: f64) -> f64 {
    d.tiling.level_geometric_error(z).max(t + dip)
}

/// The deepest a flat face of `faces` (over `positions`, metres) sinks below a sphere of the
/// Earth's mean radius through its corners: the sagitta of its longest edge,
/// R − √(R² − L²/4).
fn chord_dip(faces: &[[u32; 3]], positions: &[glam::DVec3]) -> f64 {
    const R: f64 = 6_371_008.8;
    let longest = faces
        .iter()
        .map(|f| {
            let p = f.map(|i| positions.get(i as usize).copied().unwrap_or_default());
            let [a, b, c] = p;
            a.distance(b).max(b.distance(c)).max(c.distance(a))
        })
        .fold(0.0, f64::max);
    let half = (longest / 2.0).min(R);
    R - (R * R - half * half).sqrt()
}

/// How deep a tile meshed within `t` hangs its skirts: the gap beside a neighbour some levels
/// coarser is up to both meshes' errors, several times `t`; 5 t, as CesiumJS hangs its
/// quantized-mesh skirts (5 × the level's error), and never past the relief, which no gap
/// exceeds.
fn skirt_depth(d: &Dataset, t: f64) -> f64 {
    (5.0 * t).min(threshold::relief(d))
}

/// Tile `id` as `serve` sends `.glb?frame=enu` at threshold `t`, cut to the data
/// ([`over_data`]) and with skirts ([`skirts`]), and its node of the tileset: its ENU frame
/// and the box of its vertices there. `None` for the file where nothing is over the data.
fn enu_glb(
    state: &AppState,
    d: &Dataset,
    id: TileId,
    t: f64,
) -> Result<(Option<Vec<u8>>, tileset::Node)> {
    let stitched = pipeline::stitched(state, d, id, t, &Cancel::default())?;
    let enu = frame::at_tile(d, id)?;
    let mut m = render::tri_mesh(d, id, &stitched.mesh)?;
    over_data::over_data(&mut m, d.tiling.scheme(), d.metadata().bounds);
    let surface = m.faces.len();
    let skirts = (!m.faces.is_empty()).then(|| skirts::add_skirts(&mut m, skirt_depth(d, t)));
    render::into_enu(d, id, &mut m, &enu)?;
    let dip = chord_dip(m.faces.get(..surface).unwrap_or_default(), &m.positions);
    let content = Aabb::from_points(&m.positions);
    let node = tileset::Node {
        id,
        frame: enu.to_ecef_matrix(),
        content,
        error: tile_error(d, id.z, t, dip),
    };
    let body = match skirts {
        Some(skirts) => Some(
            io::write_z_up_glb_with_normals(&m, &skirts.normals(&m))
                .with_context(|| format!("writing tile {id} as GLB"))?,
        ),
        None => None,
    };
    Ok((body, node))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--zoom` is one zoom or an ascending range; a backwards range is refused.
    #[test]
    fn zoom_ranges_are_one_zoom_or_ascending() {
        assert_eq!(parse_zooms("7"), Ok((7, 7)));
        assert_eq!(parse_zooms("3-5"), Ok((3, 5)));
        assert_eq!(parse_zooms("4-4"), Ok((4, 4)));
        assert!(parse_zooms("5-3").unwrap_err().contains("must not exceed"));
        assert!(parse_zooms("3-256").is_err());
        // No dataset has a zoom past MAX_ZOOM: refused by the parser, exit 2.
        assert_eq!(parse_zooms("28"), Ok((28, 28)));
        assert!(parse_zooms("3-29").unwrap_err().contains("0..=28"));
    }

    /// A png export of heights below terrain-RGB's −10,000 m floor reports the dataset's
    /// range, which the CLI notes (the tiles clamped silently); one within it reports none.
    #[test]
    fn a_png_export_past_terrain_rgbs_range_reports_it() {
        use zerotile_codec::raster::Heightmap;
        use zerotile_codec::Grid;
        let dir = crate::fixtures::scratch("export-clamped");
        let data = dir.join("data");
        for (name, low, clamped) in [("deep", -10_935.0, true), ("shallow", -9_000.0, false)] {
            let h: Vec<f64> = (0..9).map(|i| low + 100.0 * f64::from(i)).collect();
            let map = Heightmap::new(Grid::new(3, 3, h).unwrap(), Some(1.0), None);
            let job = crate::ingest::Ingest {
                input: PathBuf::from(format!("{name}.npy")),
                ..crate::ingest::Ingest::for_test(name, "local", &data)
            };
            crate::ingest::build(&job, map).unwrap();
            for format in ["png", "json"] {
                let done = run(&Export {
                    dataset: name.into(),
                    data: data.clone(),
                    format: format.into(),
                    out: dir.join(format!("{name}-{format}")),
                    zooms: None,
                    base_url: None,
                    png_compression: PngCompression::Fast,
                    progress: false,
                })
                .unwrap();
                let want = (clamped && format == "png").then_some([low, low + 800.0]);
                assert_eq!(done.clamped, want, "{name} {format}");
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Reads the exported tileset and walks it: each tile's frame → ECEF is the product of
    /// the transforms from the root down, as a 3D Tiles runtime composes them.
    fn walk(
        t: &serde_json::Value,
        parent: glam::DMat4,
        parent_error: f64,
        visit: &mut dyn FnMut(&serde_json::Value, glam::DMat4, f64),
    ) {
        let m: Vec<f64> = serde_json::from_value(t["transform"].clone()).unwrap();
        let frame = parent * glam::DMat4::from_cols_slice(&m);
        visit(t, frame, parent_error);
        let error = t["geometricError"].as_f64().unwrap();
        for c in t["children"].as_array().into_iter().flatten() {
            walk(c, frame, error, visit);
        }
    }

    /// The vertices of a tile's GLB in the tile's frame, as a 3D Tiles runtime places them
    /// (the node's rotation and translation, then glTF's y-up turned back to z-up), and its
    /// faces.
    fn read_glb(bytes: &[u8]) -> (Vec<glam::DVec3>, Vec<[u32; 3]>) {
        let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
        assert_eq!(&bytes[..4], b"glTF");
        let json_len = word(12);
        let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
        let bin = &bytes[20 + json_len + 8..];
        let view = |accessor: &serde_json::Value| {
            let v = &doc["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
            let at = v["byteOffset"].as_u64().unwrap_or(0) as usize;
            &bin[at..at + v["byteLength"].as_u64().unwrap() as usize]
        };
        let prim = &doc["meshes"][0]["primitives"][0];
        let positions =
            &doc["accessors"][prim["attributes"]["POSITION"].as_u64().unwrap() as usize];
        let indices = &doc["accessors"][prim["indices"].as_u64().unwrap() as usize];
        let floats: Vec<f64> = view(positions)
            .chunks_exact(4)
            .map(|b| f64::from(f32::from_le_bytes(b.try_into().unwrap())))
            .collect();
        let node = &doc["nodes"][0];
        let q: Vec<f64> =
            serde_json::from_value(node["rotation"].clone()).unwrap_or(vec![0.0, 0.0, 0.0, 1.0]);
        let t: Vec<f64> =
            serde_json::from_value(node["translation"].clone()).unwrap_or(vec![0.0; 3]);
        let q = glam::DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
        let t = glam::DVec3::new(t[0], t[1], t[2]);
        let points = floats
            .chunks_exact(3)
            .map(|c| {
                let y_up = q * glam::DVec3::new(c[0], c[1], c[2]) + t;
                glam::DVec3::new(y_up.x, -y_up.z, y_up.y)
            })
            .collect();
        let ints: Vec<u32> = view(indices)
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        let faces = ints.chunks_exact(3).map(|f| [f[0], f[1], f[2]]).collect();
        (points, faces)
    }

    /// `box` of a tile: its least and greatest corners (the half-axes are axis-aligned).
    fn corners(t: &serde_json::Value) -> [glam::DVec3; 2] {
        let b: Vec<f64> = serde_json::from_value(t["boundingVolume"]["box"].clone()).unwrap();
        assert_eq!(b.len(), 12);
        assert_eq!([b[4], b[5], b[6], b[8], b[9], b[10]], [0.0; 6], "{b:?}");
        let c = glam::DVec3::new(b[0], b[1], b[2]);
        let h = glam::DVec3::new(b[3], b[7], b[11]);
        assert!(h.min_element() > 0.0, "{b:?}");
        [c - h, c + h]
    }

    /// A 3D Tiles export of heights above EGM96: every vertex of every tile, read back from
    /// its GLB and placed by the transforms tileset.json composes from the root, lands at its
    /// longitude, latitude and height + N on WGS84, within f32's rounding; every
    /// tile's box holds its vertices and its children's boxes; errors fall from the root to
    /// the leaves, which have 0; a tile wholly over the data is the server's ENU mesh with
    /// skirts, coarse ones are cut to the data; and every tile over the data is there once.
    #[test]
    fn a_3dtiles_export_places_every_vertex_on_the_ellipsoid() {
        use zerotile_codec::geo::geoid::undulation_exact;
        use zerotile_codec::geo::{Ellipsoid, VerticalDatum};
        use zerotile_codec::raster::{Crs, Georef, Heightmap};
        use zerotile_codec::Grid;
        let dir = crate::fixtures::scratch("export-3dtiles");
        let data = dir.join("data");
        // Hills over 1° about (10.5° E, 45.5° N), 0.0025° a sample.
        let n = 401;
        let h: Vec<f64> = (0..n * n)
            .map(|k| {
                let (r, c) = ((k / n) as f64, (k % n) as f64);
                800.0 + 600.0 * (r / 40.0).sin() * (c / 55.0).cos()
            })
            .collect();
        let georef = Georef::north_up(Crs::Geographic, 10.0, 46.0, 0.0025, 0.0025);
        let mut map = Heightmap::new(Grid::new(n, n, h).unwrap(), None, Some(georef));
        map.vertical_datum = Some(VerticalDatum::Egm96);
        let job = crate::ingest::Ingest {
            input: PathBuf::from("hill.tif"),
            ..crate::ingest::Ingest::for_test("hill", "geodetic", &data)
        };
        crate::ingest::build(&job, map).unwrap();
        let out = dir.join("tiles");
        let done = run(&Export {
            dataset: "hill".into(),
            data: data.clone(),
            format: "3dtiles".into(),
            out: out.clone(),
            zooms: None,
            base_url: None,
            png_compression: PngCompression::Fast,
            progress: false,
        })
        .unwrap();
        let doc: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("tileset.json")).unwrap()).unwrap();
        assert_eq!(doc["asset"]["version"], "1.1");
        let root = &doc["root"];
        assert_eq!(root["refine"], "REPLACE");
        assert!(root.get("content").is_none() && root.get("transform").is_none());

        // The server's state over the same file, to render each tile as `serve` does.
        let path =
            crate::ingest::existing_dataset_path(std::ffi::OsStr::new("hill"), &data).unwrap();
        let mut catalog = Catalog::default();
        catalog.insert(Dataset::open(&path).unwrap());
        let state = AppState::new(catalog, Config::default()).unwrap();
        let d = state.catalog().iter().next().unwrap().clone();
        let wgs84 = Ellipsoid::WGS84;

        let root_error = root["geometricError"].as_f64().unwrap();
        let mut seen = std::collections::BTreeSet::new();
        let mut worst = [0.0f64; 3];
        let (mut cut, mut whole) = (0, 0);
        let mut check = |t: &serde_json::Value, frame: glam::DMat4, parent_error: f64| {
            let error = t["geometricError"].as_f64().unwrap();
            assert!(error <= parent_error, "{t}");
            assert_eq!(t.get("children").is_none(), error == 0.0, "{t}");
            let [lo, hi] = corners(t);
            // Children's boxes, moved into this frame, lie within it.
            for c in t["children"].as_array().into_iter().flatten() {
                let m: Vec<f64> = serde_json::from_value(c["transform"].clone()).unwrap();
                let m = glam::DMat4::from_cols_slice(&m);
                let [clo, chi] = corners(c);
                for k in 0..8 {
                    let p = glam::DVec3::new(
                        if k & 1 == 0 { clo.x } else { chi.x },
                        if k & 2 == 0 { clo.y } else { chi.y },
                        if k & 4 == 0 { clo.z } else { chi.z },
                    );
                    let q = m.transform_point3(p);
                    assert!(q.cmpge(lo - 1e-6).all() && q.cmple(hi + 1e-6).all(), "{q}");
                }
            }
            let Some(uri) = t["content"]["uri"].as_str() else {
                return;
            };
            let parts: Vec<u32> = uri
                .trim_end_matches(".glb")
                .split('/')
                .map(|p| p.parse().unwrap())
                .collect();
            let id = TileId {
                z: parts[0] as u8,
                x: parts[1],
                y: parts[2],
            };
            assert!(seen.insert(id), "{id} twice");
            let t_id = threshold::default_threshold(&d, id.z);
            let s = pipeline::stitched(&state, &d, id, t_id, &Cancel::default()).unwrap();
            let mut plain = render::tri_mesh(&d, id, &s.mesh).unwrap();
            let [west, south, east, north] = d.metadata().bounds;
            let g = d
                .tiling
                .tile_geo(zerotile_codec::geo::TileId::new(id.z, id.x, id.y))
                .unwrap();
            let within = g.west >= west && g.east <= east && g.south >= south && g.north <= north;
            over_data::over_data(&mut plain, d.tiling.scheme(), d.metadata().bounds);
            // Nothing past the data: the cut is at its bounds.
            for q in &plain.positions {
                let inside = (west..=east).contains(&q.x) && (south..=north).contains(&q.y);
                assert!(inside, "{uri}: {q} past the data");
            }
            let surface = (plain.positions.len(), plain.faces.len());
            skirts::add_skirts(&mut plain, skirt_depth(&d, t_id));
            // What the file holds, in the tile's frame as a runtime reads it.
            let (stored, stored_faces) = read_glb(&std::fs::read(out.join(uri)).unwrap());
            assert_eq!(stored_faces, plain.faces, "{uri}");
            assert_eq!(stored.len(), plain.positions.len(), "{uri}");
            // f32 keeps 24 bits of each coordinate: slack of twice that at the tile's size.
            let size = stored
                .iter()
                .map(|p| p.abs().max_element())
                .fold(0.0, f64::max);
            let slack = 2.0 * size * f64::from(f32::EPSILON) + 1e-3;
            // The tile's own geoid: coarse zooms take coarse lattices (metres off the full
            // sum at zoom 0), from zoom 8 on it is the 7.5′ one.
            let patch = frame::geoid(&d, [g.west, g.south, g.east, g.north]).unwrap();
            for (p, q) in stored.iter().zip(&plain.positions) {
                assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{uri}: {p} outside");
                let placed = frame.transform_point3(*p);
                let want = wgs84.to_ecef(q.x, q.y, q.z + patch.undulation(q.x, q.y));
                worst[0] = worst[0].max(placed.distance(want) / slack);
                let [_, _, height] = wgs84.to_geodetic(placed);
                if id.z >= 8 {
                    worst[1] = worst[1].max(slack);
                    let n = undulation_exact(q.x, q.y);
                    worst[2] = worst[2].max((height - q.z - n).abs());
                }
            }
            let enu = frame::at_tile(&d, id).unwrap();
            // A tile wholly over the data is the server's `.glb?frame=enu` mesh, then skirts.
            if !within {
                cut += 1;
                return;
            }
            whole += 1;
            let served = render::mesh_in_frame(&d, id, &s.mesh, Some(&enu)).unwrap();
            for (a, b) in served.positions.iter().zip(&stored[..surface.0]) {
                assert!(a.distance(*b) <= slack, "{uri}: {a} against {b}");
            }
            assert_eq!(served.faces, stored_faces[..surface.1], "{uri}");
            assert!(stored_faces.len() > surface.1, "{uri}: no skirts");
        };
        for top in root["children"].as_array().unwrap() {
            walk(top, glam::DMat4::IDENTITY, root_error, &mut check);
        }
        // Every vertex read back and placed by the composed transforms lies where its
        // longitude, latitude and height put it, within its f32 slack (at most 0.02 m on the
        // deepest tiles); and from zoom 8, within the 7.5′ lattice's interpolation of the
        // geoid (0.15 m) of the full sum, plus that slack.
        assert!(worst[0] <= 1.0 && worst[1] < 0.02, "{worst:?}");
        assert!(worst[2] > 0.0 && worst[2] < 0.16 + 0.02, "{worst:?}");
        // The coarse tiles span far past the data and were cut; the deepest hold some wholly
        // over it.
        assert!(cut > 0 && whole > 0, "{cut} cut, {whole} whole");
        // Every tile over the data, once; the world's other zoom-0 tile (0/0/0, all fill)
        // has no file and no node.
        let [west, south, east, north] = d.metadata().bounds;
        let exported: std::collections::BTreeSet<TileId> = d
            .container
            .tiles()
            .map(|(id, _)| id)
            .filter(|id| {
                let g = d
                    .tiling
                    .tile_geo(zerotile_codec::geo::TileId::new(id.z, id.x, id.y));
                let g = g.unwrap();
                // Overlapping, not touching: a tile beside the data has nothing over it.
                g.west < east && g.east > west && g.south < north && g.north > south
            })
            .collect();
        assert_eq!(seen, exported);
        assert_eq!(d.container.tiles().count(), exported.len() + 1);
        assert_eq!(done.tiles, exported.len() as u64);
        assert!(exported.iter().any(|t| t.z >= 9), "{exported:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A folder that is no export is refused naming what is in it (a folder as one entry), as
    /// an earlier export's additions are: it named nothing, where the README said it did.
    #[test]
    fn a_folder_that_is_no_export_is_refused_naming_its_entries() {
        let dir = crate::fixtures::scratch("check-out-other").join("other");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(dir.join("sub/b.txt"), "mine").unwrap();
        std::fs::write(dir.join("a.txt"), "mine").unwrap();
        let err = check_out(&dir).unwrap_err().to_string();
        assert!(
            err.contains(
                "other: the folder has files and is not an earlier zerotile export \
                 (no .zerotile-export): 2 entries in it (a.txt, sub) are not an export's own"
            ) && err.contains("move them out first or give a new or empty folder"),
            "{err}"
        );
        std::fs::remove_dir_all(dir.join("sub")).unwrap();
        let err = check_out(&dir).unwrap_err().to_string();
        assert!(
            err.contains("a.txt in it is not an export's own") && err.contains("move a.txt out"),
            "{err}"
        );
        let _ = std::fs::remove_dir_all(dir.parent().unwrap());
    }

    /// A symbolic link as --out is refused for what it is (the swap would replace the link).
    #[test]
    fn an_out_that_is_a_symbolic_link_is_refused_as_one() {
        let dir = crate::fixtures::scratch("check-out");
        std::fs::create_dir_all(dir.join("real")).unwrap();
        std::os::unix::fs::symlink(dir.join("real"), dir.join("link")).unwrap();
        let err = check_out(&dir.join("link")).unwrap_err().to_string();
        assert!(err.contains("symbolic link"), "{err}");
        assert!(check_out(&dir.join("real")).is_ok());
        assert!(check_out(&dir.join("absent")).is_ok());
        for nameless in [".", "..", "a/.."] {
            let err = check_out(Path::new(nameless)).unwrap_err().to_string();
            assert!(err.contains("name the folder itself"), "{nameless}: {err}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// An earlier export is replaced only while it holds nothing but an export's files
    /// (stale tiles of other zooms or formats included); a user's file there, or a folder,
    /// or a link, is named and refused, the first five of many with their count.
    #[test]
    fn an_earlier_export_with_a_users_files_is_refused_by_name() {
        let dir = crate::fixtures::scratch("check-out-own").join("tiles");
        let put = |files: &[&str], body: &str| {
            for file in files {
                let path = dir.join(file);
                std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                std::fs::write(path, body).unwrap();
            }
        };
        put(
            &[
                MARKER,
                "layer.json",
                "tiles.json",
                "3/1/2.terrain",
                "4/0/7.png",
            ],
            "x",
        );
        std::fs::create_dir_all(dir.join("5/0")).unwrap();
        assert!(check_out(&dir).is_ok());

        std::fs::write(dir.join("index.html"), "mine").unwrap();
        let err = check_out(&dir).unwrap_err().to_string();
        assert!(
            err.contains("tiles: an earlier zerotile export, but index.html in it is not")
                && err.contains("move index.html out first or give another --out"),
            "{err}"
        );
        put(
            &[
                "3/1/notes.txt",
                "3/README",
                "3/1/2.terrain.bak",
                "assets/a.css",
            ],
            "mine",
        );
        std::os::unix::fs::symlink(dir.join("3"), dir.join("6")).unwrap();
        std::fs::write(dir.join(".htaccess"), "mine").unwrap();
        let err = check_out(&dir).unwrap_err().to_string();
        assert!(
            err.contains(
                "7 entries in it (.htaccess, 3/1/2.terrain.bak, 3/1/notes.txt, 3/README, 6 and \
                 2 more) are not the export's own"
            ) && err.contains("move them out first"),
            "{err}"
        );
        assert_eq!(std::fs::read(dir.join("index.html")).unwrap(), b"mine");
        let _ = std::fs::remove_dir_all(dir.parent().unwrap());
    }
}
