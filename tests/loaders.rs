//! deck.gl's terrain loaders (loaders.gl in Node) against the real binary: QuantizedMeshLoader
//! on a geodetic dataset's `.terrain` tiles must decode the server's own meshes and the SRTM
//! source's heights, and TerrainLoader (deck.gl's TerrainLayer) on a mercator dataset's
//! terrain-RGB and Terrarium PNGs the tiles' stored heights (the script is
//! `tests/e2e/loaders.mjs`).
//!
//! Needs `node` and `npm ci --prefix web`; without them the test prints why and passes, and
//! with `ZEROTILE_E2E=1` (set by `.ci/run`) their absence fails it.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "end-to-end test: a broken step should fail loudly"
)]

use std::process::Command;

use zerotile_tests::server::Server;
use zerotile_tests::{
    client_data, ingest_n44_geodetic_with, node_missing, repo_root, shared_data, srtm_heights,
    tools_ready,
};

#[test]
fn deck_gl_loaders_read_quantized_mesh_and_terrain_rgb_tiles() {
    if !tools_ready("the loaders.gl test", &node_missing("@loaders.gl/terrain")) {
        return;
    }
    // The mercator N44W072 of the browser tests, and the same tile on the geodetic grid.
    let data = client_data("loaders");
    let hgt = shared_data().join("dem/N44W072.hgt");
    // Heights as stored (the geoid left out), so the `.terrain` meshes compare with the
    // `.json` ones vertex for vertex and both with the source; the EGM96 offset is
    // `clients.rs`'s (CesiumJS) and the server's own tests'.
    ingest_n44_geodetic_with(&data, "n44g", &["--vertical-datum", "ellipsoid"]);
    let server = Server::start(&data);
    // Zoom 10 is both datasets' deepest: the geodetic lattice is finer than the source there,
    // the mercator one a little coarser.
    let status = Command::new("node")
        .arg(repo_root().join("tests/e2e/loaders.mjs"))
        .args([
            "--base",
            server.base(),
            "--geodetic",
            "n44g",
            "--mercator",
            "n44m",
        ])
        .args([
            "--zoom",
            "10",
            "--threshold",
            "4",
            "--expect",
            &srtm_heights(&hgt),
        ])
        .status()
        .unwrap();
    drop(server);
    let _ = std::fs::remove_dir_all(&data);
    assert!(
        status.success(),
        "a loaders.gl check failed (its output is above)"
    );
}
