//! Real clients in headless Chromium against the real binary: CesiumJS on a geodetic
//! dataset's `layer.json`, MapLibre GL JS `raster-dem` on a mercator dataset's terrain-RGB
//! tiles, and the viewer page at `/` (the browser side is `tests/e2e/clients.mjs`).
//!
//! Needs `node`, Chromium (`apt-get install -y chromium`, or `CHROMIUM=/path`) and
//! `npm ci --prefix web`. Without them the test prints why and passes, so a laptop without a
//! browser can still run `cargo test`; with `ZEROTILE_E2E=1` (set by `.ci/run`) their absence
//! fails the test, so CI cannot silently skip it. Screenshots go to `target/e2e/`.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "end-to-end test: a broken step should fail loudly"
)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use zerotile_tests::server::Server;
use zerotile_tests::{run_ok, shared_data, zerotile_bin};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// What is missing for the browser tests, if anything.
fn missing_tools(chromium: &Path) -> Vec<String> {
    let mut missing = Vec::new();
    if Command::new("node").arg("--version").output().is_err() {
        missing.push("node (Node.js 18+)".to_string());
    }
    if !chromium.is_file() {
        missing.push(format!(
            "Chromium at {} (apt-get install -y chromium, or set CHROMIUM)",
            chromium.display()
        ));
    }
    if !repo().join("web/node_modules/playwright-core").is_dir() {
        missing.push("web/node_modules (npm ci --prefix web)".to_string());
    }
    missing
}

fn run(args: &[&str], data: &Path) {
    run_ok(
        Command::new(zerotile_bin())
            .args(args)
            .arg("--data")
            .arg(data),
    );
}

#[test]
fn cesium_maplibre_and_the_viewer_render_in_headless_chromium() {
    let chromium = PathBuf::from(std::env::var("CHROMIUM").unwrap_or("/usr/bin/chromium".into()));
    let missing = missing_tools(&chromium);
    if !missing.is_empty() {
        let msg = format!("browser client tests need: {}", missing.join("; "));
        if std::env::var("ZEROTILE_E2E").is_ok_and(|v| v == "1") {
            panic!("ZEROTILE_E2E=1 but {msg}");
        }
        eprintln!("SKIPPED (set ZEROTILE_E2E=1 to require it): {msg}");
        return;
    }

    // The default data (geodetic demo-ridges and the object meshes) plus SRTM on the
    // mercator grid, which is what MapLibre's raster-dem expects.
    let t0 = Instant::now();
    let data = std::env::temp_dir().join(format!("zerotile-clients-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&data);
    std::fs::create_dir_all(&data).unwrap();
    run(&["demo-data", "--quiet"], &data);
    let hgt = shared_data().join("dem/N44W072.hgt");
    run(
        &[
            "ingest",
            hgt.to_str().unwrap(),
            "--name",
            "n44m",
            "--scheme",
            "mercator",
            "--max-zoom",
            "10",
            "--quiet",
        ],
        &data,
    );
    eprintln!("data ready in {:.1} s", t0.elapsed().as_secs_f64());

    let server = Server::start(&data);
    let target = std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| repo().join("target"));
    let out = target.join("e2e");
    let t1 = Instant::now();
    let status = Command::new("node")
        .arg(repo().join("tests/e2e/clients.mjs"))
        .args(["--base", server.base(), "--geodetic", "demo-ridges"])
        .args(["--mercator", "n44m", "--out"])
        .arg(&out)
        .env("CHROMIUM", &chromium)
        .status()
        .unwrap();
    eprintln!(
        "browser clients ran in {:.1} s; screenshots in {}",
        t1.elapsed().as_secs_f64(),
        out.display()
    );
    drop(server);
    let _ = std::fs::remove_dir_all(&data);
    assert!(
        status.success(),
        "a browser client failed (its output is above)"
    );
}
