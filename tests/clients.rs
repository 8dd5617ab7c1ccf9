//! Real clients in headless Chromium against the real binary: CesiumJS on a geodetic
//! dataset's `layer.json`, MapLibre GL JS `raster-dem` on a mercator dataset's terrain-RGB
//! tiles, the viewer page at `/`, CesiumJS on a `zerotile export --format terrain` tree, and
//! MapLibre on a `zerotile export --format png --base-url URL` tree through its `tiles.json`
//! alone (URL a placeholder the page's `transformRequest` maps to the real host), CesiumJS's
//! `Cesium3DTileset` on a `zerotile export --format 3dtiles` tree of the terrain tree's
//! dataset (its heights must be the terrain tree's), each tree
//! served by a plain file server on another origin, as a CDN would. Both static checks
//! sample the SRTM source's heights from the tree, CesiumJS's raised to the ellipsoid by
//! EGM96's undulation (the browser side is
//! `tests/e2e/clients.mjs`).
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
use zerotile_tests::{
    client_data, e2e_out, ingest_n44_geodetic, node_missing, repo_root, run_in, shared_data,
    srtm_heights, srtm_heights_on_the_ellipsoid, tools_ready,
};

/// What is missing for the browser tests, if anything.
fn missing_tools(chromium: &Path) -> Vec<String> {
    let mut missing = node_missing("playwright-core");
    if !chromium.is_file() {
        missing.push(format!(
            "Chromium at {} (apt-get install -y chromium, or set CHROMIUM)",
            chromium.display()
        ));
    }
    missing
}

#[test]
fn cesium_maplibre_and_the_viewer_render_in_headless_chromium() {
    let chromium = PathBuf::from(std::env::var("CHROMIUM").unwrap_or("/usr/bin/chromium".into()));
    if !tools_ready("the browser client test", &missing_tools(&chromium)) {
        return;
    }

    // The default data (geodetic demo-ridges and the object meshes) plus SRTM on the
    // mercator grid, which is what MapLibre's raster-dem expects.
    let t0 = Instant::now();
    let data = client_data("clients");
    let hgt = shared_data().join("dem/N44W072.hgt");
    // The same SRTM tile on Cesium's geodetic grid, exported as a static tree: CesiumJS must
    // load it and sample the source's heights from it.
    ingest_n44_geodetic(&data);
    // `export DATASET ARGS… --out` a fresh folder beside the data, named by `suffix`.
    let export = |suffix: &str, dataset: &str, args: &[&str]| {
        let out = data.with_file_name(format!("zerotile-clients-{}-{suffix}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let mut all = vec!["export", dataset];
        all.extend(args);
        all.extend(["--out", out.to_str().unwrap(), "--quiet"]);
        run_in(&all, &data);
        out
    };
    let exported = export("static", "n44g", &["--format", "terrain"]);
    // The same dataset as a 3D Tiles tree: CesiumJS must sample the terrain tree's heights
    // from it.
    let tiles3d = export("3dtiles", "n44g", &["--format", "3dtiles"]);
    // The mercator ingest as a static terrain-RGB tree with its tiles.json, which names the
    // tiles under a placeholder origin: the MapLibre page maps it to the real host (its
    // transformRequest), as a page does for a tileset that moved. Every zoom: 41 tiles.
    let png = export(
        "png",
        "n44m",
        &["--format", "png", "--base-url", "http://cdn.invalid/rgb"],
    );
    // CesiumJS draws on the ellipsoid: SRTM's EGM96 heights come raised by the geoid's
    // undulation, as n44g records them (an .hgt's datum).
    let expect = srtm_heights_on_the_ellipsoid(&hgt);
    eprintln!("data ready in {:.1} s", t0.elapsed().as_secs_f64());

    let server = Server::start(&data);
    let out = e2e_out("");
    let t1 = Instant::now();
    let status = Command::new("node")
        .arg(repo_root().join("tests/e2e/clients.mjs"))
        .args(["--base", server.base(), "--geodetic", "demo-ridges"])
        .args(["--mercator", "n44m", "--static"])
        .arg(&exported)
        .arg("--static-png")
        .arg(&png)
        .arg("--static-3dtiles")
        .arg(&tiles3d)
        .args([
            "--expect",
            &expect,
            "--expect-png",
            &srtm_heights(&hgt),
            "--out",
        ])
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
    let _ = std::fs::remove_dir_all(&exported);
    let _ = std::fs::remove_dir_all(&png);
    let _ = std::fs::remove_dir_all(&tiles3d);
    assert!(
        status.success(),
        "a browser client failed (its output is above)"
    );
}
