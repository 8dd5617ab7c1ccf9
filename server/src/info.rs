//! `zerotile info`: what a dataset file holds, and with `--verify` whether all of it reads.
//!
//! The server checks a tile only when someone asks for it, so a bad copy (a flipped bit on
//! the way to object storage, a truncated upload) shows up as one 500 weeks later. Verifying
//! reads every record through the server's own reader (its CRC) and decodes every stream to
//! the end, before the file goes live.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Mutex;

use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use serde::Serialize;
use zerotile_codec::container::TileId;
use zerotile_codec::ezw::{self, DecodeLimit};
use zerotile_codec::geo::{Bounds, VerticalDatum};

use crate::serve::dataset::Dataset;

/// The exit code of a file that failed a check, its header's included, apart from 1 (the
/// system would not give it), so a script can tell a bad copy from a missing one.
pub const CHECKS_FAILED: u8 = 3;

/// The error `info` ends with when a check failed.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ChecksFailed(pub String);

/// A file `info` could read but whose header or index does not hold (a truncated or
/// garbled copy, metadata the server could not use): with `--json` it is still one object,
/// led by the keys a [`Report`]'s object is, so a script reads `ok` and `error` first
/// whatever failed (serde writes fields in declaration order).
#[derive(Debug, Serialize, thiserror::Error)]
#[error("{path}: {error}")]
pub struct Unreadable {
    pub ok: bool,
    pub error: String,
    pub name: String,
    pub path: String,
}

/// Announced tiles listed by name (all are counted).
const MISSING_LISTED: usize = 100;
/// Ranges per zoom checked; an ingest writes one (two for the geodetic roots).
const MAX_RANGES: usize = 64;

/// What to look at.
#[derive(Clone, Debug)]
pub struct Info {
    /// A dataset name in `data`, or a path to a `.ztd` file (any bytes: a path need not be
    /// UTF-8).
    pub dataset: std::ffi::OsString,
    pub data: PathBuf,
    pub verify: bool,
    pub progress: bool,
}

/// Tiles and bytes of one zoom.
#[derive(Clone, Debug, Serialize)]
pub struct Zoom {
    pub zoom: u8,
    pub tiles: u64,
    /// Record bytes: corners and stream (each record's CRC sits in the index).
    pub bytes: u64,
    /// Record bits per coded sample.
    pub bps: f64,
}

/// One tile that failed verification.
#[derive(Clone, Debug, Serialize)]
pub struct Failure {
    pub tile: String,
    pub error: String,
}

/// The report `info` prints.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The name the server serves it under: the file's stem.
    pub name: String,
    pub path: String,
    /// Why `serve` would skip the file under its name (`None`: it serves it as `name`).
    /// Not a failed check: the copy is good, only its name is not one a URL may carry.
    pub name_problem: Option<String>,
    pub metadata: zerotile_codec::container::Metadata,
    pub zooms: Vec<Zoom>,
    pub tiles: u64,
    pub bytes: u64,
    /// Tiles `layer.json` announces (the metadata's availability) that the file lacks:
    /// clients would get 404s where they were promised data. The first
    /// `MISSING_LISTED`; `missing_total` counts them all.
    pub missing: Vec<String>,
    pub missing_total: u64,
    /// Availability the check could not read.
    pub availability_problems: Vec<String>,
    /// With `--verify`, the tiles that did not read or decode (empty: all did).
    pub failed: Option<Vec<Failure>>,
    /// Bytes after the last tile record. A writer ends the file there (records follow the
    /// header back to back), so anything after it is an append or a copy gone wrong, which
    /// no tile read would ever notice.
    pub trailing_bytes: u64,
}

impl Report {
    /// Whether every check run found nothing wrong.
    pub fn ok(&self) -> bool {
        self.problems().is_empty()
    }

    /// One phrase per kind of check that failed, for the one-line error `info` exits with
    /// (the report itself lists the tiles).
    pub fn problems(&self) -> Vec<String> {
        let mut problems = Vec::new();
        if self.missing_total > 0 {
            problems.push(format!(
                "{} announced tiles are missing",
                self.missing_total
            ));
        }
        if !self.availability_problems.is_empty() {
            problems.push("its availability could not be checked".to_string());
        }
        if let Some(f) = self.failed.as_ref().filter(|f| !f.is_empty()) {
            problems.push(format!("{} of {} tiles failed", f.len(), self.tiles));
        }
        if self.trailing_bytes > 0 {
            problems.push(format!(
                "{} bytes follow the last tile record",
                self.trailing_bytes
            ));
        }
        problems
    }
}

/// `--json`: the report led by `ok` and `error`, as an [`Unreadable`] file's object is.
pub fn json(r: &Report) -> serde_json::Result<String> {
    #[derive(Serialize)]
    struct Json<'a> {
        ok: bool,
        error: Option<String>,
        #[serde(flatten)]
        report: &'a Report,
    }
    let problems = r.problems();
    serde_json::to_string(&Json {
        ok: problems.is_empty(),
        error: (!problems.is_empty()).then(|| problems.join("; ")),
        report: r,
    })
}

pub fn run(job: &Info) -> Result<Report> {
    let (dataset, data) = (job.dataset.to_string_lossy(), job.data.to_string_lossy());
    for given in [&*dataset, &*data] {
        if crate::serve::storage::is_url(given) {
            crate::bail_usage!(
                "{given}: info reads local files; verify a dataset before uploading it, or \
                 copy it down first"
            );
        }
    }
    let path = crate::ingest::existing_dataset_path(&job.dataset, &job.data)?;
    let d = match Dataset::open_any_name(&path) {
        Ok(d) => d,
        // A truncated or garbled copy is a bad copy, which is what the exit code tells apart
        // from a file the system would not give us.
        Err(e) if !system_refused(&e) => {
            return Err(Unreadable {
                ok: false,
                error: format!("{e:#}"),
                name: path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                path: path.display().to_string(),
            }
            .into())
        }
        Err(e) => return Err(e.context(path.display().to_string())),
    };
    // `serve` lists only `*.ztd` (any case): a good copy kept as `n44.bak` was described with
    // no word that it would not be served.
    let name_problem = [
        (!crate::ingest::is_dataset_file(&path))
            .then(|| format!("it lists only .{} files", crate::ingest::EXTENSION)),
        crate::ingest::check_name(&d.name)
            .err()
            .map(|e| format!("{e:#}")),
    ]
    .into_iter()
    .flatten()
    .reduce(|a, b| format!("{a}; {b}"));
    let file_len = std::fs::metadata(&path)
        .with_context(|| path.display().to_string())?
        .len();
    let records_end = d
        .container
        .tiles()
        .map(|(_, e)| e.offset.saturating_add(u64::from(e.len)))
        .fold(d.container.header_len() as u64, u64::max);
    let m = d.metadata().clone();
    let side = m.tile_side as u64;

    let mut per_zoom: BTreeMap<u8, (u64, u64)> = BTreeMap::new();
    for (id, e) in d.container.tiles() {
        let z = per_zoom.entry(id.z).or_default();
        z.0 += 1;
        z.1 += u64::from(e.len);
    }
    let zooms: Vec<Zoom> = per_zoom
        .into_iter()
        .map(|(zoom, (tiles, bytes))| Zoom {
            zoom,
            tiles,
            bytes,
            bps: bytes as f64 * 8.0 / (tiles * side * side) as f64,
        })
        .collect();

    let absent = absent(&d);

    let failed = job.verify.then(|| verify(&d, job.progress));
    Ok(Report {
        name: d.name.clone(),
        path: path.display().to_string(),
        name_problem,
        metadata: m,
        tiles: zooms.iter().map(|z| z.tiles).sum(),
        bytes: zooms.iter().map(|z| z.bytes).sum(),
        zooms,
        missing: absent.listed,
        missing_total: absent.total,
        availability_problems: absent.problems,
        failed,
        trailing_bytes: file_len.saturating_sub(records_end),
    })
}

/// Whether opening failed in the operating system (no such file, no permission, an I/O
/// error) rather than on what the file holds.
fn system_refused(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.is::<std::io::Error>()
            || c.downcast_ref::<crate::regular_file::OpenError>()
                .is_some_and(crate::regular_file::OpenError::is_io)
    })
}

/// Announced tiles the file lacks.
struct Absent {
    /// Per range, its area minus the stored tiles inside it, summed (saturating).
    total: u64,
    /// The first [`MISSING_LISTED`] of them, as z/x/y.
    listed: Vec<String>,
    /// Zooms whose ranges were not checked, and why.
    problems: Vec<String>,
}

/// Counts announced-but-absent tiles by arithmetic, so a header announcing 2^64 tiles
/// costs nothing to count, and lists the first few by walking positions under a step
/// budget, so overlapping or repeated ranges cannot make the walk long.
fn absent(d: &Dataset) -> Absent {
    let m = d.metadata();
    let mut stored: BTreeMap<u8, Vec<(u32, u32)>> = BTreeMap::new();
    for (id, _) in d.container.tiles() {
        stored.entry(id.z).or_default().push((id.x, id.y));
    }
    let mut out = Absent {
        total: 0,
        listed: Vec::new(),
        problems: Vec::new(),
    };
    let mut budget = d.container.len() + 100_000;
    for (i, ranges) in m.available.iter().enumerate() {
        let Ok(z) = u8::try_from(usize::from(m.min_zoom) + i) else {
            break;
        };
        if ranges.len() > MAX_RANGES {
            out.problems.push(format!(
                "zoom {z} announces {} ranges (an ingest writes one or two); not checked",
                ranges.len()
            ));
            continue;
        }
        let here = stored.get(&z).map_or(&[][..], Vec::as_slice);
        for r in ranges {
            if r.end_x < r.start_x || r.end_y < r.start_y {
                out.problems.push(format!("zoom {z}: an empty range {r:?}"));
                continue;
            }
            let inside = |&(x, y): &(u32, u32)| {
                (r.start_x..=r.end_x).contains(&x) && (r.start_y..=r.end_y).contains(&y)
            };
            let gap = r.tile_count() - here.iter().filter(|t| inside(t)).count() as u128;
            out.total = out
                .total
                .saturating_add(u64::try_from(gap).unwrap_or(u64::MAX));
            let mut found = 0u128;
            'range: for y in r.start_y..=r.end_y {
                for x in r.start_x..=r.end_x {
                    if found == gap || out.listed.len() >= MISSING_LISTED || budget == 0 {
                        break 'range;
                    }
                    budget -= 1;
                    if !d.has_tile(TileId { z, x, y }) {
                        found += 1;
                        out.listed.push(format!("{z}/{x}/{y}"));
                    }
                }
            }
        }
    }
    out
}

/// Reads and fully decodes every tile; the ones that fail, in tile order.
fn verify(d: &Dataset, progress: bool) -> Vec<Failure> {
    let mut ids: Vec<TileId> = d.container.tiles().map(|(id, _)| id).collect();
    ids.sort_by_key(|t| (t.z, t.y, t.x));
    let bar = crate::ingest::tile_bar("verifying", progress, ids.len() as u64);
    let failed = Mutex::new(Vec::new());
    ids.par_iter().for_each(|&id| {
        if let Err(e) = check_tile(d, id) {
            if let Ok(mut f) = failed.lock() {
                f.push((id, format!("{e:#}")));
            }
        }
        bar.inc(1);
    });
    bar.finish_and_clear();
    let mut failed = failed.into_inner().unwrap_or_default();
    failed.sort_by_key(|(t, _)| (t.z, t.y, t.x));
    failed
        .into_iter()
        .map(|(id, error)| Failure {
            tile: id.to_string(),
            error,
        })
        .collect()
}

fn check_tile(d: &Dataset, id: TileId) -> Result<()> {
    let m = d.metadata();
    let (side, precision) = (m.tile_side, m.precision);
    // The reader checks the CRC and that the corners are finite.
    let rec = d.read_tile(id)?;
    // The stream's own header governs its decode; the metadata's wavelet and step are what
    // the dataset description tells clients, so a header edited apart from its streams
    // would describe another codec.
    let (head, _) =
        ezw::Header::read(&rec.stream, side * side).context("reading the stream header")?;
    if head.wavelet != m.wavelet {
        bail!(
            "the stream is coded with the {} wavelet, the dataset says {}",
            head.wavelet.name(),
            m.wavelet.name()
        );
    }
    if (head.step - m.step).abs() > 1e-12 * head.step.abs().max(m.step.abs()) {
        bail!(
            "the stream's step is {:?} m, the dataset says {:?} m",
            head.step,
            m.step
        );
    }
    // A decode takes any prefix, so a stream that lost its tail (or gained one) would pass
    // it: the stream's own header and trailer say where it ends.
    let len = rec.stream.len();
    match ezw::whole_len(&rec.stream, side * side).context("reading the stream header")? {
        Some(n) if n == len => {}
        Some(n) => bail!("the stream ends at byte {n} of its {len}: {} bytes follow it", len - n),
        None => bail!("the stream is cut short: its {len} bytes end before its header's passes and trailer do"),
    }
    let dec = ezw::decode_heights(&rec.stream, DecodeLimit::All, side * side)
        .context("decoding the stream to its end")?;
    if dec.heights.rows() != side || dec.heights.cols() != side {
        bail!(
            "decodes to {}×{}, the dataset says {side}²",
            dec.heights.rows(),
            dec.heights.cols()
        );
    }
    if dec.heights.data().iter().any(|h| !h.is_finite()) {
        bail!("decodes to heights that are not finite");
    }
    // The record's corners are the samples the stream encoded there (stitched meshes use
    // them), so the decode must agree with them within the bound the stream records: a
    // stream stored under another tile's record would not.
    if let Some(bound) = dec.max_error {
        let last = side - 1;
        let decoded =
            [(0, 0), (0, last), (last, 0), (last, last)].map(|(r, c)| *dec.heights.get(r, c));
        for (k, (&d, &c)) in decoded.iter().zip(&rec.corners).enumerate() {
            if (d - c).abs() > bound * (1.0 + 1e-9) + 1e-9 {
                bail!(
                    "corner {k} decodes to {d} m, the record says {c} m (the stream bounds its \
                     error by {bound} m)"
                );
            }
        }
    }
    // The residual pass records the bound it guarantees; it must be the one promised.
    if let Some(p) = precision {
        match dec.max_error {
            Some(e) if e <= p * (1.0 + 1e-9) => {}
            Some(e) => bail!("the stream guarantees {e} m, the dataset promises {p} m"),
            None => bail!("the stream records no error bound; the dataset promises {p} m"),
        }
    }
    Ok(())
}

/// The human-readable report.
pub fn render(r: &Report) -> String {
    use std::fmt::Write;
    let m = &r.metadata;
    let mut s = String::new();
    let precision = match m.precision {
        Some(p) => format!("within {p} m of the source"),
        None => "every bit plane kept".to_string(),
    };
    // Served under the file's name; say so when the ingest named it otherwise.
    let ingested_as = if m.name == r.name {
        String::new()
    } else {
        format!(", ingested as {}", m.name)
    };
    let _ = writeln!(
        s,
        "{} ({}{ingested_as}): {} tiling, {}² tiles, zooms {}–{}, {}, step {} m, {precision}",
        r.name,
        r.path,
        m.scheme,
        m.tile_side,
        m.min_zoom,
        m.max_zoom,
        m.wavelet.name(),
        m.step
    );
    if m.scheme == "local" {
        let [rows, cols] = m.source_size;
        let _ = writeln!(s, "source grid {rows} × {cols} samples");
    } else {
        let [w, so, e, n] = m.bounds;
        let across = if Bounds::from(m.bounds).crosses_antimeridian() {
            " (across the antimeridian)"
        } else {
            ""
        };
        let _ = writeln!(s, "bounds (W, S, E, N) {w}, {so}, {e}, {n} degrees{across}");
    }
    // "none" is what the metadata records for a source without a CRS.
    let crs = match m.source_crs.as_str() {
        "none" => "no CRS",
        c => c,
    };
    // The source's own range, where the fill around it widens the dataset's.
    let source_range = match m.source_height_range {
        Some([lo, hi]) if [lo, hi] != m.height_range => format!(" (the source's {lo} … {hi} m)"),
        _ => String::new(),
    };
    // A local grid serves neither quantized-mesh nor ENU: nothing is raised there.
    let datum = match (m.vertical_datum, m.scheme.as_str()) {
        (Some(VerticalDatum::Egm96), "local") => " above EGM96",
        (Some(VerticalDatum::Egm96), _) => " above EGM96 (raised to the ellipsoid for Cesium, ENU)",
        (Some(VerticalDatum::Ellipsoid), _) => " above the WGS84 ellipsoid",
        (None, _) => "",
    };
    let _ = writeln!(
        s,
        "heights {} … {} m{datum}{source_range}, fill {} m; source {} ({crs}), ingested {}",
        m.height_range[0], m.height_range[1], m.fill, m.source, m.created
    );
    // Records hold the corners besides the stream: 32 bytes a tile above the stream bytes
    // ingest reports.
    let _ = writeln!(
        s,
        "{:>4} {:>8} {:>12} {:>11}",
        "zoom", "tiles", "record bytes", "bits/sample"
    );
    for z in &r.zooms {
        let _ = writeln!(
            s,
            "{:>4} {:>8} {:>12} {:>11.3}",
            z.zoom, z.tiles, z.bytes, z.bps
        );
    }
    let side = m.tile_side as f64;
    let _ = writeln!(
        s,
        "{:>4} {:>8} {:>12} {:>11.3}",
        "all",
        r.tiles,
        r.bytes,
        r.bytes as f64 * 8.0 / (r.tiles.max(1) as f64 * side * side)
    );
    if r.missing_total > 0 {
        let more = r.missing_total.saturating_sub(r.missing.len() as u64);
        let _ = writeln!(
            s,
            "{} announced tiles are missing: {}{}",
            r.missing_total,
            r.missing.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        );
    }
    for p in &r.availability_problems {
        let _ = writeln!(s, "availability: {p}");
    }
    match &r.failed {
        None => {}
        Some(f) if f.is_empty() => {
            let _ = writeln!(
                s,
                "verified: all {} tiles read (checksums hold) and decode to the end",
                r.tiles
            );
        }
        Some(f) => {
            for x in f {
                // The reader's own errors already name the tile.
                if x.error.contains(&x.tile) {
                    let _ = writeln!(s, "{}", x.error);
                } else {
                    let _ = writeln!(s, "tile {}: {}", x.tile, x.error);
                }
            }
            let _ = writeln!(s, "{} of {} tiles failed verification", f.len(), r.tiles);
        }
    }
    if r.trailing_bytes > 0 {
        let _ = writeln!(
            s,
            "{} bytes follow the last tile record (a written dataset ends there)",
            r.trailing_bytes
        );
    }
    if let Some(why) = &r.name_problem {
        let _ = writeln!(
            s,
            "note: serve skips this file under its name ({why}); rename it to serve it, \
             e.g. as {}.ztd",
            servable_name(&r.name)
        );
    }
    s
}

/// A name `serve` takes, made from `stem`: what the note suggests renaming a file to.
fn servable_name(stem: &str) -> String {
    let name: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .take(64)
        .collect();
    if name.is_empty() {
        "dataset".into()
    } else {
        name
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::local_257;
    use zerotile_codec::container::{Availability, Writer};
    use zerotile_codec::ezw::EncodeParams;
    use zerotile_codec::wavelet::Wavelet;
    use zerotile_codec::Grid;

    /// Writes a container to a fresh folder and returns `info`'s report on it.
    fn report_on(tag: &str, file: Vec<u8>, verify: bool) -> Report {
        run_on(tag, "t.ztd", file, verify).unwrap()
    }

    /// `info` on `file` written as `name` in a fresh folder.
    fn run_on(tag: &str, name: &str, file: Vec<u8>, verify: bool) -> Result<Report> {
        let dir = crate::fixtures::scratch(&format!("info-{tag}"));
        let path = dir.join(name);
        std::fs::write(&path, file).unwrap();
        let report = run(&Info {
            dataset: path.clone().into_os_string(),
            data: dir.clone(),
            verify,
            progress: false,
        });
        let _ = std::fs::remove_dir_all(&dir);
        report
    }

    /// A one-tile local file whose stream and corners agree: verifies clean.
    fn sound_file(edit: impl FnOnce(&mut zerotile_codec::container::Metadata)) -> Vec<u8> {
        let n = 257;
        let g = Grid::new(n, n, (0..n * n).map(|k| (k % 7) as f64).collect()).unwrap();
        let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
        let corners = [
            *g.get(0, 0),
            *g.get(0, n - 1),
            *g.get(n - 1, 0),
            *g.get(n - 1, n - 1),
        ];
        let mut m = local_257(enc.bytes.len() as u64);
        edit(&mut m);
        let mut w = Writer::new();
        w.add(TileId { z: 0, x: 0, y: 0 }, corners, &enc.bytes);
        w.finish(&m).unwrap()
    }

    /// A path that is not UTF-8 (a Latin-1 file name from an old archive) is read like any
    /// other; it was refused as a usage error before it got here.
    #[test]
    fn a_path_that_is_not_utf8_is_read() {
        use std::os::unix::ffi::OsStrExt;
        let dir = crate::fixtures::scratch("info-latin1");
        let path = dir.join(std::ffi::OsStr::from_bytes(b"caf\xe9.ztd"));
        std::fs::write(&path, sound_file(|_| {})).unwrap();
        let r = run(&Info {
            dataset: path.into_os_string(),
            data: dir.join("elsewhere"),
            verify: true,
            progress: false,
        })
        .unwrap();
        assert!(r.ok(), "{:?}", r.problems());
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A good copy under a file name `serve` would not take (`n44.v2.ztd`, `n44 copy.ztd`)
    /// is described and verified like any other, with a note on its name: `info` failed it
    /// with exit 3, as though the copy were bad.
    #[test]
    fn a_file_named_outside_the_name_rule_is_described_with_a_note() {
        for (name, suggested) in [("n44.v2.ztd", "n44-v2"), ("n44 copy.ztd", "n44-copy")] {
            let r = run_on("named", name, sound_file(|_| {}), true).unwrap();
            assert!(r.ok(), "{name}: {:?}", r.problems());
            let why = r.name_problem.as_deref().unwrap_or_default();
            assert!(why.contains("use 1–64 characters"), "{name}: {why}");
            let text = render(&r);
            assert!(text.contains("verified: all 1 tiles"), "{text}");
            assert!(
                text.contains("note: serve skips this file under its name (dataset name")
                    && text.contains(&format!("e.g. as {suggested}.ztd")),
                "{text}"
            );
        }
        let r = run_on("named", "n44_v2.ztd", sound_file(|_| {}), false).unwrap();
        assert_eq!(r.name_problem, None);
        assert!(!render(&r).contains("note:"));
        let r = run_on("named", "n44_v2.ZTD", sound_file(|_| {}), false).unwrap();
        assert_eq!(r.name_problem, None);
    }

    /// `serve` lists only `*.ztd`: a copy under another extension (or none) gets the note,
    /// which it did not, its stem being a dataset name.
    #[test]
    fn a_file_without_the_ztd_extension_is_noted() {
        for (name, suggested) in [("n44-xyz.bak", "n44-xyz"), ("n44", "n44")] {
            let r = run_on("ext", name, sound_file(|_| {}), false).unwrap();
            assert!(r.ok(), "{name}: {:?}", r.problems());
            assert_eq!(
                r.name_problem.as_deref(),
                Some("it lists only .ztd files"),
                "{name}"
            );
            let text = render(&r);
            assert!(
                text.contains(&format!(
                    "note: serve skips this file under its name (it lists only .ztd files); \
                     rename it to serve it, e.g. as {suggested}.ztd"
                )),
                "{text}"
            );
        }
        // Both wrong: both said.
        let r = run_on("ext", "n44 copy.bak", sound_file(|_| {}), false).unwrap();
        let why = r.name_problem.unwrap_or_default();
        assert!(
            why.starts_with("it lists only .ztd files; ") && why.contains("use 1–64 characters"),
            "{why}"
        );
    }

    /// A header that does not hold is an [`Unreadable`] (exit 3), whose `--json` object
    /// leads with the keys a report's does: `info --json` printed nothing for it.
    #[test]
    fn a_header_that_fails_is_one_json_object_like_a_report() {
        let mut bad = sound_file(|_| {});
        bad[0] ^= 1;
        let e = run_on("badmagic", "t.ztd", bad, true).unwrap_err();
        let u = e.downcast_ref::<Unreadable>().expect("an Unreadable");
        // Led by `ok` and `error`, as the docs say: it began with `name` and `path`.
        let text = serde_json::to_string(u).unwrap();
        assert!(text.starts_with(r#"{"ok":false,"error":"#), "{text}");
        let v: serde_json::Value = serde_json::to_value(u).unwrap();
        assert_eq!(v["ok"], false);
        assert_eq!(v["name"], "t");
        assert!(v["path"].as_str().unwrap().ends_with("t.ztd"), "{v}");
        assert!(v["error"].as_str().unwrap().contains("bad magic"), "{v}");
        // A report says the same two things first.
        let good = report_on("good-json", sound_file(|_| {}), true);
        let text = json(&good).unwrap();
        assert!(text.starts_with(r#"{"ok":true,"error":null,"#), "{text}");
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(
            (&v["ok"], &v["error"]),
            (&true.into(), &serde_json::Value::Null)
        );
        assert_eq!(v["name"], "t");
        let mut junk = sound_file(|_| {});
        junk.extend_from_slice(&[0; 10]);
        let v: serde_json::Value =
            serde_json::from_str(&json(&report_on("junk-json", junk, false)).unwrap()).unwrap();
        assert_eq!(v["ok"], false);
        assert_eq!(v["error"], "10 bytes follow the last tile record");
        assert_eq!(v["trailing_bytes"], 10);
    }

    /// Bytes after the last record fail the check, counted: no tile read reaches them, so
    /// `--verify` passed a file with 1000 bytes appended.
    #[test]
    fn bytes_after_the_last_record_fail_the_check() {
        let mut file = sound_file(|_| {});
        file.extend_from_slice(&[0; 1000]);
        let r = report_on("junk", file, true);
        assert_eq!(r.trailing_bytes, 1000);
        assert_eq!(r.problems(), ["1000 bytes follow the last tile record"]);
        assert!(
            render(&r).contains("1000 bytes follow the last tile record"),
            "{}",
            render(&r)
        );
        assert_eq!(
            report_on("nojunk", sound_file(|_| {}), true).trailing_bytes,
            0
        );
    }

    /// Metadata that names another wavelet or step than its streams are coded with fails
    /// `--verify` at the tile (the header alone cannot tell): it passed, and clients were
    /// told a codec the tiles do not use.
    #[test]
    fn a_wavelet_or_step_the_streams_do_not_use_fails() {
        let r = report_on(
            "wavelet",
            sound_file(|m| m.wavelet = Wavelet::LeGall53),
            true,
        );
        let f = r.failed.unwrap();
        assert!(
            f.len() == 1
                && f[0].error
                    == "the stream is coded with the cdf97 wavelet, the dataset says legall53",
            "{f:?}"
        );
        let r = report_on("step", sound_file(|m| m.step = 1e308), true);
        let f = r.failed.unwrap();
        assert!(
            f.len() == 1
                && f[0]
                    .error
                    .contains("step is 1.0 m, the dataset says 1e308 m"),
            "{f:?}"
        );
    }

    /// A header's metadata the server cannot use fails `info` naming the field; the same
    /// header with sane values passes.
    #[test]
    fn metadata_the_server_cannot_use_fails_naming_the_field() {
        let e = run_on("zoom", "t.ztd", sound_file(|m| m.max_zoom = 200), false).unwrap_err();
        assert!(e.is::<Unreadable>(), "{e:#}");
        assert!(
            e.to_string().contains("metadata is invalid: max_zoom 200"),
            "{e:#}"
        );
        // A max_zoom past the availability and every stored tile (tiles at zoom 0, max_zoom
        // 1 on a grid that has a zoom 1), whose zoom serve would announce and 404: it passed.
        let past = sound_file(|m| {
            (m.source_size, m.bounds) = ([513, 513], [0.0, 512.0, 512.0, 0.0]);
            m.max_zoom = 1;
        });
        let e = run_on("zoom-past", "t.ztd", past, true).unwrap_err();
        assert!(e.is::<Unreadable>(), "{e:#}");
        assert!(
            e.to_string()
                .contains("available lists 1 zooms, but min_zoom 0 to max_zoom 1 are 2"),
            "{e:#}"
        );
        // A local grid's size that its one zoom is not the full resolution of (every mesh
        // scaled 2×): it passed --verify.
        let scaled = sound_file(|m| {
            (m.source_size, m.bounds) = ([513, 513], [0.0, 512.0, 512.0, 0.0]);
        });
        let e = run_on("scaled", "t.ztd", scaled, true).unwrap_err();
        assert!(e.is::<Unreadable>(), "{e:#}");
        assert!(
            e.to_string().contains(
                "metadata is invalid: source_size [513, 513]: max_zoom 0 is a local grid's full \
                 resolution when its longer side is 2 to 257 samples"
            ),
            "{e:#}"
        );
    }

    /// A file the system would not open (none there, no permission) is a system error (exit
    /// 1), not a bad copy (exit 3, which it became when the open's error stopped carrying
    /// its io::Error); a FIFO is about the file.
    #[test]
    fn an_open_the_system_refuses_is_not_a_bad_copy() {
        let dir = crate::fixtures::scratch("info-refused");
        let open = |p: &std::path::Path| {
            anyhow::Error::new(crate::regular_file::open(p).unwrap_err()).context("opening x")
        };
        assert!(system_refused(&open(&dir.join("absent.ztd"))));
        let fifo = dir.join("f.ztd");
        crate::fixtures::mkfifo(&fifo);
        assert!(!system_refused(&open(&fifo)));
    }

    /// A FIFO or a device where the dataset is named is said to be one, not "no such
    /// dataset file" (it is there); neither is opened, which would block on a FIFO.
    #[test]
    fn a_fifo_or_device_is_not_a_regular_file() {
        let dir = crate::fixtures::scratch("info-fifo");
        let fifo = dir.join("f.ztd");
        crate::fixtures::mkfifo(&fifo);
        let job = |dataset: &str| Info {
            dataset: dataset.into(),
            data: dir.clone(),
            verify: true,
            progress: false,
        };
        for (given, what) in [("f", "a FIFO"), ("/dev/null", "a device")] {
            let e = format!("{:#}", run(&job(given)).unwrap_err());
            assert!(
                e.ends_with(&format!(": not a regular file ({what}); give a .ztd file")),
                "{given}: {e}"
            );
            assert!(!e.contains("no such"), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn verify_file(tag: &str, file: Vec<u8>) -> Report {
        report_on(tag, file, true)
    }

    /// A record whose corners disagree with its stream (beyond the stream's own error
    /// bound) fails verification; the same stream with its true corners passes.
    #[test]
    fn corners_that_disagree_with_the_stream_fail() {
        let n = 257;
        let g = Grid::new(
            n,
            n,
            (0..n * n).map(|k| ((k / n) + (k % n)) as f64).collect(),
        )
        .unwrap();
        let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
        let id = TileId { z: 0, x: 0, y: 0 };
        let file = |corners: [f64; 4]| {
            let mut w = Writer::new();
            w.add(id, corners, &enc.bytes);
            w.finish(&local_257(enc.bytes.len() as u64)).unwrap()
        };
        let good = verify_file("good", file([0.0, 256.0, 256.0, 512.0]));
        assert!(good.ok(), "{:?}", good.failed);
        let bad = verify_file("bad", file([0.0, 256.0, 256.0, 500.0]));
        let failed = bad.failed.unwrap();
        assert_eq!(failed.len(), 1);
        assert!(
            failed[0].error.contains("corner 3 decodes to"),
            "{}",
            failed[0].error
        );
    }

    /// A stream stored without its tail (its record's CRC made to match, as a writer that
    /// stopped early would) decodes, as any prefix does, but is not whole; nor is one with
    /// bytes after it.
    #[test]
    fn a_cut_or_padded_stream_fails_though_it_decodes() {
        let n = 257;
        let g = Grid::new(
            n,
            n,
            (0..n * n)
                .map(|k| ((k / n) * (k % n) % 97) as f64)
                .collect(),
        )
        .unwrap();
        let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
        let corners = [
            *g.get(0, 0),
            *g.get(0, n - 1),
            *g.get(n - 1, 0),
            *g.get(n - 1, n - 1),
        ];
        let file = |stream: &[u8]| {
            let mut w = Writer::new();
            w.add(TileId { z: 0, x: 0, y: 0 }, corners, stream);
            w.finish(&local_257(stream.len() as u64)).unwrap()
        };
        assert!(verify_file("whole", file(&enc.bytes)).ok());
        // At the end of a pass halfway through: a prefix the decoder takes without a word.
        let cut = enc.passes[enc.passes.len() / 2].end;
        assert!(ezw::decode_heights(&enc.bytes[..cut], DecodeLimit::All, n * n).is_ok());
        let r = verify_file("cut", file(&enc.bytes[..cut]));
        let f = r.failed.unwrap();
        assert!(f.len() == 1 && f[0].error.contains("cut short"), "{f:?}");
        let mut padded = enc.bytes.clone();
        padded.extend_from_slice(&[0; 10]);
        let r = verify_file("padded", file(&padded));
        let f = r.failed.unwrap();
        assert!(
            f.len() == 1 && f[0].error.contains("10 bytes follow"),
            "{f:?}"
        );
    }

    /// `info` (without --verify) on a one-tile file whose header announces `available` at
    /// geodetic zoom 28, the deepest a header may announce (2^29 × 2^28 tiles), storing
    /// 28/0/0.
    fn announce(available: Vec<Availability>) -> Report {
        let mut m = local_257(16);
        (m.scheme, m.min_zoom, m.max_zoom) = ("geodetic".into(), 28, 28);
        m.bounds = [-180.0, -90.0, 180.0, 90.0];
        m.available = vec![available];
        let mut w = Writer::new();
        w.add(TileId { z: 28, x: 0, y: 0 }, [0.0; 4], b"not decoded here");
        report_on("a", w.finish(&m).unwrap(), false)
    }

    /// The `heights` line of `info` on a one-tile local dataset whose metadata `edit` sets.
    fn heights_line(edit: impl FnOnce(&mut zerotile_codec::container::Metadata)) -> String {
        let mut m = local_257(16);
        edit(&mut m);
        let mut w = Writer::new();
        w.add(TileId { z: 0, x: 0, y: 0 }, [0.0; 4], b"not decoded here");
        let text = render(&report_on("a", w.finish(&m).unwrap(), false));
        let heights = text.lines().find(|l| l.starts_with("heights")).unwrap();
        heights.to_string()
    }

    /// The source's own heights are shown where the fill widens the dataset's range, and not
    /// where they are the same or were not recorded.
    #[test]
    fn the_sources_height_range_is_shown_beside_the_datasets() {
        let line = |source| heights_line(|m| m.source_height_range = source);
        assert!(
            line(Some([115.0, 512.0]))
                .starts_with("heights 0 … 512 m (the source's 115 … 512 m), fill"),
            "{}",
            line(Some([115.0, 512.0]))
        );
        assert!(line(Some([0.0, 512.0])).starts_with("heights 0 … 512 m, fill"));
        assert!(line(None).starts_with("heights 0 … 512 m, fill"));
    }

    /// The datum is said beside the heights; that they are raised for Cesium and ENU only
    /// where the scheme serves those (not on a local grid).
    #[test]
    fn the_vertical_datum_is_said_as_the_scheme_serves_it() {
        let line = |datum| heights_line(|m| m.vertical_datum = datum);
        assert!(line(Some(VerticalDatum::Egm96)).starts_with("heights 0 … 512 m above EGM96, fill"));
        assert!(line(Some(VerticalDatum::Ellipsoid))
            .starts_with("heights 0 … 512 m above the WGS84 ellipsoid, fill"));
        assert!(line(None).starts_with("heights 0 … 512 m, fill"));
    }

    /// A header that announces every tile of geodetic zoom 28 but stores one: the check
    /// counts the absent ones by arithmetic (saturating) and lists the first few, rather
    /// than walking 2^57 positions; repeated ranges are counted, not walked either. (A range
    /// past its zoom's tiles, 2^32 × 2^32, is refused with the header now.)
    #[test]
    fn an_absurd_availability_is_counted_not_walked() {
        let range = |end: u32| Availability {
            start_x: 0,
            start_y: 0,
            end_x: end,
            end_y: end,
        };
        let report = announce(vec![Availability {
            end_x: (1 << 29) - 1,
            end_y: (1 << 28) - 1,
            ..range(0)
        }]);
        assert_eq!(report.tiles, 1);
        assert_eq!(report.missing.len(), MISSING_LISTED);
        assert_eq!(report.missing[0], "28/1/0");
        assert_eq!(report.missing_total, (1 << 57) - 1);
        assert!(!report.ok());
        let text = render(&report);
        assert!(
            text.contains("announced tiles are missing: 28/1/0, 28/2/0"),
            "{text}"
        );
        assert!(
            text.contains(&format!("and {} more", (1u64 << 57) - 1 - 100)),
            "{text}"
        );

        // The one stored tile, announced as often as allowed: nothing missing.
        let report = announce(vec![range(0); MAX_RANGES]);
        assert!(report.ok(), "{:?}", report.missing);
        assert!(report.problems().is_empty());
        // A 2 × 2 range four times: three absent in each copy, listed once each copy.
        let report = announce(vec![range(1); 4]);
        assert_eq!(report.missing_total, 12);
        assert_eq!(report.problems(), ["12 announced tiles are missing"]);
        // More ranges than an ingest writes: not checked, and said so.
        let report = announce(vec![range(0); MAX_RANGES + 1]);
        assert_eq!(report.availability_problems.len(), 1);
        assert!(!report.ok());
        assert_eq!(report.problems(), ["its availability could not be checked"]);
    }
    /// Zoom rows give record bytes (each stream plus its 32 bytes of corners) and bits per
    /// coded sample from them; the totals add the rows up.
    #[test]
    fn zoom_rows_count_record_bytes_and_their_bits_per_sample() {
        let mut m = local_257(3000);
        (m.max_zoom, m.source_size) = (1, [513, 513]);
        m.bounds = [0.0, 512.0, 512.0, 0.0];
        m.available.push(m.available[0].clone());
        let mut w = Writer::new();
        w.add(TileId { z: 0, x: 0, y: 0 }, [0.0; 4], &[7u8; 1000]);
        w.add(TileId { z: 1, x: 0, y: 0 }, [0.0; 4], &[7u8; 800]);
        w.add(TileId { z: 1, x: 1, y: 1 }, [0.0; 4], &[7u8; 1200]);
        let r = report_on("bytes", w.finish(&m).unwrap(), false);
        let rows: Vec<(u8, u64, u64)> =
            r.zooms.iter().map(|z| (z.zoom, z.tiles, z.bytes)).collect();
        assert_eq!(rows, [(0, 1, 1032), (1, 2, 2064)]);
        let samples = 257.0 * 257.0;
        assert!((r.zooms[1].bps - 2064.0 * 8.0 / (2.0 * samples)).abs() < 1e-12);
        assert_eq!((r.tiles, r.bytes), (3, 3096));
        // The readable table's last row is the whole file's.
        let text = render(&r);
        let all = text
            .lines()
            .find(|l| l.trim_start().starts_with("all"))
            .unwrap();
        let expected = format!("{:.3}", 3096.0 * 8.0 / (3.0 * samples));
        assert!(
            all.contains("3096") && all.ends_with(&expected),
            "{all:?} {expected}"
        );
    }

    /// The header's availability lists start at the dataset's min zoom: a file whose
    /// pyramid starts at zoom 1 announces zoom 1 first, and an absent tile there is named
    /// 1/x/y.
    #[test]
    fn availability_is_counted_from_the_min_zoom() {
        let mut m = local_257(16);
        (m.min_zoom, m.max_zoom, m.source_size) = (1, 1, [513, 513]);
        m.bounds = [0.0, 512.0, 512.0, 0.0];
        m.available = vec![vec![Availability {
            start_x: 0,
            start_y: 0,
            end_x: 1,
            end_y: 0,
        }]];
        let mut w = Writer::new();
        w.add(TileId { z: 1, x: 0, y: 0 }, [0.0; 4], b"not decoded here");
        let r = report_on("minzoom", w.finish(&m).unwrap(), false);
        assert_eq!(r.missing, ["1/1/0"]);
        assert_eq!(r.missing_total, 1);
    }

    /// A range that ends before it starts is reported as a problem, not counted (its area
    /// would underflow).
    #[test]
    fn an_empty_range_is_a_problem_not_a_count() {
        let report = announce(vec![Availability {
            start_x: 1,
            start_y: 0,
            end_x: 0,
            end_y: 0,
        }]);
        assert_eq!(report.missing_total, 0);
        assert_eq!(report.availability_problems.len(), 1);
        assert!(
            report.availability_problems[0].contains("an empty range"),
            "{:?}",
            report.availability_problems
        );
        assert!(!report.ok());
        // Empty in y alone is as empty.
        let report = announce(vec![Availability {
            start_x: 0,
            start_y: 1,
            end_x: 0,
            end_y: 0,
        }]);
        assert_eq!(report.availability_problems.len(), 1);
        assert_eq!(report.missing_total, 0);
    }

    /// A dataset that promises a precision its streams do not guarantee fails verification
    /// (a tile re-encoded looser, or metadata edited tighter); one that promises the
    /// stream's own bound passes.
    #[test]
    fn a_stream_looser_than_the_promised_precision_fails() {
        let n = 257;
        let g = Grid::new(
            n,
            n,
            (0..n * n)
                .map(|k| ((k / n) * (k % n) % 89) as f64)
                .collect(),
        )
        .unwrap();
        let mut params = EncodeParams::new(Wavelet::Cdf97, 1.0);
        params.max_error = Some(2.0);
        let enc = ezw::encode(&g, &params).unwrap();
        let corners = [
            *g.get(0, 0),
            *g.get(0, n - 1),
            *g.get(n - 1, 0),
            *g.get(n - 1, n - 1),
        ];
        let file = |precision: f64| {
            let mut m = local_257(enc.bytes.len() as u64);
            m.precision = Some(precision);
            let mut w = Writer::new();
            w.add(TileId { z: 0, x: 0, y: 0 }, corners, &enc.bytes);
            w.finish(&m).unwrap()
        };
        let kept = verify_file("kept", file(2.0));
        assert!(kept.ok(), "{:?}", kept.failed);
        let broken = verify_file("broken", file(0.25));
        let f = broken.failed.unwrap();
        assert!(
            f.len() == 1 && f[0].error.contains("the dataset promises 0.25 m"),
            "{f:?}"
        );
    }

    /// A folder, or a name with no file behind it, is refused with what to give instead.
    #[test]
    fn a_folder_or_a_missing_name_is_refused_with_what_to_give() {
        let dir = crate::fixtures::scratch("info-dir");
        let job = |dataset: String| Info {
            dataset: dataset.into(),
            data: dir.clone(),
            verify: false,
            progress: false,
        };
        let e = run(&job(dir.display().to_string()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("a folder; give a .ztd file"), "{e}");
        let e = run(&job("nothing".into())).unwrap_err().to_string();
        assert!(e.contains("no such dataset file"), "{e}");
        // Neither a file nor a name: said as a missing file first, the name rule after.
        let e = run(&job("missing/README.md".into()))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("missing/README.md: no such file, and not a dataset name")
                && e.contains("use 1–64 characters"),
            "{e}"
        );
        // A dataset of that name in --data wins over a file or folder of the name in the
        // current folder (`info n44` once read a stray ./n44).
        let cwd = std::env::current_dir().unwrap();
        let stray = cwd.join("src");
        assert!(stray.is_dir(), "the test runs in the crate folder");
        let e = run(&job("src".into())).unwrap_err().to_string();
        assert!(e.contains("a folder; give a .ztd file"), "{e}");
        std::fs::write(dir.join("src.ztd"), b"not a dataset").unwrap();
        let e = format!("{:#}", run(&job("src".into())).unwrap_err());
        assert!(e.contains("src.ztd") && !e.contains("a folder"), "{e}");
        // A file name alone, not in the current folder, is looked up in --data too.
        let e = format!("{:#}", run(&job("src.ztd".into())).unwrap_err());
        let in_data = dir.join("src.ztd").display().to_string();
        assert!(e.starts_with(&format!("{in_data}: 13 bytes")), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
    /// Failures are listed in tile order (zoom, then rows, then columns), whatever order
    /// the parallel check finished them in, so two runs over one file print the same.
    #[test]
    fn failures_are_listed_in_tile_order() {
        let n = 257;
        let g = Grid::new(n, n, (0..n * n).map(|k| (k % 13) as f64).collect()).unwrap();
        let enc = ezw::encode(&g, &EncodeParams::new(Wavelet::Cdf97, 1.0)).unwrap();
        let mut m = local_257(16 * enc.bytes.len() as u64);
        (m.min_zoom, m.max_zoom, m.source_size) = (2, 2, [1025, 1025]);
        m.bounds = [0.0, 1024.0, 1024.0, 0.0];
        m.available = vec![vec![Availability {
            start_x: 0,
            start_y: 0,
            end_x: 3,
            end_y: 3,
        }]];
        let mut w = Writer::new();
        // Stored in reverse, each with corners its stream does not decode to.
        let mut ids: Vec<TileId> = (0..16)
            .map(|k| TileId {
                z: 2,
                x: k % 4,
                y: k / 4,
            })
            .collect();
        ids.reverse();
        for &id in &ids {
            w.add(id, [1e4; 4], &enc.bytes);
        }
        let r = verify_file("order", w.finish(&m).unwrap());
        // All 16 are stored, so nothing is missing: the one problem is the failures.
        assert_eq!(r.problems(), ["16 of 16 tiles failed"]);
        let listed: Vec<String> = r.failed.unwrap().into_iter().map(|f| f.tile).collect();
        let expected: Vec<String> = (0..16).map(|k| format!("2/{}/{}", k % 4, k / 4)).collect();
        assert_eq!(listed, expected);
    }
}
