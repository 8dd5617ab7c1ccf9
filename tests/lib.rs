//! Shared helpers for the end-to-end tests: where the binary and the shared fixtures are.
#![allow(
    clippy::expect_used,
    clippy::panic,
    reason = "test support: without a current binary the run cannot go on"
)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::SystemTime;

pub mod qm;
pub mod server;

/// `../shared/data` beside the repository: real rasters and meshes, read in place.
pub fn shared_data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data")
}

/// The repository root.
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Where end-to-end tests leave files worth a look (screenshots, GLBs): `TARGET/e2e/WHAT`.
pub fn e2e_out(what: &str) -> PathBuf {
    std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| repo_root().join("target"))
        .join("e2e")
        .join(what)
}

/// Whether a test that needs outside tools (a browser, nginx, an S3 server) can run: yes
/// when `missing` is empty. Otherwise it prints why and says no, so a laptop without them
/// still passes `cargo test`; under `ZEROTILE_E2E=1` (set by `.ci/run`) it fails the test
/// instead, so CI cannot skip silently.
pub fn tools_ready(test: &str, missing: &[String]) -> bool {
    if missing.is_empty() {
        return true;
    }
    let msg = format!("{test} needs: {}", missing.join("; "));
    if std::env::var("ZEROTILE_E2E").is_ok_and(|v| v == "1") {
        panic!("ZEROTILE_E2E=1 but {msg}");
    }
    eprintln!("SKIPPED (set ZEROTILE_E2E=1 to require it): {msg}");
    false
}

/// What a node-driven test lacks: node itself, or `package` under web/node_modules.
pub fn node_missing(package: &str) -> Vec<String> {
    let mut missing = Vec::new();
    if Command::new("node").arg("--version").output().is_err() {
        missing.push("node (Node.js 18+)".to_string());
    }
    if !repo_root().join("web/node_modules").join(package).is_dir() {
        missing.push(format!(
            "web/node_modules/{package} (npm ci --prefix web --ignore-scripts)"
        ));
    }
    missing
}

/// A fresh data folder for the client tests: the default data (geodetic demo-ridges and
/// the object meshes) and N44W072 on the mercator grid as `n44m` (zooms to 10).
pub fn client_data(tag: &str) -> PathBuf {
    let data = fresh_dir(tag);
    run_in(&["demo-data", "--quiet"], &data);
    let hgt = shared_data().join("dem/N44W072.hgt");
    let mut ingest = ingest_command(
        &hgt,
        "n44m",
        &data,
        &["--scheme", "mercator", "--max-zoom", "10"],
    );
    run_ok(&mut ingest);
    data
}

/// N44W072 on Cesium's geodetic grid as `n44g` in `data` (zooms to 10), beside
/// [`client_data`]'s mercator `n44m`.
pub fn ingest_n44_geodetic(data: &Path) {
    ingest_n44_geodetic_as(data, "n44g");
}

/// [`ingest_n44_geodetic`] under the dataset name `name`.
pub fn ingest_n44_geodetic_as(data: &Path, name: &str) {
    ingest_n44_geodetic_with(data, name, &[]);
}

/// [`ingest_n44_geodetic_as`] with more ingest arguments.
pub fn ingest_n44_geodetic_with(data: &Path, name: &str, args: &[&str]) {
    let hgt = shared_data().join("dem/N44W072.hgt");
    let mut all = vec!["--scheme", "geodetic"];
    all.extend(args);
    run_ok(&mut ingest_command(&hgt, name, data, &all));
}

#[path = "../codec/src/scratch.rs"]
mod scratch_dirs;

/// A fresh, empty folder for one test, its own on every call; see the codec's `scratch.rs`
/// for where it lives and when it goes.
pub fn fresh_dir(tag: &str) -> PathBuf {
    scratch_dirs::scratch(tag)
}

/// `zerotile ARGS --data DATA`, which must succeed.
pub fn run_in(args: &[&str], data: &Path) -> std::process::Output {
    run_ok(
        Command::new(zerotile_bin())
            .args(args)
            .arg("--data")
            .arg(data),
    )
}

/// The `zerotile` binary built for this test profile.
///
/// Cargo builds it only when the server package is in the run (`cargo test --workspace`, as
/// CI does); `cargo test -p zerotile-tests` alone runs whatever binary an earlier build
/// left. So a binary that is missing or older than the server's and codec's sources stops
/// the test with what to run, instead of failing it on behaviour the sources no longer have.
pub fn zerotile_bin() -> PathBuf {
    static CHECKED: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    match CHECKED.get_or_init(check_bin) {
        Ok(path) => path.clone(),
        Err(why) => panic!("{why}"),
    }
}

fn check_bin() -> Result<PathBuf, String> {
    let mut dir = std::env::current_exe().map_err(|e| format!("test executable path: {e}"))?;
    dir.pop();
    if dir.ends_with("deps") {
        dir.pop();
    }
    let bin = dir.join(format!("zerotile{}", std::env::consts::EXE_SUFFIX));
    let fix = "build it with the tests: `cargo test --workspace --profile ci`";
    let built =
        modified(&bin).ok_or_else(|| format!("no zerotile binary at {}: {fix}", bin.display()))?;
    match newest_input(&dir.join("zerotile.d")) {
        Some(source) if source > built => Err(format!(
            "{} is older than the server's or codec's sources: {fix}",
            bin.display()
        )),
        _ => Ok(bin),
    }
}

fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// The latest modification time of the files the binary was built from, as cargo's dep-info
/// beside it lists them (`zerotile: a.rs b.rs …`, a space in a path escaped). Those are what
/// relink it: unit-test modules (`tests.rs`, `*_tests.rs`, behind `#[cfg(test)]`) and notes
/// are not among them, so an edit to one leaves the binary current. (A walk of the source
/// folders that left out `tests.rs` by name took any `*_tests.rs` edit for a stale binary.)
fn newest_input(dep_info: &Path) -> Option<SystemTime> {
    let text = std::fs::read_to_string(dep_info).ok()?;
    let (_, inputs) = text.lines().next()?.split_once(": ")?;
    let mut newest = None;
    let mut path = String::new();
    let mut chars = inputs.chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => path.extend(chars.next()),
            ' ' => newest = newest.max(modified(Path::new(&std::mem::take(&mut path)))),
            _ => path.push(c),
        }
    }
    newest.max(modified(Path::new(&path)))
}

/// `zerotile ingest INPUT --name NAME --quiet --data DATA EXTRA…`, not yet run.
pub fn ingest_command(input: &Path, name: &str, data: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(zerotile_bin());
    cmd.arg("ingest")
        .arg(input)
        .args(["--name", name, "--quiet", "--data"])
        .arg(data)
        .args(extra);
    cmd
}

/// Fails the test with the command's stderr unless it succeeded.
pub fn assert_success(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs `cmd` to completion and returns its output, failing the test with the command and
/// its stderr unless it succeeded.
pub fn run_ok(cmd: &mut std::process::Command) -> std::process::Output {
    let out = cmd.output().expect("the command starts");
    assert!(
        out.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// `[[lon, lat, metres], ...]` read from N44W072's SRTM samples (1201² big-endian i16, rows
/// from 45° N down, columns from 72° W), bilinear between them: Mount Washington and a 10×10
/// grid over the tile.
pub fn srtm_heights(hgt: &Path) -> String {
    srtm_heights_plus(hgt, |_, _| 0.0)
}

/// [`srtm_heights`], each plus `above(lon, lat)`.
fn srtm_heights_plus(hgt: &Path, above: impl Fn(f64, f64) -> f64) -> String {
    let bytes = std::fs::read(hgt).expect("the SRTM tile in ../shared/data");
    let n = 1201usize;
    assert_eq!(bytes.len(), n * n * 2, "{}", hgt.display());
    let at = |r: usize, c: usize| {
        let i = 2 * (r.min(n - 1) * n + c.min(n - 1));
        f64::from(i16::from_be_bytes([bytes[i], bytes[i + 1]]))
    };
    let height = |lon: f64, lat: f64| {
        let (r, c) = ((45.0 - lat) * 1200.0, (lon + 72.0) * 1200.0);
        let (r0, c0) = (r.floor(), c.floor());
        let (fr, fc) = (r - r0, c - c0);
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "the points lie inside the tile"
        )]
        let (r0, c0) = (r0 as usize, c0 as usize);
        at(r0, c0) * (1.0 - fr) * (1.0 - fc)
            + at(r0, c0 + 1) * (1.0 - fr) * fc
            + at(r0 + 1, c0) * fr * (1.0 - fc)
            + at(r0 + 1, c0 + 1) * fr * fc
    };
    let mut points = vec![(-71.3033, 44.2705)];
    for i in 0..10 {
        for j in 0..10 {
            points.push((
                -72.0 + 0.05 + 0.1 * f64::from(i),
                44.0 + 0.05 + 0.1 * f64::from(j),
            ));
        }
    }
    let rows: Vec<_> = points
        .iter()
        .map(|&(lon, lat)| serde_json::json!([lon, lat, height(lon, lat) + above(lon, lat)]))
        .collect();
    serde_json::Value::from(rows).to_string()
}

/// [`srtm_heights`] above the WGS84 ellipsoid, where a quantized-mesh client draws the
/// EGM96 heights of SRTM: each raised by the geoid's undulation (about −28 m there).
pub fn srtm_heights_on_the_ellipsoid(hgt: &Path) -> String {
    srtm_heights_plus(hgt, zerotile_codec::geo::geoid::undulation_exact)
}
