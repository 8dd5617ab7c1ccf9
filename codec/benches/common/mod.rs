//! Inputs every bench reads: real data from `../shared/data`, through the codec's own readers.
#![allow(
    dead_code,
    clippy::expect_used,
    reason = "each bench uses part of this; a bench without its data file should stop loudly"
)]

use std::path::PathBuf;

use zerotile_codec::mesh::io::{read_path, MeshLimits};
use zerotile_codec::mesh::TriMesh;
use zerotile_codec::raster::{self, ReadOptions};
use zerotile_codec::Grid;

/// A file under `../shared/data` beside the repository.
pub fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel)
}

/// The `side`² window of N44W072 from row 300, column 500: the tile the tests use too.
pub fn n44w072_tile(side: usize) -> Grid<f64> {
    let map = raster::read_heightmap(shared("dem/N44W072.hgt"), &ReadOptions::default())
        .expect("../shared/data/dem/N44W072.hgt");
    map.heights.crop(300, 500, side, side).expect("crop")
}

/// A classic test mesh from `../shared/data/meshes`.
pub fn mesh(name: &str) -> TriMesh {
    read_path(&shared(&format!("meshes/{name}")), &MeshLimits::default())
        .expect("../shared/data/meshes")
}
